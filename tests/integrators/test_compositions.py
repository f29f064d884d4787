"""High-order structure-preserving methods: Gauss-Legendre with 4 to 6 stages (its tableau against the
simplifying conditions B(2s), C(s), D(s) in exact arithmetic), and symmetric compositions of the midpoint rule,
of Gauss-Legendre steps and of the Lie-Poisson splitting. The composition weights are checked on their own,
in 50-digit arithmetic, by composing Strang's splitting of two random matrices (whose flows are matrix
exponentials, so that nothing but the weights decides the order); the compiled composition is checked against
the same Gauss-Legendre sub-steps taken one by one; long runs keep the energy bounded."""

import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.errors import InputError
from geomech.integrators import Composition, GaussLegendre, LiePoissonSplitting, solve
from geomech.integrators.methods import COMPOSITION_TABLES, composition_weights

SCHEMES = [(order, scheme) for order, scheme in COMPOSITION_TABLES] + [
    (4, "yoshida"),
    (6, "yoshida"),
    (8, "yoshida"),
    (4, "suzuki"),
    (6, "suzuki"),
]


@pytest.mark.parametrize("order, scheme", SCHEMES)
def test_weights_are_symmetric_consistent_and_kill_the_odd_powers(order, scheme):
    g = np.array(composition_weights(order, scheme))
    np.testing.assert_array_equal(g, g[::-1])
    assert abs(g.sum() - 1.0) < 1e-14
    for k in range(3, order, 2):  # necessary conditions of order `order` for a symmetric base of order 2
        assert abs((g**k).sum()) < 1e-12 * max(1.0, (np.abs(g) ** k).sum()), k


def _strang_composition_error(weights, h, A, B):
    """|Psi_h - exp(h (A + B))| for the composition of Strang steps exp(g h A/2) exp(g h B) exp(g h A/2)."""
    step = mpmath.eye(A.rows)
    for g in weights:
        gh = mpmath.mpf(g) * h
        half = mpmath.expm(gh * A / 2)
        step = half * mpmath.expm(gh * B) * half * step
    return mpmath.mnorm(step - mpmath.expm(h * (A + B)), 1)


@pytest.mark.parametrize(
    "order, scheme, h",
    [(6, "s7", 0.5), (6, "s9", 0.5), (6, "yoshida", 0.5), (8, "s15", 1.0), (8, "s17", 1.0), (10, "s35", 2.0)],
)
def test_weights_raise_strang_to_their_order_in_50_digits(order, scheme, h):
    rng = np.random.default_rng(11)
    with mpmath.workdps(50):
        A = mpmath.matrix(rng.normal(size=(4, 4)).tolist())
        B = mpmath.matrix(rng.normal(size=(4, 4)).tolist())
        A, B = A / mpmath.mnorm(A, 1), B / mpmath.mnorm(B, 1)
        # steps large enough that the truncation error stands far above the weights' own rounding (1e-16 h)
        g = composition_weights(order, scheme)
        errors = [_strang_composition_error(g, mpmath.mpf(x), A, B) for x in (h, h / 2)]
        slope = float(mpmath.log(errors[0] / errors[1]) / mpmath.log(2))
        # a local error of order p + 1 (p = order); an order-(p-2) method would show a slope near p - 1
        assert abs(slope - (order + 1)) < 0.3, (slope, [float(e) for e in errors])
        assert errors[1] > 1e-15


@pytest.mark.parametrize("s", [1, 2, 3, 4, 5, 6])
def test_gauss_tableau_satisfies_the_simplifying_conditions_exactly(s):
    A, b, c = GaussLegendre(s).tableau()
    # the exact nodes: zeros of the shifted Legendre polynomial, by sympy in exact arithmetic
    x = sp.Symbol("x")
    exact = sorted(float(r) for r in sp.Poly(sp.legendre(s, 2 * x - 1), x).nroots(n=30))
    np.testing.assert_allclose(c, exact, rtol=0, atol=2e-16)
    for k in range(2 * s):  # B(2s): the quadrature has order 2s
        assert abs(b @ c**k - float(Fraction(1, k + 1))) < 4e-16, k
    for k in range(s):  # C(s) and D(s)
        np.testing.assert_allclose(A @ c**k, c ** (k + 1) / (k + 1), rtol=0, atol=4e-16)
        np.testing.assert_allclose((b * c**k) @ A, b * (1 - c ** (k + 1)) / (k + 1), rtol=0, atol=4e-16)
    # symmetric: c_i + c_{s+1-i} = 1, b symmetric
    np.testing.assert_allclose(c + c[::-1], 1.0, rtol=0, atol=4e-16)
    np.testing.assert_allclose(b, b[::-1], rtol=0, atol=4e-16)


def _pendulum():
    q, p = sp.symbols("q p", real=True)
    return gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum")


@pytest.mark.parametrize("method", [Composition(6), Composition(8, "yoshida", stages=2)], ids=lambda m: m.key)
def test_a_composed_step_is_its_gauss_legendre_substeps_one_by_one(method):
    pend = _pendulum()
    h, y = 0.3, np.array([1.2, 0.5])
    composed = solve(pend, method, y0=y, h=h, t_final=h, newton_tol=1e-16).states[-1]
    base = GaussLegendre(method.stages)
    t = 0.0
    for g in method.weights():  # negative weights are steps backwards in time
        y = solve(pend, base, y0=y, t0=t, h=abs(g * h), t_final=t + g * h, newton_tol=1e-16).states[-1]
        t += g * h
    assert abs(t - h) < 1e-15
    np.testing.assert_allclose(composed, y, rtol=0, atol=1e-14)


@pytest.mark.parametrize(
    "method, q0, ns",
    [
        (Composition(6), 2.0, [14, 20, 28, 40]),
        (Composition(8), 1.0, [16, 22, 30, 40]),
        (GaussLegendre(4), 1.0, [11, 16, 22, 32]),
    ],
    ids=lambda m: getattr(m, "key", ""),
)
def test_convergence_order_on_the_pendulum(method, q0, ns, fitted_order):
    pend = _pendulum()
    T = 8.0
    ref = solve(pend, "dop853", y0=[q0, 0.0], t_final=T, rtol=1e-15, atol=1e-16).states[-1]
    errors = [
        np.abs(solve(pend, method, y0=[q0, 0.0], h=T / n, t_final=T, newton_tol=1e-16).states[-1] - ref).max()
        for n in ns
    ]
    assert abs(fitted_order([T / n for n in ns], errors, floor=1e-12) - method.order) < 0.3, errors


def test_lie_poisson_splitting_of_order_6_and_8_against_the_exact_free_body():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    m0 = np.array([1.0, 0.3, 0.2])
    exact = body.exact_solution(m0).momentum(6.0)
    for method, ns in ((LiePoissonSplitting(6, "s9"), (24, 48)), (LiePoissonSplitting(8, "s17"), (12, 24))):
        errors = [np.abs(solve(body, method, m0=m0, h=6.0 / n, t_final=6.0).m[-1] - exact).max() for n in ns]
        assert errors[1] < 1e-8
        assert math.log2(errors[0] / errors[1]) > method.order - 0.6, errors


def test_bad_compositions_are_refused_with_what_exists():
    with pytest.raises(InputError, match="s9 \\(order 6\\)"):
        Composition(8, "s9")
    with pytest.raises(InputError, match="midpoint rule"):
        Composition(6, "s9", stages=2)
    with pytest.raises(InputError, match="above the base"):
        Composition(6, "yoshida", stages=3)
    with pytest.raises(InputError, match="order"):
        LiePoissonSplitting(5)
    with pytest.raises(InputError, match="1 to 6"):
        GaussLegendre(7)
    assert Composition(8).key == "midpoint_s17_8" and Composition(6, "yoshida", stages=2).key == (
        "gauss_legendre_2_yoshida_6"
    )


@pytest.mark.slow
@pytest.mark.parametrize("method", [Composition(6), LiePoissonSplitting(6, "s9")], ids=lambda m: m.key)
def test_energy_stays_bounded_over_a_million_steps(method):
    if isinstance(method, Composition):
        system, start = _pendulum(), {"y0": [2.0, 0.0]}
    else:
        system, start = gm.RigidBody([3.0, 2.0, 1.0]), {"m0": [1.0, 0.3, 0.2]}
    h = 0.1
    sol = solve(system, method, h=h, t_final=1e6 * h, saveat=1001, **start)
    drift = np.abs(sol.energy - sol.energy[0])
    # bounded, not growing: the second half of the run is no worse than the first
    assert drift.max() < 1e-6
    assert drift[500:].max() < 3 * drift[:500].max() + 1e-15
