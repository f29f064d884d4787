"""Simplification of the rational trigonometric expressions of mechanics, exact where it matters: an expression
equal to zero is recognised as zero (every Jacobiator, every invariance check depends on it), denominators are
kept factored, and each step is bounded in size so that a derivation takes seconds."""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np
import sympy as sp
from sympy.simplify.fu import TR2

from ..errors import SymbolicError
from ._derivative import derivative
from .polys import (
    _divide_on_circles,
    _ring,
    _Unsupported,
    as_expr,
    circle_rem,
    exact_quotient,
    factor_list,
)

__all__ = [
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
    "vanishes",
]

#: Above this many terms in a numerator, factoring is skipped (it dominates the cost, and longer numerators
#: of the examples are irreducible).
_FACTOR_MAX_TERMS = 48


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


@lru_cache(maxsize=4096)
def _factor(p: Any) -> sp.Expr:
    """A ring polynomial as a product of its irreducible factors (cached: the same numerator recurs)."""
    content, factors = factor_list(p)
    return sp.Mul(sp.Rational(content.numerator, content.denominator), *[as_expr(f) ** k for f, k in factors])


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
