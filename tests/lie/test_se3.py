"""SE(3)-specific checks: ordering (v, omega), Ad = [[R, hat(t) R], [0, R]], screw motions, log near pi."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geomech.lie import se3, so3


def test_module_constants():
    assert (se3.DIM, se3.MATRIX_SIZE, se3.POINT_DIM) == (6, 4, 3)


def test_hat_ordering_is_translation_first():
    X = se3.hat([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    np.testing.assert_array_equal(X[:3, 3], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(X[:3, :3], so3.hat([4.0, 5.0, 6.0]))
    np.testing.assert_array_equal(X[3], np.zeros(4))


def test_Ad_block_form():
    g = se3.random(1)
    R, t = g[:3, :3], g[:3, 3]
    expected = np.block([[R, so3.hat(t) @ R], [np.zeros((3, 3)), R]])
    np.testing.assert_allclose(se3.Ad(g), expected, atol=1e-15)


def test_screw_motion_about_z():
    # Rotation by a about z with velocity h along z and about the origin: a helix with pitch h/a.
    a, h = 1.3, 0.7
    g = se3.exp([0.0, 0.0, h, 0.0, 0.0, a])
    np.testing.assert_allclose(g[:3, :3], so3.rot_z(a), atol=1e-15)
    np.testing.assert_allclose(g[:3, 3], [0.0, 0.0, h], atol=1e-15)
    # about an axis through p = (1, 0, 0): v = -omega x p
    p = np.array([1.0, 0.0, 0.0])
    w = np.array([0.0, 0.0, a])
    g = se3.exp(np.concatenate([-np.cross(w, p), w]))
    np.testing.assert_allclose(se3.act(g, p), p, atol=1e-15)


def test_coad_is_spatial_momentum():
    g = se3.random(2)
    R, t = g[:3, :3], g[:3, 3]
    p, m = np.array([0.1, -0.5, 2.0]), np.array([1.0, 0.3, -0.7])
    expected = np.concatenate([R @ p, R @ m + np.cross(t, R @ p)])
    np.testing.assert_allclose(se3.coad(g, np.concatenate([p, m])), expected, atol=1e-14)


def test_left_jacobian_is_the_series_of_ad():
    xi = np.array([0.4, -1.1, 0.3, 0.9, -1.6, 0.5])
    A = se3.ad(xi)
    series, term = np.zeros((6, 6)), np.eye(6)
    for k in range(40):
        series += term / math.factorial(k + 1)
        term = term @ A
    np.testing.assert_allclose(se3.left_jacobian(xi), series, atol=1e-14)


@pytest.mark.parametrize("delta", [1e-6, 1e-10, 0.0])
def test_log_near_rotation_angle_pi(delta):
    n = np.array([2.0, -1.0, 0.5])
    n /= np.linalg.norm(n)
    xi = np.concatenate([[0.3, 1.0, -2.0], (np.pi - delta) * n])
    g = se3.exp(xi)
    back = se3.log(g)
    np.testing.assert_allclose(se3.exp(back), g, atol=1e-14)
    if delta > 0:
        np.testing.assert_allclose(back, xi, atol=1e-9)
