"""Coefficients of a quadratic form read off in one walk of the expression, against sympy's Hessian and mixed
derivatives (a second route), and refused where the expression is not a polynomial of degree <= 2."""

import pytest
import sympy as sp

from geomech.errors import SymbolicError
from geomech.symbolic import quadratic_blocks, quadratic_coefficients, quadratic_form, simplify_expr

r, s, a, b = sp.symbols("r s a b")
u, v, w = sp.symbols("u v w")


def _forms():
    c1 = sp.sin(r) / (a + b * sp.cos(s) ** 2)
    c2 = (a * r + 1) ** 3 / (2 + sp.sin(s))
    return [
        c1 * u**2 + c2 * u * v - sp.Rational(3, 7) * w**2 + sp.exp(r) * v * w + a,  # expanded
        (c1 * u + c2 * v) * (u - sp.cos(r) * w) + (v + 2 * w) ** 2 / (1 + b**2) - sp.sin(s) * (u + v) * c2 * w,
        sp.Rational(1, 2) * (u + v + w) ** 2 * c1 - c2 * (a + u * (v - w)) + sp.log(1 + r**2),  # constant part
        sp.Integer(5),
    ]


@pytest.mark.parametrize("k", range(4))
def test_the_quadratic_form_is_half_the_hessian(k):
    e = _forms()[k]
    got, want = quadratic_form(e, [u, v, w]), sp.hessian(e, [u, v, w]) / 2
    assert got.shape == (3, 3) and got == got.T
    assert all(simplify_expr(x) == 0 for x in got - want)
    coeffs = quadratic_coefficients(e, [u, v, w])
    assert simplify_expr(coeffs.get((), 0) - e.subs({u: 0, v: 0, w: 0})) == 0  # the part free of the variables
    assert all(len(m) != 1 for m in coeffs)  # no linear terms in these forms


def test_linear_terms_are_kept_apart():
    e = a * u + sp.sin(r) * u * w + 3 * w - b
    c = quadratic_coefficients(e, [u, w])
    assert c == {(0,): a, (1,): 3, (0, 1): sp.sin(r), (): -b}


def test_the_blocks_match_the_mixed_derivatives():
    e = _forms()[1]
    Q, R, S = quadratic_blocks(e, [u], [v, w])
    assert simplify_expr(Q[0, 0] - sp.diff(e, u, 2) / 2) == 0
    assert all(simplify_expr(R[0, j] - sp.diff(e, u, y)) == 0 for j, y in enumerate([v, w]))
    assert all(simplify_expr(x) == 0 for x in S - sp.hessian(e, [v, w]) / 2)


@pytest.mark.parametrize(
    "bad, words",
    [
        (u**3 + v, "degree <= 2"),
        (u * v * w, "degree <= 2"),
        (sp.sin(u) * v, "factor sin(u)"),
        (a / (1 + u**2), "factor"),
        (sp.sqrt(u) * v, "factor"),
    ],
)
def test_what_is_not_a_quadratic_polynomial_is_refused(bad, words):
    with pytest.raises(SymbolicError, match=words.replace("(", r"\(").replace(")", r"\)")):
        quadratic_coefficients(bad, [u, v, w])
