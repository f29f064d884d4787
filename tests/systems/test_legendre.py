"""A Lagrangian system on SO(3) gives its left-invariant Hamiltonian by the Legendre transform (the Serret-Andoyer
route starts from it), checked against the inverse inertia and against the Lagrangian dynamics themselves."""

import numpy as np
import pytest

from geomech import solve
from geomech.errors import InputError
from geomech.systems import NonholonomicSystem, spacecraft_with_rotors
from geomech.systems.nonholonomic_examples import chaplygin_sleigh

# Body angular velocity of R = Rz(phi) Rx(theta) Rz(psi) (3-1-3 Euler angles; Goldstein), written out here
W1 = "(phi_dot*sin(theta)*sin(psi) + theta_dot*cos(psi))"
W2 = "(phi_dot*sin(theta)*cos(psi) - theta_dot*sin(psi))"
W3 = "(phi_dot*cos(theta) + psi_dot)"
# a full inertia tensor [[a, d, 0], [d, b, e], [0, e, c]] and a constant potential
LAGRANGIAN = f"a*{W1}**2/2 + b*{W2}**2/2 + c*{W3}**2/2 + d*{W1}*{W2} + e*{W2}*{W3} - V0"
VALUES = {"a": 3.0, "b": 2.0, "c": 1.2, "d": 0.3, "e": -0.2, "V0": 0.7}


@pytest.fixture(scope="module")
def body():
    return NonholonomicSystem.from_lagrangian(LAGRANGIAN, "SO3", parameters=VALUES, name="tilted body")


def test_hamiltonian_is_half_m_inverse_inertia_m_plus_v(body, rng):
    H = body.legendre_transform()
    inertia = np.array([[3.0, 0.3, 0.0], [0.3, 2.0, -0.2], [0.0, -0.2, 1.2]])
    m = rng.normal(size=(6, 3))
    want = 0.5 * np.einsum("...i,ij,...j->...", m, np.linalg.inv(inertia), m) + 0.7
    np.testing.assert_allclose(H.hamiltonian(m), want, rtol=1e-13)
    np.testing.assert_allclose(H.gradient(m), m @ np.linalg.inv(inertia), rtol=1e-13)  # omega = I^-1 m
    assert H.parameters == VALUES
    # the parameters follow: with_parameters on the system or on H gives the same Hamiltonian
    H2 = body.with_parameters(a=4.0).legendre_transform()
    np.testing.assert_allclose(H2.hamiltonian(m), H.with_parameters(a=4.0).hamiltonian(m), rtol=1e-13)


def test_lie_poisson_flow_of_h_is_the_lagrangian_flow(body):
    # Two routes: the Euler-Lagrange equations of L in Euler angles (solve's lagrange_dalembert, body momentum
    # dl/dxi read off the solution) and the Lie-Poisson equations m' = m x grad H of the transformed H.
    q0 = np.array([0.3, 1.1, -0.4])
    qd0 = np.array([0.5, -0.3, 0.8])
    lag = solve(body, "lagrange_dalembert", q0=q0, qdot0=qd0, t_final=4.0, saveat=9, rtol=1e-12, atol=1e-12)
    H = body.legendre_transform()
    ham = solve(H, "solve_ivp", m0=lag.momentum[0], t_final=4.0, saveat=9, rtol=1e-12, atol=1e-12)
    scale = np.abs(lag.momentum).max()
    assert np.abs(lag.momentum[-1] - lag.momentum[0]).max() > 0.1 * scale  # the momentum does move
    np.testing.assert_allclose(ham.m, lag.momentum, atol=1e-8 * scale)
    np.testing.assert_allclose(H.hamiltonian(ham.m), lag.energy, rtol=1e-9)


def test_only_a_body_on_so3_without_shape_or_constraints():
    with pytest.raises(InputError, match="needs G = SO"):
        chaplygin_sleigh(m=1.0, I_c=0.2, a=0.3).legendre_transform()
    with pytest.raises(InputError, match="shape variable"):
        spacecraft_with_rotors().legendre_transform()
    bare = NonholonomicSystem.from_lagrangian(f"a*{W1}**2/2 + b*{W2}**2/2 + c*{W3}**2/2", "SO3", name="no values")
    with pytest.raises(InputError, match=r"with_parameters\("):
        bare.legendre_transform()
