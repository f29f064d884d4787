"""The adaptive engines of :func:`~geomech.solve` for a Lagrangian system: the Lagrange-d'Alembert equations in
coordinates (:class:`~geomech.integrators.LagrangeDAlembert`) and the BKMM equations
(:class:`~geomech.integrators.BKMM`), stepped by scipy's solvers with their work bounded before and during the
run and their failures returned as data with the states reached."""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ... import _validate as V
from ...errors import InputError, NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from ...symbolic.taylor import TAYLOR_FUNCTIONS
from .._adaptive import (
    MAX_EVALUATIONS,
    MAX_EVALUATIONS_COMPILED,
    PILOT,
    budget_spent,
    integrate_ivp,
    projected_cost_error,
)
from .._events import compile_lagrangian_events, event_table, stepped_lagrangian_events
from .._observe import bound_observation, observe
from .._runners import INFO_COLUMNS, failed_rows, from_bound, keep_bound, run_embedded, run_taylor, total
from .._variational import augment
from ..methods import TAYLOR
from ..solution import Failure, Status
from ._compiled import COMPILED_SOLVERS, bkmm_module, bkmm_slots, compiled_pair, lda_module, lda_slots
from ._inputs import _group_rates, _Setup, scalar_values
from ._trajectory import _accelerations, _Raw

#: What the variational equations of a Lagrangian system need.
VARIATIONAL_NEEDS = (
    "`sensitivities` of a Lagrangian system integrate the variational equations of its BKMM equations, compiled: "
    "method BKMM with solver 'DOP853' or 'RK45', the gait and torques as formulas, numba installed, no `events`."
)

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
    backend: str = "auto",
    events: Any = None,
    max_events: int = 0,
) -> _Raw:
    """The Lagrange-d'Alembert equations with multipliers (the index-reduced DAE), by ``method.solver``: compiled
    (the Dormand-Prince loops) where the solver has a compiled twin and the gait and torques are formulas, unless
    ``backend`` is "python"; otherwise stepped by scipy with the equations in Python."""
    system = setup.system
    compiled = _compiled_or_refused(setup, method, backend, events, lambda: lda_module(setup, float(method.baumgarte)))
    if compiled is not None:
        module, made = compiled
        fr = setup.free_coordinates()
        run = run_compiled(
            module,
            made,
            made.rows({**system.parameters, **dict(parameters or {})}, 1),
            np.r_[q_init[fr], qd_init[fr], 0.0][None],
            t0,
            times,
            method,
            tolerances,
            max_evaluations,
            1,
            None if events is None else compile_lagrangian_events(setup, made, lda_slots(setup), events),
            max_events,
            setup.compiled,
        )
        return run.raw(setup, None, 0, run.failures[0][1] if run.failures else None)
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
    budget = MAX_EVALUATIONS if max_evaluations is None else max_evaluations
    return run_stepped(
        "LagrangeDAlembert",
        setup,
        rhs,
        evaluate,
        y0,
        t0,
        times,
        method,
        tolerances,
        budget,
        parameters,
        events,
        max_events,
    )


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
    events: Any = None,
    max_events: int = 0,
    sensitivities: tuple[str, ...] | None = None,
    p_init: np.ndarray | None = None,
) -> _Raw:
    """The BKMM equations (1.1)-(1.3): momentum, shape and reconstruction; the state is
    ``(g, r_free, rdot_free, p, W)`` and the group coordinates follow :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi`,
    from ``p_init``, the momentum given, or that of ``(q_init, qd_init)``.
    Compiled (the Dormand-Prince loops) where the solver has a compiled twin and the gait and torques are
    formulas, unless ``backend`` is "python"; otherwise stepped by scipy with the equations in Python."""
    system = setup.system
    red = bkmm_reduction(system)
    k, sigma, m = system.k, system.sigma, red.m
    F, P = setup.free_shapes, setup.prescribed
    nF = len(F)
    if p_init is None:
        p_init = red.numeric(parameters).momentum(q_init, qd_init)
    y0 = np.concatenate([q_init[:k], q_init[k:][F], qd_init[k:][F], p_init, [0.0]])
    taylor = method.solver == TAYLOR
    work = method.work
    compiled = _compiled_or_refused(
        setup, method, backend, events, lambda: bkmm_module(setup, red, taylor, sensitivities, work), sensitivities
    )
    if compiled is None and sensitivities is not None:
        raise InputError(VARIATIONAL_NEEDS)
    if compiled is not None:
        module, made = compiled
        run = run_compiled(
            module,
            made,
            made.rows({**system.parameters, **dict(parameters or {})}, 1),
            y0[None] if sensitivities is None else augment(y0[None], len(sensitivities)),
            t0,
            times,
            method,
            tolerances,
            max_evaluations,
            1,
            None if events is None else compile_lagrangian_events(setup, made, bkmm_slots(setup, m), events),
            max_events,
            setup.compiled,
        )
        failure = run.failures[0][1] if run.failures else None
        return run.raw(setup, m, 0, failure)
    # stepped by scipy, the equations in Python
    rn = red.numeric(parameters)
    rates = _group_rates(system)

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
        return np.r_[qd[:k], qd[k:][F], rdd_f, pdot, tau_v @ qd[k:] if work else 0.0]

    def evaluate(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, _, _, tau_v, _ = evaluate_all(t, y)
        return q, qd, tau_v

    budget = MAX_EVALUATIONS if max_evaluations is None else max_evaluations
    return run_stepped(
        "BKMM", setup, rhs, evaluate, y0, t0, times, method, tolerances, budget, parameters, events, max_events
    )


def run_stepped(
    name: str,
    setup: _Setup,
    rhs: Callable,
    evaluate: Callable,
    y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    budget: Any,
    parameters: Mapping[str, float] | None,
    events: Any,
    max_events: int,
) -> _Raw:
    """A run in Python stepped by scipy's ``method.solver`` (Lagrange-d'Alembert, BKMM, the Hamiltonian forms):
    ``evaluate(t, y)`` gives the (q, qdot, shape forces) of its state, the ``events`` located on the solver's dense
    output."""

    def shown(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, _ = evaluate(t, y)
        return np.r_[q, qd]

    located = None if events is None else stepped_lagrangian_events(setup, events, scalar_values(parameters), shown)
    Y, failure, nfev, n_steps = integrate_ivp(
        name, rhs, y0, t0, times, method.solver, tolerances, budget, SINGULAR, located
    )
    Q, QD, TAU = _rows(setup, times, Y, evaluate)
    table = {} if located is None else located.table(shown, 2 * setup.system.n, max_events)
    return _Raw(Q, QD, TAU, Y[:, -1], failure, nfev, steps=n_steps, events=table)


def _compiled_or_refused(setup: _Setup, method: Any, backend: str, events: Any, module: Callable, *key: Any) -> Any:
    """The compiled module and source of a run (``module()``) where the method's solver has a compiled twin and
    ``backend`` is not "python", or None; raises where ``backend`` is "numba" or ``events`` are asked for and the run
    cannot be compiled. Found once per ``setup`` (a prepared problem's runs share it), method, backend and ``key``."""
    memo = (method, backend, events is None, *key)
    if memo in setup.compiled:
        return setup.compiled[memo]
    system = setup.system
    if method.solver == TAYLOR:
        compiled = _taylor_or_refused(system, method, backend, module)
    else:
        pair = compiled_pair(method.solver) if backend != "python" else None
        compiled = module() if pair is not None else None
        if compiled is None and backend == "numba":
            raise InputError(
                f"backend='numba' runs {type(method).__name__} with the solvers {sorted(COMPILED_SOLVERS)} on a gait "
                f"and torques given as formulas (and numba installed); got solver {method.solver!r}"
                + ("" if pair is None else ", and a gait or torque given as a Python callable")
                + "."
            )
    setup.compiled[memo] = compiled
    return compiled


def _taylor_or_refused(system: Any, method: Any, backend: str, module: Callable) -> Any:
    """The compiled module of a run by Taylor's method, which runs compiled only, or the reason it cannot."""
    name = type(method).__name__
    if backend == "python":
        raise InputError(
            f"{name}(solver='taylor') runs compiled only; use backend='auto' or 'numba', or another solver."
        )
    compiled = module()
    if compiled is None:
        raise InputError(
            f"{name}(solver='taylor') needs numba, the gait and torques of {system.name} as formulas, and functions "
            f"with a Taylor recurrence ({', '.join(TAYLOR_FUNCTIONS)}); use solver='DOP853'."
        )
    return compiled


@dataclass
class CompiledRun:
    """A compiled run of a batch (BKMM or Lagrange-d'Alembert): the states ``(B, n_saved, d)`` (``(g, r_F, rdot_F,
    p, W)`` or ``(q_F, qdot_F, W)``), what they show ``(B, n_saved, w)`` (:class:`~._compiled.LagrangianSource`'s
    observation: q, qdot, shape forces, energy, constraints),
    the failures by member, the evaluations and accepted steps in all, and the compile and loop times."""

    states: np.ndarray
    observed: np.ndarray
    failures: list[tuple[int, Failure]]
    nfev: int
    steps: int
    compile_time: float
    loop_time: float
    events: dict[str, np.ndarray] = field(default_factory=dict)
    #: with variational equations: ``stm`` (B, n_saved, d, d) and ``parameter_sensitivity`` (B, n_saved, d, k)
    variational: dict[str, np.ndarray] = field(default_factory=dict)

    def raw(self, setup: _Setup, m: int | None, b: int, failure: Failure | None) -> _Raw:
        """Member ``b`` as the engines' :class:`_Raw`, its quantities included (the momentum where the state holds
        it: ``m`` momenta after the group coordinates and the free shapes and their rates; None for none)."""
        s = setup.system
        n, sigma, c = s.n, s.sigma, s.c
        k_p = s.k + 2 * len(setup.free_shapes)
        w, y = self.observed[b], self.states[b]
        return _Raw(
            w[:, :n],
            w[:, n : 2 * n],
            w[:, 2 * n : 2 * n + sigma],
            y[:, -1],
            failure,
            int(self.nfev),
            steps=self.steps,
            backend="numba",
            compile_time=self.compile_time,
            loop_time=self.loop_time,
            energy=w[:, 2 * n + sigma],
            momentum=None if m is None else y[:, k_p : k_p + m],
            residual=w[:, 2 * n + sigma + 1 : 2 * n + sigma + 1 + c],
            events=self.events,
            variational={key: v[b] for key, v in self.variational.items()},
        )


def run_compiled(
    module: Any,
    made: Any,
    PRM: np.ndarray,
    Y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    threads: int,
    events: Any = None,
    max_events: int = 0,
    keep: dict | None = None,
) -> CompiledRun:
    """The states ``Y0`` of ``module``'s equations (rows ``(g, r_F, rdot_F, p, W)`` for BKMM, ``(q_F, qdot_F, W)``
    for Lagrange-d'Alembert, one per member; ``PRM`` one row for all or one per member) at ``times`` by the
    compiled pair of ``method.solver``, the time appended to the state (its rate 1), the members over ``threads``;
    each member's work bounded before it is done (a pilot of its first evaluations, its
    pace projected to the end, as in Python), its failure its own. ``events`` (compiled for this state) are located
    and returned as rows ``(member, t, q, qdot)``. A single run without events given ``keep`` (a prepared problem's
    memo) keeps there its loop bound to its buffers (:class:`~._runners.BoundRun`), which runs the next single run
    of the same options from its start (the general way where it fails, or its budget is spent, which reports it)."""
    limit = float(
        V.positive_scalar(MAX_EVALUATIONS_COMPILED if max_evaluations is None else max_evaluations, "max_evaluations")
    )
    pair = compiled_pair(method.solver)
    assert pair is not None or method.solver == TAYLOR
    B, d = Y0.shape[0], Y0.shape[1] + 1
    reasons: dict[int, str] = {}
    # a single run: its loop bound once for these options' values, these times (a prepared problem's, which never
    # change: held with it, their id never reused) and width; the observation of its states bound too
    bind: list | None = [] if keep is not None and B == 1 and events is None else None
    key = (method, tolerances, float(t0), limit, PRM.tobytes(), d, id(times))
    store: dict = {} if keep is None else keep.setdefault("bound", {})

    def observation(kept: Any) -> Any:
        return bound_observation(module, made, kept.OUT.reshape(len(times), d), PRM, len(times))

    done = None if bind is None else from_bound(store, key, Y0[0], observation)  # (its time, t0, as bound)
    if done is not None:
        OUT, INFO, seconds, shown = done
        return _compiled_run(module, made, OUT, INFO, PRM, times, reasons, 0.0, int(INFO[0, 6]), seconds, OBS=shown)
    Y0 = np.concatenate([Y0, np.full((B, 1), float(t0))], axis=1)
    t_end = float(times[-1])
    OUT = np.empty((B, len(times), d))
    INFO = np.zeros((B, INFO_COLUMNS))
    reached: dict[int, float] = {}
    looped: list[float] = []  # the seconds of each call into the compiled loop

    def run(members: np.ndarray, budget: float) -> tuple[int, float]:
        """``members`` with ``budget`` evaluations each, into OUT, INFO, reasons and reached."""
        whole = members.size == B  # every member, in order (a small batch's pilot): in place
        out = OUT if whole else np.empty((members.size, len(times), d))
        info = INFO if whole else np.zeros((members.size, INFO_COLUMNS))
        why: dict[int, str] = {}
        when: dict[int, float] = {}
        rows = PRM if PRM.shape[0] == 1 else PRM[members]
        # Taylor's loop, or the embedded pair's: the same arguments after the module's
        engine = (
            functools.partial(run_taylor, module, rows)
            if pair is None
            else functools.partial(run_embedded, module, "numba", None, rows, pair)
        )
        n, seconds, loop, evt, count = engine(
            Y0 if whole else Y0[members],
            t0,
            times,
            tolerances,
            budget,
            out,
            info,
            why,
            when,
            threads,
            events,
            max_events,
            bind=bind if whole else None,
        )
        looped.append(loop)
        if not whole:
            OUT[members], INFO[members] = out, info
        if events is not None:
            EVT[members], ECOUNT[members] = evt, count
        for i, b in enumerate(members.tolist()):
            reasons.pop(b, None)
            reached.pop(b, None)
            if i in why:
                reasons[b], reached[b] = why[i], when[i]
        return n, seconds

    # the work is bounded before it is done: a pilot of a few members (spread over the batch), their pace projected
    # to the end (as in Python); the members it finished are kept, the others run with the budget
    pilot = np.arange(B) if B <= 8 else np.unique(np.linspace(0, B - 1, 8).astype(int))
    EVT = np.zeros((B, max_events if events is not None else 0, 2 + d))
    ECOUNT = np.zeros(B)
    steps, compile_time = run(pilot, min(limit, PILOT))
    OUT, INFO = keep_bound(store, key, bind, OUT, INFO, times)  # (done within the pilot: the next runs start there)
    codes = INFO[:, 0] if pilot.size == B else INFO[pilot, 0]  # (a small batch's pilot is the batch)
    spent = pilot[codes == 8] if limit > PILOT else pilot[:0]
    if spent.size:
        t_far = INFO[spent, 5]
        with np.errstate(divide="ignore", invalid="ignore"):
            projected = np.where(t_far != t0, PILOT * (t_end - t0) / (t_far - t0), np.inf)
        worst = int(np.argmax(projected))
        if projected[worst] > 2.0 * limit:
            b = int(spent[worst])
            raise projected_cost_error(
                made.equations + (f" (member {b} of the batch)" if B > 1 else ""),
                int(INFO[b, 4]),
                float(t_far[worst]),
                t_end,
                float(projected[worst]),
                limit,
            )
        steps -= int(INFO[spent, 6].sum())
    finished = set(pilot.tolist()) - set(spent.tolist())
    rest = np.array([b for b in range(B) if b not in finished], dtype=int) if len(finished) < B else pilot[:0]
    if rest.size:
        steps += run(rest, limit)[0]
    return _compiled_run(
        module, made, OUT, INFO, PRM, times, reasons, compile_time, steps, sum(looped), events, max_events, EVT, ECOUNT
    )


def _compiled_run(
    module: Any,
    made: Any,
    OUT: np.ndarray,
    INFO: np.ndarray,
    PRM: np.ndarray,
    times: np.ndarray,
    reasons: dict[int, str],
    compile_time: float,
    steps: int,
    loop_time: float,
    events: Any = None,
    max_events: int = 0,
    EVT: Any = None,
    ECOUNT: Any = None,
    OBS: np.ndarray | None = None,
) -> CompiledRun:
    """The :class:`CompiledRun` of a compiled run's outputs ``OUT`` and ``INFO``: its states observed (``OBS``, where
    they were), its failures told, its events shown as the solution's states, its variational equations apart."""
    B, n, d = OUT.shape
    t_end = float(times[-1])
    if OBS is None:
        OBS, seconds = observe(module, made, OUT.reshape(B * n, d), PRM, n)
        compile_time += seconds
    OBS = OBS.reshape(B, n, made.observed)
    failures = []
    for b in failed_rows(INFO):
        code = int(INFO[b, 0])
        kind = {8: Status.BUDGET_EXHAUSTED, 4: Status.ADAPTIVE_FAILED}.get(code, SINGULAR)
        if kind is Status.BUDGET_EXHAUSTED:
            detail = budget_spent(int(INFO[b, 4]), t_end)
        elif kind is SINGULAR:
            detail = f"{made.singular}, or the state is not finite, past t = {INFO[b, 5]:.6g}"
        else:
            detail = reasons[b]
        failures.append((b, Failure(kind, (), int(INFO[b, 1]), float(INFO[b, 5]), float("nan"), detail)))
    table: dict[str, np.ndarray] = {}
    if events is not None:
        # each event's state (g, r_F, rdot_F, p, W, t) shown as the solution's (q, qdot)
        table = event_table(events, EVT, ECOUNT, False, max_events)
        n_q = 2 * made.n
        for name, rows in table.items():
            if rows.size:
                Y = np.ascontiguousarray(rows[:, 2:])
                per_member = PRM if PRM.shape[0] == 1 else PRM[rows[:, 0].astype(int)]
                shown, seconds = observe(module, made, Y, np.ascontiguousarray(per_member), 1)
                compile_time += seconds
                shown = shown[:, :n_q]
                table[name] = np.concatenate([rows[:, :2], shown], axis=1)
            else:
                table[name] = np.zeros((0, 2 + n_q))
    states = OUT[..., :-1]
    variational: dict[str, np.ndarray] = {}
    if made.core:  # the state, then Phi (d x d) and S (d x k), row-major
        d0, k = made.core, len(made.wrt)
        variational["stm"] = states[..., d0 : d0 + d0 * d0].reshape(B, n, d0, d0)
        if k:
            variational["parameter_sensitivity"] = states[..., d0 + d0 * d0 :].reshape(B, n, d0, k)
        states = states[..., :d0]
    return CompiledRun(states, OBS, failures, total(INFO, 4), steps, compile_time, loop_time, table, variational)
