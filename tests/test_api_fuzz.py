"""Property-based fuzzing of the public API with bad and extreme arguments.

Every call either returns finite numbers or raises a :class:`~geomech.errors.GeomechError` (an
``InputError`` naming the argument, or a ``NumericalError`` saying where and why): never another exception,
never a NaN or an infinity in what it returns.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import geomech as gm
from geomech.analysis import Gait
from geomech.errors import GeomechError
from geomech.systems.nonholonomic_examples import chaplygin_sleigh, snakeboard

#: Fuzzing is a long verification run: `make test` and `make fuzz` run it, `make test-fast` does not.
pytestmark = pytest.mark.slow

EXAMPLES = int(os.environ.get("GEOMECH_FUZZ_EXAMPLES", "20"))

extreme = st.sampled_from(
    [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.3,
        1e-300,
        -1e-300,
        1e15,
        1e16,
        1e154,
        1e308,
        -1e308,
        float("nan"),
        float("inf"),
        -float("inf"),
        5e-324,
    ]
)
floats = st.one_of(extreme, st.floats(-1e3, 1e3, allow_nan=False))
vectors = st.integers(0, 5).flatmap(lambda n: st.lists(floats, min_size=n, max_size=n))
matrices = st.lists(st.lists(floats, min_size=3, max_size=3), min_size=3, max_size=3)
words = st.sampled_from(
    [
        "m1**2/2",
        "1/0",
        "acos(2)",
        "I",
        "oo",
        "nan",
        "sin(",
        "10**10**10",
        "foo(m1)",
        "__import__('os')",
        "m1**2*k",
        "exp(m1*1000)",
        "",
        "m1 +",
        "m1**2/(2*I1)",
    ]
)
anything = st.one_of(floats, vectors, matrices, words, st.none(), st.booleans(), st.integers(-(10**30), 10**30))

RUNS = {
    "so3.exp": (lambda v: gm.lie.so3.exp(v), st.tuples(vectors)),
    "so3.log": (lambda R: gm.lie.so3.log(R), st.tuples(matrices)),
    "se2.exp": (lambda v: gm.lie.se2.exp(v), st.tuples(vectors)),
    "se3.exp": (lambda v: gm.lie.se3.exp(v), st.tuples(st.lists(floats, min_size=6, max_size=6))),
    "quaternion.from_rotvec": (lambda v: gm.lie.quaternion.from_rotvec(v), st.tuples(vectors)),
    "quaternion.as_matrix": (lambda q: gm.lie.quaternion.as_matrix(q), st.tuples(vectors)),
    "euler.as_matrix": (lambda a: gm.lie.euler.as_matrix(a), st.tuples(vectors)),
    "euler.from_matrix": (lambda R: gm.lie.euler.from_matrix(R), st.tuples(matrices)),
    "RigidBody.exact_solution": (
        lambda I, m: gm.RigidBody(inertia=I).exact_solution(m).momentum(3.0),
        st.tuples(vectors, vectors),
    ),
    "LeftInvariantSystem.from_expression": (
        lambda h, k: gm.LeftInvariantSystem.from_expression(h, {"k": k} if "k" in str(h) else None).hamiltonian(
            [0.3, 0.2, 0.1]
        ),
        st.tuples(words, floats),
    ),
    "snakeboard": (
        lambda m, r: snakeboard(m=m, r=r, J=0.18, J0=0.05, J1=0.01).parameter_values(),
        st.tuples(anything, anything),
    ),
    "Gait.from_expressions": (
        lambda e, T: Gait.from_expressions([e, "sin(2*pi*t)"], T).r(0.25),
        st.tuples(words, floats),
    ),
    "solve": (
        lambda y0, h, tf: (
            gm.solve(_reduced(), "rk4", y0=y0, h=h, t_final=tf, raise_on_failure=False, max_steps=200_000).states
        ),
        st.tuples(vectors, floats, floats),
    ),
    "chaplygin_sleigh.simulate": (lambda tf, v: _sleigh_run(tf, v), st.tuples(floats, floats)),
}


def _reduced():
    m1, m2, m3 = gm.M_SYMBOLS
    if not hasattr(_reduced, "cached"):
        sys = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3**4 / 10)
        _reduced.cached = gm.GeneralizedSerretAndoyer(sys).reduced_system(G=1.0)
    return _reduced.cached


def _sleigh_run(t_final, v):
    from geomech.integrators import BKMM

    s = chaplygin_sleigh(m=1.0, a=0.5, I_c=0.2)
    return gm.solve(s, BKMM(), t_final=t_final, saveat=11, p0=[v, 0.1]).q


def _finite(value) -> bool:
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    arr = np.asarray(value)
    return arr.dtype.kind not in "fc" or bool(np.all(np.isfinite(arr)))


@pytest.mark.parametrize("name", sorted(RUNS))
def test_every_public_call_returns_finite_numbers_or_a_geomech_error(name):
    fn, args = RUNS[name]
    unexpected = []

    @settings(
        max_examples=EXAMPLES, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck)
    )
    @given(args)
    def check(a):
        try:
            with np.errstate(all="ignore"):
                out = fn(*a)
        except GeomechError:
            return
        except Exception as exc:  # noqa: BLE001 - collected and reported below
            unexpected.append(f"{name}{a!r}: {type(exc).__name__}: {exc}")
            return
        if not _finite(out):
            unexpected.append(f"{name}{a!r}: returned NaN or inf")

    check()
    assert not unexpected, "\n".join(unexpected[:10])
