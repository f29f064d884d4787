r"""The rotation group SO(3) as ``(..., 3, 3)`` matrices and its algebra so(3) as ``(..., 3)`` vectors.

Every function is vectorised over leading batch axes and broadcasts them where it takes two arguments.
Conventions: a rotation ``R`` maps body to space coordinates, ``x = R X``; the algebra is identified with
``R^3`` by the hat map of eq. (12) of the Serret-Andoyer paper, ``hat(v) w = v x w``; the dual so(3)* is
identified with ``R^3`` by the Euclidean pairing. The API is shared with :mod:`geomech.lie.se2` and
:mod:`geomech.lie.se3`.

Jacobians follow the convention of Barfoot, *State Estimation for Robotics* (2017), sec. 7.1.3:

.. math::

    \exp(v + \delta) = \exp(J_l(v)\,\delta)\,\exp(v) + O(\delta^2)
                      = \exp(v)\,\exp(J_r(v)\,\delta) + O(\delta^2).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import finite
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
    "project",
    "rot_x",
    "rot_y",
    "rot_z",
]

DIM = 3
"""Dimension of the algebra so(3)."""
MATRIX_SIZE = 3
"""Size of the matrices representing the group."""
POINT_DIM = 3
"""Dimension of the points the group acts on."""


def _hat(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape + (3,), dtype=v.dtype)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    out[..., 0, 1] = -z
    out[..., 0, 2] = y
    out[..., 1, 0] = z
    out[..., 1, 2] = -x
    out[..., 2, 0] = -y
    out[..., 2, 1] = x
    return out


def _outer(v: np.ndarray) -> np.ndarray:
    return v[..., :, None] * v[..., None, :]


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def hat(v: Any, *, check: bool = True) -> np.ndarray:
    r"""Skew-symmetric matrix of a vector: the hat map of eq. (12) of the Serret-Andoyer paper.

    .. math::

        \hat v = \begin{pmatrix} 0 & -v_3 & v_2 \\ v_3 & 0 & -v_1 \\ -v_2 & v_1 & 0 \end{pmatrix},
        \qquad \hat v\, w = v \times w.

    Parameters
    ----------
    v : array_like, shape (..., 3)
    check : bool
        Validate ``v`` (finite, trailing shape 3). Inner loops of integrators whose state is checked
        elsewhere pass ``False``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _hat(c.vector(v, "v", 3) if check else np.asarray(v, dtype=float))


def vee(W: Any) -> np.ndarray:
    r"""Inverse of :func:`hat`: the vector of the skew-symmetric part of ``W``.

    .. math::

        \operatorname{vee}(W) = \tfrac12 (W_{32} - W_{23},\; W_{13} - W_{31},\; W_{21} - W_{12}).

    Parameters
    ----------
    W : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    W = c.matrix(W, "W", 3)
    return _vee(W)


def _vee(W: np.ndarray) -> np.ndarray:
    return 0.5 * np.stack(
        [W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0], W[..., 1, 0] - W[..., 0, 1]], axis=-1
    )


def _exp(v: np.ndarray) -> np.ndarray:
    theta = _norm(v)
    A = c.SINC(theta)[..., None, None]
    B = c.ONE_MINUS_COS_T2(theta)[..., None, None]
    return np.cos(theta)[..., None, None] * np.eye(3) + A * _hat(v) + B * _outer(v)


def exp(v: Any) -> np.ndarray:
    r"""Exponential map so(3) -> SO(3) (Rodrigues' formula).

    .. math::

        \exp(\hat v) = \cos\theta\, I + \frac{\sin\theta}{\theta}\, \hat v
                       + \frac{1 - \cos\theta}{\theta^2}\, v v^T, \qquad \theta = |v|,

    using ``\hat v^2 = v v^T - \theta^2 I``. Near ``theta = 0`` both coefficients come from their
    Taylor series, so the result is exact to round-off and never NaN.

    Parameters
    ----------
    v : array_like, shape (..., 3)
        Rotation vector: axis times angle (radians).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _exp(c.angles(c.vector(v, "v", 3), "v"))


def _log(R: np.ndarray) -> np.ndarray:
    w = _vee(R)  # sin(theta) * axis
    s = _norm(w)
    cos_t = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    # atan2 of (sin, cos) is accurate at every angle, unlike arccos(cos) near 0 and pi.
    theta = np.arctan2(s, cos_t)

    v_generic = c.T_OVER_SIN(theta)[..., None] * w

    # Past pi/2 the axis from the skew part, w / sin(theta), loses accuracy as 1/sin(theta). The symmetric
    # part is (1 - cos) n n^T there with 1 - cos >= 1, so its largest diagonal entry gives n to round-off;
    # the skew part only decides the sign of n (either sign is right at theta = pi exactly).
    S = 0.5 * (R + np.swapaxes(R, -1, -2)) - cos_t[..., None, None] * np.eye(3)
    diag = np.diagonal(S, axis1=-2, axis2=-1)
    k = np.argmax(diag, axis=-1)
    col = np.take_along_axis(S, k[..., None, None], axis=-1)[..., 0]
    dk = np.take_along_axis(diag, k[..., None], axis=-1)[..., 0]
    denom = np.sqrt(np.maximum(dk * (1.0 - cos_t), np.finfo(R.dtype).tiny))
    n = col / denom[..., None]
    sign = np.where(np.einsum("...i,...i->...", n, w) < 0, -1.0, 1.0)
    v_near_pi = (sign * theta)[..., None] * n

    return np.where((cos_t < 0)[..., None], v_near_pi, v_generic)


def log(R: Any) -> np.ndarray:
    r"""Logarithm SO(3) -> so(3): the rotation vector with angle in [0, pi].

    .. math::

        \theta = \operatorname{atan2}(|w|, \tfrac12(\operatorname{tr} R - 1)), \quad
        w = \operatorname{vee}(R), \quad \log R = \frac{\theta}{\sin\theta}\, w
        \;(\theta \le \pi/2).

    For ``theta > pi/2`` the axis ``n`` is read off the symmetric part
    ``(R + R^T)/2 - \cos\theta\, I = (1 - \cos\theta)\, n n^T`` (its largest diagonal element), with the
    sign of ``w``; this stays exact to round-off up to and at ``theta = pi``, where either sign is returned.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (validated: ``R^T R = I`` within 1e-9 and ``det R = +1``).

    Returns
    -------
    ndarray, shape (..., 3)
    """
    return _log(c.rotation(R, "R"))


def inverse(R: Any) -> np.ndarray:
    """Inverse rotation, ``R^{-1} = R^T``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return np.swapaxes(c.rotation(R, "R"), -1, -2).copy()


def compose(A: Any, B: Any) -> np.ndarray:
    """Group product ``A B`` (apply ``B`` first), batch axes broadcast.

    Parameters
    ----------
    A, B : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return c.rotation(A, "A") @ c.rotation(B, "B")


def act(R: Any, x: Any) -> np.ndarray:
    """Action on points, ``R x``, batch axes broadcast.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
    x : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    return np.einsum("...ij,...j->...i", c.rotation(R, "R"), c.vector(x, "x", 3))


def Ad(R: Any) -> np.ndarray:
    r"""Matrix of the adjoint action on so(3) ~ R^3, which for SO(3) is ``R`` itself.

    .. math::

        \widehat{\mathrm{Ad}_R v} = R\, \hat v\, R^T, \qquad \mathrm{Ad}_R = R.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return c.rotation(R, "R").copy()


def ad(v: Any) -> np.ndarray:
    """Matrix of the adjoint action of the algebra, ``ad_v w = [v, w] = v x w``, i.e. ``hat(v)``.

    Parameters
    ----------
    v : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return hat(v)


def coad(R: Any, mu: Any) -> np.ndarray:
    r"""Coadjoint action ``Ad*_{R^{-1}} mu`` on so(3)* ~ R^3.

    Computed from its definition by the pairing,

    .. math::

        \langle \mathrm{Ad}^*_{R^{-1}} \mu, \xi \rangle = \langle \mu, \mathrm{Ad}_{R^{-1}} \xi \rangle
        \;\Longrightarrow\; \mathrm{Ad}^*_{R^{-1}} \mu = \mathrm{Ad}_{R^{-1}}^T \mu,

    which for SO(3) is ``R mu`` (Lemma 3 of the Serret-Andoyer paper): body momentum to spatial momentum.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
    mu : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    AdInv = Ad(inverse(R))
    return np.einsum("...ji,...j->...i", AdInv, c.vector(mu, "mu", 3))


def identity(batch_shape: Any = ()) -> np.ndarray:
    """Identity rotations of shape ``(*batch_shape, 3, 3)``."""
    return c.eye(3, batch_shape)


def random(rng: Any = None, size: Any = ()) -> np.ndarray:
    """Rotations drawn from the Haar (uniform) measure on SO(3).

    Drawn as normalised isotropic Gaussian quaternions, which are uniform on S^3 and hence Haar on SO(3).

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
        Generator, or a seed for :func:`numpy.random.default_rng`.
    size : int or tuple of int
        Batch shape; ``()`` gives a single ``(3, 3)`` matrix.

    Returns
    -------
    ndarray, shape ``(*size, 3, 3)``
    """
    return c.quat_to_matrix(c.random_unit_quaternions(c.generator(rng), size))


def _left_jacobian(v: np.ndarray) -> np.ndarray:
    theta = _norm(v)
    A = c.SINC(theta)[..., None, None]
    B = c.ONE_MINUS_COS_T2(theta)[..., None, None]
    C = c.T_MINUS_SIN_T3(theta)[..., None, None]
    return A * np.eye(3) + B * _hat(v) + C * _outer(v)


def _left_jacobian_inverse(v: np.ndarray) -> np.ndarray:
    theta = _norm(v)
    alpha = c.HALF_COT_HALF(theta)[..., None, None]
    D = c.JINV_D(theta)[..., None, None]
    return alpha * np.eye(3) - 0.5 * _hat(v) + D * _outer(v)


def left_jacobian(v: Any) -> np.ndarray:
    r"""Left Jacobian of SO(3), ``exp(v + d) ~ exp(J_l(v) d) exp(v)``.

    .. math::

        J_l(v) = \sum_{k \ge 0} \frac{\hat v^k}{(k+1)!}
               = \frac{\sin\theta}{\theta} I + \frac{1 - \cos\theta}{\theta^2} \hat v
                 + \frac{\theta - \sin\theta}{\theta^3} v v^T,

    Barfoot (2017), eq. (7.37), rewritten with ``\hat v^2 = v v^T - \theta^2 I``; Taylor branches near 0.

    Parameters
    ----------
    v : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian(c.vector(v, "v", 3))


def right_jacobian(v: Any) -> np.ndarray:
    """Right Jacobian of SO(3), ``exp(v + d) ~ exp(v) exp(J_r(v) d)``; ``J_r(v) = J_l(-v) = J_l(v)^T``.

    Parameters
    ----------
    v : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian(-c.vector(v, "v", 3))


def left_jacobian_inverse(v: Any) -> np.ndarray:
    r"""Inverse of :func:`left_jacobian`.

    .. math::

        J_l^{-1}(v) = \frac{\theta}{2}\cot\frac{\theta}{2}\, I - \tfrac12 \hat v
                    + \frac{1 - \frac{\theta}{2}\cot\frac{\theta}{2}}{\theta^2}\, v v^T,

    Barfoot (2017), eq. (7.38); singular at ``theta = 2 pi k``, ``k != 0``. Taylor branches near 0.

    Parameters
    ----------
    v : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian_inverse(c.vector(v, "v", 3))


def right_jacobian_inverse(v: Any) -> np.ndarray:
    """Inverse of :func:`right_jacobian`, ``J_r^{-1}(v) = J_l^{-1}(-v)``.

    Parameters
    ----------
    v : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _left_jacobian_inverse(-c.vector(v, "v", 3))


def project(A: Any) -> np.ndarray:
    r"""Nearest rotation in the Frobenius norm (orthogonal Procrustes), by SVD.

    .. math::

        A = U \Sigma V^T \;\Longrightarrow\;
        \operatorname{project}(A) = U \operatorname{diag}(1, 1, \det(U V^T))\, V^T.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Any finite matrices, e.g. rotations that drifted off SO(3).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    A = c.matrix(A, "A", 3)
    U, _, Vt = np.linalg.svd(A)
    d = np.sign(np.linalg.det(U @ Vt))
    # A rank-deficient A can give det = 0 to round-off; either sign is a nearest rotation then.
    d = np.where(d == 0, 1.0, d)
    U = U.copy()
    U[..., :, 2] *= d[..., None]
    return U @ Vt


def _elementary(a: Any, axis: int, name: str) -> np.ndarray:
    a = finite(a, name)
    ca, sa = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = ca
    out[..., j, j] = ca
    out[..., i, j] = -sa
    out[..., j, i] = sa
    return out


def rot_x(a: Any) -> np.ndarray:
    r"""Rotation by angle ``a`` about the x axis, ``exp(a hat(e_1))``.

    .. math::

        R_x(a) = \begin{pmatrix} 1 & 0 & 0 \\ 0 & \cos a & -\sin a \\ 0 & \sin a & \cos a \end{pmatrix}

    Parameters
    ----------
    a : array_like, shape (...)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _elementary(a, 0, "a")


def rot_y(a: Any) -> np.ndarray:
    r"""Rotation by angle ``a`` about the y axis, ``exp(a hat(e_2))``.

    .. math::

        R_y(a) = \begin{pmatrix} \cos a & 0 & \sin a \\ 0 & 1 & 0 \\ -\sin a & 0 & \cos a \end{pmatrix}

    Parameters
    ----------
    a : array_like, shape (...)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _elementary(a, 1, "a")


def rot_z(a: Any) -> np.ndarray:
    r"""Rotation by angle ``a`` about the z axis, ``exp(a hat(e_3))``.

    .. math::

        R_z(a) = \begin{pmatrix} \cos a & -\sin a & 0 \\ \sin a & \cos a & 0 \\ 0 & 0 & 1 \end{pmatrix}

    Parameters
    ----------
    a : array_like, shape (...)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _elementary(a, 2, "a")
