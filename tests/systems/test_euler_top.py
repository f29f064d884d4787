"""Tests of the exact free-rigid-body solution ``geomech.systems._euler_top.EulerTopSolution``.

The references are independent of the code under test: Euler's equations themselves (by an
8th-order central difference), scipy's DOP853, hand-computed classifications, mpmath's Jacobi
functions at high precision, and a sympy check of the derivation.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.special import ellipkm1

from geomech.errors import InputError, NumericalError, ShapeError
from geomech.systems._euler_top import EulerTopSolution, _jacobi

ORDERS = list(itertools.permutations(range(3)))
# 8th-order central difference for f'(t): offsets -4..4.
_FD = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])


# -- independent references -----------------------------------------------------------------------
def euler_rhs(m, inertia):
    """Euler's equations m' = m x (m / I), written out (not the code under test).

    1/I3 - 1/I2 is formed as (I2 - I3) / (I2 I3): the difference of two rounded reciprocals would lose
    all its digits for nearly equal moments.
    """
    I1, I2, I3 = inertia
    m = np.asarray(m)
    m1, m2, m3 = m[..., 0], m[..., 1], m[..., 2]
    c1, c2, c3 = (I2 - I3) / (I2 * I3), (I3 - I1) / (I3 * I1), (I1 - I2) / (I1 * I2)
    return np.stack([m2 * m3 * c1, m3 * m1 * c2, m1 * m2 * c3], axis=-1)


def dop853(inertia, m0, t):
    """m(t) by DOP853 at rtol = atol = 1e-12 (scaled to |m0| = 1), integrating from 0 to each sign of t."""
    mu = float(np.linalg.norm(m0))
    I1, I2, I3 = inertia
    c1, c2, c3 = mu * (I2 - I3) / (I2 * I3), mu * (I3 - I1) / (I3 * I1), mu * (I1 - I2) / (I1 * I2)

    def f(_, y):
        return [y[1] * y[2] * c1, y[2] * y[0] * c2, y[0] * y[1] * c3]

    t = np.asarray(t, dtype=float)
    out = np.empty(t.shape + (3,))
    for sel in (t >= 0, t < 0):
        if not sel.any():
            continue
        ts = t[sel]
        order = np.argsort(np.abs(ts))
        span = (0.0, float(ts[order[-1]]))
        sol = solve_ivp(f, span, np.asarray(m0) / mu, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=ts[order])
        assert sol.success, sol.message
        y = np.empty((ts.size, 3))
        y[order] = sol.y.T
        out[sel] = mu * y
    return out


def fd_residual(sol, t):
    """max |d/dt momentum - euler_rhs| over t, relative to the scale |m|^2 (1/I_min - 1/I_max) of m'."""
    inertia = np.asarray(sol.inertia)
    mu = math.sqrt(sol.casimir)
    scale = mu * (1 / inertia.min() - 1 / inertia.max())
    h = 2e-3 / scale
    ms = sol.momentum(np.asarray(t)[:, None] + h * np.arange(-4, 5))
    deriv = np.einsum("k,tkj->tj", _FD, ms) / h
    return np.abs(deriv - euler_rhs(ms[:, 4], inertia)).max() / (mu * scale)


def family_by_hand(inertia, m):
    """'major' iff |m|^2 > 2 E I_mid, 'minor' iff <, for a triaxial body."""
    I_mid = sorted(inertia)[1]
    two_e = sum(mi * mi / Ii for mi, Ii in zip(m, inertia))
    g = float(np.dot(m, m)) - two_e * I_mid
    return "major" if g > 0 else "minor"


def period_by_hand(inertia, m0):
    """4 K(k) / rate from Landau-Lifshitz (37.10)-(37.11), in 50-digit arithmetic from the float data.

    With I1 < I2 < I3: about I3 (M^2 > 2 E I2), k'^2 = (I3 - I1)(M^2 - 2 E I2) / ((I3 - I2)(M^2 - 2 E I1))
    and rate^2 = (I3 - I2)(M^2 - 2 E I1) / (I1 I2 I3); about I1, exchange I1 and I3.
    """
    with mpmath.workdps(50):
        order = np.argsort(inertia)
        I1, I2, I3 = (mpmath.mpf(float(inertia[i])) for i in order)
        m = [mpmath.mpf(float(m0[i])) for i in order]
        M2 = sum(x * x for x in m)
        twoE = m[0] ** 2 / I1 + m[1] ** 2 / I2 + m[2] ** 2 / I3
        if M2 < twoE * I2:
            I1, I3 = I3, I1
        kp2 = (I3 - I1) * (M2 - twoE * I2) / ((I3 - I2) * (M2 - twoE * I1))
        rate = mpmath.sqrt((I3 - I2) * (M2 - twoE * I1) / (I1 * I2 * I3))
        return float(4 * mpmath.ellipk(1 - kp2) / rate)


def random_body(rng, gap=0.05):
    while True:
        a, b, c = np.sort(rng.uniform(0.5, 3.0, 3))
        if c <= a + b and min(b - a, c - b) >= gap * c:
            return np.array([a, b, c])


def random_case(rng, order, family, margin=0.03):
    """Moments in the given order and an m0 of the given family, away from the separatrix."""
    inertia = random_body(rng)[list(order)]
    I_mid = np.sort(inertia)[1]
    while True:
        m0 = rng.normal(size=3) * rng.uniform(0.3, 3.0)
        g = m0 @ m0 - np.sum(m0**2 / inertia) * I_mid
        if family_by_hand(inertia, m0) == family and abs(g) > margin * (m0 @ m0):
            return inertia, m0


def separatrix_point(inertia, x=0.6, y=0.7, signs=(1, 1)):
    """m0 with m_max^2 (I_max - I_mid) / I_max = m_min^2 (I_mid - I_min) / I_min, i.e. 2 E I_mid = |m|^2."""
    i_min, i_mid, i_max = np.argsort(inertia)
    Imin, Imid, Imax = inertia[i_min], inertia[i_mid], inertia[i_max]
    m0 = np.zeros(3)
    m0[i_min] = signs[0] * x
    m0[i_max] = signs[1] * x * math.sqrt((Imid - Imin) * Imax / (Imin * (Imax - Imid)))
    m0[i_mid] = y
    return m0


# -- classification ---------------------------------------------------------------------------------
def test_hand_computed_classification():
    # I = (3, 2, 1), m0 = (1, 0.3, 0.2): |m|^2 = 1.13, 2E = 1/3 + 0.045 + 0.04 = 0.41833...,
    # 2 E I_mid = 0.83667 < |m|^2: low energy, circulation about axis 0 (I = 3, the largest).
    s = EulerTopSolution.from_initial([3.0, 2.0, 1.0], [1.0, 0.3, 0.2])
    assert s.family == "major"
    assert s.casimir == pytest.approx(1.13, rel=1e-15)
    assert s.energy == pytest.approx(0.5 * (1 / 3 + 0.045 + 0.04), rel=1e-15)
    # m0 = (0.1, 0.3, 1.0): |m|^2 = 1.1, 2E = 0.00333 + 0.045 + 1 = 1.04833, 2 E I_mid = 2.0967 > 1.1:
    # circulation about axis 2 (I = 1, the smallest).
    s = EulerTopSolution.from_initial([3.0, 2.0, 1.0], [0.1, 0.3, 1.0])
    assert s.family == "minor"
    assert s.energy == pytest.approx(0.5 * (0.1**2 / 3 + 0.045 + 1.0), rel=1e-15)
    # The same two bodies with the axes listed in another order classify the same way.
    assert EulerTopSolution.from_initial([1.0, 3.0, 2.0], [0.2, 1.0, 0.3]).family == "major"
    assert EulerTopSolution.from_initial([2.0, 1.0, 3.0], [0.3, 1.0, 0.1]).family == "minor"
    # I = (1, 2, 3), m0 = (1, 1, 1): |m|^2 = 3, 2E = 1 + 1/2 + 1/3 = 11/6, 2 E I_mid = 11/3 > 3.
    assert EulerTopSolution.from_initial([1.0, 2.0, 3.0], [1.0, 1.0, 1.0]).family == "minor"


@pytest.mark.parametrize("order", ORDERS)
def test_classification_matches_energy_inequality(order):
    rng = np.random.default_rng(sum(order) * 7 + order[0])
    for _ in range(40):
        inertia = random_body(rng)[list(order)]
        m0 = rng.normal(size=3)
        assert EulerTopSolution.from_initial(inertia, m0).family == family_by_hand(inertia, m0)


def test_elliptic_constants_against_landau_lifshitz():
    # L&L eq. (37.10)-(37.11) for I1 < I2 < I3 and M^2 > 2 E I2 (circulation about axis 3):
    # k^2 = (I2 - I1)(2 E I3 - M^2) / ((I3 - I2)(M^2 - 2 E I1)),
    # rate = sqrt((I3 - I2)(M^2 - 2 E I1) / (I1 I2 I3)).
    I1, I2, I3 = 1.0, 2.0, 3.0
    m0 = np.array([0.2, 0.3, 1.0])
    M2, twoE = m0 @ m0, np.sum(m0**2 / [I1, I2, I3])
    s = EulerTopSolution.from_initial([I1, I2, I3], m0)
    assert s.family == "major"
    assert s.k**2 == pytest.approx((I2 - I1) * (twoE * I3 - M2) / ((I3 - I2) * (M2 - twoE * I1)), rel=1e-13)
    assert s.rate == pytest.approx(math.sqrt((I3 - I2) * (M2 - twoE * I1) / (I1 * I2 * I3)), rel=1e-13)
    assert s.period == pytest.approx(4 * float(ellipkm1(1 - s.k**2)) / s.rate, rel=1e-13)


# -- elliptic families ------------------------------------------------------------------------------
@pytest.mark.parametrize("family", ["major", "minor"])
@pytest.mark.parametrize("order", ORDERS)
def test_satisfies_euler_equations(order, family):
    rng = np.random.default_rng(100 + 10 * order[0] + order[1] + (family == "major"))
    for _ in range(4):
        inertia, m0 = random_case(rng, order, family, margin=0.0)
        s = EulerTopSolution.from_initial(inertia, m0)
        assert s.family == family
        t = np.linspace(-1.3, 1.7, 40) * s.period
        assert fd_residual(s, t) < 1e-7


@pytest.mark.parametrize("family", ["major", "minor"])
@pytest.mark.parametrize("order", ORDERS)
def test_matches_dop853_over_five_periods(order, family):
    rng = np.random.default_rng(200 + 10 * order[0] + order[1] + (family == "major"))
    inertia, m0 = random_case(rng, order, family)
    s = EulerTopSolution.from_initial(inertia, m0)
    t = np.linspace(-5.0, 5.0, 81) * s.period  # also backwards in time
    err = np.abs(s.momentum(t) - dop853(inertia, m0, t)).max()
    assert err < 1e-9 * np.linalg.norm(m0)


@pytest.mark.parametrize("family", ["major", "minor"])
@pytest.mark.parametrize("order", ORDERS)
def test_initial_value_period_and_invariants(order, family):
    rng = np.random.default_rng(300 + 10 * order[0] + order[1] + (family == "major"))
    for _ in range(5):
        inertia, m0 = random_case(rng, order, family, margin=0.0)
        s = EulerTopSolution.from_initial(inertia, m0)
        mu = np.linalg.norm(m0)
        assert np.abs(s.momentum(0.0) - m0).max() < 1e-13 * mu
        assert np.abs(s.momentum(s.period) - m0).max() < 1e-10 * mu
        assert np.abs(s.momentum(-3 * s.period) - m0).max() < 1e-10 * mu
        # Not periodic with half the period: `period` is the least period.
        assert np.abs(s.momentum(0.5 * s.period) - m0).max() > 1e-3 * mu
        m = s.momentum(np.linspace(-2, 2, 201) * s.period)
        assert np.abs(np.sum(m**2, -1) / s.casimir - 1).max() < 1e-12
        assert np.abs(0.5 * np.sum(m**2 / inertia, -1) / s.energy - 1).max() < 1e-12


@pytest.mark.parametrize("family", ["major", "minor"])
@pytest.mark.parametrize("order", [(0, 1, 2), (2, 1, 0), (1, 2, 0)])
def test_every_octant(order, family):
    # Flip the signs of one m0 in all 8 ways: momentum(0) must reproduce it and m(t) solve Euler.
    rng = np.random.default_rng(400 + order[0] + (family == "major"))
    inertia, base = random_case(rng, order, family)
    base = np.abs(base)
    for signs in itertools.product((1.0, -1.0), repeat=3):
        m0 = base * signs
        s = EulerTopSolution.from_initial(inertia, m0)
        assert np.abs(s.momentum(0.0) - m0).max() < 1e-13 * np.linalg.norm(m0)
        assert fd_residual(s, np.linspace(-1, 1, 17) * s.period) < 1e-7
        # The direction of motion at t = 0 is Euler's, in every octant and for backward time.
        h = 1e-6 / s.rate
        v = (s.momentum(h) - s.momentum(-h)) / (2 * h)
        np.testing.assert_allclose(v, euler_rhs(m0, inertia), rtol=1e-6, atol=1e-9 * s.casimir)


def test_momentum_shapes():
    s = EulerTopSolution.from_initial([1.0, 2.0, 3.0], [0.3, -0.4, 1.0])
    assert s.momentum(0.5).shape == (3,)
    t = np.linspace(0, 1, 10).reshape(2, 5)
    m = s.momentum(t)
    assert m.shape == (2, 5, 3)
    np.testing.assert_array_equal(m[1, 2], s.momentum(t[1, 2]))


def test_derivation_symbolically():
    """The documented working-frame formulas solve Euler's equations (sympy, both families)."""
    a, b, c, J1, A, B, mu = sp.symbols("a b c J1 A B mu", positive=True)
    S, Cn, D, Sh, Th = sp.symbols("S Cn D Sh Th")
    for J0, J2 in ((J1 + a, J1 - b), (J1 - a, J1 + b)):  # major, minor
        s0 = 1
        s2 = s0 * sp.sign(J2 - J0)
        rA = J0 * (J1 - J2) / (J1 * (J0 - J2))
        rB = J1 * (J2 - J0) / (J2 * (J1 - J0))
        C = B / sp.sqrt(rB)
        k2 = (B / A) ** 2 * rA
        lam = A / J0 * sp.sqrt((J0 - J1) * (J0 - J2) / (J1 * J2))
        w = [s0 * A * D, B * S, s2 * C * Cn]
        J = [J0, J1, J2]

        def ddt(f, lam=lam, k2=k2):  # sn' = cn dn, cn' = -sn dn, dn' = -k^2 sn cn; du/dt = lam
            return lam * (sp.diff(f, S) * Cn * D - sp.diff(f, Cn) * S * D - sp.diff(f, D) * k2 * S * Cn)

        for i in range(3):
            res = ddt(w[i]) - w[(i + 1) % 3] * w[(i + 2) % 3] * (1 / J[(i + 2) % 3] - 1 / J[(i + 1) % 3])
            assert sp.simplify(res) == 0
    # Separatrix, J0 > J1 > J2 > 0, all four sign quadrants; sech' = -sech tanh, tanh' = sech^2.
    J2, J1, J0 = c, c + b, c + b + a
    Ah = sp.sqrt(J0 * (J1 - J2) / (J1 * (J0 - J2)))
    Ch = sp.sqrt(J2 * (J0 - J1) / (J1 * (J0 - J2)))
    lam = mu / J1 * sp.sqrt((J0 - J1) * (J1 - J2) / (J0 * J2))
    assert sp.simplify(Ah**2 + Ch**2 - 1) == 0
    for s0, s2 in itertools.product((1, -1), repeat=2):
        w = [mu * s0 * Ah * Sh, -s0 * s2 * mu * Th, mu * s2 * Ch * Sh]
        J = [J0, J1, J2]
        for i in range(3):
            d = lam * (sp.diff(w[i], Th) * Sh**2 - sp.diff(w[i], Sh) * Sh * Th)
            res = d - w[(i + 1) % 3] * w[(i + 2) % 3] * (1 / J[(i + 2) % 3] - 1 / J[(i + 1) % 3])
            assert sp.simplify(res) == 0


# -- separatrix ---------------------------------------------------------------------------------
@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("signs", [(1, 1), (1, -1), (-1, 1), (-1, -1)])
def test_separatrix(order, signs):
    inertia = np.array([1.0, 2.0, 2.5])[list(order)]
    i_mid = int(np.argsort(inertia)[1])
    m0 = separatrix_point(inertia, signs=signs)
    s = EulerTopSolution.from_initial(inertia, m0)
    mu = np.linalg.norm(m0)
    assert s.family == "separatrix" and s.period == math.inf and s.k == 1.0
    assert np.abs(s.momentum(0.0) - m0).max() < 1e-13 * mu
    t = np.linspace(-6, 6, 49) / s.rate
    assert fd_residual(s, t) < 1e-7
    assert np.abs(s.momentum(t) - dop853(inertia, m0, t)).max() < 1e-9 * mu
    m = s.momentum(t)
    assert np.abs(np.sum(m**2, -1) / s.casimir - 1).max() < 1e-12
    assert np.abs(0.5 * np.sum(m**2 / inertia, -1) / s.energy - 1).max() < 1e-12
    # m_mid is monotone along a heteroclinic orbit: the sign of m_mid'(0) says which pole it reaches.
    pole = np.zeros(3)
    pole[i_mid] = math.copysign(mu, euler_rhs(m0, inertia)[i_mid])
    np.testing.assert_allclose(s.momentum(40 / s.rate), pole, atol=1e-12 * mu)
    np.testing.assert_allclose(s.momentum(-40 / s.rate), -pole, atol=1e-12 * mu)
    assert np.all(np.isfinite(s.momentum([-1e6 / s.rate, 1e6 / s.rate])))


def test_separatrix_recognised_within_rounding():
    # Separatrix points built in floating point miss 2 E I_mid = |m|^2 by a rounding error; they are still
    # classified "separatrix", while 1e-13 off is an elliptic orbit of the right family.
    rng = np.random.default_rng(7)
    for _ in range(30):
        inertia = random_body(rng)[list(ORDERS[rng.integers(6)])]
        m0 = separatrix_point(inertia, x=rng.uniform(0.1, 2), y=rng.uniform(-2, 2), signs=rng.choice([-1, 1], 2))
        assert EulerTopSolution.from_initial(inertia, m0).family == "separatrix"
        i_max = int(np.argmax(inertia))
        for eps, family in ((1e-13, "major"), (-1e-13, "minor")):
            m1 = m0.copy()
            m1[i_max] *= 1 + eps
            assert EulerTopSolution.from_initial(inertia, m1).family == family


def test_separatrix_rate_is_the_linearised_instability():
    # Linearising Euler's equations about the spin mu e_2 of I = (1, 2, 3) gives the growth rate
    # mu sqrt((1/I1 - 1/I2)(1/I2 - 1/I3)) = mu sqrt(1/2 * 1/6).
    inertia = np.array([1.0, 2.0, 3.0])
    m0 = separatrix_point(inertia, x=0.3, y=-0.9)
    s = EulerTopSolution.from_initial(inertia, m0)
    assert s.family == "separatrix"
    assert s.rate == pytest.approx(np.linalg.norm(m0) * math.sqrt(1 / 12), rel=1e-14)


# -- steady spins, axisymmetric and spherical bodies -----------------------------------------------
@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("rank", [0, 1, 2])  # smallest, intermediate, largest moment
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_steady_spins(order, rank, sign):
    inertia = np.array([1.0, 2.0, 2.5])[list(order)]
    axis = int(np.argsort(inertia)[rank])
    m0 = np.zeros(3)
    m0[axis] = 1.7 * sign
    s = EulerTopSolution.from_initial(inertia, m0)
    assert s.family == "steady" and s.axis == axis and s.stable is (rank != 1)
    assert s.period == math.inf and s.rate == 0.0
    np.testing.assert_array_equal(s.momentum(np.array([-1e3, 0.0, 7.5])), np.tile(m0, (3, 1)))
    np.testing.assert_array_equal(euler_rhs(m0, inertia), 0.0)
    # `stable` means something: a 1e-6 perturbation stays small about the major and minor axes and
    # flips the body over about the intermediate one (evaluated with the elliptic solution).
    other = [i for i in range(3) if i != axis]
    m1 = m0.copy()
    m1[other] = 1e-6
    p = EulerTopSolution.from_initial(inertia, m1)
    dev = np.abs(p.momentum(np.linspace(0, p.period, 401)) - m1).max()
    if rank == 1:
        assert dev > 3.0  # reaches the opposite pole, 2 |m| away
    else:
        assert dev < 1e-4


@pytest.mark.parametrize(
    "inertia, a", [((2.0, 2.0, 1.0), 2), ((1.0, 2.0, 1.0), 1), ((3.0, 2.0, 2.0), 0), ((1.0, 1.0, 1.5), 2)]
)
def test_axisymmetric_precession(inertia, a):
    inertia = np.array(inertia)
    rng = np.random.default_rng(a)
    for _ in range(3):
        m0 = rng.normal(size=3)
        s = EulerTopSolution.from_initial(inertia, m0)
        perp = inertia[(a + 1) % 3]
        assert s.family == "axisymmetric" and s.axis == a and s.k == 0.0
        assert s.rate == pytest.approx(abs(m0[a] * (1 / inertia[a] - 1 / perp)), rel=1e-15)
        assert s.period == pytest.approx(2 * math.pi / s.rate, rel=1e-15)
        mu = np.linalg.norm(m0)
        t = np.linspace(-5, 5, 61) * s.period
        assert np.abs(s.momentum(t) - dop853(inertia, m0, t)).max() < 1e-9 * mu
        assert fd_residual(s, t[::6]) < 1e-7
        assert np.abs(s.momentum(0.0) - m0).max() < 1e-15 * mu
        assert np.abs(s.momentum(s.period) - m0).max() < 1e-13 * mu
    # m along the symmetry axis: a stable steady spin. m in the equatorial plane: at rest on the sphere.
    m0 = np.zeros(3)
    m0[a] = -2.0
    s = EulerTopSolution.from_initial(inertia, m0)
    assert s.family == "steady" and s.axis == a and s.stable is True
    m0 = np.ones(3)
    m0[a] = 0.0
    s = EulerTopSolution.from_initial(inertia, m0)
    assert s.family == "axisymmetric" and s.rate == 0.0 and s.period == math.inf
    np.testing.assert_array_equal(s.momentum([0.0, 100.0]), [m0, m0])


def test_spherical_body():
    m0 = np.array([0.3, -1.0, 2.0])
    s = EulerTopSolution.from_initial([1.5, 1.5, 1.5], m0)
    assert s.family == "spherical" and s.period == math.inf and s.rate == 0.0
    np.testing.assert_array_equal(s.momentum([-5.0, 0.0, 5.0]), np.tile(m0, (3, 1)))
    assert s.energy == pytest.approx(0.5 * (m0 @ m0) / 1.5, rel=1e-15)


# -- near-degenerate cases --------------------------------------------------------------------------
@pytest.mark.parametrize("eps", [1e-4, 1e-8, 1e-12, -1e-6, -1e-10, -1e-14])
@pytest.mark.parametrize("order", [(0, 1, 2), (1, 0, 2), (2, 0, 1)])
def test_near_separatrix(order, eps):
    inertia = np.array([1.0, 2.0, 3.0])[list(order)]
    m0 = separatrix_point(inertia, x=0.6, y=0.7)
    m0[int(np.argmax(inertia))] *= 1 + eps  # more weight on the major axis: lower energy, 'major'
    s = EulerTopSolution.from_initial(inertia, m0)
    assert s.family == ("major" if eps > 0 else "minor")
    assert 1 - s.k < 1e-3 and math.isfinite(s.period)
    mu = np.linalg.norm(m0)
    assert np.abs(s.momentum(0.0) - m0).max() < 1e-13 * mu
    assert np.abs(s.momentum(s.period) - m0).max() < 1e-10 * mu
    t = np.linspace(-1, 1, 61) * s.period
    assert fd_residual(s, t) < 1e-7
    m = s.momentum(t)
    assert np.abs(np.sum(m**2, -1) / s.casimir - 1).max() < 1e-12
    assert np.abs(0.5 * np.sum(m**2 / inertia, -1) / s.energy - 1).max() < 1e-12
    # The period, which diverges like log(1 / k'^2), against L&L's formulas at 50 digits.
    assert s.period == pytest.approx(period_by_hand(inertia, m0), rel=1e-12)
    # Short-time agreement with the integrator (longer runs are ill-conditioned near the separatrix).
    t = np.linspace(-4, 4, 33) / s.rate
    assert np.abs(s.momentum(t) - dop853(inertia, m0, t)).max() < 1e-9 * mu


@pytest.mark.parametrize("p", [0.5, 1e-3, 1e-7, 1e-8, 2e-8, 1e-12, 1e-30, 1e-200])
def test_jacobi_functions_against_mpmath(p):
    """Accuracy of the internal sn, cn, dn near k = 1, where scipy's ellipj(u, 1 - k'^2) loses digits."""
    K = float(ellipkm1(p))
    u = np.concatenate([np.linspace(-5 * K, 5 * K, 23), [K, K - 1e-3, 0.5 * K, 2 * K - 1e-3, -3 * K + 0.25]])
    sn, cn, dn = _jacobi(u, 1 - p, p, K)
    with mpmath.workdps(40 + int(-math.log10(p))):
        m = 1 - mpmath.mpf(p)
        for i, ui in enumerate(u):
            x = mpmath.mpf(ui)
            ref_sn, ref_cn, ref_dn = (float(mpmath.ellipfun(f, x, m=m)) for f in ("sn", "cn", "dn"))
            # Relative error against the local scale of each function (|f| + its size along the
            # rounding 4e-16 |u| of the argument), so the small values near zeros are judged too.
            # Allowed: 2e-13 relative, plus the effect |f'(u)| * 4e-16 |u| of rounding the argument
            # (sn' = cn dn, cn' = -sn dn, dn' = -k^2 sn cn); mpmath returns ~1e-200, not 0, for sn(0).
            du = 4e-16 * abs(ui)
            assert abs(sn[i] - ref_sn) <= 2e-13 * abs(ref_sn) + abs(ref_cn * ref_dn) * du + 1e-30
            assert abs(cn[i] - ref_cn) <= 2e-13 * abs(ref_cn) + abs(ref_sn * ref_dn) * du
            assert abs(dn[i] - ref_dn) <= 2e-13 * abs(ref_dn) + abs(ref_sn * ref_cn) * du


def test_small_amplitude_about_stable_axes():
    # k -> 0: a 1e-9 wobble about the largest and about the smallest moment.
    inertia = np.array([2.0, 3.0, 1.5])
    for axis, family in ((1, "major"), (2, "minor")):
        m0 = np.full(3, 1e-9)
        m0[axis] = 1.0
        s = EulerTopSolution.from_initial(inertia, m0)
        assert s.family == family and s.k < 1e-8
        t = np.linspace(-5, 5, 41) * s.period
        assert np.abs(s.momentum(t) - dop853(inertia, m0, t)).max() < 1e-9
        assert np.abs(s.momentum(s.period) - m0).max() < 1e-12
        # Linearised frequency about axis j: |m| sqrt((1/I_i - 1/I_j)(1/I_k - 1/I_j)).
        i, k = [n for n in range(3) if n != axis]
        lin = math.sqrt((1 / inertia[i] - 1 / inertia[axis]) * (1 / inertia[k] - 1 / inertia[axis]))
        assert 2 * math.pi / s.period == pytest.approx(lin, rel=1e-12)


def test_tiny_perturbation_of_the_unstable_spin():
    inertia = np.array([3.0, 1.0, 2.0])  # intermediate axis is 2
    for d in (1e-9, 1e-100, 1e-150):
        m0 = np.array([d, -d, 1.0])
        s = EulerTopSolution.from_initial(inertia, m0)
        assert s.family in ("major", "minor", "separatrix")
        assert np.abs(s.momentum(0.0) - m0).max() < 4e-15  # |m0| = 1: a few ulps
        m = s.momentum(np.linspace(-800, 800, 101) / s.rate)
        assert np.all(np.isfinite(m))
        assert np.abs(np.sum(m**2, -1) - 1).max() < 1e-12
    # 1e-200 off the axis, k'^2 ~ 1e-400 underflows: reported, never a NaN.
    with pytest.raises(NumericalError, match="separatrix"):
        EulerTopSolution.from_initial(inertia, [1e-200, -1e-200, 1.0])
    m0 = np.array([1e-9, -1e-9, 1.0])
    s = EulerTopSolution.from_initial(inertia, m0)
    t = np.linspace(-6, 6, 25) / s.rate
    assert np.abs(s.momentum(t) - dop853(inertia, m0, t)).max() < 1e-9
    assert fd_residual(s, t) < 1e-7


@pytest.mark.parametrize("delta", [1e-6, 1e-10, 1e-14])
def test_nearly_equal_moments(delta):
    # Two moments 1 + delta apart: still triaxial, close to the symmetric top (1, 2, 2).
    inertia = np.array([2.0 * (1 + delta), 1.0, 2.0])
    rng = np.random.default_rng(int(-math.log10(delta)))
    for _ in range(4):
        m0 = rng.normal(size=3)
        s = EulerTopSolution.from_initial(inertia, m0)
        assert s.family == family_by_hand(inertia, m0)
        mu = np.linalg.norm(m0)
        assert np.abs(s.momentum(0.0) - m0).max() < 1e-13 * mu
        horizon = min(s.period, 50 / mu) if math.isfinite(s.period) else 50 / mu
        t = np.linspace(-1, 1, 41) * horizon
        assert np.abs(s.momentum(t) - dop853(inertia, m0, t)).max() < 1e-9 * mu
        sym = EulerTopSolution.from_initial([2.0, 1.0, 2.0], m0)  # the axisymmetric limit
        assert np.abs(s.momentum(t) - sym.momentum(t)).max() < 1e3 * delta * mu + 1e-12


@pytest.mark.parametrize("scale", [1e-150, 1e-5, 1e5, 1e150])
def test_extreme_magnitudes(scale):
    inertia = np.array([1.0, 2.0, 3.0])
    ref = EulerTopSolution.from_initial(inertia, [0.3, -0.5, 0.8])
    s = EulerTopSolution.from_initial(inertia, scale * np.array([0.3, -0.5, 0.8]))
    assert s.family == ref.family and s.k == pytest.approx(ref.k, rel=1e-14)
    assert s.period == pytest.approx(ref.period / scale, rel=1e-13)
    t = np.linspace(0, 2, 9) * ref.period
    np.testing.assert_allclose(s.momentum(t / scale) / scale, ref.momentum(t), rtol=1e-12, atol=1e-13)


# -- property test --------------------------------------------------------------------------------
moment = st.floats(0.2, 5.0)
component = st.floats(-3.0, 3.0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(moment, moment, st.floats(0.0, 1.0), st.permutations([0, 1, 2]), st.tuples(component, component, component))
def test_property_random_bodies(a, b, frac, order, m0):
    lo, hi = max(a, b), a + b  # the third moment within the triangle inequality
    inertia = np.array([a, b, lo + frac * (hi - lo)])[order]
    m0 = np.array(m0)
    mu = np.linalg.norm(m0)
    assume(mu > 1e-3)
    try:
        s = EulerTopSolution.from_initial(inertia, m0)
    except NumericalError:
        # Allowed only within float64 underflow of the separatrix: |m|^2 - 2 E I_mid, exactly, ~ 0.
        I_mid = Fraction(float(np.sort(inertia)[1]))
        g = sum(Fraction(float(v)) ** 2 * (1 - I_mid / Fraction(float(i))) for v, i in zip(m0, inertia))
        assert abs(float(g / Fraction(float(mu)) ** 2)) < 1e-290
        return
    assert np.abs(s.momentum(0.0) - m0).max() < 1e-13 * mu
    if s.rate == 0.0:
        return
    span = s.period if math.isfinite(s.period) and s.period * s.rate < 1e3 else 20 / s.rate
    t = np.linspace(-1, 1, 9) * span
    m = s.momentum(t)
    assert np.all(np.isfinite(m))
    assert np.abs(np.sum(m**2, -1) / s.casimir - 1).max() < 1e-12
    assert np.abs(0.5 * np.sum(m**2 / inertia, -1) / s.energy - 1).max() < 1e-12
    assert fd_residual(s, t) < 1e-7
    if math.isfinite(s.period):
        assert np.abs(s.momentum(s.period) - m0).max() < 1e-10 * mu


# -- input errors ---------------------------------------------------------------------------------
def test_bad_inputs():
    with pytest.raises(InputError, match="m0"):
        EulerTopSolution.from_initial([1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    with pytest.raises(ShapeError, match=r"`m0`.*\(3,\)"):
        EulerTopSolution.from_initial([1.0, 2.0, 3.0], [1.0, 2.0])
    with pytest.raises(InputError, match="finite"):
        EulerTopSolution.from_initial([1.0, 2.0, 3.0], [1.0, np.nan, 0.0])
    with pytest.raises(InputError, match="finite"):
        EulerTopSolution.from_initial([1.0, 2.0, 3.0], [1.0, np.inf, 0.0])
    with pytest.raises(InputError, match="inertia"):
        EulerTopSolution.from_initial([1.0, -2.0, 3.0], [1.0, 1.0, 0.0])
    s = EulerTopSolution.from_initial([1.0, 2.0, 3.0], [1.0, 1.0, 0.0])
    with pytest.raises(InputError, match="`t`"):
        s.momentum([0.0, np.nan])
