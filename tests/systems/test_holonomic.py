"""Holonomic systems on Q = G x S: groups, Lagrangians, reduced mass matrices, full simulation."""

import numpy as np
import pytest
import sympy as sp

from geomech.errors import InputError, ShapeError, SingularityError, SymbolicError
from geomech.lie import SE2, SE3, SO2, named_group
from geomech.systems import (
    HolonomicSystem,
    planar_point_masses,
    planar_point_positions,
    spacecraft_with_rotors,
    three_link_chain,
    three_link_positions,
    two_pinned_bodies,
)


@pytest.fixture(scope="module")
def three_bodies():
    return planar_point_masses([1.0, 2.0, 1.5])


def test_group_names_and_errors():
    assert named_group("so(2)") == SO2() and named_group("se(2)") == SE2() and named_group("SE3") == SE3()
    with pytest.raises(InputError, match="one of"):
        named_group("SE7")
    with pytest.raises(InputError, match="Expected 1 coordinate names for SO"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2 + psi_dot**2/2", SO2("a", "b"), ["psi"])
    s = HolonomicSystem.from_lagrangian("a_dot**2/2 + (a_dot + psi_dot)**2/2", SO2("a"), ["psi"])
    assert [c.name for c in s.group.coordinates] == ["a"] and s.c == 0 and s.shape_angles == (0,)


def test_two_pinned_bodies_reduced_mass_matrix():
    s = two_pinned_bodies(1.0, 3.0)
    I1, I2 = sp.symbols("I1 I2", real=True)
    assert sp.simplify(s.reduced_mass_matrix - sp.Matrix([[I1 + I2, I2], [I2, I2]])) == sp.zeros(2, 2)
    np.testing.assert_allclose(s.reduced_mass_function(np.array([0.3])), [[4.0, 3.0], [3.0, 3.0]])
    assert s.shape_angles == (0,)


def test_planar_masses_kinetic_energy_from_positions(three_bodies, rng):
    # T from the inertial positions (differentiated numerically) must equal 1/2 qdot^T M qdot.
    s = three_bodies
    Mf = s.compile(s.mass_matrix, s.q)
    m = np.array([1.0, 2.0, 1.5])
    for _ in range(4):
        q = np.concatenate([rng.normal(size=3), [rng.uniform(0.5, 2)], rng.normal(size=2)])
        qd = rng.normal(size=6)
        h = 1e-6
        v = (planar_point_positions(s, q + h * qd) - planar_point_positions(s, q - h * qd)) / (2 * h)
        T_pos = 0.5 * np.sum(m[:, None] * v**2)
        np.testing.assert_allclose(0.5 * qd @ Mf(q) @ qd, T_pos, rtol=1e-8)
        X = planar_point_positions(s, q)
        np.testing.assert_allclose(m @ X / m.sum(), q[:2], atol=1e-12)  # (x, y) is the centre of mass
        d = X[1] - X[0]
        assert abs(np.arctan2(d[1], d[0]) - q[2]) < 1e-12 or abs(abs(np.arctan2(d[1], d[0]) - q[2]) - 2 * np.pi) < 1e-9


@pytest.mark.parametrize("masses", [[1.0, 2.0, 1.5], [1.0, 2.0, 1.5, 0.7]])
def test_planar_masses_potential_is_the_pair_sum_over_positions(masses, rng):
    """The potential of the Lagrangian (its distances written from the Jacobi vectors, each component one
    fraction) against -sum m_i m_j / |x_i - x_j| over the inertial positions, a second construction; and compact
    (the distances' arguments were once expanded over (m1 + m2)^4 denominators)."""
    s = planar_point_masses(masses)
    V = -s.lagrangian.xreplace({v: 0 for v in s.qdot})
    Vf = s.compile(V, s.q)
    m = np.array(masses)
    for _ in range(3):
        q = np.concatenate([rng.normal(size=3), [rng.uniform(0.5, 2)], rng.normal(size=s.sigma - 1)])
        X = planar_point_positions(s, q)
        pairs = [(i, j) for i in range(m.size) for j in range(i + 1, m.size)]
        expected = -sum(m[i] * m[j] / np.linalg.norm(X[i] - X[j]) for i, j in pairs)
        np.testing.assert_allclose(Vf(q), expected, rtol=1e-12)
    assert sp.count_ops(V) < 60 * len(masses)


def test_planar_masses_locked_inertia_closed_form(three_bodies, rng):
    s = three_bodies
    m1, m2, m3 = 1.0, 2.0, 1.5
    mu1, mu2 = m1 * m2 / (m1 + m2), m3 * (m1 + m2) / (m1 + m2 + m3)
    for _ in range(3):
        r = np.array([rng.uniform(0.5, 2), *rng.normal(size=2)])
        I, IA, _ = s.shape_matrix(r)
        I_th = mu1 * r[0] ** 2 + mu2 * (r[1] ** 2 + r[2] ** 2)
        np.testing.assert_allclose(I, np.diag([4.5, 4.5, I_th]), atol=1e-12)
        # A_theta = sum mu_j (s_j x ds_j) / I_theta with s_1 = (rho, 0), s_2 = (a, b)
        np.testing.assert_allclose(IA[2], [0.0, -mu2 * r[2], mu2 * r[1]], atol=1e-12)
        np.testing.assert_allclose(IA[:2], 0.0, atol=1e-12)


def test_three_link_chain_straight_is_a_rod():
    # A straight chain of three unit rods is one rod of length 3 and mass 3: I = M L^2 / 12 = 9/4.
    s = three_link_chain(origin="middle")
    I, IA, _ = s.shape_matrix(np.zeros(2))
    np.testing.assert_allclose(I, np.diag([3.0, 3.0, 2.25]), atol=1e-12)
    # With the middle link held, alpha1' = 1 turns link 1 (centre at (-1, 0)) at -1 rad/s: its centre moves
    # at (0, 1/2), momentum (0, 1/2), angular momentum -1/2 - J1 = -7/12; alpha2' = 1 mirrors it.
    np.testing.assert_allclose(IA, [[0.0, 0.0], [0.5, 0.5], [-7 / 12, 7 / 12]], atol=1e-12)


@pytest.mark.parametrize("origin", ["com", "middle"])
def test_three_link_positions_are_the_chain_the_coordinates_say(origin, rng):
    """Links of the given lengths, joint angles and heading read back from the points, and (x, y) the centre of
    mass or of the middle link, at random states of a chain with unequal links (vectorised over states)."""
    masses, lengths = np.array([1.0, 2.0, 0.5]), np.array([0.7, 1.2, 0.9])
    s = three_link_chain(masses, lengths, origin=origin)
    q = rng.uniform(-2, 2, (4, 5))
    P = three_link_positions(s, q)
    assert P.shape == (4, 4, 2)
    links = np.diff(P, axis=1)
    np.testing.assert_allclose(np.linalg.norm(links, axis=-1), np.broadcast_to(lengths, (4, 3)), atol=1e-12)
    heading = np.arctan2(links[..., 1], links[..., 0])
    wrap = lambda a: np.angle(np.exp(1j * a))  # noqa: E731
    np.testing.assert_allclose(wrap(heading[:, 1] - q[:, 2]), 0, atol=1e-12)
    np.testing.assert_allclose(wrap(heading[:, 1] - heading[:, 0] - q[:, 3]), 0, atol=1e-12)
    np.testing.assert_allclose(wrap(heading[:, 2] - heading[:, 1] - q[:, 4]), 0, atol=1e-12)
    centres = (P[:, :-1] + P[:, 1:]) / 2
    origin_point = masses @ centres / masses.sum() if origin == "com" else centres[:, 1]
    np.testing.assert_allclose(origin_point, q[:, :2], atol=1e-12)
    with pytest.raises(InputError, match="three_link_chain"):
        three_link_positions(two_pinned_bodies(), np.zeros(4))


def test_spacecraft_reduced_mass_matrix():
    s = spacecraft_with_rotors([3.0, 2.0, 1.0], axes=[[1, 0, 0], [0, 1, 0]], rotor_inertias=[0.2, 0.3])
    M = s.reduced_mass_function(np.zeros(2))
    want = np.array([[3, 0, 0, 0.2, 0], [0, 2, 0, 0, 0.3], [0, 0, 1, 0, 0], [0.2, 0, 0, 0.2, 0], [0, 0.3, 0, 0, 0.3]])
    np.testing.assert_allclose(M, want, atol=1e-14)


def test_from_lagrangian_rejects_what_is_not_invariant_or_not_simple():
    with pytest.raises(SymbolicError, match="not invariant"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2 + psi_dot**2/2 + cos(theta)", "S1", ["psi"])
    with pytest.raises(SymbolicError, match="not invariant under SE"):
        HolonomicSystem.from_lagrangian("(x_dot**2 + y_dot**2)/2 + x**2*theta_dot**2/2 + r_dot**2/2", "SE2", ["r"])
    with pytest.raises(SymbolicError, match="linear in the velocities"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2 + psi_dot**2/2 + psi*theta_dot", "S1", ["psi"])
    with pytest.raises(SymbolicError, match="quadratic"):
        HolonomicSystem.from_lagrangian("theta_dot**4/2 + psi_dot**2/2", "S1", ["psi"])
    # a mixed cubic term, hidden in a product, and one that is not a polynomial in the velocities at all
    with pytest.raises(SymbolicError, match="degree > 2"):
        HolonomicSystem.from_lagrangian("(theta_dot + psi_dot)**2*(1 + psi_dot)/2 + psi_dot**2/2", "S1", ["psi"])
    with pytest.raises(SymbolicError, match="not polynomial|quadratic"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2 + psi_dot**2/2 + cos(psi)*exp(psi_dot)", "S1", ["psi"])
    symbolic = HolonomicSystem.from_lagrangian("J*theta_dot**2/2 + psi_dot**2/2", "S1", ["psi"])
    with pytest.raises(InputError, match=r"no value for parameter\(s\) \['J'\]"):
        symbolic.reduced_mass_function  # noqa: B018 (compiling needs every value)
    assert symbolic.with_parameters(J=2.0).reduced_mass_function(np.zeros(1))[0, 0] == 2.0
    with pytest.raises(InputError, match="Expected 3 coordinate names for SE"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2", SE2("theta"), ["psi"])
    with pytest.raises(ShapeError, match="no constraints"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2 + psi_dot**2/2", "S1", ["psi"], ["theta_dot - psi_dot"])
    with pytest.raises(ShapeError, match="rigid body"):
        HolonomicSystem.from_lagrangian("theta_dot**2/2", "S1", [])


def test_invariant_user_lagrangian_with_positions_through_g():
    # A point mass on a rotating arm written in inertial coordinates: SE(2)-invariant after all.
    L = (
        "(x_dot**2 + y_dot**2)/2 + (x_dot - r_dot*sin(theta) - r*cos(theta)*theta_dot)**2/2"
        " + (y_dot + r_dot*cos(theta) - r*sin(theta)*theta_dot)**2/2 + theta_dot**2/2"
    )
    s = HolonomicSystem.from_lagrangian(L, "SE2", ["r"])
    assert not any(s.reduced_mass_matrix.has(a) for a in s.group.coordinates)


def test_pinned_bodies_input_errors():
    with pytest.raises(SingularityError, match="singular"):
        two_pinned_bodies(0.0, 0.0)
    with pytest.raises(InputError, match=">= 0"):
        two_pinned_bodies(-1.0, 2.0)


def test_locked_inertia_singular_when_all_masses_coincide(three_bodies):
    with pytest.raises(SingularityError, match="singular"):
        three_bodies.check_locked_inertia(np.zeros(3))


def test_free_simulation_conserves_energy_and_momentum():
    # Euler-Lagrange equations of the free chain through solve(): energy and the SE(2) momentum map are conserved,
    # and the Solution's spatial momentum is the connection's momentum map (two routes: the numeric Legendre
    # transform with Ad*, and the symbolic J(q, qdot) of the generators).
    from geomech import solve
    from geomech.reduction import bkmm_reduction

    s = three_link_chain(origin="middle")
    q0 = np.array([0.3, -0.2, 0.5, 0.4, -0.7])
    qd0 = np.array([0.2, -0.1, 0.3, 1.1, -0.8])
    sol = solve(s, "lagrange_dalembert", q0=q0, qdot0=qd0, t_final=3.0, saveat=31, rtol=1e-12, atol=1e-12)
    Mf = s.compile(s.mass_matrix, s.q)
    E = np.array([0.5 * v @ Mf(q) @ v for q, v in zip(sol.q, sol.qdot)])
    J = bkmm_reduction(s).numeric().momentum_map(sol.q, sol.qdot)
    assert np.abs(E - E[0]).max() < 1e-10 * E[0]
    np.testing.assert_allclose(sol.energy, E, rtol=1e-12)
    assert np.abs(J - J[0]).max() < 1e-10
    np.testing.assert_allclose(sol.spatial_momentum, J, atol=1e-12 * np.abs(J).max())
    assert np.ptp(sol.momentum[:, 2]) > 1e-2  # the body momentum is not conserved on SE(2), its image J is
    # the group part as elements of SE(2): the translation column is (x, y)
    np.testing.assert_allclose(sol.element[:, :2, 2], sol.g[:, :2], atol=1e-15)
    assert sol.net_motion()["theta"] == pytest.approx(sol.g[-1, 2] - sol.g[0, 2])
    # the same state from the shape rates and the body momentum (rdot0, p0) instead of every velocity
    again = solve(
        s,
        "lagrange_dalembert",
        q0=q0,
        rdot0=qd0[3:],
        p0=sol.momentum[0],
        t_final=3.0,
        saveat=31,
        rtol=1e-12,
        atol=1e-12,
    )
    np.testing.assert_allclose(again.qdot[0], qd0, atol=1e-13)
