r"""A motion on a Lie group given by its body velocity: the reconstruction equation

.. math::

    g^{-1}\dot g = \xi(t, g),

eq. (1.1) of the nonholonomic seed and eq. (2.2) of its section 2 once the shape path and the momentum are
known. :class:`GroupFlow` is the system :func:`~geomech.solve` integrates on the group with the
Runge-Kutta-Munthe-Kaas methods (``"rkmk"``, ``"rkmk4"``), staying on the group exactly, for any group of
:mod:`geomech.lie`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, NumericalError, SymbolicError
from ..symbolic.charts import GroupChart, group_chart
from ..symbolic.compile import compile_vector
from ..symbolic.formula import to_expression
from .gait import T_SYMBOL

__all__ = ["GroupFlow"]


@dataclass(frozen=True, eq=False)
class GroupFlow:
    """The body velocity :math:`\\xi(t, g)` of a path on a Lie group.

    Parameters
    ----------
    group : a group of :mod:`geomech.lie` (with its coordinate names), its
        :class:`~geomech.symbolic.GroupChart`, or a group's name (``"SE2"``, ``"SO3"``, ``"S1"``, ...).
    xi : callable ``xi(t, g) -> (k,)``, or k formulas
        The body velocity at time ``t`` and element ``g`` (an ``(N, N)`` matrix), in the basis of the group's
        algebra (``group.algebra_names``): a Python callable, or one formula a component (text, parsed by the
        whitelist, or sympy) in ``t``, the element's entries ``g11, g12, ..., gNN`` (row, column; 1-based, the
        names of the :class:`~geomech.Solution`'s element columns) and the names given values in ``parameters``.
        Formulas run compiled by the Runge-Kutta-Munthe-Kaas methods on the groups with closed-form kernels
        (SO(2), R^n, SE(2), SO(3), SE(3) and their products).
    name : str
    parameters : mapping of str to float, optional
        The values of the formulas' other names.
    """

    group: Any
    xi: Any
    name: str = "group flow"
    parameters: Mapping[str, float] | None = None
    #: the formulas of ``xi`` with the parameters' values in (None for a callable)
    formulas: tuple[sp.Expr, ...] | None = field(init=False, default=None, repr=False)
    #: the element entries' symbols ``g11 .. gNN``, row-major (the formulas' variables with ``t``)
    entries: tuple[sp.Symbol, ...] = field(init=False, default=(), repr=False)
    _evaluate: Callable[[float, Any], Any] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "group", group_chart(self.group))
        n = int(self.group.numeric.matrix_size)
        entries = tuple(sp.Symbol(f"g{i + 1}{j + 1}", real=True) for i in range(n) for j in range(n))
        object.__setattr__(self, "entries", entries)
        if callable(self.xi):
            if self.parameters:
                raise InputError("`parameters` give the values of formulas of `xi`; a callable `xi` takes none.")
            object.__setattr__(self, "_evaluate", self.xi)
            return
        if isinstance(self.xi, np.ndarray) and self.xi.ndim == 1:  # numbers (a constant velocity) or text
            object.__setattr__(self, "xi", self.xi.tolist())
        if isinstance(self.xi, (str, bytes)) or not isinstance(self.xi, Sequence):
            raise InputError(
                f"Expected `xi` to be a callable xi(t, g) -> body velocity or {self.k} formulas "
                f"({', '.join(self.group.algebra_names)}), got {type(self.xi).__name__}."
            )
        if len(self.xi) != self.k:
            raise InputError(
                f"Expected {self.k} formulas for `xi` ({', '.join(self.group.algebra_names)}), got {len(self.xi)}."
            )
        variables = {"t": T_SYMBOL, **{str(e): e for e in entries}}
        values = dict(self.parameters or {})
        for key, value in values.items():
            if key in variables:
                raise InputError(f"`parameters` names {key!r}, which is a variable of `xi` (t or an entry of g).")
            values[key] = float(V.exact_shape(value, f"parameters[{key!r}]", ()))
        formulas = []
        for a, text in enumerate(self.xi):
            argname = f"xi[{a}]"
            try:
                e = to_expression(text, argname, variables)
            except SymbolicError as exc:
                raise InputError(str(exc)) from None
            free = {str(x) for x in e.free_symbols} - set(variables)
            missing = sorted(free - set(values))
            if missing:
                raise InputError(
                    f"`{argname}` = {e} uses {missing}, which are not t, the entries g11..g{n}{n} of the element, "
                    "nor given in `parameters`: give their values there."
                )
            formulas.append(e.xreplace({x: sp.Float(values[str(x)]) for x in e.free_symbols if str(x) in values}))
        object.__setattr__(self, "formulas", tuple(formulas))
        f = compile_vector(formulas, (T_SYMBOL, *entries))

        def evaluate(t: float, g: Any) -> np.ndarray:
            with np.errstate(all="ignore"):  # a formula's pole is reported by velocity(), as not finite
                return f(np.r_[t, np.asarray(g, dtype=float).ravel()])

        object.__setattr__(self, "_evaluate", evaluate)

    @property
    def chart(self) -> GroupChart:
        return self.group

    @property
    def k(self) -> int:
        """Dimension of the group."""
        return int(self.group.dim)

    def velocity(self, t: float, g: np.ndarray) -> np.ndarray:
        """:math:`\\xi(t, g)` as a float array of shape ``(k,)``; :class:`NumericalError` where it is not finite."""
        v = np.asarray(self._evaluate(t, g), dtype=np.float64)
        if v.size != self.k:
            raise InputError(
                f"Expected the body velocity of {self.name} to have {self.k} components "
                f"({', '.join(self.group.algebra_names)}), got shape {v.shape}."
            )
        v = v.reshape(self.k)
        if not np.all(np.isfinite(v)):
            raise NumericalError(f"the body velocity is not finite at t = {t:.6g}: {v.tolist()}")
        return v

    def __repr__(self) -> str:
        return f"GroupFlow({self.name!r}, group={self.group.name})"
