r"""Theorem 2.2 where the momentum's isotropy group is a circle: a body on :math:`SO(3)` with shape variables (a
spacecraft with rotors or a moving appendage, a chain of bodies), its spatial momentum :math:`\mu \ne 0` conserved.

With the body momentum :math:`\Pi = R^T\mu` and :math:`\xi = R^{-1}\dot R = -\mathcal A(r)\dot r +
\mathbb I(r)^{-1}\Pi` (eq. 2.2), along a prescribed shape loop :math:`\Pi` obeys :math:`\dot\Pi = \Pi\times\xi`.
When the curve :math:`(\Pi(t), r(t))` closes after one period (a closed curve in :math:`Q/G_\mu = S^2\times S`),
:math:`R(T)R(0)^{-1}` fixes :math:`\mu`: it is the rotation about :math:`\mu` by the phase

.. math::

    \Delta\theta = \underbrace{-\Lambda - \frac1{|\mu|}\oint\Pi\cdot\mathcal A(r)\,dr}_{\text{geometric}}
                 + \underbrace{\frac1{|\mu|}\int_0^T\Pi\cdot\mathbb I(r)^{-1}\Pi\,dt}_{\text{dynamic}},

with :math:`\Lambda` the solid angle that :math:`\Pi(t)/|\mu|` encloses on the unit sphere (counterclockwise about
its interior). It is :math:`\Delta\theta = \frac1{|\mu|}\int\Pi\cdot\xi\,dt - \Lambda` (Montgomery's formula for
any motion whose body momentum returns) with eq. (2.2) inserted; without shapes it is the free rigid body's
:math:`2ET/|\mu| - \Lambda`. The geometric part depends only on the closed curve :math:`(\Pi, r)`, not on its
timing; the dynamic part is eq. (2.3)'s :math:`\mu\int\mathbb I^{-1}dt` for this group.

A prescribed loop closes :math:`\Pi` only from special starts: :func:`periodic_body_momentum` finds one (a fixed
point of the period map on the sphere :math:`|\Pi| = |\mu|`, by Newton from a guess).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import ConvergenceError, InputError, NumericalError
from ..reduction.nonholonomic import reduced_numeric
from ..reduction.reduced_numeric import ReducedNumeric
from .gait_model import gait_loop
from .shape_loops import bind_loop

__all__ = ["IsotropyPhase", "isotropy_phase", "periodic_body_momentum"]


def _model_and_loop(
    system: Any, loop: Any, period: float | None, parameters: Mapping[str, float] | None
) -> tuple[ReducedNumeric, Any]:
    model = system if isinstance(system, ReducedNumeric) else reduced_numeric(system, parameters)
    s = model.system
    if s.group.name != "SO(3)" or s.c:
        raise InputError(
            f"isotropy_phase is for a body on SO(3) with shape variables and no constraints (G_mu a circle); "
            f"{s.name} has G = {s.group.name} and {s.c} constraint(s): use geomech.analysis.phases (S^1, SE(2)) or "
            "reconstruct on the group."
        )
    loop = gait_loop(s, loop, period, parameters=parameters)
    bind_loop(model, loop)
    return model, loop


def _rates(model: ReducedNumeric, loop: Any, G: float):
    """The right-hand side of (Pi, geometric connection term, dynamic term, solid-angle term)."""

    def rhs(t: float, y: np.ndarray, axis: np.ndarray) -> np.ndarray:
        r, rd = loop.r(t), loop.rdot(t)
        Pi = y[:3]
        A = model.connection(r)
        Iinv_Pi = np.linalg.solve(model.locked_inertia(r), Pi)
        xi = -A @ rd + Iinv_Pi
        dPi = np.cross(Pi, xi)
        u, du = Pi / G, dPi / G
        # the solid angle swept about `axis`, as the integral of the monopole connection (singular only at -axis)
        berry = axis @ np.cross(u, du) / (1.0 + axis @ u)
        return np.array([*dPi, -(Pi @ (A @ rd)) / G, (Pi @ Iinv_Pi) / G, berry])

    return rhs


def _period_map(model: ReducedNumeric, loop: Any, Pi0: np.ndarray, rtol: float, atol: float) -> Any:
    """(Pi, the three integrals of the phase) over one period from Pi0; the integrals start at 0."""
    from scipy.integrate import solve_ivp

    G = float(np.linalg.norm(Pi0))
    rhs = _rates(model, loop, G)
    axis = Pi0 / G
    y0 = np.concatenate([Pi0, np.zeros(3)])
    sol = solve_ivp(lambda t, y: rhs(t, y, axis), (0.0, loop.T), y0, method="DOP853", rtol=rtol, atol=atol * G)
    if sol.status != 0 or not np.all(np.isfinite(sol.y)):
        raise NumericalError(f"The body momentum along the shape loop failed at t = {sol.t[-1]:.6g}: {sol.message}")
    return sol


@dataclass(frozen=True)
class IsotropyPhase(ShowsItselfAsHTML):
    """The phase about the spatial momentum over one period, split as geometric + dynamic (module docstring).

    Attributes
    ----------
    geometric, dynamic, total : float
        :math:`-\\Lambda - \\oint\\Pi\\cdot\\mathcal A\\,dr/|\\mu|`,
        :math:`\\int\\Pi\\cdot\\mathbb I^{-1}\\Pi\\,dt/|\\mu|` and their sum (not wrapped).
    solid_angle : float
        :math:`\\Lambda`.
    connection_term : float
        :math:`-\\oint\\Pi\\cdot\\mathcal A\\,dr/|\\mu|`.
    body_momentum : (3,) :math:`\\Pi(0)`; closure : :math:`|\\Pi(T) - \\Pi(0)|/|\\mu|`; period : T.
    """

    geometric: float
    dynamic: float
    total: float
    solid_angle: float
    connection_term: float
    body_momentum: np.ndarray
    closure: float
    period: float

    @property
    def total_wrapped(self) -> float:
        return float(np.angle(np.exp(1j * self.total)))

    def to_json(self) -> dict[str, Any]:
        return {
            "geometric": self.geometric,
            "dynamic": self.dynamic,
            "total": self.total,
            "total_wrapped": self.total_wrapped,
            "solid_angle": self.solid_angle,
            "connection_term": self.connection_term,
            "body_momentum": self.body_momentum.tolist(),
            "closure": self.closure,
            "period": self.period,
        }


def isotropy_phase(
    system: Any,
    loop: Any,
    Pi0: Any,
    *,
    period: float | None = None,
    parameters: Mapping[str, float] | None = None,
    closure_tol: float = 1e-8,
    rtol: float = 1e-12,
    atol: float = 1e-13,
) -> IsotropyPhase:
    """Theorem 2.2 for a body on SO(3) with shapes (module docstring): the phase about :math:`\\mu` after one period
    of the closed shape ``loop``, from the body momentum ``Pi0`` (``(3,)``, nonzero; the attitude :math:`R_0` only
    fixes :math:`\\mu = R_0\\Pi_0` and does not enter).

    Raises
    ------
    InputError
        Not a body on SO(3) without constraints; ``Pi0`` zero (the isotropy is then all of SO(3)); the body momentum
        does not return after one period (the curve is not closed in :math:`Q/G_\\mu`): start from
        :func:`periodic_body_momentum`.
    """
    model, loop = _model_and_loop(system, loop, period, parameters)
    Pi0 = V.exact_shape(Pi0, "Pi0", (3,))
    G = float(np.linalg.norm(Pi0))
    if G == 0:
        raise InputError("Expected a nonzero body momentum `Pi0`: at mu = 0 the isotropy group is SO(3), not a circle.")
    sol = _period_map(model, loop, Pi0, rtol, atol)
    yT = sol.y[:, -1]
    closure = float(np.linalg.norm(yT[:3] - Pi0) / G)
    if closure > closure_tol:
        raise InputError(
            f"The body momentum does not return after one period (|Pi(T) - Pi(0)| / |Pi| = {closure:.3g} > "
            f"closure_tol = {closure_tol:g}): the motion is not a closed curve in Q/G_mu, where the phase is defined. "
            "Start from geomech.analysis.periodic_body_momentum(system, loop, Pi_guess)."
        )
    conn, dyn, Lam = (float(v) for v in yT[3:])
    return IsotropyPhase(-Lam + conn, dyn, -Lam + conn + dyn, Lam, conn, Pi0.copy(), closure, float(loop.T))


def periodic_body_momentum(
    system: Any,
    loop: Any,
    Pi_guess: Any,
    *,
    period: float | None = None,
    parameters: Mapping[str, float] | None = None,
    tol: float = 1e-12,
) -> np.ndarray:
    """A body momentum :math:`\\Pi_0` on the sphere :math:`|\\Pi| = |\\Pi_{guess}|` that returns after one period of
    the shape ``loop``: a fixed point of the period map, by Newton (scipy's ``hybr``) in the tangent plane at the
    guess. Raises :class:`~geomech.errors.ConvergenceError` when none is found near the guess."""
    from scipy.optimize import root

    model, loop = _model_and_loop(system, loop, period, parameters)
    guess = V.exact_shape(Pi_guess, "Pi_guess", (3,))
    G = float(np.linalg.norm(guess))
    if G == 0:
        raise InputError("Expected a nonzero `Pi_guess`.")
    u0 = guess / G
    e1 = np.cross(u0, [1.0, 0.0, 0.0] if abs(u0[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u0, e1)

    def point(a: np.ndarray) -> np.ndarray:
        v = u0 + a[0] * e1 + a[1] * e2
        return G * v / np.linalg.norm(v)

    def residual(a: np.ndarray) -> np.ndarray:
        P0 = point(a)
        PT = _period_map(model, loop, P0, 1e-13, 1e-14).y[:3, -1]
        d = (PT - P0) / G
        return np.array([d @ e1, d @ e2])

    res = root(residual, np.zeros(2), method="hybr", options={"xtol": tol})
    P0 = point(res.x)
    final = np.linalg.norm(residual(res.x))
    if not res.success or final > 1e3 * tol:
        raise ConvergenceError(
            f"No body momentum near {guess.tolist()} returns after one period of the loop (the period map's residual "
            f"stalled at {final:.3g}): try another guess, e.g. near a steady spin about a principal axis."
        )
    return P0
