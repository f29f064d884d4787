"""The discrete Lagrange-d'Alembert integrator with the group's discrete Lagrangian
(``DiscreteLagrangeDAlembert("group")``): in the Euler angles of SO(3), where the midpoint discrete Lagrangian is
not invariant (Remark 10 of the Serret-Andoyer seed), it keeps the whole discrete momentum map to round-off and
commutes with the group's action; it converges at order 2, without constraints (the free body) and with them
(Suslov's body on SO(3), the snakeboard on SE(2)). References: a free-body trajectory from the Euler equations and
the attitude equation integrated by scipy in matrices (no chart), and the Lagrange-d'Alembert equations with
multipliers."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from own_systems import free_body_in_euler_angles, suslov_with_rotor
from scipy.integrate import solve_ivp

from geomech import solve
from geomech.errors import InputError
from geomech.integrators import DiscreteLagrangeDAlembert, LagrangeDAlembert
from geomech.lie import SO3
from geomech.systems.nonholonomic_examples import snakeboard_bkmm

INERTIA = np.array([3.0, 2.0, 1.0])
Q0 = np.array([0.3, 1.1, -0.5])  # 3-1-3 angles, away from the gimbal lock theta = 0
QDOT0 = np.array([0.4, -0.7, 0.9])
T_FINAL = 2.0


@pytest.fixture(scope="module")
def body():
    return free_body_in_euler_angles(tuple(INERTIA))


def _euler_rates_to_body(system, q, qd):
    """The body angular velocity Lambda(q) qdot, from the chart's matrix."""
    f = sp.lambdify(system.group.coordinates, system.group.body_velocity_matrix, "numpy")
    return np.asarray(f(*q), dtype=float) @ qd


def _free_body_attitude(R0, omega0, t):
    """R(t) of the free body from Euler's equations and R' = R hat(omega), in matrices (no chart)."""

    def rhs(_, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        return np.r_[(R @ SO3().hat(w)).ravel(), np.cross(INERTIA * w, w) / INERTIA]

    y = solve_ivp(rhs, (0, t), np.r_[R0.ravel(), omega0], rtol=1e-13, atol=1e-14, method="DOP853").y[:, -1]
    return y[:9].reshape(3, 3)


def _run(system, discretization, h, **kw):
    return solve(system, DiscreteLagrangeDAlembert(discretization), t_final=T_FINAL, h=h, saveat=3, **kw)


def test_the_group_discretisation_keeps_the_whole_momentum_map_in_euler_angles(body):
    group = _run(body, "group", 0.02, q0=Q0, qdot0=QDOT0)
    midpoint = _run(body, "midpoint", 0.02, q0=Q0, qdot0=QDOT0)
    J = group.quantities["spatial_momentum"]
    scale = np.linalg.norm(J[0])
    assert np.abs(J - J[0]).max() < 1e-12 * scale * T_FINAL / 0.02  # round-off, accumulated over the steps
    # the midpoint discrete Lagrangian in Euler angles is invariant only under the rotations about the spatial
    # axis 3 (phi is cyclic): that component is kept, the others drift at O(h^2)
    Jm = midpoint.quantities["spatial_momentum"]
    drift = np.abs(Jm - Jm[0]).max(axis=0)
    assert drift[2] < 1e-12 * scale * T_FINAL / 0.02 and drift[:2].min() > 1e-6 * scale
    # the energy of both stays near its value (variational, symplectic without constraints)
    for sol in (group, midpoint):
        assert np.ptp(sol.energy) < 1e-3 * sol.energy[0]


def test_the_group_discretisation_commutes_with_the_action(body):
    """The run from eta g0 (same body velocity) is eta times the run from g0, whatever the chart does."""
    G = body.group
    eta = SO3().exp([0.4, -0.9, 0.3])
    omega0 = _euler_rates_to_body(body, Q0, QDOT0)
    q0b = G.to_coordinates(eta @ G.from_coordinates(Q0), start=Q0)
    qd0b = np.linalg.solve(
        np.asarray(_euler_rates_to_body(body, q0b, np.eye(3)), dtype=float), omega0
    )  # the same body velocity in the new chart point
    for disc, at_least, at_most in (("group", 0.0, 1e-11), ("midpoint", 1e-6, np.inf)):
        a = _run(body, disc, 0.05, q0=Q0, qdot0=QDOT0)
        b = _run(body, disc, 0.05, q0=q0b, qdot0=qd0b)
        gap = max(np.abs(eta @ G.from_coordinates(x) - G.from_coordinates(y)).max() for x, y in zip(a.q, b.q))
        assert at_least <= gap < at_most, (disc, gap)


def test_both_discretisations_converge_at_order_2_to_the_free_body(body):
    R0 = body.group.from_coordinates(Q0)
    exact = _free_body_attitude(R0, _euler_rates_to_body(body, Q0, QDOT0), T_FINAL)
    for disc in ("group", "midpoint"):
        errors = [
            np.abs(body.group.from_coordinates(_run(body, disc, h, q0=Q0, qdot0=QDOT0).q[-1]) - exact).max()
            for h in (0.04, 0.02)
        ]
        assert abs(np.log2(errors[0] / errors[1]) - 2) < 0.2, (disc, errors)


@pytest.mark.parametrize(
    "make, kw",
    [
        (
            suslov_with_rotor,
            dict(shapes={"psi": "0.8*sin(2*pi*t)"}, q0={"a": 0.2, "b": 1.0, "c": -0.4}, p0=[0.4, -0.3]),
        ),
        (
            lambda: snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1),
            dict(shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, q0={"theta": 0.3}, qdot0="rest"),
        ),
    ],
    ids=["suslov_on_SO3", "snakeboard_on_SE2"],
)
def test_with_constraints_both_converge_at_order_2(make, kw):
    system = make()
    ref = solve(system, LagrangeDAlembert(), t_final=1.0, saveat=3, rtol=1e-12, atol=1e-13, **kw)
    for disc in ("group", "midpoint"):
        errors, balance = [], []
        for h in (0.02, 0.01):
            sol = solve(system, DiscreteLagrangeDAlembert(disc), t_final=1.0, h=h, saveat=3, **kw)
            errors.append(np.abs(sol.q[-1] - ref.q[-1]).max())
            balance.append(np.abs(sol.energy - sol.energy[0] - sol.work).max())
        assert abs(np.log2(errors[0] / errors[1]) - 2) < 0.2, (disc, errors)
        # the gait's work and the energy at the nodes agree as the step shrinks, at the scheme's order too
        assert abs(np.log2(balance[0] / balance[1]) - 2) < 0.3, (disc, balance)


def test_an_unknown_discretisation_is_named():
    with pytest.raises(InputError, match="`discretization`"):
        DiscreteLagrangeDAlembert("cayley")
