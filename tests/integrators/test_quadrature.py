"""Exact propagation by quadrature of 1-degree-of-freedom systems: periods against the elliptic solution and
a 40-digit quadrature, states against the exact solution and a tight DOP853 run, the reconstruction angle
and the attitude against the Serret-Andoyer atlas (solve) and closed forms, separatrices, equilibria, the
conditioning limits and bad input."""

import math

import mpmath as mp
import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.special import ellipk

import geomech as gm
from geomech import CanonicalSystem, LeftInvariantSystem, RigidBody
from geomech.errors import ConvergenceError, InputError, ShapeError, SingularityError
from geomech.integrators import QuadraturePropagator, SerretAndoyerAtlas, SerretAndoyerPropagator
from geomech.lie import so3
from geomech.reduction import GeneralizedSerretAndoyer, SerretAndoyerChart

l_, L_, q_, p_ = sp.symbols("l L q p", real=True)
CHART = SerretAndoyerChart(2)


def atlas(system, m0, t, *, R0=None, axis=None, rtol=None, atol=None):
    """The Serret-Andoyer atlas through solve() at the times ``t`` (``axis``: the first chart, 0-based)."""
    t = np.asarray(t, dtype=float)
    method = SerretAndoyerAtlas(axis=None if axis is None else axis + 1)
    R0 = np.eye(3) if R0 is None else R0
    return gm.solve(system, method, t_final=t[-1], saveat=t, m0=m0, R0=R0, rtol=rtol, atol=atol)


def free_body_h(inertia, G):
    """Eq. (10) of the Serret-Andoyer paper with exact rational moments (no rounding in the coefficients)."""
    I1, I2, I3 = (sp.Rational(i) for i in inertia)
    Gs = sp.Float(G, 30)
    h = (Gs**2 - L_**2) * (sp.sin(l_) ** 2 / I1 + sp.cos(l_) ** 2 / I2) / 2 + L_**2 / (2 * I3)
    return CanonicalSystem.from_expression(h, [l_], [L_], angle_coordinates=(0,))


def closed_loop():
    """The seed's closed loop (section 8): one rotor, phi(v) = 2 tan(v/G), p = 0, so
    H_c = m.diag(1/lambda1, 1/lambda2, 1/I3).m / 2 - (1/I3) int_0^m3 2 tan(v/G) dv
        = ... + (2 G / I3) log cos(m3 / G)."""
    expr = "m1**2/(2*lam1) + m2**2/(2*lam2) + m3**2/(2*I3) + 2*G/I3*log(cos(m3/G))"
    return LeftInvariantSystem.from_expression(expr, {"lam1": 3.0, "lam2": 2.0, "I3": 1.0, "G": 1.0})


def counting(system):
    """The same system with its evaluations counted (points, not calls)."""
    count = {"n": 0}

    def wrap(fn):
        def inner(y):
            count["n"] += np.asarray(y)[..., 0].size
            return fn(y)

        return inner

    wrapped = CanonicalSystem(
        n=1,
        name=system.name,
        _hamiltonian=wrap(system._hamiltonian),
        _gradient=wrap(system._gradient),
        _hessian=wrap(system._hessian),
        angle_coordinates=(0,),
    )
    return wrapped, count


def mp_free_body_period(inertia, G, E):
    """T = oint dl / |l'| with |l'| = G sqrt((A - a(l))(b - a(l))) (eq. 11a), in 40-digit arithmetic, with the
    turning-point singularities of a libration removed by l = c + w sin u."""
    with mp.workdps(40):
        return float(_mp_free_body_period(inertia, G, E))


def _mp_free_body_period(inertia, G, E):
    I1, I2, I3 = (mp.mpf(i) for i in inertia)
    G, E = mp.mpf(G), mp.mpf(E)
    A, b = 2 * E / G**2, 1 / I3
    a = lambda l: mp.sin(l) ** 2 / I1 + mp.cos(l) ** 2 / I2
    rate = lambda l: G * mp.sqrt(abs((A - a(l)) * (b - a(l))))  # abs: rounding at the turning points
    lo, hi = sorted((1 / I1, 1 / I2))
    if not lo < A < hi:
        return mp.quad(lambda l: 1 / rate(l), mp.linspace(0, 2 * mp.pi, 5))
    e = mp.asin(mp.sqrt((A - 1 / I2) / (1 / I1 - 1 / I2)))  # a(l) = A at l = +-e and pi -+ e
    # l librates about 0 (|l| < e) or about pi/2 (e < l < pi - e): where A - a and b - a share a sign
    c, w = (0, e) if (A - 1 / I2) * (b - 1 / I2) > 0 else (mp.pi / 2, mp.pi / 2 - e)
    return 2 * mp.quad(lambda u: w * mp.cos(u) / rate(c + w * mp.sin(u)), [-mp.pi / 2, 0, mp.pi / 2])


# -- periods ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("inertia", [(1.0, 2.0, 3.0), (3.0, 2.0, 1.0), (2.0, 3.0, 1.5), (1.5, 1.0, 2.0)])
@pytest.mark.parametrize("family", ["major", "minor"])
def test_free_body_period_equals_the_elliptic_one(inertia, family):
    body = RigidBody(inertia)
    big, small = int(np.argmax(inertia)), int(np.argmin(inertia))
    m0 = np.full(3, 0.35)
    m0[big if family == "major" else small] = 0.9
    solution = body.exact_solution(m0)
    assert solution.family == family
    G = np.linalg.norm(m0)
    orbit = QuadraturePropagator(GeneralizedSerretAndoyer(body).reduced_system(G), CHART.forward(m0), L_bounds=(-G, G))
    # about axis 3 (the chart's pole) m circulates in l; about axes 1, 2 it librates in l
    assert orbit.kind == ("rotation" if (big if family == "major" else small) == 2 else "libration")
    assert orbit.period == pytest.approx(solution.period, rel=1e-11)
    assert orbit.period_error < 1e-12 * orbit.period


@pytest.mark.parametrize("m0", [(0.3, 0.5, 0.8), (0.9, 0.2, 0.3), (0.2, 0.95, 0.1)])
def test_period_is_exact_to_round_off_against_a_40_digit_quadrature(m0):
    """With rational coefficients the only error is the quadrature's: T to a few ulps."""
    m0 = np.array(m0)
    G = float(np.linalg.norm(m0))
    orbit = QuadraturePropagator(free_body_h((1, 2, 3), G), CHART.forward(m0), L_bounds=(-G, G))
    reference = mp_free_body_period((1, 2, 3), G, orbit.energy)
    assert abs(orbit.period / float(reference) - 1) < 8 * np.finfo(float).eps


# -- states -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("m0", [(0.3, 0.5, 0.8), (0.9, 0.2, 0.3), (0.6, -0.6, 0.5)])
def test_state_equals_the_exact_solution_at_any_time_at_a_cost_independent_of_t(m0):
    m0 = np.array(m0)
    G = float(np.linalg.norm(m0))
    body = RigidBody([1.0, 2.0, 3.0])
    system, count = counting(free_body_h((1, 2, 3), G))
    orbit = QuadraturePropagator(system, CHART.forward(m0), L_bounds=(-G, G))
    exact = body.exact_solution(m0)
    built = count["n"]
    assert built > 0
    for t, tol in ((0.37, 1e-10), (10.0, 1e-10), (1e3, 1e-10), (1e6, 1e-9)):
        # at t = 1e6 the state moves by t * (dT / T) * |y'|: the period's last-bit rounding, a relative
        # 1e-16, is 1e-10 there; that (not the quadrature) sets the bound
        m = CHART.inverse(orbit.state(t), G)
        np.testing.assert_allclose(m, exact.momentum(t), atol=tol, err_msg=f"t = {t}")
    assert count["n"] == built  # no evaluation of H at any t, however large
    many = orbit.state(np.linspace(-50.0, 50.0, 2001))
    np.testing.assert_allclose(CHART.inverse(many, G), exact.momentum(np.linspace(-50.0, 50.0, 2001)), atol=1e-12)
    assert count["n"] == built


def test_rotation_is_lifted_and_librations_close():
    G = 1.0
    rot = QuadraturePropagator(free_body_h((1, 2, 3), G), [0.4, 0.9], L_bounds=(-G, G))
    assert rot.kind == "rotation" and rot.winding in (1, -1)
    # l' = dh/dL = L (1/I3 - a(l)) < 0 for L > 0 here: l decreases
    assert rot.winding == -1
    np.testing.assert_allclose(rot.state(rot.period), [0.4 - 2 * np.pi, 0.9], atol=1e-12)
    np.testing.assert_allclose(rot.state(3 * rot.period), [0.4 - 6 * np.pi, 0.9], atol=1e-11)
    lib = QuadraturePropagator(free_body_h((1, 2, 3), G), [0.4, 0.3], L_bounds=(-G, G))
    assert lib.kind == "libration" and lib.winding == 0
    np.testing.assert_allclose(lib.state([lib.period, -2 * lib.period]), [[0.4, 0.3]] * 2, atol=1e-12)


def test_turning_points_of_a_free_body_libration():
    """dh/dL = L (1/I3 - a(l)) = 0 with a(l) > 1/I3: L = 0 and a(l) = sin^2 l + cos^2 l / 2 = 2E/G^2, and the
    orbit librates about l = pi/2 (m about the minor axis e1)."""
    G = 1.0
    orbit = QuadraturePropagator(free_body_h((1, 2, 3), G), [0.4, 0.3], L_bounds=(-G, G))
    A = 2 * orbit.energy / G**2
    sin2 = (A - 1 / 2) / (1 - 1 / 2)
    tp = orbit.turning_points
    assert tp.shape == (2, 2)
    np.testing.assert_allclose(tp[:, 1], 0.0, atol=1e-14)
    e = np.arcsin(np.sqrt(sin2))
    np.testing.assert_allclose(np.sort(tp[:, 0]), [e, np.pi - e], atol=1e-12)
    np.testing.assert_allclose(orbit.state(orbit.turning_times), tp, atol=1e-11)
    assert abs(np.diff(orbit.turning_times)[0] - orbit.period / 2) < 1e-10  # symmetric orbit
    assert orbit.L_range == pytest.approx((-orbit.L_range[1], orbit.L_range[1]), abs=1e-13)


def test_non_quadratic_closed_loop_against_tight_dop853():
    h = GeneralizedSerretAndoyer(closed_loop()).reduced_system(1.0)
    y0 = np.array([0.3, 0.2])
    orbit = QuadraturePropagator(h, y0, L_bounds=(-1.0, 1.0))
    assert orbit.kind == "libration"
    t = np.linspace(0.0, 3.2 * orbit.period, 40)
    ref = solve_ivp(lambda _t, y: h.vector_field(y), (0, t[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t)
    np.testing.assert_allclose(orbit.state(t), ref.y.T, atol=1e-10)
    # the period is where the reference returns to y0 (a root of l(t) - l0 with L increasing)
    ev = lambda _t, y: y[0] - y0[0]
    ev.direction = np.sign(h.vector_field(y0)[0])
    run = solve_ivp(
        lambda _t, y: h.vector_field(y), (0, 1.5 * orbit.period), y0, method="DOP853", rtol=1e-13, atol=1e-14, events=ev
    )
    assert run.t_events[0][-1] == pytest.approx(orbit.period, rel=1e-10)


def test_pendulum_in_the_plane_and_on_the_cylinder():
    """H = p^2/2 - cos q: libration period 4 K(k^2), k = sin(q_max/2); rotation against mpmath."""
    H = CanonicalSystem.from_expression(p_**2 / 2 - sp.cos(q_), [q_], [p_])
    lib = QuadraturePropagator(H, [1.0, 0.0])  # q not an angle: no rotations possible
    assert lib.angle_period is None and lib.kind == "libration"
    assert lib.period == pytest.approx(4 * ellipk(math.sin(0.5) ** 2), rel=1e-13)
    np.testing.assert_allclose(sorted(lib.turning_points[:, 0]), [-1.0, 1.0], atol=1e-13)
    rot = QuadraturePropagator(H, [0.0, 2.5], angle_period=2 * np.pi)
    assert rot.kind == "rotation" and rot.winding == 1
    with mp.workdps(30):
        E = mp.mpf(2.5) ** 2 / 2 - 1
        ref = mp.quad(lambda q: 1 / mp.sqrt(2 * (E + mp.cos(q))), [0, mp.pi, 2 * mp.pi])
    assert rot.period == pytest.approx(float(ref), rel=1e-13)
    sep = QuadraturePropagator(H, [0.0, 2.0], angle_period=2 * np.pi)
    assert sep.kind == "separatrix"
    assert {round(abs(s.y[0]) / np.pi) for s in sep.saddles} == {1} and all(s.kind == "saddle" for s in sep.saddles)


def test_callable_system_without_a_hessian():
    """The finite-difference Hessian is used only to find critical points and scale steps."""
    H = CanonicalSystem(
        n=1,
        name="pendulum",
        _hamiltonian=lambda y: y[..., 1] ** 2 / 2 - np.cos(y[..., 0]),
        _gradient=lambda y: np.stack([np.sin(y[..., 0]), y[..., 1]], -1),
    )
    orbit = QuadraturePropagator(H, [1.0, 0.0])
    assert orbit.period == pytest.approx(4 * ellipk(math.sin(0.5) ** 2), rel=1e-13)


# -- integrals along the orbit, phi and the attitude ------------------------------------------------------
def test_integral_along_the_orbit():
    H = free_body_h((1, 2, 3), 1.0)
    for y0, turns in (([0.4, 0.3], 0), ([0.4, 0.9], -1)):
        orbit = QuadraturePropagator(H, y0, L_bounds=(-1, 1))
        ldot = orbit.integral(lambda y: H.vector_field(y)[:, 0])  # int l' dt = l(t) - l0
        assert ldot.per_period == pytest.approx(2 * np.pi * turns, abs=1e-11)
        t = np.array([0.3, 7.0, 1234.5])
        np.testing.assert_allclose(ldot(t), orbit.state(t)[:, 0] - y0[0], atol=1e-9)
        both = orbit.integral(lambda y: np.stack([np.ones(len(y)), y[:, 1] ** 2], -1))
        np.testing.assert_allclose(both(t)[:, 0], t, rtol=1e-12)
        assert both.mean_rate[0] == pytest.approx(1.0, rel=1e-13)


@pytest.mark.parametrize("system", ["closed loop", "free body"])
def test_phi_and_attitude_against_the_atlas(system):
    if system == "closed loop":
        sys, m0 = closed_loop(), CHART.inverse([0.3, 0.2], 1.0)
    else:
        sys, m0 = RigidBody([1.0, 2.0, 3.0]), np.array([0.5, 0.3, 0.7])  # a rotation in l, |L|/G < 0.9
    sa = GeneralizedSerretAndoyer(sys)
    R0 = so3.exp(np.array([0.3, -0.7, 0.2]))
    prop = SerretAndoyerPropagator(sa, m0, R0=R0)
    assert prop.axis == 2
    t = np.linspace(0.0, 1.6 * prop.period, 25)
    ref = atlas(sys, m0, t, R0=R0)
    assert np.all((ref.chart_axis - 1) == 2)
    np.testing.assert_allclose(prop.phi(t), ref.serret_andoyer[:, 2], atol=1e-9)
    np.testing.assert_allclose(prop.attitude(t), ref.R, atol=1e-9)
    np.testing.assert_allclose(prop.momentum(t), ref.m, atol=1e-10)
    # the spatial momentum R m is conserved (a check that does not go through the reduction)
    p = np.einsum("...ij,...j->...i", prop.attitude(t), prop.momentum(t))
    np.testing.assert_allclose(p, np.broadcast_to(R0 @ m0, p.shape), atol=1e-12)


def test_attitude_at_large_times_and_phi_per_period():
    body = RigidBody([1.0, 2.0, 3.0])
    m0 = np.array([0.9, 0.2, 0.3])
    prop = SerretAndoyerPropagator(body, m0)
    T = prop.period
    # phi advances by the same angle every period of (l, L)
    assert prop.phi(5 * T) - prop.phi(4 * T) == pytest.approx(prop.phi_per_period, abs=1e-10)
    R = prop.attitude(np.array([1e3, 1e3 + T]))
    # after one period m returns, so R(t + T) R(t)^T fixes p: a rotation about p by phi_per_period
    p_hat = prop.p / np.linalg.norm(prop.p)
    np.testing.assert_allclose(R[1], so3.exp(prop.phi_per_period * p_hat) @ R[0], atol=1e-9)


def test_steady_spin_attitude_is_a_rotation_about_the_axis():
    """m0 = G e1 is an equilibrium; R(t) = R0 Rx(G t / I1) exactly."""
    body = RigidBody([1.0, 2.0, 3.0])
    G = 1.3
    R0 = so3.exp(np.array([0.1, 0.2, -0.4]))
    prop = SerretAndoyerPropagator(body, [G, 0.0, 0.0], R0=R0)
    assert prop.kind == "equilibrium" and prop.orbit.equilibrium.kind == "center"
    t = np.array([0.0, 2.0, 1e4])
    np.testing.assert_allclose(prop.attitude(t), R0 @ so3.rot_x(G * t / 1.0), atol=1e-10)


def test_automatic_chart_choice_avoids_the_poles():
    """Near a steady spin about axis 3, the axis-3 chart sees a thin rotation close to its pole; another chart
    sees a small libration about its equator."""
    body = RigidBody([1.0, 2.0, 3.0])
    m0 = np.array([0.05, 0.08, 1.0])
    prop = SerretAndoyerPropagator(body, m0)
    assert prop.axis != 2 and prop.pole_ratio < 0.2
    pinned = SerretAndoyerPropagator(body, m0, axis=2)
    assert pinned.pole_ratio > 0.99
    exact = body.exact_solution(m0)
    t = np.array([0.5, 40.0, 3e3])
    for p in (prop, pinned):
        np.testing.assert_allclose(p.momentum(t), exact.momentum(t), atol=1e-10)
        assert p.period == pytest.approx(exact.period, rel=1e-11)


def test_orbit_through_a_pole_of_the_chart():
    """A Hamiltonian whose poles are not equilibria: the orbit crosses the axis-3 pole, so the axis-3 chart
    fails loudly and the automatic choice takes another; the attitude matches the atlas."""
    m1, m2, m3 = sp.symbols("m1 m2 m3", real=True)
    sys = LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + sp.Rational(1, 10) * m3**4 + m1)
    through_pole = solve_ivp(lambda _t, m: sys.euler_vector_field(m), (0, 0.7), [0, 0, 1.0], rtol=1e-12, atol=1e-13)
    m0 = through_pole.y[:, -1]
    with pytest.raises(SingularityError, match="pole"):
        SerretAndoyerPropagator(sys, m0, axis=2)
    prop = SerretAndoyerPropagator(sys, m0)
    assert prop.axis != 2
    t = np.linspace(0, 1.2 * prop.period, 12)
    ref = atlas(sys, m0, t)
    np.testing.assert_allclose(prop.attitude(t), ref.R, atol=1e-9)


def test_from_reduced_starts_at_l0_L0_with_phi0_zero():
    prop = SerretAndoyerPropagator.from_reduced(closed_loop(), [0.3, 0.2], 1.0)
    np.testing.assert_allclose(prop.state(0.0), [0.3, 0.2], atol=1e-15)
    assert abs(prop.phi(0.0)) < 1e-14


# -- separatrices, equilibria and conditioning ----------------------------------------------------------
def test_separatrix_of_the_free_body_is_detected_with_its_saddles():
    """m0 on the separatrix of I = (1, 2, 3): m1^2/2 = m3^2/6 (|m|^2 = 2 E I2)."""
    body = RigidBody([1.0, 2.0, 3.0])
    m0 = np.array([0.5, 0.0, np.sqrt(3) / 2])
    assert body.exact_solution(m0).family == "separatrix"
    orbit = QuadraturePropagator(
        GeneralizedSerretAndoyer(body).reduced_system(1.0), CHART.forward(m0), L_bounds=(-1, 1)
    )
    assert orbit.kind == "separatrix" and orbit.period == math.inf
    assert len(orbit.saddles) == 2
    for s in orbit.saddles:  # m = +-G e2, the intermediate axis: (l, L) = (0 or pi, 0)
        assert s.kind == "saddle" and s.energy == pytest.approx(0.25, rel=1e-14)
        np.testing.assert_allclose(np.cos(s.y[0]) ** 2, 1.0, atol=1e-12)
        assert abs(s.y[1]) < 1e-12
        # linearised rate at the intermediate axis: G sqrt((1/I1 - 1/I2)(1/I2 - 1/I3))
        assert s.rate == pytest.approx(np.sqrt((1 - 1 / 2) * (1 / 2 - 1 / 3)), rel=1e-10)
    with pytest.raises(SingularityError, match="separatrix"):
        orbit.state(1.0)
    with pytest.raises(SingularityError, match="separatrix"):
        SerretAndoyerPropagator(body, m0, axis=2).phi(1.0)


@pytest.mark.parametrize(("m0", "kind"), [((0.0, 1.0, 0.0), "saddle"), ((1.0, 0.0, 0.0), "center")])
def test_equilibria_of_the_free_body(m0, kind):
    body = RigidBody([1.0, 2.0, 3.0])
    orbit = QuadraturePropagator(
        GeneralizedSerretAndoyer(body).reduced_system(1.0), CHART.forward(m0), L_bounds=(-1, 1)
    )
    assert orbit.kind == "equilibrium" and orbit.equilibrium.kind == kind
    np.testing.assert_allclose(orbit.state([0.0, 1e5]), [CHART.forward(m0)] * 2)
    if kind == "center":  # the classical small-oscillation frequency about the minor axis
        assert orbit.equilibrium.rate == pytest.approx(np.sqrt((1 - 1 / 2) * (1 - 1 / 3)), rel=1e-12)
        small = body.exact_solution(np.array([1.0, 1e-3, 0.0]))
        assert 2 * np.pi / orbit.equilibrium.rate == pytest.approx(small.period, rel=1e-6)


def test_near_a_centre_the_accuracy_limit_is_reported_not_hidden():
    """At amplitude 1e-5, E - E_c ~ 1e-11: H in double precision fixes the curve to ~1e-6 relative."""
    body = RigidBody([1.0, 2.0, 3.0])
    m0 = np.array([1.0, 1e-5, 0.0])
    G = float(np.linalg.norm(m0))
    h = GeneralizedSerretAndoyer(body).reduced_system(G)
    with pytest.raises(ConvergenceError, match="resolved only"):
        QuadraturePropagator(h, CHART.forward(m0), L_bounds=(-G, G))
    orbit = QuadraturePropagator(h, CHART.forward(m0), L_bounds=(-G, G), tol=1e-5)
    exact = body.exact_solution(m0).period
    assert abs(orbit.period - exact) <= max(orbit.period_error, 1e-12 * exact) * 10
    assert orbit.period_error > 1e-9 * exact  # it does say that the period is not good to 1e-12


# -- bad input ---------------------------------------------------------------------------------------------
def test_bad_input():
    H = free_body_h((1, 2, 3), 1.0)
    two = CanonicalSystem.from_expression(p_**2 + l_**2 + L_**2, [q_, l_], [p_, L_])
    with pytest.raises(InputError, match="one degree of freedom"):
        QuadraturePropagator(two, [0.1, 0.2, 0.3, 0.4])
    with pytest.raises(InputError, match="one degree of freedom"):
        QuadraturePropagator(RigidBody([1, 2, 3]), [0.1, 0.2])
    with pytest.raises(ShapeError, match="y0"):
        QuadraturePropagator(H, [0.1, 0.2, 0.3])
    with pytest.raises(InputError, match="inside `L_bounds`"):
        QuadraturePropagator(H, [0.1, 1.5], L_bounds=(-1, 1))
    with pytest.raises(InputError, match="L_bounds"):
        QuadraturePropagator(H, [0.1, 0.2], L_bounds=(1, -1))
    with pytest.raises(InputError, match="tol"):
        QuadraturePropagator(H, [0.1, 0.2], tol=1e-20)
    with pytest.raises(InputError, match="angle_period"):
        QuadraturePropagator(H, [0.1, 0.2], angle_period=-1.0)
    with pytest.raises(InputError, match="finite"):
        QuadraturePropagator(H, [np.nan, 0.2])
    log = CanonicalSystem.from_expression(sp.log(L_) + sp.cos(l_), [l_], [L_], angle_coordinates=(0,))
    with pytest.raises(InputError, match="finite at `y0`"):
        QuadraturePropagator(log, [0.1, -0.5])
    with pytest.raises(SingularityError, match="leaves the domain"):
        QuadraturePropagator(H, [0.4, 0.9], L_bounds=(-0.92, 0.92))  # the orbit reaches L = 0.9097
    orbit = QuadraturePropagator(H, [0.4, 0.3], L_bounds=(-1, 1))
    with pytest.raises(InputError, match="`t`"):
        orbit.state([0.0, np.inf])
    with pytest.raises(InputError, match="phase"):
        orbit.state(1e20)
    with pytest.raises(InputError, match="callable"):
        orbit.integral(3.0)
    with pytest.raises(InputError, match="axis"):
        SerretAndoyerPropagator(RigidBody([1, 2, 3]), [0.1, 0.2, 0.3], axis=3)
    with pytest.raises(InputError, match="nonzero"):
        SerretAndoyerPropagator(RigidBody([1, 2, 3]), [0.0, 0.0, 0.0])
    with pytest.raises(SingularityError, match="pole"):
        SerretAndoyerPropagator(RigidBody([1, 2, 3]), [0.0, 0.0, 1.0], axis=2)
