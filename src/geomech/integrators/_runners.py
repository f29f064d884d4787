"""The runners behind :func:`~geomech.solve` for the systems with a compiled model: each fills the saved
states ``OUT`` (batch, times, state) and the ``INFO`` rows (status, first step or output not reached, residual,
Newton iterations, evaluations, and for the adaptive loops the time reached and the accepted and rejected
steps) the way the compiled loops do, so that one code turns them into a :class:`~geomech.Solution`."""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from .._storage import remember
from ..errors import InputError
from ..symbolic.taylor import TaylorTape
from ._adaptive import integrate_ivp
from ._codegen import RHS, rhs_address
from ._events import CompiledEvents
from ._native import bound, loop_of
from ._problem import Problem
from ._taylor_llvm import UNROLL_LIMIT, horner_address, simd_lanes, unrolled_address
from .methods import DormandPrince, PeriodicOrbit, Quadrature, SerretAndoyerAtlas, SolveIVP, taylor_order
from .solution import STATUS

__all__ = [
    "BoundRun",
    "CODES",
    "INFO_COLUMNS",
    "from_bound",
    "keep_bound",
    "run_compiled",
    "run_embedded",
    "run_ivp",
    "run_atlas",
    "run_periodic",
    "run_taylor",
]

#: Columns of the INFO array of a run.
INFO_COLUMNS = 8


def _chunks(B: int, threads: int) -> list[tuple[int, int]]:
    bounds = np.linspace(0, B, min(threads, B) + 1).astype(int)
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist()))


def _threaded(call: Any, B: int, threads: int) -> float:
    """``call(a, b)`` on the rows a:b of a batch, split over ``threads`` threads (the compiled loops release
    the GIL); returns the seconds from the first call to the last one's end (the compiled loop's wall time)."""
    if threads <= 1 or B < 2:
        start = time.perf_counter()
        call(0, B)
        return time.perf_counter() - start
    with ThreadPoolExecutor(max_workers=min(threads, B)) as pool:
        start = time.perf_counter()
        for fut in [pool.submit(call, a, b) for a, b in _chunks(B, threads)]:
            fut.result()
        return time.perf_counter() - start


def failed_rows(INFO: np.ndarray) -> list[int]:
    """The members whose status (``INFO[:, 0]``) is not 0 (a run of one member read as a number: every call asks)."""
    if INFO.shape[0] == 1:
        return [] if INFO[0, 0] == 0 else [0]
    return np.flatnonzero(INFO[:, 0] != 0).tolist()


#: No chart's bounds (rows: component, lower, upper), read by the compiled loops, never written.
NO_CHART = np.zeros((0, 3))


def chart_bounds(system: Any) -> np.ndarray:
    """The bounds of ``system``'s chart as the compiled loops read them, rows (component, lower, upper)."""
    bounds = getattr(system, "chart", ())
    return np.array(bounds, dtype=float).reshape(-1, 3) if bounds else NO_CHART


def total(INFO: np.ndarray, column: int) -> int:
    """The sum of a column of the members' counts (steps, evaluations), one member's read as a number."""
    return int(INFO[0, column]) if INFO.shape[0] == 1 else int(INFO[:, column].sum())


def rows(PRM: np.ndarray, a: int, b: int) -> np.ndarray:
    """The parameter rows of trajectories a:b: all of ``PRM`` when it has one row (shared), else its rows a:b."""
    return PRM if PRM.shape[0] == 1 else PRM[a:b]


class BoundRun:
    """A single run's compiled loop bound to its buffers: the start ``Y0`` (1, d) and the outputs ``OUT`` and
    ``INFO`` it was first run with (its other arguments, the times, tolerances, budget and parameters, fixed), which
    :meth:`run` runs again from another start, the arguments neither checked nor gathered again. Made by the
    adaptive runners (``bind``) for a prepared problem, which keeps it; used by one thread at a time."""

    def __init__(self, again: Any, Y0: np.ndarray, OUT: np.ndarray, INFO: np.ndarray):
        self.again, self.Y0, self.OUT, self.INFO = again, Y0, OUT, INFO
        self._lock = threading.Lock()
        #: a run stopped by its budget (a pilot's, the run then projected and run again): every run is then made the
        #: general way, not started here first
        self.spent = False
        #: what is computed from the outputs after the loop, bound to them too (``(call, its output)``), or None
        self.then: tuple[Any, np.ndarray] | None = None
        #: what its key names by identity, held with it (an id is not reused while the object lives)
        self.held: tuple[Any, ...] = ()

    def run(self, y0: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, np.ndarray | None] | None:
        """The run from ``y0`` (the start's first ``y0.size`` entries; the others, an appended time, as bound): its
        outputs (copies), the loop's seconds and what :attr:`then` computed from them (a copy, or None); None where it
        did not succeed (a failure, a spent budget) or another thread runs it now, for the caller to run it the
        general way, which reports why."""
        if self.spent or not self._lock.acquire(blocking=False):
            return None
        try:
            self.Y0[0, : y0.size] = y0
            self.INFO[:] = 0.0
            start = time.perf_counter()
            if self.again() != 0:  # pragma: no cover - the buffers are sized by the loop's own function
                raise RuntimeError("the compiled loop's work buffers are too short")
            seconds = time.perf_counter() - start
            if self.INFO[0, 0] != 0:
                self.spent = self.INFO[0, 0] == 8
                return None
            shown = None
            if self.then is not None:
                self.then[0]()
                shown = self.then[1].copy()
            return self.OUT.copy(), self.INFO.copy(), seconds, shown
        finally:
            self._lock.release()


def from_bound(store: dict, key: Any, y0: np.ndarray, observation: Any = None) -> Any:
    """The run from ``y0`` of the :class:`BoundRun` kept in ``store`` under ``key`` (:meth:`BoundRun.run`), the
    observation of its outputs bound first where ``observation(bound)`` makes it (tried until it does: it can once
    the observation has its C entry); None where none is kept or the run did not succeed."""
    kept = store.get(key)
    if kept is None:
        return None
    if kept.then is None and observation is not None:
        kept.then = observation(kept)
    return kept.run(y0)


def keep_bound(
    store: dict, key: Any, bind: list | None, OUT: np.ndarray, INFO: np.ndarray, *held: Any
) -> tuple[np.ndarray, np.ndarray]:
    """After a general run given ``bind``: the :class:`BoundRun` it made kept in ``store`` under ``key`` (the last
    four; ``held``: what the key names by identity) where the run succeeded; returns the outputs to use, copies
    where they are the bound run's buffers (the next run's)."""
    if not bind or INFO[0, 0] != 0:
        return OUT, INFO
    bind[0].held = held
    remember(store, key, bind[0], 4)
    return OUT.copy(), INFO.copy()


def run_compiled(
    kern: Any,
    FP: np.ndarray,
    Y0: np.ndarray,
    h: float,
    nsteps: int,
    save_every: int,
    OUT: np.ndarray,
    INFO: np.ndarray,
    tol: float,
    maxit: int,
    P: np.ndarray,
    PRM: np.ndarray,
    threads: int,
) -> float:
    """A fixed-step loop over the batch ``Y0``; ``FP`` the addresses of the model functions it calls, ``PRM`` the
    parameter values (one row for all, or one per trajectory). Returns the loop's seconds."""

    def call(a: int, b: int) -> None:
        kern(FP, Y0[a:b], h, nsteps, save_every, OUT[a:b], INFO[a:b], tol, maxit, P, rows(PRM, a, b))

    return _threaded(call, Y0.shape[0], threads)


CODES = {status: code for code, status in STATUS.items()}


def run_ivp(
    module: Any,
    PRM: np.ndarray,
    method: SolveIVP,
    Y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    OUT: np.ndarray,
    INFO: np.ndarray,
    reasons: dict[int, str],
    reached: dict[int, float],
    events: Any = None,
    max_events: int = 0,
) -> tuple[int, np.ndarray, np.ndarray]:
    """Each row of ``Y0`` by a scipy solver on the compiled right-hand side; fills ``OUT`` and ``INFO`` as the
    loops do, ``reasons`` and ``reached`` (the last time reached) for a failed row, the ``events``
    (:class:`~._events.CompiledEvents`) located on the solver's dense output; returns the steps taken and the
    events recorded as the compiled loops record them ((B, max_events, 2 + d), their counts (B,))."""
    d = Y0.shape[1]
    steps = 0
    EVT = np.zeros((Y0.shape[0], max_events if events is not None else 0, 2 + d))
    ECOUNT = np.zeros(Y0.shape[0])
    for b in range(Y0.shape[0]):
        buf = np.empty(d)
        prm = rows(PRM, b, b + 1)[0]

        def f(_t: float, y: np.ndarray, buf: np.ndarray = buf, prm: np.ndarray = prm) -> np.ndarray:
            module.rhs(np.ascontiguousarray(y, dtype=float), buf, prm)
            return buf.copy()

        located = None if events is None else events.stepped(prm, d)
        Y, failure, nfev, n = integrate_ivp(
            type(method).__name__, f, Y0[b], t0, times, method.solver, tolerances, max_evaluations, events=located
        )
        if located is not None:
            events.record(located.rows, EVT, ECOUNT, b)
        OUT[b] = Y
        INFO[b, 4] = nfev
        steps += n
        if failure is not None:
            INFO[b, 0], INFO[b, 1], INFO[b, 2] = CODES[failure.kind], failure.step, np.nan
            reasons[b], reached[b] = failure.detail, failure.time
    return steps, EVT, ECOUNT


def run_atlas(
    problem: Problem,
    method: SerretAndoyerAtlas,
    Y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    OUT: np.ndarray,
    INFO: np.ndarray,
    reasons: dict[int, str],
    reached: dict[int, float],
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Each row of ``Y0`` on the Serret-Andoyer atlas; fills ``OUT`` and ``INFO`` as the loops do and returns
    the chart switches, rows ``(trajectory, t, from axis, to axis)``, and the (l, L, phi) and chart axis along
    each run."""
    from ..reduction.serret_andoyer import GeneralizedSerretAndoyer
    from ._atlas import run_atlas

    sa = GeneralizedSerretAndoyer(problem.core, switch_at=method.switch_at)
    B, n = Y0.shape[0], len(times)
    lLphi, axis = np.full((B, n, 3), np.nan), np.full((B, n), np.nan)
    switches: list[tuple[float, float, float, float]] = []
    for b in range(B):
        m0 = Y0[b, :3]
        if not np.linalg.norm(m0) > 0:
            raise InputError("Expected `m0` to be nonzero: the Serret-Andoyer atlas charts the sphere |m| = G > 0.")
        R0 = Y0[b, 3:].reshape(3, 3) if problem.layout == "mR" else np.eye(3)
        first = None if method.axis is None else method.axis - 1
        run = run_atlas(sa, m0, R0, t0, times, tolerances, first)
        OUT[b, :, :3] = run.m
        if problem.layout == "mR":
            OUT[b, :, 3:] = run.R.reshape(n, 9)
        lLphi[b], axis[b] = run.lLphi, run.axis
        INFO[b, 4] = run.nfev
        switches += [(float(b), t, float(a), float(c)) for t, a, c in run.switches]
        if run.failure is not None:
            INFO[b, 0], INFO[b, 1], INFO[b, 2] = CODES[run.failure.kind], run.failure.step, np.nan
            reasons[b], reached[b] = run.failure.detail, run.failure.time
    return np.array(switches, dtype=float).reshape(-1, 4), {"serret_andoyer": lLphi, "chart_axis": axis}


def run_periodic(
    core: Any,
    method: PeriodicOrbit | Quadrature,
    Y0: np.ndarray,
    times: np.ndarray,
    OUT: np.ndarray,
    INFO: np.ndarray,
    reasons: dict[int, str],
) -> tuple[int, float]:
    """Each row of ``Y0`` by :class:`PeriodicOrbitPropagator` or :class:`QuadraturePropagator`; returns
    (mesh steps or quadrature nodes, compile time)."""
    from ..errors import NumericalError, SingularityError
    from .periodic import PeriodicOrbitPropagator
    from .quadrature import QuadraturePropagator

    steps, compile_time = 0, 0.0
    orbit: QuadraturePropagator | PeriodicOrbitPropagator
    for b in range(Y0.shape[0]):
        try:
            if isinstance(method, Quadrature):
                orbit = QuadraturePropagator(core, Y0[b], L_bounds=method.L_bounds, tol=method.tol)
                if not np.isfinite(orbit.period):
                    raise SingularityError(
                        f"The orbit of y0 = {Y0[b].tolist()} is a {orbit.kind}: it has no period; use an integrator."
                    )
                OUT[b] = orbit.state(times)
            else:
                orbit = PeriodicOrbitPropagator(core, Y0[b], L_bounds=method.L_bounds, tol=method.tol)
                compile_time += orbit.stats["compile_time"]
                OUT[b] = orbit.state(times)
                steps += orbit.n_mesh
            INFO[b, 4] = orbit.nfev
        except NumericalError as exc:
            OUT[b] = np.nan
            OUT[b, times == 0.0] = Y0[b]
            INFO[b, 0], INFO[b, 1], INFO[b, 2] = 5, 1, np.nan
            reasons[b] = str(exc)
    return steps, compile_time


def run_embedded(
    module: Any,
    used: str,
    problem_system: Any,
    PRM: np.ndarray,
    method: DormandPrince,
    Y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    OUT: np.ndarray,
    INFO: np.ndarray,
    reasons: dict[int, str],
    reached: dict[int, float],
    threads: int,
    events: Any = None,
    max_events: int = 0,
    bind: list | None = None,
) -> tuple[int, float, float, np.ndarray, np.ndarray]:
    """Each row of ``Y0`` by the compiled Dormand-Prince loop, stopped where it leaves the chart of
    ``problem_system`` (its ``chart``: component, lower and upper bound) or at a terminal event; returns (accepted
    steps, compile time, the compiled loop's seconds, the events recorded (B, max_events, 2 + d), their counts
    (B,)). A single run given a list ``bind`` appends to it its :class:`BoundRun`."""
    ev = CompiledEvents.none() if events is None else events
    Y0, times, PRM = np.ascontiguousarray(Y0), np.ascontiguousarray(times, dtype=float), np.ascontiguousarray(PRM)
    EVT = np.zeros((Y0.shape[0], max_events if ev.names else 0, 2 + Y0.shape[1]))
    ECOUNT = np.zeros(Y0.shape[0])
    pair = method.tableau()
    rtol, atol = tolerances
    budget = float(max_evaluations)
    chart = chart_bounds(problem_system)
    # the pair's flag an integer: the loop's arguments all have a C form (:func:`._native.kinds`)
    args = (pair.A, pair.b, pair.e, pair.e2, pair.dense, pair.n_stages, pair.error_order, int(pair.alternating), chart)
    d = Y0.shape[1]
    erk_work = getattr(module.erk_work, "py_func", module.erk_work)
    n_work = int(erk_work(pair.A.shape[0], pair.dense.shape[0], d))
    # the model's C right-hand side: its own code loaded from the cache, or compiled (or loaded from numba's cache),
    # the first time
    compile_time, start = 0.0, time.perf_counter()
    first = used == "numba" and not module.ready(RHS)
    fp = rhs_address(module)
    if first:
        compile_time = time.perf_counter() - start
    event_args = (ev.address, ev.directions, ev.terminal)

    def arguments(a: int, b: int) -> tuple[Any, ...]:
        return (
            fp, Y0[a:b], t0, times, OUT[a:b], INFO[a:b], rtol, atol, budget, *args, *event_args, EVT[a:b],
            ECOUNT[a:b], rows(PRM, a, b), np.empty(n_work),
        )  # fmt: skip

    def warm_up() -> None:  # the first call compiles the loop (or loads numba's disk cache), on a one-step problem
        module.erk_run(
            fp, Y0[:1].copy(), t0, np.array([t0, t0 + (times[-1] - t0) * 1e-9]), np.empty((1, 2, d)),
            np.zeros((1, INFO.shape[1])), rtol, atol, 1.0, *args, 0, np.zeros(0), np.zeros(0), np.zeros((1, 0, 2 + d)),
            np.zeros(1), PRM[:1], np.empty(n_work),
        )  # fmt: skip

    loop, more = loop_of(module, "erk_run", lambda: arguments(0, 1), warm_up)
    compile_time += more

    def call(a: int, b: int) -> None:
        if _call(loop, arguments(a, b), bind, Y0, OUT, INFO) != 0:  # pragma: no cover - the buffer is sized by erk_work
            raise RuntimeError("the Dormand-Prince loop's work buffer is too short")

    with np.errstate(all="ignore"):  # the Python backend's overflow is a rejected step, as in the loop
        loop_time = _threaded(call, Y0.shape[0], threads if used == "numba" else 1)
    _adaptive_outcome(INFO, times, tolerances, reasons, reached)
    return total(INFO, 6), compile_time, loop_time, EVT, ECOUNT


#: The largest output (numbers) a bound run keeps buffers for: a longer run's Python is a small part of its time,
#: and its problem would hold a second copy of its output.
BOUND_SIZE = 100_000


def _call(
    loop: Any, args: tuple[Any, ...], bind: list | None, Y0: np.ndarray, OUT: np.ndarray, INFO: np.ndarray
) -> int:
    """``loop`` on ``args``; for a single run given a list ``bind`` (its output no larger than ``BOUND_SIZE``), bound
    to them first (its :class:`BoundRun` on the run's ``Y0``, ``OUT`` and ``INFO`` appended to the list)."""
    if bind is None or Y0.shape[0] != 1 or OUT.size > BOUND_SIZE:
        return int(loop(*args))
    again = bound(loop, args)
    bind.append(BoundRun(again, Y0, OUT, INFO))
    return int(again())


def _adaptive_outcome(
    INFO: np.ndarray, times: np.ndarray, tolerances: tuple[float, float], reasons: dict[int, str], reached: dict
) -> None:
    """The members of an adaptive loop stopped by a terminal event made successes (their outputs after it NaN); why
    each failed member stopped (``reasons``), and where (``reached``)."""
    if not failed_rows(INFO):  # every member a success
        return
    stopped = INFO[:, 0] == 9
    INFO[stopped, 0] = 0
    rtol, atol = tolerances
    for b in failed_rows(INFO):
        reached[b] = float(INFO[b, 5])
        code = int(INFO[b, 0])
        if code == 8:
            reasons[b] = (
                f"stopped after {int(INFO[b, 4])} evaluations, at t = {INFO[b, 5]:.6g} of {times[-1]:.6g}: the motion "
                "is faster, or the span longer, than the budget allows; shorten t_final or raise `max_evaluations`"
            )
        elif code == 4:
            reasons[b] = (
                f"the step size fell below the resolution of t at t = {INFO[b, 5]:.6g} to meet rtol = {rtol:g}, "
                f"atol = {atol:g}: a singularity of the equations, or tolerances below round-off"
            )
        elif code == 6:
            reasons[b] = f"located by the continuous extension at t = {INFO[b, 5]:.12g}"
        else:
            reasons[b] = f"the state or its error estimate is not finite past t = {INFO[b, 5]:.6g} (a blow-up)"


def run_taylor(
    module: Any,
    PRM: np.ndarray,
    Y0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    OUT: np.ndarray,
    INFO: np.ndarray,
    reasons: dict[int, str],
    reached: dict[int, float],
    threads: int,
    events: Any = None,
    max_events: int = 0,
    problem_system: Any = None,
    compact: bool | None = None,
    bind: list | None = None,
) -> tuple[int, float, float, np.ndarray, np.ndarray]:
    """Each row of ``Y0`` by the compiled Taylor loop of ``module`` at the order :func:`taylor_order` of
    ``tolerances``, stopped where it leaves the chart of ``problem_system`` or at a terminal event; returns (steps,
    compile time, the compiled loop's seconds, the events recorded (B, max_events, 2 + d), their counts (B,)). The
    coefficients are the module's tape (``TAYLOR_TAPE``) unrolled for the order (:mod:`._taylor_llvm`, compiled once
    per order: its time is counted in the compile time), or with ``compact`` (default: where the unrolled code would
    pass ``UNROLL_LIMIT`` multiply-adds) the module's loop over the orders, ``taylor_coeffs``. A single run given a
    list ``bind`` appends to it its :class:`BoundRun`."""
    ev = CompiledEvents.none() if events is None else events
    Y0, times, PRM = np.ascontiguousarray(Y0), np.ascontiguousarray(times, dtype=float), np.ascontiguousarray(PRM)
    EVT = np.zeros((Y0.shape[0], max_events if ev.names else 0, 2 + Y0.shape[1]))
    ECOUNT = np.zeros(Y0.shape[0])
    rtol, atol = tolerances
    order = taylor_order(tolerances)
    budget = float(max_evaluations)
    rows_w = int(module.TAYLOR_ROWS)
    chart = chart_bounds(problem_system)
    compile_time = 0.0
    # the coefficients' code for this order: (address of the unrolled code or 0 for the loop, constants), chosen
    # and compiled once per module, order and choice
    codes = module.__dict__.setdefault("_TAYLOR_CODES", {})
    if (order, compact) not in codes:
        tape = TaylorTape.from_data(module.TAYLOR_TAPE)
        unroll = tape.multiply_adds(order) <= UNROLL_LIMIT if compact is None else not compact
        start = time.perf_counter()
        codes[order, compact] = (unrolled_address(tape, order) if unroll else 0, len(tape.constants))
        compile_time += time.perf_counter() - start
    tfp, n_k = codes[order, compact]
    lanes = 1
    if tfp:
        rows_w = 0  # the unrolled code keeps its values in registers
        # a batch whose threads each run several members computes the coefficients of several at once (the lanes
        # of the vector unit), compiled once per order too
        width = simd_lanes()
        if width > 1 and Y0.shape[0] >= 2 * width * max(1, threads):
            if (order, compact, width) not in codes:
                start = time.perf_counter()
                codes[order, compact, width] = unrolled_address(TaylorTape.from_data(module.TAYLOR_TAPE), order, width)
                compile_time += time.perf_counter() - start
            tfp, lanes = codes[order, compact, width], width
    hfp = 0
    if tfp:  # the states advanced by Horner's rule on the lanes at once, compiled once per size, order and lanes
        if ("horner", Y0.shape[1], order, lanes) not in codes:
            start = time.perf_counter()
            codes["horner", Y0.shape[1], order, lanes] = horner_address(Y0.shape[1], order, lanes)
            compile_time += time.perf_counter() - start
        hfp = codes["horner", Y0.shape[1], order, lanes]
    d = Y0.shape[1]
    taylor_work = getattr(module.taylor_work, "py_func", module.taylor_work)
    n_work = int(taylor_work(d, order, lanes, rows_w, n_k, PRM.shape[1], ev.directions.shape[0]))
    event_args = (ev.address, ev.directions, ev.terminal)

    def arguments(a: int, b: int) -> tuple[Any, ...]:
        return (
            Y0[a:b], t0, times, OUT[a:b], INFO[a:b], rtol, atol, order, rows_w, tfp, hfp, n_k, lanes, budget, chart,
            *event_args, EVT[a:b], ECOUNT[a:b], rows(PRM, a, b), np.empty(n_work), np.empty(5 * lanes, dtype=np.int64),
        )  # fmt: skip

    def warm_up() -> None:  # the first call compiles the loop (or loads numba's disk cache), on a small problem
        module.taylor_run(
            Y0[:1].copy(), t0, np.array([t0, t0 + (times[-1] - t0) * 1e-9]), np.empty((1, 2, d)),
            np.zeros((1, INFO.shape[1])), rtol, atol, order, rows_w, tfp, hfp, n_k, lanes, 1.0, np.zeros((0, 3)), 0,
            np.zeros(0), np.zeros(0), np.zeros((1, 0, 2 + d)), np.zeros(1), PRM[:1],
            np.empty(int(taylor_work(d, order, lanes, rows_w, n_k, PRM.shape[1], 0))),
            np.empty(5 * lanes, dtype=np.int64),
        )  # fmt: skip

    loop, more = loop_of(module, "taylor_run", lambda: arguments(0, 1), warm_up)
    compile_time += more

    def call(a: int, b: int) -> None:
        if _call(loop, arguments(a, b), bind, Y0, OUT, INFO) != 0:  # pragma: no cover - sized by taylor_work
            raise RuntimeError("the Taylor loop's work buffers are too short")

    loop_time = _threaded(call, Y0.shape[0], threads)  # (compiled: numpy's floating-point state is not involved)
    _adaptive_outcome(INFO, times, tolerances, reasons, reached)
    return total(INFO, 6), compile_time, loop_time, EVT, ECOUNT
