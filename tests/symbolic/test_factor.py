"""The simplifier's factorization by FLINT (symbolic/simplify.py, factor_list) against sympy's own (a second,
independent implementation) and against the product it must give back."""

import random

import pytest
import sympy as sp

from geomech.symbolic.simplify import factor_list


def _polynomials():
    """Products of random sparse factors over the rationals in a ring like the simplifier's: cosines, sines and
    parameters as generators, repeated factors, rational coefficients and contents."""
    R, *g = sp.ring("C_phi S_phi m r J J0", sp.QQ)
    rng = random.Random(7)
    out = [R(3), R(0) + sp.Rational(2, 3) * g[0], (g[0] ** 2 + g[1] ** 2 - 1) * g[2]]
    for _ in range(12):
        p = R(rng.choice([1, -1, 2, sp.Rational(1, 6)]))
        for _ in range(rng.randint(1, 4)):
            f = sum(
                (rng.randint(-3, 3) * sp.Rational(1, rng.randint(1, 4)) * g[rng.randrange(6)] ** rng.randint(0, 2))
                * g[rng.randrange(6)]
                for _ in range(rng.randint(1, 4))
            ) + rng.randint(-2, 2)
            if f and not f.is_ground:
                p *= f ** rng.randint(1, 2)
        out.append(p)
    return out


@pytest.mark.parametrize("p", _polynomials(), ids=str)
def test_flint_factors_are_sympys(p):
    content, factors = factor_list(p)
    expected_content, expected = p.factor_list()
    assert content == expected_content
    assert sorted((str(f), k) for f, k in factors) == sorted((str(f), k) for f, k in expected)
    product = p.ring(content)
    for f, k in factors:
        product *= f**k
    assert product == p
