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


def test_sums_print_in_sympys_order_of_terms():
    """The printer orders a sum's terms itself (remembering each factor and base across sums): the order of
    sympy's ``as_ordered_terms``, for sums of monomials in symbols, functions, roots, numbers such as sqrt(2) and
    pi, complex and float coefficients, non-commutative symbols, and sympy's case of 1 - x."""
    a, b = sp.symbols("a b", commutative=False)
    rng = random.Random(7)
    atoms = [
        x,
        y,
        z,
        sp.sin(x),
        sp.cos(y + z),
        sp.sqrt(2),
        sp.pi,
        sp.I,
        sp.Float(0.25),
        sp.Rational(-3, 7),
        sp.sqrt(1 + x**2),
        1 / (1 + y),
        sp.exp(z),
        a,
        b,
        sp.Integer(2),
    ]
    text = TextPrinter().text
    exprs = [1 - x, 2 - 3 * sp.pi, sp.pi - 2 * x, -1 + x, 1 - x * y, 3 - 2 * x, -x + sp.sqrt(2)]
    for _ in range(300):
        e = sp.Integer(0)
        for _ in range(rng.randint(1, 6)):
            e += sp.Mul(*[rng.choice(atoms) ** rng.choice([1, 1, 2, -1]) for _ in range(rng.randint(1, 3))])
        exprs.append(e)
    for e in exprs:
        assert text(e) == str(e)
        assert text(sp.Matrix([[e, e + x]])[0, 1]) == str(e + x)


def test_the_latex_printer_gives_sympys_latex_with_shared_parts():
    """The LaTeX of the derived objects: ``sympy.latex`` with the system's symbol names, character for character,
    for sums, fractions, powers of functions (printed as sin^2), roots, floats, matrices, with each subexpression's
    text remembered across expressions (a second pass answered from the memo)."""
    from geomech.reduction._derived import LatexText

    theta = sp.Symbol("theta")
    names = {x: r"\xi", theta: r"\vartheta"}
    rng = random.Random(5)
    atoms = [
        x,
        y,
        z,
        theta,
        sp.sin(theta),
        sp.cos(y) ** 2,
        sp.sqrt(1 + x**2),
        1 / (1 + y),
        sp.Float(0.125),
        sp.Rational(-3, 7),
        sp.pi,
        sp.exp(z),
        sp.Integer(2),
    ]
    exprs = [1 - x, sp.sin(theta) ** 2 / (1 + sp.cos(theta) ** 3), sp.Matrix([[x / y, 1 - theta], [sp.sqrt(x), 0]])]
    for _ in range(200):
        e = sp.Integer(0)
        for _ in range(rng.randint(1, 5)):
            e += sp.Mul(*[rng.choice(atoms) ** rng.choice([1, 1, 2, -1]) for _ in range(rng.randint(1, 3))])
        exprs.append(e)
        exprs.append(e / (1 + e))
    printer = LatexText(names)
    for e in exprs + exprs[::-1]:
        assert printer.text(e) == sp.latex(e, symbol_names=names)
    red = bkmm_reduction(EXAMPLES["snakeboard"]())
    printed = red.to_dict(("latex",))["latex"]
    for name, _, value in red.items():
        if isinstance(value, (sp.Basic, sp.MatrixBase)):
            assert printed[name] == sp.latex(value, symbol_names=red._latex_names())
