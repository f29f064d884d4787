"""Montgomery's formula for the free rigid body (:math:`G_\\mu = S^1`): after one period of the body momentum,
the attitude has turned about the spatial momentum by minus the oriented solid angle enclosed on the momentum
sphere plus the dynamic phase :math:`2ET/|\\mu|`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import InputError, NumericalError
from ..lie._common import wrap_angle
from .group_paths import integrate_path
from .shape_loops import periodic_integral

__all__ = ["RigidBodyPhase", "rigid_body_phase", "spherical_polygon_area"]


# ---------------------------------------------------------------------------------------------------
# The free rigid body: Montgomery's formula (G_mu = S^1)
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RigidBodyPhase(ShowsItselfAsHTML):
    """Montgomery's formula for the free rigid body over one period :math:`T` of the body momentum.

    After one period the attitude has turned about the spatial momentum :math:`\\mu` by

    .. math::

        \\Delta\\theta = -\\Lambda + \\frac{2 E T}{|\\mu|} \\pmod{2\\pi},

    :math:`\\Lambda` the oriented solid angle enclosed by the curve :math:`m(t)/|m|` on the unit sphere:
    the area of the cap around the pole :math:`s\\,e_a` that the curve encircles (``axis`` :math:`a`, in the
    principal frame), positive when the curve runs counterclockwise seen from outside above that pole.

    Attributes (angles in radians; ``solid_angle``, ``geometric``, ``dynamic`` and ``total`` unwrapped,
    every ``*_wrapped`` in (-pi, pi])
    ----------
    period, energy, momentum (:math:`|\\mu|`), family, axis, pole_sign (:math:`s`), spatial_momentum (3,),
    solid_angle, geometric (:math:`-\\Lambda`), dynamic (:math:`2ET/|\\mu|`), total, total_wrapped,
    direct_wrapped (read off a direct integration of :math:`(R, m)`), reconstructed_wrapped (read off the
    Lie-group reconstruction :math:`R^{-1}\\dot R = \\mathbb I^{-1}R^T\\mu`), difference (formula minus
    direct, wrapped), attitude_residual (:math:`|R(T)R(0)^T\\hat\\mu - \\hat\\mu|`: the rotation is about
    :math:`\\mu`), samples (quadrature nodes).
    """

    period: float
    energy: float
    momentum: float
    family: str
    axis: int
    pole_sign: int
    spatial_momentum: np.ndarray
    solid_angle: float
    geometric: float
    dynamic: float
    total: float
    total_wrapped: float
    direct_wrapped: float | None
    reconstructed_wrapped: float | None
    difference: float | None
    attitude_residual: float | None
    body: Any = field(repr=False, default=None)
    m0: np.ndarray | None = field(repr=False, default=None)

    def momentum_curve(self, n: int = 400) -> np.ndarray:
        """One period of the body momentum :math:`m(t)` (user's body frame), shape ``(n, 3)``."""
        return self.body.exact_solution(self.m0).momentum(np.linspace(0.0, self.period, n))

    def to_json(self) -> dict[str, Any]:
        out = {
            k: getattr(self, k)
            for k in (
                "period",
                "energy",
                "momentum",
                "family",
                "axis",
                "pole_sign",
                "solid_angle",
                "geometric",
                "dynamic",
                "total",
                "total_wrapped",
                "direct_wrapped",
                "reconstructed_wrapped",
                "difference",
                "attitude_residual",
            )
        }
        out["spatial_momentum"] = np.asarray(self.spatial_momentum).tolist()
        return out


def _rotation_about(Q: np.ndarray, n: np.ndarray) -> tuple[float, float]:
    """Signed angle of the rotation ``Q`` about the unit axis ``n`` in (-pi, pi], and ``|Q n - n|``."""
    s = 0.5 * n @ np.array([Q[2, 1] - Q[1, 2], Q[0, 2] - Q[2, 0], Q[1, 0] - Q[0, 1]])
    c = 0.5 * (np.trace(Q) - 1.0)
    return float(wrap_angle(np.asarray(np.arctan2(s, c)))), float(np.linalg.norm(Q @ n - n))


def rigid_body_phase(
    body: Any, m0: Any, *, R0: Any = None, rtol: float = 1e-12, direct: bool = True, reconstructed: bool = True
) -> RigidBodyPhase:
    """Montgomery's formula for the free rigid body, the solid angle by the Serret-Andoyer variables.

    In the Serret-Andoyer chart about the encircled principal axis :math:`a`
    (:math:`m = (\\sqrt{G^2 - L^2}\\sin l, \\sqrt{G^2 - L^2}\\cos l, L)` after the chart's permutation),
    the sphere :math:`|m| = G` has area element :math:`G\\,dl\\,dL` (Archimedes), the azimuth about
    :math:`e_a` is :math:`\\pi/2 - l`, and so

    .. math::

        \\Lambda = -\\oint \\Big(s - \\frac{L}{G}\\Big)\\,dl, \\qquad s = \\operatorname{sign} L,

    integrated over one period by the trapezoidal rule in time (spectral for this periodic integrand),
    with :math:`m(t)` from the exact elliptic solution and :math:`\\dot l = \\partial h/\\partial L`. The
    reconstruction angle of Theorem 3 of the Serret-Andoyer paper satisfies
    :math:`\\dot\\varphi = m\\cdot\\nabla H/G - (L/G)\\dot l` (derived with sympy), whose integral over a period
    is the formula above up to :math:`s\\,\\Delta l = \\pm 2\\pi`.

    Parameters
    ----------
    body : RigidBody (or its inertia).
    m0 : initial body momentum, on a periodic orbit (not a steady spin or a separatrix).
    R0 : initial attitude (default identity); it fixes the spatial momentum :math:`\\mu = R_0 m_0`.
    direct : also integrate :math:`R' = R\\hat\\omega`, :math:`m' = m\\times\\omega` (DOP853, ``rtol``).
    reconstructed : also reconstruct :math:`R` on SO(3) by Runge-Kutta-Munthe-Kaas (:func:`~geomech.solve` on a
        :class:`~geomech.systems.GroupFlow`).
    """
    from scipy.integrate import solve_ivp

    from ..reduction import GeneralizedSerretAndoyer, SerretAndoyerChart
    from ..systems import RigidBody

    if not isinstance(body, RigidBody):
        body = RigidBody(body)
    m0 = V.exact_shape(m0, "m0", (3,))
    G = float(np.linalg.norm(m0))
    if G == 0:
        raise InputError("Expected `m0` to be nonzero: with zero momentum the body does not move.")
    R0 = np.eye(3) if R0 is None else V.rotation_matrix(R0, "R0")
    exact = body.exact_solution(m0)
    if exact.family not in ("major", "minor", "axisymmetric") or not np.isfinite(exact.period):
        raise InputError(
            f"Expected `m0` on a periodic orbit of the body momentum, got a {exact.family} motion "
            f"(m0 = {m0.tolist()}): there is no period to take a phase over; perturb m0."
        )
    T, E = float(exact.period), float(exact.energy)
    J = body.principal_moments
    a = {"major": int(np.argmax(J)), "minor": int(np.argmin(J))}.get(exact.family, exact.axis)
    chart = SerretAndoyerChart(a)
    sa = GeneralizedSerretAndoyer(RigidBody(J))
    s = float(np.sign(body.to_principal(m0)[a]))

    def integrand(t: np.ndarray) -> np.ndarray:
        lL = chart.forward(body.to_principal(exact.momentum(t)))
        ldot = sa.reduced_vector_field(lL, G, axis=a)[..., 0]
        return np.stack([-(s - lL[..., 1] / G) * ldot, ldot], -1)

    Lam, dl = periodic_integral(integrand, T, rtol=1e-14, what="solid angle")
    if abs(abs(dl) - 2 * np.pi) > 1e-6:
        raise NumericalError(
            f"The Serret-Andoyer angle l advanced by {dl:.9g} over a period instead of +-2 pi; "
            "the orbit does not encircle the expected axis."
        )
    geo, dyn = -float(Lam), 2 * E * T / G
    total = geo + dyn
    mu = R0 @ m0
    n = mu / G
    direct_angle = residual = rec_angle = None
    if direct:

        def rhs(_t: float, y: np.ndarray) -> np.ndarray:
            R, m = y[:9].reshape(3, 3), y[9:]
            w = np.linalg.solve(body.tensor, m)
            return np.concatenate(
                [(R @ np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])).ravel(), np.cross(m, w)]
            )

        sol = solve_ivp(
            rhs, (0.0, T), np.concatenate([R0.ravel(), m0]), method="DOP853", rtol=rtol, atol=rtol * max(1.0, G)
        )
        if sol.status != 0:
            raise NumericalError(f"Direct attitude integration failed at t = {sol.t[-1]:.6g}: {sol.message}")
        direct_angle, residual = _rotation_about(sol.y[:9, -1].reshape(3, 3) @ R0.T, n)
    if reconstructed:
        path = integrate_path(
            "SO3", lambda t, R: np.linalg.solve(body.tensor, R.T @ mu), R0, np.array([0.0, T]), rtol=rtol, atol=rtol
        )
        rec_angle = _rotation_about(path.element[-1] @ R0.T, n)[0]
    tw = float(wrap_angle(np.asarray(total)))
    diff = None if direct_angle is None else float(wrap_angle(np.asarray(tw - direct_angle)))
    return RigidBodyPhase(
        T,
        E,
        G,
        exact.family,
        a,
        int(s),
        mu,
        float(Lam),
        geo,
        dyn,
        total,
        tw,
        direct_angle,
        rec_angle,
        diff,
        residual,
        body,
        m0,
    )


def spherical_polygon_area(points: Any, pole: Any) -> float:
    """Oriented solid angle enclosed by the closed polygon ``points`` ``(m, 3)`` (projected to the unit
    sphere) around ``pole``: the area of the region containing ``pole``, positive when the polygon runs
    counterclockwise about it (a sum of triangles, Van Oosterom-Strackee; second order in the spacing,
    a check of :func:`rigid_body_phase`)."""
    P = V.trailing_shape(points, "points", (3,))
    P = P / np.linalg.norm(P, axis=-1, keepdims=True)
    c = V.exact_shape(pole, "pole", (3,))
    c = c / np.linalg.norm(c)
    a, b = P, np.roll(P, -1, axis=0)
    num = np.einsum("i,ni->n", c, np.cross(a, b))
    den = 1.0 + a @ c + np.einsum("ni,ni->n", a, b) + b @ c
    return float(2 * np.arctan2(num, den).sum())
