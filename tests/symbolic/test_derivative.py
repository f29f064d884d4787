"""The remembered first derivative against sympy's ``diff``: the same expressions, node for node."""

import random

import pytest
import sympy as sp

from geomech.symbolic import derivative, jacobian
from geomech.systems.nonholonomic_examples import EXAMPLES

x, y, z = sp.symbols("x y z")
a = sp.Symbol("a", positive=True)


def _random_expression(rng: random.Random, depth: int) -> sp.Expr:
    """A random tree of sums, products, integer and rational powers, sines, cosines and other functions."""
    if depth == 0:
        return rng.choice([x, y, z, a, sp.Integer(rng.randint(-3, 3)), sp.Rational(rng.randint(1, 5), 7)])
    kind = rng.randrange(7)
    e1 = _random_expression(rng, depth - 1)
    e2 = _random_expression(rng, depth - 1)
    if kind == 0:
        return e1 + e2
    if kind == 1:
        return e1 * e2 * _random_expression(rng, depth - 1)
    if kind == 2:
        return (e1 + 2) ** rng.choice([-2, -1, 2, 3, sp.Rational(1, 2)])
    if kind == 3:
        return sp.sin(e1) * sp.cos(e2)
    if kind == 4:
        return e1 / (1 + e2**2)
    if kind == 5:
        return sp.exp(e1) + sp.atan2(e2, 1 + x**2)  # nodes sympy differentiates itself
    return 3 * (e1 - e2)  # a number times a sum, distributed by sympy


@pytest.mark.parametrize("seed", range(40))
def test_random_expressions_differentiate_to_sympys_own_result(seed):
    rng = random.Random(seed)
    e = _random_expression(rng, 4)
    for v in (x, y, a):
        assert derivative(e, v) == sp.diff(e, v)
    # and again, from the memo: the same objects
    assert derivative(e, x) == sp.diff(e, x)


def test_matrices_nonsymbols_and_the_jacobian():
    M = sp.Matrix([[x * y, sp.sin(x) ** 2], [1 / (x + y), z]])
    assert derivative(M, x) == sp.diff(M, x)
    assert isinstance(derivative(sp.ImmutableMatrix(M), y), sp.ImmutableMatrix)
    f = sp.Function("f")
    assert derivative(f(x) ** 2, f(x)) == sp.diff(f(x) ** 2, f(x))  # a function as the variable: sympy's route
    assert derivative(f(x) * x, x) == sp.diff(f(x) * x, x)
    F = sp.Matrix([[f(x) ** 2, x * f(x)]])
    assert derivative(F, f(x)) == sp.diff(F, f(x)) == sp.Matrix([[2 * f(x), x]])
    col = sp.Matrix([x**2 * sp.cos(y), y * z, sp.sqrt(x + z)])
    assert jacobian(col, [x, y, z]) == col.jacobian([x, y, z])
    assert jacobian(col.T, [z, x]) == col.T.jacobian([z, x])
    with pytest.raises(ValueError, match="column or a row"):
        jacobian(M, [x, y])


@pytest.mark.parametrize("name", ["snakeboard", "roller_racer", "chaplygin_ball"])
def test_a_systems_lagrangian_and_mass_matrix(name):
    """The derivations' own inputs: every first and second derivative of the Lagrangian in the velocities and
    coordinates, as sympy gives them."""
    s = EXAMPLES[name]()
    L = s.lagrangian
    for v in list(s.q) + list(s.qdot):
        d = derivative(L, v)
        assert d == sp.diff(L, v)
        for w in s.qdot:
            assert derivative(d, w) == sp.diff(d, w)
