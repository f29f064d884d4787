"""A body velocity given as formulas (``GroupFlow(group, ["...", ...])``) runs compiled by the Runge-Kutta-Munthe-Kaas
methods: against the Python engine on every group with kernels and a product, against the attitude equation
integrated in matrices by scipy (no chart, no RKMK), at the order of RKMK4, backwards, across the box's exits at
the very end of a run, on the group to round-off; failures as the Python engine's; the formulas' input checks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from geomech import GroupFlow, solve
from geomech.errors import InputError
from geomech.integrators import Status
from geomech.lie import SE2, SE3, SO2, SO3, Rn

FLOWS = {
    "SE2": (SE2(), ["v*cos(t)", "0.2 + 0.1*g13", "w"], {"v": 1.0, "w": 0.7}),
    "SO3": (SO3(), ["sin(3*t)", "1 + 0.5*g31", "cos(t)*g12"], None),
    "SE3": (SE3(), ["1", "0.3*g24", "0.5*g14", "0.4", "cos(t)", "0.9*g33"], None),
    "SE2xSO2xR2": (
        SE2("x", "y", "p") * SO2("a") * Rn("u", "v"),
        ["1", "0", "0.3", "sin(t)*g44", "g11", "t"],
        None,
    ),
}


def _flow(case):
    group, xi, parameters = FLOWS[case]
    return GroupFlow(group, xi, case, parameters=parameters)


@pytest.mark.parametrize("case", list(FLOWS))
@pytest.mark.parametrize("method, times", [("rkmk", {"rtol": 1e-10, "atol": 1e-12}), ("rkmk4", {"h": 0.01})])
def test_the_compiled_run_is_the_python_engines(case, method, times):
    flow = _flow(case)
    g0 = flow.group.numeric.exp(np.linspace(0.1, 0.4, flow.k))
    a, b = (solve(flow, method, t_final=5.0, saveat=11, g0=g0, backend=k, **times) for k in ("python", "numba"))
    assert b.stats["backend"] == "numba" and a.stats["backend"] == "python" and b.status is Status.SUCCESS
    # RKMK4: the same steps (round-off); RKMK: the same pair and the same chart's box, their steps apart by the
    # tolerance (scipy's step-size start and the box's exits located apart)
    atol = 1e-12 if method == "rkmk4" else 1e-8
    np.testing.assert_allclose(b.states, a.states, rtol=0, atol=atol * (1.0 + np.abs(a.states).max()))


def _attitude(xi, t_final, R0):
    """R(t) from R' = R hat(xi(t, R)) integrated in matrices by scipy (no chart, no group method)."""

    def rhs(t, y):
        R = y.reshape(3, 3)
        return (R @ SO3().hat(xi(t, R))).ravel()

    return solve_ivp(rhs, (0.0, t_final), R0.ravel(), rtol=1e-13, atol=1e-14, method="DOP853").y[:, -1].reshape(3, 3)


def test_the_compiled_methods_follow_the_attitude_equation_and_rkmk4_has_order_4():
    flow = _flow("SO3")
    R0 = SO3().exp([0.3, -0.2, 0.5])
    exact = _attitude(lambda t, R: np.array([np.sin(3 * t), 1 + 0.5 * R[2, 0], np.cos(t) * R[0, 1]]), 4.0, R0)
    adaptive = solve(flow, "rkmk", t_final=4.0, g0=R0, rtol=1e-12, atol=1e-13, backend="numba")
    assert np.abs(adaptive.element[-1] - exact).max() < 1e-10
    hs = np.array([0.2, 0.1, 0.05])
    errs = [
        np.abs(solve(flow, "rkmk4", t_final=4.0, h=h, g0=R0, backend="numba").element[-1] - exact).max() for h in hs
    ]
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert abs(order - 4) < 0.2, (order, errs)


def test_the_compiled_adaptive_run_goes_back_to_its_start_and_stays_on_the_group():
    flow = _flow("SE3")
    g0 = SE3().exp([0.2, -0.1, 0.3, 0.5, -0.4, 0.2])
    kw = dict(rtol=1e-12, atol=1e-12, backend="numba")
    fwd = solve(flow, "rkmk", t_final=10.0, saveat=31, g0=g0, **kw)
    back = solve(flow, "rkmk", t0=10.0, t_final=0.0, saveat=2, g0=fwd.element[-1], **kw)
    # the flow stretches errors (the Python engine's round trip misses by as much): 1e-12 tolerances, 20 units
    assert np.abs(back.element[-1] - g0).max() < 2e-10
    R = fwd.element[:, :3, :3]
    assert np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max() < 1e-13
    assert np.array_equal(fwd.element[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (31, 1)))
    assert fwd.stats["n_rhs"] > 0 and fwd.stats["loop_time"] > 0


@pytest.mark.parametrize("t_final", [3.0, 4.0, 5.0])
def test_an_exit_of_the_box_at_the_last_time_keeps_the_last_output(t_final):
    """The translation's component of u reaches the box's side 1 at every whole second: the last exit is within
    round-off of the last output time, which the pair cannot step to; that output is the new centre."""
    flow = GroupFlow(SE2("x", "y", "p") * SO2("a"), ["1", "0", "0.3", "sin(t)*g44"])
    kw = dict(t_final=t_final, saveat=11, g0=np.eye(5), rtol=1e-10, atol=1e-12)
    sol, ref = (solve(flow, "rkmk", backend=k, **kw) for k in ("numba", "python"))
    assert sol.status is Status.SUCCESS and np.all(np.isfinite(sol.states))
    np.testing.assert_allclose(sol.states, ref.states, rtol=0, atol=1e-8 * (1 + np.abs(ref.states).max()))


@pytest.mark.parametrize("method, times", [("rkmk", {"rtol": 1e-10, "atol": 1e-12}), ("rkmk4", {"h": 0.01})])
def test_failures_are_the_python_engines(method, times):
    # the evaluation budget
    flow = _flow("SO3")
    runs = [
        solve(
            flow,
            method,
            t_final=5.0,
            saveat=11,
            g0=np.eye(3),
            max_evaluations=150,
            raise_on_failure=False,
            backend=k,
            **times,
        )
        for k in ("python", "numba")
    ]
    for sol in runs:
        assert sol.status is Status.BUDGET_EXHAUSTED and "max_evaluations" in sol.message
        first = sol.failures[0].step
        assert 0 < first < 11 and np.all(np.isfinite(sol.element[:first])) and np.isnan(sol.element[first:]).all()
    if method == "rkmk4":  # the same steps: the same outputs before the budget ran out
        assert runs[0].failures[0].step == runs[1].failures[0].step
        np.testing.assert_allclose(runs[1].element[:first], runs[0].element[:first], rtol=0, atol=1e-13)
    # a body velocity that is infinite at t = 1
    blows = GroupFlow(SO3(), ["1/(1 - t)", "0", "1"])
    for k in ("python", "numba"):
        sol = solve(blows, method, t_final=2.0, saveat=5, g0=np.eye(3), raise_on_failure=False, backend=k, **times)
        # the rotation's rate diverges: the run ends before t = 1, reported (not finite, the steps' size or the
        # budget spent on a spin ever faster), with the states before it
        assert sol.status in (Status.NONFINITE, Status.ADAPTIVE_FAILED, Status.BUDGET_EXHAUSTED), (k, sol.status)
        assert sol.failures[0].time <= 1.0 and sol.failures[0].step == 2
        assert np.all(np.isfinite(sol.element[:2])) and np.isnan(sol.element[2:]).all()


def test_what_does_not_compile_runs_in_python_or_is_refused_by_name():
    callable_flow = GroupFlow(SO3(), lambda t, R: np.array([1.0, 0.0, np.sin(t)]))
    assert solve(callable_flow, "rkmk4", t_final=1.0, h=0.1, g0=np.eye(3)).stats["backend"] == "python"
    with pytest.raises(InputError, match="backend='numba'.*formulas"):
        solve(callable_flow, "rkmk4", t_final=1.0, h=0.1, g0=np.eye(3), backend="numba")
    # RK23 has no compiled twin: scipy's, in Python
    from geomech.integrators import RKMK

    flow = _flow("SO3")
    assert solve(flow, RKMK(solver="RK23"), t_final=1.0, g0=np.eye(3)).stats["backend"] == "python"
    with pytest.raises(InputError, match="DOP853 or RK45"):
        solve(flow, RKMK(solver="RK23"), t_final=1.0, g0=np.eye(3), backend="numba")


@pytest.mark.parametrize(
    "xi, parameters, match",
    [
        (["1", "0"], None, "Expected 3 formulas"),
        (["v", "0", "1"], None, r"\['v'\].*`parameters`"),
        (["1", "0", "g11"], {"g11": 1.0}, "variable of `xi`"),
        (["1", "0", "a"], {"a": float("nan")}, "finite"),
        (["__import__('os')", "0", "1"], None, "xi\\[0\\]"),
        ("1, 0, 1", None, "callable .* or 3 formulas"),
    ],
)
def test_the_formulas_are_checked(xi, parameters, match):
    with pytest.raises(InputError, match=match):
        GroupFlow(SO3(), xi, parameters=parameters)


def test_parameters_go_with_formulas():
    with pytest.raises(InputError, match="callable `xi` takes none"):
        GroupFlow(SO3(), lambda t, g: np.zeros(3), parameters={"a": 1.0})
    flow = GroupFlow("SE2", ["v", "0", "w"], parameters={"v": 2.0, "w": 0.5})
    assert np.array_equal(flow.velocity(0.0, np.eye(3)), [2.0, 0.0, 0.5])
    # numbers are formulas too: a constant velocity, whose flow is the exponential
    xi = np.array([0.3, -1.2, 2.5])
    sol = solve(GroupFlow("SE2", xi), "rkmk4", t_final=3.0, h=0.01, saveat=4, g0=np.eye(3), backend="numba")
    np.testing.assert_allclose(sol.element, SE2().exp(sol.t[:, None] * xi), rtol=0, atol=1e-12)


def test_the_analyses_paths_take_formulas():
    """integrate_path builds its GroupFlow from what it is given: formulas run compiled, the same path as the
    callable's in Python."""
    from geomech.analysis.group_paths import integrate_path

    t = np.linspace(0.0, 3.0, 7)
    by_formula = integrate_path("SO3", ["sin(3*t)", "1 + 0.5*g31", "cos(t)*g12"], np.eye(3), t)
    by_callable = integrate_path(
        "SO3", lambda s, R: [np.sin(3 * s), 1 + 0.5 * R[2, 0], np.cos(s) * R[0, 1]], np.eye(3), t
    )
    assert by_formula.stats["backend"] == "numba" and by_callable.stats["backend"] == "python"
    np.testing.assert_allclose(by_formula.element, by_callable.element, rtol=0, atol=1e-10)
