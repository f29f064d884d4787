"""Jupyter displays: symbolic results as LaTeX (_repr_latex_), reports and solutions as HTML tables (_repr_html_),
with user text escaped and long expressions shortened."""

from __future__ import annotations

import html
import re
from html.parser import HTMLParser

import numpy as np
import pytest

import geomech as gm
from geomech import _display
from geomech.analysis import analyse_gait, analyse_stability, momentum_transport
from geomech.integrators import ImplicitMidpoint
from geomech.reduction import EulerCoordinates, almost_poisson, bkmm_reduction
from geomech.systems import LeftInvariantSystem
from geomech.systems.nonholonomic_examples import snakeboard_bkmm


def balanced_latex(text: str) -> bool:
    depth = 0
    for i, ch in enumerate(text):
        if ch in "{}" and i and text[i - 1] == "\\":
            continue
        depth += {"{": 1, "}": -1}.get(ch, 0)
        if depth < 0:
            return False
    return depth == 0 and text.count(r"\begin{aligned}") == text.count(r"\end{aligned}") == 1


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.ok = True
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.stack.append(tag)

    def handle_endtag(self, tag):
        self.ok &= bool(self.stack) and self.stack.pop() == tag

    def handle_data(self, data):
        self.text.append(data)


def parsed(markup: str) -> _Tags:
    p = _Tags()
    p.feed(markup)
    p.close()
    assert p.ok and not p.stack, markup[:300]
    return p


def test_symbolic_results_render_as_latex():
    H = LeftInvariantSystem.from_expression("m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)", {"I1": 3, "I2": 2, "I3": 1})
    tex = H._repr_latex_()
    assert tex.startswith("$$") and tex.endswith("$$") and balanced_latex(tex[2:-2])
    assert r"\frac{m_{1}^{2}}{2 I_{1}}" in tex
    board = snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)
    for obj in (board, bkmm_reduction(board), almost_poisson(board), EulerCoordinates(H).canonical_system()):
        tex = obj._repr_latex_()
        assert balanced_latex(tex[2:-2]), type(obj).__name__
    assert r"\omega^{1}" in board._repr_latex_() and "= 0" in board._repr_latex_()
    # a system from a callable has no formula to show: Jupyter falls back to its repr
    assert LeftInvariantSystem.from_callable(lambda m: m @ m, lambda m: 2 * m)._repr_latex_() is None


def test_long_expressions_are_shortened_and_text_is_escaped():
    tex = _display.latex_block("a_b & 50% {x}", [("x", "y" * (_display.LATEX_LIMIT + 1))])
    assert f"{_display.LATEX_LIMIT + 1} characters" in tex and "y" * 100 not in tex
    assert r"a\_b \& 50\% \{x\}" in tex and balanced_latex(tex[2:-2])
    markup = _display.html_table("<script>", {"name": "<b>x</b>", "values": np.arange(100.0), "nested": {"a": 1.5}})
    assert "<script>" not in markup and html.escape("<b>x</b>") in markup and "array of shape (100,)" in markup
    parsed(markup)


def test_solutions_and_reports_render_as_html_tables():
    H = LeftInvariantSystem.from_expression("m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)", {"I1": 3, "I2": 2, "I3": 1})
    sol = gm.solve(H, ImplicitMidpoint(), m0=[0.1, 1.0, 0.2], t_final=1.0, h=0.01, backend="python")
    text = "".join(parsed(sol._repr_html_()).text)
    assert "ImplicitMidpoint" in text and "largest drift" in text and "energy" in text
    assert re.search(r"Casimir \|m\|\^2\s*[0-9.e-]+", text)
    analysis = analyse_stability(H, 1.0, n_points=200)
    text = "".join(parsed(analysis._repr_html_()).text)
    assert "verdict" in text and "stable" in text and "unstable" in text
    parsed(analysis.reports[0]._repr_html_())
    board = snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)
    gait = {"psi": "sin(4*pi*t/T)", "phi": "0.4*sin(2*pi*t/T)"}
    text = "".join(parsed(analyse_gait(board, gait, period=1.0, p0=[0.2])._repr_html_()).text)
    assert "net" in text.lower()
    text = "".join(parsed(momentum_transport(board, gait, period=1.0)._repr_html_()).text)
    assert "holonomy" in text


@pytest.mark.parametrize("value, shown", [(float("nan"), "nan"), (3.0, "3"), (1.23456789e-7, "1.23457e-07")])
def test_numbers_are_shown_compactly(value, shown):
    assert shown in _display.html_table("t", {"x": value})
