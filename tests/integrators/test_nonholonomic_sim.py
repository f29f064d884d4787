"""Simulation of nonholonomic systems: full equations with multipliers, reduced equations, discrete
Lagrange-d'Alembert. Checked against each other, exact solutions, energy and the work-energy balance."""

import numpy as np
import pytest

from geomech import Gait, solve
from geomech.errors import InputError, NumericalError
from geomech.integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert, Status
from geomech.systems.nonholonomic_examples import (
    chaplygin_sleigh,
    roller_racer,
    rolling_disk,
    simplified_bicycle,
    snakeboard,
)

SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
GAIT = {"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}


def full(s, t_final, **kw):
    return solve(s, LagrangeDAlembert(), t_final=t_final, **kw)


def reduced(s, t_final, **kw):
    return solve(s, BKMM(), t_final=t_final, **kw)


def discrete(s, t_final, h, **kw):
    return solve(s, DiscreteLagrangeDAlembert(), t_final=t_final, h=h, **kw)


def max_residual(sol):
    return float(np.abs(sol.constraint_residual).max())


def test_full_and_reduced_agree_on_a_snakeboard_gait():
    s = snakeboard(**SNAKE)
    a = full(s, 1.0, shapes=GAIT, saveat=11)
    b = reduced(s, 1.0, shapes=GAIT, saveat=11)
    np.testing.assert_allclose(a.q, b.q, atol=1e-8)
    np.testing.assert_allclose(a.p, b.p, atol=1e-8)
    assert abs(a.work[-1] - b.work[-1]) < 1e-8
    # the gait drives the board: it moves (backwards along x for this phase) and turns
    assert a.final()["x"] < -0.3 and abs(a.final()["theta"]) > 0.05
    for tr in (a, b):
        assert np.abs(tr.energy - tr.energy[0] - tr.work).max() < 1e-8  # work-energy balance
    assert max_residual(a) < 1e-8 and max_residual(b) < 1e-13
    # the initial state: board at rest, shapes on their gait (x' = y' = theta' = 0 at phi = 0)
    np.testing.assert_allclose(a.qdot[0], [0, 0, 0, 2 * np.pi, np.pi], atol=1e-14)


def test_discrete_integrator_converges_at_second_order():
    s = snakeboard(**SNAKE)
    ref = full(s, 1.0, shapes=GAIT, saveat=3, rtol=1e-12, atol=1e-13)
    hs = np.array([0.02, 0.01, 0.005])
    errs = [np.abs(discrete(s, 1.0, h, shapes=GAIT).q[-1] - ref.q[-1]).max() for h in hs]
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 1.8 < slope < 2.2 and errs[-1] < 5e-5
    c = discrete(s, 1.0, 0.005, shapes=GAIT)
    assert abs(c.work[-1] - ref.work[-1]) < 1e-3 and max_residual(c) < 1e-3


@pytest.mark.parametrize(
    "build, q0, rdot0",
    [
        (snakeboard, {"phi": 0.3}, {"psi": 0.7, "phi": 0.1}),
        (roller_racer, {"phi": 0.4}, {"phi": 0.8}),
        (chaplygin_sleigh, {}, {}),
        (rolling_disk, {}, {"phi": 0.9}),
    ],
)
def test_energy_is_conserved_with_free_shapes_and_no_torque(build, q0, rdot0, rng):
    s = build()
    s = s.with_parameters(**{p.name: float(rng.uniform(0.6, 1.4)) for p in s.parameter_symbols})
    kw = dict(q0=q0, rdot0=rdot0, p0=np.full(1 if s.name != "chaplygin_sleigh" else 2, 0.4))
    a = full(s, 3.0, saveat=31, **kw)
    b = reduced(s, 3.0, saveat=31, **kw)
    c = discrete(s, 3.0, 0.01, **kw)
    E0 = a.energy[0]
    assert np.abs(a.energy - E0).max() < 1e-9 * max(1.0, E0)
    assert np.abs(b.energy - E0).max() < 1e-9 * max(1.0, E0)
    assert np.abs(c.energy - E0).max() < 1e-4 * max(1.0, E0)
    assert max_residual(a) < 1e-9 and max_residual(c) < 1e-3
    assert np.all(a.work == 0) and np.all(c.work == 0)
    np.testing.assert_allclose(a.q, b.q, atol=1e-8)
    assert np.abs(c.q[-1] - a.q[-1]).max() < 1e-4


@pytest.mark.parametrize("sim", ["full", "reduced", "discrete"])
def test_rolling_disk_exact_solution(sim):
    """theta' = w and phi' = nu constant: x = R nu / w (sin(w t) - 0), y = -R nu / w (cos(w t) - 1)."""
    I, R, nu, w = 0.7, 0.4, 1.3, 0.9
    s = rolling_disk(m=1.2, R=R, I=I, J=0.3)
    kw = dict(rdot0={"phi": nu}, p0=[I * w])
    tr = (
        discrete(s, 2.0, 0.01, **kw)
        if sim == "discrete"
        else (full if sim == "full" else reduced)(s, 2.0, saveat=21, **kw)
    )
    t = tr.t
    exact = np.stack([R * nu / w * np.sin(w * t), -R * nu / w * (np.cos(w * t) - 1), w * t, nu * t], -1)
    tol = 1e-4 if sim == "discrete" else 1e-9
    np.testing.assert_allclose(tr.q, exact, atol=tol)


@pytest.mark.parametrize("sim", ["reduced", "full"])
def test_chaplygin_sleigh_exact_speed(sim):
    """v' = a w^2, w' = -m a v w / (I + m a^2) give v(t) = V tanh(kappa V t + artanh(v0 / V)), V^2 = 2E/m,
    kappa = m a / (I + m a^2)."""
    m, I_c, a = 1.5, 0.4, 0.6
    s = chaplygin_sleigh(m=m, I_c=I_c, a=a)
    v0, w0 = 0.2, 1.1
    Itot = I_c + m * a**2
    tr = (reduced if sim == "reduced" else full)(s, 4.0, saveat=41, p0=[m * v0, Itot * w0])
    V = np.sqrt(v0**2 + Itot * w0**2 / m)
    kappa = m * a / Itot
    v_exact = V * np.tanh(kappa * V * tr.t + np.arctanh(v0 / V))
    np.testing.assert_allclose(tr.p[:, 0] / m, v_exact, atol=1e-8)


def test_torque_driven_roller_racer_work_energy_balance():
    s = roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6)
    tau = {"phi": "0.3*sin(3*t) - 0.05*phi_dot"}
    a = full(s, 4.0, tau=tau, saveat=41)
    b = reduced(s, 4.0, tau=tau, saveat=41)
    np.testing.assert_allclose(a.q, b.q, atol=1e-8)
    for tr in (a, b):
        assert np.abs(tr.energy - tr.energy[0] - tr.work).max() < 1e-8
    assert abs(a.work[-1]) > 1e-3 and np.hypot(*a.q[-1, :2]) > 1e-2  # the oscillating joint propels the racer
    c = discrete(s, 4.0, 0.005, tau=tau)
    assert np.abs(c.q[-1] - a.q[-1]).max() < 1e-3 and abs(c.energy[-1] - c.energy[0] - c.work[-1]) < 1e-3


def test_bicycle_with_prescribed_steering_and_free_lean():
    s = simplified_bicycle(m=1.0, h=0.8, c=0.3, b=1.0, g=9.81, J_s=0.05)
    shapes = {"sigma": "0.05*sin(2*t)"}
    kw = dict(shapes=shapes, q0={"phi": 0.02}, p0=[1.0])
    a = full(s, 0.6, saveat=13, **kw)
    b = reduced(s, 0.6, saveat=13, **kw)
    np.testing.assert_allclose(a.q, b.q, atol=1e-8)
    for tr in (a, b):
        assert np.abs(tr.energy - tr.energy[0] - tr.work).max() < 1e-8
    assert a.q[-1, 3] > 0.05  # the bicycle falls over (to the left) without lean control


def test_input_errors():
    s = snakeboard(**SNAKE)
    with pytest.raises(InputError, match="not shape variables"):
        reduced(s, 1.0, shapes={"rho": "t"})
    with pytest.raises(InputError, match="formula in t only"):
        reduced(s, 1.0, shapes={"psi": "sin(w*t)"})
    with pytest.raises(InputError, match="prescribed gait"):
        full(s, 1.0, shapes={"psi": "t"}, tau={"psi": "1"})
    with pytest.raises(InputError, match="violates the constraints"):
        full(s, 1.0, qdot0=[0, 1.0, 0, 0, 0])
    with pytest.raises(InputError, match="positive"):
        discrete(s, 1.0, 0.0)
    with pytest.raises(InputError, match="t_final"):
        full(s, 0.0)  # no span (a t_final before t0 integrates backwards)
    with pytest.raises(InputError, match="whole number of steps"):
        discrete(s, 1.0, 0.3)
    with pytest.raises(InputError, match="no value for parameter"):
        full(snakeboard(), 1.0)


def test_gait_derivatives_are_exact():
    g = Gait.from_expressions({"psi": "sin(2*pi*t)"})
    r, rd, rdd = g(0.1)
    w = 2 * np.pi
    np.testing.assert_allclose([r[0], rd[0], rdd[0]], [np.sin(w * 0.1), w * np.cos(w * 0.1), -(w**2) * np.sin(w * 0.1)])


def test_trajectory_csv(tmp_path):
    tr = reduced(snakeboard(**SNAKE), 0.5, shapes=GAIT, saveat=6)
    path = tr.to_csv(tmp_path / "traj.csv")
    rows = path.read_text().splitlines()
    assert rows[0].startswith("t,x,y,theta,psi,phi,x_dot") and len(rows) == 7
    header = rows[0].split(",")
    extra = {"momentum", "tau1", "tau2", "energy", "work", "constraint_residual1", "constraint_residual2"}
    assert set(header[11:]) == extra
    ds = tr.to_dataset()
    assert {"q", "qdot", "energy", "momentum", "tau", "work", "constraint_residual"} <= set(ds.data_vars)
    assert set(tr.final()) == set(header[1:11])  # positions and velocities by name


def test_principally_kinematic_system_simulates_in_all_three_ways():
    # S_q = 0: no momentum; the reduced simulator is the connection term alone, x' = R cos(theta) psi', ...
    from geomech.systems.nonholonomic_examples import kinematic_car

    s = kinematic_car(m=1.0, I=0.2, R=0.3, ell=1.0, J=0.1, K=0.1)
    gait = {"psi": "2*t", "phi": "0.3"}
    a = full(s, 2.0, shapes=gait, saveat=21)
    b = reduced(s, 2.0, shapes=gait, saveat=21)
    c = discrete(s, 2.0, 0.01, shapes=gait)
    # a circle of radius ell / tan(phi) driven at speed 2 R
    rho, omega = 1.0 / np.tan(0.3), 2 * 0.3 * np.tan(0.3) / 1.0
    th = omega * a.t
    exact = np.column_stack([rho * np.sin(th), rho * (1 - np.cos(th)), th])
    for tr in (a, b):
        np.testing.assert_allclose(tr.q[:, :3], exact, atol=1e-8)
    np.testing.assert_allclose(c.q[-1, :3], exact[-1], atol=1e-4)


def test_bad_torques_and_unphysical_parameters_are_reported():
    s = snakeboard(**SNAKE)
    with pytest.raises(InputError, match=r"unknown function\(s\) \['foo'\]"):
        full(s, 0.1, shapes={"phi": "0"}, tau={"psi": "foo(t)"})
    with pytest.raises(InputError, match="unknown symbols"):
        full(s, 0.1, shapes={"phi": "0"}, tau={"psi": "k*t"})
    # the example declares its mass positive: a negative one is refused when given
    with pytest.raises(InputError, match="`m` of snakeboard to be positive"):
        snakeboard(**{**SNAKE, "m": -1.0})
    # where a model does not declare it (parameters as plain real symbols), the kinetic energy, indefinite on D,
    # is refused before integrating
    import dataclasses

    bad = dataclasses.replace(s, parameters={**s.parameters, "m": -1.0})
    with pytest.raises(InputError, match="not positive definite.*m=-1"):
        reduced(bad, 0.1, shapes=GAIT)


@pytest.mark.parametrize("method", [LagrangeDAlembert(), BKMM()])
def test_a_simulation_needs_an_end_time(method):
    s = chaplygin_sleigh(m=1.0, I_c=0.5, a=0.3)
    with pytest.raises(InputError, match="Expected `t_final`"):
        solve(s, method, t_final=None, p0=[0.1, 0.0])
    sol = solve(s, method, t_final=1.0, saveat=[0.0, 0.5, 1.0], p0=[0.1, 0.0])  # output times as given
    assert sol.t.tolist() == [0.0, 0.5, 1.0]


def test_the_three_methods_agree_through_solve_at_given_output_times():
    s = snakeboard(**SNAKE)
    times = np.array([0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0])  # on the grid of h = 0.005
    a = solve(s, "lagrange_dalembert", t_final=1.0, shapes=GAIT, saveat=times)
    b = solve(s, "bkmm", t_final=1.0, shapes=GAIT, saveat=times)
    c = solve(s, "discrete_lagrange_dalembert", t_final=1.0, h=0.005, shapes=GAIT, saveat=times)
    assert [sol.method.key for sol in (a, b, c)] == ["lagrange_dalembert", "bkmm", "discrete_lagrange_dalembert"]
    for sol in (a, b, c):
        assert sol.status == "success" and sol.success
        np.testing.assert_allclose(sol.t, times, rtol=0, atol=1e-15)
        assert sol.q.shape == (len(times), 5) and sol.g.shape == (len(times), 3) and sol.r.shape == (len(times), 2)
        np.testing.assert_allclose(sol.r[:, 0], np.sin(2 * np.pi * times), atol=1e-12)  # the gait is followed
    np.testing.assert_allclose(a.q, b.q, atol=1e-8)
    np.testing.assert_allclose(a.p, b.p, atol=1e-8)
    np.testing.assert_allclose(c.q, a.q, atol=5e-5)  # second order, h = 0.005
    assert abs(c.work[-1] - a.work[-1]) < 1e-3
    # saving a few times is the same run as saving every step
    every = discrete(s, 1.0, 0.005, shapes=GAIT)
    np.testing.assert_array_equal(c.q, every.q[np.rint(times / 0.005).astype(int)])
    with pytest.raises(InputError, match="not on the step grid"):
        discrete(s, 1.0, 0.005, shapes=GAIT, saveat=[0.0, 0.0123, 1.0])


@pytest.mark.parametrize(
    "method", [LagrangeDAlembert(), pytest.param(BKMM(), marks=pytest.mark.slow)], ids=["lagrange_dalembert", "bkmm"]
)
def test_an_exhausted_budget_is_data_with_the_states_reached(method):
    s = snakeboard(**SNAKE)
    t_final = 10.0
    sol = solve(s, method, t_final=t_final, shapes=GAIT, saveat=101, max_evaluations=3000, raise_on_failure=False)
    assert sol.status == Status.BUDGET_EXHAUSTED == "budget_exhausted" and not sol.success
    assert len(sol.failures) == 1 and "max_evaluations" in sol.message
    when = sol.failures[0].time
    assert 0.0 < when < t_final
    before, after = sol.t <= when, sol.t > when
    assert before.sum() >= 2 and after.sum() >= 2
    assert np.all(np.isfinite(sol.states[before])) and np.all(np.isnan(sol.states[after]))
    assert np.all(np.isfinite(sol.energy[before])) and np.all(np.isnan(sol.energy[after]))
    # raised by default, with the same partial solution on the exception
    with pytest.raises(NumericalError, match="budget") as info:
        solve(s, method, t_final=t_final, shapes=GAIT, saveat=101, max_evaluations=3000)
    np.testing.assert_array_equal(info.value.solution.states, sol.states)
