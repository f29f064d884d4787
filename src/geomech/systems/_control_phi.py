"""The feedback map :math:`\\varphi` of a structure-preserving control as the user gives it: formulas (parsed by
the whitelist, real, finite, in the right variables, not clashing with the model's parameters) or Python
callables with their derivatives (wrapped to the vectorised form the control evaluates)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError, SymbolicError
from ..symbolic.formula import parse_formula

__all__ = ["parse_phi", "wrap_phi_callables"]


def _real(expr: sp.Expr) -> sp.Expr:
    return expr.xreplace({s: sp.Symbol(str(s), real=True) for s in expr.free_symbols})


def parse_phi(expressions: Sequence[Any], variables: Sequence[str], argname: str, reserved: set[str]) -> list[sp.Expr]:
    out = []
    for k, e in enumerate(expressions):
        name = argname if len(expressions) == 1 else f"{argname}[{k}]"
        if isinstance(e, str):
            e = parse_formula(e, name)
        if isinstance(e, (int, float)):
            e = sp.Float(e) if isinstance(e, float) else sp.Integer(e)
        if not isinstance(e, sp.Basic):
            raise SymbolicError(f"Expected `{name}` to be a sympy expression or a string, got {type(e).__name__}.")
        e = _real(sp.sympify(e))
        if e.has(sp.I) or e.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
            raise SymbolicError(f"`{name}` must be a finite real expression, got {e}.")
        names = {str(s) for s in e.free_symbols}
        wrong_vars = sorted(names & ({"v", "m1", "m2", "m3"} - set(variables)))
        if wrong_vars:
            want = (
                "v alone (v = m3 for the rotor on axis 3, v = m_i for phi_i)"
                if variables == ("v",)
                else "the body momentum m1, m2, m3"
            )
            raise SymbolicError(f"Expected `{name}` to be a function of {want}, got {e}, which involves {wrong_vars}.")
        clash = sorted(names & reserved)
        if clash:
            raise SymbolicError(
                f"`{name}` uses {clash}, which name the model's own parameters {sorted(reserved)}; rename them."
            )
        out.append(e)
    return out


def wrap_phi_callables(callables: Any, axes: np.ndarray, separable: bool, n_rotors: int) -> tuple[Any, Any, Any]:
    """``(phi(m, theta), dphi(m, theta), phi_1d)`` from phi given as Python callables (and their derivatives):
    scalar functions of ``v = a . m`` for a separable control, else one map of ``m`` with its Jacobian."""
    phis, derivs = callables
    if separable:

        def phi(m, th):
            v = np.asarray(m, float) @ axes.T
            return np.stack([np.asarray(f(v[..., i]), float) for i, f in enumerate(phis)], -1)

        def dphi(m, th):
            v = np.asarray(m, float) @ axes.T
            d = np.stack([np.asarray(f(v[..., i]), float) for i, f in enumerate(derivs)], -1)
            return d[..., :, None] * axes

        phi_1d = [lambda x, th, f=f: np.asarray(f(x), float) for f in phis]
        return phi, dphi, phi_1d
    f, jac = phis[0], derivs[0]
    n = n_rotors

    def phi_of_m(m, th):
        out = np.asarray(f(np.asarray(m, float)), float)
        if out.shape != np.shape(m)[:-1] + (n,):
            raise InputError(
                f"Expected `phi` to return shape (..., {n}), got {out.shape} for m of shape {np.shape(m)}."
            )
        return out

    def dphi_of_m(m, th):
        out = np.asarray(jac(np.asarray(m, float)), float)
        if out.shape != np.shape(m)[:-1] + (n, 3):
            raise InputError(f"Expected `jacobian` to return shape (..., {n}, 3), got {out.shape}.")
        return out

    return phi_of_m, dphi_of_m, None
