"""Compiled embedded Runge-Kutta pairs with error control and dense output: Dormand & Prince's 8(5,3)
(DOP853) and 5(4) (DOPRI5), and their tableaux as one type shared with the periodic-orbit propagator."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ...errors import InputError
from ._base import Kind, Method, Structure

__all__ = ["EmbeddedPair", "embedded_pair", "DormandPrince", "Taylor", "taylor_order"]


def taylor_order(tolerances: tuple[float, float]) -> int:
    """The order of Taylor's method at ``tolerances`` (rtol, atol): ``ceil(-ln(eps) / 2) + 1``, eps the smaller,
    between 4 and 40 (Jorba & Zou's choice, heyoka's: the cost of the coefficients, p^2 a step, against the steps)."""
    eps = min(tolerances)
    return min(40, max(4, math.ceil(-0.5 * math.log(eps)) + 1))


@dataclass(frozen=True, eq=False)
class EmbeddedPair:
    """The tableau of an explicit embedded Runge-Kutta pair with a continuous extension.

    A step of size ``h`` from ``y`` takes the stages ``K_0 = f(y)``, ``K_s = f(y + h sum_j A[s, j] K_j)``
    for ``s < n_stages``, and ``y1 = y + h b . K``; ``K_{n_stages} = f(y1)`` (first of the next step).
    The local error estimate is ``h e . K`` (and ``h e2 . K`` for DOP853's 3rd-order estimate, zero
    otherwise), on the stages and ``f(y1)``. Rows of ``A`` beyond ``n_stages`` are the extra stages of the
    dense output. The dense output is ``y + sum_k F_k phi_k(theta)``, ``theta = (t - t_n)/h``, with
    ``F_k = h sum_j dense[k, j] K_j`` and ``phi_k = theta^(k+1)`` (``alternating`` False), or, as in Hairer's
    DOP853, the nested form ``F_0 + (1 - theta)(F_1 + theta(F_2 + (1 - theta)(F_3 + ...)))`` times ``theta``.
    """

    name: str
    A: np.ndarray
    b: np.ndarray
    e: np.ndarray
    e2: np.ndarray
    dense: np.ndarray
    alternating: bool
    n_stages: int
    order: int
    error_order: int
    dense_order: int

    @property
    def c(self) -> np.ndarray:
        return self.A.sum(axis=1)

    @property
    def n_total(self) -> int:
        """Stages, ``f(y1)`` and the extra stages of the dense output."""
        return int(self.A.shape[0])


@functools.cache
def embedded_pair(name: str) -> EmbeddedPair:
    """The tableau ``"DOP853"`` (Dormand & Prince 8(5,3), [HNW] II.10) or ``"DOPRI5"`` (Dormand & Prince 5(4)
    with Shampine's dense output of order 4), with the coefficients scipy's solvers of the same names use."""
    from . import _dormand_prince as dp

    if name == "DOP853":
        ns = dp.DOP853_STAGES
        n_total = ns + 1 + len(dp.DOP853_A_EXTRA)
        A = np.zeros((n_total, n_total))
        A[:ns, :ns] = _dense(dp.DOP853_A, ns)
        b = _dense((dp.DOP853_B,), ns)[0]
        A[ns, :ns] = b
        A[ns + 1 :, :] = _dense(dp.DOP853_A_EXTRA, n_total)
        # F0 = y1 - y, F1 = h f(y) - (y1 - y), F2 = 2 (y1 - y) - h (f(y1) + f(y)), F3.. = h D . K
        bb, e0, e1 = np.zeros(n_total), np.eye(n_total)[0], np.eye(n_total)[ns]
        bb[:ns] = b
        dense = np.vstack([bb, e0 - bb, 2 * bb - e1 - e0, _dense(dp.DOP853_D, n_total)])
        e5, e3 = _dense((dp.DOP853_E5, dp.DOP853_E3), ns + 1)
        return EmbeddedPair("DOP853", A, b, e5, e3, dense, True, ns, 8, 7, 7)
    if name == "DOPRI5":
        ns = dp.DOPRI5_STAGES
        A = np.zeros((ns + 1, ns + 1))
        A[:ns, : ns - 1] = _dense(dp.DOPRI5_A, ns - 1)
        b = _dense((dp.DOPRI5_B,), ns)[0]
        A[ns, :ns] = b
        dense = np.ascontiguousarray(_dense(dp.DOPRI5_P, 4).T)  # row k: theta^(k+1)
        return EmbeddedPair(
            "DOPRI5", A, b, _dense((dp.DOPRI5_E,), ns + 1)[0], np.zeros(ns + 1), dense, False, ns, 5, 4, 4
        )
    raise InputError(f"Expected an embedded pair 'DOP853' or 'DOPRI5', got {name!r}.")


def _dense(rows: tuple[dict[int, float], ...], columns: int) -> np.ndarray:
    """The matrix of ``rows`` of nonzero entries ``{column: value}``, ``columns`` wide."""
    out = np.zeros((len(rows), columns))
    for i, row in enumerate(rows):
        for j, value in row.items():
            out[i, j] = value
    return out


_PAIRS = {"DOP853": "dop853", "DOPRI5": "dopri5"}


@dataclass(frozen=True)
class DormandPrince(Method):
    """A Dormand-Prince embedded Runge-Kutta pair, compiled, with error control and dense output.

    ``pair="DOP853"`` (the default): order 8 with the 5th- and 3rd-order error estimates combined as in
    Hairer's DOP853, dense output of order 7 (three more evaluations in a step where a state is saved);
    ``pair="DOPRI5"``: order 5, 4th-order error estimate, dense output of order 4 (Shampine), first same as
    last. Steps are accepted when the scaled RMS error estimate (``atol + rtol max(|y|, |y1|)``) is below 1,
    resized by ``0.9 err^(-1/(q+1))`` within [0.2, 10] (no growth right after a rejection); the first step by
    Hairer's rule. The state is summed with compensation, so that round-off does not grow with the number of
    steps. The same arithmetic as scipy's solvers of these names, in a compiled loop over a batch (threads).
    Kind: adaptive (``rtol``, ``atol``; default 1e-10, 1e-12). Order: 8 (DOP853) or 5 (DOPRI5); explicit;
    not symplectic nor symmetric. Structure: any ODE with a compiled right-hand side. Cost: 12 (DOP853) or
    6 (DOPRI5) evaluations a step.
    Reference: [HNW] II.4-II.6, II.10; Shampine, Math. Comp. 46 (1986).

    Parameters
    ----------
    pair : {"DOP853", "DOPRI5"}
    """

    pair: str = "DOP853"
    structure: ClassVar[Structure] = Structure.ODE
    kind: ClassVar[Kind] = Kind.ADAPTIVE
    explicit: ClassVar[bool] = True
    default_tolerances: ClassVar[tuple[float, float]] = (1e-10, 1e-12)
    kernel: ClassVar[str] = "erk_run"

    def __post_init__(self) -> None:
        if self.pair not in _PAIRS:
            raise InputError(f"Expected `pair` to be one of {sorted(_PAIRS)}, got {self.pair!r}.")

    @property
    def order(self) -> int:
        return embedded_pair(self.pair).order

    @property
    def key(self) -> str:
        return _PAIRS[self.pair]

    def tableau(self) -> EmbeddedPair:
        return embedded_pair(self.pair)


#: scipy's solvers (of BKMM, of RKMK) that have a compiled twin: the same pairs, the same error control
COMPILED_SOLVERS = {"DOP853": "DOP853", "RK45": "DOPRI5"}


def compiled_pair(solver: str) -> DormandPrince | None:
    """The compiled embedded pair for a scipy ``solver`` name, or None (Radau, BDF, LSODA, RK23 stay scipy's)."""
    name = COMPILED_SOLVERS.get(solver)
    return None if name is None else DormandPrince(name)


@dataclass(frozen=True)
class Taylor(Method):
    """Taylor's method, compiled: the Taylor coefficients of the solution generated from the system's formulas.

    The right-hand side's formulas (Hamilton's, Euler's or a body with rotors' equations, their common
    subexpressions shared) are split into elementary operations and their coefficients computed order by order by
    the recurrences of each operation (:mod:`geomech.symbolic.taylor`), at the order ``ceil(-ln(eps) / 2) + 1``
    (4 to 40) of the smaller tolerance eps; the step is Jorba & Zou's, from the last two coefficients weighed by
    ``atol + rtol |y_i|`` with the margin ``exp(-0.7 / (p - 1))``; the saved states and the events (located by
    bisection) are read from each step's polynomial. Kind: adaptive (``rtol``, ``atol``; default 1e-10, 1e-12).
    Order: that of the tolerances, fixed along a run (15 at the defaults); explicit; not symplectic nor
    symmetric. Structure: an ODE given by formulas (compiled only; the exit of a system's chart located on the
    polynomial, as the embedded pairs locate it). Cost: a step of order p costs about p^2 / 2 multiply-adds per
    product of the equations; a few dozen steps where DOP853 takes hundreds, for smooth motions at tight
    tolerances. The coefficients' code is written out for the run's order (every sum unrolled, the coefficients
    known to vanish dropped; compiled by LLVM in about a second per order and cached on disk), or, for equations
    too large for that or with ``compact=True``, a loop over the orders (heyoka's "compact mode": about twice
    the time a step, compiled once for every order).
    Reference: Jorba & Zou, Experiment. Math. 14 (2005); Griewank & Walther, Evaluating Derivatives (2008), 13.2.

    Parameters
    ----------
    compact : bool or None
        The loop over the orders (True) or the code unrolled for the order (False); None (the default): unrolled
        unless a pass would be more than 60,000 multiply-adds.
    """

    compact: bool | None = None
    structure: ClassVar[Structure] = Structure.ODE
    kind: ClassVar[Kind] = Kind.ADAPTIVE
    explicit: ClassVar[bool] = True
    default_tolerances: ClassVar[tuple[float, float]] = (1e-10, 1e-12)
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "taylor"})

    @property
    def order(self) -> int:
        return taylor_order(self.default_tolerances)  # a run's is that of its tolerances, fixed along it

    def __post_init__(self) -> None:
        if self.compact not in (None, True, False):
            raise InputError(f"Expected `compact` to be True, False or None (chosen by size), got {self.compact!r}.")

    @property
    def key(self) -> str:
        return "taylor"
