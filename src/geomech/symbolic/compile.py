"""Formulas to numeric functions: canonical symbols, binding a user formula to its variables and parameters, and
compiling expressions to vectorised numpy functions (the integrators' numba kernels are printed by
:mod:`geomech.integrators._codegen` from the same expressions)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import SymbolicError
from .formula import parse_formula

#: Body angular momentum components, the variables of a left-invariant Hamiltonian H(m).
M_SYMBOLS: tuple[sp.Symbol, sp.Symbol, sp.Symbol] = sp.symbols("m1 m2 m3", real=True)


def bind_expression(
    expression: Any,
    parameters: Mapping[str, float] | None,
    variables: Sequence[sp.Symbol],
    argname: str,
) -> tuple[sp.Expr, dict[str, float]]:
    """Parse a user formula, rename its variables to the canonical ``variables`` (matched by name),
    make every other symbol a real parameter, and check that each parameter has a finite value.

    Returns the expression (with parameters still symbolic) and the parameter values by name.
    """
    if isinstance(expression, str):
        expression = parse_formula(expression, argname)
    if not isinstance(expression, sp.Basic):
        raise SymbolicError(
            f"Expected `{argname}` to be a sympy expression or a string, got {type(expression).__name__}."
        )
    expr = expression
    undefined = sorted({str(f.func) for f in expr.atoms(sp.Function) if isinstance(f, sp.core.function.AppliedUndef)})
    if undefined:
        raise SymbolicError(f"`{argname}` calls unknown function(s) {undefined}; use sympy's functions (sin, exp, "
                            "sqrt, tanh, ...), or build the system from a Python callable instead of a formula.")
    names = {str(v): v for v in variables}
    rename = {}
    params_in_expr = set()
    for s in expr.free_symbols:
        if str(s) in names:
            rename[s] = names[str(s)]
        else:
            params_in_expr.add(str(s))
            rename[s] = sp.Symbol(str(s), real=True)
    expr = expr.xreplace(rename)
    given = dict(parameters or {})
    missing = sorted(params_in_expr - set(given))
    if missing:
        raise SymbolicError(
            f"`{argname}` has symbols {missing} that are neither variables {sorted(names)} nor given in "
            f"`parameters`; pass parameters={{{', '.join(repr(m) + ': ...' for m in missing)}}}."
        )
    unused = sorted(set(given) - params_in_expr)
    values: dict[str, float] = {}
    for k in sorted(params_in_expr):
        try:
            v = float(given[k])
        except (TypeError, ValueError) as exc:
            raise SymbolicError(f"Expected parameter `{k}` to be a number, got {given[k]!r}.") from exc
        if not np.isfinite(v):
            raise SymbolicError(f"Expected parameter `{k}` to be finite, got {v}.")
        values[k] = v
    if unused:
        raise SymbolicError(f"`parameters` names {unused}, which do not appear in `{argname}`.")
    if expr.has(sp.I) or expr.has(sp.zoo, sp.oo, sp.nan):
        raise SymbolicError(f"`{argname}` must be a finite real expression, got {expr}.")
    if values:
        with_values = expr.subs({sp.Symbol(k, real=True): v for k, v in values.items()})
        if with_values.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
            shown = ", ".join(f"{k} = {v:g}" for k, v in values.items())
            raise SymbolicError(f"`{argname}` is not finite at the parameter values {shown} (a division by zero "
                                "or a pole there); choose other values.")
    return expr, values


def _lambdify(exprs: Any, variables: Sequence[sp.Symbol]):
    flat = exprs if isinstance(exprs, list) else [exprs]
    if any(isinstance(e, sp.Basic) and e.has(sp.zoo, sp.oo, -sp.oo, sp.nan) for e in flat):
        raise SymbolicError("A formula to compile is not finite (it holds a division by zero or a pole at the "
                            "given parameter values): " + ", ".join(str(e) for e in flat if isinstance(e, sp.Basic)
                                                                     and e.has(sp.zoo, sp.oo, sp.nan))[:300] + ".")
    return sp.lambdify(list(variables), exprs, modules="numpy", cse=True)


def compile_scalar(expr: sp.Expr, variables: Sequence[sp.Symbol]):
    """Compile ``expr`` to ``f(x)`` with ``x`` of shape ``(..., n)``, returning shape ``(...)``."""
    f = _lambdify(expr, variables)

    def scalar(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = f(*np.moveaxis(x, -1, 0))
        return np.broadcast_to(np.asarray(out, dtype=float), x.shape[:-1]).copy()

    return scalar


def compile_vector(exprs: Any, variables: Sequence[sp.Symbol]):
    """Compile a (nested) list of expressions to ``f(x)`` with ``x`` of shape ``(..., n)``, returning
    an array of shape ``(..., *shape)``; constant entries are broadcast."""
    arr = np.array(exprs, dtype=object)
    shape = arr.shape
    flat = list(arr.ravel())
    f = _lambdify(flat, variables)

    def vector(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        batch = x.shape[:-1]
        vals = f(*np.moveaxis(x, -1, 0))
        out = np.stack([np.broadcast_to(np.asarray(v, dtype=float), batch) for v in vals], -1)
        return out.reshape(batch + shape)

    return vector


def stack_last(*arrays: Any) -> np.ndarray:
    """Concatenate along the last axis after broadcasting the leading (batch) axes only."""
    arrs = [np.asarray(a, dtype=float) for a in arrays]
    arrs = [a[..., None] if a.ndim == 0 else a for a in arrs]
    batch = np.broadcast_shapes(*(a.shape[:-1] for a in arrs))
    return np.concatenate([np.broadcast_to(a, batch + a.shape[-1:]) for a in arrs], axis=-1)


def compile_matrix(e: sp.Matrix, variables: Sequence[sp.Symbol]):
    """A sympy matrix to ``f(x)`` of shape ``(..., rows, cols)``, like :func:`compile_vector`, also for matrices with a
    zero dimension."""
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


def column(seq: Sequence[Any]) -> sp.Matrix:
    """A column vector, also with no entries (``sp.Matrix(())`` would be 0 x 0)."""
    return sp.Matrix(len(seq), 1, list(seq))


def suffixed_symbols(suffix: str, names: Sequence[str]) -> tuple[sp.Symbol, ...]:
    """Real symbols ``name_suffix`` (or ``name`` with no suffix), e.g. the velocities ``x_dot`` of ``x``."""
    return tuple(sp.Symbol(f"{n}_{suffix}" if suffix else n, real=True) for n in names)
