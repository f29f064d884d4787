r"""Unit quaternions as ``(..., 4)`` arrays representing rotations.

Conventions: Hamilton product (``i j = k``), active rotations, and the rotation of a unit quaternion
``q = (w, x, y, z) = (\cos\frac\theta2, \sin\frac\theta2\, n)`` is the matrix ``R`` with ``x = R X``
(the same ``R`` as :func:`geomech.lie.so3.exp` of ``theta n``). Component order is chosen by the keyword
``scalar_first``, named as in :mod:`scipy.spatial.transform`; its default here is ``True``, i.e.
``(w, x, y, z)`` (scipy's default is ``False``, ``(x, y, z, w)``). ``q`` and ``-q`` are the same rotation
(the double cover); functions returning a quaternion of a rotation pick the one with ``w >= 0``.

The products compose like matrices, ``as_matrix(multiply(q, r)) = as_matrix(q) @ as_matrix(r)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from . import _common as c

__all__ = [
    "from_matrix",
    "as_matrix",
    "multiply",
    "conjugate",
    "inverse",
    "normalize",
    "from_rotvec",
    "as_rotvec",
    "exp",
    "log",
    "identity",
    "random",
]

UNIT_ATOL = 1e-8
"""Default tolerance on ``| |q| - 1 |`` where a unit quaternion is required."""


def _to_wxyz(q: np.ndarray, scalar_first: bool) -> np.ndarray:
    return q if scalar_first else np.roll(q, 1, axis=-1)


def _from_wxyz(q: np.ndarray, scalar_first: bool) -> np.ndarray:
    return q if scalar_first else np.roll(q, -1, axis=-1)


def _quat(q: Any, name: str, scalar_first: bool) -> np.ndarray:
    return _to_wxyz(c.vector(q, name, 4), bool(scalar_first))


def _check_unit(q: np.ndarray, name: str, atol: float) -> None:
    norm = np.linalg.norm(q, axis=-1)
    off = np.abs(norm - 1.0)
    bad = off > atol
    if np.any(bad):
        if off.ndim == 0:
            got = f"got norm {float(norm):.12g}"
        else:
            worst = np.unravel_index(np.argmax(off), off.shape)
            got = (
                f"got {int(bad.sum())} of {bad.size} with another norm, the worst norm "
                f"{float(norm[worst]):.12g} at batch index {tuple(int(i) for i in worst)}"
            )
        raise InputError(
            f"Expected `{name}` to be a unit quaternion (| |q| - 1 | <= {atol:g}), {got}. Normalise it with "
            f"geomech.lie.quaternion.normalize if it only drifted."
        )


def _canonical(q: np.ndarray) -> np.ndarray:
    """Pick the sign with w > 0, or, when w = 0, the first non-zero of x, y, z positive (as scipy)."""
    lead = q[..., 0]
    for k in (1, 2, 3):
        lead = np.where(lead == 0, q[..., k], lead)
    return np.where((lead < 0)[..., None], -q, q)


def _multiply(q: np.ndarray, r: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = np.moveaxis(q, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(r, -1, 0)
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )


def _from_matrix(R: np.ndarray) -> np.ndarray:
    """Shepperd's method on validated rotations, returning ``(w, x, y, z)`` with ``w >= 0``."""
    tr = np.trace(R, axis1=-2, axis2=-1)
    d0, d1, d2 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    # 4 w^2, 4 x^2, 4 y^2, 4 z^2 up to the factor; the largest is >= 1, so its square root is well
    # conditioned and the other components follow by division without loss of accuracy.
    cand = np.stack([1.0 + tr, 1.0 + 2.0 * d0 - tr, 1.0 + 2.0 * d1 - tr, 1.0 + 2.0 * d2 - tr], axis=-1)
    k = np.argmax(cand, axis=-1)
    s21 = R[..., 2, 1] - R[..., 1, 2]
    s02 = R[..., 0, 2] - R[..., 2, 0]
    s10 = R[..., 1, 0] - R[..., 0, 1]
    a01 = R[..., 0, 1] + R[..., 1, 0]
    a02 = R[..., 0, 2] + R[..., 2, 0]
    a12 = R[..., 1, 2] + R[..., 2, 1]
    rows = [
        np.stack([cand[..., 0], s21, s02, s10], -1),
        np.stack([s21, cand[..., 1], a01, a02], -1),
        np.stack([s02, a01, cand[..., 2], a12], -1),
        np.stack([s10, a02, a12, cand[..., 3]], -1),
    ]
    all_q = np.stack(rows, axis=-2)  # row k is 4 q_k q
    q = np.take_along_axis(all_q, k[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return _canonical(q)


def from_matrix(R: Any, *, scalar_first: bool = True) -> np.ndarray:
    r"""Unit quaternion of a rotation matrix, by Shepperd's method, with non-negative scalar part.

    Of the four expressions

    .. math::

        4w^2 = 1 + \operatorname{tr}R, \quad 4x^2 = 1 + 2R_{11} - \operatorname{tr}R, \quad
        4y^2 = 1 + 2R_{22} - \operatorname{tr}R, \quad 4z^2 = 1 + 2R_{33} - \operatorname{tr}R

    the largest (at least 1) gives one component, and the others come from the off-diagonal sums and
    differences (Shepperd, J. Guid. Control 1(3), 1978), which is accurate for every rotation. The sign is
    then chosen so that ``w >= 0`` (``w = 0``: the first non-zero of ``x, y, z`` is positive).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (validated).
    scalar_first : bool
        Return ``(w, x, y, z)`` if True (default), ``(x, y, z, w)`` otherwise.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    return _from_wxyz(_from_matrix(c.rotation(R, "R")), scalar_first)


def as_matrix(q: Any, *, scalar_first: bool = True, atol: float = UNIT_ATOL) -> np.ndarray:
    r"""Rotation matrix of a unit quaternion.

    .. math::

        R = \begin{pmatrix}
        1 - 2(y^2 + z^2) & 2(xy - zw) & 2(xz + yw) \\
        2(xy + zw) & 1 - 2(x^2 + z^2) & 2(yz - xw) \\
        2(xz - yw) & 2(yz + xw) & 1 - 2(x^2 + y^2)
        \end{pmatrix}

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions; raises :class:`~geomech.errors.InputError` naming the norm if
        ``| |q| - 1 | > atol`` (it does not normalise silently).
    scalar_first : bool
    atol : float

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    q = _quat(q, "q", scalar_first)
    _check_unit(q, "q", atol)
    return c.quat_to_matrix(q)


def multiply(q: Any, r: Any, *, scalar_first: bool = True) -> np.ndarray:
    r"""Hamilton product ``q r``, batch axes broadcast.

    .. math::

        (w_1, u_1)(w_2, u_2) = (w_1 w_2 - u_1 \cdot u_2,\; w_1 u_2 + w_2 u_1 + u_1 \times u_2),

    so that ``as_matrix(multiply(q, r)) = as_matrix(q) @ as_matrix(r)``.

    Parameters
    ----------
    q, r : array_like, shape (..., 4)
    scalar_first : bool

    Returns
    -------
    ndarray, shape (..., 4)
    """
    sf = bool(scalar_first)
    return _from_wxyz(_multiply(_quat(q, "q", sf), _quat(r, "r", sf)), sf)


def conjugate(q: Any, *, scalar_first: bool = True) -> np.ndarray:
    """Conjugate ``(w, -x, -y, -z)``; the inverse rotation for a unit quaternion.

    Parameters
    ----------
    q : array_like, shape (..., 4)
    scalar_first : bool

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q = _quat(q, "q", scalar_first)
    return _from_wxyz(q * np.array([1.0, -1.0, -1.0, -1.0]), scalar_first)


def _norm_checked(q: np.ndarray, name: str) -> np.ndarray:
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n == 0):
        raise InputError(f"Expected `{name}` to be non-zero, got a zero quaternion{c._where(n[..., 0] == 0)}.")
    return n


def inverse(q: Any, *, scalar_first: bool = True) -> np.ndarray:
    r"""Multiplicative inverse ``q^{-1} = \bar q / |q|^2`` of non-zero quaternions.

    Parameters
    ----------
    q : array_like, shape (..., 4)
    scalar_first : bool

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q = _quat(q, "q", scalar_first)
    n = _norm_checked(q, "q")
    return _from_wxyz(q * np.array([1.0, -1.0, -1.0, -1.0]) / n**2, scalar_first)


def normalize(q: Any) -> np.ndarray:
    """``q / |q|`` for non-zero quaternions (any component order).

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q = c.vector(q, "q", 4)
    return q / _norm_checked(q, "q")


def _from_rotvec(v: np.ndarray) -> np.ndarray:
    theta = np.sqrt(np.einsum("...i,...i->...", v, v))
    # sin(theta/2)/theta = (1/2) sinc(theta/2), exact to round-off near 0 through the series branch.
    s = 0.5 * c.SINC(0.5 * theta)
    return np.concatenate([np.cos(0.5 * theta)[..., None], s[..., None] * v], axis=-1)


def _as_rotvec(q: np.ndarray) -> np.ndarray:
    q = _canonical(q)
    u = q[..., 1:]
    s = np.sqrt(np.einsum("...i,...i->...", u, u))
    # Half angle by atan2 in [0, pi/2] (w >= 0): accurate at every angle, unlike 2 arccos(w) near 0.
    half = np.arctan2(s, q[..., 0])
    # theta / sin(theta/2) = 2 * half / sin(half): the series branch covers half -> 0.
    return (2.0 * c.T_OVER_SIN(half))[..., None] * u


def from_rotvec(v: Any, *, scalar_first: bool = True) -> np.ndarray:
    r"""Unit quaternion of a rotation vector ``v = theta n``.

    .. math::

        q = \Big(\cos\frac\theta2,\; \frac{\sin(\theta/2)}{\theta}\, v\Big), \qquad \theta = |v|,

    so that ``as_matrix(from_rotvec(v)) = so3.exp(v)``. The sign is not canonicalised: for
    ``theta > pi`` the scalar part is negative, and ``from_rotvec`` is continuous in ``v``.

    Parameters
    ----------
    v : array_like, shape (..., 3)
    scalar_first : bool

    Returns
    -------
    ndarray, shape (..., 4)
    """
    return _from_wxyz(_from_rotvec(c.angles(c.vector(v, "v", 3), "v")), scalar_first)


def as_rotvec(q: Any, *, scalar_first: bool = True, atol: float = UNIT_ATOL) -> np.ndarray:
    r"""Rotation vector of a unit quaternion, angle in [0, pi].

    .. math::

        \theta = 2\operatorname{atan2}(|u|, w), \qquad v = \frac{\theta}{\sin(\theta/2)}\, u,

    after choosing the sign with ``w >= 0``; equal to ``so3.log(as_matrix(q))``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions (validated as in :func:`as_matrix`).
    scalar_first : bool
    atol : float

    Returns
    -------
    ndarray, shape (..., 3)
    """
    q = _quat(q, "q", scalar_first)
    _check_unit(q, "q", atol)
    return _as_rotvec(q)


def exp(v: Any, *, scalar_first: bool = True) -> np.ndarray:
    r"""Exponential so(3) -> unit quaternions, consistent with :func:`geomech.lie.so3.exp`.

    .. math::

        \exp(v) = e^{(0,\, v/2)} = \Big(\cos\frac{|v|}{2},\; \sin\frac{|v|}{2}\,\frac{v}{|v|}\Big),

    the quaternion exponential of the pure quaternion ``v/2``, so ``as_matrix(exp(v)) = so3.exp(v)``.
    Same as :func:`from_rotvec`.

    Parameters
    ----------
    v : array_like, shape (..., 3)
    scalar_first : bool

    Returns
    -------
    ndarray, shape (..., 4)
    """
    return from_rotvec(v, scalar_first=scalar_first)


def log(q: Any, *, scalar_first: bool = True, atol: float = UNIT_ATOL) -> np.ndarray:
    """Logarithm of unit quaternions into so(3) ~ R^3, consistent with :func:`geomech.lie.so3.log`.

    Twice the vector part of the quaternion logarithm of the representative with ``w >= 0``, so that
    ``log(q) = so3.log(as_matrix(q))`` with angle in [0, pi]. Same as :func:`as_rotvec`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
    scalar_first : bool
    atol : float

    Returns
    -------
    ndarray, shape (..., 3)
    """
    return as_rotvec(q, scalar_first=scalar_first, atol=atol)


def identity(batch_shape: Any = (), *, scalar_first: bool = True) -> np.ndarray:
    """Identity quaternions of shape ``(*batch_shape, 4)``."""
    out = np.zeros(c.batch_shape_of(batch_shape) + (4,))
    out[..., 0] = 1.0
    return _from_wxyz(out, scalar_first)


def random(rng: Any = None, size: Any = (), *, scalar_first: bool = True) -> np.ndarray:
    """Haar-uniform random rotations as unit quaternions (uniform on S^3), not canonicalised.

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
    size : int or tuple of int
        Batch shape.
    scalar_first : bool

    Returns
    -------
    ndarray, shape ``(*size, 4)``
    """
    return _from_wxyz(c.random_unit_quaternions(c.generator(rng), size), scalar_first)
