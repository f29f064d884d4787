"""Canonical Hamiltonian systems :math:`H(q, p)` on :math:`\\mathbb R^{2n}` (or a cylinder).

The reduced Serret-Andoyer system (l, L) and the Euler-angle coordinates of T*SO(3) are of this form;
integrators for canonical systems take a :class:`CanonicalSystem`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError
from ..symbolic.compile import compile_scalar, compile_vector
from ..symbolic.formula import to_expression

__all__ = ["CanonicalSystem"]


@dataclass(frozen=True, eq=False)
class CanonicalSystem:
    """A Hamiltonian system in canonical coordinates, :math:`\\dot q = \\partial H/\\partial p`,
    :math:`\\dot p = -\\partial H/\\partial q`.

    The state is ``y = (q, p)`` of shape ``(..., 2 n)``. ``expression`` (sympy, in the symbols
    ``q_symbols`` and ``p_symbols`` with every parameter substituted) is present when the system came
    from a formula; the numeric callables are always present.
    """

    n: int
    name: str
    _hamiltonian: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    _gradient: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    _hessian: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)
    expression: sp.Expr | None = None
    q_symbols: tuple[sp.Symbol, ...] = ()
    p_symbols: tuple[sp.Symbol, ...] = ()
    angle_coordinates: tuple[int, ...] = ()
    chart: tuple[tuple[int, float, float], ...] = ()
    """Open intervals ``(index, low, high)`` of state components outside which the coordinates are not a
    chart (the Serret-Andoyer ``L`` in ``(-G, G)``, the Euler angle ``theta`` in ``(0, pi)``): a trajectory
    that reaches their ends is reported as failed (``left_chart``), not continued with a formula that has
    lost its meaning."""
    """Indices of the q that are angles (defined modulo 2 pi)."""
    template: tuple[sp.Expr, Mapping[str, float]] | None = field(default=None, repr=False)
    """``expression`` before its numeric parameters were substituted, and their values: the compiled
    solvers read the values at run time, so systems that differ only in them share one compilation."""

    @classmethod
    def from_expression(
        cls,
        expression: sp.Expr,
        q_symbols: Sequence[sp.Symbol],
        p_symbols: Sequence[sp.Symbol],
        *,
        name: str = "H(q, p)",
        angle_coordinates: Sequence[int] = (),
        chart: Sequence[tuple[int, float, float]] = (),
        substitutions: Mapping[sp.Symbol, Any] | None = None,
    ) -> CanonicalSystem:
        """Build from a sympy Hamiltonian (or a formula as text); gradient and Hessian are exact (differentiated
        symbolically). The coordinates and momenta are symbols, or names (``["q"], ["p"]``)."""
        q_symbols, p_symbols = _symbols(q_symbols, "q_symbols"), _symbols(p_symbols, "p_symbols")
        names = {s.name: s for s in (*q_symbols, *p_symbols)}
        given = to_expression(expression, "expression", names)
        subs = dict(substitutions or {})
        expr = given.subs(subs)
        y = list(q_symbols) + list(p_symbols)
        numbers = {k: v for k, v in subs.items() if isinstance(k, sp.Symbol) and _is_number(v)}
        template = given.subs({k: v for k, v in subs.items() if k not in numbers})
        template_ok = not (template.free_symbols - set(y) - set(numbers)) and len({k.name for k in numbers}) == len(
            numbers
        )
        grad = [sp.diff(expr, s) for s in y]
        hess = [[sp.diff(g, s) for s in y] for g in grad]
        return cls(
            n=len(q_symbols),
            name=name,
            _hamiltonian=compile_scalar(expr, y),
            _gradient=compile_vector(grad, y),
            _hessian=compile_vector(hess, y),
            expression=expr,
            q_symbols=tuple(q_symbols),
            p_symbols=tuple(p_symbols),
            angle_coordinates=tuple(angle_coordinates),
            chart=tuple((int(i), float(lo), float(hi)) for i, lo, hi in chart),
            template=(template, {k.name: float(v) for k, v in numbers.items()}) if template_ok else None,
        )

    def _repr_latex_(self) -> str | None:
        """Jupyter: :math:`H(q, p)` (nothing for a system built from callables)."""
        if self.expression is None:
            return None
        from .._display import latex_block

        return latex_block(self.name, [("H(q, p)", sp.latex(self.expression))])

    def _y(self, y: Any) -> np.ndarray:
        return V.trailing_shape(y, "y", (2 * self.n,))

    def hamiltonian(self, y: Any) -> np.ndarray:
        """:math:`H(q, p)`, shape ``(...)``."""
        return np.asarray(self._hamiltonian(self._y(y)), dtype=float)

    def gradient(self, y: Any) -> np.ndarray:
        """:math:`(\\partial H/\\partial q, \\partial H/\\partial p)`, shape ``(..., 2n)``."""
        return np.asarray(self._gradient(self._y(y)), dtype=float)

    def hessian(self, y: Any) -> np.ndarray:
        """Second derivatives of H, shape ``(..., 2n, 2n)``."""
        if self._hessian is None:
            from ..errors import SymbolicError

            raise SymbolicError(f"{self.name} has no Hessian: build it from a formula or pass one.")
        return np.asarray(self._hessian(self._y(y)), dtype=float)

    def vector_field(self, y: Any) -> np.ndarray:
        """Hamilton's equations :math:`(\\dot q, \\dot p) = (\\partial_p H, -\\partial_q H)`."""
        g = self.gradient(y)
        return np.concatenate([g[..., self.n :], -g[..., : self.n]], axis=-1)


def _is_number(value: Any) -> bool:
    try:
        return bool(np.isfinite(float(value)))
    except (TypeError, ValueError):
        return False


def _symbols(values: Any, argname: str) -> tuple[sp.Symbol, ...]:
    """Symbols, or names made into real symbols; anything else named in the error."""
    if isinstance(values, (str, sp.Symbol)):
        values = [values]
    out = []
    for v in values:
        if isinstance(v, str) and v.isidentifier():
            out.append(sp.Symbol(v, real=True))
        elif isinstance(v, sp.Symbol):
            out.append(v)
        else:
            raise InputError(f"Expected `{argname}` to hold sympy symbols or names, got {v!r}.")
    return tuple(out)
