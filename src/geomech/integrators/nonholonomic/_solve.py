"""A Lagrangian system on G x S through :func:`~geomech.solve`: the initial state, the engine of the method,
and the :class:`~geomech.Solution` with the run's quantities (energy, nonholonomic momentum, shape forces,
work, constraint residual)."""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from ... import _validate as V
from ..._storage import remember
from ...errors import InputError
from ...reduction import bkmm_reduction
from .._adaptive import MAX_EVALUATIONS
from .._batch import batch_index
from .._events import compile_lagrangian_events, events_need_adaptive
from .._observe import observe
from .._times import Times
from .._variational import augment, named_sensitivities
from ..methods import BKMM, TAYLOR, DiscreteLagrangeDAlembert, LagrangeDAlembert, Method, NonholonomicHamilton
from ..solution import Failure, Solution, Status, run_stats
from ._compiled import COMPILED_SOLVERS, bkmm_module, bkmm_slots, compiled_pair
from ._continuous import VARIATIONAL_NEEDS, run_compiled, run_full, run_reduced
from ._discrete import run_discrete
from ._hamiltonian import run_hamiltonian
from ._inputs import (
    _by_name,
    _require_positive_kinetic_energy,
    _setup,
    check_parameter_names,
    initial_state_of,
    scalar_values,
)
from ._trajectory import quantities, spatial_momentum

#: Default ceiling on steps of the discrete Lagrange-d'Alembert integrator (a Python loop, about 0.2 ms a step).
MAX_DISCRETE_STEPS = 1_000_000


@dataclasses.dataclass(eq=False)
class _Made:
    """What a prepared Lagrangian problem keeps for one set of coefficients' values: the set-up (the gait and torques
    as functions), the names the sensitivities are taken with respect to (None for none), and the system's
    parameter values by name (None until a run of one trajectory asks for them)."""

    setup: Any
    wrt: tuple | None
    values: dict[str, float] | None = None


class PreparedLagrangian:
    """A Lagrangian system on G x S with one of the Lagrangian methods, the times and the options, ready for
    :meth:`solve` from initial states with the parameters' values (internal: :class:`~geomech.integrators.Prepared`
    has checked the method and the times). The gait and torques are made into functions once for each distinct
    values of their coefficients."""

    def __init__(
        self,
        system: Any,
        method: Method,
        times: Times,
        *,
        t0: float,
        shapes: Any,
        tau: Any,
        tolerances: tuple[float, float] | None,
        max_steps: Any,
        max_evaluations: Any,
        memory_limit: float,
        newton_tol: float,
        max_newton: int,
        backend: str = "auto",
        threads: int | None = None,
        events: Any = None,
        max_events: int = 1000,
        sensitivities: Any = None,
    ) -> None:
        if events is not None and not isinstance(method, (BKMM, LagrangeDAlembert, NonholonomicHamilton)):
            raise InputError(events_need_adaptive(system.name) + f" Got {method!r}.")
        self.system, self.method, self.times, self.t0 = system, method, times, t0
        # the gait, torques and events as given now (copies of mappings: what each call makes from them is kept)
        self.shapes = dict(shapes) if isinstance(shapes, Mapping) else shapes
        self.tau = dict(tau) if isinstance(tau, Mapping) else tau
        self.tolerances = tolerances
        self.max_steps, self.max_evaluations, self.memory_limit = max_steps, max_evaluations, memory_limit
        self.newton_tol, self.max_newton, self.backend, self.threads = newton_tol, max_newton, backend, threads
        self.events = dict(events) if isinstance(events, Mapping) else events
        self.max_events, self.sensitivities = max_events, sensitivities
        self._setups: dict[tuple, _Made] = {}
        self.labels = tuple(q.name for q in system.q) + tuple(q.name for q in system.qdot)

    def setup(self, parameters: Mapping[str, Any] | None) -> _Made:
        """The gait and torques made into functions with the values in ``parameters`` (a batch's first member's; the
        compiled loop reads every member's) and checked against the names the system and its formulas know, with
        the names of the sensitivities: made once for each distinct values (the last 16 kept)."""
        key = tuple(sorted(scalar_values(parameters).items()))
        made = self._setups.get(key)
        if made is None:
            setup = _setup(self.system, self.shapes, self.tau, parameters)
            check_parameter_names(setup, parameters)
            made = _Made(setup, _sensitivity_names(setup, self.method, self.backend, self.events, self.sensitivities))
            remember(self._setups, key, made, 16)  # (the oldest dropped first)
        return made

    def solve(self, *, q0: Any, qdot0: Any, rdot0: Any, p0: Any, parameters: Mapping[str, Any] | None) -> Solution:
        """One run (or a batch: arrays in ``parameters``, initial states with leading axes) from ``q0`` with
        ``qdot0``, or with ``rdot0`` and ``p0``."""
        system, method, times, t0 = self.system, self.method, self.times, self.t0
        tolerances, max_evaluations, backend, events = self.tolerances, self.max_evaluations, self.backend, self.events
        max_events, newton_tol, max_newton = self.max_events, self.newton_tol, self.max_newton
        made = self.setup(parameters)
        setup, wrt = made.setup, made.wrt
        shape = _batch_shape(parameters, q0, rdot0, p0)
        if shape is not None:
            return _solve_batch(
                setup,
                method,
                times,
                shape,
                t0=t0,
                q0=q0,
                qdot0=qdot0,
                rdot0=rdot0,
                p0=p0,
                parameters=parameters,
                tolerances=tolerances,
                max_evaluations=max_evaluations,
                memory_limit=self.memory_limit,
                backend=backend,
                threads=self.threads,
                events=events,
                max_events=max_events,
                wrt=wrt,
            )
        # BKMM's state holds the momentum, not the group's velocities
        q_init, qd_init, p_init = initial_state_of(
            setup, t0, q0, rdot0, p0, qdot0, parameters, group_velocity=not isinstance(method, BKMM)
        )
        h = times.h
        if isinstance(method, DiscreteLagrangeDAlembert):
            assert h is not None  # a fixed-step method: solve() has set the step
            limit = MAX_DISCRETE_STEPS if self.max_steps == V.MAX_STEPS else self.max_steps
            V.work_budget(
                float(times.n_steps),
                float(limit),
                f"The number of steps ({times.n_steps:.3g} of h = {abs(h):.3g})",
                "max_steps",
                "take a larger h or a shorter span",
                seconds_each=2e-4,
            )
        n_values = float(times.n_saved) * (3 * system.n + system.sigma + system.c + 4)
        V.memory_budget(
            n_values,
            float(self.memory_limit),
            f"Keeping {times.n_saved:.3g} states",
            "memory_limit",
            "save fewer times (`saveat`)",
        )
        start = time.perf_counter()
        if isinstance(method, DiscreteLagrangeDAlembert):
            assert h is not None
            raw = run_discrete(
                setup,
                q_init,
                qd_init,
                t0,
                h,
                times.n_steps,
                newton_tol,
                max_newton,
                parameters,
                method.discretization,
                backend,
                times.kernel_steps() if times.k is None else times.k,
            )
            n_rhs, internal = 0, raw.nfev
        else:
            assert isinstance(method, (LagrangeDAlembert, BKMM, NonholonomicHamilton)) and tolerances is not None
            budget = MAX_EVALUATIONS if max_evaluations is None else max_evaluations
            if isinstance(method, NonholonomicHamilton):
                raw = run_hamiltonian(
                    setup, q_init, qd_init, t0, times.t, method, tolerances, budget, parameters, events, max_events
                )
            else:  # the two that run compiled: the equations with multipliers, or BKMM's
                args = (setup, q_init, qd_init, t0, times.t, method, tolerances, max_evaluations, parameters, backend)
                if isinstance(method, LagrangeDAlembert):
                    raw = run_full(*args, events, max_events)
                else:
                    raw = run_reduced(*args, events, max_events, wrt, p_init)
            n_rhs, internal = raw.nfev, raw.steps
        run_time = time.perf_counter() - start
        extra: dict[str, Any] = {} if raw.loop_time is None else {"loop_time": raw.loop_time}
        failures: tuple[Failure, ...] = () if raw.failure is None else (raw.failure,)
        name = type(method).__name__
        if failures:
            message = f"{name} on {system.name}: {failures[0].describe()}."
        elif times.h is not None:
            message = f"{name}: {times.n_steps} steps of h = {abs(times.h):g} from t = {t0:g}."
        else:
            message = (
                f"{name} ({getattr(method, 'solver', '')}): {len(times.t)} outputs from t = {t0:g} to {times.t[-1]:g}."
            )
        qv = np.concatenate([raw.q, raw.qd], axis=1)
        if made.values is None:
            made.values = {k.name: float(v) for k, v in system.parameter_values(parameters).items()}
        return Solution(
            t=times.t,
            states=qv,
            system=system,
            method=method,
            layout="qv",
            labels=self.labels,
            quantities={
                key: v
                for key, v in quantities(setup, raw, parameters).items()
                if key != "work" or not isinstance(method, BKMM) or method.work
            },
            status=failures[0].kind if failures else Status.SUCCESS,
            message=message,
            failures=failures,
            stats=run_stats(
                times.n_steps,
                internal,
                n_rhs,
                run_time - raw.compile_time,
                n_newton=raw.newton,
                backend=raw.backend,
                compile_time=raw.compile_time,
                **extra,
            ),
            parameters=dict(made.values),
            group_dim=system.k,
            events=raw.events,
        )


def _sensitivity_names(setup: Any, method: Method, backend: str, events: Any, sensitivities: Any) -> tuple | None:
    """The names of ``sensitivities`` (True: the initial state only), checked against what can be differentiated:
    the system's parameters and the gait's and torques' coefficients; None for no variational equations."""
    if sensitivities is None or sensitivities is False:
        return None
    if (
        not isinstance(method, BKMM)
        or method.solver not in COMPILED_SOLVERS
        or backend == "python"
        or events is not None
    ):
        raise InputError(VARIATIONAL_NEEDS + f" Got {method!r} with backend {backend!r}.")
    known = [q.name for q in setup.system.parameter_symbols] + list(setup.coefficients)
    owner = f"the parameters of {setup.system.name} and of its gait's and torques' coefficients"
    return named_sensitivities(sensitivities, known, owner)


def _batch_shape(parameters: Mapping[str, Any] | None, q0: Any, rdot0: Any, p0: Any) -> tuple[int, ...] | None:
    """The batch of a run (the broadcast shape of the arrays in ``parameters`` and of the leading axes of ``q0``,
    ``rdot0``, ``p0`` given as arrays), or None for one trajectory."""
    shapes = {f"parameters[{k!r}]": np.shape(v) for k, v in (parameters or {}).items() if np.ndim(v) > 0}
    for name, value in (("q0", q0), ("rdot0", rdot0), ("p0", p0)):
        if value is not None and not isinstance(value, Mapping) and np.ndim(value) > 1:
            shapes[name] = np.shape(value)[:-1]
    if not shapes:
        return None
    try:
        return tuple(np.broadcast_shapes(*shapes.values()))
    except ValueError:
        raise InputError(
            "Expected the batches to broadcast: " + ", ".join(f"{k} {v}" for k, v in shapes.items()) + "."
        ) from None


def _rows(value: Any, names: list[str], argname: str, shape: tuple[int, ...]) -> np.ndarray:
    """An initial value for every member of a batch, ``(B, len(names))``: a mapping by name (zero where not given)
    or an array with the batch's leading axes (or none)."""
    if value is None or isinstance(value, Mapping):
        row = np.array([_by_name(value, names, argname).get(n, 0.0) for n in names])
        return np.broadcast_to(row, shape + (len(names),)).reshape(int(np.prod(shape)), len(names))
    arr = V.finite(value, argname)
    if arr.shape[-1:] != (len(names),):
        raise InputError(
            f"Expected `{argname}` to have {len(names)} entries ({names}) on its last axis, got {arr.shape}."
        )
    return np.broadcast_to(arr, shape + (len(names),)).reshape(int(np.prod(shape)), len(names))


def _solve_batch(
    setup: Any,
    method: Method,
    times: Times,
    shape: tuple[int, ...],
    *,
    t0: float,
    q0: Any,
    qdot0: Any,
    rdot0: Any,
    p0: Any,
    parameters: Mapping[str, Any] | None,
    tolerances: tuple[float, float] | None,
    max_evaluations: Any,
    memory_limit: float,
    backend: str,
    threads: int | None,
    events: Any = None,
    max_events: int = 1000,
    wrt: tuple[str, ...] | None = None,
) -> Solution:
    """A batch of trajectories (over initial states, the system's parameters and the coefficients of the gait and
    torques) in one call of the compiled BKMM loop, across threads (with ``wrt``, their variational equations)."""
    system = setup.system
    compiled = None
    taylor = isinstance(method, BKMM) and method.solver == TAYLOR
    if isinstance(method, BKMM) and backend != "python" and (taylor or compiled_pair(method.solver) is not None):
        red = bkmm_reduction(system)
        compiled = bkmm_module(setup, red, taylor, wrt, method.work)
    if compiled is None:
        raise InputError(
            f"A batch (arrays in `parameters`, or initial states with leading axes) of {system.name} runs in the "
            f"compiled BKMM loops: method BKMM with solver 'DOP853', 'RK45' or 'taylor', the gait and torques as "
            "formulas, numba "
            f"installed, backend 'auto' or 'numba'; got {method!r} with backend {backend!r}. Give one value each, or "
            "loop over the members."
        )
    assert isinstance(method, BKMM)
    if qdot0 is not None:
        raise InputError(
            "In a batch, give the initial state by `q0`, `rdot0` and `p0` (the nonholonomic momentum), not `qdot0`: "
            "the group velocity then follows from eq. (1.1) for each member."
        )
    assert tolerances is not None
    module, made = compiled
    B = int(np.prod(shape))
    k, m = system.k, red.m
    F = setup.free_shapes
    n_values = float(B) * times.n_saved * (3 * system.n + system.sigma + system.c + 4)
    V.memory_budget(
        n_values,
        float(memory_limit),
        f"Keeping {times.n_saved:.3g} states of {B} trajectories",
        "memory_limit",
        "save fewer times (`saveat`), or split the batch",
    )
    values: dict[str, Any] = {**system.parameters, **dict(parameters or {})}
    missing = sorted(n for n in made.parameters + made.coefficients if n not in values)
    if missing:
        raise InputError(f"{system.name}: no value for {missing}; pass them in `parameters`.")
    arrays = {}
    for name in made.parameters + made.coefficients:
        arr = V.finite(values[name], f"parameters[{name!r}]")
        arrays[name] = np.broadcast_to(arr, shape).reshape(-1) if arr.ndim else arr
    PRM = made.rows(arrays, B)
    Q = _rows(q0, [q.name for q in system.q], "q0", shape)
    RD = _rows(rdot0, [r.name for r in system.shape], "rdot0", shape)
    P = _rows(p0, [f"p{i}" for i in range(m)], "p0", shape) if p0 is None or not isinstance(p0, Mapping) else None
    if P is None:
        raise InputError(f"Expected `p0` as numbers or an array (..., {m}), got a mapping.")
    Y0 = np.concatenate([Q[:, :k], Q[:, [k + j for j in F]], RD[:, F], P, np.zeros((B, 1))], axis=1)
    if wrt is not None:
        Y0 = augment(Y0, len(wrt))  # Phi = I, S = 0
    # each member's configuration at t0 (its prescribed shapes from its gait), checked as one trajectory is
    start, observe_compile = observe(module, made, np.concatenate([Y0, np.full((B, 1), float(t0))], axis=1), PRM, 1)
    _require_positive_kinetic_energy(system, start[:, : system.n], arrays, members=f" {shape}")
    n_threads = threads if threads is not None else (os.cpu_count() or 1)
    compiled_events = None if events is None else compile_lagrangian_events(setup, made, bkmm_slots(setup, m), events)
    run = run_compiled(
        module,
        made,
        PRM,
        Y0,
        t0,
        times.t,
        method,
        tolerances,
        max_evaluations,
        int(n_threads),
        compiled_events,
        max_events,
    )
    n, sigma, c = system.n, system.sigma, system.c
    W = run.observed
    k_p = k + 2 * len(F)
    quantities = {
        "energy": W[..., 2 * n + sigma],
        "momentum": run.states[..., k_p : k_p + m],
        "tau": W[..., 2 * n : 2 * n + sigma],
        **({"work": run.states[..., -1]} if method.work else {}),
        "constraint_residual": W[..., 2 * n + sigma + 1 : 2 * n + sigma + 1 + c],
        **run.variational,
    }
    if c == 0:
        quantities["spatial_momentum"] = spatial_momentum(system, W[..., :n], quantities["momentum"])
    failures = tuple(dataclasses.replace(f, batch_index=batch_index(b, shape)) for b, f in run.failures)
    name = type(method).__name__
    if failures:
        message = f"{name} on {system.name}: {failures[0].describe()} ({len(failures)} of {B} trajectories failed)."
    else:
        message = (
            f"{name} ({method.solver}): {B} trajectories, {len(times.t)} outputs from t = {t0:g} to {times.t[-1]:g}."
        )
    batch = lambda x: x.reshape(shape + x.shape[1:])  # noqa: E731
    return Solution(
        t=times.t,
        states=batch(W[..., : 2 * n]),
        system=system,
        method=method,
        layout="qv",
        labels=tuple(s.name for s in system.q) + tuple(s.name for s in system.qdot),
        quantities={key: batch(v) for key, v in quantities.items()},
        status=failures[0].kind if failures else Status.SUCCESS,
        message=message,
        failures=failures,
        stats=run_stats(
            times.n_steps,
            run.steps,
            run.nfev,
            run.loop_time,
            backend="numba",
            compile_time=run.compile_time + observe_compile,
            loop_time=run.loop_time,
        ),
        parameters={key: (v.reshape(shape) if v.ndim else float(v)) for key, v in arrays.items()},
        group_dim=system.k,
        events=run.events,
    )
