"""The derived objects' text: sympy's ``str`` character for character, with shared subexpressions printed once."""

import random

import sympy as sp

from geomech.reduction import bkmm_reduction
from geomech.reduction._derived import TextPrinter
from geomech.systems.nonholonomic_examples import EXAMPLES

x, y, z = sp.symbols("x y z")


def test_the_printer_gives_str_of_every_expression_with_shared_parts_and_floats():
    """Floats print with all their digits at the top level and shortened inside an expression: the remembered
    text of a subexpression is the nested one, the top level printed afresh."""
    third = sp.Float(1) / 3
    shared = (x + third * y) ** 2 / (1 + sp.sin(z) ** 2)
    rng = random.Random(3)
    exprs = [third, -third, shared, shared + 1, x * shared, sp.Matrix([[shared, third]])[0, 1]]
    for _ in range(30):
        a, b = rng.choice(exprs), rng.choice(exprs)
        exprs.append(rng.choice([a + b, a * b - 2, a / (b + 3), sp.cos(a) * b, -a, a**2]))
    text = TextPrinter().text
    for e in exprs + exprs[::-1]:  # the second pass is answered from the memo
        assert text(e) == str(e)


def test_a_reductions_text_is_strs():
    red = bkmm_reduction(EXAMPLES["snakeboard"]())
    printed = red.to_dict(("text",))["text"]
    for name, _, value in red.items():
        if isinstance(value, sp.MatrixBase):
            assert printed[name] == [[str(value[i, j]) for j in range(value.cols)] for i in range(value.rows)]
        elif isinstance(value, sp.Basic):
            assert printed[name] == str(value)
