"""Symbolic and numeric helpers of the nonholonomic reduction: simplification of trigonometric rational
functions, time derivatives along shape curves, compiling derived expressions to numpy, and the caches of the
derivations (in memory, shared by systems that differ only in parameter values, and on disk, shared by
processes)."""

from __future__ import annotations

import copy
import hashlib
import json
import pickle
from collections.abc import Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from sympy.simplify.fu import TR2

from .._storage import cache_subdir, write_atomic
from .._symbolic import compile_vector

__all__ = ["Derived", "Labelled", "shared_property", "shared_value", "simplify_expr", "simplify_matrix",
           "time_derivative", "stack_last", "clear_denominators", "inverse", "cache_dir", "DiskCache", "DISK_CACHE"]

#: Above this many terms in a numerator, factoring is skipped (it dominates the cost, and longer numerators
#: of the examples are irreducible).
_FACTOR_MAX_TERMS = 48
#: Factors of a denominator longer than this are not tested for division on the circles S^2 + C^2 = 1.
_CIRCLE_MAX_TERMS = 24


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
    a short numerator is factored. Expressions outside this class fall back to ``sympy.trigsimp``.
    """
    expr = sp.sympify(expr)
    if not expr.free_symbols:
        return sp.simplify(expr)
    e = sp.expand_trig(TR2(expr))
    args = sorted({t.args[0] for t in e.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    pairs, fwd, back = [], {}, {}
    # named after the angle (not Dummy): the same polynomial is then the same expression in every call, and the
    # factorizations of denominators are shared (_FACTORS); Dummy if two angles print alike
    named = len({str(u) for u in args}) == len(args)
    for i, u in enumerate(args):
        S, C = (sp.Symbol(f"_sin({u})"), sp.Symbol(f"_cos({u})")) if named else (sp.Dummy(f"S{i}"), sp.Dummy(f"C{i}"))
        pairs.append((S, C))
        fwd[sp.sin(u)], fwd[sp.cos(u)] = S, C
        back[S], back[C] = sp.sin(u), sp.cos(u)
    e = e.xreplace(fwd)
    if e.atoms(sp.Function) or any(not p.exp.is_Integer for p in e.atoms(sp.Pow)):
        return sp.trigsimp(expr)
    # Work in a sparse polynomial ring (much faster than expanding sympy expressions), reduced modulo
    # S^2 + C^2 - 1 always to the same normal form (cosines to the power 0 or 1), so that an expression equal to
    # zero is recognised and a denominator met in several derived objects is the same polynomial everywhere.
    others = sorted(e.free_symbols - {x for pr in pairs for x in pr}, key=sp.default_sort_key)
    gens = tuple(C for _, C in pairs) + tuple(S for S, _ in pairs) + tuple(others)
    try:
        R = _ring(gens)
        rel = [R.gens[i] ** 2 + R.gens[len(pairs) + i] ** 2 - 1 for i in range(len(pairs))]
        n_, den = _Fractions(R, rel).convert(e)
    except (ValueError, TypeError, ZeroDivisionError, sp.polys.polyerrors.PolynomialError, sp.CoercionFailed,
            _Unsupported):
        return _simplify_expr_slow(e, pairs, back)
    if not n_:
        return sp.Integer(0)
    n_, den = _cancel_factors(n_, den, R, len(pairs), rel)
    num = n_.as_expr()
    # The denominator is kept as the product of its irreducible factors (readable, and no costly gcd).
    den = sp.Mul(*[f.as_expr() ** k for f, k in sorted(den.items(), key=lambda fk: sp.default_sort_key(fk[0].as_expr()))
                   if k])
    if len(n_.terms()) <= _FACTOR_MAX_TERMS:
        num = _factor(n_)
    for S, C in pairs:
        num, den = _pythagoras(num, S, C), _pythagoras(den, S, C)
    if den.could_extract_minus_sign():
        num, den = -num, -den
    return (num / den).xreplace(back)


@lru_cache(maxsize=4096)
def _factor(p: Any) -> sp.Expr:
    """A ring polynomial as a product of its irreducible factors (cached: the same numerator recurs)."""
    content, factors = p.factor_list()
    return sp.Mul(sp.Rational(content.numerator, content.denominator),
                  *[f.as_expr() ** k for f, k in factors])


class _Unsupported(Exception):
    pass


#: Factorizations of denominators (expressions in the angle-named sine and cosine symbols), shared by calls.
_FACTORS: dict = {}


class _Fractions:
    """Rational functions as ``(numerator, {irreducible factor: multiplicity})`` over a polynomial ring.

    Converting a sympy expression bottom up keeps every denominator factored: a sum takes the lcm of the
    factored denominators (no gcd of large polynomials, the cost of ``together`` followed by ``cancel`` on
    nested expressions), a negative power factors only its base (short, usually). Numerators are reduced
    modulo the circle relations ``rel`` after every product.
    """

    def __init__(self, R: Any, rel: list):
        self.R, self.rel = R, rel
        self.gen = {g.as_expr(): g for g in R.gens}
        self.memo: dict = {}
        self.factors: dict = {}

    def reduce(self, p: Any) -> Any:
        return p.rem(self.rel) if self.rel else p

    def factor(self, p: Any) -> tuple[Any, list]:
        p = self.reduce(p)
        if not p:
            raise ZeroDivisionError("a denominator vanishes identically")
        if p.is_ground:
            return p.LC, []
        if p not in self.factors:
            key = p.as_expr()
            if key not in _FACTORS:
                content, facs = p.factor_list()
                _FACTORS[key] = (content, [(f.as_expr(), k) for f, k in facs])
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
        if e.is_Symbol:
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


def _cancel_factors(num: Any, den: dict, R: Any, npairs: int, rel: list) -> tuple[Any, dict]:
    """Divide ``num`` by the factors of ``den`` it is a multiple of: as polynomials, or on the circles
    (:func:`_divide_on_circles`)."""
    den = dict(den)
    for f in list(den):
        while den[f]:
            q, r = num.div(f)
            if r:
                q = _divide_on_circles(num, f, R, npairs, rel) if rel else None
                if q is None:
                    break
            num, den[f] = q, den[f] - 1
    return num, den


def _divide_on_circles(num: Any, f: Any, R: Any, npairs: int, rel: list) -> Any:
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
    conj, norm = R.one, f
    for C in cos_gens:
        if norm.degree(C) > 0:
            c = norm.compose(C, -C)
            norm, conj = (norm * c).rem(rel), conj * c
    q, r = (num * conj).rem(rel).div(norm)
    return None if r else q


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


def time_derivative(expr: Any, coords: Sequence[sp.Symbol], rates: Sequence[sp.Symbol]) -> Any:
    """Time derivative of an expression (or matrix) that depends on time through ``coords`` only."""
    zero = sp.zeros(*expr.shape) if isinstance(expr, sp.MatrixBase) else sp.Integer(0)
    return sum((sp.diff(expr, c) * v for c, v in zip(coords, rates)), zero)


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


def stack_last(*arrays: Any) -> np.ndarray:
    """Concatenate along the last axis after broadcasting the leading (batch) axes only."""
    arrs = [np.asarray(a, dtype=float) for a in arrays]
    arrs = [a[..., None] if a.ndim == 0 else a for a in arrs]
    batch = np.broadcast_shapes(*(a.shape[:-1] for a in arrs))
    return np.concatenate([np.broadcast_to(a, batch + a.shape[-1:]) for a in arrs], axis=-1)


#: Derived symbolic objects and compiled kernels, shared by every object with the same symbolic content
#: (``_cache_key``): systems that differ only in their parameter values share all symbolic work.
_SHARED: dict = {}

#: Bump when the layout of cached entries changes.
_CACHE_FORMAT = "1"
#: The modules whose code determines the derived objects: their source is part of every on-disk key, so that an
#: edited derivation never reads results of the code before it.
_SOURCES = ("reduction/nonholonomic.py", "reduction/lagrange_dalembert.py",
            "reduction/nonholonomic_symbolic.py", "reduction/almost_poisson.py",
            "systems/nonholonomic.py")


def cache_dir() -> Path | None:
    """Directory of the derivation cache: ``derivations`` in the cache (:mod:`geomech._storage`:
    ``$GEOMECH_CACHE_DIR``, else ``$XDG_CACHE_HOME/geomech``, else ``~/.cache/geomech``); ``None`` (no disk
    cache) when ``GEOMECH_CACHE_DIR`` is ``off``, ``0`` or empty, or the directory is not private."""
    return cache_subdir("derivations")


@lru_cache(maxsize=1)
def _code_fingerprint() -> str:
    from .. import __version__

    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256(f"geomech {__version__} sympy {sp.__version__} format {_CACHE_FORMAT}".encode())
    for rel in _SOURCES:
        try:
            h.update((root / rel).read_bytes())
        except OSError:
            h.update(rel.encode())
    return h.hexdigest()


class DiskCache:
    """Pickled symbolic results under :func:`cache_dir`, one file per derived object.

    A file's name hashes the system's symbolic content (``system.key``, printed with ``srepr``: exact, and the
    same in every process), the object's own key, the geomech and sympy versions and the source of the
    derivation modules. A file that cannot be read or unpickled (truncated, corrupted, from an incompatible
    version) is ignored and rewritten; writes go to a temporary file that is renamed, so a reader never sees a
    partial file. Failing to write (read-only home, full disk) only costs the next process the derivation.
    """

    def __init__(self) -> None:
        self.hits = 0
        self.misses = 0

    def path(self, system_key: Any, key: Any) -> Path | None:
        root = cache_dir()
        if root is None:
            return None
        h = hashlib.sha256(_code_fingerprint().encode())
        h.update(sp.srepr(system_key).encode())
        h.update(b"\0")
        h.update(sp.srepr(key).encode())
        digest = h.hexdigest()
        return root / digest[:2] / f"{digest}.pkl"

    def load(self, system_key: Any, key: Any) -> Any:
        """The stored value, or :data:`MISSING`."""
        path = self.path(system_key, key)
        if path is None or not path.is_file():
            self.misses += 1
            return MISSING
        try:
            with path.open("rb") as fh:
                stored_key, value = pickle.load(fh)
            if stored_key != sp.srepr(key):
                raise ValueError("key mismatch")
        except Exception:  # a damaged or foreign file: recompute (and overwrite) rather than fail
            self.misses += 1
            return MISSING
        self.hits += 1
        return value

    def save(self, system_key: Any, key: Any, value: Any) -> None:
        path = self.path(system_key, key)
        if path is None:
            return
        try:
            data = pickle.dumps((sp.srepr(key), value), protocol=pickle.HIGHEST_PROTOCOL)
            path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
            write_atomic(path, data)
        except (OSError, pickle.PicklingError, TypeError, AttributeError, RecursionError):
            pass


MISSING = object()
#: The process-wide on-disk cache of derived symbolic objects.
DISK_CACHE = DiskCache()


def shared_value(obj: Any, name: str, compute: Any, extra: Any = ()) -> Any:
    """The derived object ``name`` of ``obj``: from memory (shared by every object with the same ``_cache_key``),
    else from the disk cache, else ``compute()`` (then stored in both)."""
    key = (type(obj).__name__, obj._cache_key, name) + ((extra,) if extra != () else ())
    try:
        return _SHARED[key]
    except KeyError:
        pass
    system_key = obj.system.key
    value = DISK_CACHE.load(system_key, key)
    if value is MISSING:
        value = compute()
        DISK_CACHE.save(system_key, key, value)
    _SHARED[key] = value
    return value


class shared_property:
    """Like ``functools.cached_property``, but stored under the owner's ``_cache_key`` (its symbolic content), so
    that a derivation done for one object is reused by every equivalent one, in this process (memory) and in
    later ones (:class:`DiskCache`)."""

    def __init__(self, func: Any):
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return shared_value(obj, self.name, lambda: self.func(obj))


class NumericCache:
    """Compile expressions with the parameter values substituted, once per set of values (shared store)."""

    system: Any

    def _compile(self, values: Mapping[str, float] | None, exprs: dict, variables: Sequence[sp.Symbol]) -> dict:
        pv = self.system.parameter_values(values)
        key = (type(self).__name__, self._cache_key, "compiled", tuple(sorted((s.name, v) for s, v in pv.items())),
               tuple(exprs), tuple(variables))
        cache = _SHARED
        if key not in cache:
            out = {}
            for name, e in exprs.items():
                e = sp.Matrix(e) if isinstance(e, (sp.MatrixBase, list, tuple)) else sp.Matrix([e])
                out[name] = _compile_matrix(e.subs(pv), variables)
            cache[key] = out
        return cache[key]


def _compile_matrix(e: sp.Matrix, variables: Sequence[sp.Symbol]):
    """Like :func:`geomech._symbolic.compile_vector`, also for matrices with a zero dimension."""
    if e.rows == 0 or e.cols == 0:
        shape = e.shape

        def empty(x: np.ndarray) -> np.ndarray:
            x = np.asarray(x, dtype=float)
            return np.zeros(x.shape[:-1] + shape)

        return empty
    if not variables:
        const = np.array(e.evalf(), dtype=float)

        def constant(x: np.ndarray) -> np.ndarray:
            x = np.asarray(x, dtype=float)
            return np.broadcast_to(const, x.shape[:-1] + const.shape).copy()

        return constant
    return compile_vector(e.tolist(), variables)


class Labelled(tuple):
    """Derived values with names: a tuple of ``(text_label, latex_label, value)``; printed as a JSON object
    ``{text_label: value}``, as one ``label = value`` line each in text, and as ``latex_label = value`` in LaTeX."""

    def as_dict(self) -> dict:
        return {label: value for label, _, value in self}


def _as_text(value: Any) -> Any:
    if isinstance(value, Labelled):
        return {label: _as_text(v) for label, _, v in value}
    if isinstance(value, sp.MatrixBase):
        return [[str(value[i, j]) for j in range(value.cols)] for i in range(value.rows)]
    if isinstance(value, sp.Basic):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _as_text(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_as_text(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


TEXT_LIMIT = 600  # characters of one expression in readable text; JSON and LaTeX always hold all of it


def _short(expr: Any) -> str:
    text = str(expr)
    if len(text) <= TEXT_LIMIT:
        return text
    return f"<{len(text)} characters, {sp.count_ops(expr)} operations: see the JSON or LaTeX output or the attribute>"


def _short_text(value: Any) -> Any:
    if isinstance(value, sp.Basic):
        return _short(value)
    if isinstance(value, (list, tuple)):
        return [_short_text(v) for v in value]
    if isinstance(value, sp.MatrixBase):
        return [[_short(value[i, j]) for j in range(value.cols)] for i in range(value.rows)]
    return _as_text(value)


class Derived:
    """Mixin of every derived object: readable text, LaTeX and JSON. A subclass provides :meth:`items`, a list of
    ``(name, latex_name, value)`` (sympy values or lists of them), and :meth:`_latex_names` for its symbols."""

    title: str = ""

    def items(self) -> list[tuple[str, str, Any]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _latex_names(self) -> dict:
        return {}

    def _latex(self, value: Any) -> str:
        names = self._latex_names()
        if isinstance(value, Labelled):
            return r",\; ".join(f"{tex} = {self._latex(v)}" for _, tex, v in value)
        if isinstance(value, (list, tuple)):
            return r",\; ".join(self._latex(v) for v in value)
        if isinstance(value, (sp.Basic, sp.MatrixBase)):
            return sp.latex(value, symbol_names=names)
        return str(value)

    def to_latex(self) -> str:
        """LaTeX, one ``name = value`` line per derived object."""
        return "\n".join(f"{tex} = {self._latex(v)}" for _, tex, v in self.items())

    def to_text(self) -> str:
        """Readable text, one ``name = value`` block per derived object; an expression longer than
        ``TEXT_LIMIT`` characters is replaced by its size (the JSON and LaTeX outputs hold it in full)."""
        lines = [self.title] if self.title else []
        for name, _, value in self.items():
            if isinstance(value, Labelled):
                lines.append(f"{name}:")
                lines += [f"  {label} = {_short_text(v)}" for label, _, v in value]
            elif isinstance(value, sp.MatrixBase):
                rows = ["[" + ", ".join(_short(value[i, j]) for j in range(value.cols)) + "]"
                        for i in range(value.rows)]
                lines.append(f"{name} = [" + (",\n" + " " * (len(name) + 4)).join(rows) + "]")
            else:
                lines.append(f"{name} = {_short_text(value)}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """A JSON-ready dict: every value as text (sympy ``str``) and as LaTeX (cached with the derivation: printing
        long expressions costs as much as deriving them)."""

        def render() -> dict:
            items = self.items()
            return {"title": self.title,
                    "text": {name: _as_text(v) for name, _, v in items},
                    "latex": {name: self._latex(v) for name, _, v in items}}

        return copy.deepcopy(shared_value(self, "to_dict", render))

    def to_json(self, **kwargs: Any) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), **kwargs)

    def __str__(self) -> str:
        return self.to_text()
