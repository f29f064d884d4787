"""Simplification of the rational trigonometric expressions of mechanics, exact where it matters: an expression
equal to zero is recognised as zero (every Jacobiator, every invariance check depends on it), denominators are
kept factored, and each step is bounded in size so that a derivation takes seconds."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np
import sympy as sp
from sympy.core.basic import _args_sortkey
from sympy.simplify.fu import TR2

from ..errors import SymbolicError
from ._derivative import derivative

__all__ = [
    "as_expr",
    "simplify_expr",
    "simplify_matrix",
    "tidy_trig",
    "inverse",
    "simplified_inverse",
    "time_derivative",
    "quadratic_blocks",
    "quadratic_coefficients",
    "quadratic_form",
    "clear_denominators",
    "expand_terms",
    "vanishes",
]

#: Above this many terms in a numerator, factoring is skipped (it dominates the cost, and longer numerators
#: of the examples are irreducible).
_FACTOR_MAX_TERMS = 48
#: Factors of a denominator longer than this are not tested for division on the circles S^2 + C^2 = 1.
_CIRCLE_MAX_TERMS = 24
#: Nor are those whose norm (the product of their conjugates in the cosines, reduced) has more terms than this:
#: the three-link chain's locked inertia, 22 terms in two angles, has a norm of 3113 terms and divides its shape
#: mass's numerators (a sixteenth of their size after the division), in milliseconds with FLINT.
_CIRCLE_MAX_NORM = 20000


def _normal_form(expr: sp.Expr, pairs: Sequence[tuple[sp.Symbol, sp.Symbol]], keep_sin: bool) -> sp.Expr:
    """Normal form of a polynomial in (S_u, C_u) modulo S_u^2 + C_u^2 - 1: even powers of one of them go."""
    expr = sp.expand(expr)
    if not pairs:
        return expr
    gens = [C for _, C in pairs] if keep_sin else [S for S, _ in pairs]
    poly = sp.Poly(expr, *gens)
    out = sp.Integer(0)
    for mon, coeff in poly.terms():
        term = coeff
        for (S, C), k in zip(pairs, mon):
            g, other = (C, S) if keep_sin else (S, C)
            term *= g ** (k % 2) * (1 - other**2) ** (k // 2)
        out += term
    return sp.expand(out)


def _nterms(e: sp.Expr) -> int:
    return len(sp.Add.make_args(e))


@lru_cache(maxsize=16384)
def simplify_expr(expr: sp.Expr) -> sp.Expr:
    r"""Simplify a rational function of parameters, polynomial variables and sines and cosines.

    Each :math:`\sin u, \cos u` (after ``tan -> sin/cos`` and expanding sums and multiples of angles) becomes
    a pair of symbols :math:`S_u, C_u`. The expression is brought to one fraction bottom up with its denominator
    kept as a product of irreducible factors (:class:`_Fractions`: the lcm of factored denominators, no gcd of
    large polynomials); the numerator is reduced modulo :math:`S_u^2 + C_u^2 - 1` (a Groebner basis, so an
    expression equal to zero is recognised exactly; even powers of cosines are eliminated) and divided by every
    factor of the denominator it is a multiple of, also where that holds only on the circles
    (:func:`_divide_on_circles`: the spurious :math:`\cos\theta` or :math:`\sin(\theta + \phi)` of a right inverse);
    a short numerator is factored. Expressions outside this class fall back to ``sympy.trigsimp`` (with floats
    as symbols).
    """
    expr = sp.sympify(expr)
    scan = _Scan(expr)
    if not scan.any_symbol:
        return sp.simplify(expr)
    # tan -> sin/cos and sums and multiples of angles expanded, each a pass that rebuilds the whole tree: made only
    # where they have something to do (in the derivations, sines and cosines of the coordinates, most of the time)
    e = expr
    if scan.tan:
        e = TR2(e)
        scan = _Scan(e)
    if scan.compound:
        e = sp.expand_trig(e)
        scan = _Scan(e, expanded=True)
    args = sorted({t.args[0] for t in scan.trig}, key=sp.default_sort_key)
    pairs, fwd, back = [], {}, {}
    # named after the angle (not Dummy): the same polynomial is then the same expression in every call, and the
    # factorizations of denominators are shared (_FACTORS); Dummy if two angles print alike
    named = len({str(u) for u in args}) == len(args)
    for i, u in enumerate(args):
        S, C = (sp.Symbol(f"_sin({u})"), sp.Symbol(f"_cos({u})")) if named else (sp.Dummy(f"S{i}"), sp.Dummy(f"C{i}"))
        pairs.append((S, C))
        fwd[sp.sin(u)], fwd[sp.cos(u)] = S, C
        back[S], back[C] = sp.sin(u), sp.cos(u)
    if scan.other:  # another function, or a power that is not an integer's
        return _trigsimp(expr)
    # Work in a sparse polynomial ring (much faster than expanding sympy expressions), reduced modulo
    # S^2 + C^2 - 1 always to the same normal form (cosines to the power 0 or 1), so that an expression equal to
    # zero is recognised and a denominator met in several derived objects is the same polynomial everywhere. The
    # sines and cosines become the ring's generators as they are met (no substituted copy of the tree is made).
    others = sorted(scan.symbols, key=sp.default_sort_key)
    gens = tuple(C for _, C in pairs) + tuple(S for S, _ in pairs) + tuple(others)
    try:
        R = _ring(gens)
        n_, den = _Fractions(R, len(pairs), fwd).convert(e)
    except (
        ValueError,
        TypeError,
        ZeroDivisionError,
        sp.polys.polyerrors.PolynomialError,
        sp.CoercionFailed,
        _Unsupported,
    ):
        return _simplify_expr_slow(e.xreplace(fwd), pairs, back)
    if not n_:
        return sp.Integer(0)
    n_, den = _cancel_factors(n_, den, R, len(pairs))
    # The denominator is kept as the product of its irreducible factors (readable, and no costly gcd).
    den = sp.Mul(
        *[as_expr(f) ** k for f, k in sorted(den.items(), key=lambda fk: sp.default_sort_key(as_expr(fk[0]))) if k]
    )
    for S, C in pairs:
        den = _pythagoras(den, S, C)
    if len(n_.terms()) <= _FACTOR_MAX_TERMS:
        num = _factor(n_)
        for S, C in pairs:
            num = _pythagoras(num, S, C)
        num = num.xreplace(back)
    else:
        # a long numerator, not factored (and so no (S - 1)(S + 1) to write as -C^2): built in the sines and
        # cosines at once, where building it in S, C and replacing them walked it twice more
        num = as_expr(n_, [back.get(g, g) for g in gens])
    if den.could_extract_minus_sign():
        num, den = -num, -den
    return num / den.xreplace(back)


class _Scan:
    """One walk of an expression, each distinct subexpression once (sympy's ``atoms``, ``has`` and ``xreplace``
    walk a shared subtree again wherever it occurs: the derived matrices share most of theirs): its sines and
    cosines, the symbols met outside their arguments, and what :func:`simplify_expr` must do first or cannot do
    in its ring (a tangent, a sine of a sum before ``expanded``, another function or a root)."""

    def __init__(self, expr: sp.Expr, *, expanded: bool = False):
        self.trig: set = set()
        self.symbols: set = set()
        self.any_symbol = self.tan = self.compound = self.other = False
        seen: set = set()
        stack = [(expr, False)]
        while stack:
            item = stack.pop()
            if item in seen:
                continue
            seen.add(item)
            x, inside = item
            if x.is_Symbol:
                self.any_symbol = True
                if not inside:
                    self.symbols.add(x)
                continue
            if x.is_Atom:
                continue
            t = type(x)
            if t is sp.sin or t is sp.cos:
                a = x.args[0]
                if not inside:
                    self.trig.add(x)
                    if not (expanded or a.is_Symbol or a.is_Number):
                        self.compound = True
                stack.append((a, True))
                continue
            if t is sp.tan or t is sp.cot:
                self.tan = True
            elif not inside and (x.is_Function or (x.is_Pow and not x.exp.is_Integer)):
                self.other = True
            stack.extend((a, inside) for a in x.args)


def _trigsimp(expr: sp.Expr) -> sp.Expr:
    """``sympy.trigsimp`` with each Float a symbol: trigsimp factors, and factoring turns a float into the exact
    rational of its binary value (1e308 into an integer of 309 digits, 12 s in sympy's Wang algorithm for a
    Serret-Andoyer reduction with I1 = -1e308), where as a symbol it costs nothing; its value is put back after."""
    floats = {f: sp.Dummy() for f in expr.atoms(sp.Float)}
    if not floats:
        return sp.trigsimp(expr)
    return sp.trigsimp(expr.xreplace(floats)).xreplace({d: f for f, d in floats.items()})


def as_expr(p: Any, symbols: Sequence[sp.Expr] | None = None) -> sp.Expr:
    """``p.as_expr(*symbols)`` of a polynomial of a sympy ring, the same expression, built five times faster where
    every symbol is a Symbol, a sine or a cosine: each term's product is made from its factors in sympy's canonical
    order (ranked once for the polynomial, where ``Mul`` sorts and flattens every term), and the sum from its
    terms in sympy's order. Products of powers of such distinct atoms are what ``Mul`` would return (nothing in them
    merges or distributes), so the arguments are the ones sympy builds."""
    symbols = tuple(symbols) if symbols else p.ring.symbols
    if len(set(symbols)) < len(symbols) or not all(
        (x.is_Symbol or type(x) in (sp.sin, sp.cos)) and x.is_commutative for x in symbols
    ):
        return p.as_expr(*symbols)
    to_sympy = p.ring.domain.to_sympy
    powers: dict = {}
    rows, constant = [], None
    for mon, c in p.iterterms():
        factors = []
        for i, m in enumerate(mon):
            if m:
                f = powers.get((i, m))
                if f is None:
                    f = powers[(i, m)] = symbols[i] if m == 1 else sp.Pow(symbols[i], m)
                factors.append(f)
        if factors:
            rows.append((to_sympy(c), factors))
        else:
            constant = to_sympy(c)
    rank = {f: r for r, f in enumerate(sorted(powers.values(), key=_args_sortkey))}
    terms = []
    for c, factors in rows:
        factors.sort(key=rank.__getitem__)
        if c is not sp.S.One:
            factors.insert(0, c)
        terms.append(factors[0] if len(factors) == 1 else sp.Mul._from_args(tuple(factors), True))
    terms.sort(key=_args_sortkey)
    if constant is not None:
        terms.insert(0, constant)
    if len(terms) <= 1:
        return terms[0] if terms else sp.S.Zero
    return sp.Add._from_args(tuple(terms), True)


@lru_cache(maxsize=4096)
def _factor(p: Any) -> sp.Expr:
    """A ring polynomial as a product of its irreducible factors (cached: the same numerator recurs)."""
    content, factors = factor_list(p)
    return sp.Mul(sp.Rational(content.numerator, content.denominator), *[as_expr(f) ** k for f, k in factors])


def factor_list(p: Any) -> tuple[Any, list]:
    """``p.factor_list()`` of a polynomial of a ring over the rationals, by FLINT's multivariate factorization
    where python-flint is installed (sympy's own, in Python, is most of a derivation's time): the content, and the
    irreducible factors with integer coefficients, primitive, their leading coefficients positive, as sympy's."""
    flint = _flint()
    if flint is None or p.is_ground:
        return p.factor_list()
    R = p.ring
    terms = p.terms()
    den = 1
    for _, c in terms:
        den = den * c.denominator // math.gcd(den, c.denominator)
    ctx = flint.fmpz_mpoly_ctx.get(tuple(f"x{i}" for i in range(len(R.gens))), "lex")
    f = ctx.from_dict({m: int(c.numerator) * (den // int(c.denominator)) for m, c in terms})
    content, factors = f.factor()
    QQ = R.domain
    out = [(R.from_dict({m: QQ(int(v)) for m, v in g.to_dict().items()}), int(k)) for g, k in factors]
    return QQ(int(content), den), out


def exact_quotient(p: Any, f: Any) -> Any:
    """``p / f`` for polynomials of one ring over the rationals where ``f`` divides ``p``, else ``None``: by
    FLINT's exact division where python-flint is installed (sympy's ``div`` finds the leading term of the whole
    remainder at every step: quadratic in the number of terms)."""
    if _flint() is None:
        q, r = p.div(f)
        return None if r else q
    from flint.utils.flint_exceptions import DomainError

    try:
        q = _to_flint(p) / _to_flint(f)
    except DomainError:  # not a multiple
        return None
    return _from_flint(q, p.ring)


def _to_flint(p: Any) -> Any:
    fmpq = _flint().fmpq
    ctx = _fmpq_context(len(p.ring.gens))
    return ctx.from_dict({m: fmpq(int(c.numerator), int(c.denominator)) for m, c in p.iterterms()})


def _from_flint(q: Any, R: Any) -> Any:
    QQ = R.domain
    return R.from_dict({m: QQ(int(c.p), int(c.q)) for m, c in q.to_dict().items()})


@lru_cache(maxsize=64)
def _fmpq_context(n: int) -> Any:
    return _flint().fmpq_mpoly_ctx.get(tuple(f"x{i}" for i in range(n)), "lex")


@lru_cache(maxsize=1)
def _flint() -> Any:
    try:
        import flint
    except ImportError:  # pragma: no cover - python-flint is a dependency; sympy's factorization otherwise
        return None
    return flint if hasattr(flint, "fmpz_mpoly_ctx") else None


class _Unsupported(Exception):
    pass


#: Factorizations of denominators (expressions in the angle-named sine and cosine symbols), shared by calls.
_FACTORS: dict = {}


class _Fractions:
    """Rational functions as ``(numerator, {irreducible factor: multiplicity})`` over a polynomial ring.

    Converting a sympy expression bottom up keeps every denominator factored: a sum takes the lcm of the
    factored denominators (no gcd of large polynomials, the cost of ``together`` followed by ``cancel`` on
    nested expressions), a negative power factors only its base (short, usually). Numerators are reduced
    modulo the circle relations of the first ``npairs`` cosines (:func:`circle_rem`) after every product.
    """

    def __init__(self, R: Any, npairs: int, atoms: dict | None = None):
        self.R, self.npairs = R, npairs
        self.gen = {g.as_expr(): g for g in R.gens}
        # sines and cosines read as the generators named by ``atoms`` (sin(u) -> S_u, cos(u) -> C_u)
        self.gen.update({a: self.gen[g] for a, g in (atoms or {}).items()})
        self.memo: dict = {}
        self.factors: dict = {}

    def reduce(self, p: Any) -> Any:
        return circle_rem(p, self.npairs)

    def factor(self, p: Any) -> tuple[Any, list]:
        p = self.reduce(p)
        if not p:
            raise ZeroDivisionError("a denominator vanishes identically")
        if p.is_ground:
            return p.LC, []
        if p not in self.factors:
            key = as_expr(p)
            if key not in _FACTORS:
                content, facs = factor_list(p)
                _FACTORS[key] = (content, [(as_expr(f), k) for f, k in facs])
            content, facs = _FACTORS[key]
            out = []
            for f, k in facs:
                f = self.R.from_expr(f)
                # one sign per factor in this ring (its generators' order may differ from the cached one's)
                if f.LC < 0:
                    f, content = -f, content * (-1) ** k
                out.append((f, k))
            self.factors[p] = (content, out)
        return self.factors[p]

    def convert(self, e: sp.Expr) -> tuple[Any, dict]:
        try:
            return self.memo[e]
        except KeyError:
            pass
        R = self.R
        out: tuple[Any, dict]
        if e.is_Symbol or e.is_Function:
            if e not in self.gen:
                raise _Unsupported(type(e).__name__)
            out = (self.gen[e], {})
        elif e.is_Rational:
            out = (R(R.domain.convert(e)), {})
        elif e.is_Add:
            parts = [self.convert(a) for a in e.args]
            lcm: dict = {}
            for _, d in parts:
                for f, k in d.items():
                    lcm[f] = max(lcm.get(f, 0), k)
            num = R.zero
            for n, d in parts:
                for f, k in lcm.items():
                    if k > d.get(f, 0):
                        n = n * f ** (k - d.get(f, 0))
                num += n
            out = (self.reduce(num), lcm)
        elif e.is_Mul:
            den: dict[Any, int]
            num, den = R.one, {}
            for a in e.args:
                n, d = self.convert(a)
                num = self.reduce(num * n)
                for f, k in d.items():
                    den[f] = den.get(f, 0) + k
            out = (num, den)
        elif e.is_Pow and e.exp.is_Integer:
            n, d = self.convert(e.base)
            k = int(e.exp)
            if k >= 0:
                out = (self.reduce(n**k), {f: m * k for f, m in d.items()})
            else:
                content, facs = self.factor(n)
                num = R(R.domain.convert(1) / content ** (-k))
                for f, m in d.items():
                    num = num * f ** (-k * m)
                out = (self.reduce(num), {f: m * (-k) for f, m in facs})
        else:
            raise _Unsupported(type(e).__name__)
        self.memo[e] = out
        return out


def _cancel_factors(num: Any, den: dict, R: Any, npairs: int) -> tuple[Any, dict]:
    """Divide ``num`` by the factors of ``den`` it is a multiple of: as polynomials, or on the circles
    (:func:`_divide_on_circles`)."""
    den = dict(den)
    for f in list(den):
        while den[f]:
            q = exact_quotient(num, f)
            if q is None:
                q = _divide_on_circles(num, f, R, npairs) if npairs else None
                if q is None:
                    break
            num, den[f] = q, den[f] - 1
    return num, den


def _divide_on_circles(num: Any, f: Any, R: Any, npairs: int) -> Any:
    r"""``num / f`` where it is a multiple of ``f`` on the circles :math:`S_u^2 + C_u^2 = 1` (reduced), else ``None``.

    Polynomial division misses such multiples: the ring :math:`\mathbb Q[S, C]/(S^2 + C^2 - 1)` is not
    factorial, so :math:`\cos u` may divide a numerator although no polynomial factor shows it (a numerator that
    is :math:`\cos u\,g` only after :math:`C^2 \to 1 - S^2`). With :math:`\bar f` the product of the conjugates
    :math:`C_u \to -C_u` of ``f`` (so that :math:`N = f\bar f` reduced modulo the circles is free of cosines),
    ``f`` divides ``num`` iff :math:`N` divides the reduced :math:`\mathrm{num}\,\bar f`: the reduced forms are a
    free module over the polynomials in the sines with the square-free monomials in the cosines as basis, so
    exact division by :math:`N` is ordinary polynomial division, coefficient by coefficient.
    """
    cos_gens = R.gens[:npairs]
    # spurious factors are short (cos u, sin(u + v) expanded, ...); the norm of a long one is costly
    if len(f.terms()) > _CIRCLE_MAX_TERMS or not any(f.degree(C) > 0 for C in cos_gens):
        return None
    if _flint() is not None:
        return _divide_on_circles_flint(num, f, npairs)
    conj, norm = R.one, f
    for C in cos_gens:
        if norm.degree(C) > 0:
            c = norm.compose(C, -C)
            norm, conj = circle_rem(norm * c, npairs), conj * c
            if len(norm.terms()) > _CIRCLE_MAX_NORM:
                return None
    return exact_quotient(circle_rem(num * conj, npairs), norm)


def _divide_on_circles_flint(num: Any, f: Any, npairs: int) -> Any:
    """:func:`_divide_on_circles` in FLINT's polynomials: the norm in two angles has thousands of terms, and its
    products and reductions in sympy's (Python) took seconds. The reduction modulo the circles is the remainder of
    the division by each relation, whose leading term is :math:`C_i^2` in the lex order of the ring."""
    from flint.utils.flint_exceptions import DomainError

    n = len(f.ring.gens)
    g = _fmpq_context(n).gens()
    rel = [g[i] ** 2 + g[npairs + i] ** 2 - 1 for i in range(npairs)]

    def rem(p: Any) -> Any:
        for r in rel:
            p = divmod(p, r)[1]
        return p

    norm, top = _to_flint(f), _to_flint(num)
    if _not_a_multiple_at_a_point(top, norm, npairs):
        return None
    v = _angle_free_lead(norm, npairs)
    if v is not None:
        q = _divide_in(top, norm, v, rem)
        return None if q is None else _from_flint(q, f.ring)
    # the numerator times each conjugate in turn, reduced after each (times their product at once made a product
    # of thousands of terms by thousands: the three-link chain's locked inertia, 22 terms in two angles, has
    # conjugates of 22 and 400 terms)
    for i in range(npairs):
        if norm.degrees()[i] > 0:
            c = norm.compose(*[-g[j] if j == i else g[j] for j in range(n)])
            norm, top = rem(norm * c), rem(top * c)
            if len(norm) > _CIRCLE_MAX_NORM:
                return None
    try:
        q = top / norm
    except DomainError:  # not a multiple on the circles
        return None
    return _from_flint(q, f.ring)


def _angle_free_lead(f: Any, npairs: int) -> int | None:
    """A generator outside the angles in which ``f``'s leading coefficient holds no sine or cosine (the lowest
    degree, then the shortest coefficient), or None."""
    n = f.context().nvars()
    degrees = f.degrees()
    best, out = None, None
    terms = list(zip(f.monoms(), f.coeffs()))
    for v in range(2 * npairs, n):
        if degrees[v] == 0:
            continue
        lead = [m for m, _ in terms if m[v] == degrees[v]]
        if all(not any(m[: 2 * npairs]) for m in lead) and (best is None or (degrees[v], len(lead)) < best):
            best, out = (degrees[v], len(lead)), v
    return out


def _divide_in(num: Any, f: Any, v: int, rem: Any) -> Any:
    r"""``num / f`` on the circles by long division in the generator ``v`` (FLINT polynomials, ``rem`` the reduction
    modulo the circles), where ``f``'s leading coefficient ``b`` in ``v`` holds no angle; None if not a multiple.

    The reduced forms are a domain's, and multiplying one by ``b`` leaves it reduced: if ``num = q f`` on the
    circles, the leading coefficient of ``num`` in ``v`` is exactly ``b`` times ``q``'s, so each step's quotient is
    an exact polynomial division, and the remainder of lower degree in ``v`` is zero; a step that does not divide
    or a remainder left proves that ``num`` is not a multiple. The norm's route multiplies the numerator by the
    conjugates (the three-link chain's locked inertia: 190,000 terms divided by 3,113, for a quotient of 212)."""
    from flint.utils.flint_exceptions import DomainError

    ctx = f.context()

    def lead(p: Any) -> tuple[int, Any]:
        terms = list(zip(p.monoms(), p.coeffs()))
        k = max(m[v] for m, _ in terms)
        return k, ctx.from_dict({m[:v] + (0,) + m[v + 1 :]: c for m, c in terms if m[v] == k})

    d, b = lead(f)
    x = ctx.gens()[v]
    q = ctx.from_dict({})
    while not num.is_zero():
        k, a = lead(num)
        if k < d:
            return None
        try:
            t = (a / b) * x ** (k - d)
        except DomainError:
            return None
        q, num = q + t, rem(num - t * f)
    return q


def _not_a_multiple_at_a_point(num: Any, f: Any, npairs: int) -> bool:
    r"""True where ``f`` surely does not divide ``num`` on the circles (FLINT polynomials of :func:`_fmpq_context`):
    if :math:`\mathrm{num} = q f` modulo the circles, then at a point of the circles (rational:
    :math:`S = 2t/(1 + t^2)`, :math:`C = (1 - t^2)/(1 + t^2)`) with every other generator a number but one, ``v``,
    :math:`\mathrm{num}(v) = q(v) f(v)` exactly, so a nonzero remainder of the division of one polynomial in ``v``
    by the other proves that the division on the circles fails, for the cost of two substitutions (most divisions
    tried fail, and the test by the norm multiplies the numerator by the conjugates and reduces it). False where
    it cannot tell: no generator outside the angles in ``f``, or ``f(v)`` a number at the point."""
    n = num.context().nvars()
    degrees = f.degrees()
    free = [j for j in range(2 * npairs, n) if degrees[j] > 0]
    if not free:
        return False
    v = min(free, key=lambda j: degrees[j])
    flint = _flint()
    point: dict = {}
    for i in range(n):
        if i == v or (npairs <= i < 2 * npairs):
            continue
        if i < npairs:  # a point of the circle of angle i, its sine and cosine together
            t = flint.fmpq(_POINT[i % len(_POINT)], 7)
            point[f"x{i}"] = (1 - t**2) / (1 + t**2)
            point[f"x{npairs + i}"] = 2 * t / (1 + t**2)
        else:
            point[f"x{i}"] = flint.fmpq(_POINT[i % len(_POINT)], 5)
    fv, nv = (_univariate(p.subs(point), v) for p in (f, num))
    if fv.degree() < 1:
        return False
    return bool(divmod(nv, fv)[1])


#: Numerators of the test point's coordinates (no pattern among them that a mechanical formula would share).
_POINT = (3, 11, 5, 17, 2, 13, 19, 4, 23, 9, 29, 6, 31, 8)


def _univariate(p: Any, v: int) -> Any:
    """A FLINT polynomial in one generator (index ``v``; the others substituted) as an ``fmpq_poly``."""
    coeffs: dict[int, Any] = {}
    for mon, c in zip(p.monoms(), p.coeffs()):
        coeffs[mon[v]] = c
    if not coeffs:
        return _flint().fmpq_poly([])
    return _flint().fmpq_poly([coeffs.get(k, 0) for k in range(max(coeffs) + 1)])


def circle_rem(p: Any, npairs: int) -> Any:
    r"""The remainder of ``p`` modulo the circles :math:`C_i^2 + S_i^2 - 1`, where the ring's generators are
    :math:`(C_1, \dots, C_n, S_1, \dots, S_n, \dots)` with ``n = npairs`` in lex order: every :math:`C_i^{2k+e}` becomes
    :math:`C_i^e(1 - S_i^2)^k`. The relations' leading terms :math:`C_i^2` are coprime, so they are a Groebner basis
    and this is ``p.rem(relations)``, term by term (sympy's general division looks for the leading term of the
    whole remainder at every step: quadratic in the number of terms)."""
    if not npairs or all(max(m[:npairs]) < 2 for m in p.itermonoms()):
        return p
    zero = p.ring.domain.zero
    out: dict = {}
    for mon, c in p.iterterms():
        terms = [(mon, c)]
        for i in range(npairs):
            k = mon[i] // 2
            if not k:
                continue
            # C^(2k+e) -> C^e sum_j binom(k, j) (-S^2)^j
            expanded = []
            for m, cc in terms:
                m = list(m)
                m[i] -= 2 * k
                for j in range(k + 1):
                    mj = list(m)
                    mj[npairs + i] += 2 * j
                    expanded.append((tuple(mj), cc * math.comb(k, j) * (-1) ** j))
            terms = expanded
        for m, cc in terms:
            out[m] = out.get(m, zero) + cc
    return p.ring.from_dict({m: c for m, c in out.items() if c})


def _pythagoras(expr: sp.Expr, S: sp.Symbol, C: sp.Symbol) -> sp.Expr:
    """Write the factors (S - 1)(S + 1) of a factored product as -C**2 (they come from factoring 1 - S**2)."""
    minus, plus, one_minus, rest = 0, 0, 0, []
    for a in sp.Mul.make_args(expr):
        base, exp = a.as_base_exp()
        if exp.is_Integer and exp > 0 and base in (S - 1, S + 1, 1 - S):
            if base == S - 1:
                minus += int(exp)
            elif base == S + 1:
                plus += int(exp)
            else:
                one_minus += int(exp)
        else:
            rest.append(a)
    k1 = min(minus, plus)
    k2 = min(one_minus, plus - k1)
    if k1 + k2 == 0:
        return expr
    out = sp.Mul(*rest) * (-1) ** k1 * C ** (2 * (k1 + k2))
    return out * (S - 1) ** (minus - k1) * (1 - S) ** (one_minus - k2) * (S + 1) ** (plus - k1 - k2)


@lru_cache(maxsize=256)
def _ring(gens: tuple) -> Any:
    return sp.ring(gens, sp.QQ)[0]


def _simplify_expr_slow(e: sp.Expr, pairs: list, back: dict) -> sp.Expr:
    """The same reduction on sympy expressions (for coefficients outside the rationals, e.g. sqrt(2))."""
    num, den = sp.fraction(sp.together(e))
    num, den = _normal_form(num, pairs, True), _normal_form(den, pairs, True)
    if num == 0:
        return sp.Integer(0)
    num, den = sp.fraction(sp.cancel(num / den))
    if den.could_extract_minus_sign():
        num, den = -num, -den
    return (num / den).xreplace(back)


def _expand_in_ring(e: sp.Expr) -> sp.Expr | None:
    """``sympy.expand(e)`` of a rational function with rational coefficients in symbols and in sines and cosines
    of expanded arguments whose denominators are products of powers of polynomials, multiplied out in a sparse
    polynomial ring whose generators are those atoms (the same sum of terms; sympy's expand of a
    Lagrange-d'Alembert system took a tenth of the three-link chain's derivation). As sympy's expand, each term
    of the result is a monomial over the expanded product of the denominators it carries (``x (y + 1)/(a + b)``
    is ``x y/(a + b) + x/(a + b)``, ``x/((a + b) c)`` is ``x/(a c + b c)``). None for anything else (a root, a
    Float, another function, a denominator within a denominator, a term over a polynomial and a power of an atom
    at once, a numerator that is a multiple of its denominator's polynomial: there sympy's result depends on the
    order in which it builds the products, and sympy's expand is used)."""
    atoms: set = set()
    stack, seen = [e], set()
    while stack:
        x = stack.pop()
        if x in seen:
            continue
        seen.add(x)
        if x.is_Symbol:
            atoms.add(x)
        elif type(x) in (sp.sin, sp.cos):
            u = x.args[0]
            if not (u.is_Symbol or u.is_Rational or u == sp.expand(u)):
                return None
            atoms.add(x)
        elif x.is_Rational:
            continue
        elif x.is_Add or x.is_Mul:
            stack.extend(x.args)
        elif x.is_Pow and x.exp.is_Integer and x.exp != 0:
            stack.append(x.base)
        else:
            return None
    if not atoms:
        return None
    gens = sorted(atoms, key=sp.default_sort_key)
    R = _ring(tuple(gens))
    image = dict(zip(gens, R.gens))
    memo: dict = {}
    # an expression is {denominator: numerator}, the denominator a sorted tuple of (base, exponent) of sympy
    # expressions, each base a polynomial (its own key the empty tuple), () for none
    one: tuple = ()

    def times(d1: tuple, d2: tuple) -> tuple:
        if not d1 or not d2:
            return d1 or d2
        out = dict(d1)
        for base, k in d2:
            out[base] = out.get(base, 0) + k
        return tuple(sorted(out.items(), key=lambda bk: sp.default_sort_key(bk[0])))

    def convert(x: sp.Expr) -> dict:
        try:
            return memo[x]
        except KeyError:
            pass
        out: dict
        if x in image:
            out = {one: image[x]}
        elif x.is_Rational:
            out = {one: R(R.domain.convert(x))}
        elif x.is_Add:
            out = {}
            for a in x.args:
                for d, n in convert(a).items():
                    out[d] = out[d] + n if d in out else n
        elif x.is_Mul:
            out = {one: R.one}
            for a in x.args:
                new: dict = {}
                for d1, n1 in out.items():
                    for d2, n2 in convert(a).items():
                        d = times(d1, d2)
                        new[d] = new[d] + n1 * n2 if d in new else n1 * n2
                out = new
        elif x.exp > 0:
            out = {one: R.one}
            base = convert(x.base)
            for _ in range(int(x.exp)):
                new = {}
                for d1, n1 in out.items():
                    for d2, n2 in base.items():
                        d = times(d1, d2)
                        new[d] = new[d] + n1 * n2 if d in new else n1 * n2
                out = new
        else:
            base = convert(x.base)
            if set(base) != {one}:
                raise _Unsupported("a denominator within a denominator")
            out = {((x.base, -int(x.exp)),): R.one}
        memo[x] = out
        return out

    try:
        parts = convert(e)
    except _Unsupported:
        return None
    gindex = {g: i for i, g in enumerate(gens)}
    terms = []
    for d, n in parts.items():
        if not n:
            continue
        if not d:
            terms.append(as_expr(n, gens))
            continue
        # powers of atoms in the denominator cancel against the numerator's monomials (sympy's Mul combines
        # x * x**-2 as it is built); the polynomial bases stay whole, and where the numerator is a multiple of one
        # (sympy may have cancelled it as it built a product) sympy's own expand decides
        atom_k = [0] * len(gens)
        den = R.one
        for base, k in d:
            if base in gindex:
                atom_k[gindex[base]] += k
            else:
                b = convert(base)[one]
                if exact_quotient(n, b) is not None:
                    return None
                den *= b**k
        if den != 1 and any(atom_k):  # both: where sympy cancels the atoms depends on the order it builds in
            return None
        dens: dict = {}
        for mon, c in n.iterterms():
            kept = tuple(max(m - k, 0) for m, k in zip(mon, atom_k))
            rest = tuple(max(k - m, 0) for m, k in zip(mon, atom_k))
            # the coefficient's denominator joins the term's denominator, expanded with it (9/(7 (b + y)) is
            # 9/(7 b + 7 y) in sympy's expand)
            key = (rest, c.denominator)
            if key not in dens:
                dens[key] = sp.Pow(as_expr(den * R({rest: R.domain(int(c.denominator))}), gens), -1)
            terms.append(as_expr(R({kept: R.domain(int(c.numerator))}), gens) * dens[key])
    return sp.Add(*terms)


def expand_terms(e: Any) -> Any:
    """``e`` (an expression or a matrix) expanded into a sum of terms, with every root (a power whose exponent is
    not an integer, such as the distance of a potential) kept whole: ``sympy.expand`` would expand its argument
    and spread the argument's denominators over it (the planar three-body's equations grew a thousandfold)."""
    if isinstance(e, sp.MatrixBase):
        return e.applyfunc(expand_terms)
    e = sp.sympify(e)
    fast = _expand_in_ring(e)
    if fast is not None:
        return fast
    roots = [p for p in e.atoms(sp.Pow) if not p.exp.is_Integer]
    if not roots:
        return sp.expand(e)
    keep = {r: sp.Dummy() for r in roots}
    return sp.expand(e.xreplace(keep)).xreplace({d: r for r, d in keep.items()})


def tidy_trig(e: sp.Expr) -> sp.Expr:
    """Expand, trade sin^2 for 1 - cos^2, and only then trigsimp: much faster than ``simplify`` on the
    polynomials in sines and cosines of a mass matrix."""
    e = sp.expand(e)
    e = sp.expand(e.xreplace({sp.sin(s) ** 2: 1 - sp.cos(s) ** 2 for s in e.free_symbols}))
    if e.has(sp.sin, sp.cos):
        e = sp.trigsimp(e)
    return sp.factor_terms(e)


def simplify_matrix(M: sp.MatrixBase) -> sp.ImmutableMatrix:
    """:func:`simplify_expr` entry by entry."""
    return sp.ImmutableMatrix(sp.Matrix(M).applyfunc(simplify_expr))


def inverse(M: sp.MatrixBase) -> sp.Matrix:
    """The inverse of a square matrix by LU, :math:`M^{-1} = M \\ I` (not simplified).

    The same result as ``M.inv(method="LU")`` without its up-front invertibility test: that test computes the
    determinant and proves it nonzero with ``Expr.equals``, which costs far more than the inverse for the
    metrics met here (tens of seconds for a 3 x 3 metric). A structurally singular matrix still raises sympy's
    ``NonInvertibleMatrixError`` (a ``ValueError``) from the elimination.
    """
    M = sp.Matrix(M)
    if M.rows != M.cols:
        raise sp.matrices.exceptions.NonSquareMatrixError(f"Expected a square matrix, got shape {M.shape}.")
    if M.rows == 0:
        return sp.zeros(0, 0)
    return M.LUsolve(sp.eye(M.rows))


def simplified_inverse(M: sp.MatrixBase) -> sp.ImmutableMatrix:
    """The inverse of a square matrix, simplified entry by entry (:func:`simplify_expr`).

    Up to 3 x 3 it is the adjugate over the determinant, each simplified once: the determinant's factors are then
    known to the simplifier, which cancels them (also on the circles S^2 + C^2 = 1). Through the LU factors the
    entries are nested fractions whose simplification meets the determinant's numerator as one long irreducible
    polynomial and cannot cancel it (a 2 x 2 shape mass of the three-link chain: 72 s and 1.6 million operations
    an entry, against 0.4 s and a thousand). Larger matrices: :func:`inverse`, simplified. Raises sympy's
    ``NonInvertibleMatrixError`` (a ``ValueError``) where the determinant simplifies to zero.
    """
    M = sp.Matrix(M)
    if M.rows != M.cols or M.rows == 0 or M.rows > 3:
        return simplify_matrix(inverse(M))
    from sympy.matrices.utilities import dotprodsimp

    with dotprodsimp(False):  # sympy's det of a small matrix expands its entries by default
        det, adj = M.det(method="berkowitz"), M.adjugate(method="berkowitz")
    det = simplify_expr(det)
    if det == 0:
        raise sp.matrices.exceptions.NonInvertibleMatrixError("Matrix det == 0; not invertible.")
    return sp.ImmutableMatrix(M.rows, M.cols, [simplify_expr(simplify_expr(a) / det) for a in adj])


def time_derivative(expr: Any, coords: Sequence[sp.Symbol], rates: Sequence[sp.Symbol]) -> Any:
    """Time derivative of an expression (or matrix) that depends on time through ``coords`` only."""
    zero = sp.zeros(*expr.shape) if isinstance(expr, sp.MatrixBase) else sp.Integer(0)
    return sum((derivative(expr, c) * v for c, v in zip(coords, rates)), zero)


def quadratic_coefficients(expr: Any, variables: Sequence[sp.Symbol]) -> dict[tuple[int, ...], sp.Expr]:
    """The coefficients of ``expr`` as a polynomial of degree at most 2 in ``variables``: a dict from the sorted
    indices of a monomial (``()``, ``(i,)``, ``(i, j)`` with ``i <= j``) to its coefficient, which is free of the
    variables.

    Only the products that hold a variable are multiplied out (the coefficients keep their form: a Hessian by
    ``diff`` walks the whole expression once per entry, this walks it once). Raises :class:`SymbolicError` where
    ``expr`` is not such a polynomial (a variable inside a function or a denominator, or a degree above 2).
    """
    index = {v: i for i, v in enumerate(variables)}
    names = set(index)

    def poly(e: sp.Expr) -> dict[tuple[int, ...], list]:
        if not (e.free_symbols & names):
            return {(): [e]}
        if e in index:
            return {(index[e],): [sp.Integer(1)]}
        if e.is_Add:
            out: dict[tuple[int, ...], list] = {}
            for a in e.args:
                for mon, cs in poly(a).items():
                    out.setdefault(mon, []).extend(cs)
            return out
        if e.is_Mul:
            free, dep = e.as_independent(*variables, as_Add=False)
            out = {(): [free]}
            for f in sp.Mul.make_args(dep):
                out = product(out, poly(f))
            return out
        if e.is_Pow and e.exp.is_Integer and 0 < e.exp <= 2:
            base = poly(e.base)
            return product(base, base) if e.exp == 2 else base
        raise SymbolicError(f"Expected a polynomial of degree <= 2 in {list(variables)}, got the factor {e}.")

    def product(a: dict, b: dict) -> dict[tuple[int, ...], list]:
        out: dict[tuple[int, ...], list] = {}
        sums = {mb: sp.Add(*cb) for mb, cb in b.items()}
        for ma, ca in a.items():
            fa = sp.Add(*ca)
            for mb, fb in sums.items():
                mon = tuple(sorted(ma + mb))
                if len(mon) > 2:
                    raise SymbolicError(f"Expected a polynomial of degree <= 2 in {list(variables)}, got {expr}.")
                out.setdefault(mon, []).append(fa * fb)
        return out

    return {mon: sp.Add(*cs) for mon, cs in poly(sp.sympify(expr)).items()}


def quadratic_blocks(expr: Any, x: Sequence[sp.Symbol], y: Sequence[sp.Symbol] = ()) -> tuple[sp.Matrix, ...]:
    r"""``(Q, R, S)`` with :math:`x^T Q x + x^T R y + y^T S y` the quadratic part of ``expr`` in ``(x, y)`` (``Q``,
    ``S`` symmetric: half the Hessians; ``R`` the mixed second derivatives), from :func:`quadratic_coefficients`."""
    c = quadratic_coefficients(expr, list(x) + list(y))
    nx, ny = len(x), len(y)

    def sym(offset: int, n: int) -> sp.Matrix:
        return sp.Matrix(
            n, n, lambda i, j: c.get((offset + min(i, j), offset + max(i, j)), sp.Integer(0)) / (1 if i == j else 2)
        )

    return sym(0, nx), sp.Matrix(nx, ny, lambda i, j: c.get((i, nx + j), sp.Integer(0))), sym(nx, ny)


def quadratic_form(expr: Any, variables: Sequence[sp.Symbol]) -> sp.Matrix:
    """The symmetric matrix :math:`Q` of the quadratic part :math:`x^T Q x` of ``expr`` in ``variables`` (half
    its Hessian)."""
    return quadratic_blocks(expr, variables)[0]


def half_quadratic(Q: Any, variables: Sequence[sp.Symbol]) -> sp.Expr:
    r""":math:`\tfrac12 x^TQx` of a symmetric matrix ``Q`` as a sum of its entries times monomials,
    :math:`\sum_a \tfrac12 Q_{aa}x_a^2 + \sum_{a<b} Q_{ab}x_ax_b`: a kinetic energy or a Hamiltonian written
    with the (simplified) entries of its metric, rather than one fraction over their common denominator."""
    Q, x = sp.Matrix(Q), list(variables)
    if Q.shape != (len(x), len(x)):
        raise ValueError(f"Expected a {len(x)} x {len(x)} matrix for the variables {x}, got {Q.shape}.")
    terms = [Q[a, a] * x[a] ** 2 / 2 for a in range(len(x))]
    terms += [Q[a, b] * x[a] * x[b] for a in range(len(x)) for b in range(a + 1, len(x))]
    return sp.Add(*terms)


def clear_denominators(v: sp.MatrixBase) -> sp.Matrix:
    """Scale a vector so that its entries have no common denominator (and no common numeric factor)."""
    entries = [sp.together(TR2(e)) for e in v]
    lcm = sp.Integer(1)
    for e in entries:
        lcm = sp.lcm(lcm, sp.fraction(e)[1])
    out = sp.Matrix([simplify_expr(e * lcm) for e in entries])
    nz = [e for e in out if e != 0]
    if nz:
        g = sp.gcd_list([sp.factor_terms(e).as_coeff_Mul()[0] for e in nz])
        if g not in (0, 1):
            out = out / g
    return out


def vanishes(expr: Any, tries: int = 3) -> bool:
    """Whether ``expr`` (an expression, or every entry of a matrix or sequence) is identically zero.

    A screen first: the expression is evaluated exactly (30 digits) at ``tries`` random rational points of
    its free symbols in [-0.9, 0.9]; a value above 1e-20 proves it is not zero, at no cost of simplification
    (a long trigonometric expression that is zero costs the evaluations only). Where the screen passes,
    :func:`simplify_expr`, then ``sympy.simplify``, decide exactly. Points where an entry has a pole give no
    information and are skipped. The points are fixed by the number of symbols: the answer is reproducible.
    """
    items = list(expr) if isinstance(expr, (sp.MatrixBase, list, tuple)) else [expr]
    entries = [sp.sympify(e) for e in items]
    entries = [e for e in entries if e != 0]
    if not entries:
        return True
    symbols = sorted(set().union(*(e.free_symbols for e in entries)), key=str)
    rng = np.random.default_rng(len(symbols))
    for _ in range(tries):
        point = {v: sp.Rational(int(rng.integers(-900, 901)), 1000) for v in symbols}
        for e in entries:
            try:
                value = complex(e.xreplace(point).evalf(30))
            except (TypeError, ValueError):  # a pole here: no information
                continue
            if np.isfinite(value) and abs(value) > 1e-20:
                return False
    return all(simplify_expr(e) == 0 or sp.simplify(e) == 0 for e in entries)
