"""Compiled loops as machine code of their own (``geomech.integrators._native``): the C entry built around a numba
loop computes what the loop computes, a fresh process loads and calls it without numba, a loop that needs numba's
run time is refused (and the refusal kept), an exception raised inside is reported, and the work arrays carved out
of a buffer (``_fptr.shaped``) are views of it with C strides, in numba and in the Python twins. A generated
module binds numba's names at its first use of numba (``_deferred``): a solve from a warm cache by Taylor's method or
DOP853, in a fresh process, never imports numba, and gives the result scipy's solver gives; a model function's C
twin is code of its own too, its outputs NaN where it raised."""

import json
import math
import os
import subprocess
import sys
import textwrap
import types
import uuid
from pathlib import Path

import numba
import numpy as np
import pytest

from geomech.integrators import _codegen, _native
from geomech.integrators._fptr import shaped

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="the objects read here are ELF (Linux)")


@numba.njit(error_model="numpy")
def _damped_rows(Y, X, c, steps, W):
    """Each row of Y advanced ``steps`` times by y <- y + c sin(x) y (x the row of X), through work rows carved
    out of W; returns the steps taken."""
    n, d = Y.shape
    A = shaped(W, 0, (n, d))
    for i in range(n):
        for j in range(d):
            A[i, j] = math.sin(X[i, j])
    for _ in range(steps):
        for i in range(n):
            for j in range(d):
                Y[i, j] += c * A[i, j] * Y[i, j]
    return steps * n


@numba.njit(error_model="numpy")
def _allocating(Y, n):
    Z = np.zeros(n)  # numba's allocator makes them, and releases them at the end
    W = np.empty((n, 2))
    for i in range(n):
        Z[i] = Y[i] * 2.0
        W[i, 0] = Z[i] + 1.0
    Y[:n] = W[:, 0] - Z  # a slice copied (another allocation where numba cannot tell the two apart)
    return n


@numba.njit(error_model="numpy")
def _drawing(Y, n):
    for i in range(n):
        Y[i] = np.random.random()  # numba's random generator: its run time's state
    return n


@numba.njit(error_model="numpy")
def _raising(Y, n):
    if n > Y.shape[0]:
        raise ValueError("past the end")
    Y[:n] = 1.0
    return n


def _module(**loops):
    """A stand-in for a generated kernel module: its name (unique: the cache is shared by the run) and loops."""
    return types.SimpleNamespace(__name__=f"test_native_{uuid.uuid4().hex}", **loops)


def _expected(Y, X, c, steps):
    out = Y.copy()
    for _ in range(steps):
        out += c * np.sin(X) * out
    return out


def test_the_entry_computes_what_the_numba_loop_computes():
    rng = np.random.default_rng(3)
    Y, X = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    args = (Y.copy(), X, 0.01, 50, np.empty(12))
    spec = _native.kinds(args)
    assert spec == "f2 f2 d n f1"
    module = _module(loop=_damped_rows)
    assert _native.native_loop(module, "loop", spec) == (False, None)
    entry = _native.build(module, "loop", spec)
    assert entry is not None
    out = Y.copy()
    assert entry(out, X, 0.01, 50, np.empty(12)) == 200
    ref = Y.copy()
    _damped_rows(ref, X, 0.01, 50, np.empty(12))
    # the same source compiled twice by LLVM: agreement to round-off of 50 steps, and to an independent numpy loop
    np.testing.assert_allclose(out, ref, rtol=1e-13, atol=0)
    np.testing.assert_allclose(out, _expected(Y, X, 0.01, 50), rtol=1e-12, atol=0)
    # known from now on, in this process and on disk
    assert _native.native_loop(module, "loop", spec) == (True, entry)


def test_without_numpys_layout_the_entry_takes_pointers(monkeypatch):
    # where the offsets of an array object's data and shape are not found, the entry is given numpy's pointers
    assert _native._layout() is not None  # found on this platform: the objects' entry is the one used
    module = _module(loop=_damped_rows)
    assert _native.build(module, "loop", "f2 f2 d n f1") is not None
    data = _native._path(module.__name__, "loop", "f2 f2 d n f1").read_bytes()
    monkeypatch.setattr(_native, "_layout", lambda: None)
    entry = _native._read(data, "f2 f2 d n f1")
    rng = np.random.default_rng(7)
    Y, X = rng.normal(size=(3, 5)), rng.normal(size=(3, 5))
    out = Y.copy()
    assert entry(out, X, 0.02, 30, np.empty(15)) == 90
    np.testing.assert_allclose(out, _expected(Y, X, 0.02, 30), rtol=1e-12, atol=0)


def test_a_fresh_process_calls_the_entry_without_numba(hermetic_cache):
    module = _module(loop=_damped_rows)
    spec = "f2 f2 d n f1"
    assert _native.build(module, "loop", spec) is not None
    rng = np.random.default_rng(5)
    Y, X = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    child = textwrap.dedent(
        f"""
        import json, sys, types
        import numpy as np
        from geomech.integrators import _native
        module = types.SimpleNamespace(__name__={module.__name__!r})
        known, entry = _native.native_loop(module, "loop", {spec!r})
        Y, X = np.array({Y.tolist()!r}), np.array({X.tolist()!r})
        steps = entry(Y, X, 0.01, 50, np.empty(12))
        print(json.dumps(dict(known=known, steps=steps, Y=Y.tolist(), numba="numba" in sys.modules)))
        """
    )
    env = {**os.environ, "GEOMECH_CACHE_DIR": hermetic_cache}
    done = subprocess.run([sys.executable, "-c", child], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["known"] and report["steps"] == 200
    assert report["numba"] is False
    np.testing.assert_allclose(np.array(report["Y"]), _expected(Y, X, 0.01, 50), rtol=1e-12, atol=0)


def test_a_loop_that_allocates_runs_on_the_entrys_allocator():
    module = _module(loop=_allocating)
    spec = _native.kinds((np.ones(5), 3))
    entry = _native.build(module, "loop", spec)
    assert entry is not None
    data = _native._path(module.__name__, "loop", spec).read_bytes()
    assert {"malloc", "free"} <= set(_native._parts(data)[0]["undefined"])
    Y = np.arange(6.0)
    assert entry(Y, 4) == 4
    np.testing.assert_array_equal(Y, [1.0, 1.0, 1.0, 1.0, 4.0, 5.0])
    # every array released: 200 calls making 12 MB each would hold 2.4 GB if the memory were not given back
    import resource

    big = np.ones(500_000)
    entry(big, big.shape[0])
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    for _ in range(200):
        entry(big, big.shape[0])
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 300_000
    assert np.all(big == 1.0)


def test_a_loop_that_needs_numbas_run_time_is_refused_once():
    module = _module(loop=_drawing)
    spec = _native.kinds((np.ones(5), 3))
    assert _native.build(module, "loop", spec) is None
    data = _native._path(module.__name__, "loop", spec).read_bytes()
    assert "numba_" in _native._parts(data)[0]["refused"]
    assert _native.native_loop(module, "loop", spec) == (True, None)
    # a new process reads the refusal from the cache instead of trying again
    del _native._LOOPS[module.__name__, "loop", spec]
    assert _native.native_loop(module, "loop", spec) == (True, None)


def test_a_file_that_is_not_an_entry_is_built_again():
    module = _module(loop=_damped_rows)
    spec = "f2 f2 d n f1"
    path = _native._path(module.__name__, "loop", spec)
    path.write_bytes(b"gm-native-0\n not this version's")
    assert _native.native_loop(module, "loop", spec) == (False, None)
    assert _native.build(module, "loop", spec) is not None
    del _native._LOOPS[module.__name__, "loop", spec]  # as a new process: the file is now an entry
    known, entry = _native.native_loop(module, "loop", spec)
    assert known and entry is not None


def test_an_exception_inside_is_reported():
    module = _module(loop=_raising)
    entry = _native.build(module, "loop", "f1 n")
    assert entry is not None
    Y = np.zeros(4)
    assert entry(Y, 3) == 3
    np.testing.assert_array_equal(Y, [1.0, 1.0, 1.0, 0.0])
    with pytest.raises(RuntimeError, match="raised an exception"):
        entry(Y, 9)


def test_arguments_are_checked_against_the_kinds():
    entry = _native.build(_module(loop=_damped_rows), "loop", "f2 f2 d n f1")
    assert entry is not None
    Y, X = np.ones((2, 2)), np.ones((2, 2))
    with pytest.raises(TypeError):
        entry(Y, X.astype(np.int64), 0.1, 1, np.empty(4))
    with pytest.raises(TypeError):
        entry(Y, X.ravel(), 0.1, 1, np.empty(4))
    with pytest.raises(TypeError):
        entry(Y, X, 0.1, 1)
    with pytest.raises(TypeError):
        entry(Y, np.ones((2, 4))[:, ::2], 0.1, 1, np.empty(4))
    # kinds without a C form here
    assert _native.kinds((np.ones((3, 3))[:, 1],)) is None
    assert _native.kinds((np.ones(3, dtype=np.float32),)) is None
    assert _native.kinds((True,)) is None


@pytest.mark.parametrize("objects", [True, False], ids=["array objects", "pointers"])
def test_a_bound_entry_runs_again_on_its_arrays_contents(monkeypatch, objects):
    module = _module(loop=_damped_rows)
    entry = _native.build(module, "loop", "f2 f2 d n f1")
    assert entry is not None
    if not objects:  # the entry that takes numpy's pointers, bound to them
        data = _native._path(module.__name__, "loop", "f2 f2 d n f1").read_bytes()
        monkeypatch.setattr(_native, "_layout", lambda: None)
        entry = _native._read(data, "f2 f2 d n f1")
    rng = np.random.default_rng(11)
    Y, X = np.empty((3, 4)), rng.normal(size=(3, 4))
    again = _native.bound(entry, (Y, X, 0.03, 20, np.empty(12)))
    for _ in range(3):  # a new start written into the bound array each time, its result in place
        start = rng.normal(size=(3, 4))
        Y[:] = start
        X[:] = rng.normal(size=(3, 4))  # an input's new contents are read too
        assert again() == 60
        np.testing.assert_allclose(Y, _expected(start, X, 0.03, 20), rtol=1e-12, atol=0)
    # the arguments are checked once, when bound
    with pytest.raises(TypeError):
        entry.bind(Y, X.ravel(), 0.03, 20, np.empty(12))
    # numba's kernel (or a Python function) bound alike
    Z = Y.copy()
    plain = _native.bound(_damped_rows, (Z, X, 0.03, 20, np.empty(12)))
    assert plain() == 60
    np.testing.assert_allclose(Z, _expected(Y, X, 0.03, 20), rtol=1e-12, atol=0)


def test_the_object_leaves_the_math_library_undefined():
    module = _module(loop=_damped_rows)
    assert _native.build(module, "loop", "f2 f2 d n f1") is not None
    data = _native._path(module.__name__, "loop", "f2 f2 d n f1").read_bytes()
    size = int.from_bytes(data[len(_native._MAGIC) : len(_native._MAGIC) + 8], "little")
    obj = data[len(_native._MAGIC) + 8 + size :]
    undefined = _native.undefined_symbols(obj)
    assert "sin" in undefined
    assert not [n for n in undefined if n.startswith(("NRT_", "numba_"))]
    assert _native.undefined_symbols(b"\xcf\xfa\xed\xfe" + obj[4:]) is None  # not ELF: not read


@numba.njit
def _carved(buf, n, m):
    a = shaped(buf, 2, (n, m))
    v = shaped(buf, 2 + n * m, m)
    a[1, 0] = -1.0
    v[m - 1] = -2.0
    return a.strides[0], a.strides[1], a[n - 1, m - 1]


def test_shaped_views_write_through_with_c_strides():
    buf = np.arange(30.0)
    s0, s1, last = _carved(buf, 3, 4)
    assert (s0, s1) == (32, 8) and last == 13.0
    assert buf[2 + 4] == -1.0 and buf[2 + 12 + 3] == -2.0
    # the Python twin (the loops without numba) carves the same views
    namespace: dict = {}
    exec(_codegen.python_header(), namespace)
    twin = namespace["shaped"](np.arange(30.0), 2, (3, 4))
    assert twin.base is not None and twin.shape == (3, 4) and twin[2, 3] == 13.0


def _two_runs(child: str, *argv: str, env: dict) -> list[dict]:
    """``child`` run twice in fresh processes with ``env`` (the first fills the caches if no test did, the second
    loads from them): the JSON each printed last."""
    runs = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", child, *argv], env=env, capture_output=True, text=True, timeout=600
        )
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    return runs


SOLVE_CHILD = """
import json, sys
import numpy as np
from geomech.integrators import BKMM, solve
from geomech.systems.nonholonomic_examples import chaplygin_sleigh
s = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
sol = solve(s, BKMM(solver=sys.argv[1]), t_final=10.0, saveat=5, p0=[0.3, 0.5], rtol=1e-12, atol=1e-14)
imported = "numba" in sys.modules
# numba's loops in this process: which have machine code (compiled, or loaded from numba's cache)
from geomech.integrators._codegen import loaded
compiled = sorted(f"{name}.{loop}" for name, m in list(sys.modules.items()) if name.startswith("geomech_kernels_")
                  for loop in ("taylor_run", "erk_run") if hasattr(m, loop) and loaded(getattr(m, loop)))
print(json.dumps(dict(q=sol.q.tolist(), p=sol.p.tolist(), loaded=compiled, numba=imported)))
"""


@pytest.mark.parametrize("solver", ["taylor", "DOP853"])
def test_a_solve_from_a_warm_cache_runs_without_numbas_loop(hermetic_cache, solver):
    # the Taylor loop with its coefficients' code, or the DOP853 loop with the model's C right-hand side: each
    # loaded as code of its own
    env = {**os.environ, "GEOMECH_CACHE_DIR": hermetic_cache}
    runs = _two_runs(SOLVE_CHILD, solver, env=env)
    assert runs[1]["loaded"] == []  # the loop ran from its own object: numba's loop never loaded
    assert runs[1]["numba"] is False  # nor was numba imported
    from geomech import solve
    from geomech.integrators import BKMM
    from geomech.systems.nonholonomic_examples import chaplygin_sleigh

    # another route: scipy's solver on the equations evaluated in Python
    ref = solve(chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6), BKMM(), t_final=10.0, saveat=5, p0=[0.3, 0.5], rtol=1e-13,
                atol=1e-15, backend="python")  # fmt: skip
    assert ref.stats["backend"] == "python"
    for run in runs:
        np.testing.assert_allclose(np.array(run["p"]), ref.p, rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.array(run["q"]), ref.q, rtol=0, atol=1e-9 * max(1.0, float(np.abs(ref.q).max())))


FIXED_CHILD = """
import json, sys
import sympy as sp
import geomech as gm
from geomech.integrators import solve
from geomech.integrators._codegen import loaded
method = sys.argv[1]
if method == "implicit_midpoint":  # a canonical system
    q, p = sp.symbols("q p", real=True)
    s = gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum")
    sol = solve(s, method, y0=[1.0, 0.5], h=0.05, t_final=10.0)
    y = sol.y
elif method == "discrete_lagrange_dalembert":  # a nonholonomic system's discrete map, a gait prescribed
    from geomech.systems.nonholonomic_examples import snakeboard
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    sol = solve(s, method, t_final=1.0, h=0.01, saveat=11, shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"})
    y = sol.q
else:  # Lie-Poisson
    sol = solve(gm.RigidBody([3.0, 2.0, 1.0]), method, m0=[1.0, 0.3, 0.2], h=0.05, t_final=10.0)
    y = sol.m
compiled = sorted(f"{name}.{loop}" for name, m in list(sys.modules.items()) if name.startswith("geomech_kernels_")
                  for loop in dir(m) if loop.endswith("_run") and hasattr(getattr(m, loop), "py_func")
                  and loaded(getattr(m, loop)))
print(json.dumps(dict(y=y.tolist(), backend=sol.stats["backend"], loaded=compiled, numba="numba" in sys.modules)))
"""


@pytest.mark.parametrize(
    "method", ["implicit_midpoint", "gauss_legendre_3", "splitting_4_yoshida", "discrete_lagrange_dalembert"]
)
def test_a_fixed_step_solve_from_a_warm_cache_runs_without_numba(hermetic_cache, method):
    # a fixed-step loop (Newton's iterations on the model's C functions, or a splitting calling the model's flows)
    # loaded as code of its own, with the model's functions
    env = {**os.environ, "GEOMECH_CACHE_DIR": hermetic_cache}
    runs = _two_runs(FIXED_CHILD, method, env=env)
    assert runs[1]["backend"] == "numba" and runs[1]["loaded"] == [] and runs[1]["numba"] is False
    import sympy as sp

    import geomech as gm
    from geomech import solve

    # the same method's loop run as Python (the generated module's Python twin)
    if method == "implicit_midpoint":
        q, p = sp.symbols("q p", real=True)
        s = gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum")
        ref = solve(s, method, y0=[1.0, 0.5], h=0.05, t_final=10.0, backend="python").y
    elif method == "discrete_lagrange_dalembert":
        from geomech.systems.nonholonomic_examples import snakeboard

        gait = {"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}
        s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
        ref = solve(s, method, t_final=1.0, h=0.01, saveat=11, shapes=gait, backend="python").q
    else:
        ref = solve(gm.RigidBody([3.0, 2.0, 1.0]), method, m0=[1.0, 0.3, 0.2], h=0.05, t_final=10.0,
                    backend="python").m  # fmt: skip
    for run in runs:  # Newton's tolerance (1e-14 relative) and a few hundred steps' round-off
        np.testing.assert_allclose(np.array(run["y"]), ref, rtol=0, atol=1e-11)


FLOW_CHILD = """
import json, sys
import numpy as np
from geomech import GroupFlow, solve
from geomech.lie import SE2
from geomech.integrators._codegen import loaded
flow = GroupFlow(SE2(), ["v*cos(t)", "0.2 + 0.1*g13", "w"], "SE2", parameters={"v": 1.0, "w": 0.7})
method = sys.argv[1]
times = {"rtol": 1e-10, "atol": 1e-12} if method == "rkmk" else {"h": 0.01}
sol = solve(flow, method, t_final=5.0, saveat=11, g0=flow.group.numeric.exp(np.array([0.1, 0.25, 0.4])), **times)
compiled = sorted(f"{name}.{loop}" for name, m in list(sys.modules.items()) if name.startswith("geomech_kernels_")
                  for loop in ("rkmk_run", "rkmk4_run") if hasattr(m, loop) and loaded(getattr(m, loop)))
print(json.dumps(dict(g=sol.states.tolist(), backend=sol.stats["backend"], loaded=compiled,
                      numba="numba" in sys.modules)))
"""


@pytest.mark.parametrize("method", ["rkmk4", "rkmk"])
def test_a_group_flow_from_a_warm_cache_runs_without_numba(hermetic_cache, method):
    # the RKMK loops on the group, with the field's C twin (its matrices carved by shaped, not numba's reshape)
    env = {**os.environ, "GEOMECH_CACHE_DIR": hermetic_cache}
    runs = _two_runs(FLOW_CHILD, method, env=env)
    assert runs[1]["backend"] == "numba" and runs[1]["loaded"] == [] and runs[1]["numba"] is False
    from geomech import GroupFlow, solve
    from geomech.lie import SE2

    # the Python engine
    flow = GroupFlow(SE2(), ["v*cos(t)", "0.2 + 0.1*g13", "w"], "SE2", parameters={"v": 1.0, "w": 0.7})
    times = {"rtol": 1e-10, "atol": 1e-12} if method == "rkmk" else {"h": 0.01}
    g0 = flow.group.numeric.exp(np.array([0.1, 0.25, 0.4]))
    ref = solve(flow, method, t_final=5.0, saveat=11, g0=g0, backend="python", **times)
    # RKMK4 the same steps; RKMK the same pair, its steps apart by the tolerance (scipy's start of the step size)
    atol = 1e-12 if method == "rkmk4" else 1e-8
    for run in runs:
        np.testing.assert_allclose(np.array(run["g"]), ref.states, rtol=0, atol=atol * (1.0 + np.abs(ref.states).max()))


PERIODIC_CHILD = """
import json, sys
import sympy as sp
import geomech as gm
from geomech.integrators import solve
from geomech.integrators._codegen import loaded
q, p = sp.symbols("q p", real=True)
s = gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum", angle_coordinates=(0,))
sol = solve(s, "periodic_orbit", y0=[float(v) for v in sys.argv[1:]], t_final=1000.0, saveat=11)
compiled = sorted(f"{name}.{loop}" for name, m in list(sys.modules.items()) if name.startswith("geomech_kernels")
                  for loop in ("orbit_return", "orbit_states") if hasattr(m, loop)
                  and hasattr(getattr(m, loop), "py_func") and loaded(getattr(m, loop)))
print(json.dumps(dict(y=sol.y.tolist(), backend=sol.stats["backend"], loaded=compiled, numba="numba" in sys.modules)))
"""


@pytest.mark.parametrize("y0", [(1.0, 0.5), (0.0, 2.5)], ids=["libration", "rotation"])
def test_a_periodic_orbit_from_a_warm_cache_runs_without_numba(hermetic_cache, y0):
    # the return to the section and the states from the mesh: both loops loaded as code of their own
    env = {**os.environ, "GEOMECH_CACHE_DIR": hermetic_cache}
    runs = _two_runs(PERIODIC_CHILD, *map(str, y0), env=env)
    assert runs[1]["backend"] == "numba" and runs[1]["loaded"] == [] and runs[1]["numba"] is False
    import sympy as sp

    import geomech as gm
    from geomech import solve

    q, p = sp.symbols("q p", real=True)
    s = gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum", angle_coordinates=(0,))
    # another route to the same motion: the period and the states by quadrature along the level curve
    ref = solve(s, gm.integrators.Quadrature(tol=1e-13), y0=list(y0), t_final=1000.0, saveat=11).y
    # the phase at t = 1000 carries the periods' errors, 1e-13 relative at most: tol x t x the largest speed
    atol = 1e-13 * 1000.0 * (1.0 + float(np.abs(ref[:, 1]).max()))
    for run in runs:
        np.testing.assert_allclose(np.array(run["y"]), ref, rtol=0, atol=atol)


TWIN_MODULE = """
from geomech.integrators._deferred import Deferred
from geomech.integrators._native import Addresses

_DEFERRED = Deferred(globals())
numba = _DEFERRED.numba


def _rhs_c(y_, out_, prm_, d, n_prm):
    y = numba.carray(y_, (d,))
    out = numba.carray(out_, (d,))
    prm = numba.carray(prm_, (n_prm,))
    for i in range(d):
        out[i] = prm[0] / y[i]  # a ZeroDivisionError at y[i] = 0 (a cfunc's error model is Python's)


addresses = Addresses(globals())
"""

TWIN_CALL = """
import ctypes, importlib, json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from geomech.integrators._k_common import MODEL_FUNCTIONS
module = importlib.import_module(sys.argv[2])
address = int(module.addresses(("rhs",))[MODEL_FUNCTIONS.index("rhs")])
p = ctypes.c_void_p
twin = ctypes.CFUNCTYPE(None, p, p, p, ctypes.c_int64, ctypes.c_int64)(address)
out = {}
for case, y in (("finite", [2.0, -4.0, 0.5]), ("raised", [2.0, 0.0, 0.5])):
    y, f, prm = np.array(y), np.zeros(3), np.array([3.0])
    twin(y.ctypes.data, f.ctypes.data, prm.ctypes.data, 3, 1)
    out[case] = [None if v != v else v for v in f.tolist()]
print(json.dumps(dict(out, numba="numba" in sys.modules)))
"""


def test_a_model_functions_c_twin_is_code_of_its_own(hermetic_cache, tmp_path):
    name = f"twin_{uuid.uuid4().hex}"
    (tmp_path / f"{name}.py").write_text(TWIN_MODULE)
    env = {**os.environ, "GEOMECH_CACHE_DIR": hermetic_cache, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    # the first compiles the twin by numba and builds its own code, the second loads that
    runs = _two_runs(TWIN_CALL, str(tmp_path), name, env=env)
    assert runs[0]["numba"] is True and runs[1]["numba"] is False
    for run in runs:
        assert run["finite"] == [1.5, -0.75, 6.0]
        assert run["raised"] == [None, None, None]  # the outputs NaN where the function raised: the loop sees it
    assert len(list(Path(hermetic_cache).glob("kernels/gm_native_*.bin"))) >= 1


DEFERRED_MODULE = """
from geomech.integrators._deferred import Deferred
_DEFERRED = Deferred(globals())
numba = _DEFERRED.numba
kernel = _DEFERRED.kernel(cache=False, error_model="numpy")


@kernel
def twice(x):
    return 2.0 * x


@kernel
def total(a):
    out = 0.0
    for i in numba.prange(a.shape[0]):
        out += a[i]
    return out
"""

USER_MODULE = """
from geomech.integrators._deferred import Deferred
_DEFERRED = Deferred(globals())
kernel = _DEFERRED.kernel(cache=False)


@kernel
def four_times(x):
    return twice(twice(x))
"""


def test_a_module_binds_numba_at_its_first_use():
    from geomech.integrators._deferred import Pending

    shared: dict = {"np": np}
    exec(DEFERRED_MODULE, shared)
    user: dict = {"twice": shared["twice"]}  # a helper of the shared module, as the model modules import them
    exec(USER_MODULE, user)
    assert isinstance(user["four_times"], Pending) and isinstance(shared["twice"], Pending)
    assert user["four_times"].py_func(1.5) == 6.0  # the Python function, numba not involved
    assert user["four_times"](1.5) == 6.0  # the first call binds both modules
    assert isinstance(user["four_times"], numba.core.dispatcher.Dispatcher)
    assert user["twice"] is shared["twice"] and isinstance(shared["twice"], numba.core.dispatcher.Dispatcher)
    assert shared["numba"] is numba
    assert shared["total"](np.array([3.0, 4.0])) == 7.0  # numba's own names, read inside a kernel
