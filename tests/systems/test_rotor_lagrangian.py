"""A body with rotors in the one description: RotorBody.lagrangian_system() is a HolonomicSystem on SO(3) x T^N whose
Euler-Lagrange equations (solved in Euler angles, rotor torques as shape forces) are the seed's Hamiltonian
equations (26, 38) that RotorBody integrates in (R, m, gamma, Gamma)."""

import numpy as np
import pytest

from geomech import Gait, solve
from geomech.reduction import bkmm_reduction
from geomech.systems import RotorBody

BODIES = {
    "one rotor": lambda: RotorBody.one_rotor(3.0, 2.0, 1.0, 0.4),
    "three rotors": lambda: RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.15, 0.2]),
    "pyramid": lambda: RotorBody.pyramid([[3.0, 0.2, 0.0], [0.2, 2.5, 0.1], [0.0, 0.1, 1.8]], 0.05),
}


@pytest.mark.parametrize("name", list(BODIES))
@pytest.mark.parametrize("torque", [False, True])
def test_euler_lagrange_equations_are_the_hamiltonian_ones(name, torque, rng):
    body = BODIES[name]()
    system = body.lagrangian_system()
    n = body.n_rotors
    angles = np.array([0.3, 1.0, -0.2])  # away from the gimbal lock of 3-1-3 angles
    gamma0 = rng.uniform(-1, 1, n)
    m0, Gamma0 = rng.normal(size=3), 0.3 * rng.normal(size=n)
    R0 = system.group.from_coordinates(angles)
    omega0 = body.angular_velocity(m0, Gamma0)
    gamma_dot0 = body.rotor_rates(m0, Gamma0)
    formulas = [f"{0.2 * (k + 1)}*sin({1.5 + k}*t)" for k in range(n)]
    kw_h = {"tau": Gait.from_expressions(formulas)} if torque else {}
    kw_l = {"tau": {f"gamma{k + 1}": f for k, f in enumerate(formulas)}} if torque else {}
    times = dict(t_final=3.0, saveat=7, rtol=1e-12, atol=1e-12)
    ham = solve(body, "solve_ivp", m0=m0, Gamma0=Gamma0, R0=R0, gamma0=gamma0, **times, **kw_h)
    lag = solve(system, "lagrange_dalembert", q0=np.r_[angles, gamma0], rdot0=gamma_dot0, p0=m0, **times, **kw_l)
    assert np.allclose(system.group.numeric.inverse(R0) @ lag.element[0], np.eye(3), atol=1e-12)
    # the body momentum dl/domega is m, the attitude and the rotor angles agree
    scale = 1.0 + np.abs(ham.m).max()
    np.testing.assert_allclose(lag.momentum, ham.m, atol=1e-8 * scale)
    np.testing.assert_allclose(lag.element, ham.R, atol=1e-8)
    np.testing.assert_allclose(lag.q[:, 3:], ham.gamma, atol=1e-8)
    # Gamma_i = J_i (a_i . omega + gamma_i') along the Lagrangian solution
    omega = np.einsum("tij,tj->ti", system.body_velocity_matrix_function(lag.q[:, :3]), lag.qdot[:, :3])
    Gamma = body.rotor_inertia * (omega @ body.A + lag.qdot[:, 3:])
    np.testing.assert_allclose(Gamma, ham.Gamma, atol=1e-8 * scale)
    np.testing.assert_allclose(omega[0], omega0, atol=1e-12 * scale)
    if torque:
        assert np.abs(ham.Gamma[-1] - Gamma0).max() > 1e-3  # the motors did act


def test_the_rotors_connection_is_the_bracket_term_constant(rng):
    # l = 1/2 w.(Lambda + sum J a a^T) w + sum J (a.w) gamma' + ...: A = I_locked^-1 [J_k a_k], constant
    body = BODIES["three rotors"]()
    c = bkmm_reduction(body.lagrangian_system()).numeric()
    want = np.linalg.solve(body.locked_inertia, body.A * body.rotor_inertia)
    for r in rng.uniform(-3, 3, (3, 3)):
        np.testing.assert_allclose(c.connection(r), want, atol=1e-14)
    np.testing.assert_allclose(c.locked_inertia(np.zeros(3)), body.locked_inertia, atol=1e-14)
