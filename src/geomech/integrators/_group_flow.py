"""A motion on a Lie group through :func:`~geomech.solve`: the reconstruction equation :math:`g^{-1}\\dot g =
\\xi(t, g)` of a :class:`~geomech.systems.GroupFlow`, integrated by the Runge-Kutta-Munthe-Kaas methods in
exponential coordinates about a moving centre (every state on the group to round-off), with the angles of
the group's angle components unwrapped; compiled where the body velocity is formulas
(:mod:`._group_flow_compiled`). The :class:`~geomech.Solution` has the layout ``"group"``: the
chart coordinates (those angles unwrapped) followed by the element, row-major."""

from __future__ import annotations

import time
from typing import Any, cast

import numpy as np

from .. import _validate as V
from ..errors import InputError, NumericalError
from ..systems.group_flow import GroupFlow
from ._adaptive import _OverBudget
from ._times import Times
from .methods import RKMK, RKMK4, Method
from .methods._embedded import compiled_pair
from .solution import STATUS, Failure, Solution, Status, run_stats


def group_labels(system: GroupFlow) -> tuple[str, ...]:
    n = system.group.numeric.matrix_size
    return tuple(c.name for c in system.group.coordinates) + tuple(
        f"g{i}{j}" for i in range(1, n + 1) for j in range(1, n + 1)
    )


def _start(system: GroupFlow, g0: Any) -> tuple[np.ndarray, np.ndarray]:
    """The initial element and the initial values of the unwrapped angles, from an element ``(N, N)`` or
    chart coordinates ``(k,)`` (then the angles start where the coordinates say, turns included)."""
    chart, G = system.group, system.group.numeric
    n, k = G.matrix_size, system.k
    if g0 is None:
        raise InputError(
            f"{system.name} starts from `g0`: an element of {G.name} (an ({n}, {n}) matrix) or its chart "
            f"coordinates ({', '.join(c.name for c in chart.coordinates)})."
        )
    a = np.asarray(g0, dtype=float)
    ac = list(G.angle_components)
    if a.ndim == 1:
        alpha = V.exact_shape(a, "g0", (k,))
        element = np.asarray(chart.from_coordinates(alpha), dtype=float)
        return element, alpha[ac]
    element = G.check(a, "g0")
    if element.shape != (n, n):
        raise InputError(f"Expected one element `g0` of shape ({n}, {n}), or {k} coordinates, got {a.shape}.")
    return element, np.asarray(G.log(element), dtype=float)[ac]


def solve_group_flow(
    system: GroupFlow,
    method: Method,
    times: Times,
    *,
    t0: float,
    g0: Any,
    tolerances: tuple[float, float] | None,
    max_evaluations: Any,
    memory_limit: float,
    backend: str = "auto",
) -> Solution:
    """Integrate ``system`` from ``g0`` (internal: :func:`~geomech.solve` has checked the method and the times):
    compiled where the body velocity is formulas on a group with kernels (and the adaptive method's solver has a
    compiled pair), unless ``backend`` is "python"; in Python otherwise."""
    G = system.group.numeric
    k, n = system.k, G.matrix_size
    g_init, angle0 = _start(system, g0)
    V.memory_budget(
        float(times.n_saved) * (k + n * n),
        float(memory_limit),
        f"Keeping {times.n_saved:.3g} states",
        "memory_limit",
        "save fewer times (`saveat`)",
    )
    limit = int(V.positive_scalar(max_evaluations, "max_evaluations"))
    module = None
    if backend != "python" and (isinstance(method, RKMK4) or compiled_pair(getattr(method, "solver", "")) is not None):
        from ._group_flow_compiled import group_flow_module

        module = group_flow_module(system)
    if module is None and backend == "numba":
        raise InputError(
            f"backend='numba' runs {type(method).__name__} where the body velocity `xi` is formulas (not a callable) "
            f"on SO(2), R^n, SE(2), SO(3), SE(3) or their products ({G.name} here), with the solver DOP853 or RK45 "
            "for rkmk (and numba installed): give backend='auto' or 'python' to run it in Python."
        )
    run = _run_compiled if module is not None else _run_python
    out_g, out_a, failure, steps, nfev, run_time, extra = run(
        module, system, method, times, float(t0), g_init, angle0, tolerances, limit
    )
    saved_t = times.t
    reached = np.all(np.isfinite(out_g.reshape(len(saved_t), -1)), axis=1)
    coords = np.full((len(saved_t), k), np.nan)
    ac = list(G.angle_components)
    if reached.any():
        coords[reached] = system.group.to_coordinates(out_g[reached])
        # the chart coordinate of an angle component's index is that angle (SO(2), SE(2), their products)
        coords[np.ix_(reached, ac)] = out_a[reached]
    states = np.concatenate([coords, out_g.reshape(len(saved_t), n * n)], axis=1)
    name = type(method).__name__
    failures = () if failure is None else (failure,)
    if failures:
        message = f"{name} on {system.name}: {failures[0].describe()}."
    elif times.h is not None:
        message = f"{name}: {times.n_steps} steps of h = {abs(times.h):g} from t = {t0:g} on {G.name}."
    else:
        solver = getattr(method, "solver", "")
        message = f"{name} ({solver}): {len(saved_t)} outputs from t = {t0:g} to {saved_t[-1]:g} on {G.name}."
    return Solution(
        t=saved_t,
        states=states,
        system=system,
        method=method,
        layout="group",
        labels=group_labels(system),
        status=failures[0].kind if failures else Status.SUCCESS,
        message=message,
        failures=failures,
        stats=run_stats(times.n_steps, steps, nfev, run_time, **extra),
        group_dim=k,
    )


_BUDGET = (
    "stopped after {count} evaluations: the motion is faster, or the span longer, than the budget allows; shorten "
    "t_final or raise `max_evaluations`"
)


def _run_compiled(
    module: Any,
    system: GroupFlow,
    method: Method,
    times: Times,
    t0: float,
    g_init: np.ndarray,
    angle0: np.ndarray,
    tolerances: tuple[float, float] | None,
    limit: int,
) -> tuple[np.ndarray, np.ndarray, Failure | None, int, int, float, dict[str, Any]]:
    """The run by the compiled module (:mod:`._group_flow_compiled`): the Python engine's steps."""
    from ._group_flow_compiled import run_rkmk, run_rkmk4

    G = system.group.numeric
    AC = np.asarray(G.angle_components, dtype=np.int64)
    G0, A0 = np.ascontiguousarray(g_init, dtype=float), np.ascontiguousarray(angle0, dtype=float)
    failure: Failure | None = None
    if isinstance(method, RKMK4):
        assert times.h is not None  # a fixed-step method: solve() has set the step
        h = float(times.h)
        keep = times.kernel_steps() if times.k is None else times.k
        allowed = min(times.n_steps, limit // 4)  # the Python engine's budget: four evaluations a step
        out_g, out_a, INFO, done, compile_time, loop_time = run_rkmk4(module, G0, A0, AC, t0, h, allowed, keep)
        first = int(INFO[1])
        if INFO[0] == 2:
            detail = f"a step's body velocity is not finite after t = {t0 + done * h:.6g}"
            failure = Failure(Status.NONFINITE, (), first, t0 + done * h, float("nan"), detail)
        elif allowed < times.n_steps:
            failure = Failure(
                Status.BUDGET_EXHAUSTED, (), first, t0 + done * h, float("nan"), _BUDGET.format(count=4 * done)
            )
        steps, nfev = done, int(INFO[2])
    else:
        assert isinstance(method, RKMK) and tolerances is not None
        radius = np.inf if G.abelian else float(method.chart_radius)
        out_g, out_a, INFO, compile_time, loop_time = run_rkmk(
            module, method, system.k, G0, A0, AC, t0, times.t, tolerances, float(limit), radius
        )
        status, first, nfev, steps = int(INFO[0]), int(INFO[1]), int(INFO[2]), int(INFO[3])
        if status != 0:
            kind = STATUS.get(status, Status.ADAPTIVE_FAILED)
            detail = {
                Status.BUDGET_EXHAUSTED: _BUDGET.format(count=nfev),
                Status.NONFINITE: f"the body velocity is not finite after t = {INFO[5]:.6g}",
                Status.ADAPTIVE_FAILED: f"the step size fell below the resolution of t = {INFO[5]:.6g}",
            }.get(kind, "")
            failure = Failure(kind, (), first, float(INFO[5]), float("nan"), detail)
    extra = {"backend": "numba", "compile_time": compile_time, "loop_time": loop_time}
    return out_g, out_a, failure, steps, nfev, compile_time + loop_time, extra


def _run_python(
    module: Any,
    system: GroupFlow,
    method: Method,
    times: Times,
    t0: float,
    g_init: np.ndarray,
    angle0: np.ndarray,
    tolerances: tuple[float, float] | None,
    limit: int,
) -> tuple[np.ndarray, np.ndarray, Failure | None, int, int, float, dict[str, Any]]:
    """The run in Python: the Runge-Kutta steps of numpy, scipy's adaptive solvers."""
    from scipy.integrate import solve_ivp

    G = system.group.numeric
    k, n = system.k, G.matrix_size
    ac = list(G.angle_components)
    saved_t = times.t
    out_g = np.full((len(saved_t), n, n), np.nan)
    out_a = np.full((len(saved_t), len(ac)), np.nan)
    nfev = 0
    steps = 0

    # Elements are matrices and the product is the group's (LieGroup.compose without re-checking what exp
    # and the products of elements return: the check was twice the cost of the product in every evaluation).
    def chart_rhs(t: float, u: np.ndarray, gc: np.ndarray) -> np.ndarray:
        nonlocal nfev
        if nfev >= limit:
            raise _OverBudget(t, nfev)
        nfev += 1
        return G.right_jacobian_inverse(u) @ system.velocity(t, gc @ G.exp(u))

    failure: Failure | None = None
    start = time.perf_counter()
    i = 0
    while i < len(saved_t) and saved_t[i] == t0:
        out_g[i], out_a[i] = g_init, angle0
        i += 1
    gc, angle, tc = g_init.copy(), angle0.copy(), float(t0)
    try:
        if isinstance(method, RKMK4):
            assert times.h is not None  # a fixed-step method: solve() has set the step
            h = float(times.h)
            keep = times.kernel_steps() if times.k is None else times.k
            want = {int(s): j for j, s in enumerate(keep)}
            z = np.zeros(k)
            for step in range(1, times.n_steps + 1):
                t = t0 + (step - 1) * h
                k1 = chart_rhs(t, z, gc)
                k2 = chart_rhs(t + h / 2, h * k1 / 2, gc)
                k3 = chart_rhs(t + h / 2, h * k2 / 2, gc)
                k4 = chart_rhs(t + h, h * k3, gc)
                theta = h * (k1 + 2 * k2 + 2 * k3 + k4) / 6
                gc = gc @ G.exp(theta)
                angle = angle + theta[ac]
                steps += 1
                tc = t0 + step * h
                j = want.get(step)
                if j is not None:
                    out_g[j], out_a[j] = gc, angle
                    i = j + 1
        else:
            assert isinstance(method, RKMK) and tolerances is not None
            rtol, atol = tolerances
            # exp is a global chart of an abelian group's cover: never recentre there.
            radius = np.inf if G.abelian else float(method.chart_radius)
            t_end = float(saved_t[-1])
            sign = 1.0 if t_end > t0 else -1.0

            def leave(_t: float, u: np.ndarray, *_: Any) -> float:
                return float(np.abs(u).max()) - radius

            cast(Any, leave).terminal = True  # event attributes read by solve_ivp
            cast(Any, leave).direction = 1
            # a body velocity that is not finite makes the solver reject the step (a shorter one may pass): the
            # first such evaluation is kept, and reported if the solver gives up, with the states it reached
            bad: list[NumericalError] = []

            def soft_rhs(t: float, u: np.ndarray, gc: np.ndarray) -> np.ndarray:
                if not np.all(np.isfinite(u)):  # a stage after one that was not finite
                    return np.full(k, np.nan)
                try:
                    return chart_rhs(t, u, gc)
                except NumericalError as exc:
                    bad.append(exc)
                    return np.full(k, np.nan)

            while i < len(saved_t):
                sol = solve_ivp(
                    soft_rhs,
                    (tc, t_end),
                    np.zeros(k),
                    method=method.solver,
                    rtol=rtol,
                    atol=atol,
                    dense_output=True,
                    events=leave,
                    args=(gc,),
                )
                steps += int(sol.t.size - 1)
                t_stop = float(sol.t[-1])
                if sol.status < 0:
                    while i < len(saved_t) and sol.t.size > 1 and sign * (saved_t[i] - t_stop) <= 0:
                        u = sol.sol(saved_t[i])
                        out_g[i], out_a[i] = gc @ G.exp(u), angle + u[ac]
                        i += 1
                    kind, why = (Status.NONFINITE, str(bad[0])) if bad else (Status.ADAPTIVE_FAILED, str(sol.message))
                    failure = Failure(kind, (), i, t_stop, float("nan"), why)
                    break
                last = sol.status == 0
                while i < len(saved_t) and (
                    sign * (saved_t[i] - t_stop) < 0 or (last and sign * (saved_t[i] - t_stop) <= 0)
                ):
                    u = sol.sol(saved_t[i])
                    out_g[i], out_a[i] = gc @ G.exp(u), angle + u[ac]
                    i += 1
                u = sol.y[:, -1]
                gc = gc @ G.exp(u)
                angle = angle + u[ac]
                tc = t_stop
    except _OverBudget as stop:
        failure = Failure(Status.BUDGET_EXHAUSTED, (), i, tc, float("nan"), _BUDGET.format(count=stop.count))
    except NumericalError as exc:
        failure = Failure(Status.NONFINITE, (), i, tc, float("nan"), str(exc))
    return out_g, out_a, failure, steps, nfev, time.perf_counter() - start, {}
