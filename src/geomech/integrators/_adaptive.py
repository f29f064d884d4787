"""The adaptive runners: scipy's solve_ivp solvers stepped one step at a time (:func:`integrate_ivp`: dense
output at the saved times, the work bounded before and during the run, failures returned as data with the
states reached), and the variable-order Adams method from scipy's VODE / LSODA (:func:`run_adaptive`)."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError, NumericalError
from .solution import Failure, Status

__all__ = ["run_adaptive", "integrate_ivp", "MAX_EVALUATIONS", "MAX_EVALUATIONS_COMPILED"]


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
) -> tuple[np.ndarray, Failure | None, int, int]:
    """Integrate from ``t0``, saving at ``times`` by the solver's dense output (as solve_ivp does).

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
            while k < len(times) and sign * (times[k] - step.t) <= 0:
                Y[k] = dense(times[k])
                k += 1
            if step.status == "finished":
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
