"""The one compiler: numpy functions and numba kernel source from the same expressions, checked against
values computed another way (mpmath through sympy's own evaluation, exact derivatives)."""

import math

import numpy as np
import pytest
import sympy as sp

from geomech.errors import SymbolicError
from geomech.symbolic import compile_matrix, compile_scalar, compile_vector, vanishes
from geomech.symbolic.compile import FunctionSpec, kernel_source

x, y = sp.symbols("x y", real=True)
EXPRS = [sp.sin(x) * sp.exp(y) + sp.Rational(1, 3), sp.sqrt(1 + x**2) / (2 + sp.cos(y)), sp.erf(x - y), sp.Integer(2)]


def _exact(points):
    return np.array([[float(e.subs({x: a, y: b}).evalf(30)) for e in EXPRS] for a, b in points])


def test_numpy_functions_agree_with_sympy_evaluation_and_broadcast(rng):
    pts = rng.uniform(-2, 2, (5, 2))
    f = compile_vector(EXPRS, [x, y])
    np.testing.assert_allclose(f(pts), _exact(pts), rtol=1e-13, atol=1e-15)
    assert f(pts.reshape(5, 1, 2)).shape == (5, 1, 4)  # any batch shape, constants broadcast
    g = compile_scalar(EXPRS[0], [x, y])
    np.testing.assert_allclose(g(pts), _exact(pts)[:, 0], rtol=1e-13)
    M = compile_matrix(sp.Matrix([[x, 1], [y**2, x * y]]), [x, y])
    assert M(pts).shape == (5, 2, 2) and compile_matrix(sp.zeros(0, 3), [x])(np.zeros((4, 1))).shape == (4, 0, 3)


def test_complex_step_derivative_through_the_compiled_function():
    f = compile_vector([EXPRS[0], EXPRS[1]], [x, y], dtype=complex)
    p, h = np.array([0.7, -0.4]), 1e-30
    got = f(p + np.array([1j * h, 0.0])).imag / h
    want = [float(sp.diff(e, x).subs({x: p[0], y: p[1]})) for e in EXPRS[:2]]
    np.testing.assert_allclose(got, want, rtol=1e-14)


def test_kernel_source_computes_what_the_numpy_function_does(rng):
    k = sp.Symbol("k", real=True)
    spec_scalar = FunctionSpec("first", (EXPRS[0],), (x, y))
    spec_array = FunctionSpec("both", ([EXPRS[0], EXPRS[1]], [[k * x * y, sp.cos(k * x)]]), (x, y), parameters=(k,))
    src = kernel_source([spec_scalar, spec_array])
    assert "import" not in src  # model functions only: the loader supplies math and the decorator
    assert "1.7" not in src  # the parameter is read at run time, not written into the source
    namespace = {"math": math, "np": np, "kernel": lambda fn: fn}
    exec(compile(src, "<kernels>", "exec"), namespace)
    for kv in (1.7, -0.3):
        numpy_f = compile_vector([EXPRS[0], EXPRS[1], kv * x * y, sp.cos(kv * x)], [x, y])
        for p in rng.uniform(-1, 1, (4, 2)):
            out0, out1 = np.empty(2), np.empty((1, 2))
            namespace["both"](p, out0, out1, np.array([kv]))
            want = numpy_f(p)
            got = [namespace["first"](p, np.empty(0)), *out0, *out1.ravel()]
            np.testing.assert_allclose(got, [want[0], *want], rtol=1e-14)


def test_formulas_with_poles_are_refused_by_both_targets():
    bad = sp.zoo * x
    with pytest.raises(SymbolicError, match="not finite"):
        compile_vector([bad], [x])
    with pytest.raises(SymbolicError, match="not finite"):
        kernel_source([FunctionSpec("f", (bad,), (x,))])


def test_vanishes_decides_identities_and_rejects_near_misses():
    a, b = sp.symbols("a b", real=True)
    assert vanishes(sp.sin(a + b) - sp.sin(a) * sp.cos(b) - sp.cos(a) * sp.sin(b))
    assert vanishes(sp.Matrix([sp.cos(a) ** 2 + sp.sin(a) ** 2 - 1, 0]))
    assert not vanishes(sp.sin(a) ** 2 - sp.Rational(1, 2))
    assert not vanishes(sp.Float("1e-12") * a)  # small but not zero: the exact screen sees it
    assert vanishes(sp.Integer(0)) and vanishes([])


def test_evaluate_on_the_graph_agrees_with_the_compiled_function():
    # elementary functions, integer, half and general powers, numbers (pi, rationals, floats), a constant entry
    # broadcast, a matrix, a function outside numpy's (compiled alone), complex points (a complex-step derivative)
    import numpy as np
    import sympy as sp

    from geomech.errors import SymbolicError
    from geomech.symbolic.compile import compile_vector, evaluate

    x, y, z = sp.symbols("x y z", real=True)
    shared = (x * y + sp.sin(z)) ** 2 / (1 + y**2)
    exprs = [
        [shared + sp.cos(shared), sp.exp(x) * sp.sqrt(1 + y**2) - sp.Rational(3, 7) * sp.pi],
        [1 / sp.sqrt(2 + z**2) + (1 + x**2) ** sp.Rational(1, 3) + sp.Float(0.25) * sp.tan(y), sp.Integer(3)],
        [sp.atan(x) * sp.tanh(y) + sp.log(2 + z) + sp.Abs(x - y) + (2 + x**2) ** y, sp.erf(y**2 / 4)],
    ]
    rng = np.random.default_rng(5)
    pts = rng.uniform(-1.5, 1.5, (7, 3))
    want = compile_vector(exprs, [x, y, z])(pts)
    got = evaluate(exprs, [x, y, z], pts)
    assert got.shape == (7, 3, 2)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(evaluate(sp.Matrix(exprs), [x, y, z], pts[0]), want[0], rtol=1e-13, atol=1e-13)
    # complex step: d/dx of shared at the points, against the derivative's formula
    h = 1e-30
    stepped = pts.astype(complex)
    stepped[:, 0] += 1j * h
    d = evaluate([shared], [x, y, z], stepped, dtype=complex)[:, 0].imag / h
    np.testing.assert_allclose(d, compile_vector([sp.diff(shared, x)], [x, y, z])(pts)[:, 0], rtol=1e-12)
    with pytest.raises(SymbolicError, match="not among the variables"):
        evaluate([x + y], [x], pts[:, :1])
