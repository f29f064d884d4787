"""A motion on a Lie group through :func:`~geomech.solve`: the reconstruction equation :math:`g^{-1}\\dot g =
\\xi(t, g)` of a :class:`~geomech.systems.GroupFlow`, integrated by the Runge-Kutta-Munthe-Kaas methods in
exponential coordinates about a moving centre (every state on the group to round-off), with the angles of
the group's angle components unwrapped. The :class:`~geomech.Solution` has the layout ``"group"``: the
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
from .solution import Failure, Solution, Status, run_stats


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
) -> Solution:
    """Integrate ``system`` from ``g0`` (internal: :func:`~geomech.solve` has checked the method and the times)."""
    from scipy.integrate import solve_ivp

    G = system.group.numeric
    k, n = system.k, G.matrix_size
    ac = list(G.angle_components)
    g_init, angle0 = _start(system, g0)
    V.memory_budget(
        float(times.n_saved) * (k + n * n),
        float(memory_limit),
        f"Keeping {times.n_saved:.3g} states",
        "memory_limit",
        "save fewer times (`saveat`)",
    )
    saved_t = times.t
    out_g = np.full((len(saved_t), n, n), np.nan)
    out_a = np.full((len(saved_t), len(ac)), np.nan)
    nfev = 0
    steps = 0
    limit = int(V.positive_scalar(max_evaluations, "max_evaluations"))

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
                return float(np.linalg.norm(u)) - radius

            cast(Any, leave).terminal = True  # event attributes read by solve_ivp
            cast(Any, leave).direction = 1
            while i < len(saved_t):
                sol = solve_ivp(
                    chart_rhs,
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
                if sol.status < 0:
                    failure = Failure(Status.ADAPTIVE_FAILED, (), i, float(sol.t[-1]), float("nan"), str(sol.message))
                    break
                t_stop = float(sol.t[-1])
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
        detail = (
            f"stopped after {stop.count} evaluations: the motion is faster, or the span longer, than the budget "
            "allows; shorten t_final or raise `max_evaluations`"
        )
        failure = Failure(Status.BUDGET_EXHAUSTED, (), i, tc, float("nan"), detail)
    except NumericalError as exc:
        failure = Failure(Status.NONFINITE, (), i, tc, float("nan"), str(exc))
    run_time = time.perf_counter() - start
    reached = np.all(np.isfinite(out_g.reshape(len(saved_t), -1)), axis=1)
    coords = np.full((len(saved_t), k), np.nan)
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
        stats=run_stats(times.n_steps, steps, nfev, run_time),
        group_dim=k,
    )
