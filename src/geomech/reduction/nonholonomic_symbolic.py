"""Symbolic and numeric helpers of the nonholonomic reduction: simplification of trigonometric rational
functions, time derivatives along shape curves, and compiling derived expressions to numpy."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from functools import lru_cache
from typing import Any

import numpy as np
import sympy as sp
from sympy.simplify.fu import TR2

from .._symbolic import compile_vector

__all__ = ["Derived", "shared_property", "simplify_expr", "simplify_matrix", "time_derivative", "stack_last",
           "clear_denominators"]

#: Above this many terms in a numerator, factoring is skipped (it dominates the cost and rarely helps).
_FACTOR_MAX_TERMS = 150


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
    a pair of symbols :math:`S_u, C_u`; the fraction is cancelled and its numerator and denominator are
    reduced modulo :math:`S_u^2 + C_u^2 - 1` (a Groebner basis, so an expression equal to zero is recognised
    exactly; even powers of cosines are eliminated), then factored. Expressions outside this class fall back to
    ``sympy.trigsimp``.
    """
    expr = sp.sympify(expr)
    if not expr.free_symbols:
        return sp.simplify(expr)
    e = sp.expand_trig(TR2(expr))
    args = sorted({t.args[0] for t in e.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    pairs, fwd, back = [], {}, {}
    for i, u in enumerate(args):
        S, C = sp.Dummy(f"S{i}"), sp.Dummy(f"C{i}")
        pairs.append((S, C))
        fwd[sp.sin(u)], fwd[sp.cos(u)] = S, C
        back[S], back[C] = sp.sin(u), sp.cos(u)
    e = e.xreplace(fwd)
    if e.atoms(sp.Function) or any(not p.exp.is_Integer for p in e.atoms(sp.Pow)):
        return sp.trigsimp(expr)
    # Work in a sparse polynomial ring (much faster than expanding sympy expressions); reduce numerator and
    # denominator modulo S^2 + C^2 - 1 before cancelling (the gcd is the costly step), always to the same
    # normal form (cosines to the power 0 or 1), so that a denominator met in several derived objects is the
    # same polynomial everywhere and cancels cheaply when they are combined.
    num, den = sp.fraction(sp.together(e))
    others = sorted(e.free_symbols - {x for pr in pairs for x in pr}, key=sp.default_sort_key)
    gens = tuple(C for _, C in pairs) + tuple(S for S, _ in pairs) + tuple(others)
    try:
        R = _ring(gens)
        n_, d_ = R.from_expr(num), R.from_expr(den)
    except (ValueError, TypeError, sp.polys.polyerrors.PolynomialError, sp.CoercionFailed):
        return _simplify_expr_slow(e, pairs, back)
    rel = [R.gens[i] ** 2 + R.gens[len(pairs) + i] ** 2 - 1 for i in range(len(pairs))]
    if rel:
        n_, d_ = n_.rem(rel), d_.rem(rel)
    if not n_:
        return sp.Integer(0)
    n_, d_ = n_.cancel(d_)
    num, den = n_.as_expr(), d_.as_expr()
    # Factoring the denominator (a product of a few powers, usually) is cheap and makes it readable.
    if len(d_.terms()) <= 4 * _FACTOR_MAX_TERMS:
        den = sp.factor(den)
    if len(n_.terms()) <= _FACTOR_MAX_TERMS:
        num = sp.factor(num)
    for S, C in pairs:
        num, den = _pythagoras(num, S, C), _pythagoras(den, S, C)
    if den.could_extract_minus_sign():
        num, den = -num, -den
    return (num / den).xreplace(back)


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


class shared_property:
    """Like ``functools.cached_property``, but stored under the owner's ``_cache_key`` (its symbolic content), so
    that a derivation done for one object is reused by every equivalent one."""

    def __init__(self, func: Any):
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        key = (type(obj).__name__, obj._cache_key, self.name)
        try:
            return _SHARED[key]
        except KeyError:
            value = _SHARED[key] = self.func(obj)
            return value


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


def _as_text(value: Any) -> Any:
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
            if isinstance(value, sp.MatrixBase):
                rows = ["[" + ", ".join(_short(value[i, j]) for j in range(value.cols)) + "]"
                        for i in range(value.rows)]
                lines.append(f"{name} = [" + (",\n" + " " * (len(name) + 4)).join(rows) + "]")
            else:
                lines.append(f"{name} = {_short_text(value)}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """A JSON-ready dict: every value as text (sympy ``str``) and as LaTeX."""
        return {
            "title": self.title,
            "text": {name: _as_text(v) for name, _, v in self.items()},
            "latex": {name: self._latex(v) for name, _, v in self.items()},
        }

    def to_json(self, **kwargs: Any) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), **kwargs)

    def __str__(self) -> str:
        return self.to_text()
