r"""The planar rigid motions SE(2) as homogeneous ``(..., 3, 3)`` matrices, se(2) as ``(..., 3)`` vectors.

An element is ``g = [[R, t], [0, 1]]`` with ``R`` in SO(2) and ``t`` in R^2, acting on points by
``x -> R x + t``. The tangent vector is ordered ``xi = (v_x, v_y, omega)``: translational velocity first,
angular velocity last, so that

.. math::

    \hat\xi = \begin{pmatrix} 0 & -\omega & v_x \\ \omega & 0 & v_y \\ 0 & 0 & 0 \end{pmatrix}.

The dual se(2)* is identified with R^3 by the Euclidean pairing. The API is that of
:mod:`geomech.lie.so3`; Jacobians follow the same convention,
``exp(xi + d) ~ exp(J_l(xi) d) exp(xi) ~ exp(xi) exp(J_r(xi) d)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _common as c

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

DIM = 3
"""Dimension of the algebra se(2)."""
MATRIX_SIZE = 3
"""Size of the homogeneous matrices representing the group."""
POINT_DIM = 2
"""Dimension of the points the group acts on."""


def _element(g: Any, name: str) -> np.ndarray:
    return c.rigid_motion(g, name, 2)


def _hat(xi: np.ndarray) -> np.ndarray:
    out = np.zeros(xi.shape + (3,), dtype=xi.dtype)
    out[..., 0, 1] = -xi[..., 2]
    out[..., 1, 0] = xi[..., 2]
    out[..., 0, 2] = xi[..., 0]
    out[..., 1, 2] = xi[..., 1]
    return out


def hat(xi: Any) -> np.ndarray:
    r"""Matrix of a tangent vector ``xi = (v_x, v_y, omega)``.

    .. math::

        \hat\xi = \begin{pmatrix} 0 & -\omega & v_x \\ \omega & 0 & v_y \\ 0 & 0 & 0 \end{pmatrix}

    Parameters
    ----------
    xi : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _hat(c.vector(xi, "xi", 3))


def vee(X: Any) -> np.ndarray:
    r"""Inverse of :func:`hat`, ``(X_{13}, X_{23}, (X_{21} - X_{12})/2)``.

    Parameters
    ----------
    X : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    X = c.matrix(X, "X", 3)
    return np.stack([X[..., 0, 2], X[..., 1, 2], 0.5 * (X[..., 1, 0] - X[..., 0, 1])], axis=-1)


def _rot2(w: np.ndarray) -> np.ndarray:
    cw, sw = np.cos(w), np.sin(w)
    return np.stack([np.stack([cw, -sw], -1), np.stack([sw, cw], -1)], -2)


def _V(w: np.ndarray) -> np.ndarray:
    # V = A I + B J with J the planar quarter turn; B is odd in omega, so B = omega * (1 - cos)/omega^2.
    A = c.SINC(w)
    B = w * c.ONE_MINUS_COS_T2(w)
    return np.stack([np.stack([A, -B], -1), np.stack([B, A], -1)], -2)


def _assemble(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.zeros(R.shape[:-2] + (3, 3), dtype=R.dtype)
    out[..., :2, :2] = R
    out[..., :2, 2] = t
    out[..., 2, 2] = 1.0
    return out


def exp(xi: Any) -> np.ndarray:
    r"""Exponential map se(2) -> SE(2).

    .. math::

        \exp\hat\xi = \begin{pmatrix} R(\omega) & V(\omega)\, v \\ 0 & 1 \end{pmatrix}, \qquad
        V(\omega) = \begin{pmatrix} \frac{\sin\omega}{\omega} & -\frac{1 - \cos\omega}{\omega} \\
                                   \frac{1 - \cos\omega}{\omega} & \frac{\sin\omega}{\omega} \end{pmatrix},

    with Taylor branches near ``omega = 0`` (exact to round-off, never NaN).

    Parameters
    ----------
    xi : array_like, shape (..., 3)
        ``(v_x, v_y, omega)``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    xi = c.vector(xi, "xi", 3)
    w = c.angles(xi[..., 2], "xi")
    t = np.einsum("...ij,...j->...i", _V(w), xi[..., :2])
    return _assemble(_rot2(w), t)


def log(g: Any) -> np.ndarray:
    r"""Logarithm SE(2) -> se(2), with ``omega`` in (-pi, pi].

    .. math::

        \omega = \operatorname{atan2}(R_{21}, R_{11}), \qquad
        v = V(\omega)^{-1} t = \Big(\tfrac{\omega}{2}\cot\tfrac{\omega}{2}\, I
            - \tfrac{\omega}{2} J\Big) t, \quad J = \begin{pmatrix} 0 & -1 \\ 1 & 0 \end{pmatrix}.

    Parameters
    ----------
    g : array_like, shape (..., 3, 3)
        Homogeneous matrices (validated).

    Returns
    -------
    ndarray, shape (..., 3)
    """
    g = _element(g, "g")
    w = np.arctan2(g[..., 1, 0], g[..., 0, 0])
    # atan2 returns -pi for a rotation by pi whose sine rounds to -0.0; keep the range (-pi, pi].
    w = np.where(w <= -np.pi, np.pi, w)
    alpha = c.HALF_COT_HALF(w)
    tx, ty = g[..., 0, 2], g[..., 1, 2]
    vx = alpha * tx + 0.5 * w * ty
    vy = -0.5 * w * tx + alpha * ty
    return np.stack([vx, vy, w], axis=-1)


def inverse(g: Any) -> np.ndarray:
    r"""Inverse, ``[[R, t], [0, 1]]^{-1} = [[R^T, -R^T t], [0, 1]]``.

    Parameters
    ----------
    g : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    g = _element(g, "g")
    Rt = np.swapaxes(g[..., :2, :2], -1, -2)
    return _assemble(Rt, -np.einsum("...ij,...j->...i", Rt, g[..., :2, 2]))


def compose(g: Any, h: Any) -> np.ndarray:
    """Group product ``g h`` (apply ``h`` first), batch axes broadcast.

    Parameters
    ----------
    g, h : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _element(g, "g") @ _element(h, "h")


def act(g: Any, x: Any) -> np.ndarray:
    """Action on points, ``R x + t``, batch axes broadcast.

    Parameters
    ----------
    g : array_like, shape (..., 3, 3)
    x : array_like, shape (..., 2)

    Returns
    -------
    ndarray, shape (..., 2)
    """
    g = _element(g, "g")
    x = c.vector(x, "x", 2)
    return np.einsum("...ij,...j->...i", g[..., :2, :2], x) + g[..., :2, 2]


def Ad(g: Any) -> np.ndarray:
    r"""Matrix of the adjoint action on se(2) ~ R^3, for the ordering ``(v_x, v_y, omega)``.

    .. math::

        \widehat{\mathrm{Ad}_g \xi} = g \hat\xi g^{-1}, \qquad
        \mathrm{Ad}_g = \begin{pmatrix} R & (t_y, -t_x)^T \\ 0 & 1 \end{pmatrix}.

    Parameters
    ----------
    g : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    g = _element(g, "g")
    out = np.zeros_like(g)
    out[..., :2, :2] = g[..., :2, :2]
    out[..., 0, 2] = g[..., 1, 2]
    out[..., 1, 2] = -g[..., 0, 2]
    out[..., 2, 2] = 1.0
    return out


def ad(xi: Any) -> np.ndarray:
    r"""Matrix of ``ad_xi eta = [xi, eta]`` (the derivative of :func:`Ad` at the identity).

    .. math::

        \mathrm{ad}_\xi = \begin{pmatrix} 0 & -\omega & v_y \\ \omega & 0 & -v_x \\ 0 & 0 & 0 \end{pmatrix}

    Parameters
    ----------
    xi : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    xi = c.vector(xi, "xi", 3)
    out = np.zeros(xi.shape + (3,), dtype=xi.dtype)
    out[..., 0, 1] = -xi[..., 2]
    out[..., 1, 0] = xi[..., 2]
    out[..., 0, 2] = xi[..., 1]
    out[..., 1, 2] = -xi[..., 0]
    return out


def coad(g: Any, mu: Any) -> np.ndarray:
    r"""Coadjoint action ``Ad*_{g^{-1}} mu = Ad_{g^{-1}}^T mu`` on se(2)* ~ R^3.

    From the pairing, :math:`\langle \mathrm{Ad}^*_{g^{-1}}\mu, \xi\rangle
    = \langle \mu, \mathrm{Ad}_{g^{-1}}\xi\rangle`; this is the spatial momentum of a body momentum ``mu``.

    Parameters
    ----------
    g : array_like, shape (..., 3, 3)
    mu : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    return np.einsum("...ji,...j->...i", Ad(inverse(g)), c.vector(mu, "mu", 3))


def identity(batch_shape: Any = ()) -> np.ndarray:
    """Identity elements of shape ``(*batch_shape, 3, 3)``."""
    return c.eye(3, batch_shape)


def random(rng: Any = None, size: Any = ()) -> np.ndarray:
    """Random elements: rotation angle uniform on [-pi, pi), translation standard normal.

    SE(2) has no invariant probability measure (it is not compact); the translation law is a choice.

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
    size : int or tuple of int
        Batch shape.

    Returns
    -------
    ndarray, shape ``(*size, 3, 3)``
    """
    rng = c.generator(rng)
    shape = c.batch_shape_of(size)
    w = rng.uniform(-np.pi, np.pi, size=shape)
    t = rng.standard_normal(shape + (2,))
    return _assemble(_rot2(w), t)


def _jac_column(xi: np.ndarray) -> np.ndarray:
    w = xi[..., 2]
    vx, vy = xi[..., 0], xi[..., 1]
    # Third column of J_l = sum ad^k/(k+1)!: (P vy + Q vx, -P vx + Q vy), with P = (1 - cos)/w^2 (even)
    # and Q = (w - sin w)/w^2 = w (w - sin w)/w^3 (odd, so built from the even series).
    P = c.ONE_MINUS_COS_T2(w)
    Q = w * c.T_MINUS_SIN_T3(w)
    return np.stack([P * vy + Q * vx, -P * vx + Q * vy], axis=-1)


def _left_jacobian(xi: np.ndarray) -> np.ndarray:
    return _assemble(_V(xi[..., 2]), _jac_column(xi))


def _left_jacobian_inverse(xi: np.ndarray) -> np.ndarray:
    col = _jac_column(xi)
    w = xi[..., 2]
    alpha = c.HALF_COT_HALF(w)
    Vinv = np.stack([np.stack([alpha, 0.5 * w], -1), np.stack([-0.5 * w, alpha], -1)], -2)
    return _assemble(Vinv, -np.einsum("...ij,...j->...i", Vinv, col))


def left_jacobian(xi: Any) -> np.ndarray:
    r"""Left Jacobian of SE(2), ``exp(xi + d) ~ exp(J_l(xi) d) exp(xi)``.

    .. math::

        J_l(\xi) = \sum_{k\ge0} \frac{\mathrm{ad}_\xi^k}{(k+1)!}
        = \begin{pmatrix} V(\omega) & \begin{matrix} P v_y + Q v_x \\ -P v_x + Q v_y \end{matrix} \\
          0 & 1 \end{pmatrix},
        \quad P = \frac{1 - \cos\omega}{\omega^2}, \; Q = \frac{\omega - \sin\omega}{\omega^2},

    derived by summing the series (``ad`` is block upper triangular); Taylor branches near ``omega = 0``.

    Parameters
    ----------
    xi : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian(c.vector(xi, "xi", 3))


def right_jacobian(xi: Any) -> np.ndarray:
    """Right Jacobian of SE(2), ``J_r(xi) = J_l(-xi)``.

    Parameters
    ----------
    xi : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian(-c.vector(xi, "xi", 3))


def left_jacobian_inverse(xi: Any) -> np.ndarray:
    r"""Inverse of :func:`left_jacobian`, ``[[V^{-1}, -V^{-1} c], [0, 1]]`` with ``c`` its third column.

    Singular at ``omega = 2 pi k``, ``k != 0``.

    Parameters
    ----------
    xi : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian_inverse(c.vector(xi, "xi", 3))


def right_jacobian_inverse(xi: Any) -> np.ndarray:
    """Inverse of :func:`right_jacobian`, ``J_r^{-1}(xi) = J_l^{-1}(-xi)``.

    Parameters
    ----------
    xi : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian_inverse(-c.vector(xi, "xi", 3))
