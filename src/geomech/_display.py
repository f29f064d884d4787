"""How geomech's objects show themselves in Jupyter: symbolic results as LaTeX (``_repr_latex_``), reports and
solutions as compact HTML tables (``_repr_html_``).

One renderer for each, used by every class that shows itself. Text that comes from a user (a system's name, a
formula, a message) is escaped; an expression too long to read is replaced by its size (the object's
``to_latex()`` or ``to_json()`` has it in full), so that a large derivation cannot make a notebook unusable.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

#: LaTeX of one entry longer than this (characters) is shown as its size.
LATEX_LIMIT = 3000
#: Entries of a list or array shown before an ellipsis.
LIST_ITEMS = 8
#: Characters of a string shown before an ellipsis.
TEXT_LIMIT = 400

_LATEX_SPECIAL = {
    "\\": r"\textbackslash{}",
    "{": r"\{",
    "}": r"\}",
    "_": r"\_",
    "^": r"\^{}",
    "~": r"\~{}",
    "$": r"\$",
    "&": r"\&",
    "#": r"\#",
    "%": r"\%",
}


def latex_text(text: str) -> str:
    r"""``text`` as LaTeX text mode content (``\text{...}``), its special characters escaped."""
    return "".join(_LATEX_SPECIAL.get(ch, ch) for ch in str(text))


def latex_block(title: str, lines: Sequence[tuple[str, str]]) -> str:
    r"""A display-math block for ``_repr_latex_``: ``title`` as text, then one aligned ``name = value`` per line
    (``name`` and ``value`` already LaTeX). A value longer than :data:`LATEX_LIMIT` is shown by its size."""
    rows = []
    if title:
        rows.append(rf"&\text{{{latex_text(title)}}}")
    for name, value in lines:
        if len(value) > LATEX_LIMIT:
            value = rf"\text{{(an expression of {len(value)} characters: see to\_latex())}}"
        rows.append(f"{name} &= {value}")
    return r"$$\begin{aligned}" + r" \\ ".join(rows) + r"\end{aligned}$$"


def _number(x: float) -> str:
    if math.isnan(x) or math.isinf(x):
        return str(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.6g}"


def _cell(value: Any) -> str:
    """One value as escaped HTML (nested mappings as nested tables)."""
    if isinstance(value, Mapping):
        return _table(value)
    if isinstance(value, (bool, np.bool_)):
        return html.escape(str(bool(value)))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return html.escape(_number(float(value)))
    if isinstance(value, complex):
        return html.escape(f"{_number(value.real)}{'+' if value.imag >= 0 else '-'}{_number(abs(value.imag))}j")
    if isinstance(value, np.ndarray) and value.size > LIST_ITEMS:
        return html.escape(f"array of shape {value.shape}")
    if isinstance(value, (list, tuple, np.ndarray)):
        items = list(value)
        if items and all(isinstance(v, Mapping) for v in items):
            return "".join(_table(v) for v in items[:LIST_ITEMS]) + (
                f"<div>... {len(items) - LIST_ITEMS} more</div>" if len(items) > LIST_ITEMS else ""
            )
        shown = ", ".join(_plain(v) for v in items[:LIST_ITEMS])
        more = f", ... ({len(items)} in all)" if len(items) > LIST_ITEMS else ""
        return html.escape(f"[{shown}{more}]")
    text = str(value)
    if len(text) > TEXT_LIMIT:
        text = text[:TEXT_LIMIT] + f"... ({len(text)} characters)"
    return html.escape(text)


def _plain(value: Any) -> str:
    if isinstance(value, (float, np.floating)):
        return _number(float(value))
    if isinstance(value, (list, tuple, np.ndarray)):
        return (
            "[" + ", ".join(_plain(v) for v in list(value)[:LIST_ITEMS]) + ("...]" if len(value) > LIST_ITEMS else "]")
        )
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k}: {_plain(v)}" for k, v in value.items()) + "}"
    return str(value)


def _table(data: Mapping[str, Any]) -> str:
    rows = "".join(
        f'<tr><th style="text-align:left;vertical-align:top">{html.escape(str(k))}</th>'
        f'<td style="text-align:left">{_cell(v)}</td></tr>'
        for k, v in data.items()
    )
    return f"<table>{rows}</table>"


def html_table(title: str, data: Mapping[str, Any]) -> str:
    """A compact HTML table for ``_repr_html_``: ``title`` as its caption, one row per key (nested mappings as
    nested tables, long lists and arrays shortened), everything escaped."""
    return f"<div><strong>{html.escape(str(title))}</strong>{_table(data)}</div>"


class ShowsItselfAsHTML:
    """Mixin of the reports: ``_repr_html_`` renders :meth:`_html_data` (default ``to_json()``) under
    :attr:`_html_title` (default the class name)."""

    def _html_data(self) -> Mapping[str, Any]:
        return self.to_json()  # type: ignore[attr-defined]

    @property
    def _html_title(self) -> str:
        return type(self).__name__

    def _repr_html_(self) -> str:
        return html_table(self._html_title, self._html_data())
