"""A nonholonomic system on SO(3) (non-abelian, Euler-angle chart): Suslov's body (angular velocity about a
body axis forbidden) carrying a driven rotor. The full and reduced simulators are checked against the
Euler-Poincare-Suslov equations written by hand in the body frame, which use neither the chart nor the
reduction."""

import numpy as np
import sympy as sp
from own_systems import SUSLOV_INERTIA, SUSLOV_ROTOR, suslov_with_rotor
from scipy.integrate import solve_ivp

from geomech import solve
from geomech.integrators import BKMM, LagrangeDAlembert
from geomech.reduction.nonholonomic import bkmm_reduction
from geomech.symbolic import group_chart
from geomech.systems.nonholonomic import NonholonomicSystem

GAIT = {"psi": "0.8*sin(2*pi*t)"}
Q0 = {"a": 0.2, "b": 1.0, "c": -0.4}  # away from the chart's gimbal lock at b = 0
INERTIA, J_ROTOR = SUSLOV_INERTIA, SUSLOV_ROTOR


def _system() -> tuple[NonholonomicSystem, sp.Matrix]:
    system = suslov_with_rotor()
    return system, system.group.body_velocity_matrix


def _body_rates(system, Lam, traj) -> np.ndarray:
    f = sp.lambdify(system.group.coordinates, Lam, "numpy")
    return np.array([np.asarray(f(*q[:3]), float) @ qd[:3] for q, qd in zip(traj.q, traj.qdot)])


def _suslov_by_hand(omega0, t_eval):
    """mu' = mu x omega + lambda e3, mu = I omega + J (psi' + omega_1) e1, omega_3 = 0 (left-invariant)."""
    w = 2 * np.pi

    def rhs(t, y):
        om = np.array([y[0], y[1], 0.0])
        psid, psidd = 0.8 * w * np.cos(w * t), -0.8 * w * w * np.sin(w * t)
        mu = INERTIA @ om + J_ROTOR * (psid + om[0]) * np.array([1.0, 0, 0])
        A = np.column_stack([INERTIA[:, 0] + J_ROTOR * np.array([1.0, 0, 0]), INERTIA[:, 1], [0, 0, -1.0]])
        b = np.cross(mu, om) - J_ROTOR * psidd * np.array([1.0, 0, 0])
        return np.linalg.solve(A, b)[:2]

    return solve_ivp(rhs, (t_eval[0], t_eval[-1]), omega0, t_eval=t_eval, rtol=1e-12, atol=1e-13).y.T


def test_suslov_body_with_rotor_on_so3():
    system, Lam = _system()
    assert system.check_invariance().ok
    red = bkmm_reduction(system)
    assert red.basis.shape == (3, 2)  # S_q = {omega_3 = 0}: a two-dimensional nonholonomic momentum
    p0 = [0.4, -0.3]
    full = solve(system, LagrangeDAlembert(), t_final=1.5, shapes=GAIT, q0=Q0, p0=p0, saveat=31)
    reduced = solve(system, BKMM(), t_final=1.5, shapes=GAIT, q0=Q0, p0=p0, saveat=31)
    np.testing.assert_allclose(full.q, reduced.q, atol=1e-8)
    np.testing.assert_allclose(full.p, reduced.p, atol=1e-8)
    assert np.abs(full.constraint_residual).max() < 1e-8
    omega = _body_rates(system, Lam, full)
    assert np.abs(omega[:, 2]).max() < 1e-8
    by_hand = _suslov_by_hand(omega[0, :2], full.t)
    np.testing.assert_allclose(omega[:, :2], by_hand, atol=1e-7)
    assert np.ptp(omega[:, 0]) > 0.05  # the rotor and the tilted inertia make the body rates move
    # the rotor drives the body; its work balances the energy
    assert np.abs(full.energy - full.energy[0] - full.work).max() < 1e-8


def test_three_dimensional_sleigh_on_se3():
    """A body in space that may only move along its body x axis (no sideslip, no heave), centre of mass a
    distance a ahead of the constrained point: the SE(3) analogue of the Chaplygin sleigh. No shape: the
    momentum equation is all the dynamics. Energy is conserved, the full and reduced simulators agree, and
    the centre of mass obeys Newton's law with the constraint forces as the only forces."""
    from geomech.lie import SE3
    from geomech.reduction import lagrange_dalembert

    G = SE3("x", "y", "z", "a1", "a2", "a3")
    xi = group_chart(G).body_velocity_matrix * sp.Matrix(sp.symbols("x_dot y_dot z_dot a1_dot a2_dot a3_dot"))
    v, w = xi[:3, 0], xi[3:, 0]
    m, a = 2.0, 0.4
    Ic = sp.diag(sp.Rational(1, 2), sp.Rational(4, 5), 1)
    vc = v + w.cross(sp.Matrix([sp.Rational(2, 5), 0, 0]))  # velocity of the centre of mass, body frame
    L = m / 2 * vc.dot(vc) + (w.T * Ic * w)[0] / 2
    system = NonholonomicSystem.from_lagrangian(sp.nsimplify(L), G, (), [v[1], v[2]], name="sleigh3d")
    assert system.check_invariance().ok
    red = bkmm_reduction(system)
    assert red.m == 4  # S_q = D: forward speed and the three angular velocities
    p0 = [0.8, 0.3, -0.2, 0.5]
    full = solve(system, LagrangeDAlembert(), t_final=3.0, p0=p0, saveat=61)
    reduced = solve(system, BKMM(), t_final=3.0, p0=p0, saveat=61)
    np.testing.assert_allclose(full.q, reduced.q, atol=1e-8)
    assert np.ptp(full.energy) < 1e-9 and np.abs(full.constraint_residual).max() < 1e-8
    assert np.ptp(full.q[:, 0]) > 0.1 and np.ptp(full.p[:, 0]) > 1e-3  # it moves, and p is not conserved
    # Newton: m * (centre of mass acceleration) = sum of the constraint forces A^T lambda (spatial frame)
    lda = lagrange_dalembert(system).numeric()
    com = G.from_coordinates(full.q[:, :6])[:, :3, :3] @ [a, 0, 0] + full.q[:, :3]
    t = full.t
    acc = np.gradient(np.gradient(com, t, axis=0, edge_order=2), t, axis=0, edge_order=2)
    _, lam = lda.solve(full.q, full.qdot)
    A = np.array([np.asarray(sp.lambdify(system.q, system.constraint_matrix, "numpy")(*q), float) for q in full.q])
    force = np.einsum("kci,kc->ki", A, lam)[:, :3]
    assert np.abs(force).max() > 0.05  # the constraints do push
    inner = slice(5, -5)
    np.testing.assert_allclose(m * acc[inner], force[inner], atol=2e-3 * np.abs(force).max() + 1e-6)


def test_chaplygin_ball_keeps_its_angular_momentum_about_the_contact_point():
    """Chaplygin's integral K = R I omega + m r^2 (Omega - Omega_z e3), constant in space: Newton-Euler about
    the contact point, independent of the reduction; the full and reduced simulators both keep it."""
    from geomech.lie import euler
    from geomech.systems.nonholonomic_examples import chaplygin_ball

    m, r, inertia = 1.3, 0.8, np.array([0.4, 0.5, 0.7])
    s = chaplygin_ball(m=m, r=r, I1=inertia[0], I2=inertia[1], I3=inertia[2])
    kw = dict(q0={"theta": 1.0, "psi": 0.3}, rdot0={"theta": 0.5, "psi": 1.0}, p0=[0.3], saveat=51)
    full = solve(s, LagrangeDAlembert(), t_final=8.0, **kw)
    reduced = solve(s, BKMM(), t_final=8.0, **kw)
    np.testing.assert_allclose(full.q, reduced.q, atol=1e-8)
    for tr in (full, reduced):
        R = euler.as_matrix(tr.q[:, 2:5], seq="ZXZ")
        # angular velocities from the attitude's time derivative (chain rule on the 3-1-3 angles), not from L
        dR = np.zeros_like(R)
        eps = 1e-6
        for j in range(3):
            dq = np.zeros(3)
            dq[j] = eps
            dR += (
                (euler.as_matrix(tr.q[:, 2:5] + dq, seq="ZXZ") - euler.as_matrix(tr.q[:, 2:5] - dq, seq="ZXZ"))
                / (2 * eps)
                * tr.qdot[:, 2 + j, None, None]
            )
        omega_hat = np.swapaxes(R, 1, 2) @ dR
        omega = np.stack([omega_hat[:, 2, 1], omega_hat[:, 0, 2], omega_hat[:, 1, 0]], -1)
        Omega = np.einsum("nij,nj->ni", R, omega)
        K = np.einsum("nij,nj->ni", R, inertia * omega) + m * r**2 * (Omega - Omega[:, 2:3] * [0, 0, 1])
        assert np.ptp(K, axis=0).max() < 1e-7 and np.abs(K[0]).max() > 0.1
        assert np.ptp(tr.energy) < 1e-9
        # the contact point does not slip: the centre moves as r e3 x Omega... i.e. x' = r Omega_y, y' = -r Omega_x
        np.testing.assert_allclose(tr.qdot[:, :2], r * np.stack([Omega[:, 1], -Omega[:, 0]], -1), atol=1e-7)
    assert np.ptp(full.q[:, 3]) > 0.3  # the ball really tumbles (theta moves)
