"""MatrixLieGroup (any matrix group from a basis of its algebra) against the closed-form groups."""

import numpy as np
import pytest

from geomech.errors import InputError
from geomech.lie import se2, se3, so3
from geomech.lie.matrix_group import MatrixLieGroup
from geomech.systems.nonholonomic import S1, SE2, SE3, SO3, Rn


@pytest.mark.parametrize("build, lie", [(SE2, se2), (lambda: SO3(seq="ZYX"), so3), (SE3, se3)])
def test_exp_ad_and_right_jacobian_match_the_closed_forms(build, lie, rng):
    G = build().numeric()
    u = rng.normal(size=(5, G.dim)) * 0.8
    np.testing.assert_allclose(G.exp(u), lie.exp(u), atol=1e-13)
    np.testing.assert_allclose(G.ad(u), lie.ad(u), atol=1e-14)
    np.testing.assert_allclose(G.dexpinv(u), lie.right_jacobian_inverse(u), atol=1e-11)
    g = lie.exp(u)
    np.testing.assert_allclose(G.Ad(g), lie.Ad(g), atol=1e-13)


def test_right_jacobian_is_the_derivative_of_exp(rng):
    # d/dt exp(u + t v) at t = 0 equals exp(u) hat(J_r(u) v), by central differences
    G = (SE3() * S1()).numeric()
    assert G.dim == 7 and not G.abelian
    u, v = rng.normal(size=7), rng.normal(size=7)
    eps = 1e-6
    fd = (G.exp(u + eps * v) - G.exp(u - eps * v)) / (2 * eps)
    np.testing.assert_allclose(fd, G.exp(u) @ G.hat(G.right_jacobian(u) @ v), atol=1e-8)


def test_coordinates_are_read_back_continuously_along_a_path():
    G = (SE2("x", "y", "th") * Rn("z")).numeric()
    t = np.linspace(0, 3, 61)
    q = np.stack([np.cos(t), np.sin(2 * t), 4.0 * t, 0.5 * t], -1)  # the heading turns ~2 times: not wrapped
    g = G.from_coordinates(q)
    np.testing.assert_allclose(G.to_coordinates(g, start=q[0]), q, atol=1e-10)
    assert (Rn("a", "b").numeric()).abelian


def test_a_basis_that_is_not_an_algebra_is_refused():
    X = np.zeros((2, 3, 3))
    X[0, 0, 1] = 1.0
    X[1, 1, 0] = 1.0  # [X0, X1] = diag(1, -1, 0), not in the span
    with pytest.raises(InputError, match="not closed"):
        MatrixLieGroup("bad", X)
