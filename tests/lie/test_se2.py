"""SE(2)-specific checks: ordering (v_x, v_y, omega), closed forms, log at omega = pi."""

from __future__ import annotations

import numpy as np
import pytest

from geomech.lie import se2, so3


def test_module_constants():
    assert (se2.DIM, se2.MATRIX_SIZE, se2.POINT_DIM) == (3, 3, 2)


def test_hat_ordering():
    np.testing.assert_array_equal(se2.hat([1.0, 2.0, 3.0]), [[0, -3.0, 1.0], [3.0, 0, 2.0], [0, 0, 0]])


def test_exp_of_pure_translation_and_pure_rotation():
    np.testing.assert_allclose(se2.exp([1.0, -2.0, 0.0]), [[1, 0, 1.0], [0, 1, -2.0], [0, 0, 1]], atol=0)
    g = se2.exp([0.0, 0.0, np.pi / 2])
    np.testing.assert_allclose(g, [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)


def test_exp_is_a_circular_arc():
    # Unit forward speed with unit turning rate for time pi: half a circle of radius 1, ending at (0, 2).
    g = se2.exp([np.pi, 0.0, np.pi])
    np.testing.assert_allclose(g[:2, 2], [0.0, 2.0], atol=1e-15)


def test_rotation_block_agrees_with_so3_about_z():
    w = np.linspace(-3, 3, 7)
    g = se2.exp(np.stack([np.zeros_like(w), np.zeros_like(w), w], -1))
    np.testing.assert_allclose(g[..., :2, :2], so3.rot_z(w)[..., :2, :2], atol=1e-15)


@pytest.mark.parametrize("w", [np.pi, -np.pi])
def test_log_at_pi_returns_omega_pi(w):
    g = se2.exp([0.7, -0.2, w])
    xi = se2.log(g)
    assert xi[2] == pytest.approx(np.pi, abs=1e-15)
    np.testing.assert_allclose(se2.exp(xi), g, atol=1e-15)


def test_Ad_closed_form():
    g = se2.exp([0.3, -1.2, 0.8])
    R, t = g[:2, :2], g[:2, 2]
    expected = np.block([[R, np.array([[t[1]], [-t[0]]])], [np.zeros((1, 2)), np.ones((1, 1))]])
    np.testing.assert_allclose(se2.Ad(g), expected, atol=0)
