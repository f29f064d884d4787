"""What the one-degree-of-freedom propagators share: their common arguments checked, the critical points of
:math:`H` (equilibria, saddles) and integrals of a function along a periodic orbit."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError
from ..systems.canonical import CanonicalSystem
from ._chebyshev import _Piecewise

__all__ = ["CriticalPoint", "OrbitIntegral", "one_dof_arguments"]


def one_dof_arguments(
    system: Any, y0: Any, tol: Any, tol_range: tuple[float, float], what: str
) -> tuple[CanonicalSystem, np.ndarray, float]:
    """Check the arguments common to the one-degree-of-freedom propagators: ``(system, y0, tol)``."""
    if not isinstance(system, CanonicalSystem) or system.n != 1:
        got = f"n = {system.n}" if isinstance(system, CanonicalSystem) else type(system).__name__
        raise InputError(
            f"Expected `system` to be a CanonicalSystem with one degree of freedom (n = 1), got {got}; "
            f"{what} applies to 1-degree-of-freedom systems such as GeneralizedSerretAndoyer.reduced_system(G)."
        )
    y0 = V.exact_shape(y0, "y0", (2,))
    tol = V.positive_scalar(tol, "tol")
    if not (tol_range[0] <= tol <= tol_range[1]):
        raise InputError(f"Expected `tol` in [{tol_range[0]:g}, {tol_range[1]:g}], got {tol}.")
    return system, y0, tol


@dataclass(frozen=True)
class CriticalPoint:
    """A critical point of :math:`H`: an equilibrium of the flow.

    Attributes
    ----------
    y : (2,) its location ``(q, p)`` (``q`` lifted as traced, not reduced modulo the period).
    energy : :math:`H(y)`.
    kind : ``"center"`` (:math:`\\det D^2H > 0`), ``"saddle"`` (:math:`< 0`) or ``"degenerate"``.
    rate : :math:`\\sqrt{|\\det D^2H|}`: the angular frequency of the linearised oscillation about a centre
        (small librations have period :math:`2\\pi/\\text{rate}`), the growth rate of the linearised flow
        at a saddle (a separatrix approaches it like :math:`e^{-\\text{rate}\\, t}`).
    """

    y: np.ndarray
    energy: float
    kind: str
    rate: float


class OrbitIntegral:
    """:math:`F(t) = \\int_0^t f(y(s))\\,ds` along a periodic orbit: ``n * per_period + F(t - n T)``.

    Attributes
    ----------
    per_period : float or (k,), the increment over one period; mean_rate : ``per_period / period``.
    """

    def __init__(self, period: float, per_period: np.ndarray, table: _Piecewise | None, rate: np.ndarray):
        self.period, self._table, self._vector = period, table, per_period.size > 1
        self.per_period = per_period if self._vector else float(per_period[0])
        self.mean_rate = rate if self._vector else float(rate[0])

    def __call__(self, t: Any) -> np.ndarray:
        """:math:`\\int_0^t f(y(s))\\,ds`, shape ``t.shape`` (or ``t.shape + (k,)`` for vector ``f``)."""
        t = V.finite(t, "t")
        if self._table is None:  # an equilibrium: f is constant along the (constant) solution
            out = t[..., None] * np.atleast_1d(self.mean_rate)
        else:
            n = np.floor(t / self.period)
            out = n[..., None] * np.atleast_1d(self.per_period) + self._table(t - n * self.period)
        return out if self._vector else out[..., 0]
