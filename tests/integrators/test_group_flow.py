"""A body velocity on a Lie group through solve(): the Runge-Kutta-Munthe-Kaas methods against exact
solutions, their order, their staying on the group, backwards in time, failures as data, and the Solution's
views of a path (coordinates with angles unwrapped, elements, displacement, net motion)."""

import numpy as np
import pytest

from geomech import GroupFlow, solve
from geomech.errors import InputError, NumericalError
from geomech.integrators import RKMK, RKMK4, IncompatibleMethodError, Kind, Status
from geomech.lie import SE2, SO3, se2, so3
from geomech.systems import RigidBody


def spinning(t, g):
    """A body velocity on SO(3) that depends on time and on the attitude (no closed form)."""
    return np.array([np.sin(3 * t), 1.0 + 0.5 * g[2, 0], np.cos(t) * g[0, 1]])


@pytest.mark.parametrize("method, times", [("rkmk", {"rtol": 1e-12, "atol": 1e-12}), ("rkmk4", {"h": 0.01})])
def test_constant_velocity_is_the_exponential(method, times):
    # g(t) = g0 exp(t xi) exactly; RKMK4 is exact for a constant velocity too (one exp per step of h xi)
    for G, exp, xi in ((SE2(), se2.exp, np.array([0.3, -1.2, 2.5])), (SO3(), so3.exp, np.array([1.0, -2.0, 0.5]))):
        g0 = G.exp(np.array([0.2, 0.9, -0.4]))
        sol = solve(GroupFlow(G, lambda _t, _g, xi=xi: xi), method, t_final=3.0, saveat=7, g0=g0, **times)
        exact = g0 @ exp(sol.t[:, None] * xi)
        np.testing.assert_allclose(sol.element, exact, atol=1e-10)
        assert sol.status is Status.SUCCESS and sol.layout == "group"
        if isinstance(G, SE2):  # the heading is unwrapped: 2.5 rad/s for 3 s is more than a turn
            np.testing.assert_allclose(sol.g[:, 2] - sol.g[0, 2], sol.t * xi[2], atol=1e-10)
            assert sol.net_motion()["theta"] == pytest.approx(7.5, abs=1e-10)


def test_rkmk4_converges_at_order_4():
    flow = GroupFlow(SO3(), spinning, "spinning top")
    ref = solve(flow, "rkmk", t_final=4.0, saveat=2, g0=np.eye(3), rtol=1e-13, atol=1e-13).element[-1]
    hs = np.array([0.2, 0.1, 0.05])
    errs = [np.abs(solve(flow, RKMK4(), t_final=4.0, h=h, g0=np.eye(3)).element[-1] - ref).max() for h in hs]
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 3.7 < order < 4.4


@pytest.mark.slow
def test_both_stay_on_the_group_over_long_times():
    flow = GroupFlow(SO3(), spinning, "spinning top")
    # far from the start, every state is a rotation to round-off (no drift off SO(3), unlike an ODE on R^9)
    for sol in (
        solve(flow, "rkmk", t_final=200.0, saveat=11, g0=np.eye(3), rtol=1e-8, atol=1e-8),
        solve(flow, "rkmk4", t_final=200.0, h=0.1, saveat=11, g0=np.eye(3)),
    ):
        R = sol.element
        assert np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max() < 1e-12
        assert np.abs(np.linalg.det(R) - 1.0).max() < 1e-12


def test_backwards_returns_to_the_start():
    flow = GroupFlow(SO3(), spinning)
    fwd = solve(flow, "rkmk", t_final=3.0, saveat=4, g0=np.eye(3), rtol=1e-12, atol=1e-12)
    back = solve(flow, "rkmk", t0=3.0, t_final=0.0, saveat=4, g0=fwd.element[-1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(back.t, [3.0, 2.0, 1.0, 0.0])
    np.testing.assert_allclose(back.element[::-1], fwd.element, atol=1e-9)
    back4 = solve(flow, "rkmk4", t0=3.0, t_final=0.0, h=0.01, g0=fwd.element[-1])
    np.testing.assert_allclose(back4.element[-1], np.eye(3), atol=1e-8)


def test_start_from_coordinates_keeps_the_winding():
    # theta0 = 7 (more than a turn) as coordinates: the heading continues from 7, not from 7 - 2 pi
    flow = GroupFlow(SE2("x", "y", "theta"), lambda t, g: np.array([1.0, 0.0, 0.5]))
    sol = solve(flow, "rkmk", t_final=2.0, saveat=3, g0=[1.0, 2.0, 7.0])
    np.testing.assert_allclose(sol.g[:, 2], [7.0, 7.5, 8.0], atol=1e-10)
    assert sol.labels[:3] == ("x", "y", "theta")
    np.testing.assert_allclose(sol.displacement(), se2.exp(np.array([2.0, 0.0, 1.0])), atol=1e-10)
    ds = sol.to_dataset()
    assert ds["g"].dims == ("t", "coordinate") and list(ds["coordinate"].values) == ["x", "y", "theta"]
    assert ds["element"].shape == (3, 3, 3)


def test_failures_are_data_with_the_states_reached():
    def blows_up(t, g):
        return np.array([1.0, 0.0, np.nan if t > 1.0 else 0.3])

    flow = GroupFlow(SE2(), blows_up, "blows up")
    with pytest.raises(NumericalError, match="not finite at t = 1") as err:
        solve(flow, "rkmk", t_final=2.0, saveat=5, g0=np.eye(3))
    sol = err.value.solution
    assert sol.status is Status.NONFINITE and sol.failures[0].time <= 1.0 + 1e-12
    assert np.all(np.isfinite(sol.g[:2])) and np.all(np.isnan(sol.g[3:]))  # t = 1 may or may not be reached
    quiet = solve(flow, "rkmk4", t_final=2.0, h=0.1, g0=np.eye(3), raise_on_failure=False)
    assert quiet.status is Status.NONFINITE and np.isfinite(quiet.g[0]).all()
    budget = solve(
        GroupFlow(SO3(), spinning),
        "rkmk",
        t_final=1e4,
        saveat=3,
        g0=np.eye(3),
        max_evaluations=500,
        raise_on_failure=False,
    )
    assert budget.status is Status.BUDGET_EXHAUSTED and budget.stats["n_rhs"] <= 500


def test_methods_and_systems_that_do_not_fit_are_refused_before_any_work():
    calls = []
    flow = GroupFlow(SO3(), lambda t, g: calls.append(t) or np.zeros(3))
    with pytest.raises(IncompatibleMethodError, match="rkmk, rkmk4"):
        solve(flow, "rk4", t_final=1.0, h=0.1, g0=np.eye(3))
    with pytest.raises(IncompatibleMethodError, match="body velocity on a Lie group.*give `R0`"):
        solve(RigidBody([3.0, 2.0, 1.0]), "rkmk", t_final=1.0, m0=[1.0, 0.0, 0.0])
    with pytest.raises(InputError, match="`g0`"):
        solve(flow, "rkmk", t_final=1.0)
    with pytest.raises(InputError, match="not `m0`"):
        solve(flow, "rkmk", t_final=1.0, g0=np.eye(3), m0=[1.0, 0.0, 0.0])
    with pytest.raises(InputError, match=r"`g0` to have shape \(\.\.\., 3, 3\)"):
        solve(flow, "rkmk", t_final=1.0, g0=np.eye(2))
    with pytest.raises(InputError, match="chart_radius"):
        RKMK(chart_radius=5.0)
    with pytest.raises(InputError, match="3 components"):
        solve(GroupFlow(SO3(), lambda t, g: np.zeros(2)), "rkmk", t_final=1.0, g0=np.eye(3))
    assert calls == []
    assert RKMK().kind is Kind.ADAPTIVE and RKMK4().kind is Kind.FIXED_STEP and RKMK4().order == 4
