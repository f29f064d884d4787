"""One battery of property tests run over every matrix Lie group module (SO(3), SE(2), SE(3))."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.linalg import expm

from geomech.errors import InputError, ShapeError
from geomech.lie import se2, se3, so3

GROUPS = [so3, se2, se3]
IDS = ["so3", "se2", "se3"]
SETTINGS = settings(max_examples=20, deadline=None)

seeds = st.integers(0, 2**32 - 1)


def tangent(G, scale: float = 3.0):
    return arrays(np.float64, G.DIM, elements=st.floats(-scale, scale, allow_nan=False, allow_infinity=False))


def rotation_angle(G, xi: np.ndarray) -> np.ndarray:
    """Angle of the rotation part of a tangent vector, in the ordering of each module."""
    if G is so3:
        return np.linalg.norm(xi, axis=-1)
    if G is se2:
        return np.abs(xi[..., 2])
    return np.linalg.norm(xi[..., 3:], axis=-1)


def with_rotation_angle(G, xi: np.ndarray, angle: float) -> np.ndarray:
    """Rescale the rotation part of ``xi`` to ``angle`` (direction kept, or a fixed one if it is zero)."""
    xi = np.array(xi, dtype=float)
    rot = xi[..., 2:] if G is se2 else (xi if G is so3 else xi[..., 3:])
    n = np.linalg.norm(rot)
    direction = rot / n if n > 0 else np.eye(rot.shape[-1])[0]
    rot[...] = angle * direction
    return xi


def all_groups(test):
    return pytest.mark.parametrize("G", GROUPS, ids=IDS)(test)


# -- exp / log -------------------------------------------------------------------------------------------


@all_groups
def test_exp_matches_matrix_exponential(G):
    rng = np.random.default_rng(0)
    xi = rng.normal(size=(20, G.DIM)) * 2.0
    expected = np.stack([expm(G.hat(x)) for x in xi])
    np.testing.assert_allclose(G.exp(xi), expected, atol=1e-12)


@all_groups
@SETTINGS
@given(data=st.data())
def test_log_exp_round_trip_below_pi(G, data):
    xi = data.draw(tangent(G))
    if rotation_angle(G, xi) >= np.pi - 1e-3:
        xi = with_rotation_angle(G, xi, np.pi - 1e-3)
    np.testing.assert_allclose(G.log(G.exp(xi)), xi, atol=1e-10)


@all_groups
@SETTINGS
@given(seed=seeds)
def test_exp_log_round_trip_every_element(G, seed):
    g = G.random(seed, size=8)
    np.testing.assert_allclose(G.exp(G.log(g)), g, atol=1e-12)
    assert np.all(rotation_angle(G, G.log(g)) <= np.pi + 1e-15)


@all_groups
@SETTINGS
@given(data=st.data())
def test_hat_vee_round_trip_and_hat_is_linear(G, data):
    x, y = data.draw(tangent(G)), data.draw(tangent(G))
    np.testing.assert_array_equal(G.vee(G.hat(x)), x)
    np.testing.assert_allclose(G.hat(2.0 * x - y), 2.0 * G.hat(x) - G.hat(y), atol=1e-14)


@all_groups
def test_hat_of_a_basis_vector_is_a_generator(G):
    # exp(t hat(e_k)) is a one-parameter subgroup: exp(s e_k) exp(t e_k) = exp((s + t) e_k)
    for k in range(G.DIM):
        e = np.eye(G.DIM)[k]
        np.testing.assert_allclose(G.compose(G.exp(0.4 * e), G.exp(0.9 * e)), G.exp(1.3 * e), atol=1e-14)


# -- group axioms ----------------------------------------------------------------------------------------


@all_groups
@SETTINGS
@given(seed=seeds)
def test_compose_associative_and_inverse(G, seed):
    rng = np.random.default_rng(seed)
    g, h, k = G.random(rng, size=(3, 4))
    np.testing.assert_allclose(G.compose(G.compose(g, h), k), G.compose(g, G.compose(h, k)), atol=1e-12)
    np.testing.assert_allclose(G.compose(g, G.inverse(g)), G.identity(4), atol=1e-12)
    np.testing.assert_allclose(G.inverse(g), np.linalg.inv(g), atol=1e-12)
    np.testing.assert_allclose(G.inverse(G.compose(g, h)), G.compose(G.inverse(h), G.inverse(g)), atol=1e-12)


@all_groups
def test_identity_shape_and_value(G):
    e = G.identity((2, 3))
    assert e.shape == (2, 3, G.MATRIX_SIZE, G.MATRIX_SIZE)
    np.testing.assert_array_equal(G.log(e), np.zeros((2, 3, G.DIM)))
    assert G.identity().shape == (G.MATRIX_SIZE, G.MATRIX_SIZE)


@all_groups
@SETTINGS
@given(seed=seeds)
def test_act_is_an_action_and_matches_the_homogeneous_product(G, seed):
    rng = np.random.default_rng(seed)
    g, h = G.random(rng, size=2)
    x = rng.normal(size=(5, G.POINT_DIM))
    np.testing.assert_allclose(G.act(G.compose(g, h), x), G.act(g, G.act(h, x)), atol=1e-12)
    if G is so3:
        homogeneous = x @ g.T
    else:
        xh = np.concatenate([x, np.ones((5, 1))], axis=-1)
        homogeneous = (xh @ g.T)[:, :-1]
    np.testing.assert_allclose(G.act(g, x), homogeneous, atol=1e-12)


# -- adjoint and coadjoint -------------------------------------------------------------------------------


@all_groups
@SETTINGS
@given(seed=seeds)
def test_Ad_is_a_homomorphism(G, seed):
    g, h = G.random(seed, size=2)
    np.testing.assert_allclose(G.Ad(G.compose(g, h)), G.Ad(g) @ G.Ad(h), atol=1e-12)
    np.testing.assert_allclose(G.Ad(G.inverse(g)), np.linalg.inv(G.Ad(g)), atol=1e-10)


@all_groups
@SETTINGS
@given(seed=seeds, data=st.data())
def test_Ad_is_conjugation(G, seed, data):
    g = G.random(seed)
    xi = data.draw(tangent(G))
    g_inv = np.linalg.inv(g)
    np.testing.assert_allclose(G.hat(G.Ad(g) @ xi), g @ G.hat(xi) @ g_inv, atol=1e-11)
    np.testing.assert_allclose(G.exp(G.Ad(g) @ xi), g @ G.exp(xi) @ g_inv, atol=1e-10)


@all_groups
@SETTINGS
@given(data=st.data())
def test_ad_is_the_bracket_and_the_derivative_of_Ad(G, data):
    xi, eta = data.draw(tangent(G)), data.draw(tangent(G))
    bracket = G.hat(xi) @ G.hat(eta) - G.hat(eta) @ G.hat(xi)
    np.testing.assert_allclose(G.hat(G.ad(xi) @ eta), bracket, atol=1e-12)
    h = 1e-5
    fd = (G.Ad(G.exp(h * xi)) - G.Ad(G.exp(-h * xi))) / (2 * h)
    np.testing.assert_allclose(fd, G.ad(xi), atol=1e-7)


@all_groups
@SETTINGS
@given(seed=seeds)
def test_coad_is_the_dual_left_action(G, seed):
    rng = np.random.default_rng(seed)
    g, h = G.random(rng, size=2)
    mu, xi = rng.normal(size=(2, G.DIM))
    # <Ad*_{g^-1} mu, Ad_g xi> = <mu, xi>: the pairing is invariant
    assert np.isclose(G.coad(g, mu) @ (G.Ad(g) @ xi), mu @ xi, atol=1e-11)
    np.testing.assert_allclose(G.coad(G.compose(g, h), mu), G.coad(g, G.coad(h, mu)), atol=1e-11)
    np.testing.assert_allclose(G.coad(G.identity(), mu), mu, atol=0)


# -- derivatives ---------------------------------------------------------------------------------------


@all_groups
@SETTINGS
@given(data=st.data())
def test_derivative_of_exp_at_zero_is_hat(G, data):
    xi = data.draw(tangent(G))
    h = 1e-6
    fd = (G.exp(h * xi) - G.exp(-h * xi)) / (2 * h)
    np.testing.assert_allclose(fd, G.hat(xi), atol=1e-8)


def _fd_jacobians(G, xi: np.ndarray, h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Left and right Jacobians of exp at ``xi`` by central differences of log, all directions at once."""
    E = np.eye(G.DIM)
    g = G.exp(xi)
    g_inv = G.inverse(g)
    plus, minus = G.exp(xi + h * E), G.exp(xi - h * E)
    left = (G.log(G.compose(plus, g_inv)) - G.log(G.compose(minus, g_inv))) / (2 * h)
    right = (G.log(G.compose(g_inv, plus)) - G.log(G.compose(g_inv, minus))) / (2 * h)
    return left.T, right.T


@all_groups
@SETTINGS
@given(data=st.data())
def test_jacobians_against_finite_differences(G, data):
    xi = data.draw(tangent(G, scale=2.0))
    left, right = _fd_jacobians(G, xi)
    np.testing.assert_allclose(G.left_jacobian(xi), left, atol=1e-7)
    np.testing.assert_allclose(G.right_jacobian(xi), right, atol=1e-7)
    np.testing.assert_allclose(G.left_jacobian_inverse(xi) @ G.left_jacobian(xi), np.eye(G.DIM), atol=1e-12)
    np.testing.assert_allclose(G.right_jacobian_inverse(xi) @ G.right_jacobian(xi), np.eye(G.DIM), atol=1e-12)
    # J_l = Ad_{exp(xi)} J_r
    np.testing.assert_allclose(G.left_jacobian(xi), G.Ad(G.exp(xi)) @ G.right_jacobian(xi), atol=1e-12)


@all_groups
@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-3, 0.5])
def test_jacobians_near_zero_rotation(G, angle):
    rng = np.random.default_rng(3)
    xi = with_rotation_angle(G, rng.normal(size=G.DIM), angle)
    left, right = _fd_jacobians(G, xi)
    np.testing.assert_allclose(G.left_jacobian(xi), left, atol=1e-8)
    np.testing.assert_allclose(G.right_jacobian(xi), right, atol=1e-8)
    np.testing.assert_allclose(G.left_jacobian_inverse(xi), np.linalg.inv(left), atol=1e-8)


# -- hand-picked near-singular rotation angles ---------------------------------------------------------

SINGULAR_ANGLES = [0.0, 1e-12, 1e-8, np.pi - 1e-6, np.pi - 1e-10, np.pi]


@all_groups
@pytest.mark.parametrize("angle", SINGULAR_ANGLES)
def test_exp_log_at_hand_picked_angles(G, angle):
    rng = np.random.default_rng(7)
    for _ in range(5):
        xi = with_rotation_angle(G, rng.normal(size=G.DIM), angle)
        g = G.exp(xi)
        np.testing.assert_allclose(g, expm(G.hat(xi)), atol=1e-12)
        back = G.log(g)
        assert np.all(np.isfinite(back))
        np.testing.assert_allclose(G.exp(back), g, atol=1e-12)
        if angle < np.pi:
            np.testing.assert_allclose(back, xi, atol=1e-9)
        else:
            # At pi, xi and the element with the opposite rotation vector are the same group element; only
            # the rotation angle and exp(log g) = g are determined.
            assert abs(rotation_angle(G, back) - np.pi) < 1e-12
        for J in (G.left_jacobian, G.right_jacobian, G.left_jacobian_inverse, G.right_jacobian_inverse):
            assert np.all(np.isfinite(J(xi)))


# -- batches --------------------------------------------------------------------------------------------


@all_groups
def test_batch_shapes_preserved_and_elementwise(G):
    rng = np.random.default_rng(11)
    xi = rng.normal(size=(2, 5, G.DIM))
    n = G.MATRIX_SIZE
    g = G.exp(xi)
    assert g.shape == (2, 5, n, n)
    x = rng.normal(size=(2, 5, G.POINT_DIM))
    checks = {
        "exp": (G.exp(xi), lambda i, j: G.exp(xi[i, j])),
        "hat": (G.hat(xi), lambda i, j: G.hat(xi[i, j])),
        "log": (G.log(g), lambda i, j: G.log(g[i, j])),
        "vee": (G.vee(G.hat(xi)), lambda i, j: xi[i, j]),
        "inverse": (G.inverse(g), lambda i, j: G.inverse(g[i, j])),
        "Ad": (G.Ad(g), lambda i, j: G.Ad(g[i, j])),
        "ad": (G.ad(xi), lambda i, j: G.ad(xi[i, j])),
        "coad": (G.coad(g, xi), lambda i, j: G.coad(g[i, j], xi[i, j])),
        "act": (G.act(g, x), lambda i, j: G.act(g[i, j], x[i, j])),
        "compose": (G.compose(g, g[0, 0]), lambda i, j: G.compose(g[i, j], g[0, 0])),
        "left_jacobian": (G.left_jacobian(xi), lambda i, j: G.left_jacobian(xi[i, j])),
        "right_jacobian": (G.right_jacobian(xi), lambda i, j: G.right_jacobian(xi[i, j])),
        "left_jacobian_inverse": (G.left_jacobian_inverse(xi), lambda i, j: G.left_jacobian_inverse(xi[i, j])),
        "right_jacobian_inverse": (G.right_jacobian_inverse(xi), lambda i, j: G.right_jacobian_inverse(xi[i, j])),
    }
    for name, (batched, single) in checks.items():
        assert batched.shape[:2] == (2, 5), name
        for i in range(2):
            for j in range(5):
                np.testing.assert_allclose(batched[i, j], single(i, j), atol=1e-13, err_msg=name)
    assert G.random(0, size=(2, 5)).shape == (2, 5, n, n)
    assert G.random(0, size=3).shape == (3, n, n)


@all_groups
def test_random_is_seeded_and_in_the_group(G):
    a, b = G.random(42, size=10), G.random(np.random.default_rng(42), size=10)
    np.testing.assert_array_equal(a, b)
    G.log(a)  # validates membership


# -- validation -----------------------------------------------------------------------------------------


@all_groups
def test_shape_errors_name_the_argument(G):
    bad = np.zeros(G.DIM + 1)
    name = "v" if G is so3 else "xi"
    expected = rf"^Expected `{name}` to have shape \(\.\.\., {G.DIM}\), got \({G.DIM + 1},\)\.$"
    with pytest.raises(ShapeError, match=expected):
        G.exp(bad)
    with pytest.raises(ShapeError, match=r"Expected `.*` to have shape \(\.\.\., \d, \d\)"):
        G.log(np.zeros((2, G.MATRIX_SIZE + 1, G.MATRIX_SIZE)))


@all_groups
def test_non_elements_and_non_finite_input_are_rejected(G):
    g = G.random(0)
    g[0, 0] += 1e-3
    with pytest.raises(InputError, match="off by"):
        G.log(g)
    with pytest.raises(InputError, match="finite"):
        G.exp(np.full(G.DIM, np.nan))
    if G is not so3:
        h = G.random(0)
        h[-1, 0] = 0.5
        with pytest.raises(InputError, match=r"homogeneous matrix \[\[R, t\], \[0, 1\]\]"):
            G.inverse(h)
