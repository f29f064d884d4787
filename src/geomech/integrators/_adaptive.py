"""The adaptive runners: scipy's solve_ivp solvers stepped one step at a time (:func:`integrate_ivp`: dense
output at the saved times, the work bounded before and during the run, failures returned as data with the
states reached), and the variable-order Adams method from scipy's VODE / LSODA (:func:`run_adaptive`)."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError, NumericalError
from .solution import Failure, Status

__all__ = ["run_adaptive", "integrate_ivp", "StepEvents", "MAX_EVALUATIONS", "MAX_EVALUATIONS_COMPILED"]


#: Default ceiling on right-hand-side evaluations of the adaptive simulators (tens of seconds of work).
MAX_EVALUATIONS = 200_000
#: Default ceiling on evaluations of a compiled adaptive loop, per trajectory (seconds of compiled work).
MAX_EVALUATIONS_COMPILED = 100_000_000

#: Evaluations after which the pace of the integration is measured and the whole run's cost projected.
PILOT = 2_000


class _OverBudget(Exception):
    def __init__(self, t: float, count: int, projected: float | None = None):
        self.t, self.count, self.projected = t, count, projected


def _budgeted(rhs: Callable, max_evaluations: Any, t_span: tuple[float, float]) -> Callable:
    """``rhs`` that stops the integration (raising :class:`_OverBudget`) past ``max_evaluations`` calls, or
    early, after a pilot of :data:`PILOT` calls, when the pace so far projects a total far above it."""
    limit = int(V.positive_scalar(max_evaluations, "max_evaluations"))
    t_start, t_end = t_span
    count = 0
    t_far = t_start

    def counted(t: float, y: np.ndarray) -> np.ndarray:
        nonlocal count, t_far
        count += 1
        if abs(t - t_start) > abs(t_far - t_start):
            t_far = t
        if count == PILOT and limit > PILOT and t_far != t_start:
            projected = count * (t_end - t_start) / (t_far - t_start)
            if projected > 2.0 * limit:
                raise _OverBudget(t, count, projected)
        if count > limit:
            raise _OverBudget(t, count - 1)
        return rhs(t, y)

    return counted


def projected_cost_error(name: str, count: int, t: float, t_end: float, projected: float, limit: Any) -> InputError:
    """The refusal of a run whose pace over its first ``count`` evaluations (to ``t``) projects more than twice
    its budget ``limit`` to ``t_end``."""
    return InputError(
        f"{name}: at the pace of its first {count} evaluations (to t = {t:.6g}) the run to {t_end:.6g} needs about "
        f"{min(projected, 1e300):.3g} evaluations of the equations, above `max_evaluations` = {int(limit)}; shorten "
        "t_final or raise `max_evaluations`."
    )


def budget_spent(count: int, t_end: float) -> str:
    """What a run that used up its evaluations says."""
    return (
        f"stopped after {count} evaluations, of {t_end:.6g}: the motion is faster, or the span longer, than the "
        "budget allows; shorten t_final or raise `max_evaluations`"
    )


def _failure(kind: Status, k: int, when: Any, detail: str = "") -> Failure:
    return Failure(kind=kind, batch_index=(), step=int(k), time=float(when), residual=float("nan"), detail=detail)


@dataclass
class StepEvents:
    """The events of a run stepped by :func:`integrate_ivp`: ``g(t, y)`` the values of the event functions at a
    time and state, their ``directions`` (+1 rising, -1 falling, 0 both) and ``terminal`` flags; the occurrences
    located are appended to ``rows`` as ``(event, t, state...)``, in time order, up to and including the first
    terminal one (the rule of the compiled loops, :func:`~geomech.integrators._k_embedded.erk_crossed`)."""

    g: Callable[[float, np.ndarray], np.ndarray]
    directions: np.ndarray
    terminal: np.ndarray
    names: tuple[str, ...] = ()
    rows: list[np.ndarray] = field(default_factory=list)

    def table(
        self, shown: Callable[[float, np.ndarray], np.ndarray], width: int, max_events: int
    ) -> dict[str, np.ndarray]:
        """Solution.events of one trajectory: for each event its rows ``(0, t, shown(t, state))`` (``width``
        numbers shown); raises where there were more than ``max_events``."""
        if len(self.rows) > max_events:
            raise InputError(
                f"The run had {len(self.rows)} events, more than `max_events` = {max_events}; raise it, or make the "
                "events rarer (a direction, a terminal event)."
            )
        out: dict[str, list[np.ndarray]] = {name: [] for name in self.names}
        for r in self.rows:
            out[self.names[int(r[0])]].append(np.r_[0.0, r[1], shown(r[1], r[2:])])
        return {k: np.array(v) if v else np.zeros((0, 2 + width)) for k, v in out.items()}

    def crossed(self, g0: np.ndarray, g1: np.ndarray) -> np.ndarray:
        """Which functions went from g0 to g1 through zero in their direction (from a nonzero value to zero or
        past it: a zero at the start of a step is the previous step's)."""
        rising = (g0 < 0.0) & (g1 >= 0.0)
        falling = (g0 > 0.0) & (g1 <= 0.0)
        return (rising & (self.directions >= 0.0)) | (falling & (self.directions <= 0.0))

    def locate(self, dense: Callable, t_old: float, t_new: float, g_old: np.ndarray, g_new: np.ndarray) -> float | None:
        """The step's occurrences, each zero found on the dense output by bisection to the resolution of doubles,
        recorded; returns the time of the first terminal one (None: none)."""
        hits: list[tuple[float, float, int]] = []
        for j in np.flatnonzero(self.crossed(g_old, g_new)).tolist():
            lo, hi = t_old, t_new  # g keeps g_old's sign at lo; the zero is reached at hi
            below = g_old[j] < 0.0
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if mid in (lo, hi):
                    break
                gm = self.g(mid, dense(mid))[j]
                if (gm < 0.0) == below and gm != 0.0:
                    lo = mid
                else:
                    hi = mid
            hits.append((abs(hi - t_old), hi, j))
        stop = None
        for _, t, jj in sorted(hits):
            self.rows.append(np.r_[jj, t, dense(t)])
            if self.terminal[jj]:
                stop = t
                break
        return stop


def integrate_ivp(
    name: str,
    rhs: Callable,
    y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    solver: str,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    error_status: Status = Status.NONFINITE,
    events: StepEvents | None = None,
) -> tuple[np.ndarray, Failure | None, int, int]:
    """Integrate from ``t0``, saving at ``times`` by the solver's dense output (as solve_ivp does), the ``events``
    located on it (a terminal one ends the run there, the saved states after it NaN).

    Returns the saved states (NaN past a failure), the :class:`Failure` (``step`` the index of the first
    time not reached, ``time`` the last time reached) or None, the number of evaluations and of steps. A
    :class:`~geomech.errors.NumericalError` raised by ``rhs`` ends the run as the failure ``error_status``.
    """
    from scipy import integrate as _scipy_integrate

    rtol, atol = tolerances
    Y = np.full((len(times), y0.size), np.nan)
    k = 0
    while k < len(times) and times[k] == t0:
        Y[k] = y0
        k += 1
    if k == len(times):
        return Y, None, 0, 0
    counted = _budgeted(rhs, max_evaluations, (t0, float(times[-1])))
    step = getattr(_scipy_integrate, solver)(counted, t0, y0, float(times[-1]), rtol=rtol, atol=atol)
    sign = 1.0 if times[-1] > t0 else -1.0
    failure: Failure | None = None
    n_steps = 0
    g_old = None if events is None else events.g(t0, np.asarray(y0, dtype=float))
    try:
        while k < len(times):
            message = step.step()
            n_steps += 1
            if step.status == "failed":
                failure = _failure(Status.ADAPTIVE_FAILED, k, step.t, str(message))
                break
            if not np.all(np.isfinite(step.y)):
                failure = _failure(Status.NONFINITE, k, step.t_old)
                break
            dense = step.dense_output()
            stop = None
            if events is not None and g_old is not None:
                g_new = events.g(float(step.t), step.y)
                stop = events.locate(dense, float(step.t_old), float(step.t), g_old, g_new)
                g_old = g_new
            end = step.t if stop is None else stop
            while k < len(times) and sign * (times[k] - end) <= 0:
                Y[k] = dense(times[k])
                k += 1
            if step.status == "finished" or stop is not None:
                break
    except _OverBudget as stop:
        if stop.projected is not None:
            raise projected_cost_error(
                name, stop.count, stop.t, float(times[-1]), stop.projected, max_evaluations
            ) from None
        failure = _failure(Status.BUDGET_EXHAUSTED, k, step.t, budget_spent(stop.count, float(times[-1])))
    except NumericalError as exc:
        failure = _failure(error_status, k, step.t, str(exc))
    return Y, failure, int(step.nfev), n_steps


def run_adaptive(
    module: Any,
    PRM: np.ndarray,
    method: Any,
    Y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    OUT: np.ndarray,
    INFO: np.ndarray,
) -> int:
    """Integrate each row of ``Y0`` from ``t0`` with ``method`` (an AdaptiveAdams; ``PRM`` the parameter values, one
    row for all or one per row of ``Y0``), saving at ``times`` and
    filling ``OUT`` and ``INFO`` as the compiled loops do (``INFO[b, 1]`` is the index of the first output
    time not reached); returns the number of internal steps taken (summed over the batch)."""
    from scipy.integrate import ode

    rhs = module.rhs
    d = Y0.shape[1]
    rtol, atol = tolerances
    steps_total = 0
    for b in range(Y0.shape[0]):
        count = [0]
        buf = np.empty(d)
        prm = PRM[0] if PRM.shape[0] == 1 else PRM[b]

        def f(
            _t: float, y: np.ndarray, count: list = count, buf: np.ndarray = buf, prm: np.ndarray = prm
        ) -> np.ndarray:
            count[0] += 1
            rhs(np.ascontiguousarray(y, dtype=float), buf, prm)
            return buf.copy()

        solver = ode(f)
        options: dict[str, Any] = {"rtol": rtol, "atol": atol, "nsteps": method.max_steps}
        if method.solver == "vode":
            options["method"] = "adams"
        solver.set_integrator(method.solver, **options)
        solver.set_initial_value(Y0[b], t0)
        for k, t in enumerate(times):
            if t == t0:
                OUT[b, k] = Y0[b]
                continue
            with warnings.catch_warnings():
                # VODE/LSODA report trouble as a warning and an unsuccessful flag; the flag is what counts
                warnings.simplefilter("ignore", UserWarning)
                y = solver.integrate(t)
            if not solver.successful() or not np.all(np.isfinite(y)):
                INFO[b, 0] = 4 if not solver.successful() else 2
                INFO[b, 1] = k
                INFO[b, 2] = np.nan
                OUT[b, k:] = np.nan
                break
            OUT[b, k] = y
        INFO[b, 4] = count[0]
        iwork = getattr(getattr(solver, "_integrator", None), "iwork", None)
        if iwork is not None and len(iwork) > 10:
            steps_total += int(iwork[10])
    return steps_total
