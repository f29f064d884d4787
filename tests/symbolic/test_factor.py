"""The simplifier's factorization by FLINT (symbolic/simplify.py, factor_list) against sympy's own (a second,
independent implementation) and against the product it must give back."""

import random

import pytest
import sympy as sp

from geomech.symbolic.polys import factor_list


def _polynomials():
    """Products of random sparse factors over the rationals in a ring like the simplifier's: cosines, sines and
    parameters as generators, repeated factors, rational coefficients and contents."""
    R, *g = sp.ring("C_phi S_phi m r J J0", sp.QQ)
    rng = random.Random(7)
    out = [R(3), R(0) + sp.Rational(2, 3) * g[0], (g[0] ** 2 + g[1] ** 2 - 1) * g[2]]
    for _ in range(12):
        p = R(rng.choice([1, -1, 2, sp.Rational(1, 6)]))
        for _ in range(rng.randint(1, 4)):
            f = sum(
                (rng.randint(-3, 3) * sp.Rational(1, rng.randint(1, 4)) * g[rng.randrange(6)] ** rng.randint(0, 2))
                * g[rng.randrange(6)]
                for _ in range(rng.randint(1, 4))
            ) + rng.randint(-2, 2)
            if f and not f.is_ground:
                p *= f ** rng.randint(1, 2)
        out.append(p)
    return out


@pytest.mark.parametrize("p", _polynomials(), ids=str)
def test_flint_factors_are_sympys(p):
    content, factors = factor_list(p)
    expected_content, expected = p.factor_list()
    assert content == expected_content
    assert sorted((str(f), k) for f, k in factors) == sorted((str(f), k) for f, k in expected)
    product = p.ring(content)
    for f, k in factors:
        product *= f**k
    assert product == p


def test_division_on_the_circles_finds_a_spurious_factor_and_is_bounded(monkeypatch):
    """A numerator that is a multiple of sin(a + b) only on the circles S^2 + C^2 = 1 is divided by it (the
    spurious factor of a right inverse); so is one that is a multiple of a long factor in two angles (its norm
    has thousands of terms: the three-link chain's locked inertia), by FLINT's polynomials and by sympy's (the
    fallback) alike; a factor that does not divide is not found to; a norm longer than _CIRCLE_MAX_NORM terms is not
    tried."""
    from geomech.symbolic import polys as S
    from geomech.symbolic.simplify import simplify_expr

    R, Ca, Cb, Sa, Sb, m, r, J = sp.ring("Ca Cb Sa Sb m r J", sp.QQ)
    rel = [Ca**2 + Sa**2 - 1, Cb**2 + Sb**2 - 1]
    f = Sa * Cb + Ca * Sb  # sin(a + b)
    # (sin a cos b + cos a sin b) (cos a - m), with cos^2 a written 1 - sin^2 a: no polynomial factor f shows
    num = (f * (Ca - m)).rem(rel)
    assert num.div(f)[1] != 0
    q = S._divide_on_circles(num, f, R, 2)
    assert q is not None and (q * f - num).rem(rel) == 0
    # 20 terms in both angles (within _CIRCLE_MAX_TERMS): a norm of 4599 terms
    rng = random.Random(3)
    monomials = [Sa, Ca, Sa * Cb, Ca * Sb, Ca * Cb, Sb, Cb]
    long = sum(
        rng.randint(1, 9)
        * rng.choice(monomials)
        * m ** rng.randint(0, 3)
        * r ** rng.randint(0, 3)
        * J ** rng.randint(0, 2)
        for _ in range(20)
    )
    assert len(long.terms()) <= S._CIRCLE_MAX_TERMS
    multiple = (long * (Ca * Sb - m * J)).rem(rel)
    assert multiple.div(long)[1] != 0  # a multiple on the circles only
    for flint in (S._flint(), None):
        monkeypatch.setattr(S, "_flint", lambda flint=flint: flint)
        q = S._divide_on_circles(multiple, long, R, 2)
        assert q is not None and (q * long - multiple).rem(rel) == 0
        assert S._divide_on_circles((multiple + m * Sa).rem(rel), long, R, 2) is None
    monkeypatch.undo()
    monkeypatch.setattr(S, "_CIRCLE_MAX_NORM", 50)
    assert S._divide_on_circles(multiple, long, R, 2) is None

    a, b, mm = sp.symbols("a b m")
    top = sp.expand(sp.expand_trig(sp.sin(a + b)) * (sp.cos(a) - mm)).subs(sp.cos(a) ** 2, 1 - sp.sin(a) ** 2)
    e = top / sp.expand_trig(sp.sin(a + b))
    assert sp.cancel(e) != sp.cos(a) - mm  # no polynomial cancellation shows it
    assert simplify_expr(e) == sp.cos(a) - mm


def test_circle_remainder_is_the_division_by_the_circle_relations():
    """The simplifier's term-by-term reduction modulo C^2 + S^2 - 1 against sympy's multivariate division by the
    relations (a Groebner basis: the remainder is unique), on random polynomials with high cosine powers."""
    from geomech.symbolic.polys import circle_rem

    R, Ca, Cb, Sa, Sb, m = sp.ring("Ca Cb Sa Sb m", sp.QQ)
    rel = [Ca**2 + Sa**2 - 1, Cb**2 + Sb**2 - 1]
    rng = random.Random(11)
    for _ in range(60):
        p = R(0)
        for _ in range(rng.randint(0, 25)):
            p += (
                sp.Rational(rng.randint(-5, 5), rng.randint(1, 3))
                * Ca ** rng.randint(0, 5)
                * Cb ** rng.randint(0, 4)
                * Sa ** rng.randint(0, 3)
                * Sb ** rng.randint(0, 2)
                * m ** rng.randint(0, 2)
            )
        reduced = circle_rem(p, 2)
        assert reduced == p.rem(rel)
        assert all(mon[0] < 2 and mon[1] < 2 for mon in reduced.itermonoms())
    R1, C, S, x = sp.ring("C S x", sp.QQ)
    assert circle_rem(C**5 * x, 1) == C * (1 - S**2) ** 2 * x
    assert circle_rem(C * S**3 + x**4, 1) == C * S**3 + x**4


def test_expand_terms_keeps_roots_whole():
    """A sum of terms, as sympy's expand gives it, except inside roots: their arguments are not expanded (their
    denominators spread over every term of the argument otherwise), and the value is the same."""
    from geomech.symbolic import expand_terms

    a, b, m, x = sp.symbols("a b m x", positive=True)
    root = sp.sqrt(b**2 + (a + m * x) ** 2 / (1 + m) ** 2)
    e = (a + x) * (a - m / root) + (x + 1) ** 2
    out = expand_terms(e)
    assert 1 / root in out.atoms(sp.Pow)  # kept whole
    assert len(sp.Add.make_args(out)) == 7  # a^2 + a x - a m/root - m x/root + x^2 + 2 x + 1, expanded outside
    assert sp.simplify(out - e) == 0
    assert sp.count_ops(out) < sp.count_ops(sp.expand(e))
    assert expand_terms(sp.Matrix([(a + x) ** 2])) == sp.Matrix([a**2 + 2 * a * x + x**2])


def test_simplified_inverse_is_the_inverse_and_cancels_the_determinant():
    """The adjugate over a simplified determinant (up to 3 x 3) against M M^-1 = I, simplified, and against sympy's
    inverse at a random point; a matrix whose determinant vanishes only on the circles is refused; a 4 x 4 goes
    through the LU factors."""
    from geomech.symbolic import simplified_inverse, simplify_matrix

    a, b, m, J = sp.symbols("a b m J", real=True)
    M2 = sp.Matrix([[J + m * sp.cos(a) ** 2, m * sp.sin(a) * sp.cos(b)], [m * sp.sin(a) * sp.cos(b), J + m]])
    M3 = sp.Matrix(
        [[m, 0, m * sp.sin(a)], [0, m, -m * sp.cos(a)], [m * sp.sin(a), -m * sp.cos(a), J + m * sp.sin(b) ** 2]]
    )
    point = {a: sp.Rational(3, 10), b: sp.Rational(-7, 10), m: sp.Rational(3, 2), J: sp.Rational(2, 5)}
    for M in (M2, M3, sp.diag(M2, M2)):
        inv = simplified_inverse(M)
        assert simplify_matrix(M * inv) == sp.eye(M.rows)
        assert (inv.subs(point) - M.subs(point).inv()).evalf(30).norm() < 1e-25
    # det M3 = m^2 (J - m cos^2 b): each entry's denominator divides m (J + m sin^2 b - m), the m^2 cancelled
    for e in simplified_inverse(M3):
        assert sp.fraction(sp.cancel(m * (J + m * sp.sin(b) ** 2 - m) / sp.fraction(e)[1]))[1] == 1
    singular = sp.Matrix([[sp.sin(a) ** 2, sp.cos(a)], [1 - sp.cos(a) ** 2, sp.cos(a)]])
    with pytest.raises(ValueError):
        simplified_inverse(singular)


def test_tangents_sums_and_multiples_of_angles_are_brought_to_sines_and_cosines_of_the_coordinates():
    """The passes simplify_expr makes only where they apply (tan -> sin/cos, sums and multiples of angles
    expanded): identities that need them vanish, and an expression without them comes back equal to itself."""
    from geomech.symbolic import simplify_expr

    x, y, a = sp.symbols("x y a")
    assert simplify_expr(sp.tan(x) * sp.cos(x) - sp.sin(x)) == 0
    assert simplify_expr(sp.cot(y) * sp.sin(y) ** 2 - sp.sin(2 * y) / 2) == 0
    assert simplify_expr(sp.sin(x + y) - sp.sin(x) * sp.cos(y) - sp.cos(x) * sp.sin(y)) == 0
    assert simplify_expr(sp.cos(2 * x) + 2 * sp.sin(x) ** 2 - 1) == 0
    plain = a * sp.sin(x) / (2 + sp.cos(y)) + sp.cos(x) ** 3
    assert sp.expand(simplify_expr(plain) - plain) == 0 or sp.simplify(simplify_expr(plain) - plain) == 0
    long = sum(sp.Integer(k) * sp.sin(x) ** (k % 3) * sp.cos(y) ** (k % 2) * a**k for k in range(1, 60))
    assert sp.simplify(simplify_expr(long / (1 + a**2)) - long / (1 + a**2)) == 0


def test_expand_terms_of_a_polynomial_in_sines_and_cosines_is_sympys_expand():
    """The ring's expansion of a polynomial in symbols, sines and cosines is sympy.expand's sum, term for term;
    whatever lies outside (a denominator, a Float, a root, an unexpanded angle) is expanded by sympy."""
    from geomech.symbolic import expand_terms

    x, y, a = sp.symbols("x y a")
    rng = random.Random(5)
    atoms = [x, y, a, sp.sin(x), sp.cos(y), sp.sin(x + y), sp.Rational(3, 7), sp.Integer(-2)]
    for _ in range(25):
        e = sp.Integer(0)
        for _ in range(rng.randint(1, 4)):
            term = sp.Integer(1)
            for _ in range(rng.randint(1, 3)):
                term *= (rng.choice(atoms) + rng.choice(atoms)) ** rng.randint(1, 3)
            e += term
        assert expand_terms(e) == sp.expand(e)
    for other in (x / (1 + y), 0.5 * (x + y) ** 2, sp.sin(x * (1 + y)) * (a + 1) ** 2, sp.exp(x) * (x + 1)):
        assert expand_terms(other) == sp.expand(other)


def test_expand_terms_of_a_rational_function_is_sympys_sum_of_terms_or_shorter():
    """With denominators (polynomials, powers of atoms), each term is a monomial over the expanded product of
    the denominators it carries, as sympy's expand writes it: the same value always, the same text where sympy's
    result does not depend on the order it builds products in, never more operations."""
    from geomech.symbolic import expand_terms

    x, y, a, b, c = sp.symbols("x y a b c")
    rng = random.Random(11)
    atoms = [x, y, a, b, sp.sin(x), sp.cos(y), sp.sin(x + y), sp.Rational(3, 7), sp.Integer(-2)]
    atoms += [1 / (a + b), 1 / (2 * a + 2 * c), 1 / a, (a + b) ** -2, 1 / (x**2 + 1)]
    same = 0
    for _ in range(300):
        e = sp.Integer(0)
        for _ in range(rng.randint(1, 4)):
            term = sp.Integer(1)
            for _ in range(rng.randint(1, 3)):
                term *= (rng.choice(atoms) + rng.choice(atoms)) ** rng.choice([1, 1, 2, 3, -1])
            e += term
        got, want = expand_terms(e), sp.expand(e)
        same += got == want
        assert sp.count_ops(got) <= sp.count_ops(want)
        pt = {s: rng.uniform(0.5, 1.5) for s in (x, y, a, b, c)}
        assert abs(float(got.subs(pt)) - float(want.subs(pt))) <= 1e-12 * max(1.0, abs(float(want.subs(pt))))
    assert same >= 290
    # the mechanics' case: denominators in the parameters (a centre of mass), integer and rational coefficients
    m1, m2, m3 = sp.symbols("m1 m2 m3", positive=True)
    e = x * (y + sp.sin(x)) ** 2 * m1 / (m1 + m2 + m3) + sp.Rational(3, 2) * y * (x + m2) / (m1 + m2) ** 2
    assert expand_terms(e) == sp.expand(e)
    assert len(sp.Add.make_args(expand_terms(e))) == 5
    # a numerator that is a multiple of its denominator: sympy's expand decides
    e = (x + 1 / (a + b)) * (a + b)
    assert expand_terms(e) == sp.expand(e)


def test_simplify_expr_reads_sines_of_any_argument_in_its_ring():
    # a sine of a root or of another function is a generator as it is (its argument is not walked again); a
    # function outside the sines and cosines sends the expression to trigsimp; a tangent becomes sin/cos
    from geomech.symbolic import simplify_expr

    x, y = sp.symbols("x y", real=True)
    u = sp.exp(x) * sp.sqrt(1 + y**2)
    assert simplify_expr(sp.sin(u) ** 2 + sp.cos(u) ** 2 - 1) == 0
    assert simplify_expr((sp.sin(u) ** 2 - 1) / (sp.cos(u) * y)) == -sp.cos(u) / y
    assert simplify_expr(sp.exp(x) * (sp.sin(x) ** 2 + sp.cos(x) ** 2)) == sp.exp(x)
    assert simplify_expr(sp.tan(x) * sp.cos(x) - sp.sin(x)) == 0
    assert simplify_expr(sp.sin(x + y) - sp.sin(x) * sp.cos(y) - sp.cos(x) * sp.sin(y)) == 0
    assert simplify_expr(sp.Integer(3) + sp.sin(2) ** 2 + sp.cos(2) ** 2) == 4


def test_divisions_on_the_circles_find_every_multiple_and_reject_the_rest():
    # num = q f + h (S1^2 + C1^2 - 1) + k (S2^2 + C2^2 - 1) is a multiple of f on the circles, however q, h, k are
    # drawn; the point's test must never say otherwise (it would change a simplification), and the division by the
    # norm must agree with it; one term more and both say no
    from geomech.symbolic import polys as S

    C1, C2, S1, S2, m, k = sp.symbols("C1 C2 S1 S2 m k")
    R = S._ring((C1, C2, S1, S2, m, k))
    C1, C2, S1, S2, m, k = R.gens
    rng = random.Random(2)
    monomials = [R.one, C1, C2, S1, S2, m, k, C1 * S2, m * k, m**2, C2 * S1 * m]
    rejected, routes = 0, [0, 0]
    for _ in range(40):
        f = sum(rng.randint(-3, 3) * rng.choice(monomials) for _ in range(4)) + m * (1 + C1 * S2)
        q = sum(rng.randint(-3, 3) * rng.choice(monomials) * rng.choice(monomials) for _ in range(5))
        h, g = (sum(rng.randint(-2, 2) * rng.choice(monomials) for _ in range(3)) for _ in range(2))
        num = q * f + h * (S1**2 + C1**2 - 1) + g * (S2**2 + C2**2 - 1)
        if not num:
            continue
        top = S.circle_rem(num, 2)
        # by long division in a parameter whose leading coefficient has no angle, or by the norm
        routes[S._angle_free_lead(S._to_flint(f), 2) is None] += 1
        assert not S._not_a_multiple_at_a_point(S._to_flint(top), S._to_flint(f), 2)
        quotient = S._divide_on_circles(top, f, R, 2)
        assert quotient is not None and S.circle_rem(quotient * f - top, 2) == 0
        off = S.circle_rem(top + k**3 * S1, 2)
        if S._not_a_multiple_at_a_point(S._to_flint(off), S._to_flint(f), 2):
            rejected += 1
            assert S._divide_on_circles(off, f, R, 2) is None
    assert rejected >= 30 and min(routes) >= 5


def test_a_polynomial_as_an_expression_is_sympys_own():
    # the same arguments in the same order (srepr), for polynomials in symbols, sines and cosines with rational
    # coefficients, constants, one term, zero; other symbols (a product, a root) by sympy's as_expr
    from geomech.symbolic.polys import _ring, as_expr

    x, y, a, u = sp.symbols("x y a u")
    R = _ring((x, y, a, u))
    X, Y, A, U = R.gens
    rng = random.Random(4)
    atoms = [x, y, sp.sin(u), sp.cos(u)]
    for _ in range(200):
        p = R.zero
        for _ in range(rng.randint(0, 30)):
            p += (
                sp.QQ(rng.randint(-9, 9), rng.randint(1, 4))
                * X ** rng.randint(0, 3)
                * Y ** rng.randint(0, 2)
                * (A ** rng.randint(0, 4) * U ** rng.randint(0, 2))
            )
        for symbols in (None, [x, y, sp.sin(u), sp.cos(u)], rng.sample(atoms, 4)):
            want = p.as_expr(*(symbols or ()))
            got = as_expr(p, symbols)
            assert got == want and sp.srepr(got) == sp.srepr(want)
    p = X**2 * Y + 3 * X
    assert sp.srepr(as_expr(p, [x * y, sp.sqrt(a), a, u])) == sp.srepr(p.as_expr(x * y, sp.sqrt(a), a, u))
