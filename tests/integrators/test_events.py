"""Events located by the continuous extension of the compiled embedded pairs (``solve(..., events=...)``), against
the exact solutions they should land on: the free body's elliptic functions and the pendulum's period."""

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipk

import geomech as gm
from geomech.errors import InputError
from geomech.integrators import BKMM, Event, IncompatibleMethodError, LagrangeDAlembert, NonholonomicHamilton, SolveIVP

BODY = gm.RigidBody([3.0, 2.0, 1.0])
M0 = np.array([1.0, 0.3, 0.2])


def exact_zeros(f, t_end, n=4000):
    """The zeros of f on [0, t_end] (sign changes on a fine grid, each refined by Brent's method)."""
    t = np.linspace(0.0, t_end, n)
    v = np.array([f(s) for s in t])
    return np.array(
        [brentq(f, t[i], t[i + 1], xtol=1e-15) for i in np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)]
    )


@pytest.fixture(scope="module")
def exact():
    return BODY.exact_solution(M0)


# the compiled pair, and scipy's solvers stepped from Python (an explicit pair, an implicit Radau method, BDF)
METHODS = ["dop853", SolveIVP(solver="DOP853"), SolveIVP(solver="Radau"), SolveIVP(solver="BDF")]


@pytest.mark.parametrize("method", METHODS, ids=str)
def test_the_zeros_of_a_component_are_the_exact_solutions(exact, method):
    tight = isinstance(method, str) or method.solver == "DOP853"
    tol = 1e-12 if tight else 1e-11  # BDF and Radau to 1e-11 in a few seconds
    sol = gm.solve(BODY, method, m0=M0, t_final=40.0, rtol=tol, atol=tol, events={"m2_zero": "m2"})
    rows = sol.events["m2_zero"]
    expected = exact_zeros(lambda s: exact.momentum(np.array([s]))[0, 1], 40.0)
    assert len(rows) == len(expected) >= 4
    assert np.all(rows[:, 0] == 0)  # one trajectory
    # the times to the accuracy of the run: |dm2/dt| is of order 0.3 here, the state error of order 1e-11 (the
    # compiled and scipy's DOP853); BDF's and Radau's within 20 times their own state error
    err = sol.m[-1] - exact.momentum(np.array([40.0]))[0]
    accuracy = 1e-9 if tight else 20 * max(float(np.abs(err).max()), 1e-12)
    np.testing.assert_allclose(rows[:, 1], expected, rtol=0, atol=accuracy)
    np.testing.assert_allclose(rows[:, 3], 0.0, atol=1e-12)  # the state at the event: m2 = 0
    np.testing.assert_allclose(rows[:, 2:], exact.momentum(rows[:, 1]), rtol=0, atol=accuracy)


@pytest.mark.parametrize("method", METHODS[:2], ids=str)
def test_a_direction_keeps_one_kind_of_crossing_and_a_terminal_event_ends_the_run(exact, method):
    both = gm.solve(BODY, method, m0=M0, t_final=40.0, rtol=1e-11, atol=1e-12, events={"z": "m3"}).events["z"]
    falling = gm.solve(
        BODY, method, m0=M0, t_final=40.0, rtol=1e-11, atol=1e-12, events={"z": Event("m3", direction=-1)}
    ).events["z"]
    velocity = np.cross(falling[:, 2:], falling[:, 2:] / [3.0, 2.0, 1.0])[:, 2]  # m x grad H
    assert len(falling) < len(both) and np.all(velocity < 0)
    np.testing.assert_allclose(falling[:, 1], both[1::2, 1] if both[0, 4] > 0 else both[::2, 1], rtol=0, atol=1e-9)
    sol = gm.solve(
        BODY,
        method,
        m0=M0,
        t_final=40.0,
        saveat=81,
        rtol=1e-11,
        atol=1e-12,
        events={"stop": Event("m3", direction=-1, terminal=True), "m2_zero": "m2"},
    )
    stop = sol.events["stop"]
    assert sol.status == "success" and len(stop) == 1
    np.testing.assert_allclose(stop[0, 1], falling[0, 1], rtol=0, atol=1e-12)
    after = sol.t > stop[0, 1]
    assert np.isnan(sol.m[after]).all() and np.isfinite(sol.m[~after]).all()
    np.testing.assert_allclose(sol.m[~after], exact.momentum(sol.t[~after]), rtol=0, atol=1e-9)
    # the other events up to the stop only
    assert np.all(sol.events["m2_zero"][:, 1] <= stop[0, 1])


def test_the_pendulum_crosses_its_bottom_once_a_period():
    """H = p^2/2 - cos q from (q, p) = (a, 0): q = 0 is crossed upwards every T = 4 K(sin^2(a/2))."""
    pendulum = gm.CanonicalSystem.from_expression("p**2/2 - cos(q)", ["q"], ["p"])
    a = 2.0
    sol = gm.solve(
        pendulum, "dopri5", y0=[a, 0.0], t_final=60.0, rtol=1e-11, atol=1e-12, events={"up": Event("q", direction=1)}
    )
    times = sol.events["up"][:, 1]
    T = 4.0 * ellipk(np.sin(a / 2) ** 2)
    assert len(times) >= 5
    np.testing.assert_allclose(np.diff(times), T, rtol=0, atol=1e-8)
    np.testing.assert_allclose(sol.events["up"][:, 3], np.sqrt(2 * (1 - np.cos(a))), rtol=1e-9)  # p at the bottom


def test_a_batch_reports_each_trajectory_and_events_read_parameters():
    m0 = np.array([[1.0, 0.3, 0.2], [0.2, 0.3, 1.0]])
    sol = gm.solve(
        BODY, "dop853", m0=m0, t_final=20.0, rtol=1e-10, atol=1e-12, events={"energy_level": "m1**2/I1 - 0.3"}
    )
    rows = sol.events["energy_level"]
    assert set(rows[:, 0]) <= {0.0, 1.0} and (rows[:, 0] == 0).any()
    np.testing.assert_allclose(rows[:, 2] ** 2 / 3.0, 0.3, rtol=1e-9)
    for b in (0, 1):
        assert np.all(np.diff(rows[rows[:, 0] == b, 1]) > 0)  # time order within a trajectory


def test_bad_events_are_named():
    run = dict(m0=M0, t_final=5.0, rtol=1e-10, atol=1e-12)
    with pytest.raises(InputError, match="x9"):
        gm.solve(BODY, "dop853", events={"e": "m1 - x9"}, **run)
    with pytest.raises(IncompatibleMethodError, match="dop853"):
        gm.solve(BODY, "rk4", m0=M0, t_final=1.0, h=0.1, events={"e": "m1"})
    with pytest.raises(InputError, match="direction"):
        Event("m1", direction=2)
    with pytest.raises(InputError, match="mapping"):
        gm.solve(BODY, "dop853", events="m1", **run)
    with pytest.raises(InputError, match="max_events"):
        gm.solve(BODY, "dop853", events={"e": "m2"}, max_events=1, **{**run, "t_final": 40.0})


SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
GAIT = {"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}


def test_a_gait_returning_to_its_start_and_a_group_coordinate_crossing_a_value():
    """The snakeboard under a periodic gait: psi (prescribed) returns to 0 rising at every whole period; the heading
    theta (integrated) reaches a value where a run stopped at that time ends on it."""
    from geomech.systems.nonholonomic_examples import snakeboard

    board = snakeboard(**SNAKE)
    run = dict(t_final=3.5, shapes=GAIT, parameters={"a": 1.0}, rtol=1e-11, atol=1e-12)
    sol = gm.solve(
        board, "bkmm", events={"period": Event("psi", direction=1), "turn": Event("theta - 0.2", terminal=True)}, **run
    )
    period, turn = sol.events["period"], sol.events["turn"]
    assert sol.status == "success" and len(turn) == 1
    t_turn = turn[0, 1]
    whole = np.arange(1.0, np.floor(t_turn) + 1)
    np.testing.assert_allclose(period[:, 1], whole, rtol=0, atol=1e-12)  # the gait's zeros, exactly
    labels = list(sol.labels)
    np.testing.assert_allclose(turn[0, 2 + labels.index("theta")], 0.2, atol=1e-12)
    # a second route: the run that ends at that time ends where the event row says
    again = gm.solve(board, "bkmm", **{**run, "t_final": t_turn})
    np.testing.assert_allclose(turn[0, 2:], again.states[-1], rtol=0, atol=1e-8)
    after = sol.t > t_turn
    assert np.isnan(sol.states[after]).all() and np.isfinite(sol.states[~after]).all()
    # a batch over the gait's amplitude: each member's events, in its own rows
    batch = gm.solve(
        board,
        "bkmm",
        events={"period": Event("psi", direction=1)},
        **{**run, "parameters": {"a": np.array([0.8, 1.2])}},
    )
    rows = batch.events["period"]
    for b in (0, 1):
        np.testing.assert_allclose(rows[rows[:, 0] == b, 1], [1.0, 2.0, 3.0], rtol=0, atol=1e-12)
    # the Lagrange-d'Alembert equations with multipliers, compiled: the same events, a second route to them
    lda = gm.solve(
        board,
        "lagrange_dalembert",
        events={"period": Event("psi", direction=1), "turn": Event("theta - 0.2", terminal=True)},
        **run,
    )
    assert lda.stats["backend"] == "numba"
    np.testing.assert_allclose(lda.events["period"][:, 1], whole, rtol=0, atol=1e-12)
    np.testing.assert_allclose(lda.events["turn"][:, 1:], turn[:, 1:], rtol=0, atol=1e-8)
    # Taylor's method on the BKMM equations: the events on its steps' polynomials, one member and a batch
    taylor = gm.solve(
        board,
        BKMM(solver="taylor"),
        events={"period": Event("psi", direction=1), "turn": Event("theta - 0.2", terminal=True)},
        **run,
    )
    assert taylor.status == "success"
    np.testing.assert_allclose(taylor.events["period"][:, 1], whole, rtol=0, atol=1e-12)
    np.testing.assert_allclose(taylor.events["turn"][:, 1:], turn[:, 1:], rtol=0, atol=1e-8)
    assert np.isnan(taylor.states[after]).all() and np.isfinite(taylor.states[~after]).all()
    rows = gm.solve(
        board,
        BKMM(solver="taylor"),
        events={"period": Event("psi", direction=1)},
        **{**run, "parameters": {"a": np.array([0.8, 1.2])}},
    ).events["period"]
    for b in (0, 1):
        np.testing.assert_allclose(rows[rows[:, 0] == b, 1], [1.0, 2.0, 3.0], rtol=0, atol=1e-12)
    with pytest.raises(InputError, match="discrete Lagrange-d'Alembert map has none"):
        gm.solve(board, "discrete_lagrange_dalembert", h=0.01, events={"e": "x"}, **{**run, "rtol": None, "atol": None})
    with pytest.raises(InputError, match=r"LagrangeDAlembert state of snakeboard .*theta_dot"):
        gm.solve(board, "lagrange_dalembert", events={"e": "p0"}, **run)
    # the equations in Python stepped by scipy's solvers (an explicit pair, implicit Radau): the same events, by the
    # solvers' dense output
    events = {"period": Event("psi", direction=1), "turn": Event("theta - 0.2", terminal=True)}
    for method in (LagrangeDAlembert(), BKMM(solver="Radau")):
        python = gm.solve(board, method, backend="python", events=events, **run)
        assert python.stats["backend"] == "python" and python.status == "success"
        np.testing.assert_allclose(python.events["period"][:, 1], whole, rtol=0, atol=1e-10)
        np.testing.assert_allclose(python.events["turn"][:, 1:], turn[:, 1:], rtol=0, atol=1e-7)
        assert np.isnan(python.states[after]).all() and np.isfinite(python.states[~after]).all()
    with pytest.raises(InputError, match=r"\['p0'\].*theta_dot"):
        gm.solve(board, "lagrange_dalembert", backend="python", events={"e": "p0"}, **run)


def test_the_hamiltonian_forms_locate_the_coasting_sleighs_events_as_bkmm():
    """The Chaplygin sleigh coasting from a momentum: its heading's crossings of 1/2 and the turn rate's maximum
    (theta_dot falling through a value), by Hamilton's equations in each form (scipy's DOP853 on z = (q, pt)) and
    by the BKMM equations (momentum and reconstruction; in Python, where an event may read the group's velocity):
    two routes to the same instants."""
    from geomech.systems.nonholonomic_examples import chaplygin_sleigh

    sleigh = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
    run = dict(t_final=10.0, p0=[0.3, 0.5], rtol=1e-11, atol=1e-12)
    events = {"heading": "theta - 1/2", "slow": Event("theta_dot - 0.3", direction=-1, terminal=True)}
    bkmm = gm.solve(sleigh, "bkmm", backend="python", events=events, **run)
    assert len(bkmm.events["heading"]) >= 1 and len(bkmm.events["slow"]) == 1
    labels = list(bkmm.labels)
    np.testing.assert_allclose(bkmm.events["heading"][:, 2 + labels.index("theta")], 0.5, atol=1e-12)
    np.testing.assert_allclose(bkmm.events["slow"][:, 2 + labels.index("theta_dot")], 0.3, atol=1e-12)
    for form in ("almost_poisson", "bates_sniatycki", "full"):
        ham = gm.solve(sleigh, NonholonomicHamilton(form=form), events=events, **run)
        for name in events:
            assert len(ham.events[name]) == len(bkmm.events[name]), (form, name)
            np.testing.assert_allclose(ham.events[name][:, 1:], bkmm.events[name][:, 1:], rtol=0, atol=1e-8)


def test_events_at_the_same_instant_are_each_recorded():
    """Two formulas with the same zeros (m2 and -2 m2) cross in the same step at the same fraction: each is listed,
    at the same time, and a terminal one stops both there."""
    run = dict(m0=M0, t_final=25.0, rtol=1e-11, atol=1e-12)
    sol = gm.solve(BODY, "dop853", events={"a": "m2", "b": "-2*m2"}, **run)
    a, b = sol.events["a"], sol.events["b"]
    assert len(a) == len(b) >= 2
    np.testing.assert_array_equal(a[:, 1], b[:, 1])
    stopped = gm.solve(BODY, "dop853", events={"a": "m2", "b": Event("-2*m2", terminal=True)}, **run)
    assert len(stopped.events["a"]) == len(stopped.events["b"]) == 1
    assert stopped.events["a"][0, 1] == stopped.events["b"][0, 1] == a[0, 1]
