"""Quaternion canonical coordinates of T*SO(3): the chart derived independently with sympy, the momentum map, the
flow against a Lie-group solution, and Remark 10 of the Serret-Andoyer paper as computations: the midpoint rule
conserves the spatial momentum in quaternion coordinates and not in Euler angles."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.errors import SingularityError, SymbolicError
from geomech.integrators import DormandPrince, ImplicitMidpoint
from geomech.lie import quaternion as quat
from geomech.lie import so3
from geomech.reduction import ClassicalSerretAndoyer, EulerCoordinates, QuaternionCoordinates
from geomech.systems import LeftInvariantSystem, RigidBody

FREE = "m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)"
INERTIA = {"I1": 3.0, "I2": 2.0, "I3": 1.0}


def free_body() -> LeftInvariantSystem:
    return LeftInvariantSystem.from_expression(FREE, parameters=INERTIA)


def own_system() -> LeftInvariantSystem:
    """Not a rigid body: a quartic term and a cross term (a user's own Hamiltonian)."""
    return LeftInvariantSystem.from_expression(
        FREE + " + c*m1**4 + d*m2*m3", parameters={**INERTIA, "c": 0.1, "d": 0.2}
    )


def _qmul(a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    """The Hamilton product written out (independent of geomech.lie.quaternion)."""
    w1, v1, w2, v2 = a[0], a[1:, 0], b[0], b[1:, 0]
    return sp.Matrix([w1 * w2 - v1.dot(v2), *(w1 * v2 + w2 * v1 + v1.cross(v2))])


def test_legendre_map_of_the_quaternion_lagrangian_gives_the_body_momentum(rng):
    # L(q, qdot) = 1/2 w.I w with w = 2 Im(conj(q) qdot), differentiated by sympy; at a unit q the chart's
    # m = 1/2 Im(conj(q) pi) must be I w, and its forward map must give back pi.
    q = sp.Matrix(sp.symbols("a0:4", real=True))
    qd = sp.Matrix(sp.symbols("b0:4", real=True))
    conj = sp.Matrix([q[0], -q[1], -q[2], -q[3]])
    omega = 2 * _qmul(conj, qd)[1:, 0]
    inertia = sp.diag(3, 2, 1)
    L = (omega.T * inertia * omega)[0] / 2
    pi = sp.Matrix([sp.diff(L, s) for s in qd])
    chart = QuaternionCoordinates(free_body())
    for _ in range(5):
        qv = quat.random(rng)
        qdv = rng.normal(size=4)
        sub = {**dict(zip(q, qv)), **dict(zip(qd, qdv))}
        piv = np.array(pi.subs(sub), dtype=float).ravel()
        w = np.array(omega.subs(sub), dtype=float).ravel()
        y = np.concatenate([qv, piv])
        np.testing.assert_allclose(chart.body_momentum(y), np.diag([3.0, 2.0, 1.0]) @ w, rtol=0, atol=1e-12 * 10)
        # qdot's component along q does not enter L; pi is the forward map of (q, m) in any case
        np.testing.assert_allclose(chart.from_quaternion(qv, chart.body_momentum(y)), y, rtol=0, atol=1e-11)


def test_chart_round_trip_and_spatial_momentum_is_R_m(rng):
    chart = QuaternionCoordinates(free_body())
    R = so3.exp(rng.normal(size=(6, 3)))
    m = rng.normal(size=(6, 3))
    y = chart.forward(R, m)
    R2, m2 = chart.inverse(y)
    np.testing.assert_allclose(R2, R, atol=1e-14)
    np.testing.assert_allclose(m2, m, atol=1e-14)
    np.testing.assert_allclose(chart.spatial_momentum(y), np.einsum("...ij,...j->...i", R, m), atol=1e-14)
    np.testing.assert_allclose(chart.invariants(y), 0.0, atol=1e-14)
    # (q, pi) and (-q, -pi) are the same state
    R3, m3 = chart.inverse(-y)
    np.testing.assert_allclose(R3, R, atol=1e-14)
    np.testing.assert_allclose(m3, m, atol=1e-14)


def test_spatial_momentum_is_the_momentum_map_of_the_left_action_and_H_is_invariant(rng):
    chart = QuaternionCoordinates(own_system())
    y = np.concatenate([rng.normal(size=4), rng.normal(size=4)])  # off the physical set too
    for _ in range(4):
        xi = rng.normal(size=3)
        # generator of the left action on q: d/de exp(e xi) q = 1/2 (0, xi) q; on pi the same (cotangent lift)
        gen = 0.5 * quat.multiply(np.concatenate([[0.0], xi]), y[:4])
        # Hamilton's equations of J.xi: qdot = d(J.xi)/dpi must be the generator; by the chain rule through m
        # nothing else: check d(J.xi)/dpi by exact differentiation of the bilinear J
        eps = 1e-6
        grad_pi = np.array(
            [
                (chart.spatial_momentum(y + eps * e) - chart.spatial_momentum(y - eps * e)) @ xi / (2 * eps)
                for e in np.eye(8)[4:]
            ]
        )
        np.testing.assert_allclose(grad_pi, gen, atol=1e-9)
        a = quat.exp(xi)
        moved = np.concatenate([quat.multiply(a, y[:4]), quat.multiply(a, y[4:])])
        np.testing.assert_allclose(chart.hamiltonian(moved), chart.hamiltonian(y), rtol=1e-13)
        np.testing.assert_allclose(chart.body_momentum(moved), chart.body_momentum(y), atol=1e-13)
        # the spatial momentum moves by the rotation of a (equivariance)
        np.testing.assert_allclose(
            chart.spatial_momentum(moved), quat.as_matrix(a) @ chart.spatial_momentum(y), atol=1e-13
        )


@pytest.mark.parametrize("make", [free_body, own_system])
def test_symbolic_equations_agree_with_the_chain_rule_and_push_forward_to_euler(make, rng):
    system = make()
    chart = QuaternionCoordinates(system)
    eqs = sp.lambdify(chart.symbols, chart.hamilton_equations(substitute_parameters=True))
    for _ in range(4):
        R, m = so3.exp(rng.normal(size=3)), rng.normal(size=3)
        y = chart.forward(R, m)
        f = chart.vector_field(y)
        np.testing.assert_allclose(np.array(eqs(*y), dtype=float), f, atol=1e-12 * (1 + np.abs(f).max()))
        omega = system.gradient(m)
        # qdot = 1/2 q (0, omega) (R' = R omega^) and m' = m x omega (Euler's equation)
        np.testing.assert_allclose(f[:4], 0.5 * quat.multiply(y[:4], np.concatenate([[0.0], omega])), atol=1e-13)
        np.testing.assert_allclose(chart.momentum_jacobian(y) @ f, np.cross(m, omega), atol=1e-12)
        # the momentum Jacobian is the exact derivative of the bilinear m(y)
        eps = 1e-6
        fd = np.stack(
            [(chart.body_momentum(y + eps * e) - chart.body_momentum(y - eps * e)) / (2 * eps) for e in np.eye(8)], -1
        )
        np.testing.assert_allclose(chart.momentum_jacobian(y), fd, atol=1e-9)


def test_callable_system_numeric_side_works_and_symbolic_side_says_it_needs_a_formula(rng):
    body = RigidBody(np.diag([3.0, 2.0, 1.0]))
    formula = QuaternionCoordinates(free_body())
    inverse_inertia = 1.0 / np.array([3.0, 2.0, 1.0])
    numeric = QuaternionCoordinates(
        LeftInvariantSystem.from_callable(
            lambda m: 0.5 * np.sum(m**2 * inverse_inertia, -1), lambda m: m * inverse_inertia
        )
    )
    y = formula.forward(so3.exp(rng.normal(size=3)), rng.normal(size=3))
    np.testing.assert_allclose(numeric.vector_field(y), formula.vector_field(y), atol=1e-13)
    np.testing.assert_allclose(QuaternionCoordinates(body).vector_field(y), formula.vector_field(y), atol=1e-13)
    with pytest.raises(SymbolicError, match="formula"):
        numeric.canonical_hamiltonian()


def test_midpoint_in_quaternions_conserves_the_momentum_map_through_the_gimbal_lock(rng):
    system = own_system()
    chart = QuaternionCoordinates(system)
    # from the identity (theta = 0 of the 3-1-3 angles: a state Euler angles cannot even represent), spinning
    # nearly about the major axis b1 = s1: b3 turns in the s2-s3 plane and comes back near s3 every period
    R0, m0 = np.eye(3), np.array([1.0, 0.05, 0.02])
    with pytest.raises(SingularityError):
        EulerCoordinates(system).forward(R0, m0)
    y0 = chart.forward(R0, m0)
    sol = gm.solve(chart.canonical_system(), ImplicitMidpoint(), t_final=20.0, h=0.02, y0=y0, backend="python")
    assert sol.success
    R, m = chart.inverse(sol.y)
    theta = np.arccos(np.clip(R[:, 2, 2], -1, 1))
    # b3 goes round: from s3 (theta = 0) near -s3 (theta = pi, the other gimbal lock) and back near s3
    assert theta.max() > 3.1 and theta[len(theta) // 4 :].min() < 0.06
    p = chart.spatial_momentum(sol.y)
    scale = np.linalg.norm(p[0])
    assert np.abs(p - p[0]).max() < 1e-12 * scale
    assert np.abs(chart.invariants(sol.y)).max() < 1e-12
    # the energy is not conserved exactly (a symplectic method), but bounded at O(h^2): and not zero
    dH = np.ptp(chart.hamiltonian(sol.y))
    assert 1e-10 < dH / abs(chart.hamiltonian(y0)) < 1e-2
    # the attitude is a rotation and p = R m along the run
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, m), p, atol=1e-12 * scale)


def test_midpoint_in_euler_angles_conserves_only_the_cyclic_momentum_drifting_at_order_2():
    # Remark 10 of the seed: in Euler coordinates the discrete equations are not invariant under the rotations
    # about the spatial axes 1 and 2; Phi = p3 (phi cyclic, linear) is conserved, p1 and p2 are not
    system = own_system()
    chart = EulerCoordinates(system)
    R0 = so3.exp(np.array([1.0, 0.4, 0.3]))
    y0 = chart.forward(R0, np.array([0.2, 1.0, -0.4]))
    drift = []
    for h in (0.02, 0.01):
        sol = gm.solve(chart.canonical_system(), ImplicitMidpoint(), t_final=10.0, h=h, y0=y0, backend="python")
        assert sol.success
        p = chart.spatial_momentum(sol.y)
        scale = np.linalg.norm(p[0])
        assert np.abs(p[:, 2] - p[0, 2]).max() < 1e-12 * scale
        drift.append(np.abs(p[:, :2] - p[0, :2]).max() / scale)
    assert drift[1] > 1e-7  # far above round-off: not conserved
    assert 3.0 < drift[0] / drift[1] < 5.0  # O(h^2)


def test_midpoint_in_quaternions_converges_at_order_2_to_the_lie_group_solution():
    system = own_system()
    chart = QuaternionCoordinates(system)
    R0, m0 = so3.exp(np.array([0.3, -0.2, 0.5])), np.array([0.2, 1.0, -0.4])
    ref = gm.solve(
        system, DormandPrince(), t_final=5.0, m0=m0, R0=R0, rtol=1e-13, atol=1e-13, saveat=[0.0, 5.0], backend="python"
    )
    y0 = chart.forward(R0, m0)
    errors = []
    for h in (0.05, 0.025, 0.0125):
        sol = gm.solve(
            chart.canonical_system(), ImplicitMidpoint(), t_final=5.0, h=h, y0=y0, saveat=[0.0, 5.0], backend="python"
        )
        R, m = chart.inverse(sol.y[-1])
        errors.append(max(np.abs(R - ref.R[-1]).max(), np.abs(m - ref.m[-1]).max()))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] > 1e-8  # far above the reference's error
    np.testing.assert_allclose(orders, 2.0, atol=0.1)


def test_serret_andoyer_in_quaternion_form_is_canonical_and_agrees_with_the_euler_route(rng):
    sa_map = ClassicalSerretAndoyer()
    chart = QuaternionCoordinates(free_body())
    euler = EulerCoordinates(free_body())
    eps = 1e-6
    for _ in range(5):
        R, m = so3.exp(rng.normal(size=3)), rng.normal(size=3)
        sa = sa_map.from_body(R, m)
        y = sa_map.to_quaternion(sa)
        # the same state as the quaternion chart's (up to the sign of the double cover), and both routes agree
        y_chart = chart.forward(R, m)
        assert min(np.abs(y - y_chart).max(), np.abs(y + y_chart).max()) < 1e-13
        np.testing.assert_allclose(sa_map.from_quaternion(y), sa, atol=1e-13)
        np.testing.assert_allclose(sa_map.forward(euler.forward(R, m)), sa, atol=1e-12)
        # canonical: the Liouville form pi . dq pulls back to L dl + G dg + H dh
        pulled = [
            y[4:] @ (sa_map.to_quaternion(sa + eps * e)[:4] - sa_map.to_quaternion(sa - eps * e)[:4]) / (2 * eps)
            for e in np.eye(6)
        ]
        np.testing.assert_allclose(pulled, [sa[3], sa[4], sa[5], 0.0, 0.0, 0.0], atol=1e-8 * sa[4])
        # a turn of l is a turn of the body: the other sheet of the double cover
        np.testing.assert_allclose(sa_map.to_quaternion(sa + 2 * np.pi * np.eye(6)[0]), -y, atol=1e-13)


def test_serret_andoyer_variables_along_a_motion_through_the_gimbal_lock():
    system = free_body()
    chart = QuaternionCoordinates(system)
    sa_map = ClassicalSerretAndoyer()
    R0, m0 = np.eye(3), np.array([1.0, 0.05, 0.02])  # theta = 0: the Euler route cannot start
    with pytest.raises(SingularityError):
        sa_map.forward(EulerCoordinates(system).forward(R0, m0))
    sol = gm.solve(
        chart.canonical_system(), ImplicitMidpoint(), t_final=30.0, h=0.02, y0=chart.forward(R0, m0), backend="python"
    )
    R, m = chart.inverse(sol.y)
    theta = np.arccos(np.clip(R[:, 2, 2], -1, 1))
    assert theta.max() > 3.0 and theta[len(theta) // 4 :].min() < 0.06
    sa = sa_map.from_quaternion(sol.y)
    G = np.linalg.norm(m0)
    # G, H and the node h are the spatial momentum's: constant to round-off; L is m3; l turns continuously
    np.testing.assert_allclose(sa[:, 4], G, atol=1e-13 * G)
    np.testing.assert_allclose(sa[:, 5], sa[0, 5], atol=1e-13 * G)
    np.testing.assert_allclose(np.unwrap(sa[:, 2]), sa[0, 2], atol=1e-12)
    np.testing.assert_allclose(sa[:, 3], m[:, 2], atol=1e-14)
    assert np.abs(np.diff(np.unwrap(sa[:, 0]))).max() < 0.1
