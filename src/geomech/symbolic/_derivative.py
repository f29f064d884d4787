"""First derivatives of the derived formulas, remembered.

The derivations differentiate the same expressions many times over (the Lagrangian and its momenta in every
reduction, the entries of a mass matrix in each of its Christoffel symbols, a tensor's entries in each Jacobiator),
and sympy's ``diff`` builds a ``Derivative`` at every node of every tree it walks (its free symbols, an ``is_zero``
query and a ``replace`` pass each time): for the three-link chains, 150,000 such calls were a quarter of a cold
``geomech derive``. :func:`derivative` applies sympy's own rules to sums, products, powers, sines and cosines
(``Add._eval_derivative``, ``Mul._eval_derivative_n_times``, ``Pow._eval_derivative``,
``Function._eval_derivative``), in the same order and with the same constructors, so that its results are sympy's
expressions, and remembers each node's derivative and free symbols; any other node goes to sympy.
"""

from __future__ import annotations

from typing import Any

import sympy as sp

__all__ = ["derivative", "jacobian"]

#: Past this many remembered derivatives (or free-symbol sets) the memo starts again: a derivation of the largest
#: built-in example keeps about 200,000.
_MEMO_LIMIT = 1_000_000
_derivatives: dict[tuple[sp.Basic, sp.Symbol], sp.Expr] = {}
_free: dict[sp.Basic, frozenset] = {}
_TRIG = (sp.sin, sp.cos)


def _free_symbols(e: sp.Basic) -> frozenset:
    try:
        return _free[e]
    except KeyError:
        pass
    if e.is_Atom or not (e.is_Add or e.is_Mul or e.is_Pow or type(e) in _TRIG):
        out = frozenset(e.free_symbols)
    else:
        out = frozenset().union(*[_free_symbols(a) for a in e.args])
    if len(_free) > _MEMO_LIMIT:
        _free.clear()
    _free[e] = out
    return out


def _d(e: sp.Basic, x: sp.Symbol) -> Any:
    key = (e, x)
    try:
        return _derivatives[key]
    except KeyError:
        pass
    if e.is_Symbol:
        out = sp.S.One if e == x else sp.S.Zero
    elif x not in _free_symbols(e):
        out = sp.S.Zero
    elif e.is_Add:
        out = e.func(*[_d(a, x) for a in e.args])
    elif e.is_Mul:
        # Leibniz's rule as Mul._eval_derivative_n_times applies it for a first derivative (the route diff takes):
        # each factor differentiated in turn, the product made by Mul of all the factors at once
        # (the factors free of x skipped: a Mul with a zero among its factors is built before it is zero)
        args = e.args
        terms = []
        for i, a in enumerate(args):
            da = _d(a, x)
            if da is not sp.S.Zero:
                terms.append(sp.Mul(*(args[:i] + (da,) + args[i + 1 :])))
        out = sp.Add(*terms)
    elif e.is_Pow:
        out = e * (_d(e.exp, x) * sp.log(e.base) + _d(e.base, x) * e.exp / e.base)
    elif type(e) in _TRIG:
        da = _d(e.args[0], x)
        out = sp.Add(*([] if da.is_zero else [e.fdiff(1) * da]))
    else:
        out = sp.diff(e, x)
    if len(_derivatives) > _MEMO_LIMIT:
        _derivatives.clear()
    _derivatives[key] = out
    return out


def derivative(expr: Any, x: sp.Symbol) -> Any:
    """:math:`\\partial\\,\\mathrm{expr}/\\partial x` for an expression or a matrix (entry by entry) and a symbol:
    sympy's ``diff(expr, x)``, the same expression, with every node's derivative remembered."""
    if not isinstance(x, sp.Symbol):  # a function or a derivative as the variable: sympy's own route
        return sp.diff(expr, x)
    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(lambda e: _d(sp.sympify(e), x))
    return _d(sp.sympify(expr), x)


def jacobian(column: Any, variables: Any) -> sp.Matrix:
    """The Jacobian matrix of a column (or row) of expressions in ``variables``, as ``Matrix.jacobian``."""
    m = sp.Matrix(column)
    entries = list(m) if 1 in m.shape else None
    if entries is None:
        raise ValueError(f"Expected a column or a row of expressions, got a {m.shape[0]} x {m.shape[1]} matrix.")
    v = list(variables)
    return sp.Matrix(len(entries), len(v), lambda i, j: derivative(entries[i], v[j]))
