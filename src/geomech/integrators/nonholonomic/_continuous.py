"""The adaptive engines of :func:`~geomech.solve` for a Lagrangian system: the Lagrange-d'Alembert equations in
coordinates (:class:`~geomech.integrators.LagrangeDAlembert`) and the BKMM equations
(:class:`~geomech.integrators.BKMM`), stepped by scipy's solvers with their work bounded before and during the
run and their failures returned as data with the states reached."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from scipy import integrate as _scipy_integrate

from ... import _validate as V
from ...errors import InputError, NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from ..solution import Status
from ._inputs import _group_rates, _Setup
from ._trajectory import _accelerations, _Raw

#: Default ceiling on right-hand-side evaluations of the adaptive simulators (tens of seconds of work).
MAX_EVALUATIONS = 200_000

#: Evaluations after which the pace of the integration is measured and the whole run's cost projected.
_PILOT = 2_000


class _OverBudget(Exception):
    def __init__(self, t: float, count: int, projected: float | None = None):
        self.t, self.count, self.projected = t, count, projected


def _budgeted(rhs: Callable, max_evaluations: Any, t_span: tuple[float, float]) -> Callable:
    """``rhs`` that stops the integration (raising :class:`_OverBudget`) past ``max_evaluations`` calls, or
    early, after a pilot of :data:`_PILOT` calls, when the pace so far projects a total far above it."""
    limit = int(V.positive_scalar(max_evaluations, "max_evaluations"))
    t_start, t_end = t_span
    count = 0
    t_far = t_start

    def counted(t: float, y: np.ndarray) -> np.ndarray:
        nonlocal count, t_far
        count += 1
        if abs(t - t_start) > abs(t_far - t_start):
            t_far = t
        if count == _PILOT and limit > _PILOT and t_far != t_start:
            projected = count * (t_end - t_start) / (t_far - t_start)
            if projected > 2.0 * limit:
                raise _OverBudget(t, count, projected)
        if count > limit:
            raise _OverBudget(t, count - 1)
        return rhs(t, y)

    return counted


def _adaptive(
    name: str,
    rhs: Callable,
    y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    solver: str,
    tolerances: tuple[float, float],
    max_evaluations: Any,
) -> tuple[np.ndarray, Any, int, int]:
    """Integrate from ``t0``, saving at ``times`` by the solver's dense output (as solve_ivp does).

    Returns the saved states (NaN past a failure), the failure as ``(status, index of the first time not
    reached, last time reached, detail, residual)`` or None, the number of evaluations and of steps.
    """
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
    failure = None
    n_steps = 0
    try:
        while k < len(times):
            message = step.step()
            n_steps += 1
            if step.status == "failed":
                failure = (Status.ADAPTIVE_FAILED, k, float(step.t), str(message), float("nan"))
                break
            if not np.all(np.isfinite(step.y)):
                failure = (Status.NONFINITE, k, float(step.t_old), "", float("nan"))
                break
            dense = step.dense_output()
            while k < len(times) and sign * (times[k] - step.t) <= 0:
                Y[k] = dense(times[k])
                k += 1
            if step.status == "finished":
                break
    except _OverBudget as stop:
        if stop.projected is not None:
            raise InputError(
                f"{name}: at the pace of its first {stop.count} evaluations (to t = {stop.t:.6g}) the run to "
                f"{times[-1]:.6g} needs about {min(stop.projected, 1e300):.3g} evaluations of the equations, above "
                f"`max_evaluations` = {int(max_evaluations)}; shorten t_final or raise `max_evaluations`."
            ) from None
        detail = (
            f"stopped after {stop.count} evaluations, of {times[-1]:.6g}: the motion is faster, or the span longer, "
            "than the budget allows; shorten t_final or raise `max_evaluations`"
        )
        failure = (Status.BUDGET_EXHAUSTED, k, float(step.t), detail, float("nan"))
    except NumericalError as exc:
        failure = (Status.SINGULAR_CONSTRAINTS, k, float(step.t), str(exc), float("nan"))
    return Y, failure, int(step.nfev), n_steps


def _rows(
    setup: _Setup, times: np.ndarray, Y: np.ndarray, evaluate: Callable
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, qd, tau) at each saved state that was reached; NaN rows after a failure."""
    ok = np.all(np.isfinite(Y), axis=1)
    n, sigma = setup.system.n, setup.system.sigma
    out = [np.full((len(times), d), np.nan) for d in (n, n, sigma)]
    for i in np.flatnonzero(ok):
        for arr, x in zip(out, evaluate(times[i], Y[i])):
            arr[i] = x
    return out[0], out[1], out[2]


def run_full(
    setup: _Setup,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    parameters: Mapping[str, float] | None,
) -> _Raw:
    """The Lagrange-d'Alembert equations with multipliers (the index-reduced DAE), by ``method.solver``."""
    system = setup.system
    funcs = lagrange_dalembert(system).numeric(parameters).funcs
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    nf = len(fr)
    baumgarte = float(method.baumgarte)

    def full_state(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd = np.empty(system.n), np.empty(system.n)
        q[fr], qd[fr] = y[:nf], y[nf : 2 * nf]
        r_p, rd_p, rdd_p = setup.gait(t)
        q[pr], qd[pr] = r_p, rd_p
        return q, qd, rdd_p

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, rdd_p = full_state(t, y)
        a, _, tau_v = _accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)
        return np.r_[qd[fr], a, tau_v @ qd[system.k :]]

    def evaluate(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, rdd_p = full_state(t, y)
        return q, qd, _accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)[2]

    y0 = np.r_[q_init[fr], qd_init[fr], 0.0]
    Y, failure, nfev, n_steps = _adaptive(
        "LagrangeDAlembert", rhs, y0, t0, times, method.solver, tolerances, max_evaluations
    )
    Q, QD, TAU = _rows(setup, times, Y, evaluate)
    return _Raw(Q, QD, TAU, Y[:, -1], failure, nfev, steps=n_steps)


def run_reduced(
    setup: _Setup,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    parameters: Mapping[str, float] | None,
) -> _Raw:
    """The BKMM equations (1.1)-(1.3): momentum, shape and reconstruction; the state is
    ``(g, r_free, rdot_free, p, W)`` and the group coordinates follow :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi`."""
    system = setup.system
    red = bkmm_reduction(system)
    rn = red.numeric(parameters)
    rates = _group_rates(system)
    k, sigma, m = system.k, system.sigma, red.m
    F, P = setup.free_shapes, setup.prescribed
    nF = len(F)

    def unpack(t: float, y: np.ndarray):
        g = y[:k]
        r, rd = np.empty(sigma), np.empty(sigma)
        r[F], rd[F] = y[k : k + nF], y[k + nF : k + 2 * nF]
        r_p, rd_p, rdd_p = setup.gait(t)
        r[P], rd[P] = r_p, rd_p
        p = y[k + 2 * nF : k + 2 * nF + m]
        return g, r, rd, rdd_p, p

    def evaluate_all(t: float, y: np.ndarray):
        g, r, rd, rdd_p, p = unpack(t, y)
        xi = rn.xi(r, rd, p)
        q, qd = np.r_[g, r], np.r_[rates(g) @ xi, rd]
        tau_f = setup.torques(t, q, qd)
        M, delta = rn.shape_mass(r, rd, p), rn.delta(r, rd, p)
        # Unknowns: free shape accelerations and the forces that realise the gait.
        K = np.zeros((sigma, sigma))
        K[:, :nF] = M[:, F]
        for j, i in enumerate(P):
            K[i, nF + j] = -1.0
        b = delta.copy()
        b[F] += tau_f
        b -= M[:, P] @ rdd_p
        try:
            z = np.linalg.solve(K, b) if sigma else np.zeros(0)
        except np.linalg.LinAlgError as exc:
            raise NumericalError(f"The shape equations are singular at t = {t:.6g}, q = {q}.") from exc
        tau_v = np.zeros(sigma)
        tau_v[F], tau_v[P] = tau_f, z[nF:]
        return q, qd, xi, z[:nF], tau_v, rn.pdot(r, rd, p)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, _, rdd_f, tau_v, pdot = evaluate_all(t, y)
        return np.r_[qd[:k], qd[k:][F], rdd_f, pdot, tau_v @ qd[k:]]

    def evaluate(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, _, _, tau_v, _ = evaluate_all(t, y)
        return q, qd, tau_v

    p_init = rn.momentum(q_init, qd_init)
    y0 = np.r_[q_init[:k], q_init[k:][F], qd_init[k:][F], p_init, 0.0]
    Y, failure, nfev, n_steps = _adaptive("BKMM", rhs, y0, t0, times, method.solver, tolerances, max_evaluations)
    Q, QD, TAU = _rows(setup, times, Y, evaluate)
    return _Raw(Q, QD, TAU, Y[:, -1], failure, nfev, steps=n_steps)
