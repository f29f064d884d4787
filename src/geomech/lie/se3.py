r"""The rigid motions SE(3) as homogeneous ``(..., 4, 4)`` matrices, se(3) as ``(..., 6)`` vectors.

An element is ``g = [[R, t], [0, 1]]`` with ``R`` in SO(3) and ``t`` in R^3, acting on points by
``x -> R x + t``. The tangent vector is ordered ``xi = (v, omega)``: translational part first, rotational
part last, so that

.. math::

    \hat\xi = \begin{pmatrix} \hat\omega & v \\ 0 & 0 \end{pmatrix}, \qquad
    \mathrm{Ad}_g = \begin{pmatrix} R & \hat t R \\ 0 & R \end{pmatrix}.

This is the ordering of Barfoot, *State Estimation for Robotics* (2017), ch. 7, whose formulas are used.
The dual se(3)* is identified with R^6 by the Euclidean pairing. The API is that of
:mod:`geomech.lie.so3`; Jacobians follow the same convention,
``exp(xi + d) ~ exp(J_l(xi) d) exp(xi) ~ exp(xi) exp(J_r(xi) d)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _common as c
from . import so3

__all__ = [
    "DIM",
    "MATRIX_SIZE",
    "POINT_DIM",
    "hat",
    "vee",
    "exp",
    "log",
    "inverse",
    "compose",
    "act",
    "Ad",
    "ad",
    "coad",
    "identity",
    "random",
    "left_jacobian",
    "right_jacobian",
    "left_jacobian_inverse",
    "right_jacobian_inverse",
]

DIM = 6
"""Dimension of the algebra se(3)."""
MATRIX_SIZE = 4
"""Size of the homogeneous matrices representing the group."""
POINT_DIM = 3
"""Dimension of the points the group acts on."""


def _element(g: Any, name: str) -> np.ndarray:
    return c.rigid_motion(g, name, 3)


def _assemble(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.zeros(R.shape[:-2] + (4, 4), dtype=R.dtype)
    out[..., :3, :3] = R
    out[..., :3, 3] = t
    out[..., 3, 3] = 1.0
    return out


def _blocks(A: np.ndarray, B: np.ndarray, D: np.ndarray) -> np.ndarray:
    """``[[A, B], [0, D]]`` from 3x3 blocks."""
    out = np.zeros(np.broadcast_shapes(A.shape, B.shape, D.shape)[:-2] + (6, 6), dtype=A.dtype)
    out[..., :3, :3] = A
    out[..., :3, 3:] = B
    out[..., 3:, 3:] = D
    return out


def hat(xi: Any) -> np.ndarray:
    r"""Matrix of a tangent vector ``xi = (v, omega)``.

    .. math::

        \hat\xi = \begin{pmatrix} \hat\omega & v \\ 0 & 0 \end{pmatrix}

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    xi = c.vector(xi, "xi", 6)
    out = np.zeros(xi.shape[:-1] + (4, 4), dtype=xi.dtype)
    out[..., :3, :3] = so3._hat(xi[..., 3:])
    out[..., :3, 3] = xi[..., :3]
    return out


def vee(X: Any) -> np.ndarray:
    """Inverse of :func:`hat`: ``(X[:3, 3], vee(X[:3, :3]))``, using the skew part of the rotation block.

    Parameters
    ----------
    X : array_like, shape (..., 4, 4)

    Returns
    -------
    ndarray, shape (..., 6)
    """
    X = c.matrix(X, "X", 4)
    return np.concatenate([X[..., :3, 3], so3._vee(X[..., :3, :3])], axis=-1)


def exp(xi: Any) -> np.ndarray:
    r"""Exponential map se(3) -> SE(3).

    .. math::

        \exp\hat\xi = \begin{pmatrix} \exp\hat\omega & J_l^{SO(3)}(\omega)\, v \\ 0 & 1 \end{pmatrix},

    Barfoot (2017), eq. (7.83), with the Taylor branches of :func:`geomech.lie.so3.left_jacobian`.

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    xi = c.vector(xi, "xi", 6)
    w = c.angles(xi[..., 3:], "xi")
    t = np.einsum("...ij,...j->...i", so3._left_jacobian(w), xi[..., :3])
    return _assemble(so3._exp(w), t)


def log(g: Any) -> np.ndarray:
    r"""Logarithm SE(3) -> se(3), with rotation angle in [0, pi].

    .. math::

        \omega = \log R, \qquad v = J_l^{SO(3)}(\omega)^{-1} t,

    with ``log R`` from :func:`geomech.lie.so3.log` (accurate up to and at angle pi) and the inverse
    Jacobian finite there (its singularities are at angle ``2 pi k``, ``k != 0``).

    Parameters
    ----------
    g : array_like, shape (..., 4, 4)
        Homogeneous matrices (validated).

    Returns
    -------
    ndarray, shape (..., 6)
    """
    g = _element(g, "g")
    w = so3._log(g[..., :3, :3])
    v = np.einsum("...ij,...j->...i", so3._left_jacobian_inverse(w), g[..., :3, 3])
    return np.concatenate([v, w], axis=-1)


def inverse(g: Any) -> np.ndarray:
    r"""Inverse, ``[[R, t], [0, 1]]^{-1} = [[R^T, -R^T t], [0, 1]]``.

    Parameters
    ----------
    g : array_like, shape (..., 4, 4)

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    g = _element(g, "g")
    Rt = np.swapaxes(g[..., :3, :3], -1, -2)
    return _assemble(Rt, -np.einsum("...ij,...j->...i", Rt, g[..., :3, 3]))


def compose(g: Any, h: Any) -> np.ndarray:
    """Group product ``g h`` (apply ``h`` first), batch axes broadcast.

    Parameters
    ----------
    g, h : array_like, shape (..., 4, 4)

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    return _element(g, "g") @ _element(h, "h")


def act(g: Any, x: Any) -> np.ndarray:
    """Action on points, ``R x + t``, batch axes broadcast.

    Parameters
    ----------
    g : array_like, shape (..., 4, 4)
    x : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    g = _element(g, "g")
    x = c.vector(x, "x", 3)
    return np.einsum("...ij,...j->...i", g[..., :3, :3], x) + g[..., :3, 3]


def Ad(g: Any) -> np.ndarray:
    r"""Matrix of the adjoint action on se(3) ~ R^6, for the ordering ``(v, omega)``.

    .. math::

        \widehat{\mathrm{Ad}_g \xi} = g \hat\xi g^{-1}, \qquad
        \mathrm{Ad}_g = \begin{pmatrix} R & \hat t R \\ 0 & R \end{pmatrix}.

    Parameters
    ----------
    g : array_like, shape (..., 4, 4)

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    g = _element(g, "g")
    R = g[..., :3, :3]
    return _blocks(R, so3._hat(g[..., :3, 3]) @ R, R)


def ad(xi: Any) -> np.ndarray:
    r"""Matrix of ``ad_xi eta = [xi, eta]`` (the derivative of :func:`Ad` at the identity).

    .. math::

        \mathrm{ad}_\xi = \begin{pmatrix} \hat\omega & \hat v \\ 0 & \hat\omega \end{pmatrix}

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    xi = c.vector(xi, "xi", 6)
    W = so3._hat(xi[..., 3:])
    return _blocks(W, so3._hat(xi[..., :3]), W)


def coad(g: Any, mu: Any) -> np.ndarray:
    r"""Coadjoint action ``Ad*_{g^{-1}} mu = Ad_{g^{-1}}^T mu`` on se(3)* ~ R^6.

    From the pairing, :math:`\langle \mathrm{Ad}^*_{g^{-1}}\mu, \xi\rangle
    = \langle \mu, \mathrm{Ad}_{g^{-1}}\xi\rangle`. With ``mu = (p, m)`` (linear, angular body momentum)
    this is ``(R p, R m + t x R p)``, the spatial momenta.

    Parameters
    ----------
    g : array_like, shape (..., 4, 4)
    mu : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 6)
    """
    return np.einsum("...ji,...j->...i", Ad(inverse(g)), c.vector(mu, "mu", 6))


def identity(batch_shape: Any = ()) -> np.ndarray:
    """Identity elements of shape ``(*batch_shape, 4, 4)``."""
    return c.eye(4, batch_shape)


def random(rng: Any = None, size: Any = ()) -> np.ndarray:
    """Random elements: Haar-uniform rotation, standard normal translation.

    SE(3) has no invariant probability measure (it is not compact); the translation law is a choice.

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
    size : int or tuple of int
        Batch shape.

    Returns
    -------
    ndarray, shape ``(*size, 4, 4)``
    """
    rng = c.generator(rng)
    shape = c.batch_shape_of(size)
    R = c.quat_to_matrix(c.random_unit_quaternions(rng, shape))
    return _assemble(R, rng.standard_normal(shape + (3,)))


def _Q(xi: np.ndarray) -> np.ndarray:
    v, w = xi[..., :3], xi[..., 3:]
    theta = so3._norm(w)
    W = so3._hat(w)
    V = so3._hat(v)
    WV, VW = W @ V, V @ W
    WVW = WV @ W
    WW = W @ W
    c1 = c.T_MINUS_SIN_T3(theta)[..., None, None]
    c2 = c.SE3_C2(theta)[..., None, None]
    c3 = c.SE3_C3(theta)[..., None, None]
    return 0.5 * V + c1 * (WV + VW + WVW) + c2 * (WW @ V + V @ WW - 3.0 * WVW) + c3 * (WVW @ W + W @ WVW)


def _left_jacobian(xi: np.ndarray) -> np.ndarray:
    J = so3._left_jacobian(xi[..., 3:])
    return _blocks(J, _Q(xi), J)


def _left_jacobian_inverse(xi: np.ndarray) -> np.ndarray:
    Jinv = so3._left_jacobian_inverse(xi[..., 3:])
    return _blocks(Jinv, -Jinv @ _Q(xi) @ Jinv, Jinv)


def left_jacobian(xi: Any) -> np.ndarray:
    r"""Left Jacobian of SE(3), ``exp(xi + d) ~ exp(J_l(xi) d) exp(xi)``.

    .. math::

        J_l(\xi) = \sum_{k\ge0}\frac{\mathrm{ad}_\xi^k}{(k+1)!}
                 = \begin{pmatrix} J & Q \\ 0 & J \end{pmatrix},

    with ``J`` the SO(3) left Jacobian of ``omega`` and

    .. math::

        Q = \tfrac12 \hat v + c_1 (\hat\omega\hat v + \hat v\hat\omega + \hat\omega\hat v\hat\omega)
            + c_2 (\hat\omega^2\hat v + \hat v\hat\omega^2 - 3\hat\omega\hat v\hat\omega)
            + c_3 (\hat\omega\hat v\hat\omega^2 + \hat\omega^2\hat v\hat\omega),

        c_1 = \frac{\theta - \sin\theta}{\theta^3},\;
        c_2 = \frac{\theta^2 + 2\cos\theta - 2}{2\theta^4},\;
        c_3 = \frac{2\theta - 3\sin\theta + \theta\cos\theta}{2\theta^5},

    Barfoot (2017), eq. (7.86b) (checked here against the series and finite differences); Taylor
    branches near ``theta = |omega| = 0``.

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    return _left_jacobian(c.vector(xi, "xi", 6))


def right_jacobian(xi: Any) -> np.ndarray:
    """Right Jacobian of SE(3), ``J_r(xi) = J_l(-xi)``.

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    return _left_jacobian(-c.vector(xi, "xi", 6))


def left_jacobian_inverse(xi: Any) -> np.ndarray:
    r"""Inverse of :func:`left_jacobian`, ``[[J^{-1}, -J^{-1} Q J^{-1}], [0, J^{-1}]]``.

    Singular at rotation angle ``2 pi k``, ``k != 0``.

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    return _left_jacobian_inverse(c.vector(xi, "xi", 6))


def right_jacobian_inverse(xi: Any) -> np.ndarray:
    """Inverse of :func:`right_jacobian`, ``J_r^{-1}(xi) = J_l^{-1}(-xi)``.

    Parameters
    ----------
    xi : array_like, shape (..., 6)

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    return _left_jacobian_inverse(-c.vector(xi, "xi", 6))
