"""One battery of property tests over every group of geomech.lie: SO3, SE2, SE3, SO2, Rn, products, and the
generic matrix group (from a basis, by matrix functions), with the symbolic twins agreeing with the numeric
groups."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.linalg import expm

from geomech.errors import InputError, ShapeError
from geomech.lie import SE2, SE3, SO2, SO3, LieGroup, MatrixGroup, Rn
from geomech.symbolic import GroupChart

SETTINGS = settings(max_examples=15, deadline=None)
seeds = st.integers(0, 2**32 - 1)

_x, _y, _t = sp.symbols("x y t", real=True)
_HEISENBERG = [[[0, 1, 0], [0, 0, 0], [0, 0, 0]], [[0, 0, 0], [0, 0, 1], [0, 0, 0]], [[0, 0, 1], [0, 0, 0], [0, 0, 0]]]

# (id, group, index blocks of its compact rotation parts, closed forms)
CASES = [
    ("SO3", SO3(), [[0, 1, 2]]),
    ("SO3-zyx", SO3("a", "b", "c", seq="ZYX"), [[0, 1, 2]]),
    ("SE2", SE2(), [[2]]),
    ("SE3", SE3(), [[3, 4, 5]]),
    ("SO2", SO2(), [[0]]),
    ("R3", Rn(3), []),
    ("SE2xSO2", SE2() * SO2("psi"), [[2], [3]]),
    ("SE3xR1", SE3() * Rn("s"), [[3, 4, 5]]),
    ("SO3xSO3", SO3("a1", "b1", "c1") * SO3("a2", "b2", "c2"), [[0, 1, 2], [3, 4, 5]]),
    # the generic group, by matrix functions: so(3) from its basis, SE(2) with a user's chart, Heisenberg
    ("matrix-so3", MatrixGroup("so3 by basis", SO3().sympy_basis()), [[0, 1, 2]]),
    (
        "matrix-se2",
        MatrixGroup(
            "se2 by chart",
            SE2().sympy_basis(),
            coordinates=(_x, _y, _t),
            matrix=sp.Matrix([[sp.cos(_t), -sp.sin(_t), _x], [sp.sin(_t), sp.cos(_t), _y], [0, 0, 1]]),
            angles=(2,),
        ),
        [[2]],
    ),
    (
        "heisenberg",
        MatrixGroup(
            "Heisenberg", _HEISENBERG, coordinates=(_x, _y, _t), matrix=sp.Matrix([[1, _x, _t], [0, 1, _y], [0, 0, 1]])
        ),
        [],
    ),
]
IDS = [c[0] for c in CASES]
GENERIC = {"matrix-so3", "matrix-se2", "heisenberg"}


def every_group(test):
    return pytest.mark.parametrize("case", CASES, ids=IDS)(test)


def tangent(G: LieGroup, scale: float = 3.0):
    return arrays(np.float64, G.dim, elements=st.floats(-scale, scale, allow_nan=False, allow_infinity=False))


def rotation_angle(blocks, xi: np.ndarray) -> float:
    return max((float(np.linalg.norm(xi[b])) for b in blocks), default=0.0)


def with_rotation_angle(blocks, xi: np.ndarray, angle: float) -> np.ndarray:
    """Rescale each rotation part of ``xi`` to ``angle`` (direction kept, or a fixed one if it is zero)."""
    xi = np.array(xi, dtype=float)
    for b in blocks:
        n = np.linalg.norm(xi[b])
        direction = xi[b] / n if n > 0 else np.eye(len(b))[0]
        xi[b] = angle * direction
    return xi


def below_pi(blocks, xi: np.ndarray, margin: float = 1e-3) -> np.ndarray:
    for b in blocks:
        n = np.linalg.norm(xi[b])
        if n >= np.pi - margin:
            xi = xi.copy()
            xi[b] *= (np.pi - margin) / n
    return xi


# -- exp / log --------------------------------------------------------------------------------------------


@every_group
def test_exp_is_the_matrix_exponential_and_hat_vee_invert(case):
    _, G, _ = case
    xi = np.random.default_rng(0).normal(size=(12, G.dim)) * 1.5
    np.testing.assert_allclose(G.exp(xi), expm(G.hat(xi)), atol=1e-12)
    np.testing.assert_allclose(G.vee(G.hat(xi)), xi, atol=1e-15)
    np.testing.assert_allclose(G.hat(xi), np.einsum("na,aij->nij", xi, G.basis), atol=0)


@every_group
@SETTINGS
@given(data=st.data())
def test_log_exp_round_trip_below_pi(case, data):
    _, G, blocks = case
    xi = below_pi(blocks, data.draw(tangent(G)))
    np.testing.assert_allclose(G.log(G.exp(xi)), xi, atol=1e-9)


@every_group
@SETTINGS
@given(seed=seeds)
def test_exp_log_round_trip_every_element(case, seed):
    name, G, blocks = case
    g = G.random(seed, size=6)
    if name in GENERIC and blocks:
        # logm is ill-conditioned at rotations by nearly pi: keep the generic groups' samples below 3
        g = G.exp(np.array([below_pi(blocks, u, 0.15) for u in G.log(g)]))
    np.testing.assert_allclose(G.exp(G.log(g)), g, atol=1e-10)
    assert all(rotation_angle(blocks, u) <= np.pi + 1e-12 for u in G.log(g))


@every_group
def test_one_parameter_subgroups(case):
    _, G, _ = case
    for k in range(G.dim):
        e = np.eye(G.dim)[k]
        np.testing.assert_allclose(G.compose(G.exp(0.4 * e), G.exp(0.9 * e)), G.exp(1.3 * e), atol=1e-13)


# -- group axioms -----------------------------------------------------------------------------------------


@every_group
@SETTINGS
@given(seed=seeds)
def test_compose_associative_and_inverse(case, seed):
    _, G, _ = case
    g, h, k = G.random(np.random.default_rng(seed), size=(3, 4))
    np.testing.assert_allclose(G.compose(G.compose(g, h), k), G.compose(g, G.compose(h, k)), atol=1e-10)
    np.testing.assert_allclose(G.compose(g, G.inverse(g)), G.identity(4), atol=1e-10)
    np.testing.assert_allclose(G.inverse(g), np.linalg.inv(g), atol=1e-10)
    np.testing.assert_allclose(G.inverse(G.compose(g, h)), G.compose(G.inverse(h), G.inverse(g)), atol=1e-10)


@every_group
def test_identity_shape_and_value(case):
    _, G, _ = case
    e = G.identity((2, 3))
    assert e.shape == (2, 3, G.matrix_size, G.matrix_size)
    np.testing.assert_allclose(G.log(e), np.zeros((2, 3, G.dim)), atol=1e-15)
    assert G.identity().shape == (G.matrix_size, G.matrix_size)


@every_group
@SETTINGS
@given(seed=seeds)
def test_act_is_an_action(case, seed):
    _, G, _ = case
    rng = np.random.default_rng(seed)
    g, h = G.random(rng, size=2)
    x = rng.normal(size=(5, G.point_dim))
    np.testing.assert_allclose(G.act(G.compose(g, h), x), G.act(g, G.act(h, x)), atol=1e-10)
    np.testing.assert_allclose(G.act(G.identity(), x), x, atol=1e-15)


def test_act_of_the_closed_groups_is_the_homogeneous_product(rng):
    for G in (SE2(), SE3(), Rn(2)):
        g = G.random(rng)
        x = rng.normal(size=(4, G.point_dim))
        xh = np.concatenate([x, np.ones((4, 1))], -1)
        np.testing.assert_allclose(G.act(g, x), (xh @ g.T)[:, :-1], atol=1e-13)
    for G in (SO3(), SO2()):
        g = G.random(rng)
        x = rng.normal(size=(4, G.point_dim))
        np.testing.assert_allclose(G.act(g, x), x @ g.T, atol=1e-13)


# -- adjoint and coadjoint --------------------------------------------------------------------------------


@every_group
@SETTINGS
@given(seed=seeds, data=st.data())
def test_Ad_is_a_homomorphism_and_conjugation(case, seed, data):
    _, G, _ = case
    g, h = G.random(seed, size=2)
    np.testing.assert_allclose(G.Ad(G.compose(g, h)), G.Ad(g) @ G.Ad(h), atol=1e-9)
    np.testing.assert_allclose(G.Ad(G.inverse(g)), np.linalg.inv(G.Ad(g)), atol=1e-9)
    xi = data.draw(tangent(G))
    np.testing.assert_allclose(G.hat(G.Ad(g) @ xi), g @ G.hat(xi) @ np.linalg.inv(g), atol=1e-9)


@every_group
@SETTINGS
@given(data=st.data())
def test_ad_is_the_bracket_and_the_derivative_of_Ad(case, data):
    _, G, _ = case
    xi, eta = data.draw(tangent(G)), data.draw(tangent(G))
    bracket = G.hat(xi) @ G.hat(eta) - G.hat(eta) @ G.hat(xi)
    np.testing.assert_allclose(G.hat(G.ad(xi) @ eta), bracket, atol=1e-12)
    np.testing.assert_allclose(G.bracket(xi, eta), G.ad(xi) @ eta, atol=1e-13)
    h = 1e-5
    fd = (G.Ad(G.exp(h * xi)) - G.Ad(G.exp(-h * xi))) / (2 * h)
    np.testing.assert_allclose(fd, G.ad(xi), atol=1e-7)
    assert G.abelian == bool(np.all(G.structure_constants == 0))


@every_group
@SETTINGS
@given(seed=seeds)
def test_coad_is_the_dual_left_action(case, seed):
    _, G, _ = case
    rng = np.random.default_rng(seed)
    g, h = G.random(rng, size=2)
    mu, xi = rng.normal(size=(2, G.dim))
    assert np.isclose(G.coad(g, mu) @ (G.Ad(g) @ xi), mu @ xi, atol=1e-9)
    np.testing.assert_allclose(G.coad(G.compose(g, h), mu), G.coad(g, G.coad(h, mu)), atol=1e-9)


# -- Jacobians --------------------------------------------------------------------------------------------


def _fd_jacobians(G: LieGroup, xi: np.ndarray, h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Left and right Jacobians of exp at ``xi`` by central differences of log, all directions at once."""
    E = np.eye(G.dim)
    g_inv = G.inverse(G.exp(xi))
    plus, minus = G.exp(xi + h * E), G.exp(xi - h * E)
    left = (G.log(G.compose(plus, g_inv)) - G.log(G.compose(minus, g_inv))) / (2 * h)
    right = (G.log(G.compose(g_inv, plus)) - G.log(G.compose(g_inv, minus))) / (2 * h)
    return left.T, right.T


@every_group
@SETTINGS
@given(data=st.data())
def test_jacobians_against_finite_differences(case, data):
    _, G, _ = case
    xi = data.draw(tangent(G, scale=2.0))
    left, right = _fd_jacobians(G, xi)
    np.testing.assert_allclose(G.left_jacobian(xi), left, atol=1e-7)
    np.testing.assert_allclose(G.right_jacobian(xi), right, atol=1e-7)
    I = np.eye(G.dim)
    np.testing.assert_allclose(G.left_jacobian_inverse(xi) @ G.left_jacobian(xi), I, atol=1e-11)
    np.testing.assert_allclose(G.right_jacobian_inverse(xi) @ G.right_jacobian(xi), I, atol=1e-11)
    np.testing.assert_allclose(G.left_jacobian(xi), G.Ad(G.exp(xi)) @ G.right_jacobian(xi), atol=1e-11)


@every_group
@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-3, 0.5])
def test_jacobians_near_zero_rotation(case, angle):
    _, G, blocks = case
    xi = with_rotation_angle(blocks, np.random.default_rng(3).normal(size=G.dim), angle)
    left, right = _fd_jacobians(G, xi)
    np.testing.assert_allclose(G.left_jacobian(xi), left, atol=1e-8)
    np.testing.assert_allclose(G.right_jacobian(xi), right, atol=1e-8)
    np.testing.assert_allclose(G.left_jacobian_inverse(xi), np.linalg.inv(left), atol=1e-8)


@every_group
@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, np.pi - 1e-6, np.pi - 1e-10, np.pi])
def test_exp_log_at_hand_picked_angles(case, angle):
    name, G, blocks = case
    if name in GENERIC and angle > 3:
        pytest.skip("logm of a rotation by nearly pi is ill-conditioned: the closed forms handle it")
    if not blocks and angle > 0:
        pytest.skip("no rotation part")
    rng = np.random.default_rng(7)
    for _ in range(5):
        xi = with_rotation_angle(blocks, rng.normal(size=G.dim), angle)
        g = G.exp(xi)
        np.testing.assert_allclose(g, expm(G.hat(xi)), atol=1e-12)
        back = G.log(g)
        np.testing.assert_allclose(G.exp(back), g, atol=1e-12)
        if angle < np.pi:
            np.testing.assert_allclose(back, xi, atol=1e-9)
        else:
            # at pi, the rotation vectors xi and -xi give the same element: only the angle is determined
            assert abs(rotation_angle(blocks, back) - np.pi) < 1e-12
        for J in (G.left_jacobian, G.right_jacobian, G.left_jacobian_inverse, G.right_jacobian_inverse):
            assert np.all(np.isfinite(J(xi)))


# -- on-manifold calculus ---------------------------------------------------------------------------------


@every_group
@SETTINGS
@given(seed=seeds)
def test_rplus_rminus_and_interpolate(case, seed):
    name, G, blocks = case
    rng = np.random.default_rng(seed)
    g = G.random(rng)
    u = below_pi(blocks, rng.normal(size=G.dim), 0.2)
    h = G.rplus(g, u)
    np.testing.assert_allclose(G.rminus(h, g), u, atol=1e-9)
    np.testing.assert_allclose(G.rplus(g, G.rminus(h, g)), h, atol=1e-9)
    np.testing.assert_allclose(G.interpolate(g, h, 0.0), g, atol=1e-12)
    np.testing.assert_allclose(G.interpolate(g, h, 1.0), h, atol=1e-9)
    # the midpoint of the geodesic is exp(u/2) from either end
    mid = G.interpolate(g, h, [0.5, 0.5])
    np.testing.assert_allclose(mid[0], G.rplus(g, u / 2), atol=1e-10)
    np.testing.assert_allclose(G.compose(mid[1], G.exp(u / 2)), h, atol=1e-9)


# -- batches ----------------------------------------------------------------------------------------------


@every_group
def test_batch_shapes_preserved_and_elementwise(case):
    _, G, _ = case
    rng = np.random.default_rng(11)
    xi = rng.normal(size=(2, 3, G.dim))
    n = G.matrix_size
    g = G.exp(xi)
    assert g.shape == (2, 3, n, n)
    x = rng.normal(size=(2, 3, G.point_dim))
    checks = {
        "exp": (G.exp(xi), lambda i, j: G.exp(xi[i, j])),
        "log": (G.log(g), lambda i, j: G.log(g[i, j])),
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
        assert batched.shape[:2] == (2, 3), name
        for i in range(2):
            for j in range(3):
                np.testing.assert_allclose(batched[i, j], single(i, j), atol=1e-12, err_msg=name)
    assert G.random(0, size=(2, 3)).shape == (2, 3, n, n)
    assert G.random(0, size=3).shape == (3, n, n)


@every_group
def test_random_is_seeded(case):
    _, G, _ = case
    np.testing.assert_array_equal(G.random(42, size=4), G.random(np.random.default_rng(42), size=4))


# -- validation -------------------------------------------------------------------------------------------


@every_group
def test_shape_errors_name_the_argument(case):
    _, G, _ = case
    with pytest.raises(ShapeError, match=rf"to have shape \(\.\.\., {G.dim}\), got \({G.dim + 1},\)"):
        G.exp(np.zeros(G.dim + 1))
    with pytest.raises(ShapeError, match=r"to have shape \(\.\.\., \d, \d\)"):
        G.log(np.zeros((2, G.matrix_size + 1, G.matrix_size)))
    with pytest.raises(InputError, match="finite"):
        G.exp(np.full(G.dim, np.nan))


@every_group
def test_non_elements_are_rejected(case):
    name, G, _ = case
    if name in GENERIC:
        pytest.skip("a group given only by its algebra has no membership test")
    g = G.random(0)
    g[0, 0] += 1e-3
    with pytest.raises(InputError, match="off by"):
        G.log(g)


def test_a_product_refuses_coupling_between_its_factors_and_says_where():
    G = SE2() * SO2("psi")
    g = G.random(1, size=3)
    G.check(g)  # block diagonal: an element
    g[2, 0, 3] = 1e-3  # couples the SE(2) block to the SO(2) block in the third element only
    with pytest.raises(
        InputError, match=r"SE\(2\) x SO\(2\) \(block diagonal\), got one off by 0\.001 at batch index \(2,\)"
    ):
        G.check(g)


def test_a_basis_that_is_not_an_algebra_is_refused():
    X = np.zeros((2, 3, 3))
    X[0, 0, 1] = 1.0
    X[1, 1, 0] = 1.0  # [X0, X1] = diag(1, -1, 0), not in the span
    with pytest.raises(InputError, match="not closed"):
        MatrixGroup("bad", X)
    with pytest.raises(InputError, match="linearly dependent"):
        MatrixGroup("dependent", [X[0], 2 * X[0]])


def test_products_flatten_and_names_must_differ():
    G = SE2() * SO2("psi") * Rn("s")
    assert [f.name for f in G.factors] == ["SE(2)", "SO(2)", "R^1"]
    assert (G.dim, G.matrix_size, G.angle_components, G.chart_angles) == (5, 7, (2, 3), (2, 3))
    with pytest.raises(InputError, match="distinct coordinate names"):
        SE2() * SO2()  # both name an angle theta
    assert SE2("a", "b", "c") == SE2("a", "b", "c") and SE2() != SE2("a", "b", "c")
    assert hash(SO3(seq="ZYX")) == hash(SO3(seq="ZYX")) and SO3(seq="ZYX") != SO3()


def test_SO3_constructors_agree_with_scipy(rng):
    from scipy.spatial.transform import Rotation

    G = SO3()
    R = G.random(rng, size=5)
    q = G.as_quaternion(R)
    np.testing.assert_allclose(G.from_quaternion(q), R, atol=1e-14)
    np.testing.assert_allclose(G.from_quaternion(q[..., [1, 2, 3, 0]], scalar_first=False), R, atol=1e-14)
    angles = G.as_euler(R, "ZYX")
    np.testing.assert_allclose(Rotation.from_euler("ZYX", angles).as_matrix(), R, atol=1e-13)
    np.testing.assert_allclose(G.from_euler(angles, "ZYX"), R, atol=1e-13)


# -- the symbolic twins -----------------------------------------------------------------------------------

CHARTED = [c for c in CASES if c[0] != "matrix-so3"]


@pytest.mark.parametrize("case", CHARTED, ids=[c[0] for c in CHARTED])
def test_twin_chart_and_body_velocity_against_the_numeric_group(case, rng):
    # g(q) of the twin is the numeric chart, and xi = Lambda(q) qdot is (g^-1 dg/dt)^vee by finite differences
    _, G, _ = case
    chart = GroupChart(G)
    q_sym = list(chart.coordinates)
    g_fn = sp.lambdify(q_sym, chart.matrix, "numpy")
    gi_fn = sp.lambdify(q_sym, chart.inverse, "numpy")
    lam_fn = sp.lambdify(q_sym, chart.body_velocity_matrix, "numpy")
    ref = np.array([float(v) for v in chart.reference])
    for _ in range(3):
        q = ref + rng.uniform(-1.0, 1.0, G.dim)
        qd = rng.normal(size=G.dim)
        g = chart.from_coordinates(q)
        np.testing.assert_allclose(g, np.asarray(g_fn(*q), float), atol=1e-14)
        np.testing.assert_allclose(np.asarray(gi_fn(*q), float) @ g, np.eye(G.matrix_size), atol=1e-13)
        h = 1e-6
        dg = (chart.from_coordinates(q + h * qd) - chart.from_coordinates(q - h * qd)) / (2 * h)
        xi = G.vee(G.inverse(g) @ dg)
        np.testing.assert_allclose(np.asarray(lam_fn(*q), float) @ qd, xi, atol=1e-8)
        # coordinates read back (Gauss-Newton where the group has no closed form), near the reference
        np.testing.assert_allclose(chart.to_coordinates(g, start=q + 1e-3), q, atol=1e-9)


@pytest.mark.parametrize("case", CHARTED, ids=[c[0] for c in CHARTED])
def test_twin_structure_constants_and_Ad_are_the_numeric_ones(case, rng):
    _, G, _ = case
    chart = GroupChart(G, [f"q{i}" for i in range(G.dim)])
    C = np.array(chart.structure_constants, dtype=float)
    np.testing.assert_allclose(C, G.structure_constants, atol=1e-14)
    xi, eta = rng.normal(size=(2, G.dim))
    exact = np.array(chart.bracket(list(map(sp.Float, xi)), list(map(sp.Float, eta))), dtype=float).ravel()
    np.testing.assert_allclose(exact, G.bracket(xi, eta), atol=1e-13)
    q = np.array([float(v) for v in chart.reference]) + rng.uniform(-1.0, 1.0, G.dim)
    Ad = sp.lambdify(chart.coordinates, chart.Ad_matrix(), "numpy")(*q)
    np.testing.assert_allclose(np.asarray(Ad, dtype=float), G.Ad(chart.from_coordinates(q)), atol=1e-12)


def test_so3_body_velocity_is_the_textbook_313_formula():
    chart = GroupChart(SO3())
    phi, th, psi = chart.coordinates
    want = sp.Matrix(
        [[sp.sin(th) * sp.sin(psi), sp.cos(psi), 0], [sp.sin(th) * sp.cos(psi), -sp.sin(psi), 0], [sp.cos(th), 0, 1]]
    )
    assert sp.simplify(chart.body_velocity_matrix - want) == sp.zeros(3, 3)


def test_coordinates_are_read_back_continuously_along_a_path():
    # a heading that turns about twice: the generic chart's Gauss-Newton follows it without wrapping
    G = CASES[IDS.index("matrix-se2")][1] * Rn("z")
    chart = GroupChart(G)
    t = np.linspace(0, 3, 61)
    q = np.stack([np.cos(t), np.sin(2 * t), 4.0 * t, 0.5 * t], -1)
    g = chart.from_coordinates(q)
    np.testing.assert_allclose(chart.to_coordinates(g, start=q[0]), q, atol=1e-10)
