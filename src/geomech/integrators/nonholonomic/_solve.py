"""A Lagrangian system on G x S through :func:`~geomech.solve`: the initial state, the engine of the method,
and the :class:`~geomech.Solution` with the run's quantities (energy, nonholonomic momentum, shape forces,
work, constraint residual)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from ... import _validate as V
from .._adaptive import MAX_EVALUATIONS
from .._times import Times
from ..methods import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert, Method
from ..solution import Failure, Solution, Status, run_stats
from ._continuous import run_full, run_reduced
from ._discrete import run_discrete
from ._inputs import _setup, initial_state
from ._trajectory import quantities

#: Default ceiling on steps of the discrete Lagrange-d'Alembert integrator (a Python loop, about 0.2 ms a step).
MAX_DISCRETE_STEPS = 1_000_000


def solve_lagrangian(
    system: Any,
    method: Method,
    times: Times,
    *,
    t0: float,
    q0: Any,
    qdot0: Any,
    rdot0: Any,
    p0: Any,
    shapes: Any,
    tau: Any,
    parameters: Mapping[str, float] | None,
    tolerances: tuple[float, float] | None,
    max_steps: Any,
    max_evaluations: Any,
    memory_limit: float,
    newton_tol: float,
    max_newton: int,
    backend: str = "auto",
) -> Solution:
    """Integrate a :class:`~geomech.systems.NonholonomicSystem` with one of the Lagrangian methods (internal:
    :func:`~geomech.solve` has checked the method and the times)."""
    setup = _setup(system, shapes, tau)
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qdot0=qdot0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    h = times.h
    if isinstance(method, DiscreteLagrangeDAlembert):
        assert h is not None  # a fixed-step method: solve() has set the step
        limit = MAX_DISCRETE_STEPS if max_steps == V.MAX_STEPS else max_steps
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
        float(memory_limit),
        f"Keeping {times.n_saved:.3g} states",
        "memory_limit",
        "save fewer times (`saveat`)",
    )
    start = time.perf_counter()
    if isinstance(method, DiscreteLagrangeDAlembert):
        assert h is not None
        raw = run_discrete(setup, q_init, qd_init, t0, h, times.n_steps, newton_tol, max_newton, parameters)
        keep = times.kernel_steps() if times.k is None else times.k
        steps_done = raw.nfev
        raw.q, raw.qd, raw.tau, raw.work = raw.q[keep], raw.qd[keep], raw.tau[keep], raw.work[keep]
        if raw.residual is not None:
            raw.residual = raw.residual[keep]
        n_rhs, internal = 0, steps_done
    else:
        assert isinstance(method, (LagrangeDAlembert, BKMM)) and tolerances is not None
        if isinstance(method, LagrangeDAlembert):
            budget = MAX_EVALUATIONS if max_evaluations is None else max_evaluations
            raw = run_full(setup, q_init, qd_init, t0, times.t, method, tolerances, budget, parameters)
        else:
            raw = run_reduced(
                setup, q_init, qd_init, t0, times.t, method, tolerances, max_evaluations, parameters, backend
            )
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
    return Solution(
        t=times.t,
        states=qv,
        system=system,
        method=method,
        layout="qv",
        labels=tuple(s.name for s in system.q) + tuple(s.name for s in system.qdot),
        quantities=quantities(setup, raw, parameters),
        status=failures[0].kind if failures else Status.SUCCESS,
        message=message,
        failures=failures,
        stats=run_stats(
            times.n_steps,
            internal,
            n_rhs,
            run_time - raw.compile_time,
            backend=raw.backend,
            compile_time=raw.compile_time,
            **extra,
        ),
        parameters={k.name: float(v) for k, v in system.parameter_values(parameters).items()},
        group_dim=system.k,
    )
