"""SO(3)-specific checks: the seed's hat map and Lemma 3, Rodrigues against scipy, log near pi, project."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from geomech.errors import InputError, ShapeError
from geomech.lie import so3

SETTINGS = settings(max_examples=25, deadline=None)
vec3 = arrays(np.float64, 3, elements=st.floats(-10, 10, allow_nan=False, allow_infinity=False))


def test_module_constants():
    assert (so3.DIM, so3.MATRIX_SIZE, so3.POINT_DIM) == (3, 3, 3)


@SETTINGS
@given(v=vec3, w=vec3)
def test_hat_is_eq_12_and_the_cross_product(v, w):
    expected = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    np.testing.assert_array_equal(so3.hat(v), expected)
    np.testing.assert_allclose(so3.hat(v) @ w, np.cross(v, w), rtol=1e-12, atol=1e-12)


def test_exp_matches_scipy_rotvec():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(200, 3)) * 3.0
    np.testing.assert_allclose(so3.exp(v), Rotation.from_rotvec(v).as_matrix(), atol=1e-14)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-4, 1.0, np.pi - 1e-6, np.pi - 1e-10, np.pi])
def test_exp_and_log_against_scipy_at_hand_picked_angles(angle):
    rng = np.random.default_rng(1)
    axes = rng.normal(size=(6, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    v = angle * axes
    R = so3.exp(v)
    np.testing.assert_allclose(R, Rotation.from_rotvec(v).as_matrix(), atol=1e-15)
    back = so3.log(R)
    assert np.all(np.isfinite(back))
    if angle < np.pi:
        np.testing.assert_allclose(back, v, atol=1e-12)
    else:
        dist = np.minimum(np.abs(back - v).max(-1), np.abs(back + v).max(-1))
        assert np.all(dist < 1e-12)


@pytest.mark.parametrize("axis", [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, -2, 3], [-1, -1, -1]])
def test_log_exactly_at_pi_from_the_symmetric_form(axis):
    n = np.asarray(axis, float) / np.linalg.norm(axis)
    R = 2.0 * np.outer(n, n) - np.eye(3)  # rotation by pi about n, built without exp
    v = so3.log(R)
    assert np.isclose(np.linalg.norm(v), np.pi, atol=1e-14)
    assert np.allclose(np.abs(v @ n), np.pi, atol=1e-14)
    np.testing.assert_allclose(so3.exp(v), R, atol=1e-15)


@pytest.mark.parametrize("delta", [1e-6, 1e-10])
def test_log_near_pi_keeps_the_sign_of_the_axis(delta):
    n = np.array([0.3, -0.4, np.sqrt(1 - 0.25)])
    for s in (1.0, -1.0):
        v = s * (np.pi - delta) * n
        np.testing.assert_allclose(so3.log(so3.exp(v)), v, atol=1e-12)


def test_log_angle_in_zero_pi():
    R = so3.random(3, size=500)
    angles = np.linalg.norm(so3.log(R), axis=-1)
    assert angles.min() >= 0.0 and angles.max() <= np.pi
    np.testing.assert_allclose(angles, Rotation.from_matrix(R).magnitude(), atol=1e-12)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), mu=vec3)
def test_coad_is_R_mu_lemma_3(seed, mu):
    R = so3.random(seed)
    np.testing.assert_allclose(so3.coad(R, mu), R @ mu, atol=1e-12)
    np.testing.assert_array_equal(so3.Ad(R), R)


def test_left_and_right_jacobians_transpose():
    rng = np.random.default_rng(4)
    v = rng.normal(size=(10, 3))
    np.testing.assert_allclose(so3.right_jacobian(v), np.swapaxes(so3.left_jacobian(v), -1, -2), atol=1e-15)


def test_random_is_haar_by_moments():
    # Under the Haar measure E[R] = 0 and E[tr R] = 0 and E[R_ij^2] = 1/3; a biased sampler fails these.
    R = so3.random(5, size=20000)
    assert np.abs(R.mean(axis=0)).max() < 0.02
    np.testing.assert_allclose((R**2).mean(axis=0), np.full((3, 3), 1 / 3), atol=0.01)


def test_project_returns_the_nearest_rotation():
    rng = np.random.default_rng(6)
    R = so3.random(rng, size=50)
    noisy = R + 1e-4 * rng.normal(size=R.shape)
    P = so3.project(noisy)
    np.testing.assert_allclose(np.swapaxes(P, -1, -2) @ P, np.broadcast_to(np.eye(3), P.shape), atol=1e-14)
    assert np.all(np.linalg.det(P) > 0)
    np.testing.assert_allclose(P, R, atol=1e-3)
    # nearest: no other rotation near it does better in the Frobenius norm
    base = np.linalg.norm(noisy - P, axis=(-2, -1))
    for d in rng.normal(size=(10, 3)) * 1e-3:
        other = P @ so3.exp(d)
        assert np.all(np.linalg.norm(noisy - other, axis=(-2, -1)) >= base - 1e-15)
    # a reflection is mapped to a rotation, not to itself
    assert np.linalg.det(so3.project(np.diag([1.0, 1.0, -1.0]))) > 0


@pytest.mark.parametrize("rot, k", [(so3.rot_x, 0), (so3.rot_y, 1), (so3.rot_z, 2)])
def test_elementary_rotations_are_exp_of_axes_and_vectorised(rot, k):
    a = np.linspace(-4, 4, 12).reshape(3, 4)
    R = rot(a)
    assert R.shape == (3, 4, 3, 3)
    np.testing.assert_allclose(R, so3.exp(a[..., None] * np.eye(3)[k]), atol=1e-15)


def test_rot_z_by_quarter_turn_maps_x_to_y():
    np.testing.assert_allclose(so3.rot_z(np.pi / 2) @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)
    np.testing.assert_allclose(so3.rot_x(np.pi / 2) @ [0, 1.0, 0], [0, 0, 1.0], atol=1e-15)
    np.testing.assert_allclose(so3.rot_y(np.pi / 2) @ [0, 0, 1.0], [1.0, 0, 0], atol=1e-15)


def test_a_rotation_is_told_from_a_reflection_alone_and_in_a_batch():
    """An orthogonal matrix with determinant -1 (-R for a rotation R) is refused, one or in a batch; R passes."""
    from geomech._validate import rotation_matrix

    R = so3.exp(np.array([0.3, -1.2, 2.0]))
    np.testing.assert_array_equal(rotation_matrix(R, "R"), R)
    np.testing.assert_array_equal(rotation_matrix(np.stack([R, R.T]), "R"), np.stack([R, R.T]))
    for bad in (-R, np.stack([R, -R]), -R.T):
        with pytest.raises(InputError, match="`R` to be a rotation matrix"):
            rotation_matrix(bad, "R")


def test_error_messages():
    with pytest.raises(ShapeError, match=r"^Expected `v` to have shape \(\.\.\., 3\), got \(4,\)\.$"):
        so3.hat(np.zeros(4))
    with pytest.raises(ShapeError, match=r"Expected `R` to have shape \(\.\.\., 3, 3\), got \(3,\)"):
        so3.log(np.zeros(3))
    with pytest.raises(InputError, match="rotation matrix"):
        so3.log(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InputError, match="project"):
        so3.inverse(2.0 * np.eye(3))
    with pytest.raises(InputError, match="finite"):
        so3.rot_x(np.inf)
