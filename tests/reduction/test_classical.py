"""The classical Serret-Andoyer transformation (section 3): symplecticity, geometry, round trips,
eq. (10) and the period of l from the quadrature eq. (11) against the exact elliptic period and a direct
integration of Euler's equations."""

import math

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from geomech.errors import InputError, ShapeError, SingularityError
from geomech.lie import so3
from geomech.reduction.classical import (
    ClassicalSerretAndoyer,
    andoyer_hamiltonian,
    momentum_l,
    period_of_l,
    period_of_l_from_momentum,
    reduced_hamiltonian,
    reduced_vector_field,
)
from geomech.reduction.euler_coordinates import EulerCoordinates
from geomech.systems import RigidBody
from geomech.systems._euler_top import EulerTopSolution

SA = ClassicalSerretAndoyer()
ANGLES = [0, 1, 2]  # angle components of both (phi, theta, psi, ...) and (l, g, h, ...)


def wrap(x):
    return np.remainder(x + np.pi, 2 * np.pi) - np.pi


def _jacobian(f, x, angle_out, h=1e-3):
    """Five-point central differences; output angle components are unwrapped."""
    y0 = f(x)
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        ys = []
        for k in (2, 1, -1, -2):
            y = f(x + k * e)
            y[angle_out] = y0[angle_out] + wrap(y[angle_out] - y0[angle_out])
            ys.append(y)
        cols.append((-ys[0] + 8 * ys[1] - 8 * ys[2] + ys[3]) / (12 * h))
    return np.stack(cols, -1)


def random_sa(rng, n):
    G = rng.uniform(0.5, 3.0, n)
    return np.column_stack(
        [
            rng.uniform(-3, 3, n),
            rng.uniform(-3, 3, n),
            rng.uniform(-3, 3, n),
            G * rng.uniform(-0.9, 0.9, n),
            G,
            G * rng.uniform(-0.9, 0.9, n),
        ]
    )


def random_body(rng):
    return so3.exp(rng.normal(size=3)), rng.normal(size=3)


# -- canonicity ---------------------------------------------------------------------------------------
def test_jacobian_is_symplectic(rng):
    """D^T Omega D = Omega for the map (phi, theta, psi, Phi, Theta, Psi) -> (l, g, h, L, G, H)."""
    Omega = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.eye(3), np.zeros((3, 3))]])
    ec = EulerCoordinates(RigidBody((3.0, 2.0, 1.0)))
    checked = 0
    while checked < 6:
        q = ec.forward(*random_body(rng))
        if np.sin(q[1]) < 0.2:
            continue
        D = _jacobian(SA.forward, q, ANGLES)
        assert np.allclose(D.T @ Omega @ D, Omega, atol=1e-8)
        # and not by accident: a non-canonical rescaling of L breaks it
        D2 = D.copy()
        D2[3] *= 1.1
        assert not np.allclose(D2.T @ Omega @ D2, Omega, atol=1e-3)
        checked += 1


# -- geometry and round trips ---------------------------------------------------------------------------
def test_to_body_is_eq20_and_the_section3_geometry(rng):
    sa = random_sa(rng, 30)
    l, g, h, L, G, H = sa.T
    R, m = SA.to_body(sa)
    s = np.sqrt(G**2 - L**2)
    assert np.allclose(m, np.column_stack([s * np.sin(l), s * np.cos(l), L]), atol=1e-13)
    sigma, beta = np.arccos(H / G), np.arccos(L / G)
    e3 = np.array([0.0, 0.0, 1.0])
    k = so3.rot_z(h) @ so3.rot_x(sigma) @ e3
    p = np.einsum("nij,nj->ni", R, m)
    assert np.allclose(p, G[:, None] * k, atol=1e-12)  # k = p / |p|
    i = so3.rot_z(h) @ np.array([1.0, 0.0, 0.0])
    assert np.allclose(np.einsum("ni,ni->n", i, p), 0, atol=1e-12)
    # the body frame from the intermediate frame by the 3-1-3 angles (g, beta, l)
    R_ref = so3.rot_z(h) @ so3.rot_x(sigma) @ so3.rot_z(g) @ so3.rot_x(beta) @ so3.rot_z(l)
    assert np.allclose(R, R_ref, atol=1e-13)


def test_forward_gives_G_norm_H_Phi_L_Psi(rng):
    ec = EulerCoordinates(RigidBody((3.0, 2.0, 1.0)))
    for _ in range(10):
        R, m = random_body(rng)
        q = ec.forward(R, m)
        sa = SA.forward(q)
        assert sa[4] == pytest.approx(np.linalg.norm(m), rel=1e-14)
        assert sa[5] == pytest.approx(q[3], abs=1e-13)  # H = p3 = Phi
        assert sa[3] == pytest.approx(q[5], abs=1e-13)  # L = m3 = Psi
        assert np.allclose(SA.from_body(R, m), sa, atol=1e-12)


@given(
    st.floats(-3.1, 3.1),
    st.floats(-3.1, 3.1),
    st.floats(-3.1, 3.1),
    st.floats(-0.999, 0.999),
    st.floats(0.1, 10.0),
    st.floats(-0.999, 0.999),
)
def test_round_trips(l, g, h, L_ratio, G, H_ratio):
    sa = np.array([l, g, h, L_ratio * G, G, H_ratio * G])
    R, m = SA.to_body(sa)
    back = SA.from_body(R, m)
    assert np.allclose(wrap(back[:3] - sa[:3]), 0, atol=1e-9)
    assert np.allclose(back[3:], sa[3:], atol=1e-12 * G)
    try:
        q = SA.inverse(sa)
    except SingularityError:  # the Euler chart's own gimbal lock (b3 = +-s3)
        return
    again = SA.forward(q)
    assert np.allclose(wrap(again[:3] - sa[:3]), 0, atol=1e-7)
    assert np.allclose(again[3:], sa[3:], atol=1e-9 * G)


def test_batches(rng):
    sa = random_sa(rng, 12).reshape(3, 4, 6)
    R, m = SA.to_body(sa)
    assert R.shape == (3, 4, 3, 3) and m.shape == (3, 4, 3)
    assert SA.from_body(R, m).shape == (3, 4, 6)


# -- singularities and bad input ------------------------------------------------------------------------
def test_poles_raise_singularity_errors_naming_the_angle():
    R = so3.rot_x(0.7)
    with pytest.raises(SingularityError, match="sigma"):
        SA.from_body(R, R.T @ [0.0, 0.0, -2.0])  # p along -s3, m not along b3
    with pytest.raises(SingularityError, match="beta"):
        SA.from_body(R, [0.0, 0.0, -1.5])  # m along -b3, p not along s3
    with pytest.raises(SingularityError, match="m = 0"):
        SA.from_body(R, [0.0, 0.0, 0.0])
    with pytest.raises(SingularityError, match="beta"):
        SA.to_body([0.1, 0.2, 0.3, 2.0, 2.0, 0.5])
    with pytest.raises(SingularityError, match="sigma"):
        SA.to_body([0.1, 0.2, 0.3, 0.5, 2.0, -2.0])
    with pytest.raises(InputError, match=r"\|L\| <= G"):
        SA.to_body([0.1, 0.2, 0.3, 2.5, 2.0, 0.5])
    with pytest.raises(InputError, match="G"):
        SA.to_body([0.1, 0.2, 0.3, 0.0, -1.0, 0.0])
    with pytest.raises(InputError, match="finite"):
        SA.forward([0.1, np.nan, 0.3, 0.0, 1.0, 0.0])
    with pytest.raises(ShapeError):
        SA.to_body(np.zeros((2, 5)))
    with pytest.raises(SingularityError, match="theta = 0 or pi"):
        SA.forward([0.1, 0.0, 0.3, 0.0, 1.0, 0.0])


# -- eq. 10 and the reduced flow ------------------------------------------------------------------------
def test_eq10_is_the_free_body_hamiltonian_through_the_transformation_symbolically():
    l, g, h, L, G, _H = SA.symbols
    I1, I2, I3 = sp.symbols("I1 I2 I3", positive=True)
    cs, ss, cb, sb = sp.symbols("cos_sigma sin_sigma cos_beta sin_beta", real=True)

    def rz(a):
        return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])

    def rx(c, s):
        return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])

    pythagoras = {sp.cos(a) ** 2: 1 - sp.sin(a) ** 2 for a in (l, g, h)} | {cs**2: 1 - ss**2, cb**2: 1 - sb**2}

    def reduce(e):
        return sp.expand(sp.expand(e).subs(pythagoras))

    R = rz(h) * rx(cs, ss) * rz(g) * rx(cb, sb) * rz(l)
    k = rz(h) * rx(cs, ss) * sp.Matrix([0, 0, 1])
    m = (R.T * (G * k)).applyfunc(reduce)  # m = R^T p with p = G k
    H_free = reduce(m[0] ** 2 / (2 * I1) + m[1] ** 2 / (2 * I2) + m[2] ** 2 / (2 * I3))
    on_chart = {cb: L / G, sb: sp.sqrt(G**2 - L**2) / G}
    assert sp.simplify(H_free.subs(on_chart) - andoyer_hamiltonian()) == 0
    assert sp.simplify(m[2].subs(on_chart) - L) == 0


def test_eq10_at_random_points_and_the_reduced_flow_is_eulers_equation(rng):
    for inertia in [(3.0, 2.0, 1.0), (1.0, 2.5, 2.0), (1.2, 1.2, 2.0)]:
        body = RigidBody(inertia)
        sa = random_sa(rng, 20)
        _, m = SA.to_body(sa)
        l, L, G = sa[:, 0], sa[:, 3], sa[:, 4]
        assert np.allclose(reduced_hamiltonian(l, L, G, inertia), body.system.hamiltonian(m), rtol=1e-13)
        # d/dt m(l, L; G) along (l', L') of eq. 10 must be m x grad H
        ldot, Ldot = reduced_vector_field(l, L, G, inertia).T
        s = np.sqrt(G**2 - L**2)
        dm_dl = np.column_stack([s * np.cos(l), -s * np.sin(l), 0 * l])
        dm_dL = np.column_stack([-L / s * np.sin(l), -L / s * np.cos(l), 1 + 0 * l])
        mdot = dm_dl * ldot[:, None] + dm_dL * Ldot[:, None]
        assert np.allclose(mdot, body.system.euler_vector_field(m), atol=1e-12)


def test_eq11b_needs_the_sign_of_L(rng):
    inertia = (3.0, 2.0, 1.0)
    for m in ([0.4, -1.0, -0.8], [1.0, 0.3, 0.6]):
        m = np.array(m)
        G, E = np.linalg.norm(m), RigidBody(inertia).system.hamiltonian(m)
        l0 = math.atan2(m[0], m[1])
        L = momentum_l(l0, G, E, inertia, sign=np.sign(m[2]))
        assert L == pytest.approx(m[2], rel=1e-13)
        printed = momentum_l(l0, G, E, inertia, sign=1.0)  # eq. 11b as printed: the positive root
        assert (printed == pytest.approx(m[2], rel=1e-6)) == (m[2] > 0)


# -- eq. 11: the period of l ----------------------------------------------------------------------------
def euler_period_check(inertia, m0, T):
    """m(T) = m0 by direct integration, and m does not come back to m0 at T/2 (least period)."""
    I = np.array(inertia)
    sol = solve_ivp(
        lambda t, m: np.cross(m, m / I), (0, T), m0, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=[T / 2, T]
    )
    return np.abs(sol.y[:, -1] - m0).max(), np.abs(sol.y[:, 0] - m0).max()


CASES = [
    # (inertia, m0, kind)
    ((3.0, 2.0, 1.0), [0.3, 0.4, 1.0], "circulating"),  # round axis 3 (smallest I)
    ((3.0, 2.0, 1.0), [1.0, 0.4, 0.3], "librating"),  # round axis 1 (largest I)
    ((3.0, 2.0, 1.0), [1.0, 1e-4, 1e-4], "librating"),  # small libration near the stable spin
    ((1.0, 3.0, 2.0), [0.2, 0.3, 1.0], "librating"),  # axis 3 intermediate: l never circulates
    ((1.0, 3.0, 2.0), [0.9, 0.2, -0.3], "librating"),
    ((1.0, 2.0, 3.0), [0.2, -0.3, -1.0], "circulating"),  # axis 3 largest
    ((2.0, 1.0, 3.0), [0.1, 1.0, 0.4], "librating"),  # round axis 2 (smallest I)
    ((2.0, 3.0, 1.5), [0.5, -0.4, 1.0], "circulating"),  # near-separatrix-free generic ordering
    ((2.0, 2.0, 1.0), [0.5, -0.4, 1.0], "circulating"),  # axisymmetric: l' constant
]


@pytest.mark.parametrize("inertia, m0, kind", CASES)
def test_period_of_l_is_the_exact_period(inertia, m0, kind):
    m0 = np.array(m0)
    G = np.linalg.norm(m0)
    E = RigidBody(inertia).system.hamiltonian(m0)
    l0 = math.atan2(m0[0], m0[1])
    res = period_of_l(inertia, G, E, l0=l0)
    assert res.kind == kind
    exact = EulerTopSolution.from_initial(inertia, m0).period
    assert res.period == pytest.approx(exact, rel=1e-10)
    back, half = euler_period_check(inertia, m0, res.period)
    assert back < 1e-9 * G and half > 1e3 * back
    res2 = period_of_l_from_momentum(inertia, m0)
    assert res2.period == pytest.approx(res.period, rel=1e-12) and res2.kind == kind
    assert res2.turning_points == pytest.approx(res.turning_points) if res.turning_points else True
    if kind == "librating":
        lo, hi = res.turning_points
        assert lo <= l0 <= hi
        for lt in (lo, hi):  # L = 0 at the turning points: a(l) = A
            a = math.sin(lt) ** 2 / inertia[0] + math.cos(lt) ** 2 / inertia[1]
            assert a == pytest.approx(res.A, rel=1e-13)
    else:
        assert res.turning_points is None


def test_period_of_l_near_the_separatrix_is_finite_and_matches(rng):
    inertia = (3.0, 2.0, 1.0)
    for eps, kind in ((1e-3, "circulating"), (1e-7, "circulating"), (-1e-6, "librating")):
        # near the unstable spin about axis 2; A - 1/I2 = eps^2/3 (and eps m3 -> -eps m3 swaps sides)
        m0 = np.array([abs(eps), 1.0, eps]) if eps > 0 else np.array([3 * abs(eps), 1.0, abs(eps)])
        res = period_of_l_from_momentum(inertia, m0)
        assert np.isfinite(res.period) and res.kind == kind
        assert res.period == pytest.approx(EulerTopSolution.from_initial(inertia, m0).period, rel=1e-10)


def test_period_of_l_reports_separatrix_steady_spin_and_bad_input():
    inertia = (3.0, 2.0, 1.0)
    with pytest.raises(SingularityError, match="separatrix"):
        period_of_l(inertia, 2.0, 0.5 * 4.0 / 2.0)  # A = 1/I2
    with pytest.raises(SingularityError, match="separatrix"):
        period_of_l((1.0, 3.0, 2.0), 1.0, 0.5 / 2.0)  # A = 1/I3, axis 3 intermediate
    with pytest.raises(InputError, match="steady spin"):
        period_of_l(inertia, 2.0, 0.5 * 4.0 / 3.0)  # A = 1/I1, the minimum
    with pytest.raises(InputError, match="steady spin"):
        period_of_l(inertia, 2.0, 0.5 * 4.0 / 1.0)  # A = 1/I3, L = +-G
    with pytest.raises(InputError, match="No motion"):
        period_of_l(inertia, 2.0, 5.0)
    with pytest.raises(InputError, match="positive"):
        period_of_l(inertia, -1.0, 1.0)
    with pytest.raises(InputError, match="positive"):
        period_of_l((3.0, -2.0, 1.0), 1.0, 0.3)
    with pytest.raises(InputError, match="finite"):
        period_of_l(inertia, 1.0, np.nan)
    with pytest.raises(InputError, match="l0"):
        # librating about l = pi/2 (round axis 1): l0 = 0 is not on the level
        period_of_l(inertia, 1.0, 0.5 * (0.9 / 3.0 + 0.1 / 2.0), l0=0.0)
    with pytest.raises(InputError, match="shape"):
        period_of_l((3.0, 2.0), 1.0, 0.3)
