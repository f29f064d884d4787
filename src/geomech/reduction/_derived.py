"""Derived objects of the reductions as text, LaTeX and JSON: the :class:`Derived` mixin and :class:`Labelled`
values."""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from functools import partial
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.latex import LatexPrinter
from sympy.printing.str import StrPrinter

from ..errors import InputError
from ..symbolic.cache import shared_value

__all__ = ["Derived", "Labelled"]


class Labelled(tuple):
    """Derived values with names: a tuple of ``(text_label, latex_label, value)``; printed as a JSON object
    ``{text_label: value}``, as one ``label = value`` line each in text, and as ``latex_label = value`` in LaTeX."""

    def as_dict(self) -> dict:
        return {label: value for label, _, value in self}


class _Remembering:
    """A printer's text of every subexpression remembered, and a sum's terms ordered with each factor and base
    remembered across sums (:func:`_ordered_terms`): a derivation's formulas share long subexpressions (a
    determinant in every entry of an inverse, a metric's entries in its Hamiltonian), each printed once. The top
    level is printed afresh and a call with options (sympy's exponent of a function) is not remembered."""

    _print_level: int
    order: Any

    def _init_memo(self) -> None:
        self._memo: dict[sp.Basic, str] = {}
        self._factors: dict[sp.Basic, tuple] = {}
        self._keys: dict[sp.Basic, Any] = {}

    def _as_ordered_terms(self, expr: Any, order: Any = None) -> list:
        """``expr.as_ordered_terms()`` (sympy's order of a sum's terms: by their monomials in the sum's bases,
        sorted), with what it finds of each factor and each base's sort key remembered across the sums: they
        recur in thousands of sums, and sympy's ordering was most of a derivation's printing."""
        if order is not None or self.order is not None or not expr.is_Add:
            return super()._as_ordered_terms(expr, order=order)  # type: ignore[misc]
        args = expr.args
        if len(args) == 2:  # sympy's special case: a positive number first, before minus a product
            number = [a for a in args if isinstance(a, (sp.Number, sp.NumberSymbol))]
            if len(number) == 1:
                other = args[1] if args[0] is number[0] else args[0]
                if isinstance(other, sp.Mul):
                    m = sorted(sp.Mul.make_args(other), key=lambda x: not isinstance(x, (sp.Number, sp.NumberSymbol)))
                    if len(m) == 2 and isinstance(m[0], sp.Number) and number[0].is_positive and m[0].is_negative:
                        return [number[0], other]
        return _ordered_terms(args, self._factors, self._keys)

    def _print(self, expr: Any, **kwargs: Any) -> str:
        if kwargs or self._print_level < 1 or not isinstance(expr, sp.Basic):
            return super()._print(expr, **kwargs)  # type: ignore[misc]
        try:
            return self._memo[expr]
        except KeyError:
            out = self._memo[expr] = super()._print(expr)  # type: ignore[misc]
            return out


class TextPrinter(_Remembering, StrPrinter):
    """sympy's ``str``, with the text of every subexpression remembered (:class:`_Remembering`). :meth:`text` gives
    ``str(expr)``, character for character (the top level is printed afresh: a Float there keeps all its digits,
    below it is printed as sympy prints it inside an expression)."""

    def __init__(self) -> None:
        super().__init__({"order": None})
        self._init_memo()

    def text(self, expr: Any) -> str:
        """``str(expr)``."""
        self._print_level = 0
        return self.doprint(expr)


class LatexText(_Remembering, LatexPrinter):
    """sympy's ``latex`` with ``symbol_names``, with the text of every subexpression remembered
    (:class:`_Remembering`): :meth:`text` gives ``sympy.latex(expr, symbol_names=names)``, character for
    character (a derivation's LaTeX took as long as the derivation)."""

    def __init__(self, names: Mapping[sp.Basic, str]) -> None:
        super().__init__({"symbol_names": dict(names)})
        self._init_memo()

    def text(self, expr: Any) -> str:
        """``sympy.latex(expr, symbol_names=names)``."""
        self._print_level = 0
        return self.doprint(expr)


def _ordered_terms(args: tuple, factors: dict, keys: dict) -> list:
    """The terms ``args`` of a sum in the order of sympy's ``Expr.as_ordered_terms`` with its default order
    (lex in the bases sorted by ``default_sort_key``, then the non-commutative parts, then the complex coefficient),
    stable as sympy's sort; ``factors`` and ``keys`` remember each factor's part and each base's key."""
    from sympy.core.exprtools import decompose_power

    rows, bases = [], set()
    for term in args:
        c, rest = term.as_coeff_Mul()
        coeff = complex(float(c)) if c.is_Rational else complex(c)
        cpart: dict = {}
        nc: list = []
        if rest is not sp.S.One:
            for f in sp.Mul.make_args(rest):
                try:
                    kind, value = factors[f]
                except KeyError:
                    kind, value = None, None
                    if f.is_number:
                        try:
                            kind, value = "number", complex(f)
                        except (TypeError, ValueError):
                            pass
                    if kind is None:
                        kind, value = ("power", decompose_power(f)) if f.is_commutative else ("nc", f)
                    factors[f] = kind, value
                if kind == "number":
                    coeff *= value
                elif kind == "power":
                    cpart[value[0]] = value[1]
                    bases.add(value[0])
                else:
                    nc.append(value)
        rows.append((term, coeff, cpart, tuple(nc)))
    for b in bases:
        if b not in keys:
            keys[b] = sp.default_sort_key(b)
    index = {b: i for i, b in enumerate(sorted(bases, key=keys.__getitem__))}

    def key(row: tuple) -> tuple:
        _, coeff, cpart, nc = row
        monom = [0] * len(index)
        for b, e in cpart.items():
            monom[index[b]] = e
        re, im = coeff.real, coeff.imag
        return tuple(-e for e in monom), tuple(e.sort_key() for e in nc), ((bool(im), im), (re, im))

    return [row[0] for row in sorted(rows, key=key)]


def _as_text(value: Any, text: Any = str) -> Any:
    if isinstance(value, Labelled):
        return {label: _as_text(v, text) for label, _, v in value}
    if isinstance(value, sp.MatrixBase):
        return [[text(value[i, j]) for j in range(value.cols)] for i in range(value.rows)]
    if isinstance(value, sp.Basic):
        return text(value)
    if isinstance(value, Mapping):
        return {str(k): _as_text(v, text) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_as_text(v, text) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


TEXT_LIMIT = 600  # characters of one expression in readable text; JSON and LaTeX always hold all of it


def _short(expr: Any, text: Any = str) -> str:
    printed = text(expr)
    if len(printed) <= TEXT_LIMIT:
        return printed
    ops = sp.count_ops(expr)
    return f"<{len(printed)} characters, {ops} operations: see the JSON or LaTeX output or the attribute>"


def _short_text(value: Any, text: Any = str) -> Any:
    if isinstance(value, sp.Basic):
        return _short(value, text)
    if isinstance(value, (list, tuple)):
        return [_short_text(v, text) for v in value]
    if isinstance(value, sp.MatrixBase):
        return [[_short(value[i, j], text) for j in range(value.cols)] for i in range(value.rows)]
    return _as_text(value, text)


class Derived:
    """Mixin of every derived object: readable text, LaTeX and JSON. A subclass provides :meth:`items`, a list of
    ``(name, latex_name, value)`` (sympy values or lists of them), and :meth:`_latex_names` for its symbols."""

    title: str = ""

    def items(self) -> list[tuple[str, str, Any]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _latex_names(self) -> dict:
        return {}

    def _latex(self, value: Any, printer: LatexText | None = None) -> str:
        printer = printer or LatexText(self._latex_names())
        if isinstance(value, Labelled):
            return r",\; ".join(f"{tex} = {self._latex(v, printer)}" for _, tex, v in value)
        if isinstance(value, (list, tuple)):
            return r",\; ".join(self._latex(v, printer) for v in value)
        if isinstance(value, (sp.Basic, sp.MatrixBase)):
            return printer.text(value)
        if isinstance(value, str):  # prose (how a basis was normalised, ...): text, not a product of symbols
            from .._display import latex_text

            return rf"\text{{{latex_text(value)}}}"
        return str(value)

    def to_latex(self) -> str:
        """LaTeX, one ``name = value`` line per derived object."""
        return "\n".join(f"{tex} = {self._latex(v)}" for _, tex, v in self.items())

    def to_text(self) -> str:
        """Readable text, one ``name = value`` block per derived object; an expression longer than
        ``TEXT_LIMIT`` characters is replaced by its size (the JSON and LaTeX outputs hold it in full)."""
        lines = [self.title] if self.title else []
        text = TextPrinter().text
        for name, _, value in self.items():
            if isinstance(value, Labelled):
                lines.append(f"{name}:")
                lines += [f"  {label} = {_short_text(v, text)}" for label, _, v in value]
            elif isinstance(value, sp.MatrixBase):
                rows = [
                    "[" + ", ".join(_short(value[i, j], text) for j in range(value.cols)) + "]"
                    for i in range(value.rows)
                ]
                lines.append(f"{name} = [" + (",\n" + " " * (len(name) + 4)).join(rows) + "]")
            else:
                lines.append(f"{name} = {_short_text(value, text)}")
        return "\n".join(lines)

    def to_dict(self, forms: tuple[str, ...] = ("text", "latex")) -> dict:
        """A JSON-ready dict: every value as text (sympy ``str``, key ``"text"``) and as LaTeX (``"latex"``), or in
        the ``forms`` asked for only; each form is cached with the derivation (printing long expressions costs as
        much as deriving them, so a caller that shows one form does not pay for the other)."""
        unknown = sorted(set(forms) - {"text", "latex"})
        if unknown:
            raise InputError(f"`forms` takes 'text' and 'latex', got {unknown}.")
        out: dict[str, Any] = {"title": self.title}
        for form in ("text", "latex"):
            if form in forms:
                out[form] = shared_value(self, f"to_dict_{form}", partial(self._printed, form))
        return copy.deepcopy(out)

    def _printed(self, form: str) -> dict:
        if form == "latex":
            printer = LatexText(self._latex_names())  # one memo for every item, as the text's
            return {name: self._latex(value, printer) for name, _, value in self.items()}
        text = TextPrinter().text  # one memo for every item: they share subexpressions
        return {name: _as_text(value, text) for name, _, value in self.items()}

    def to_json(self, **kwargs: Any) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), **kwargs)

    def __str__(self) -> str:
        return self.to_text()

    def _repr_latex_(self) -> str:
        """Jupyter: every derived object as aligned LaTeX (one that is too long to read shown by its size)."""
        from .._display import latex_block

        lines = []
        for _, tex, value in self.items():
            if isinstance(value, Labelled):
                lines += [(label_tex, self._latex(v)) for _, label_tex, v in value]
            else:
                lines.append((tex, self._latex(value)))
        return latex_block(self.title, lines)
