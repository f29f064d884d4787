"""Structure-preserving controls (sections 6.1 and 7): conservation of p along direct simulations of the open
loop, the sign of eq. (29a), the exact existence condition of a closed-loop Hamiltonian (Proposition 5's
printed condition fails), H_c in closed form and by quadrature, Lemma 4, hyperregularity and its cost, and
the reduced closed forms eqs. (32), (34), (42), (43) against h_p = H_c o U_p."""

import mpmath
import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech import GeneralizedSerretAndoyer, LeftInvariantSystem, RigidBody
from geomech.errors import InputError, SymbolicError
from geomech.integrators import SerretAndoyerAtlas
from geomech.lie import so3
from geomech.reduction import rotor_closed_forms as cf
from geomech.reduction.serret_andoyer import G_SYM, L_SYM, l_SYM
from geomech.systems.control import StructurePreservingControl as SPC
from geomech.systems.rotors import RotorBody

ONE = RotorBody.one_rotor(3.0, 2.0, 1.0, 0.4)
THREE = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.15, 0.2])
# phi_i = c a_i.m on a pyramid: Lambda^-1 A Dphi = c Lambda^-1 A A^T, symmetric since both are diagonal.
# (Not the isotropic elevation: there A A^T = 4/3 I makes H_f a function of H_c and |m|^2.)
PYRAMID = RotorBody.pyramid(np.diag([3.0, 2.5, 2.0]), [0.1, 0.12, 0.1, 0.08], elevation=0.5)


def atlas(system, m0, t, *, R0=None, axis=None, rtol=None, atol=None):
    """The Serret-Andoyer atlas through solve() at the times ``t`` (``axis``: the first chart, 0-based)."""
    t = np.asarray(t, dtype=float)
    method = SerretAndoyerAtlas(axis=None if axis is None else axis + 1)
    R0 = np.eye(3) if R0 is None else R0
    return gm.solve(system, method, t_final=t[-1], saveat=t, m0=m0, R0=R0, rtol=rtol, atol=atol)


def open_loop(body, t, **kw):
    """The open-loop equations (26) / (38) by DOP853 at the tolerances of a reference solution."""
    return gm.solve(body, "solve_ivp", t_final=t[-1], saveat=t, rtol=1e-12, atol=1e-12, **kw)


def simulate_closed_loop(body, control, m0, t, R0=None):
    return open_loop(body, t, m0=m0, Gamma0=control.rotor_momentum(m0), R0=R0, tau=control)


@pytest.mark.parametrize(
    "make",
    [
        lambda: (ONE, SPC.one_rotor(ONE, "k*v + a*v**3", parameters={"k": 0.6, "a": 0.3}, p=0.05)),
        lambda: (
            THREE,
            SPC.diagonal(
                THREE, ["a*v", "b*sin(v)", "k*v"], parameters={"a": 0.2, "b": 0.3, "k": 0.5}, p=[0.02, -0.03, 0.01]
            ),
        ),
        lambda: (THREE, SPC.three_rotors(THREE, ["3*c*m2", "2*c*m1", "k*m3"], parameters={"c": 0.2, "k": 0.4})),
        lambda: (
            PYRAMID,
            SPC.general(
                PYRAMID,
                [f"c*({float(a[0])}*m1 + {float(a[1])}*m2 + {float(a[2])}*m3)" for a in PYRAMID.axes],
                parameters={"c": 0.3},
            ),
        ),
    ],
    ids=["one-rotor", "corollary-2", "proposition-5", "pyramid"],
)
def test_p_is_constant_and_H_c_conserved_along_the_open_loop_simulation(make):
    body, control = make()
    t = np.linspace(0.0, 30.0, 301)
    m0 = np.array([0.4, 0.9, 0.3])
    traj = simulate_closed_loop(body, control, m0, t, R0=so3.exp([0.1, 0.2, -0.3]))
    p = control.conserved_p(traj.m, traj.Gamma)
    assert np.abs(p - p[0]).max() < 1e-10
    # the closed-loop motion of the body is that of H_c: H_c and R m conserved, m moves
    Hc = control.closed_loop_hamiltonian(traj.m)
    assert np.abs(Hc - Hc[0]).max() < 1e-10 * max(1.0, abs(Hc[0]))
    pi = traj.spatial_momentum
    assert np.abs(pi - pi[0]).max() < 1e-10
    assert np.abs(traj.m - m0).max() > 0.05
    # the free energy H_f is NOT conserved: the motors do work (what makes the H_c check meaningful)
    E = traj.energy
    assert np.abs(E - E[0]).max() > 1e-6


def test_pyramid_single_wheel_feedback_has_no_closed_loop_hamiltonian():
    # phi_1 = k m3 on one tilted wheel: Lambda^-1 a_1 (k e3^T) is not symmetric
    with pytest.raises(InputError, match="no closed-loop Hamiltonian"):
        SPC.general(PYRAMID, ["k*m3", "0", "0", "0"], parameters={"k": 0.3})


def test_eq29a_sign_checked_against_eq30c(rng):
    control = SPC.one_rotor(ONE, "k*v + a*v**2", parameters={"k": 0.6, "a": 0.4})
    m = rng.normal(size=(20, 3))
    Gamma = rng.normal(size=(20, 1))
    # the state feedback u = phi'(m3) m3' equals the corrected eq. (29a) for every rotor momentum
    np.testing.assert_allclose(control.feedback(m, Gamma), control.eq29a_torque(m), atol=1e-14)
    # with the sign printed in eq. (29a), p = Gamma - phi(m3) drifts along the motion
    t = np.linspace(0.0, 20.0, 201)
    m0 = np.array([0.5, 0.8, 0.3])
    printed = open_loop(
        ONE,
        t,
        m0=m0,
        Gamma0=control.rotor_momentum(m0),
        tau=lambda t, R, m, g, G: control.eq29a_torque(m, as_printed=True),
    )
    p = control.conserved_p(printed.m, printed.Gamma)
    assert np.abs(p - p[0]).max() > 1e-2
    corrected = open_loop(
        ONE, t, m0=m0, Gamma0=control.rotor_momentum(m0), tau=lambda t, R, m, g, G: control.eq29a_torque(m)
    )
    p = control.conserved_p(corrected.m, corrected.Gamma)
    assert np.abs(p - p[0]).max() < 1e-10


def test_reduced_flow_mapped_back_agrees_with_direct_open_loop_simulation():
    """Quality bar: the Serret-Andoyer reduced flow of H_c, mapped back to m (and R), agrees with a direct
    simulation of the open-loop system (R, m, gamma, Gamma) with the feedback on, to 1e-8."""
    control = SPC.one_rotor(ONE, "2*tan(v/G)", parameters={"G": 1.0}, p=0.1)
    t = np.linspace(0.0, 30.0, 301)
    m0 = np.array([0.3, 0.85, 0.4])
    m0 *= 0.95 / np.linalg.norm(m0)
    R0 = so3.exp([0.3, -0.1, 0.5])
    direct = simulate_closed_loop(ONE, control, m0, t, R0=R0)
    red = atlas(control.closed_loop(), m0, t, R0=R0)
    assert np.abs(red.m - direct.m).max() < 1e-8
    assert np.abs(red.R - direct.R).max() < 1e-8
    assert red.stats["chart_switches"] >= 0 and np.abs(direct.m - m0).max() > 0.1


def test_proposition5_printed_condition_is_not_the_right_one():
    # Dphi symmetric (the printed condition) and lambda1 != lambda2: no closed-loop Hamiltonian
    with pytest.raises(InputError, match=r"no closed-loop Hamiltonian.*\(1,2\)"):
        SPC.three_rotors(THREE, ["a*m2", "a*m1", "0"], parameters={"a": 0.3})
    # ... which exists when lambda1 = lambda2
    sym = RotorBody.three_rotors([2.0, 2.0, 1.0], [0.1, 0.1, 0.1])
    assert SPC.three_rotors(sym, ["a*m2", "a*m1", "0"], parameters={"a": 0.3}).condition.holds
    # Dphi NOT symmetric, yet Lambda^-1 Dphi symmetric: a closed-loop Hamiltonian exists
    c = SPC.three_rotors(THREE, ["3*c*m2", "2*c*m1", "0"], parameters={"c": 0.3})
    D = c.phi_jacobian(np.array([0.1, 0.2, 0.3]))
    assert abs(D[0, 1] - D[1, 0]) > 0.1
    assert c.condition.holds and c.lemma4_check().passed(1e-12)


def test_the_rejection_is_real_F_is_not_a_gradient():
    """For the rejected phi the closed-loop angular velocity F has a nonzero curl: the line integral of F
    around a closed loop is not zero, so no H_c can have grad H_c = F."""
    lam = np.array([3.0, 2.0, 1.2])
    a = 0.3

    def F(m):
        return (m - a * np.array([m[1], m[0], 0.0])) / lam

    s = np.linspace(0, 2 * np.pi, 4001)
    loop = np.stack([np.cos(s), np.sin(s), np.zeros_like(s)], 1)
    dloop = np.stack([-np.sin(s), np.cos(s), np.zeros_like(s)], 1)
    circulation = np.trapezoid([F(x) @ dx for x, dx in zip(loop, dloop)], s)
    assert abs(circulation - a * np.pi * (1 / lam[0] - 1 / lam[1])) < 1e-9


def test_callable_phi_checks():
    def phi(m):
        return np.stack([0.3 * m[..., 1], 0.3 * m[..., 0], 0 * m[..., 2]], -1)

    def jac(m):
        J = np.zeros(m.shape[:-1] + (3, 3))
        J[..., 0, 1] = J[..., 1, 0] = 0.3
        return J

    with pytest.raises(InputError, match="no closed-loop Hamiltonian"):
        SPC.three_rotors(THREE, phi, jacobian=jac)
    with pytest.raises(InputError, match="derivative"):
        SPC.three_rotors(THREE, phi)
    with pytest.raises(InputError, match="does not match"):
        SPC.one_rotor(ONE, lambda v: 0.5 * v**2, dphi=lambda v: 0.5 * v)
    with pytest.raises(InputError, match="one rotor"):
        SPC.one_rotor(THREE, "k*v", parameters={"k": 1.0})


@pytest.mark.parametrize(
    "phi, params, needle",
    [
        ("k*v + m1", {"k": 1.0}, "function of v alone"),
        ("k*v", {}, "neither its variable"),
        ("k*v", {"k": 1.0, "z": 2.0}, "do not appear"),
        ("lambda1*v", {"lambda1": 1.0}, "name the model"),
        ("k*v +", {"k": 1.0}, "Could not parse"),
        ("k*v", {"k": float("nan")}, "finite"),
    ],
)
def test_bad_symbolic_phi(phi, params, needle):
    with pytest.raises(SymbolicError, match=needle):
        SPC.one_rotor(ONE, phi, parameters=params)


def test_closed_loop_hamiltonian_eq29b_with_its_constant_fixed_at_zero(rng):
    control = SPC.one_rotor(ONE, "k*v + a*v**3", parameters={"k": 0.6, "a": 0.3}, p=0.05)
    lam1, lam2, I3 = 3.0, 2.0, 1.0
    m = rng.normal(size=(10, 3))
    expected = (
        0.5 * (m[:, 0] ** 2 / lam1 + m[:, 1] ** 2 / lam2 + m[:, 2] ** 2 / I3)
        - (0.3 * m[:, 2] ** 2 + 0.3 * m[:, 2] ** 4 / 4 + 0.05 * m[:, 2]) / I3
    )
    np.testing.assert_allclose(control.closed_loop_hamiltonian(m), expected, rtol=1e-13, atol=1e-15)
    assert control.closed_loop_hamiltonian(np.zeros(3)) == 0.0
    assert isinstance(control.closed_loop(), LeftInvariantSystem)


def test_quadrature_H_c_when_sympy_has_no_antiderivative(rng):
    control = SPC.one_rotor(ONE, "exp(sin(v))")
    assert not control.hamiltonian_is_closed_form and control.H_c.has(sp.Integral)
    m = rng.normal(size=(4, 3))
    for mi in m:
        integral = float(mpmath.quad(lambda s: mpmath.exp(mpmath.sin(s)), [0, float(mi[2])]))
        ref = 0.5 * (mi[0] ** 2 / 3 + mi[1] ** 2 / 2 + mi[2] ** 2) - integral
        assert abs(control.closed_loop_hamiltonian(mi) - ref) < 1e-13
    check = control.lemma4_check()
    assert "central differences" in check.gradient_route and check.passed(1e-9)
    # the Hamiltonian side works on the quadrature H_c
    traj = atlas(control.closed_loop(), [0.3, 0.8, 0.2], np.linspace(0, 5, 11))
    H = control.closed_loop_hamiltonian(traj.m)
    assert np.abs(H - H[0]).max() < 1e-10


def test_closed_form_and_quadrature_agree():
    sym = SPC.one_rotor(ONE, "h*tanh(k*v/h)", parameters={"h": 0.5, "k": 0.8})
    assert sym.hamiltonian_is_closed_form
    num = SPC.one_rotor(ONE, lambda v: 0.5 * np.tanh(1.6 * v), dphi=lambda v: 0.8 / np.cosh(1.6 * v) ** 2)
    assert not num.hamiltonian_is_closed_form
    m = np.random.default_rng(1).normal(size=(20, 3)) * 2
    np.testing.assert_allclose(sym.closed_loop_hamiltonian(m), num.closed_loop_hamiltonian(m), atol=1e-13)
    np.testing.assert_allclose(sym.closed_loop().gradient(m), num.closed_loop().gradient(m), atol=1e-14)


def test_lemma4_check_can_fail():
    control = SPC.one_rotor(ONE, "k*v", parameters={"k": 0.6})
    assert control.lemma4_check().passed(1e-13)
    # a wrong H_c (the constant-free sign of the rotor term flipped) is caught
    control.H_c = control.H_c + 2 * sp.Symbol("k", real=True) * sp.Symbol("m3", real=True) ** 2 / 2
    assert not control.lemma4_check().passed(1e-3)


def test_hyperregularity_and_its_cost():
    assert SPC.one_rotor(ONE, "k*v", parameters={"k": 0.6}).hyperregularity().status == "yes"
    r = SPC.one_rotor(ONE, "k*v", parameters={"k": 1.0}).hyperregularity()
    assert r.status == "no" and "every v" in r.where
    cubic = SPC.one_rotor(ONE, "v**3")
    r = cubic.hyperregularity()
    assert r.status == "no"
    np.testing.assert_allclose(sorted(r.points), [-1 / np.sqrt(3), 1 / np.sqrt(3)], atol=1e-12)
    assert "Lagrangian side" in r.cost and "Serret-Andoyer" in r.cost
    system = cubic.closed_loop()
    # the cost: the Legendre transform m -> omega = grad H_c is singular where phi'(m3) = 1, and not injective
    # across: two momenta have the same angular velocity, so omega -> m (the Lagrangian side) is lost ...
    assert not system.is_hyperregular_at([0.2, 0.3, 1 / np.sqrt(3)])
    ma = np.array([0.2, 0.3, 0.3])
    roots = np.roots([-1.0, 0.0, 1.0, -(0.3 - 0.3**3)])
    mb = np.array([0.2, 0.3, max(r.real for r in roots if abs(r.imag) < 1e-12)])
    assert abs(mb[2] - ma[2]) > 0.1
    np.testing.assert_allclose(system.gradient(mb), system.gradient(ma), atol=1e-14)
    # ... while the Hamiltonian side still works through those momenta
    m0 = np.array([0.5, 0.6, 0.55])
    traj = atlas(system, m0, np.linspace(0, 20, 201))
    assert traj.m[:, 2].min() < 1 / np.sqrt(3) < traj.m[:, 2].max()
    H = system.hamiltonian(traj.m)
    assert np.abs(H - H[0]).max() < 1e-11
    # three rotors, general phi: a numeric scan of det(I - Dphi) finds where it vanishes
    r3 = SPC.three_rotors(THREE, ["0.6*m1**2", "0", "0"], probe_radius=1.0).hyperregularity()
    assert r3.status == "no"
    d = SPC.diagonal(THREE, ["0", "0", "v**3"]).hyperregularity()
    assert d.status == "no" and "phi_3'" in d.where


def test_eq32_equals_h_p_and_eq34_differs_by_a_constant(rng):
    control = SPC.one_rotor(ONE, "k*v + a*v**3 + b*sin(v)", parameters={"k": 0.3, "a": 0.2, "b": 0.1}, p=0.07)
    hp = cf.closed_loop_h_p(control)
    e32 = cf.eq32_reduced_hamiltonian(control)
    f = sp.lambdify([l_SYM, L_SYM, G_SYM], hp - e32)
    pts = rng.uniform([-3, -0.9, 1.0], [3, 0.9, 1.5], size=(20, 3))
    assert np.abs(f(*pts.T)).max() < 1e-13
    lin = SPC.one_rotor(ONE, "k*v + c", parameters={"k": 0.3, "c": 0.05}, p=0.07)
    d = sp.lambdify([l_SYM, L_SYM, G_SYM], cf.eq34_reduced_hamiltonian(lin) - cf.closed_loop_h_p(lin))(*pts.T)
    np.testing.assert_allclose(d, (0.07 + 0.05) ** 2 / (2 * 1.0 * 0.7), rtol=1e-12)


def test_locked_rotor_reproduces_the_free_rigid_body():
    """Eq. (34) with p = 0 and k = J3/(I3 + J3): h_p is the free rigid body's with inertias (I_i + J_i), and
    a direct open-loop simulation with this control keeps the rotor locked and follows the exact elliptic
    solution of that rigid body."""
    control = cf.locked_rotor_control(ONE)
    rb = RigidBody([3.0, 2.0, 1.4])
    free = GeneralizedSerretAndoyer(rb).h_p()
    # both in floating point (the parameters are numbers): equal to round-off of h_p's scale, G^2/(2 I_min)
    pts = np.random.default_rng(3).uniform([-3, -0.9, 1.0], [3, 0.9, 1.5], size=(50, 3))
    d = sp.lambdify([l_SYM, L_SYM, G_SYM], cf.closed_loop_h_p(control) - free)(*pts.T)
    assert np.abs(d).max() < 1e-13 * (1.5**2 / 2.0)
    t = np.linspace(0.0, 30.0, 301)
    m0 = np.array([0.6, 0.5, 0.7])
    traj = simulate_closed_loop(ONE, control, m0, t)
    assert np.abs(ONE.rotor_rates(traj.m, traj.Gamma)).max() < 1e-12
    assert np.abs(traj.m - rb.exact_solution(m0).momentum(t)).max() < 1e-9


def test_eq43_equals_h_p():
    control = SPC.diagonal(THREE, ["0", "0", "k*v + a*v**3"], parameters={"k": 0.4, "a": 0.2}, p=[0.1, -0.2, 0.05])
    d = sp.lambdify([l_SYM, L_SYM, G_SYM], cf.closed_loop_h_p(control) - cf.eq43_reduced_hamiltonian(control))
    pts = np.random.default_rng(2).uniform([-3, -0.9, 1.0], [3, 0.9, 1.5], size=(20, 3))
    assert np.abs(d(*pts.T)).max() < 1e-13


def test_eq42_as_printed_leaves_a_function_of_L_undetermined():
    control = SPC.diagonal(
        THREE, ["a*v", "b*v**2", "k*v"], parameters={"a": 0.2, "b": 0.3, "k": 0.4}, p=[0.1, 0.2, 0.05]
    )
    hp = cf.closed_loop_h_p(control)
    e42 = cf.eq42_reduced_hamiltonian(control)
    diff = hp - e42
    pts = np.random.default_rng(3).uniform([-3, -0.9, 1.0], [3, 0.9, 1.5], size=(20, 3))
    # the l-derivatives agree: eq. (42) gets dh_p/dl right ...
    dl = sp.lambdify([l_SYM, L_SYM, G_SYM], sp.diff(diff, l_SYM))(*pts.T)
    assert np.abs(dl).max() < 1e-13
    # ... but misses a function of L, which is nonzero and changes l' = dh_p/dL
    vals = sp.lambdify([l_SYM, L_SYM, G_SYM], diff)(*pts.T)
    assert np.abs(vals).max() > 1e-2
    missing = sp.lambdify([l_SYM, L_SYM, G_SYM], cf.eq42_missing_term(control))(*pts.T)
    np.testing.assert_allclose(vals, missing, atol=1e-13)
    dL = sp.lambdify([l_SYM, L_SYM, G_SYM], sp.diff(diff, L_SYM))(*pts.T)
    assert np.abs(dL).max() > 1e-2


def test_family_rechecks_the_condition_when_parameters_move():
    sym = RotorBody.three_rotors([2.0, 2.0, 1.0], [0.1, 0.1, 0.1])
    control = SPC.three_rotors(sym, ["a*m2", "a*m1", "0"], parameters={"a": 0.3})
    assert isinstance(control.family()(a=0.5), LeftInvariantSystem)
    with pytest.raises(InputError, match="no closed-loop Hamiltonian"):
        control.family()(lambda1=3.0)
    with pytest.raises(InputError, match="Unknown parameter"):
        control.family()(q=1.0)


def test_eq31_is_the_reduced_flow_of_H_c(rng):
    """Theorem 4, eq. (31): l' = -L (sin^2 l/lambda1 + cos^2 l/lambda2) + (L - phi(L) - p)/I3,
    L' = (G^2 - L^2)(1/lambda2 - 1/lambda1) sin l cos l, against the generic reduction of H_c."""
    lam1, lam2, I3, p = 3.0, 2.0, 1.0, 0.07
    control = SPC.one_rotor(ONE, "k*v + a*v**3", parameters={"k": 0.3, "a": 0.2}, p=p)
    sa = GeneralizedSerretAndoyer(control.closed_loop())
    for _ in range(10):
        G = rng.uniform(0.5, 2.0)
        l, L = rng.uniform(-np.pi, np.pi), rng.uniform(-0.95, 0.95) * G
        phi = 0.3 * L + 0.2 * L**3
        ldot = -L * (np.sin(l) ** 2 / lam1 + np.cos(l) ** 2 / lam2) + (L - phi - p) / I3
        Ldot = (G**2 - L**2) * (1 / lam2 - 1 / lam1) * np.sin(l) * np.cos(l)
        np.testing.assert_allclose(sa.reduced_vector_field([l, L], G), [ldot, Ldot], atol=1e-13)


def test_eq41_closed_loop_hamiltonian_of_corollary2(rng):
    """Eq. (41): H_c = sum_i (1/lambda_i) int_0^{m_i} (s - phi_i(s) - p_i) ds."""
    lam = np.array([3.0, 2.0, 1.2])
    p = np.array([0.02, -0.03, 0.01])
    control = SPC.diagonal(THREE, ["a*v", "b*sin(v)", "k*v**2"], parameters={"a": 0.2, "b": 0.3, "k": 0.5}, p=p)
    m = rng.normal(size=(10, 3))
    antiderivatives = [0.2 * m[:, 0] ** 2 / 2, 0.3 * (1 - np.cos(m[:, 1])), 0.5 * m[:, 2] ** 3 / 3]
    expected = sum((m[:, i] ** 2 / 2 - antiderivatives[i] - p[i] * m[:, i]) / lam[i] for i in range(3))
    np.testing.assert_allclose(control.closed_loop_hamiltonian(m), expected, rtol=1e-13, atol=1e-15)


def test_general_phi_with_no_elementary_potential_uses_the_ray_quadrature(rng):
    """phi = Lambda grad(psi) with psi(m) = int_0^{m1+m2} exp(sin u) du, which sympy cannot integrate:
    H_c = |m|^2_{Lambda^-1}/2 - psi(m) by Gauss-Legendre quadrature along the ray from 0."""
    control = SPC.three_rotors(THREE, ["3*exp(sin(m1 + m2))", "2*exp(sin(m1 + m2))", "0"])
    assert control.condition.holds and not control.hamiltonian_is_closed_form
    lam = np.array([3.0, 2.0, 1.2])
    for mi in rng.normal(size=(4, 3)):
        psi = float(mpmath.quad(lambda u: mpmath.exp(mpmath.sin(u)), [0, float(mi[0] + mi[1])]))
        assert abs(control.closed_loop_hamiltonian(mi) - (0.5 * np.sum(mi**2 / lam) - psi)) < 1e-13
    assert control.lemma4_check().passed(1e-9)


def test_quadrature_when_asked_agrees_with_the_symbolic_integral(rng):
    """How the integral is done is the caller's choice (never a timer): quadrature gives the same H_c."""
    fast = SPC.one_rotor(ONE, "k*v + a*v**3", parameters={"k": 0.3, "a": 0.2}, integral="quadrature")
    ref = SPC.one_rotor(ONE, "k*v + a*v**3", parameters={"k": 0.3, "a": 0.2})
    assert ref.hamiltonian_is_closed_form and not fast.hamiltonian_is_closed_form
    m = rng.normal(size=(10, 3))
    np.testing.assert_allclose(fast.closed_loop_hamiltonian(m), ref.closed_loop_hamiltonian(m), atol=1e-14)


def test_the_integral_choice_is_a_rule_on_the_expression():
    import sympy as sp

    from geomech.errors import InputError
    from geomech.symbolic.integrals import symbolic_friendly

    v = sp.Symbol("v", real=True)
    k, G = sp.symbols("k G", positive=True)
    friendly = [k * v + v**3, 2 * sp.tan(v / G), sp.sin(v) ** 2 * sp.exp(v), v * sp.log(v), 1 / (1 + v**2)]
    hard = [v * sp.tan(v), sp.exp(sp.sin(v)), sp.tan(v) * sp.exp(v), v**9, sp.sin(v**2)]
    assert all(symbolic_friendly(e, v) for e in friendly)
    assert not any(symbolic_friendly(e, v) for e in hard)
    assert not SPC.three_rotors(THREE, ["3*exp(sin(m1 + m2))", "2*exp(sin(m1 + m2))", "0"]).hamiltonian_is_closed_form
    with pytest.raises(InputError, match="`integral`"):
        SPC.one_rotor(ONE, "k*v", parameters={"k": 0.3}, integral="fast")
