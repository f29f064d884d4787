"""The example systems against independent routes: sympy's LagrangesMethod (multipliers) for every example, and
KanesMethod on rigid-body models assembled from frames and points for the snakeboard and the Chaplygin sleigh."""

import numpy as np
import pytest
import sympy as sp
import sympy.physics.mechanics as me

from geomech.reduction import lagrange_dalembert
from geomech.systems.nonholonomic_examples import (
    EXAMPLES,
    chaplygin_sleigh,
    geared_body,
    snakeboard,
    snakeboard_bkmm,
)

ALL = [(name, {}) for name in EXAMPLES] + [("geared_body", {"scaled": True})]


def _with_random_parameters(system, rng):
    return system.with_parameters(**{p.name: float(rng.uniform(0.5, 1.5)) for p in system.parameter_symbols})


def _random_state(system, num, rng):
    """A random configuration and a random velocity in D (numeric null space of A(q))."""
    q = rng.uniform(-1.0, 1.0, system.n)
    A = num.constraint_matrix(q).reshape(system.c, system.n)
    _, _, vt = np.linalg.svd(A) if system.c else (None, None, np.eye(system.n))
    qd = vt[system.c :].T @ rng.uniform(-1.0, 1.0, system.n - system.c)
    return q, qd


@pytest.mark.parametrize("name, kw", ALL, ids=[n + ("_scaled" if kw else "") for n, kw in ALL])
def test_lagrange_dalembert_against_sympy_lagranges_method(name, kw, rng):
    s = _with_random_parameters(EXAMPLES[name](**kw), rng)
    num = lagrange_dalembert(s).numeric()
    t = me.dynamicsymbols._t
    qs = me.dynamicsymbols(f"q0:{s.n}")
    sub = {a: b for a, b in zip(s.q, qs)}
    sub.update({a: b.diff(t) for a, b in zip(s.qdot, qs)})
    L = s.lagrangian.xreplace(sub)
    taus = sp.symbols(f"f0:{s.sigma}")
    coneqs = list((s.constraint_matrix * sp.Matrix(s.qdot)).xreplace(sub))
    lm = me.LagrangesMethod(L, qs, nonhol_coneqs=coneqs if coneqs else None)
    lm.form_lagranges_equations()
    # Shape forces enter the right-hand side of the shape rows of sympy's equations.
    k = s.k
    forcing = lm.forcing_full.copy()
    for a in range(s.sigma):
        forcing[s.n + k + a] += taus[a]
    pv = s.parameter_values()
    for _ in range(2):
        q, qd = _random_state(s, num, rng)
        tau = rng.uniform(-1.0, 1.0, s.sigma)
        rep = dict(pv)
        rep.update({b.diff(t): v for b, v in zip(qs, qd)})
        rep.update({b: v for b, v in zip(qs, q)})
        rep.update(dict(zip(taus, tau)))
        MM = np.array(lm.mass_matrix_full.subs(rep).evalf(), dtype=float)
        FF = np.array(forcing.subs(rep).evalf(), dtype=float).ravel()
        x = np.linalg.solve(MM, FF)
        qdd, lam = num.solve(q, qd, tau)
        np.testing.assert_allclose(x[s.n : 2 * s.n], qdd, atol=1e-10)
        np.testing.assert_allclose(x[2 * s.n :], lam, atol=1e-10)


def _kanes_method(N, q_syms, u_syms, u_dep, constraints):
    t = me.dynamicsymbols._t
    kd = [qi.diff(t) - ui for qi, ui in zip(q_syms, u_syms)]
    u_ind = [u for u in u_syms if u not in u_dep]
    return me.KanesMethod(N, q_ind=q_syms, u_ind=u_ind, kd_eqs=kd, u_dependent=u_dep, velocity_constraints=constraints)


def _solve_dependent(constraints, u_dep, rep):
    eqs = [c.subs(rep) for c in constraints]
    sol = sp.solve(eqs, u_dep, dict=True)[0]
    return {k: float(v) for k, v in sol.items()}


def _compare_kane(system, kane, bodies, q_syms, u_syms, u_dep, constraints, values, rng):
    """Kane's accelerations of the independent speeds against ours, at random states satisfying the constraints."""
    kane.kanes_equations(bodies, [])
    num = lagrange_dalembert(system).numeric()
    for _ in range(2):
        q = rng.uniform(-1.0, 1.0, system.n)
        u_ind = {u: float(rng.uniform(-1, 1)) for u in u_syms if u not in u_dep}
        rep = dict(values)
        rep.update(dict(zip(q_syms, q)))
        rep.update(u_ind)
        rep.update(_solve_dependent(constraints, u_dep, rep))
        qd = np.array([rep[u] for u in u_syms])
        MM = np.array(kane.mass_matrix_full.subs(rep).evalf(), dtype=float)
        FF = np.array(kane.forcing_full.subs(rep).evalf(), dtype=float).ravel()
        x = np.linalg.solve(MM, FF)
        # x = (qdot, udot of the independent speeds); dependent accelerations from the acceleration constraints.
        ud_ind = dict(zip([u for u in kane.u if u not in u_dep], x[system.n :]))
        qdd_ours, _ = num.solve(q, qd)
        checked = [j for j, u in enumerate(u_syms) if u in ud_ind]
        assert len(checked) == system.n - system.c
        np.testing.assert_allclose([ud_ind[u_syms[j]] for j in checked], qdd_ours[checked], atol=1e-10)


def test_snakeboard_against_kanes_method_on_a_rigid_body_model(rng):
    """Board (mass m at the centre, inertia J), rotor (J0) at the centre, two wheel pairs (J1) at +-r, steered
    opposite; no lateral slip at either axle. Built from frames and points, not from our Lagrangian."""
    x, y, th, psi, phi = q = me.dynamicsymbols("x y theta psi phi")
    u = me.dynamicsymbols("u0:5")
    m, r, J, J0, J1 = sp.symbols("m r J J0 J1", positive=True)
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    R = B.orientnew("R", "Axis", [psi, B.z])
    Wb = B.orientnew("Wb", "Axis", [phi, B.z])  # back wheels: heading theta + phi
    Wf = B.orientnew("Wf", "Axis", [-phi, B.z])  # front wheels: heading theta - phi
    t = me.dynamicsymbols._t
    rep_qd = dict(zip([qi.diff(t) for qi in q], u))
    for F in (B, R, Wb, Wf):
        F.set_ang_vel(N, F.ang_vel_in(N).subs(rep_qd))
    O = me.Point("O")
    O.set_vel(N, u[0] * N.x + u[1] * N.y)
    Pb, Pf = O.locatenew("Pb", -r * B.x), O.locatenew("Pf", r * B.x)
    for P in (Pb, Pf):
        P.v2pt_theory(O, N, B)
    zero = 0
    bodies = [
        me.RigidBody("board", O, B, m, (me.inertia(B, 0, 0, J), O)),
        me.RigidBody("rotor", O, R, zero, (me.inertia(R, 0, 0, J0), O)),
        me.RigidBody("wb", Pb, Wb, zero, (me.inertia(Wb, 0, 0, J1), Pb)),
        me.RigidBody("wf", Pf, Wf, zero, (me.inertia(Wf, 0, 0, J1), Pf)),
    ]
    constraints = [Pb.vel(N).dot(Wb.y), Pf.vel(N).dot(Wf.y)]
    kane = _kanes_method(N, q, u, [u[0], u[1]], constraints)
    s = _with_random_parameters(snakeboard(), rng)
    values = {sym: s.parameters[sym.name] for sym in (m, r, J, J0, J1)}
    _compare_kane(s, kane, bodies, q, u, [u[0], u[1]], constraints, values, rng)


def test_chaplygin_sleigh_against_kanes_method(rng):
    x, y, th = q = me.dynamicsymbols("x y theta")
    u = me.dynamicsymbols("u0:3")
    m, I_c, a = sp.symbols("m I_c a", positive=True)
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    B.set_ang_vel(N, u[2] * N.z)
    P = me.Point("P")
    P.set_vel(N, u[0] * N.x + u[1] * N.y)
    G = P.locatenew("G", a * B.x)
    G.v2pt_theory(P, N, B)
    bodies = [me.RigidBody("sleigh", G, B, m, (me.inertia(B, 0, 0, I_c), G))]
    constraints = [P.vel(N).dot(B.y)]
    kane = _kanes_method(N, q, u, [u[1]], constraints)
    s = _with_random_parameters(chaplygin_sleigh(), rng)
    values = {sym: s.parameters[sym.name] for sym in (m, I_c, a)}
    _compare_kane(s, kane, bodies, q, u, [u[1]], constraints, values, rng)


def test_bkmm_snakeboard_is_the_general_one_with_normalised_inertia():
    g, b = snakeboard(), snakeboard_bkmm()
    m, r, J, J0, J1 = (next(p for p in g.parameter_symbols if p.name == n) for n in ("m", "r", "J", "J0", "J1"))
    assert sp.expand(g.lagrangian.subs(J, m * r**2 - J0 - 2 * J1) - b.lagrangian) == 0
    assert g.constraint_matrix == b.constraint_matrix


def test_snakeboard_constraints_are_no_slip_across_each_axle():
    """The written-out constraints against the geometry: each wheel pair's axle centre, at distance r behind and
    ahead of the board's centre, moves along its wheels (headings theta + phi and theta - phi)."""
    s = snakeboard()
    x, y, th, _, phi = s.q
    xd, yd, thd, _, _ = s.qdot
    r = next(p for p in s.parameter_symbols if p.name == "r")
    rows = list(s.constraint_matrix * sp.Matrix(s.qdot))
    for sign, heading, row in ((-1, th + phi, rows[0]), (1, th - phi, rows[1])):
        X, Y = x + sign * r * sp.cos(th), y + sign * r * sp.sin(th)
        Xd, Yd = (sum(sp.diff(P, c) * v for c, v in ((x, xd), (y, yd), (th, thd))) for P in (X, Y))
        across = -sp.sin(heading) * Xd + sp.cos(heading) * Yd
        assert sp.simplify(sp.expand_trig(row - across)) == 0


def test_plus_phi_turns_the_board_clockwise_when_rolling_forward():
    """Documented convention: moving towards the front wheels with phi > 0, theta decreases."""
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    A = np.array(
        s.constraint_matrix.subs({**dict(zip(s.q, [0, 0, 0, 0, 0.3]))}).subs(s.parameter_values()).evalf(), dtype=float
    )
    # unknowns (y_dot, theta_dot) for x_dot = 1 (forward along the board at theta = 0), psi_dot = phi_dot = 0
    sol = np.linalg.solve(A[:, 1:3], -A[:, 0])
    assert abs(sol[0]) < 1e-14 and sol[1] == pytest.approx(-np.tan(0.3) / 0.5)


def test_examples_are_built_once():
    assert snakeboard() is snakeboard() and geared_body() is geared_body()
    assert geared_body(scaled=True) is not geared_body()
