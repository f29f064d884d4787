"""Sparse polynomial rings over the rationals whose generators are symbols, sines and cosines: the arithmetic under
:mod:`.simplify` and the derivations' expansions. FLINT's multivariate factorization and exact division where
python-flint is installed; the reduction modulo the circles :math:`S_u^2 + C_u^2 = 1` and division on them (a
numerator that is a multiple of a denominator factor only there); ring elements to sympy expressions in sympy's
own canonical form; ``sympy.expand`` of polynomials and rational functions done in the ring."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import sympy as sp
from sympy.core.basic import _args_sortkey

__all__ = [
    "as_expr",
    "circle_rem",
    "exact_quotient",
    "expand_terms",
    "factor_list",
]


#: Factors of a denominator longer than this are not tested for division on the circles S^2 + C^2 = 1.
_CIRCLE_MAX_TERMS = 24
#: Nor are those whose norm (the product of their conjugates in the cosines, reduced) has more terms than this:
#: the three-link chain's locked inertia, 22 terms in two angles, has a norm of 3113 terms and divides its shape
#: mass's numerators (a sixteenth of their size after the division), in milliseconds with FLINT.
_CIRCLE_MAX_NORM = 20000


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


@lru_cache(maxsize=256)
def _ring(gens: tuple) -> Any:
    return sp.ring(gens, sp.QQ)[0]


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
