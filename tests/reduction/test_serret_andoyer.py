"""The generalized Serret-Andoyer reduction: canonicity, the reduced Hamiltonian, the atlas, and
trajectories and attitudes checked against exact solutions and direct integration."""

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import geomech as gm
from geomech import LeftInvariantSystem, RigidBody
from geomech.errors import InputError, SingularityError, SymbolicError
from geomech.integrators import SerretAndoyerAtlas
from geomech.lie import so3
from geomech.reduction import GeneralizedSerretAndoyer, SerretAndoyerChart, reduced_formulas, spatial_frame
from geomech.symbolic.formula import parse_formula

m1, m2, m3 = sp.symbols("m1 m2 m3", real=True)
# Not a rigid body: a quartic term and a gyrostat-like linear term; the poles of every chart are NOT
# equilibria here (grad H at G e_k is not along e_k), so trajectories cross them and the atlas must switch.
H_TILT = m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + sp.Rational(1, 10) * m3**4 + (m1 + m2 + m3)


def atlas(system, m0, t, *, R0=None, axis=None, rtol=None, atol=None):
    """The Serret-Andoyer atlas through solve() at the times ``t`` (``axis``: the first chart, 0-based)."""
    t = np.asarray(t, dtype=float)
    method = SerretAndoyerAtlas(axis=None if axis is None else axis + 1)
    R0 = np.eye(3) if R0 is None else R0
    return gm.solve(system, method, t_final=t[-1], saveat=t, m0=m0, R0=R0, rtol=rtol, atol=atol)


def tilt():
    return LeftInvariantSystem.from_expression(H_TILT, name="tilted")


def direct(sys, m0, R0, t):
    """Reference: R' = R hat(grad H), m' = m x grad H integrated in R^12 with tight tolerances."""

    def rhs(_t, y):
        R, m = y[:9].reshape(3, 3), y[9:]
        dR, dm = sys.vector_field(R, m)
        return np.concatenate([dR.ravel(), dm])

    sol = solve_ivp(
        rhs, (t[0], t[-1]), np.concatenate([R0.ravel(), m0]), method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t
    )
    return sol.y[:9].T.reshape(-1, 3, 3), sol.y[9:].T


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_lie_poisson_bracket_of_l_and_L_is_one_symbolically(axis):
    """Proposition 3: {l, L} = 1 for the (-) Lie-Poisson bracket {F, K} = -m . (grad F x grad K), the one
    for which F' = {F, H} reproduces Euler's equation m' = m x grad H."""
    C = sp.Matrix(SerretAndoyerChart(axis).permutation.astype(int).tolist())
    m = sp.Matrix([m1, m2, m3])
    mp = C.T * m
    l = sp.atan2(mp[0], mp[1])
    L = mp[2]
    grad = lambda f: sp.Matrix([sp.diff(f, s) for s in (m1, m2, m3)])
    bracket = -(m.T * grad(l).cross(grad(L)))[0, 0]
    assert sp.simplify(bracket) == 1
    # and the bracket really is the one that gives Euler's equation: {m_i, H} = (m x grad H)_i
    H = sp.Function("H")(m1, m2, m3)
    for i in range(3):
        lhs = -(m.T * grad(m[i]).cross(grad(H)))[0, 0]
        assert sp.simplify(lhs - m.cross(grad(H))[i]) == 0


@given(st.floats(-3.0, 3.0), st.floats(-0.99, 0.99), st.integers(0, 2))
def test_reduced_flow_pushed_forward_is_eulers_equation(l, ratio, axis):
    """dm/dt = dm/dl l' + dm/dL L' with (l', L') from h_p must equal m x grad H (canonicity and sign)."""
    sa = GeneralizedSerretAndoyer(tilt())
    G = 1.7
    lL = np.array([l, ratio * G])
    chart = sa.charts[axis]
    m = chart.inverse(lL, G)
    dl, dL = chart.tangents(lL, G)
    f = sa.reduced_vector_field(lL, G, axis)
    np.testing.assert_allclose(dl * f[0] + dL * f[1], sa.system.euler_vector_field(m), atol=1e-12)
    np.testing.assert_allclose(chart.forward(m), lL, atol=1e-12)


def test_reduced_hamiltonian_of_the_free_body_is_eq_10():
    I1, I2, I3 = sp.symbols("I1 I2 I3", positive=True)
    l, L = sp.symbols("l L", real=True)
    G = sp.Symbol("G", positive=True)
    body = RigidBody([3.0, 2.0, 1.25])
    expr = GeneralizedSerretAndoyer(body).h_p(axis=2)
    eq10 = (sp.sin(l) ** 2 / I1 + sp.cos(l) ** 2 / I2) * (G**2 - L**2) / 2 + L**2 / (2 * I3)
    eq10 = eq10.subs({I1: 3.0, I2: 2.0, I3: 1.25})
    assert sp.simplify(sp.expand_trig(expr - eq10)) == 0


@pytest.mark.parametrize("I1", [3.0, -1e308, 1e-300])
def test_reduced_formulas_agree_with_the_chain_rule_at_any_scale(rng, I1):
    # the formulas are simplified with the parameters as symbols and the numbers put in after: a value at the
    # end of the float range is no harder than 3 (simplifying with it in took 20 s: 300-digit integers in
    # sympy's factorization); checked against the chain rule through grad H, by numbers alone
    text = "m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3) + k*m3**4 + c*m1*m3"
    values = {"I1": I1, "I2": 2.0, "I3": 1.25, "k": 0.1, "c": 0.02}
    expr = parse_formula(text, "H")
    sa = GeneralizedSerretAndoyer(LeftInvariantSystem.from_expression(expr, values))
    G = 1.3
    y = np.stack([rng.uniform(-np.pi, np.pi, 20), rng.uniform(-0.95, 0.95, 20) * G], -1)
    for axis in range(3):
        h, l_dot, L_dot = reduced_formulas(expr, values, axis)
        assert h.free_symbols <= {sp.Symbol("l", real=True), sp.Symbol("L", real=True), sp.Symbol("G", positive=True)}
        f = sp.lambdify(["l", "L", "G"], [h, l_dot, L_dot])
        got = np.array([f(a, b, G) for a, b in y], dtype=float)
        scale = G**2 * (1 / 1.25 + 0.1 * G**2 + 1 / min(abs(I1), 2.0))
        np.testing.assert_allclose(got[:, 0], sa.reduced_hamiltonian(y, G, axis), atol=1e-13 * scale)
        np.testing.assert_allclose(got[:, 1:], sa.reduced_vector_field(y, G, axis), atol=1e-13 * scale)
    # a name without a value stays a symbol, and giving it after is the same formula
    part = reduced_formulas(expr, {k: v for k, v in values.items() if k != "k"}, 2)
    k = next(x for x in part[0].free_symbols if x.name == "k")
    full = reduced_formulas(expr, values, 2)
    for a, b in zip(part, full):
        d = sp.lambdify(["l", "L", "G"], a.subs(k, 0.1) - b)(y[:, 0], y[:, 1], G)
        assert np.abs(d).max() < 1e-13 * 10


def test_symbolic_and_chain_rule_reduced_fields_agree(rng):
    sa = GeneralizedSerretAndoyer(tilt())
    G = 1.3
    for axis in range(3):
        red = sa.reduced_system(G, axis)
        y = np.stack([rng.uniform(-np.pi, np.pi, 20), rng.uniform(-0.95, 0.95, 20) * G], -1)
        np.testing.assert_allclose(red.vector_field(y), sa.reduced_vector_field(y, G, axis), atol=1e-12)
        np.testing.assert_allclose(red.hamiltonian(y), sa.reduced_hamiltonian(y, G, axis), atol=1e-13)


def test_callable_systems_reduce_without_a_formula(rng):
    ref = tilt()
    sys = LeftInvariantSystem.from_callable(ref.hamiltonian, ref.gradient)
    sa = GeneralizedSerretAndoyer(sys)
    red = sa.reduced_system(1.1)
    y = np.array([0.3, 0.4])
    np.testing.assert_allclose(red.vector_field(y), GeneralizedSerretAndoyer(ref).reduced_vector_field(y, 1.1))
    with pytest.raises(SymbolicError, match="needs a formula"):
        sa.h_p()


def test_chart_poles_and_bad_input():
    chart = SerretAndoyerChart(2)
    with pytest.raises(SingularityError, match="poles"):
        chart.forward([0.0, 0.0, 2.0])
    with pytest.raises(InputError, match="axis"):
        SerretAndoyerChart(3)
    with pytest.raises(InputError, match="nonzero"):
        atlas(tilt(), [0.0, 0.0, 0.0], [0.0, 1.0])
    with pytest.raises(InputError, match="rotation matrix"):
        atlas(tilt(), [1.0, 0.0, 0.0], [0.0, 1.0], R0=2 * np.eye(3))


def test_spatial_frame_points_e3_along_p(rng):
    for p in [*rng.normal(size=(5, 3)), np.array([0, 0, 2.0]), np.array([0, 0, -3.0]), np.array([1e-9, 0, -1.0])]:
        S = spatial_frame(p)
        np.testing.assert_allclose(S @ [0, 0, 1], p / np.linalg.norm(p), atol=1e-14)
        np.testing.assert_allclose(S.T @ S, np.eye(3), atol=1e-14)


@pytest.mark.parametrize(
    "m0",
    [np.array([1.0, 0.3, 0.2]), np.array([0.1, 0.3, 1.0]), np.array([0.2, 1.0, 0.05])],
    ids=["major", "minor", "near-separatrix"],
)
def test_reduced_trajectory_matches_the_exact_elliptic_solution(m0):
    body = RigidBody([3.0, 2.0, 1.0])
    exact = body.exact_solution(m0)
    t = np.linspace(0.0, 4 * exact.period, 400)
    traj = atlas(body, m0, t)
    assert traj.success
    np.testing.assert_allclose(traj.m, exact.momentum(t), atol=1e-9 * np.linalg.norm(m0))
    np.testing.assert_allclose(np.linalg.norm(traj.m, axis=1), np.linalg.norm(m0), rtol=1e-13)


def test_chart_switches_keep_the_momentum_and_attitude_continuous(rng):
    """A trajectory of the tilted system through the poles of axis 3: switches happen, and m(t), R(t)
    still match a direct integration of Lemma 1's equations (eq. 13) in R^12."""
    sys = tilt()
    m0 = np.array([0.2, 0.9, 0.3])
    R0 = so3.exp(np.array([0.3, -0.2, 1.1]))
    t = np.linspace(0.0, 40.0, 801)
    traj = atlas(sys, m0, t, R0=R0, axis=2)
    R_ref, m_ref = direct(sys, m0, R0, t)
    assert traj.stats["chart_switches"] >= 20 and set((traj.chart_axis - 1).tolist()) == {0, 1, 2}
    assert np.max(np.abs(m_ref[:, 2])) > 0.99 * np.linalg.norm(m0)  # it does pass near axis 3's poles
    np.testing.assert_allclose(traj.m, m_ref, atol=1e-9)
    np.testing.assert_allclose(traj.R, R_ref, atol=1e-8)
    # the spatial momentum stays where it was, through every switch
    np.testing.assert_allclose(
        np.einsum("nij,nj->ni", traj.R, traj.m), np.broadcast_to(R0 @ m0, (t.size, 3)), atol=1e-9
    )


def test_reconstructed_attitude_of_the_free_body_matches_direct_integration():
    body = RigidBody([3.0, 2.0, 1.0])
    m0 = np.array([1.0, 0.3, 0.2])
    R0 = so3.exp(np.array([0.5, 0.1, -0.4]))
    t = np.linspace(0.0, 50.0, 501)
    traj = atlas(body, m0, t, R0=R0)
    R_ref, _ = direct(body.system, m0, R0, t)
    np.testing.assert_allclose(traj.R, R_ref, atol=1e-8)
    # Theorem 3: cos(theta) = L / G and theta, l are the 3-1-3 angles of S^T R C
    np.testing.assert_allclose(traj.R[0], R0, atol=1e-13)


def test_phi_rate_of_the_free_body_is_the_classical_one(rng):
    I = np.array([3.0, 2.0, 1.0])
    sa = GeneralizedSerretAndoyer(RigidBody(I))
    G = 1.4
    lL = np.stack([rng.uniform(-3, 3, 10), rng.uniform(-0.9, 0.9, 10) * G], -1)
    l = lL[:, 0]
    np.testing.assert_allclose(sa.phi_rate(lL, G), G * (np.sin(l) ** 2 / I[0] + np.cos(l) ** 2 / I[1]), rtol=1e-13)


@pytest.mark.parametrize(
    "m0, axis, family",
    [
        (np.array([0.4, 1.0, 0.3]), 1, "minor"),
        (np.array([0.1, 0.45, 0.88]), 2, "minor"),
        (np.array([0.85, 0.45, 0.1]), 0, "major"),
    ],
)
def test_free_body_through_a_chart_switch_matches_the_exact_solution(m0, axis, family):
    body = RigidBody([3.0, 2.0, 1.0])
    exact = body.exact_solution(m0)
    assert exact.family == family
    t = np.linspace(0.0, 4 * exact.period, 400)
    traj = atlas(body, m0, t, axis=axis)
    assert traj.stats["chart_switches"] >= 1 and (traj.chart_axis - 1)[0] == axis
    np.testing.assert_allclose(traj.m, exact.momentum(t), atol=1e-9 * np.linalg.norm(m0))


def test_reconstruction_by_quadrature_of_a_reduced_solution_from_elsewhere():
    """Integrate the 2-D canonical system h_p alone, then rebuild R(t) from (l, L) by Theorem 3's
    quadrature for phi; compare with a direct integration of eq. (13) in R^12."""
    body = RigidBody([3.0, 2.0, 1.0])
    sa = GeneralizedSerretAndoyer(body)
    m0 = np.array([1.0, 0.3, 0.2])
    R0 = so3.exp(np.array([0.5, 0.1, -0.4]))
    G = np.linalg.norm(m0)
    red = sa.reduced_system(G)
    y0 = sa.charts[2].forward(m0)
    t = np.linspace(0.0, 20.0, 2001)
    sol = solve_ivp(lambda _t, y: red.vector_field(y), (0, 20), y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    R = sa.reconstruct(t, sol.y.T, G, R0=R0)
    R_ref, _ = direct(body.system, m0, R0, t)
    np.testing.assert_allclose(R, R_ref, atol=1e-8)
    # halving the sampling multiplies the quadrature error by about 1/16 (fourth order)
    errs = []
    for n in (101, 201):
        tc = t[:: (len(t) - 1) // (n - 1)]
        errs.append(
            np.abs(
                sa.reconstruct(tc, sol.y.T[:: (len(t) - 1) // (n - 1)], G, R0=R0) - R_ref[:: (len(t) - 1) // (n - 1)]
            ).max()
        )
    assert 10 < errs[0] / errs[1] < 25
    with pytest.raises(InputError, match="increasing"):
        sa.reconstruct(t[::-1], sol.y.T, G)


@pytest.mark.slow
def test_long_run_near_the_separatrix_and_through_many_switches():
    """Long verification: 40 periods near the separatrix against the exact solution, and 400 time units
    of the gyrostat-like system (hundreds of chart switches) against a direct integration."""
    body = RigidBody([3.0, 2.0, 1.0])
    m0 = np.array([0.2, 1.0, 0.05])
    exact = body.exact_solution(m0)
    t = np.linspace(0.0, 40 * exact.period, 4001)
    traj = atlas(body, m0, t, rtol=1e-13, atol=1e-13)
    # DOP853 is not symplectic: its energy error drifts, so the phase error grows like t^2
    np.testing.assert_allclose(traj.m, exact.momentum(t), atol=3e-8)
    sys = tilt()
    m0 = np.array([0.2, 0.9, 0.3])
    t = np.linspace(0.0, 400.0, 4001)
    traj = atlas(sys, m0, t, axis=2)
    _, m_ref = direct(sys, m0, np.eye(3), t)
    assert traj.stats["chart_switches"] > 200
    np.testing.assert_allclose(traj.m, m_ref, atol=1e-8)
    np.testing.assert_allclose(sys.hamiltonian(traj.m), sys.hamiltonian(m0), atol=1e-10)
