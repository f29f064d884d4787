"""A prepared problem: a system and a method checked and made ready by :func:`~geomech.integrators.prepare` (the
set-up), and its :meth:`Prepared.solve` (the run), which :func:`~geomech.integrators.solve` calls once."""

from __future__ import annotations

import dataclasses
import os
import time
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import ConvergenceError, InputError, NumericalError
from . import _codegen
from ._adaptive import MAX_EVALUATIONS, MAX_EVALUATIONS_COMPILED, run_adaptive
from ._batch import batch_index, initial_states, left_chart, parameter_batch
from ._events import event_table
from ._native import loop_of
from ._problem import Problem
from ._rotor import rotor_initial_states
from ._runners import (
    INFO_COLUMNS,
    failed_rows,
    from_bound,
    keep_bound,
    run_atlas,
    run_compiled,
    run_embedded,
    run_ivp,
    run_periodic,
    run_taylor,
    total,
)
from ._times import Times
from ._variational import augment, split
from .methods import (
    AdaptiveAdams,
    DormandPrince,
    Kind,
    Method,
    PeriodicOrbit,
    Quadrature,
    SerretAndoyerAtlas,
    SolveIVP,
    Taylor,
)
from .solution import STATUS, Failure, Solution, Status, run_stats

#: The cores a batch is spread over by default (read once: ``os.cpu_count`` reads the system's files each time).
CORES = os.cpu_count() or 1


@dataclasses.dataclass(eq=False, repr=False)
class Prepared:
    """A system and a method made ready to solve, with the times, the tolerances and the options: what
    :func:`~geomech.integrators.prepare` returns (it checks the arguments and fills these fields; build one through
    it). :meth:`solve` runs it from an initial state with the parameters' values. Reusable and independent of
    earlier calls: each call is the run :func:`~geomech.integrators.solve` makes with the same arguments.

    Attributes
    ----------
    system, method, problem :
        The system as given, the method value, and the system's view for the integrators (with its torque law
        bound, for a body with rotors).
    times : Times
        The output times and, for a fixed-step method, the step grid.
    t0, t_final, attitude, backend, tolerances, newton_tol, max_newton, threads, max_events, max_steps, \
max_evaluations, memory_limit, raise_on_failure :
        The options, checked.
    lagrangian :
        A Lagrangian system's prepared engine (``PreparedLagrangian``), or None.
    compiled_events, wrt, constants, module, used :
        The compiled events, the names the sensitivities are taken with respect to, a fixed-step method's
        constants for its loop, the compiled model and its back end (``"numba"`` or ``"python"``).
    """

    system: Any
    method: Method
    problem: Problem
    times: Times
    t0: float
    t_final: float
    attitude: bool
    backend: str
    tolerances: tuple[float, float] | None
    newton_tol: float
    max_newton: int
    threads: int | None
    max_events: int
    max_steps: Any
    max_evaluations: Any
    memory_limit: float
    raise_on_failure: bool
    lagrangian: Any = None
    compiled_events: Any = None
    wrt: tuple[str, ...] | None = None
    constants: np.ndarray | None = None
    module: Any = None
    used: str = "python"
    #: the single runs' compiled loops bound to their buffers (:class:`~._runners.BoundRun`), by parameter values and
    #: state width: the next single run of an adaptive compiled method starts there
    bound: dict = dataclasses.field(default_factory=dict, init=False, repr=False)

    def __repr__(self) -> str:
        return (
            f"Prepared({self.problem.name}, {self.method!r}, t0={self.t0:g}, t_final={self.t_final:g}, "
            f"{len(self.times.t)} outputs)"
        )

    def solve(
        self,
        *,
        y0: Any = None,
        m0: Any = None,
        R0: Any = None,
        q0: Any = None,
        qdot0: Any = None,
        rdot0: Any = None,
        p0: Any = None,
        Gamma0: Any = None,
        gamma0: Any = None,
        g0: Any = None,
        parameters: Any = None,
    ) -> Solution:
        """Run from the initial state(s) with the values of ``parameters``: the arguments as :func:`solve`'s (leading
        axes a batch); ``R0`` where the problem was prepared with ``attitude=True``, and only then."""
        problem, method, system, times, t0 = self.problem, self.method, self.system, self.times, self.t0
        if R0 is not None and problem.kind not in ("lie_poisson", "rotor"):
            raise InputError(
                f"`R0` applies to left-invariant systems on T*SO(3) and bodies with rotors; {problem.name} is neither."
            )
        if (R0 is not None) != self.attitude:
            raise InputError(
                f"This problem was prepared with attitude={self.attitude}: "
                + (
                    "give `R0`, the initial attitude."
                    if self.attitude
                    else "prepare it with attitude=True to give `R0`."
                )
            )
        if problem.kind != "rotor":
            for name, value in (("Gamma0", Gamma0), ("gamma0", gamma0)):
                if value is not None:
                    raise InputError(f"`{name}` applies to bodies with rotors; {problem.name} is not one.")
        if problem.kind != "group" and g0 is not None:
            raise InputError(
                f"`g0` is the start of a body velocity on a group (a GroupFlow); {problem.name} is not one"
                + (" (its group coordinates are part of `q0`)." if problem.kind == "lagrangian" else ".")
            )
        if problem.kind == "group":
            given = (("y0", y0), ("m0", m0), ("q0", q0), ("qdot0", qdot0), ("rdot0", rdot0), ("p0", p0))
            for name, value in given + (("parameters", parameters),):
                if value is not None:
                    raise InputError(group_start(problem, system, name))
            from ._group_flow import solve_group_flow

            solution = solve_group_flow(
                system,
                method,
                times,
                t0=t0,
                g0=g0,
                tolerances=self.tolerances,
                max_evaluations=MAX_EVALUATIONS if self.max_evaluations is None else self.max_evaluations,
                memory_limit=self.memory_limit,
                backend=self.backend,
            )
            return finish(solution, self.raise_on_failure)
        if problem.kind == "lagrangian":
            for name, value in (("y0", y0), ("m0", m0)):
                if value is not None:
                    raise InputError(
                        f"{problem.name} is a Lagrangian system: give its initial state as `q0` with `qdot0`, or "
                        f"with `rdot0` and `p0`; not `{name}`."
                    )
            solution = self.lagrangian.solve(q0=q0, qdot0=qdot0, rdot0=rdot0, p0=p0, parameters=parameters)
            return finish(solution, self.raise_on_failure)
        for name, value in (("q0", q0), ("qdot0", qdot0), ("rdot0", rdot0), ("p0", p0)):
            if value is not None:
                raise InputError(f"`{name}` applies to Lagrangian systems on G x S; {problem.name} is not one.")
        if problem.kind == "rotor":
            if y0 is not None:
                raise InputError(
                    f"{problem.name} is a body with rotors: give its initial state as `m0` and `Gamma0` (with `R0` "
                    "and `gamma0`), not `y0`."
                )
            Y0, batch_shape = rotor_initial_states(problem, m0, R0, Gamma0, gamma0, t0)
        else:
            Y0, batch_shape = initial_states(problem, y0, m0, R0)
        swept, swept_shape = parameter_batch(problem, method, parameters)
        if swept:
            try:
                full = np.broadcast_shapes(batch_shape, swept_shape)
            except ValueError:
                raise InputError(
                    f"Expected the batch of initial states {batch_shape} and of `parameters` {swept_shape} to "
                    "broadcast."
                ) from None
            Y0 = np.broadcast_to(Y0.reshape(batch_shape + Y0.shape[1:]), full + Y0.shape[1:]).reshape(-1, Y0.shape[1])
            Y0, batch_shape = Y0.copy(), full
            swept = {k: np.broadcast_to(v, full).reshape(-1) for k, v in swept.items()}
        wrt = self.wrt
        d_state = Y0.shape[1]
        if wrt is not None:
            Y0 = augment(Y0, len(wrt))
        B, d = Y0.shape
        if method.kind is Kind.FIXED_STEP:
            V.work_budget(
                float(B) * times.n_steps,
                float(self.max_steps),
                f"The number of steps ({times.n_steps:.3g} of {B} trajectory(ies))",
                "max_steps",
                "take a larger h or a shorter span",
                seconds_each=1e-7,
            )
        V.memory_budget(
            float(B) * times.n_kernel_saved * (d + 1),
            float(self.memory_limit),
            f"Keeping {times.n_kernel_saved:.3g} states of {B} trajectory(ies)",
            "memory_limit",
            "save fewer times (`saveat`)",
        )
        if method.kind is Kind.FIXED_STEP:
            saved_steps = times.kernel_steps()
            saved_t = t0 + float(times.h) * saved_steps.astype(float)  # type: ignore[arg-type]
        else:
            saved_t = times.t
            saved_steps = np.arange(len(saved_t))
        OUT = np.empty((B, len(saved_steps), d))
        INFO = np.zeros((B, INFO_COLUMNS))
        module, used = self.module, self.used
        if swept and used != "numba":
            raise InputError(
                f"A batch of `parameters` runs in the compiled loops, which {problem.name} cannot use here (backend "
                f"{self.backend!r}, or numba missing): give one value per parameter."
            )
        # the parameter values: one row for all trajectories, or one per trajectory for a batch of them
        PRM = problem.parameter_rows(swept) if swept else np.ascontiguousarray(problem.prm[None, :])
        compiled_events = self.compiled_events
        max_events = self.max_events
        event_rows: dict[str, np.ndarray] = {}
        if compiled_events is not None:
            V.memory_budget(
                float(B) * max_events * (d + 2),
                float(self.memory_limit),
                f"Recording {max_events} events of {B} trajectory(ies)",
                "memory_limit",
                "lower `max_events`",
            )
        tolerances, tol, max_newton, threads = self.tolerances, self.newton_tol, self.max_newton, self.threads
        compile_time = 0.0
        loop_time: float | None = None  # the compiled loop's seconds, where there is one
        t_start = time.perf_counter()
        reasons: dict[int, str] = {}
        reached: dict[int, float] = {}
        along: dict[str, np.ndarray] = {}
        switches = np.zeros((0, 4))
        shown = None  # the observation of the states, where a bound run made it
        if isinstance(method, SerretAndoyerAtlas):
            assert tolerances is not None
            switches, along = run_atlas(problem, method, Y0, t0, saved_t, tolerances, OUT, INFO, reasons, reached)
            internal = 0
        elif isinstance(method, SolveIVP):
            assert tolerances is not None
            budget = MAX_EVALUATIONS if self.max_evaluations is None else self.max_evaluations
            ivp_args = (module, PRM, method, Y0, t0, saved_t, tolerances, budget, OUT, INFO, reasons, reached)
            internal, EVT, ECOUNT = run_ivp(*ivp_args, compiled_events, max_events)
            if compiled_events is not None:
                event_rows = event_table(compiled_events, EVT, ECOUNT, problem.timed, max_events)
        elif isinstance(method, (DormandPrince, Taylor)):
            assert tolerances is not None
            # a single run without events: from its loop bound to its buffers, where an earlier run left it
            bind: list | None = [] if B == 1 and compiled_events is None and self.used == "numba" else None
            key = (PRM.tobytes(), d)
            # a body with rotors' observation of the states (its energy and torques) bound too, where compiled
            observation = (
                (lambda kept: problem.bound_observation(kept.OUT[0], np.ascontiguousarray(PRM[:1]).copy()))
                if wrt is None and problem.kind == "rotor"
                else None
            )
            done = None if bind is None else from_bound(self.bound, key, Y0[0], observation)
            if done is not None:
                OUT, INFO, loop_time, shown = done
                internal = int(INFO[0, 6])
            else:
                internal, compile_time, loop_time, event_rows = self._adaptive(
                    method, system, PRM, Y0, saved_t, OUT, INFO, reasons, reached, bind
                )
                OUT, INFO = keep_bound(self.bound, key, bind, OUT, INFO)  # (the next single run starts there)
                t_start += compile_time
        elif isinstance(method, AdaptiveAdams):
            assert tolerances is not None
            with np.errstate(all="ignore"):
                internal = run_adaptive(module, PRM, method, Y0, t0, saved_t, tolerances, OUT, INFO)
        elif isinstance(method, (PeriodicOrbit, Quadrature)):
            internal, compile_time = run_periodic(problem.core, method, Y0, saved_t - t0, OUT, INFO, reasons)
            t_start += compile_time
        else:
            # a fixed-step method: prepare() has its kernel's name and constants
            assert method.kernel is not None and self.constants is not None
            calls = _codegen.model_functions(method.kernel)
            P = np.ascontiguousarray(self.constants, dtype=float)
            h_step, nsteps, every = float(times.h), int(times.n_steps), int(times.save_every)  # type: ignore[arg-type]
            tol_, maxit = float(tol), int(max_newton)
            # the loop's arrays of one kind at every call (its C entry takes C-contiguous float64 arrays)
            Y0, PRM = np.ascontiguousarray(Y0, dtype=float), np.ascontiguousarray(PRM, dtype=float)
            FP = module.addresses(calls) if module.ready(calls) else None
            if used == "numba":
                # the loop's C entry where it has one, else numba's kernel; the first call compiles (or loads from
                # the caches) the model's C functions and, once for all models, the loop: timed apart on a
                # one-step problem
                first = FP is None
                FP = module.addresses(calls) if FP is None else FP
                kern = getattr(module, method.kernel)

                def warm_up() -> None:
                    kern(
                        FP, Y0[:1].copy(), h_step, 1, 1, np.empty((1, 2, d)), np.zeros((1, 5)), tol_, maxit, P, PRM[:1]
                    )

                probe = (FP, Y0[:1], h_step, nsteps, every, OUT[:1], INFO[:1], tol_, maxit, P, PRM[:1])
                try:
                    kern, seconds = loop_of(module, method.kernel, probe, warm_up)
                    first = first or seconds > 0.0
                except Exception as exc:
                    from numba.core.errors import NumbaError

                    # a function sympy prints but numba cannot compile: the same loop in Python, from now on
                    if self.backend == "numba" or not isinstance(exc, NumbaError):
                        raise
                    module, used = problem.module(frozenset(method.features & {"gf", "split"}), "python")
                    self.module, self.used = module, used
                    kern = getattr(module, method.kernel)
                    FP = module.addresses(calls)
                    first = True  # the failed compilation's time apart
                if first:
                    compile_time = time.perf_counter() - t_start
                    t_start = time.perf_counter()
            else:
                kern = getattr(module, method.kernel)
                FP = module.addresses(calls) if FP is None else FP
            n_threads = threads if threads is not None else CORES
            if used != "numba" or B < 2 or B * nsteps < 20_000:
                n_threads = 1
            with np.errstate(all="ignore"):  # the Python backend's overflow is detected as a non-finite state
                loop_time = run_compiled(
                    kern, FP, Y0, h_step, nsteps, every, OUT, INFO, tol_, maxit, P, PRM, int(n_threads)
                )
            internal = B * nsteps
        run_time = time.perf_counter() - t_start

        failures = []
        for b in failed_rows(INFO):
            step = int(INFO[b, 1])
            if method.kind is Kind.FIXED_STEP:
                when = t0 + (step - 1) * float(times.h)  # type: ignore[arg-type]
            elif int(b) in reached:
                when = reached[int(b)]
            else:
                when = float(saved_t[max(step - 1, 0)])
            failures.append(
                Failure(
                    kind=STATUS.get(int(INFO[b, 0]), Status.NONFINITE),
                    batch_index=batch_index(int(b), batch_shape),
                    step=step,
                    time=when,
                    residual=float(INFO[b, 2]),
                    detail=reasons.get(int(b), ""),
                )
            )
        failures += left_chart(system, OUT, INFO, saved_steps, saved_t, batch_shape)
        pick = times.pick
        if pick is not None:
            OUT = OUT[:, pick]
        if problem.timed:
            OUT = OUT[..., :-1]  # the time, appended to the state for a torque law that reads it
        states = OUT.reshape(batch_shape + OUT.shape[1:])
        variational: dict[str, np.ndarray] = {}
        if wrt is not None:
            states, variational["stm"], sensitivity = split(states, d_state, len(wrt))
            if wrt:
                variational["parameter_sensitivity"] = sensitivity
        # a batch's quantities with each member's parameters; a body with rotors under a law of formulas, compiled,
        # has its energy and torques from them (generated once), not from the body's and the law's Python
        rows = None
        if swept:
            rows = PRM.reshape(batch_shape + PRM.shape[1:])
        elif problem.kind == "rotor" and problem.energy_expression is not None and used == "numba":
            rows = np.broadcast_to(PRM[0], batch_shape + PRM.shape[1:]) if batch_shape else PRM[0]
        inv = problem.invariants(states, times.t, rows, shown if rows is not None else None)
        inv.update({k: v.reshape(batch_shape + v.shape[1:]) for k, v in along.items()})
        inv.update(variational)
        status = failures[0].kind if failures else Status.SUCCESS
        name = type(method).__name__
        if failures:
            extra = f" ({len(failures)} of {B} trajectories failed)" if B > 1 else ""
            message = f"{name} on {problem.name}: {failures[0].describe()}{extra}."
            if failures[0].kind in (Status.NEWTON_FAILED, Status.SINGULAR_JACOBIAN):
                message += (
                    f" Reduce h (now {abs(float(times.h)):g}), or loosen newton_tol (now {tol:g}) / raise max_newton "  # type: ignore[arg-type]
                    f"(now {max_newton})."
                )
        elif method.kind is Kind.FIXED_STEP:
            message = f"{name}: {times.n_steps} steps of h = {abs(float(times.h)):g} from t = {t0:g}."  # type: ignore[arg-type]
        elif isinstance(method, Quadrature):
            message = (
                f"Quadrature: {len(saved_t)} outputs from t = {t0:g}, each from the time-of-flight integral along the "
                "level curve."
            )
        elif isinstance(method, PeriodicOrbit):
            message = (
                f"PeriodicOrbit: {len(saved_t)} outputs from t = {t0:g}, each from one stored period ({internal} mesh "
                "steps in all)."
            )
        elif isinstance(method, SerretAndoyerAtlas):
            message = (
                f"{name}: {len(saved_t)} outputs from t = {t0:g} to {self.t_final:g}, {len(switches)} chart switches."
            )
        else:
            message = f"{name}: {len(saved_t)} outputs from t = {t0:g} to {self.t_final:g}, {internal} internal steps."
        solution = Solution(
            t=times.t,
            states=states,
            system=system,
            method=method,
            layout=problem.layout,
            labels=problem.labels,
            quantities={k: v for k, v in inv.items() if v is not None},
            status=status,
            message=message,
            failures=tuple(failures),
            stats=run_stats(
                times.n_steps,
                internal,
                total(INFO, 4),
                run_time,
                n_newton=total(INFO, 3),
                backend=used,
                compile_time=compile_time,
                **({"chart_switches": len(switches)} if isinstance(method, SerretAndoyerAtlas) else {}),
                **({"loop_time": loop_time} if loop_time is not None and used == "numba" else {}),
            ),
            parameters={
                **dict(getattr(problem.core, "parameters", {}) or {}),
                **{k: v.reshape(batch_shape) for k, v in swept.items()},
            },
            events={"chart_switch": switches} if isinstance(method, SerretAndoyerAtlas) else event_rows,
        )
        return finish(solution, self.raise_on_failure)

    def _adaptive(
        self,
        method: DormandPrince | Taylor,
        system: Any,
        PRM: np.ndarray,
        Y0: np.ndarray,
        saved_t: np.ndarray,
        OUT: np.ndarray,
        INFO: np.ndarray,
        reasons: dict[int, str],
        reached: dict[int, float],
        bind: list | None,
    ) -> tuple[int, float, float, dict[str, np.ndarray]]:
        """The run of ``Y0`` by a compiled adaptive method into ``OUT`` and ``INFO``: (accepted steps, compile time,
        the loop's seconds, the events' rows); a single run given a list ``bind`` appends to it its loop bound to
        its buffers (its own copies of the start and the parameters)."""
        assert self.tolerances is not None
        B = Y0.shape[0]
        if bind is not None:
            Y0, PRM = Y0.copy(), PRM.copy()  # (the bound run writes its start into its own row)
        budget = MAX_EVALUATIONS_COMPILED if self.max_evaluations is None else self.max_evaluations
        threads = self.threads if self.threads is not None else (CORES if B > 1 else 1)
        common = (
            Y0,
            self.t0,
            saved_t,
            self.tolerances,
            V.positive_scalar(budget, "max_evaluations"),
            OUT,
            INFO,
            reasons,
            reached,
            int(threads) if B > 1 else 1,
            self.compiled_events,
            self.max_events,
        )
        if isinstance(method, Taylor):
            internal, compile_time, loop_time, EVT, ECOUNT = run_taylor(
                self.module, PRM, *common, system, method.compact, bind=bind
            )
        else:
            internal, compile_time, loop_time, EVT, ECOUNT = run_embedded(
                self.module, self.used, system, PRM, method, *common, bind=bind
            )
        rows = {}
        if self.compiled_events is not None:
            rows = event_table(self.compiled_events, EVT, ECOUNT, self.problem.timed, self.max_events)
        return internal, compile_time, loop_time, rows


def group_start(problem: Problem, system: Any, name: str) -> str:
    """What a body velocity on a group starts from, told to a call that gave ``name``."""
    return (
        f"{problem.name} is a body velocity on {system.group.name}: give its start as `g0` (an element or its "
        f"coordinates), not `{name}`."
    )


def finish(solution: Solution, raise_on_failure: bool) -> Solution:
    """``solution``, or its failure raised with the partial solution attached."""
    if solution.failures and raise_on_failure:
        failing = solution.status in (Status.NEWTON_FAILED, Status.ADAPTIVE_FAILED)
        cls = ConvergenceError if failing else NumericalError
        exc = cls(solution.message + " Pass raise_on_failure=False to get the partial solution instead.")
        exc.solution = solution  # type: ignore[attr-defined]
        raise exc
    return solution
