"""The Taylor/closed-form coefficient functions behind every group, against 120-digit mpmath values.

These coefficients are where the small-angle branches live; a wrong Taylor coefficient or a switch point
where the closed form has already lost digits shows up here as a relative error above a few ulps.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from geomech.lie import _common as c

# The closed forms cancel like t^5 at t = 1e-9, i.e. about 45 digits; 120 leave plenty. Set per test
# (mpmath's precision is global, and other tests in the same process set their own).
DIGITS = 120

REFERENCE = {
    "SINC": lambda t: mp.sin(t) / t,
    "ONE_MINUS_COS_T2": lambda t: (1 - mp.cos(t)) / t**2,
    "T_MINUS_SIN_T3": lambda t: (t - mp.sin(t)) / t**3,
    "HALF_COT_HALF": lambda t: t / 2 * mp.cot(t / 2),
    "JINV_D": lambda t: (1 - t / 2 * mp.cot(t / 2)) / t**2,
    "T_OVER_SIN": lambda t: t / mp.sin(t),
    "SE3_C2": lambda t: (t**2 + 2 * mp.cos(t) - 2) / (2 * t**4),
    "SE3_C3": lambda t: (2 * t - 3 * mp.sin(t) + t * mp.cos(t)) / (2 * t**5),
}
VALUE_AT_ZERO = {
    "SINC": 1.0,
    "ONE_MINUS_COS_T2": 0.5,
    "T_MINUS_SIN_T3": 1 / 6,
    "HALF_COT_HALF": 1.0,
    "JINV_D": 1 / 12,
    "T_OVER_SIN": 1.0,
    "SE3_C2": 1 / 24,
    "SE3_C3": 1 / 120,
}


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_coefficient_accurate_on_both_sides_of_the_switch(name):
    f = getattr(c, name)
    tol = f.tol(np.dtype(np.float64))
    t = np.concatenate([np.geomspace(1e-9, 3.0, 300), tol * np.array([0.999, 0.9999999, 1.0, 1.0000001, 1.001])])
    t = np.concatenate([t, -t])
    got = f(t)
    with mp.workdps(DIGITS):
        ref = np.array([float(REFERENCE[name](mp.mpf(float(x)))) for x in t])
    rel = np.abs(got - ref) / np.abs(ref)
    assert rel.max() < 2e-15, (name, float(t[np.argmax(rel)]), float(rel.max()))


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_coefficient_at_zero_is_exact(name):
    assert getattr(c, name)(np.array(0.0)) == VALUE_AT_ZERO[name]


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_one_double_gives_the_array_value_bit_for_bit(name):
    """A single double takes a scalar path (the group integrators call with one element at a time); it must
    round exactly as the array path does, on both sides of the switch point."""
    f = getattr(c, name)
    tol = f.tol(np.dtype(np.float64))
    ts = np.array([0.0, 1e-9, -3e-5, 0.5 * tol, -0.999 * tol, tol, 1.001 * tol, 0.3, -1.7, 2.9, 1e3])
    batch = f(ts)
    for t, want in zip(ts, batch):
        got = f(np.float64(t))
        assert got.shape == () and got.dtype == np.float64
        assert got == want or (np.isnan(got) and np.isnan(want)), (t, got, want)
    assert f(np.float32(0.3)).dtype == np.float32  # other precisions keep the array path and their dtype
