"""Open-loop torques in time are a Gait, the same type as prescribed shapes: on the free shape of a Lagrangian
system and on the rotors of a body with rotors. Each is checked against the same torques given as formulas or
callables, and against the energy balance dE/dt = (torques) . (rates), integrated independently."""

import numpy as np
import pytest
from scipy.integrate import trapezoid

import geomech as gm
from geomech import Gait, RotorBody
from geomech.errors import InputError
from geomech.systems import two_pinned_bodies


def test_a_torque_gait_on_a_free_shape_is_the_torque_formula():
    # two pinned bodies: a torque tau(t) on the hinge psi, the body angle theta free
    system = two_pinned_bodies(1.0, 3.0)
    start = dict(q0=[0.0, 0.2], qdot0=[0.1, -0.3], t_final=4.0, saveat=801, rtol=1e-12, atol=1e-12)
    gait = Gait.from_expressions({"psi": "0.4*sin(3*t) + 0.1"})
    a = gm.solve(system, "lagrange_dalembert", tau=gait, **start)
    b = gm.solve(system, "lagrange_dalembert", tau={"psi": "0.4*sin(3*t) + 0.1"}, **start)
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_allclose(a.tau[:, 0], 0.4 * np.sin(3 * a.t) + 0.1, rtol=0, atol=1e-13)  # the formula itself
    # the work of the hinge torque is the energy gained; the internal torque keeps the momentum map
    power = a.tau[:, 0] * a.qdot[:, 1]
    work = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(a.t) * (power[1:] + power[:-1]))])
    assert np.ptp(a.energy) > 1e-2
    np.testing.assert_allclose(a.energy - a.energy[0], work, atol=1e-5)
    np.testing.assert_allclose(a.energy - a.energy[0], a.work, atol=1e-9)
    assert np.ptp(a.spatial_momentum) < 1e-10


def test_a_torque_gait_on_rotors_is_the_torque_callable():
    body = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    t = np.linspace(0.0, 10.0, 201)
    gait = Gait.from_expressions(["0.05*sin(t)", "0.05*cos(0.7*t)", "-0.02"])

    def torque(s, R, m, gamma, Gamma):
        return np.array([0.05 * np.sin(s), 0.05 * np.cos(0.7 * s), -0.02])

    kw = dict(t_final=t[-1], saveat=t, m0=[0.4, 1.0, -0.3], Gamma0=[0.05, -0.1, 0.2], rtol=1e-12, atol=1e-12)
    a = gm.solve(body, "solve_ivp", tau=gait, **kw)
    b = gm.solve(body, "solve_ivp", tau=torque, **kw)
    # the same equations, the torque compiled from its formula or called in Python: equal to round-off of the states
    np.testing.assert_allclose(a.states, b.states, rtol=0, atol=1e-13 * max(1.0, float(np.abs(b.states).max())))
    power = np.sum(a.tau * body.rotor_rates(a.m, a.Gamma), axis=-1)
    np.testing.assert_allclose(a.energy[-1] - a.energy[0], trapezoid(power, t), atol=1e-4)
    assert np.ptp(np.linalg.norm(a.spatial_momentum, axis=-1)) < 1e-10
    with pytest.raises(InputError, match="3 component"):
        gm.solve(body, "solve_ivp", tau=Gait.from_expressions(["0.1"]), **kw)


def test_a_torque_gait_must_name_free_shapes():
    system = two_pinned_bodies(1.0, 3.0)
    start = dict(q0=[0.0, 0.2], qdot0=[0.1, -0.3], t_final=1.0)
    with pytest.raises(InputError, match="not a shape variable"):
        gm.solve(system, "lagrange_dalembert", tau=Gait.from_expressions({"theta": "0.1"}), **start)
    with pytest.raises(InputError, match="mapping shape name"):
        gm.solve(system, "lagrange_dalembert", tau=[0.1], **start)
