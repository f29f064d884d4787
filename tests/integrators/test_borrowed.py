"""The compiled loops' borrowed arrays (``geomech.integrators._fptr.borrowed`` and ``kept``): the same data, shape
and strides without numba's reference count, no allocation leaked or freed twice, and the identity in the Python
twins of the loops."""

import numba
import numpy as np
import pytest
from numba.core.runtime import _nrt_python, rtsys

from geomech.integrators import _codegen
from geomech.integrators._fptr import borrowed, kept


@numba.njit
def _scaled_through_a_borrowed_view(a, c):
    v = borrowed(a)
    for i in range(v.shape[0]):
        for j in range(v.shape[1]):
            v[i, j] *= c
    return v.shape[0], v.shape[1], v.strides[0], v.strides[1]


@numba.njit
def _add_row(W, k, x):
    for i in range(W.shape[1]):
        W[k % W.shape[0], i] += x * (i + 1)


@numba.njit
def _work_through_borrowed_arrays(n, d, x):
    W_ = np.zeros((3, d))
    W, X = borrowed((W_, x))  # a tuple: each borrowed
    for k in range(n):
        _add_row(W, k, X[k % X.shape[0]])
    total = 0.0
    for i in range(W.shape[0]):
        for j in range(W.shape[1]):
            total += W[i, j]
    kept((W_,))
    return total


def test_a_borrowed_view_is_the_array_itself_strides_and_all():
    base = np.arange(60.0).reshape(6, 10)
    view = base[1:5, ::3]  # not contiguous
    expected = base.copy()
    expected[1:5, ::3] *= -2.0
    shape0, shape1, s0, s1 = _scaled_through_a_borrowed_view(view, -2.0)
    assert (shape0, shape1) == view.shape and (s0, s1) == view.strides
    np.testing.assert_array_equal(base, expected)


def test_borrowed_work_arrays_compute_the_same_and_leak_nothing():
    x = np.linspace(0.5, 2.0, 7)
    n, d = 10_001, 4
    want = sum(x[k % 7] for k in range(n)) * sum(range(1, d + 1))
    _work_through_borrowed_arrays(3, d, x)  # compiled
    enabled = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()
    try:
        before = rtsys.get_allocation_stats()
        got = _work_through_borrowed_arrays(n, d, x)
        after = rtsys.get_allocation_stats()
    finally:
        if not enabled:
            _nrt_python.memsys_disable_stats()
    assert got == pytest.approx(want, rel=1e-12)
    allocated = after.mi_alloc - before.mi_alloc
    freed = after.mi_free - before.mi_free
    # the work array and the argument's meminfo: each made once and freed once, whatever the n calls in between
    assert allocated >= 1 and freed == allocated


def test_the_python_twins_take_them_as_the_identity():
    namespace: dict = {}
    exec(compile(_codegen.python_header(), "<header>", "exec"), namespace)
    a = np.ones(3)
    assert namespace["borrowed"](a) is a
    assert namespace["kept"]((a,)) is None
