"""The adaptive engines of :func:`~geomech.solve` for a Lagrangian system: the Lagrange-d'Alembert equations in
coordinates (:class:`~geomech.integrators.LagrangeDAlembert`) and the BKMM equations
(:class:`~geomech.integrators.BKMM`), stepped by scipy's solvers with their work bounded before and during the
run and their failures returned as data with the states reached."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ... import _validate as V
from ...errors import InputError, NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from .._adaptive import (
    MAX_EVALUATIONS,
    MAX_EVALUATIONS_COMPILED,
    PILOT,
    budget_spent,
    integrate_ivp,
    projected_cost_error,
)
from .._runners import INFO_COLUMNS, run_embedded
from ..solution import Failure, Status
from ._compiled import COMPILED_SOLVERS, bkmm_module, compiled_pair
from ._inputs import _group_rates, _Setup
from ._trajectory import _accelerations, _Raw

#: A NumericalError raised by the equations of a Lagrangian run: they became singular.
SINGULAR = Status.SINGULAR_CONSTRAINTS


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
    Y, failure, nfev, n_steps = integrate_ivp(
        "LagrangeDAlembert", rhs, y0, t0, times, method.solver, tolerances, max_evaluations, SINGULAR
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
    backend: str = "auto",
) -> _Raw:
    """The BKMM equations (1.1)-(1.3): momentum, shape and reconstruction; the state is
    ``(g, r_free, rdot_free, p, W)`` and the group coordinates follow :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi`.
    Compiled (the Dormand-Prince loops) where the solver has a compiled twin and the gait and torques are
    formulas, unless ``backend`` is "python"; otherwise stepped by scipy with the equations in Python."""
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
        M, delta = rn.shape_mass(r), rn.delta(r, rd, p)
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
    pair = compiled_pair(method.solver) if backend != "python" else None
    compiled = bkmm_module(setup, red, parameters) if pair is not None else None
    if compiled is None and backend == "numba":
        raise InputError(
            f"backend='numba' runs BKMM with the solvers {sorted(COMPILED_SOLVERS)} on a gait and torques given as "
            f"formulas (and numba installed); got solver {method.solver!r}"
            + ("" if pair is None else ", and a gait or torque given as a Python callable")
            + "."
        )
    if compiled is not None:
        assert pair is not None
        budget = MAX_EVALUATIONS_COMPILED if max_evaluations is None else max_evaluations
        module, prm = compiled
        Y, failure, nfev, n_steps, compile_time, loop_time = _run_compiled(
            module, pair, prm, y0, t0, times, tolerances, budget
        )
        used = "numba"
    else:
        budget = MAX_EVALUATIONS if max_evaluations is None else max_evaluations
        Y, failure, nfev, n_steps = integrate_ivp(
            "BKMM", rhs, y0, t0, times, method.solver, tolerances, budget, SINGULAR
        )
        used, compile_time, loop_time = "python", 0.0, None
    Q, QD, TAU = _rows(setup, times, Y, evaluate)
    return _Raw(
        Q, QD, TAU, Y[:, -1], failure, nfev, steps=n_steps, backend=used, compile_time=compile_time, loop_time=loop_time
    )


def _run_compiled(
    module: Any,
    pair: Any,
    prm: np.ndarray,
    y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    max_evaluations: Any,
) -> tuple[np.ndarray, Failure | None, int, int, float, float]:
    """The BKMM state ``(g, r_F, rdot_F, p, W)`` at ``times`` by the compiled pair (the time appended to the
    state, its rate 1), as :func:`~geomech.integrators._adaptive.integrate_ivp` returns it, the compile time and
    the time of the compiled loop alone."""
    Y0 = np.r_[y0, t0][None, :]
    limit = float(V.positive_scalar(max_evaluations, "max_evaluations"))
    t_end = float(times[-1])

    def run(budget: float) -> tuple[np.ndarray, np.ndarray, dict[int, str], int, float, float]:
        OUT = np.empty((1, len(times), Y0.shape[1]))
        INFO = np.zeros((1, INFO_COLUMNS))
        reasons: dict[int, str] = {}
        start = time.perf_counter()
        steps, compile_time = run_embedded(
            module, "numba", None, prm[None, :], pair, Y0, t0, times, tolerances, budget, OUT, INFO, reasons, {}, 1
        )
        return OUT, INFO, reasons, steps, compile_time, time.perf_counter() - start - compile_time

    # the work is bounded before it is done: a pilot run, and its pace projected to the end (as in Python)
    OUT, INFO, reasons, steps, compile_time, loop_time = run(min(limit, PILOT))
    if int(INFO[0, 0]) == 8 and limit > PILOT:
        t_far = float(INFO[0, 5])
        projected = PILOT * (t_end - t0) / (t_far - t0) if t_far != t0 else np.inf
        if projected > 2.0 * limit:
            raise projected_cost_error("BKMM", int(INFO[0, 4]), t_far, t_end, projected, limit)
        OUT, INFO, reasons, steps, _, loop_time = run(limit)
    failure = None
    code = int(INFO[0, 0])
    if code:
        kind = {8: Status.BUDGET_EXHAUSTED, 4: Status.ADAPTIVE_FAILED}.get(code, SINGULAR)
        if kind is Status.BUDGET_EXHAUSTED:
            detail = budget_spent(int(INFO[0, 4]), t_end)
        elif kind is SINGULAR:
            detail = (
                f"the BKMM equations are singular (the locked inertia or the constraints), or the state is not "
                f"finite, past t = {INFO[0, 5]:.6g}"
            )
        else:
            detail = reasons[0]
        failure = Failure(kind, (), int(INFO[0, 1]), float(INFO[0, 5]), float("nan"), detail)
    return OUT[0, :, :-1], failure, int(INFO[0, 4]), steps, compile_time, loop_time
