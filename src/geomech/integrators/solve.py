"""``solve(system, method, ...)``: one entry point for every integrator (as diffrax's ``diffeqsolve``)."""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import ConvergenceError, InputError, NumericalError
from ._adaptive import run_adaptive
from ._problem import Problem, make_problem
from .methods import (
    REGISTRY,
    AdaptiveAdams,
    IncompatibleMethodError,
    Method,
    PeriodicOrbit,
    Quadrature,
    get_method,
)
from .solution import STATUS, Failure, Solution

__all__ = ["solve", "compatible_methods"]


def compatible_methods(system: Any, *, attitude: bool = False) -> list[str]:
    """Keys of the registered methods that can integrate ``system``."""
    problem = make_problem(system, attitude=attitude)
    return [k for k, m in REGISTRY.items() if _why_not(problem, m) is None]


def _why_not(problem: Problem, method: Method) -> str | None:
    if not problem.has(method.structure):
        return problem.missing[method.structure]
    if method.needs_expression and problem.expression is None:
        return f"{type(method).__name__} differentiates H symbolically, and {problem.name} has no formula"
    return None


def _check_compatible(problem: Problem, method: Method) -> None:
    why = _why_not(problem, method)
    if why is None:
        return
    fits = [k for k, m in REGISTRY.items() if _why_not(problem, m) is None]
    raise IncompatibleMethodError(
        f"{method!r} needs a system with structure '{method.structure.value}', and {problem.name} "
        f"({type(problem.system).__name__}) does not have it: {why}. Methods that apply to this system: "
        f"{', '.join(fits)}."
    )


def _initial_states(problem: Problem, y0: Any, m0: Any, R0: Any) -> tuple[np.ndarray, tuple[int, ...]]:
    if problem.kind == "canonical":
        if m0 is not None or R0 is not None:
            raise InputError(
                f"{problem.name} is a canonical system: give its initial state as `y0` = (q, p), not `m0`/`R0`."
            )
        if y0 is None:
            raise InputError(f"Expected `y0`, the initial (q, p) of {problem.name} (shape (..., {problem.dim})).")
        Y = V.trailing_shape(y0, "y0", (problem.dim,))
        return Y.reshape(-1, problem.dim).copy(), Y.shape[:-1]
    if y0 is not None:
        raise InputError(
            f"{problem.name} is a left-invariant system: give the body momentum as `m0` (shape (..., 3)) and, to "
            "integrate the attitude too, `R0` (shape (..., 3, 3)); not `y0`."
        )
    if m0 is None:
        raise InputError(f"Expected `m0`, the initial body angular momentum of {problem.name} (shape (..., 3)).")
    m = V.trailing_shape(m0, "m0", (3,))
    if R0 is None:
        return m.reshape(-1, 3).copy(), m.shape[:-1]
    R = V.rotation_matrix(R0, "R0")
    try:
        shape = np.broadcast_shapes(m.shape[:-1], R.shape[:-2])
    except ValueError:
        raise InputError(
            f"Expected `m0` (batch {m.shape[:-1]}) and `R0` (batch {R.shape[:-2]}) to have broadcastable batch shapes."
        ) from None
    m = np.broadcast_to(m, shape + (3,))
    R = np.broadcast_to(R, shape + (3, 3))
    Y = np.concatenate([m, R.reshape(shape + (9,))], axis=-1)
    return Y.reshape(-1, 12).copy(), shape


def _steps(h: Any, t0: Any, t_final: Any, n_steps: Any) -> tuple[float, float, int]:
    h = V.positive_scalar(h, "h")
    t0 = float(V.finite(t0, "t0"))
    if (t_final is None) == (n_steps is None):
        raise InputError("Give exactly one of `t_final` and `n_steps`.")
    if n_steps is not None:
        if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or n_steps < 1:
            raise InputError(f"Expected `n_steps` to be a positive integer, got {n_steps!r}.")
        return h, t0, int(n_steps)
    span = float(V.finite(t_final, "t_final")) - t0
    ratio = abs(span) / h
    if not math.isfinite(ratio):
        raise InputError(
            f"`t_final - t0` = {span:g} over h = {h:g} is not a finite number of steps; take a "
            "larger h or a shorter span."
        )
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        raise InputError(
            f"Expected `t_final - t0` = {span:g} to be a positive whole number of steps h = {h:g}, got "
            f"{ratio:.12g} steps; choose h = |t_final - t0| / N, or pass `n_steps`."
        )
    return math.copysign(h, span), t0, n


def _left_chart(
    system: Any,
    OUT: np.ndarray,
    INFO: np.ndarray,
    save_steps: np.ndarray,
    t0: float,
    h: float,
    batch_shape: tuple[int, ...],
) -> list[Failure]:
    """A failure for each trajectory whose saved states reach the end of the system's chart."""
    failures = []
    for i, lo, hi in getattr(system, "chart", ()):
        x = OUT[:, :, i]
        outside = ~((x > lo) & (x < hi)) & np.isfinite(x)
        for b in np.flatnonzero(outside.any(axis=1) & (INFO[:, 0] == 0)):
            k = int(np.argmax(outside[b]))
            INFO[b, 0] = 6
            failures.append(
                Failure(
                    kind="left_chart",
                    batch_index=tuple(int(j) for j in np.unravel_index(b, batch_shape)) if batch_shape else (),
                    step=int(save_steps[k]),
                    time=t0 + float(save_steps[k]) * h,
                    residual=float("nan"),
                )
            )
    return failures


def _run_compiled(
    kern: Any,
    Y0: np.ndarray,
    h: float,
    nsteps: int,
    save_every: int,
    OUT: np.ndarray,
    INFO: np.ndarray,
    tol: float,
    maxit: int,
    P: np.ndarray,
    threads: int,
) -> None:
    B = Y0.shape[0]
    if threads <= 1 or B < 2:
        kern(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P)
        return
    bounds = np.linspace(0, B, min(threads, B) + 1).astype(int)
    with ThreadPoolExecutor(max_workers=len(bounds) - 1) as pool:
        futures = [
            pool.submit(kern, Y0[a:b], h, nsteps, save_every, OUT[a:b], INFO[a:b], tol, maxit, P)
            for a, b in zip(bounds[:-1], bounds[1:])
        ]
        for fut in futures:
            fut.result()


def _run_periodic(
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
            OUT[b, 0] = Y0[b]
            INFO[b, 0], INFO[b, 1], INFO[b, 2] = 5, 1, np.nan
            reasons[b] = str(exc)
    return steps, compile_time


def solve(
    system: Any,
    method: Any,
    *,
    y0: Any = None,
    m0: Any = None,
    R0: Any = None,
    h: float,
    t_final: float | None = None,
    n_steps: int | None = None,
    t0: float = 0.0,
    save_every: int = 1,
    max_steps: int = V.MAX_STEPS,
    memory_limit: float = V.MEMORY_LIMIT,
    newton_tol: float = 1e-14,
    max_newton: int = 20,
    raise_on_failure: bool = True,
    backend: str = "auto",
    threads: int | None = None,
) -> Solution:
    """Integrate ``system`` with ``method`` from ``t0`` to ``t_final`` with fixed steps ``h``.

    Parameters
    ----------
    system : CanonicalSystem, LeftInvariantSystem, RigidBody, ...
        A canonical system takes its initial state as ``y0 = (q, p)``; a left-invariant system as ``m0``
        and, to integrate the attitude as well (and get the spatial momentum ``p = R m``), ``R0``.
    method : Method or str
        A method value (``GaussLegendre(3)``, ``LiePoissonSplitting(order=4)``, ...) or a registry key
        (``"implicit_midpoint"``, see :data:`~geomech.integrators.REGISTRY`). An incompatible pair raises
        :class:`~geomech.integrators.IncompatibleMethodError` before any work.
    y0, m0 : array_like, shape (..., d) or (..., 3)
        Initial state(s); leading axes are a batch, integrated in one call.
    R0 : array_like, shape (..., 3, 3), optional
        Initial attitude(s), body to space; broadcast against ``m0``.
    h : float
        Step size (for :class:`AdaptiveAdams`, the output interval).
    t_final, n_steps :
        The end, as a time (``t_final - t0`` must be a whole number of steps) or a number of steps.
    t0 : float
    save_every : int
        Keep every ``save_every``-th state (and always the first and the last).
    max_steps : int
        Ceiling on steps times trajectories (default 1e9, tens of seconds to minutes of compiled work):
        a larger run is refused before it starts, with its estimated cost; raise it to run one.
    memory_limit : float
        Ceiling in bytes (default 2 GiB) on the saved states: more is refused before any allocation; raise
        ``save_every`` or this limit.
    newton_tol : float
        Implicit methods: Newton stops when its correction (or the error its contraction rate
        predicts) is below ``newton_tol * max(1, |y|)``.
    max_newton : int
        Newton iterations allowed per step before the step is declared failed.
    raise_on_failure : bool
        Raise :class:`~geomech.errors.ConvergenceError` (Newton, adaptive solver) or
        :class:`~geomech.errors.NumericalError` (non-finite state, singular Newton matrix) when a trajectory
        fails; the exception's ``solution`` attribute holds the partial result. With False, failures are
        reported in ``Solution.status`` and ``Solution.failures`` only.
    backend : {"auto", "numba", "python"}
        ``"auto"`` compiles the loops with numba for systems given by a formula and runs them as Python
        otherwise.
    threads : int, optional
        Threads over the batch (compiled loops release the GIL); default: the number of CPUs.

    Returns
    -------
    Solution
    """
    method = get_method(method)
    problem = make_problem(system, attitude=R0 is not None)
    _check_compatible(problem, method)
    Y0, batch_shape = _initial_states(problem, y0, m0, R0)
    h, t0, nsteps = _steps(h, t0, t_final, n_steps)
    if isinstance(save_every, bool) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise InputError(f"Expected `save_every` to be a positive integer, got {save_every!r}.")
    tol = V.positive_scalar(newton_tol, "newton_tol")
    if isinstance(max_newton, bool) or not isinstance(max_newton, (int, np.integer)) or max_newton < 1:
        raise InputError(f"Expected `max_newton` to be a positive integer, got {max_newton!r}.")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1):
        raise InputError(f"Expected `threads` to be a positive integer or None, got {threads!r}.")
    B, d = Y0.shape
    if not isinstance(method, (PeriodicOrbit, Quadrature)):  # those cost per output, not per step
        V.work_budget(
            float(B) * nsteps,
            float(max_steps),
            f"The number of steps ({nsteps:.3g} of {B} trajectory(ies))",
            "max_steps",
            "take a larger h or a shorter span",
            seconds_each=1e-7,
        )
    n_saved = nsteps // save_every + 2
    V.memory_budget(
        float(B) * n_saved * (d + 1),
        float(memory_limit),
        f"Keeping every {save_every}-th of {nsteps:.3g} states of {B} trajectory(ies)",
        "memory_limit",
        f"raise `save_every` (to at least {max(1, int(nsteps * B * (d + 1) * 8 / memory_limit) + 1)})",
    )
    save_steps = np.arange(0, nsteps + 1, save_every)
    if save_steps[-1] != nsteps:
        save_steps = np.append(save_steps, nsteps)
    OUT = np.empty((B, len(save_steps), d))
    INFO = np.zeros((B, 5))
    module, used = problem.module(frozenset(method.features & {"gf", "split"}), backend)
    compile_time = 0.0
    t_start = time.perf_counter()
    reasons: dict[int, str] = {}
    if isinstance(method, AdaptiveAdams):
        with np.errstate(all="ignore"):
            internal = run_adaptive(module, method, Y0, t0, h, nsteps, save_every, OUT, INFO)
    elif isinstance(method, (PeriodicOrbit, Quadrature)):
        internal, compile_time = _run_periodic(problem.core, method, Y0, h * save_steps, OUT, INFO, reasons)
        t_start += compile_time
    else:
        kern = getattr(module, method.kernel)
        P = np.ascontiguousarray(method.constants(problem), dtype=float)
        if used == "numba" and not kern.signatures:
            # the first call compiles (or loads numba's disk cache): timed apart on a one-step problem
            from numba.core.errors import NumbaError

            try:
                kern(Y0[:1].copy(), h, 1, 1, np.empty((1, 2, d)), np.zeros((1, 5)), tol, int(max_newton), P)
            except NumbaError:
                # a function sympy prints but numba cannot compile: the same loop in Python
                if backend == "numba":
                    raise
                module, used = problem.module(frozenset(method.features & {"gf", "split"}), "python")
                kern = getattr(module, method.kernel)
            compile_time = time.perf_counter() - t_start
            t_start = time.perf_counter()
        n_threads = threads if threads is not None else (os.cpu_count() or 1)
        if used != "numba" or B * nsteps < 20_000:
            n_threads = 1
        with np.errstate(all="ignore"):  # the Python backend's overflow is detected as a non-finite state
            _run_compiled(kern, Y0, h, nsteps, save_every, OUT, INFO, tol, int(max_newton), P, int(n_threads))
        internal = B * nsteps
    run_time = time.perf_counter() - t_start

    failures = []
    for b in np.flatnonzero(INFO[:, 0] != 0):
        step = int(INFO[b, 1])
        failures.append(
            Failure(
                kind=STATUS.get(int(INFO[b, 0]), "failed"),
                batch_index=tuple(int(i) for i in np.unravel_index(b, batch_shape)) if batch_shape else (),
                step=step,
                time=t0 + (step - 1) * h,
                residual=float(INFO[b, 2]),
            )
        )
    failures += _left_chart(system, OUT, INFO, save_steps, t0, h, batch_shape)
    states = OUT.reshape(batch_shape + OUT.shape[1:])
    inv = problem.invariants(states)
    status = failures[0].kind if failures else "success"
    if failures:
        extra = f" ({len(failures)} of {B} trajectories failed)" if B > 1 else ""
        message = f"{type(method).__name__} on {problem.name}: {failures[0].describe()}{extra}."
        if failures[0].kind in ("newton_failed", "singular_jacobian"):
            message += (
                f" Reduce h (now {abs(h):g}), or loosen newton_tol (now {tol:g}) / raise max_newton (now {max_newton})."
            )
    else:
        message = f"{type(method).__name__}: {nsteps} steps of h = {abs(h):g} from t = {t0:g}."
        if isinstance(method, Quadrature):
            message = (
                f"Quadrature: {nsteps} outputs every {abs(h):g} from t = {t0:g}, each from the "
                "time-of-flight integral along the level curve."
            )
        elif isinstance(method, PeriodicOrbit):
            message = (
                f"PeriodicOrbit: {nsteps} outputs every {abs(h):g} from t = {t0:g}, each from one stored "
                f"period ({internal} mesh steps in all)."
            )
    if reasons:
        message += " " + reasons[min(reasons)]
    solution = Solution(
        t=t0 + h * save_steps.astype(float),
        states=states,
        system=system,
        method=method,
        layout=problem.layout,
        energy=inv["energy"],
        casimir=inv["casimir"],
        spatial_momentum=inv["spatial_momentum"],
        status=status,
        message=message,
        failures=tuple(failures),
        stats={
            "n_steps": nsteps,
            "n_internal_steps": internal,
            "n_rhs": int(INFO[:, 4].sum()),
            "n_newton": int(INFO[:, 3].sum()),
            "backend": used,
            "compile_time": compile_time,
            "run_time": run_time,
        },
    )
    if failures and raise_on_failure:
        cls = ConvergenceError if status in ("newton_failed", "adaptive_failed") else NumericalError
        exc = cls(message + " Pass raise_on_failure=False to get the partial solution instead.")
        exc.solution = solution  # type: ignore[attr-defined]
        raise exc
    return solution
