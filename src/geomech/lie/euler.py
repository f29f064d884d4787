r"""Euler angles of all twelve axis sequences, intrinsic and extrinsic, as ``(..., 3)`` arrays.

Conventions (those of :class:`scipy.spatial.transform.Rotation`): ``seq`` is three letters from x, y, z
with no two consecutive letters equal. UPPERCASE is intrinsic (each rotation about an axis of the frame
moved by the previous ones), lowercase is extrinsic (every rotation about a fixed axis):

.. math::

    \texttt{"IJK"}:\; R = R_I(a)\, R_J(b)\, R_K(c), \qquad
    \texttt{"ijk"}:\; R = R_k(c)\, R_j(b)\, R_i(a),

with ``R_x, R_y, R_z`` the elementary rotations of :mod:`geomech.lie.so3` and ``(a, b, c)`` the angles in
the order of the letters. ``R`` maps body to space coordinates, ``x = R X``. The default ``"ZXZ"`` is the
3-1-3 sequence of eq. (1) of the Serret-Andoyer paper, ``R = R_z(phi) R_x(theta) R_z(psi)``.

Ranges returned by :func:`from_matrix`: first and third angles in (-pi, pi]; middle angle in [0, pi] for
the proper (symmetric) sequences such as ZXZ, and in [-pi/2, pi/2] for the Tait-Bryan sequences such as
ZYX. At the gimbal singularity (middle angle 0 or pi, respectively +-pi/2) only the sum or the difference
of the first and third angles is determined; :func:`from_matrix` detects it and raises or resolves as
asked, and :func:`gimbal_margin` measures the distance to it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import trailing_shape
from ..errors import InputError, SingularityError
from . import _common as c
from . import so3
from .quaternion import _from_matrix as _quat_from_matrix

__all__ = [
    "INTRINSIC_SEQUENCES",
    "EXTRINSIC_SEQUENCES",
    "angular_velocity",
    "as_matrix",
    "euler_rates",
    "from_matrix",
    "gimbal_margin",
    "gimbal_margin_angles",
    "is_proper",
]

INTRINSIC_SEQUENCES = ("XYX", "XYZ", "XZX", "XZY", "YXY", "YXZ", "YZX", "YZY", "ZXY", "ZXZ", "ZYX", "ZYZ")
"""The 12 intrinsic sequences (6 proper Euler, 6 Tait-Bryan)."""
EXTRINSIC_SEQUENCES = tuple(s.lower() for s in INTRINSIC_SEQUENCES)
"""The 12 extrinsic sequences."""

_AXIS = {"x": 0, "y": 1, "z": 2}
_ELEMENTARY = (so3.rot_x, so3.rot_y, so3.rot_z)


def _parse(seq: Any) -> tuple[tuple[int, int, int], bool]:
    """Return the axis indices and whether ``seq`` is intrinsic."""
    if isinstance(seq, str) and (seq in INTRINSIC_SEQUENCES or seq in EXTRINSIC_SEQUENCES):
        return tuple(_AXIS[ch] for ch in seq.lower()), seq.isupper()  # type: ignore[return-value]
    raise InputError(
        f"Expected `seq` to be one of the 12 intrinsic sequences (UPPERCASE, rotations about the moving "
        f"axes) {', '.join(INTRINSIC_SEQUENCES)} or one of the 12 extrinsic sequences (lowercase, fixed "
        f"axes) {', '.join(EXTRINSIC_SEQUENCES)}; got {seq!r}."
    )


def is_proper(seq: str) -> bool:
    """True for the proper (symmetric, first axis = third axis) sequences such as ZXZ, False for Tait-Bryan."""
    axes, _ = _parse(seq)
    return axes[0] == axes[2]


def as_matrix(angles: Any, seq: str = "ZXZ") -> np.ndarray:
    r"""Rotation matrices of Euler angles.

    .. math::

        \texttt{"IJK"}:\; R = R_I(a)\, R_J(b)\, R_K(c), \qquad
        \texttt{"ijk"}:\; R = R_k(c)\, R_j(b)\, R_i(a).

    For ``"ZXZ"`` this is eq. (1) of the Serret-Andoyer paper with ``(a, b, c) = (phi, theta, psi)``.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Angles in radians, in the order of the letters of ``seq``; any real values.
    seq : str
        One of the 12 intrinsic (UPPERCASE) or 12 extrinsic (lowercase) sequences.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    (i, j, k), intrinsic = _parse(seq)
    angles = trailing_shape(angles, "angles", (3,))
    Ra = _ELEMENTARY[i](angles[..., 0])
    Rb = _ELEMENTARY[j](angles[..., 1])
    Rc = _ELEMENTARY[k](angles[..., 2])
    return Ra @ Rb @ Rc if intrinsic else Rc @ Rb @ Ra


def _levi_civita(i: int, j: int, k: int) -> float:
    return float((i - j) * (j - k) * (k - i) / 2)


def _pairs(
    q: np.ndarray, axes: tuple[int, int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, float]:
    r"""Half-angle pairs of the intrinsic sequence ``R = R_i(a) R_j(b) R_k(c)`` from ``q = (w, x, y, z)``.

    Returns ``(p0, p1, r0, r1, kappa, offset)`` with, for ``B = b + offset``,
    ``(p0, p1) = rho cos(B/2) (cos phi_c, sin phi_c)`` and ``(r0, r1) = rho sin(B/2) (cos phi_s, sin phi_s)``
    (``rho > 0``), ``a = phi_c + phi_s`` and ``c = kappa (phi_c - phi_s)``. Derived by multiplying out
    ``q_i(a) q_j(b) q_k(c)``; the same construction as Bernardes and Viollet, PLoS ONE 17(11) e0276302
    (2022), which scipy also uses.
    """
    i, j, k = axes
    w = q[..., 0]
    qi, qj = q[..., 1 + i], q[..., 1 + j]
    if i == k:
        l = 3 - i - j
        eps = _levi_civita(i, j, l)
        # q = (cos(b/2) cos(s/2), cos(b/2) sin(s/2) e_i + sin(b/2) cos(d/2) e_j + eps sin(b/2) sin(d/2) e_l)
        # with s = a + c, d = a - c.
        return w, qi, qj, eps * q[..., 1 + l], 1.0, 0.0
    eps = _levi_civita(i, j, k)
    qk = q[..., 1 + k]
    # With c' = eps c and B = b + pi/2: w - q_j, q_i - eps q_k carry sqrt2 cos(B/2) (cos, sin)((a - c')/2),
    # and w + q_j, q_i + eps q_k carry sqrt2 sin(B/2) (cos, sin)((a + c')/2).
    return w - qj, qi - eps * qk, w + qj, qi + eps * qk, -eps, np.pi / 2


def _solve_intrinsic(q: np.ndarray, axes: tuple[int, int, int], tol: float, zero_last: bool):
    """Angles of ``R = R_i(a) R_j(b) R_k(c)``; at the singularity ``c = 0`` (or ``a = 0``)."""
    p0, p1, r0, r1, kappa, offset = _pairs(q, axes)
    cos_part = np.hypot(p0, p1)
    sin_part = np.hypot(r0, r1)
    # B in [0, pi] from both half-angle magnitudes: accurate at, near and away from both ends, unlike
    # arccos or arcsin of a single matrix entry.
    B = 2.0 * np.arctan2(sin_part, cos_part)
    phi_c = np.arctan2(p1, p0)
    phi_s = np.arctan2(r1, r0)
    # Away from the singularity a and c come from the two half-angle pairs, each well conditioned where
    # it is needed: the reconstructed matrix is exact to round-off even at a margin of 1e-12.
    a = phi_c + phi_s
    cc = kappa * (phi_c - phi_s)
    margin = np.minimum(B, np.pi - B)
    singular = margin <= tol
    # At B = 0 only phi_c is defined (phi_s is atan2 of round-off); at B = pi only phi_s.
    determined = np.where(B < 0.5 * np.pi, phi_c, phi_s)
    sign_c = np.where(B < 0.5 * np.pi, kappa, -kappa)
    if zero_last:
        a = np.where(singular, 2.0 * determined, a)
        cc = np.where(singular, 0.0, cc)
    else:
        a = np.where(singular, 0.0, a)
        cc = np.where(singular, 2.0 * sign_c * determined, cc)
    angles = np.stack([c.wrap_angle(a), B - offset, c.wrap_angle(cc)], axis=-1)
    return angles, margin, singular


def _tolerance(tol: Any) -> float:
    try:
        value = float(tol)
    except (TypeError, ValueError):
        value = float("nan")
    if not (np.isfinite(value) and value >= 0):
        raise InputError(f"Expected `tol` to be a finite number >= 0, got {tol!r}.")
    return value


def _default_tol() -> float:
    return float(np.sqrt(np.finfo(float).eps))


def from_matrix(R: Any, seq: str = "ZXZ", *, on_singular: str = "raise", tol: float | None = None) -> np.ndarray:
    r"""Euler angles of rotation matrices, with the gimbal singularity detected and reported.

    The matrix is converted to a unit quaternion (Shepperd's method) and the angles are read off two
    half-angle pairs (Bernardes and Viollet, PLoS ONE 17(11) e0276302, 2022). For the intrinsic proper
    sequence ``R = R_i(a) R_j(b) R_i(c)`` with third axis ``l`` and ``eps = eps_{ijl}``:

    .. math::

        q = \big(\cos\tfrac b2 \cos\tfrac{a+c}2,\; \cos\tfrac b2 \sin\tfrac{a+c}2\, e_i
              + \sin\tfrac b2 \cos\tfrac{a-c}2\, e_j + \epsilon \sin\tfrac b2 \sin\tfrac{a-c}2\, e_l\big),

    so ``b = 2 atan2(|(q_j, eps q_l)|, |(w, q_i)|)`` and ``(a +- c)/2`` are two ``atan2``; Tait-Bryan
    sequences use the analogous pairs ``(w -+ q_j, q_i -+ eps q_k)``; extrinsic sequences are the reversed
    intrinsic ones. Every angle comes from an ``atan2`` of well-conditioned entries, so the result stays
    accurate near (not at) the singularity: ``as_matrix(from_matrix(R))`` reproduces ``R`` to round-off.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (validated).
    seq : str
        One of the 12 intrinsic (UPPERCASE) or 12 extrinsic (lowercase) sequences; default ``"ZXZ"``.
    on_singular : {"raise", "resolve"}
        What to do where the gimbal margin (:func:`gimbal_margin`) is ``<= tol``. ``"raise"``: raise
        :class:`~geomech.errors.SingularityError` naming the entries. ``"resolve"``: set the third angle
        to 0 and put the whole rotation about the degenerate axis into the first angle; at the
        singularity ``as_matrix`` of the result reproduces ``R`` to round-off, and within the band
        ``0 < margin <= tol`` to about ``tol``.
    tol : float, optional
        Width of the singular band in radians. Default ``sqrt(eps) ~ 1.5e-8``: at a margin ``delta`` the
        first and third angles individually carry an error ``~ eps / delta`` while resolving costs
        ``~ delta``; ``sqrt(eps)`` balances the two.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(a, b, c)`` in the order of the letters of ``seq``; ``a, c`` in (-pi, pi]; ``b`` in [0, pi]
        (proper) or [-pi/2, pi/2] (Tait-Bryan).

    Raises
    ------
    SingularityError
        With ``on_singular="raise"``, where some rotation is within ``tol`` of gimbal lock.
    """
    axes, intrinsic = _parse(seq)
    if on_singular not in ("raise", "resolve"):
        raise InputError(f"Expected `on_singular` to be 'raise' or 'resolve', got {on_singular!r}.")
    tol = _default_tol() if tol is None else _tolerance(tol)
    q = _quat_from_matrix(c.rotation(R, "R"))
    if intrinsic:
        angles, margin, singular = _solve_intrinsic(q, axes, float(tol), zero_last=True)
    else:
        # "ijk" with (a, b, c) is R_k(c) R_j(b) R_i(a), the intrinsic "KJI" with (c, b, a); the extrinsic
        # third angle is the intrinsic first, so that is the one set to zero.
        rev, margin, singular = _solve_intrinsic(q, axes[::-1], float(tol), zero_last=False)
        angles = rev[..., ::-1]
    if on_singular == "raise" and np.any(singular):
        raise SingularityError(_singular_message(seq, angles, margin, singular, float(tol)))
    return angles


def _singular_message(seq: str, angles: np.ndarray, margin: np.ndarray, singular: np.ndarray, tol: float) -> str:
    proper = is_proper(seq)
    where = "0 or pi" if proper else "+-pi/2"
    middle = angles[..., 1]
    if singular.ndim == 0:
        which = f"the rotation is at gimbal lock (middle angle {float(middle):.17g})"
    else:
        idx = np.argwhere(singular)
        shown = ", ".join(
            f"{tuple(int(i) for i in row)} (middle angle {float(middle[tuple(row)]):.17g})" for row in idx[:5]
        )
        more = f" and {len(idx) - 5} more" if len(idx) > 5 else ""
        which = f"{len(idx)} of {singular.size} rotations are at gimbal lock, at batch index {shown}{more}"
    return (
        f"Euler angles of sequence {seq!r} are singular where the middle angle is {where}: {which}, within "
        f"tol={tol:.3g} rad (smallest margin {float(np.min(margin)):.3g} rad). There only a combination of the "
        f"first and third angles is determined. Pass on_singular='resolve' to set the third angle to 0 and "
        f"put the whole rotation about the degenerate axis into the first, or use quaternions "
        f"(geomech.lie.quaternion.from_matrix), which have no singularity."
    )


def gimbal_margin(R: Any, seq: str = "ZXZ") -> np.ndarray:
    r"""Distance in radians of rotations to the gimbal singularity of ``seq``.

    .. math::

        \text{proper: } \min(b, \pi - b), \qquad \text{Tait-Bryan: } \pi/2 - |b|,

    with ``b`` the middle angle, computed as in :func:`from_matrix` (accurate at small margins). It is
    0 at gimbal lock; :func:`from_matrix` treats margins ``<= tol`` as singular.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (validated).
    seq : str

    Returns
    -------
    ndarray, shape (...)
    """
    axes, intrinsic = _parse(seq)
    q = _quat_from_matrix(c.rotation(R, "R"))
    _, margin, _ = _solve_intrinsic(q, axes if intrinsic else axes[::-1], 0.0, zero_last=True)
    return margin


def gimbal_margin_angles(angles: Any, seq: str = "ZXZ") -> np.ndarray:
    r"""Distance in radians of Euler angles to the gimbal singularity of ``seq``.

    .. math::

        \text{proper: } \operatorname{atan2}(|\sin b|, |\cos b|), \qquad
        \text{Tait-Bryan: } \operatorname{atan2}(|\cos b|, |\sin b|),

    for any real middle angle ``b`` (the distance to the nearest ``k pi``, respectively ``pi/2 + k pi``).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
    seq : str

    Returns
    -------
    ndarray, shape (...)
    """
    proper = is_proper(seq)
    b = trailing_shape(angles, "angles", (3,))[..., 1]
    sb, cb = np.abs(np.sin(b)), np.abs(np.cos(b))
    return np.arctan2(sb, cb) if proper else np.arctan2(cb, sb)


def angular_velocity(angles: Any, rates: Any, seq: str = "ZXZ", *, frame: str = "space") -> np.ndarray:
    r"""The angular velocity of a rotation given by Euler angles and their rates.

    With :math:`R` of :func:`as_matrix`, the spatial angular velocity is :math:`\hat\omega = \dot R R^T` and
    the body one :math:`\hat\Omega = R^T\dot R = R^T \hat\omega R`. For an intrinsic ``"IJK"`` (angles
    :math:`a, b, c`), :math:`\omega = \dot a\, e_I + \dot b\, R_I(a) e_J + \dot c\, R_I(a) R_J(b) e_K`; for an
    extrinsic ``"ijk"``, :math:`\omega = \dot c\, e_k + \dot b\, R_k(c) e_j + \dot a\, R_k(c) R_j(b) e_i`.
    For ``"ZXZ"`` and ``(phi, theta, psi)`` the body one is eq. (2) of the Serret-Andoyer paper, and the
    spatial one its eq. (3) with its second component corrected (docs/conventions.md):
    :math:`\omega = (\dot\theta\cos\phi + \dot\psi\sin\phi\sin\theta,\;
    \dot\theta\sin\phi - \dot\psi\cos\phi\sin\theta,\; \dot\phi + \dot\psi\cos\theta)`.

    Parameters
    ----------
    angles, rates : array_like, shape (..., 3)
        The angles and their time derivatives, in the order of the letters of ``seq``; broadcast together.
    seq : str
        One of the 24 sequences of :func:`as_matrix`.
    frame : ``"space"`` or ``"body"``
        The frame of the components of the result.

    Returns
    -------
    ndarray, shape (..., 3)
    """
    E = _rate_matrix(angles, seq, frame)
    rates = trailing_shape(rates, "rates", (3,))
    return np.einsum("...ij,...j->...i", E, rates)


def euler_rates(angles: Any, omega: Any, seq: str = "ZXZ", *, frame: str = "space") -> np.ndarray:
    """The rates of Euler angles that give the angular velocity ``omega`` (inverse of :func:`angular_velocity`).

    Raises
    ------
    SingularityError
        At the gimbal singularity of ``seq`` (the middle angle 0 or pi for a proper sequence, +-pi/2 for a
        Tait-Bryan one), where the rates are not determined; the message names where.
    """
    E = _rate_matrix(angles, seq, frame)
    omega = trailing_shape(omega, "omega", (3,))
    det = np.linalg.det(E)
    bad = ~(np.abs(det) > 1e-12)
    if np.any(bad):
        where = np.argwhere(np.atleast_1d(bad))[0].tolist()
        smallest = float(np.min(np.abs(det)))
        raise SingularityError(
            f"The Euler angles ({seq}) are at their gimbal singularity (rate matrix determinant {smallest:.2e} at "
            f"batch index {where}): the rates are not determined there; use a rotation matrix or quaternion, or "
            "another sequence."
        )
    return np.linalg.solve(E, np.broadcast_to(omega, E.shape[:-1])[..., None])[..., 0]


def _rate_matrix(angles: Any, seq: str, frame: str) -> np.ndarray:
    """The matrix E(angles) with omega = E (a', b', c'), in the frame asked, shape (..., 3, 3)."""
    if frame not in ("space", "body"):
        raise InputError(f"Expected `frame` to be 'space' or 'body', got {frame!r}.")
    (i, j, k), intrinsic = _parse(seq)
    angles = trailing_shape(angles, "angles", (3,))
    Ra = _ELEMENTARY[i](angles[..., 0])
    Rb = _ELEMENTARY[j](angles[..., 1])
    Rc = _ELEMENTARY[k](angles[..., 2])
    e = np.eye(3)
    if intrinsic:
        cols = [np.broadcast_to(e[i], Ra.shape[:-1]), Ra[..., :, j], (Ra @ Rb)[..., :, k]]
        R = Ra @ Rb @ Rc
    else:
        cols = [(Rc @ Rb)[..., :, i], Rc[..., :, j], np.broadcast_to(e[k], Rc.shape[:-1])]
        R = Rc @ Rb @ Ra
    E = np.stack(cols, axis=-1)
    return E if frame == "space" else np.swapaxes(R, -1, -2) @ E
