"""Rigid bodies with rotors: the free Hamiltonians (eqs. 24, 37) derived from the Lagrangians (eqs. 22, 35),
the open-loop equations (26, 38) against the seed's written-out eq. (30), and conservation along direct
simulations (total angular momentum always; energy without torque; energy balance with torque)."""

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import trapezoid

import geomech as gm
from geomech.errors import InputError, NumericalError
from geomech.integrators import IncompatibleMethodError
from geomech.lie import so3
from geomech.systems.rotors import ISOTROPIC_PYRAMID_ELEVATION, RotorBody

m1, m2, m3 = sp.symbols("m1 m2 m3", real=True)


def legendre_hamiltonian(lagrangian, omega, gdot):
    """H = m.omega + Gamma.gdot - L with the velocities solved from the Legendre transform (sympy)."""
    vel = list(omega) + list(gdot)
    mom = [sp.diff(lagrangian, v) for v in vel]
    n = len(gdot)
    msyms = sp.symbols("m1 m2 m3", real=True)
    gsyms = sp.symbols(f"Gamma1:{n + 1}", real=True)
    sol = sp.solve([sp.Eq(a, b) for a, b in zip(mom, list(msyms) + list(gsyms))], vel, dict=True)
    assert len(sol) == 1
    H = sum(p * v for p, v in zip(list(msyms) + list(gsyms), vel)) - lagrangian
    return sp.simplify(H.subs(sol[0])), gsyms


def test_eq24_is_the_legendre_transform_of_eq22():
    w = sp.symbols("w1:4", real=True)
    gd = sp.Symbol("gd", real=True)
    lam1, lam2, I3, J3 = sp.symbols("lambda1 lambda2 I3 J3", positive=True)
    L = (lam1 * w[0] ** 2 + lam2 * w[1] ** 2 + I3 * w[2] ** 2) / 2 + J3 * (w[2] + gd) ** 2 / 2
    H, (G1,) = legendre_hamiltonian(L, w, [gd])
    body = RotorBody.one_rotor(3.0, 2.0, 1.0, 0.5)
    expr, (Gam,) = body.H_f, body.Gamma_symbols
    expr = expr.xreplace(
        {s: sp.Symbol(str(s), positive=True) for s in expr.free_symbols if str(s) in ("lambda1", "lambda2", "I3", "J3")}
    )
    assert sp.simplify(H - expr.xreplace({Gam: G1})) == 0


def test_eq37_is_the_legendre_transform_of_eq35_with_the_rotor_term_squared():
    w = sp.symbols("w1:4", real=True)
    gd = sp.symbols("gd1:4", real=True)
    lam = sp.symbols("lambda1:4", positive=True)
    J = sp.symbols("J1:4", positive=True)
    L = sum(l_ * wi**2 for l_, wi in zip(lam, w)) / 2 + sum(j * (wi + g) ** 2 / 2 for j, wi, g in zip(J, w, gd))
    H, Gs = legendre_hamiltonian(L, w, gd)
    body = RotorBody.three_rotors([3.0, 2.0, 1.0], [0.1, 0.2, 0.3])
    expr, Gam = body.H_f, body.Gamma_symbols
    expr = expr.xreplace({s: sp.Symbol(str(s), positive=True) for s in expr.free_symbols if str(s)[0] in "lJ"})
    assert sp.simplify(H - expr.xreplace(dict(zip(Gam, Gs)))) == 0
    # eq. (35) as printed, J_i/2 (w_i + gd_i) without the square, is linear in the rotor rates: its Legendre
    # transform is singular, which is why the rotor term must be squared.
    printed = sum(l_ * wi**2 for l_, wi in zip(lam, w)) / 2 + sum(j * (wi + g) / 2 for j, wi, g in zip(J, w, gd))
    hess = sp.hessian(printed, list(w) + list(gd))
    assert sp.simplify(hess.det()) == 0


def test_numeric_hamiltonian_legendre_and_lagrangian_agree(rng):
    body = RotorBody.pyramid(np.diag([3.0, 2.5, 2.0]), 0.1)
    omega, gdot = rng.normal(size=(5, 3)), rng.normal(size=(5, 4))
    m, Gamma = body.legendre(omega, gdot)
    np.testing.assert_allclose(body.angular_velocity(m, Gamma), omega, atol=1e-13)
    np.testing.assert_allclose(body.rotor_rates(m, Gamma), gdot, atol=1e-12)
    # For a quadratic Lagrangian, H = L at corresponding points.
    np.testing.assert_allclose(body.hamiltonian(m, Gamma), body.lagrangian(omega, gdot), rtol=1e-13)
    # and the symbolic Hamiltonian agrees with the numeric one
    expr, Gam = body.H_f, body.Gamma_symbols
    f = sp.lambdify([m1, m2, m3, *Gam], expr)
    np.testing.assert_allclose(f(*m[0], *Gamma[0]), body.hamiltonian(m[0], Gamma[0]), rtol=1e-12)


def test_open_loop_equations_are_the_seeds_written_out_eq30(rng):
    lam1, lam2, I3, J3 = 3.0, 2.0, 1.0, 0.4
    body = RotorBody.one_rotor(lam1, lam2, I3, J3)
    for _ in range(5):
        m, G = rng.normal(size=3), rng.normal()
        _, dm, dgam, dG = body.vector_field(np.eye(3), m, np.array([G]), np.array([0.7]))
        expected = [
            (1 / I3 - 1 / lam2) * m[1] * m[2] - G * m[1] / I3,  # eq. (30a)
            (1 / lam1 - 1 / I3) * m[0] * m[2] + G * m[0] / I3,  # eq. (30b)
            (1 / lam2 - 1 / lam1) * m[0] * m[1],
        ]  # eq. (30c)
        np.testing.assert_allclose(dm, expected, atol=1e-14)
        # eq. (26c): gamma' = dH_f/dGamma = -(m3 - Gamma)/I3 + Gamma/J3
        np.testing.assert_allclose(dgam, [-(m[2] - G) / I3 + G / J3], atol=1e-14)
        assert dG[0] == 0.7


def test_locked_inertia_of_the_seeds_layouts():
    np.testing.assert_allclose(RotorBody.one_rotor(3.0, 2.0, 1.0, 0.5).locked_inertia, np.diag([3.0, 2.0, 1.5]))
    np.testing.assert_allclose(
        RotorBody.three_rotors([3.0, 2.0, 1.0], [0.1, 0.2, 0.3]).locked_inertia, np.diag([3.1, 2.2, 1.3])
    )


def test_isotropic_pyramid():
    body = RotorBody.pyramid(np.eye(3), 0.05)
    np.testing.assert_allclose(body.A @ body.A.T, 4 / 3 * np.eye(3), atol=1e-14)
    assert abs(np.degrees(ISOTROPIC_PYRAMID_ELEVATION) - 35.26438968) < 1e-6
    for drop in range(4):  # any three wheels span the body frame: one can fail
        assert np.linalg.matrix_rank(np.delete(body.A, drop, axis=1)) == 3


def simulate(body, t, **kw):
    """The open-loop equations by DOP853 at the tolerances of a reference solution."""
    t = np.asarray(t, dtype=float)
    return gm.solve(body, "solve_ivp", t_final=t[-1], saveat=t, rtol=1e-12, atol=1e-12, **kw)


def test_free_simulation_conserves_energy_momentum_and_rotor_momenta():
    body = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    t = np.linspace(0.0, 40.0, 401)
    R0 = so3.exp([0.2, -0.4, 1.0])
    traj = simulate(body, t, m0=[0.4, 1.0, -0.3], Gamma0=[0.05, -0.1, 0.2], R0=R0)
    E = traj.energy
    pi = traj.spatial_momentum
    assert np.abs(E - E[0]).max() < 1e-11 * abs(E[0])
    assert np.abs(pi - pi[0]).max() < 1e-10
    np.testing.assert_allclose(traj.Gamma, np.broadcast_to(traj.Gamma[0], traj.Gamma.shape), atol=1e-14)
    # the attitude stays a rotation
    assert np.abs(np.einsum("nji,njk->nik", traj.R, traj.R) - np.eye(3)).max() < 1e-9
    # and m really moves (a test that could fail if the dynamics were frozen)
    assert np.abs(traj.m - traj.m[0]).max() > 0.1


def test_pyramid_with_torques_momentum_bookkeeping():
    """Internal torques keep the total spatial momentum R m; the energy changes by the motors' work."""
    body = RotorBody.pyramid(np.diag([3.0, 2.5, 2.0]), 0.08)
    t = np.linspace(0.0, 20.0, 4001)

    def torque(t, R, m, gamma, Gamma):
        return 0.05 * np.array([np.sin(t), np.cos(0.7 * t), -0.5, np.sin(2 * t) * m[0]])

    traj = simulate(body, t, m0=[0.3, 0.8, -0.2], Gamma0=np.zeros(4), tau=torque)
    pi = traj.spatial_momentum
    assert np.abs(pi - pi[0]).max() < 1e-10
    E = traj.energy
    power = np.sum(traj.tau * body.rotor_rates(traj.m, traj.Gamma), axis=-1)  # u . gamma_dot
    work = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (power[1:] + power[:-1]))])
    assert abs(E[-1] - E[0]) > 1e-2  # the motors do work
    np.testing.assert_allclose(E - E[0], work, atol=5e-6)
    np.testing.assert_allclose(trapezoid(traj.tau[:, 2], t), -0.5 * 0.05 * 20.0, rtol=1e-12)
    # the wheels' share of the body momentum is A Gamma
    np.testing.assert_allclose(body.wheel_momentum(traj.Gamma), traj.Gamma @ body.axes)


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"inertia": np.diag([1.0, -1.0, 1.0]), "axes": [[0, 0, 1]]}, "positive definite"),
        ({"inertia": [[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]], "axes": [[0, 0, 1]]}, "symmetric"),
        ({"inertia": np.eye(3), "axes": [[0, 0, 0]]}, "nonzero"),
        ({"inertia": np.eye(3), "axes": [[0, 0, 1]], "rotor_inertia": [0.1, 0.2]}, "one entry per rotor"),
        ({"inertia": np.eye(3), "axes": [[0, 0, 1]], "rotor_inertia": [-0.1]}, "positive"),
        ({"inertia": np.eye(2), "axes": [[0, 0, 1]]}, "shape"),
    ],
)
def test_bad_bodies(kwargs, needle):
    with pytest.raises(InputError, match=needle):
        RotorBody(**kwargs)


def test_what_needs_the_rotor_inertia_says_so():
    body = RotorBody.one_rotor(3.0, 2.0, 1.0)
    assert body.angular_velocity([1.0, 0.0, 0.0], [0.0]).shape == (3,)
    with pytest.raises(InputError, match="J3"):
        body.hamiltonian([1.0, 0.0, 0.0], [0.0])
    with pytest.raises(InputError, match="axial moments"):
        simulate(body, [0.0, 1.0], m0=[1.0, 0.0, 0.0], Gamma0=[0.0])


def test_bad_simulation_input():
    body = RotorBody.one_rotor(3.0, 2.0, 1.0, 0.5)
    with pytest.raises(InputError, match="increasing"):
        gm.solve(body, "solve_ivp", t_final=1.0, saveat=[1.0, 0.0], m0=[1.0, 0.0, 0.0], Gamma0=[0.0])
    with pytest.raises(InputError, match="one per rotor"):
        simulate(body, [0.0, 1.0], m0=[1.0, 0.0, 0.0], Gamma0=[0.0], tau=lambda *a: [1.0, 2.0])
    with pytest.raises(InputError, match="`tau`, the rotor torques"):
        simulate(body, [0.0, 1.0], m0=[1.0, 0.0, 0.0], Gamma0=[0.0], tau="lots")
    with pytest.raises(NumericalError, match="not finite .* is the torque defined"):
        simulate(body, [0.0, 1.0], m0=[1.0, 0.0, 0.0], Gamma0=[0.0], tau=lambda *a: [np.nan])
    with pytest.raises(InputError, match="`Gamma0`"):
        gm.solve(body, "solve_ivp", t_final=1.0, m0=[1.0, 0.0, 0.0])
    # an implicit method needs the Jacobian, which a torque law of Python code does not have
    with pytest.raises(IncompatibleMethodError, match="Jacobian.*explicit method"):
        gm.solve(body, "implicit_midpoint", t_final=1.0, h=0.1, m0=[1.0, 0.0, 0.0], Gamma0=[0.0], tau=lambda *a: [0.1])


def test_a_failure_is_data_with_the_states_reached():
    body = RotorBody.one_rotor(3.0, 2.0, 1.0, 0.5)

    def torque(t, R, m, gamma, Gamma):
        return [np.nan if t > 0.5 else 0.1]

    sol = simulate(
        body, np.linspace(0.0, 1.0, 11), m0=[1.0, 0.2, 0.0], Gamma0=[0.0], tau=torque, raise_on_failure=False
    )
    when = sol.failures[0].time  # the last time the solver reached: its next step met the NaN torque
    assert sol.status == "nonfinite" and 0.0 < when <= 0.5 and "torque" in sol.message
    assert np.all(np.isfinite(sol.m[sol.t <= when])) and np.all(np.isnan(sol.m[sol.t > when]))
    assert np.isnan(sol.m[-1]).all() and np.isfinite(sol.m[0]).all()
