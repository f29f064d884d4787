"""Work-precision benchmark of geomech's integrators beside scipy's solve_ivp and heyoka's Taylor integrator.

    PYTHONPATH=src python benchmarks/work_precision.py            # the full run (about 3.5 minutes)
    PYTHONPATH=src python benchmarks/work_precision.py --quick    # a 1-minute version

Not part of the test suite. heyoka (``pip install "heyoka>=7,<8"``) is the peer and also gives the
extended-precision reference; without it the harness stops with exit status 2, unless ``--skip-heyoka``
is given (then the reference of problem 1 is the quadrature propagator cross-checked against DOP853 at
tolerance 1e-14, and the heyoka rows are missing).

Problems
--------
1. ``reduced``: the reduced closed loop of section 8 of the Serret-Andoyer paper,

   .. math::

       h_p(l, L) = \\tfrac12 (G^2 - L^2)\\Bigl(\\frac{\\sin^2 l}{\\lambda_1} + \\frac{\\cos^2 l}{\\lambda_2}\\Bigr)
                 + \\frac{L^2}{2 I_3} + \\frac{2 G}{I_3} \\log\\cos\\frac{L}{G},

   (the last term is :math:`-\\frac{1}{I_3}\\int_0^L \\varphi(v)\\,dv` with :math:`\\varphi(v) = 2\\tan(v/G)`),
   :math:`\\lambda_1 = 3, \\lambda_2 = 2, I_3 = 1, G = 1, p = 0`, from :math:`(l, L) = (0.3, 0.2)`.
   Reference: heyoka's Taylor integrator in quadruple precision (real128, tolerance 1e-34) at t = 1000
   and in 80-bit long double at t = 1e5 (real128 there would take minutes); their difference at t = 1000
   and the quadrature propagator are reported as cross-checks.
2. ``free_body``: Euler's equations of ``RigidBody([3, 2, 1])`` from ``m0 = (1, 0.3, 0.2)``. Reference: the
   exact solution (Jacobi elliptic functions), cross-checked against heyoka in long double.

Measured, in one run: the max-norm error of the state at t = 1000 and the largest energy error
``max_k |H(y_k) - H(y_0)|`` along the run (at the saved states: about 2000 of them for geomech, every
accepted step for scipy, a grid of 2001 points for heyoka) against the wall time (best of several repeats;
compilation and construction timed apart); the long run t = 1e5 for the best few; the cost of a step of
the implicit midpoint rule at h = 1e-3; the throughput of the Lie-Poisson splitting on 1e5 initial
conditions. Writes ``results/work_precision.json`` (every number), ``results/tables.md`` and the figure.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.integrators import AdaptiveAdams, Kind, QuadraturePropagator, compatible_methods, get_method, solve
from geomech.integrators.periodic import PeriodicOrbitPropagator

HERE = Path(__file__).resolve().parent
T_SHORT = 1000.0
T_LONG = 1e5
N_ENERGY = 2000  # saved states per run at which the energy is measured

# step sizes at t = 1000 by order of the method (each divides 1000 exactly)
H_GRID = {
    1: [1e-2, 4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4],
    2: [5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3],
    4: [2e-1, 1e-1, 5e-2, 2.5e-2, 1.25e-2, 6.25e-3],
    6: [4e-1, 2e-1, 1e-1, 5e-2, 2.5e-2],
    8: [5e-1, 4e-1, 2.5e-1, 2e-1, 1e-1],
    10: [1.25, 1.0, 8e-1, 5e-1, 4e-1, 2.5e-1, 2e-1],
    12: [1.25, 1.0, 8e-1, 5e-1, 4e-1, 2.5e-1],
}
H_GRID_QUICK = {
    1: [4e-3, 1e-3],
    2: [2e-2, 5e-3, 1e-3],
    4: [1e-1, 2.5e-2],
    6: [2e-1, 5e-2],
    8: [4e-1, 2e-1],
    10: [5e-1, 2.5e-1],
    12: [5e-1, 2.5e-1],
}
SCIPY_TOLS = {"RK45": [1e-6, 1e-8, 1e-10], "DOP853": [1e-8, 1e-10, 1e-12, 1e-14], "LSODA": [1e-6, 1e-8, 1e-10, 1e-12]}
SCIPY_TOLS_QUICK = {"RK45": [1e-8], "DOP853": [1e-10, 1e-13], "LSODA": [1e-10]}
HEYOKA_TOLS = [1e-6, 1e-9, 1e-12, 1e-13, 1e-14, 1e-15]
HEYOKA_TOLS_QUICK = [1e-9, 1e-15]
ADAMS_TOLS = [1e-8, 1e-10, 1e-12]
# the compiled Dormand-Prince pairs
DP_TOLS = {"dop853": [1e-8, 1e-10, 1e-12, 1e-14], "dopri5": [1e-8, 1e-10, 1e-12]}
DP_TOLS_QUICK = {"dop853": [1e-10, 1e-13], "dopri5": [1e-10]}
ADAMS_TOLS_QUICK = [1e-10]
QUAD_TOLS = [1e-8, 1e-10, 1e-12, 1e-14]
QUAD_TOLS_QUICK = [1e-10, 1e-14]
PERIODIC_TOLS = [1e-12, 1e-13, 1e-14, 1e-15]
PERIODIC_TOLS_QUICK = [1e-13, 1e-15]
EXACT = ("quadrature", "periodic_orbit")  # propagators through the period: cost independent of t
ADAPTIVE = ("adams", "dop853", "dopri5")  # adaptive methods: rows by tolerance, not by step


# -- problems -------------------------------------------------------------------------------------------
class Problem:
    """One benchmark problem: its geomech system, its right-hand side for scipy and heyoka, its energy and
    its reference solution."""

    name: str
    label: str
    kind: str  # "canonical" (y0) or "lie_poisson" (m0)
    y0: np.ndarray
    system: Any

    def energy(self, Y: np.ndarray) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def heyoka_system(self, hy: Any) -> list:  # pragma: no cover - overridden
        raise NotImplementedError

    def init_kwargs(self, y0: Any = None) -> dict[str, Any]:
        key = "y0" if self.kind == "canonical" else "m0"
        return {key: self.y0 if y0 is None else y0}


class ReducedClosedLoop(Problem):
    name, label, kind = "reduced", "reduced closed loop $h_p(l, L)$", "canonical"

    def __init__(self) -> None:
        l, L = sp.symbols("l L", real=True)
        lam1, lam2, I3, G = 3, 2, 1, 1
        self.expr = (
            sp.Rational(1, 2) * (G**2 - L**2) * (sp.sin(l) ** 2 / lam1 + sp.cos(l) ** 2 / lam2)
            + L**2 / (2 * I3)
            + 2 * G * sp.log(sp.cos(L / G)) / I3
        )
        self.system = gm.systems.CanonicalSystem.from_expression(
            self.expr, (l,), (L,), name="reduced closed loop h_p", angle_coordinates=(0,)
        )
        self.y0 = np.array([0.3, 0.2])
        # scipy's right-hand side from sympy directly (an independent route from geomech's code generation)
        self._H = sp.lambdify((l, L), self.expr, "numpy")
        dl = sp.lambdify((l, L), sp.diff(self.expr, L), "math")
        dL = sp.lambdify((l, L), -sp.diff(self.expr, l), "math")
        self._rhs = lambda t, y: np.array((dl(y[0], y[1]), dL(y[0], y[1])))

    def energy(self, Y: np.ndarray) -> np.ndarray:
        return self._H(Y[..., 0], Y[..., 1])

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        return self._rhs(t, y)

    def heyoka_system(self, hy: Any) -> list:
        l, L = hy.make_vars("l", "L")
        H = 0.5 * (1.0 - L**2) * (hy.sin(l) ** 2 / 3.0 + hy.cos(l) ** 2 / 2.0) + L**2 / 2.0 + 2.0 * hy.log(hy.cos(L))
        return [(l, hy.diff(H, L)), (L, -hy.diff(H, l))]


class FreeBody(Problem):
    name, label, kind = "free_body", "free rigid body, Euler's equations", "lie_poisson"

    def __init__(self) -> None:
        self.inertia = np.array([3.0, 2.0, 1.0])
        self.system = gm.RigidBody(self.inertia)
        self.y0 = np.array([1.0, 0.3, 0.2])
        self.exact = self.system.exact_solution(self.y0)

    def energy(self, Y: np.ndarray) -> np.ndarray:
        return 0.5 * np.sum(Y**2 / self.inertia, axis=-1)

    def rhs(self, t: float, m: np.ndarray) -> np.ndarray:
        return np.cross(m, m / self.inertia)

    def heyoka_system(self, hy: Any) -> list:
        m = hy.make_vars("m1", "m2", "m3")
        w = [m[i] / float(self.inertia[i]) for i in range(3)]
        return [
            (m[0], m[1] * w[2] - m[2] * w[1]),
            (m[1], m[2] * w[0] - m[0] * w[2]),
            (m[2], m[0] * w[1] - m[1] * w[0]),
        ]


# -- timing ---------------------------------------------------------------------------------------------
def peer_options(doc: str, script: str, argv: list[str] | None) -> tuple[argparse.Namespace, Any]:
    """The options of a benchmark beside heyoka (``--quick``) and heyoka itself, or None where it is not installed
    (said on stderr): the scripts' common start."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer tolerances and repeats")
    args = ap.parse_args(argv)
    try:
        import heyoka as hy
    except ImportError:
        print(f"{script}: heyoka is not installed (pip install 'heyoka>=7,<8')", file=sys.stderr)
        return args, None
    return args, hy


def best_of(fn: Callable[[], Any], repeats: int, budget: float = 3.0) -> tuple[float, Any]:
    """Best wall time of up to ``repeats`` calls (fewer once ``budget`` seconds are spent), and the last result."""
    best, spent, out = math.inf, 0.0, None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t
        best, spent = min(best, dt), spent + dt
        if spent > budget:
            break
    return best, out


def best_run_time(fn: Callable[[], Any], repeats: int, budget: float = 3.0) -> tuple[float, Any, float]:
    """As :func:`best_of` but with geomech's own ``stats['run_time']`` (the compiled loop); also returns the
    best time of the whole ``solve`` call (validation, set-up and the invariants along the way included)."""
    best, best_call, spent, out = math.inf, math.inf, 0.0, None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t
        spent += dt
        best, best_call = min(best, out.stats["run_time"]), min(best_call, dt)
        if spent > budget:
            break
    return best, out, best_call


# -- references -----------------------------------------------------------------------------------------
def heyoka_reference(hy: Any, prob: Problem, T: float, fp: str) -> tuple[np.ndarray, float]:
    if fp == "real128":
        q = hy.real128
        ta = hy.taylor_adaptive(prob.heyoka_system(hy), np.array([q(float(v)) for v in prob.y0]), fp_type=q)
        t = time.perf_counter()
        ta.propagate_until(q(T))
    else:
        ld = np.longdouble
        ta = hy.taylor_adaptive(prob.heyoka_system(hy), prob.y0.astype(ld), fp_type=ld)
        t = time.perf_counter()
        ta.propagate_until(ld(T))
    return np.array([float(v) for v in ta.state]), time.perf_counter() - t


def references(prob: Problem, hy: Any, log: Callable[[str], None]) -> dict[str, Any]:
    """States at T_SHORT and T_LONG, with the cross-checks that say how far they can be trusted."""
    out: dict[str, Any] = {}
    if isinstance(prob, ReducedClosedLoop):
        quad = QuadraturePropagator(prob.system, prob.y0, L_bounds=(-1, 1), tol=1e-14)
        q_short, q_long = quad.state(T_SHORT), quad.state(T_LONG)
        if hy is not None:
            r128, c128 = heyoka_reference(hy, prob, T_SHORT, "real128")
            rld, cld = heyoka_reference(hy, prob, T_SHORT, "longdouble")
            rld_long, cld_long = heyoka_reference(hy, prob, T_LONG, "longdouble")
            out.update(
                short=r128,
                long=rld_long,
                source_short="heyoka real128 (tol 1e-34)",
                source_long="heyoka long double (tol 1.1e-19)",
                check={
                    "longdouble_vs_real128_at_1e3": float(np.max(np.abs(rld - r128))),
                    "quadrature_vs_reference_at_1e3": float(np.max(np.abs(q_short - r128))),
                    "quadrature_vs_reference_at_1e5": float(np.max(np.abs(q_long - rld_long))),
                    "reference_run_time_s": {"real128_1e3": c128, "longdouble_1e3": cld, "longdouble_1e5": cld_long},
                },
            )
        else:
            with warnings.catch_warnings():  # scipy raises rtol = 1e-14 to 2.2e-14 and says so
                warnings.simplefilter("ignore", UserWarning)
                dop = solve_ivp(prob.rhs, (0, T_SHORT), prob.y0, method="DOP853", rtol=1e-14, atol=1e-14)
            out.update(
                short=q_short,
                long=q_long,
                source_short="QuadraturePropagator (tol 1e-14)",
                source_long="QuadraturePropagator (tol 1e-14)",
                check={"dop853_1e-14_vs_quadrature_at_1e3": float(np.max(np.abs(dop.y[:, -1] - q_short)))},
            )
    else:
        out.update(
            short=prob.exact.momentum(T_SHORT),
            long=prob.exact.momentum(T_LONG),
            source_short="exact solution (Jacobi elliptic functions)",
            source_long="exact solution",
            check={},
        )
        if hy is not None:
            rld, _ = heyoka_reference(hy, prob, T_SHORT, "longdouble")
            out["check"]["longdouble_heyoka_vs_exact_at_1e3"] = float(np.max(np.abs(rld - out["short"])))
    for k, v in out["check"].items():
        if not isinstance(v, dict):
            log(f"    reference check {k}: {v:.2e}")
    return out


# -- the runs -------------------------------------------------------------------------------------------
def energy_error(prob: Problem, Y: np.ndarray) -> float:
    E0 = prob.energy(prob.y0)
    return float(np.max(np.abs(prob.energy(Y) - E0)))


def drift_ratio(prob: Problem, Y: np.ndarray) -> float:
    """max |dE| over the second half of the run over max |dE| over the first: about 1 when the error is
    bounded, about 2 for a linear drift."""
    dE = np.abs(prob.energy(Y) - prob.energy(prob.y0))
    half = len(dE) // 2
    return float(np.max(dE[half:]) / max(np.max(dE[1:half]), 1e-300))


def saved_times(n: int, every: int, h: float, T: float) -> Any:
    """``saveat`` keeping every ``every``-th of the times ``k h``, k = 0..n (n h = T), and T."""
    if n % every == 0:
        return n // every + 1
    times = h * np.append(np.arange(0, n + 1, every), n).astype(float)
    times[-1] = T
    return times


def run_geomech(
    prob: Problem, key: str, method: Any, h: float, T: float, ref: np.ndarray, repeats: int, tol: float | None = None
) -> dict:
    """A fixed-step method with step ``h``, or an adaptive one with tolerance ``tol`` and an output every ``h``."""
    n = int(round(T / h))
    save = max(1, n // N_ENERGY)
    kwargs = prob.init_kwargs()
    kwargs["saveat"] = saved_times(n, save, h, T)
    if get_method(method).kind is Kind.ADAPTIVE:
        kwargs.update(rtol=tol, atol=tol)
    else:
        kwargs["h"] = h
    first = solve(prob.system, method, t_final=T, raise_on_failure=False, **kwargs)
    rec = {
        "solver": "geomech",
        "method": key,
        "param": "h",
        "value": h,
        "T": T,
        "compile_time": first.stats["compile_time"],
    }
    if not first.success:
        rec.update(status=first.status.value, message=first.message)
        return rec
    wall, sol, call = best_run_time(lambda: solve(prob.system, method, t_final=T, **kwargs), repeats)
    Y = sol.states
    rec.update(
        status="success",
        wall=wall,
        call_time=call,
        error=float(np.max(np.abs(Y[-1] - ref))),
        energy_error=energy_error(prob, Y),
        drift=drift_ratio(prob, Y),
        n_steps=n,
        ns_per_step=wall / n * 1e9,
    )
    return rec


def run_scipy(prob: Problem, name: str, tol: float, T: float, ref: np.ndarray, repeats: int) -> dict:
    fn = lambda: solve_ivp(prob.rhs, (0.0, T), prob.y0, method=name, rtol=tol, atol=tol)
    wall, sol = best_of(fn, repeats, budget=4.0)
    rec = {"solver": "scipy", "method": name, "param": "tol", "value": tol, "T": T, "compile_time": 0.0}
    if not sol.success:
        rec.update(status="failed", message=sol.message)
        return rec
    Y = sol.y.T
    rec.update(
        status="success",
        wall=wall,
        error=float(np.max(np.abs(Y[-1] - ref))),
        energy_error=energy_error(prob, Y),
        drift=drift_ratio(prob, Y),
        n_steps=int(sol.t.size - 1),
        nfev=int(sol.nfev),
    )
    return rec


def heyoka_timed(hy: Any, system: list, y0: np.ndarray, T: float, tol: float, repeats: int) -> tuple:
    """heyoka's ``propagate_until(T)`` from a reset state, best of ``repeats``: (wall time, final state, the
    integrator, its construction and JIT time, which is not in the wall time)."""
    t = time.perf_counter()
    ta = hy.taylor_adaptive(system, y0.copy(), tol=tol)
    compile_time = time.perf_counter() - t

    def run() -> np.ndarray:
        ta.time = 0.0
        ta.state[:] = y0
        ta.propagate_until(T)
        return ta.state.copy()

    wall, final = best_of(run, repeats)
    return wall, final, ta, compile_time


def heyoka_rows(hy: Any, system: list, y0: np.ndarray, T: float, ref: np.ndarray, tols: Any, repeats: int) -> list:
    """One table row per tolerance of heyoka on ``system`` (the error of the state at ``T`` against ``ref``)."""
    rows = []
    for tol in tols:
        wall, state, _, jit = heyoka_timed(hy, system, y0, T, tol, repeats)
        rows.append(
            dict(
                who="heyoka taylor_adaptive",
                tol=tol,
                error=float(np.abs(state - ref).max()),
                wall_ms=wall * 1e3,
                compile_s=jit,
            )
        )
    return rows


def quadruple_reference(hy: Any, system: list, y0: np.ndarray, T: float) -> tuple[np.ndarray, float]:
    """The state at ``T`` by heyoka in quadruple precision (real128, tolerance 1e-32), and its distance to heyoka
    in long double (tolerance 1e-19): the reference and how far it can be trusted."""
    q = hy.real128
    ta = hy.taylor_adaptive(system, np.array([q(float(v)) for v in y0]), fp_type=q, tol=q("1e-32"))
    ta.propagate_until(q(T))
    ref = np.array([float(v) for v in ta.state])
    ld = np.longdouble
    check = hy.taylor_adaptive(system, y0.astype(ld), fp_type=ld, tol=ld(1e-19))
    check.propagate_until(ld(T))
    return ref, float(np.abs(np.array(check.state, dtype=float) - ref).max())


def run_heyoka(hy: Any, prob: Problem, tol: float, T: float, ref: np.ndarray, repeats: int) -> dict:
    wall, final, ta, compile_time = heyoka_timed(hy, prob.heyoka_system(hy), prob.y0, T, tol, repeats)
    # the energy along the run, from a separate (untimed) run with output on a grid
    ta.time = 0.0
    ta.state[:] = prob.y0
    grid = ta.propagate_grid(np.linspace(0.0, T, N_ENERGY + 1))[-1]
    return {
        "solver": "heyoka",
        "method": "taylor_adaptive",
        "param": "tol",
        "value": tol,
        "T": T,
        "compile_time": compile_time,
        "status": "success",
        "wall": wall,
        "error": float(np.max(np.abs(final - ref))),
        "energy_error": energy_error(prob, grid),
        "drift": drift_ratio(prob, grid),
        "order": int(ta.order),
    }


def _propagator_record(
    prob: Problem, build, method: str, tol: float, T: float, ref: np.ndarray, repeats: int, compile_time: float
) -> tuple[dict, Any]:
    """Time ``build()`` plus the state at T (a new initial condition needs a new build, so that is the cost),
    then one evaluation alone, and the energy along a grid of the built propagator."""

    def run() -> tuple[Any, np.ndarray]:
        prop = build()
        return prop, prop.state(T)

    wall, (prop, final) = best_of(run, repeats)
    t = time.perf_counter()
    for _ in range(1000):
        prop.state(T)
    eval_time = (time.perf_counter() - t) / 1000
    Y = prop.state(np.linspace(0.0, T, N_ENERGY + 1))
    record = {
        "solver": "geomech",
        "method": method,
        "param": "tol",
        "value": tol,
        "T": T,
        "compile_time": compile_time,
        "status": "success",
        "wall": wall,
        "eval_time": eval_time,
        "error": float(np.max(np.abs(final - ref))),
        "energy_error": energy_error(prob, Y),
        "drift": drift_ratio(prob, Y),
        "period": prop.period,
    }
    return record, prop


def run_quadrature(prob: Problem, tol: float, T: float, ref: np.ndarray, repeats: int) -> dict:
    """The exact propagator as a method: its whole cost (tracing the orbit, building the tables, evaluating
    at T) is the wall time, since each new initial condition needs a new build."""
    record, _ = _propagator_record(
        prob,
        lambda: QuadraturePropagator(prob.system, prob.y0, L_bounds=(-1, 1), tol=tol),
        "quadrature",
        tol,
        T,
        ref,
        repeats,
        0.0,
    )
    return record


def run_periodic(prob: Problem, tol: float, T: float, ref: np.ndarray, repeats: int) -> dict:
    """The periodic-orbit propagator as a method: its whole cost (integrating one period with the compiled
    8th-order Runge-Kutta method, then the state at T) is the wall time; the first construction in the
    process (numba compiling or loading its cache) is the compile time."""
    compile_time = PeriodicOrbitPropagator(prob.system, prob.y0, L_bounds=(-1, 1), tol=tol).stats["compile_time"]
    record, po = _propagator_record(
        prob,
        lambda: PeriodicOrbitPropagator(prob.system, prob.y0, L_bounds=(-1, 1), tol=tol),
        "periodic_orbit",
        tol,
        T,
        ref,
        max(repeats, 20),
        compile_time,
    )
    record.update(period_time=po.stats["run_time"], n_mesh=po.n_mesh)
    return record


def method_order(key: str) -> int:
    order = get_method(key).order
    return 2 if order == 3 else min(order, 12)


# -- the throughput measurements ------------------------------------------------------------------------
def midpoint_step_cost(prob: ReducedClosedLoop, repeats: int, n: int) -> dict:
    kwargs = prob.init_kwargs()
    solve(prob.system, "implicit_midpoint", h=1e-3, t_final=10 * 1e-3, **kwargs)
    wall, sol, _ = best_run_time(
        lambda: solve(prob.system, "implicit_midpoint", h=1e-3, t_final=n * 1e-3, saveat=2, **kwargs),
        repeats,
        budget=6.0,
    )
    return {"h": 1e-3, "n_steps": n, "ns_per_step": wall / n * 1e9, "newton_per_step": sol.stats["n_newton"] / n}


def splitting_throughput(repeats: int, batch: int, n: int) -> list[dict]:
    m1, m2, m3 = gm.M_SYMBOLS
    closed_loop = gm.LeftInvariantSystem.from_expression(
        m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + 2 * sp.log(sp.cos(m3)), name="closed loop H_c"
    )
    rng = np.random.default_rng(0)
    m0 = rng.normal(size=(batch, 3))
    m0 /= np.linalg.norm(m0, axis=1, keepdims=True)
    out = []
    for sysname, system in (("closed loop H_c", closed_loop), ("free body [3, 2, 1]", gm.RigidBody([3, 2, 1]))):
        for key in ("strang", "splitting_4_yoshida", "splitting_4_suzuki"):
            solve(system, key, m0=m0[:2], h=1e-2, t_final=2 * 1e-2)
            for threads in (1, 2):
                wall, _, _ = best_run_time(
                    lambda system=system, key=key, threads=threads: solve(
                        system, key, m0=m0, h=1e-2, t_final=n * 1e-2, saveat=2, threads=threads
                    ),
                    repeats,
                    budget=6.0,
                )
                out.append(
                    {
                        "system": sysname,
                        "method": key,
                        "threads": threads,
                        "batch": batch,
                        "n_steps": n,
                        "wall": wall,
                        "rate": batch * n / wall,
                    }
                )
    return out


# -- reporting ------------------------------------------------------------------------------------------
def machine_info(hy: Any) -> dict:
    import numba
    import scipy

    info = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "sympy": sp.__version__,
        "geomech": getattr(gm, "__version__", "?"),
        "heyoka": getattr(hy, "__version__", None) if hy is not None else None,
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
    }
    try:
        lines = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout.splitlines()
        keep = ("Model name", "CPU(s)", "Thread(s) per core", "L2 cache", "L3 cache", "Hypervisor vendor")
        info["lscpu"] = {k.strip(): v.strip() for k, _, v in (ln.partition(":") for ln in lines) if k.strip() in keep}
    except (OSError, subprocess.CalledProcessError):
        info["lscpu"] = {}
    return info


def label(rec: dict) -> str:
    if rec["solver"] == "scipy":
        return f"scipy {rec['method']}"
    if rec["solver"] == "heyoka":
        return "heyoka taylor_adaptive"
    return rec["method"]


def fmt(x: Any, spec: str = ".2e") -> str:
    return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


def brief(records: list[dict]) -> str:
    return ", ".join(f"{r['value']:g}: {fmt(r.get('error'))} in {fmt(r.get('wall'), '.2g')} s" for r in records)


def table(records: list[dict]) -> str:
    rows = [
        "| solver / method | h or tol | state error | max energy error | E drift ratio | wall time (s) "
        "| whole call (s) | compile (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        if r.get("status") != "success":
            rows.append(f"| {label(r)} | {r['value']:g} | failed: {r.get('status')} | | | | | |")
            continue
        rows.append(
            f"| {label(r)} | {r['value']:g} | {fmt(r['error'])} | {fmt(r['energy_error'])} "
            f"| {fmt(r['drift'], '.2f')} | {fmt(r['wall'], '.3g')} | {fmt(r.get('call_time'), '.3g')} "
            f"| {fmt(r['compile_time'], '.2f')} |"
        )
    return "\n".join(rows)


def fastest_to(records: list[dict], target: float) -> dict | None:
    ok = [r for r in records if r.get("status") == "success" and r["error"] <= target]
    return min(ok, key=lambda r: r["wall"]) if ok else None


def figure(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    probs = list(results["problems"])
    fig, axes = plt.subplots(2, len(probs), figsize=(7 * len(probs), 10.5), squeeze=False)
    names = sorted({label(r) for p in results["problems"].values() for r in p["short"]})
    colors = [plt.get_cmap("tab10")(i) for i in range(10)] + [plt.get_cmap("Dark2")(i) for i in range(8)]
    markers = "os^vD<>ph"
    style = {}
    for i, name in enumerate(n for n in names if not n.startswith(("scipy", "heyoka"))):
        style[name] = {"color": colors[i % len(colors)], "marker": markers[i % len(markers)], "ls": "-", "ms": 5}
    style["quadrature"] = {"color": "m", "marker": "*", "ls": "-", "ms": 12}
    style["periodic_orbit"] = {"color": "r", "marker": "P", "ls": "-", "ms": 10}
    for i, name in enumerate(n for n in names if n.startswith("scipy")):
        style[name] = {"color": ("0.35", "0.55", "0.75")[i % 3], "marker": "s", "ls": "--", "ms": 5}
    style["heyoka taylor_adaptive"] = {"color": "k", "marker": "X", "ls": "-.", "ms": 7}
    handles = {}
    for j, pname in enumerate(probs):
        recs = [r for r in results["problems"][pname]["short"] if r.get("status") == "success"]
        groups: dict[str, list[dict]] = {}
        for r in recs:
            groups.setdefault(label(r), []).append(r)
        for name, rs in groups.items():
            rs = sorted(rs, key=lambda r: r["wall"])
            for row, key in ((0, "error"), (1, "energy_error")):
                y = np.maximum([r[key] for r in rs], 1e-17)
                (line,) = axes[row, j].loglog([r["wall"] for r in rs], y, label=name, **style[name])
                handles[name] = line
        axes[0, j].set_title(f"{results['problems'][pname]['label']}, t = {T_SHORT:g}")
        axes[0, j].set_ylabel("state error at t = 1000 (max norm)")
        axes[1, j].set_ylabel("max energy error along the run")
        for row in range(2):
            axes[row, j].set_xlabel("wall time (s), best of repeats, compilation excluded")
            axes[row, j].grid(True, which="major", alpha=0.4)
        axes[0, j].axhline(1e-11, color="grey", lw=0.8, ls=":")
    order = [n for n in names if n in handles]
    fig.legend([handles[n] for n in order], order, loc="lower center", ncol=6, fontsize=8, frameon=False)
    rows = -(-len(order) // 6)  # the legend's rows, below the axes
    fig.tight_layout(rect=(0, 0.02 + 0.016 * rows, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- main -----------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="fewer step sizes, tolerances and repeats (~1 minute)")
    parser.add_argument("--repeats", type=int, default=None, help="repeats per configuration (best is kept)")
    parser.add_argument("--skip-heyoka", action="store_true", help="run without heyoka (no peer, weaker reference)")
    parser.add_argument("--out", type=Path, default=HERE / "results", help="directory of the JSON and tables")
    parser.add_argument("--figure", type=Path, default=HERE / "work_precision.png")
    parser.add_argument(
        "--replot",
        type=Path,
        default=None,
        metavar="JSON",
        help="redraw the figure and the tables from a saved work_precision.json; run nothing",
    )
    args = parser.parse_args(argv)
    if args.replot is not None:
        saved = json.loads(args.replot.read_text())
        figure(saved, args.figure)
        (args.replot.parent / "tables.md").write_text(markdown(saved))
        return 0
    quick = args.quick
    repeats = args.repeats or (2 if quick else 5)

    try:
        import heyoka as hy
    except ImportError:
        hy = None
        if not args.skip_heyoka:
            print(
                "work_precision: heyoka is not installed; it is the benchmark's peer and its extended-precision "
                'reference. Install it with `pip install "heyoka>=7,<8"`, or pass --skip-heyoka to run the rest '
                "without it.",
                file=sys.stderr,
            )
            return 2
        print("note: heyoka missing (--skip-heyoka): no heyoka rows; reference of problem 1 by quadrature.")
    if hy is not None and not hasattr(hy, "real128"):
        print("note: this heyoka has no real128; the reference uses long double only.")

    t_start = time.perf_counter()
    log = lambda s: print(f"[{time.perf_counter() - t_start:6.1f} s] {s}", flush=True)
    hgrid = H_GRID_QUICK if quick else H_GRID
    results: dict[str, Any] = {
        "command": " ".join([Path(sys.argv[0]).name] + (argv or sys.argv[1:])),
        "quick": quick,
        "repeats": repeats,
        "machine": machine_info(hy),
        "problems": {},
    }
    log(f"machine: {results['machine']['lscpu'].get('Model name', '?')}, {os.cpu_count()} CPUs")

    for prob in (ReducedClosedLoop(), FreeBody()):
        log(f"problem {prob.name}: references")
        ref = references(prob, hy, log)
        recs: list[dict] = []
        # the fixed-step methods; adams and the exact propagators have rows of their own, lgvi_exp is lgvi at a
        # higher cost
        keys = [k for k in compatible_methods(prob.system) if get_method(k).kind is Kind.FIXED_STEP and k != "lgvi_exp"]
        for key in keys:
            for h in hgrid[method_order(key)]:
                recs.append(run_geomech(prob, key, key, h, T_SHORT, ref["short"], repeats))
            log(f"  {key}: " + brief(recs[-len(hgrid[method_order(key)]) :]))
        for tol in ADAMS_TOLS_QUICK if quick else ADAMS_TOLS:
            rec = run_geomech(prob, "adams", AdaptiveAdams(), 1.0, T_SHORT, ref["short"], repeats, tol=tol)
            rec.update(param="tol", value=tol)
            recs.append(rec)
        log("  adams (VODE, output every 1): " + brief([r for r in recs if r["method"] == "adams"]))
        for key, tols in (DP_TOLS_QUICK if quick else DP_TOLS).items():
            for tol in tols:
                rec = run_geomech(prob, key, key, 1.0, T_SHORT, ref["short"], repeats, tol=tol)
                rec.update(param="tol", value=tol)
                recs.append(rec)
            log(f"  {key} (compiled, output every 1): " + brief(recs[-len(tols) :]))
        if isinstance(prob, ReducedClosedLoop):
            for tol in QUAD_TOLS_QUICK if quick else QUAD_TOLS:
                recs.append(run_quadrature(prob, tol, T_SHORT, ref["short"], repeats))
            log("  quadrature: " + brief([r for r in recs if r["method"] == "quadrature"]))
            for tol in PERIODIC_TOLS_QUICK if quick else PERIODIC_TOLS:
                recs.append(run_periodic(prob, tol, T_SHORT, ref["short"], repeats))
            log("  periodic orbit: " + brief([r for r in recs if r["method"] == "periodic_orbit"]))
        for name, tols in (SCIPY_TOLS_QUICK if quick else SCIPY_TOLS).items():
            for tol in tols:
                recs.append(run_scipy(prob, name, tol, T_SHORT, ref["short"], max(1, repeats // 2)))
            log(f"  scipy {name}: " + brief(recs[-len(tols) :]))
        if hy is not None:
            for tol in HEYOKA_TOLS_QUICK if quick else HEYOKA_TOLS:
                recs.append(run_heyoka(hy, prob, tol, T_SHORT, ref["short"], repeats))
            log("  heyoka: " + brief([r for r in recs if r["solver"] == "heyoka"]))

        # the long run for the most accurate few whose t = 1000 run, scaled by 100, stays within a budget
        budget = 1.5 if quick else 6.0
        cand = sorted(
            (
                r
                for r in recs
                if r.get("status") == "success"
                and r["solver"] == "geomech"
                and r["method"] != "adams"
                and (r["method"] in EXACT or 100 * r["wall"] <= budget)
            ),
            key=lambda r: r["error"],
        )
        chosen, seen = [], set()
        for r in cand:
            if r["method"] not in seen:
                chosen.append(r)
                seen.add(r["method"])
            if len(chosen) == (3 if quick else 5):
                break
        # the propagators, whose cost does not grow with t, always (their most accurate run)
        for key in EXACT:
            best = next((r for r in cand if r["method"] == key), None)
            if best is not None and key not in seen:
                chosen.append(best)
                seen.add(key)
        # and, for the target at t = 1e5 to 1e-9 (a phase error growing linearly in t), the cheapest run of each
        # fixed-step method that reaches 1e-11 at t = 1000
        if not quick:
            for key in sorted({r["method"] for r in cand if r["param"] == "h" and r["method"] not in EXACT}):
                g = fastest_to([r for r in cand if r["method"] == key], 1e-11)
                if g is not None and all(g is not c for c in chosen):
                    chosen.append(g)
        long_recs = []
        for r in chosen:
            if r["method"] == "quadrature":
                long_recs.append(run_quadrature(prob, r["value"], T_LONG, ref["long"], 1 if quick else 3))
            elif r["method"] == "periodic_orbit":
                long_recs.append(run_periodic(prob, r["value"], T_LONG, ref["long"], 1 if quick else 3))
            elif r["param"] == "tol":
                rec = run_geomech(
                    prob, r["method"], r["method"], 1.0, T_LONG, ref["long"], 1 if quick else 2, tol=r["value"]
                )
                rec.update(param="tol", value=r["value"])
                long_recs.append(rec)
            else:
                long_recs.append(
                    run_geomech(prob, r["method"], r["method"], r["value"], T_LONG, ref["long"], 1 if quick else 2)
                )
        if hy is not None:
            for tol in (1e-12, 1e-13, 1e-14, 1e-15) if not quick else (1e-15,):
                long_recs.append(run_heyoka(hy, prob, tol, T_LONG, ref["long"], 1 if quick else 3))
        if not quick:
            long_recs.append(run_scipy(prob, "DOP853", 1e-12, T_LONG, ref["long"], 1))
        log(
            "  long run: "
            + ", ".join(
                f"{label(r)} {r['value']:g}: {fmt(r.get('error'))}@{fmt(r.get('wall'), '.2g')}s" for r in long_recs
            )
        )
        results["problems"][prob.name] = {
            "label": prob.label,
            "y0": prob.y0.tolist(),
            "reference": {
                "short": ref["short"].tolist(),
                "long": ref["long"].tolist(),
                "source_short": ref["source_short"],
                "source_long": ref["source_long"],
                "check": ref["check"],
            },
            "short": recs,
            "long": long_recs,
        }

    red = ReducedClosedLoop()
    results["midpoint_step"] = midpoint_step_cost(red, repeats, 200_000 if quick else 1_000_000)
    log(f"implicit midpoint, h = 1e-3: {results['midpoint_step']['ns_per_step']:.1f} ns/step")
    results["splitting"] = splitting_throughput(max(2, repeats // 2), 100_000, 50 if quick else 200)
    for r in results["splitting"]:
        log(f"  {r['system']}, {r['method']}, {r['threads']} thread(s): {r['rate']:.3g} trajectory-steps/s")

    results["targets"] = targets(results)
    results["total_time_s"] = time.perf_counter() - t_start
    args.out.mkdir(parents=True, exist_ok=True)
    tmp = args.out / "work_precision.json.tmp"
    tmp.write_text(json.dumps(results, indent=1, default=float))
    tmp.replace(args.out / "work_precision.json")
    (args.out / "tables.md").write_text(markdown(results))
    figure(results, args.figure)
    print(markdown(results))
    log(f"wrote {args.out / 'work_precision.json'}, {args.out / 'tables.md'}, {args.figure}")
    return 0


def targets(results: dict) -> list[dict]:
    """The figures of issue 4, item 3, each with the measured number and whether it is met."""
    out = []
    red = results["problems"]["reduced"]
    hey = [r for r in red["short"] if r["solver"] == "heyoka"]
    gmr = [r for r in red["short"] if r["solver"] == "geomech"]
    fixed = [r for r in gmr if r["method"] not in EXACT + ADAPTIVE]
    h_best = fastest_to(hey, 1e-11)
    for name, pool in (
        ("fixed-step geomech", fixed),
        ("quadrature propagator", [r for r in gmr if r["method"] == "quadrature"]),
        ("periodic-orbit propagator", [r for r in gmr if r["method"] == "periodic_orbit"]),
        ("compiled DOP853", [r for r in gmr if r["method"] == "dop853"]),
    ):
        g = fastest_to(pool, 1e-11)
        met = g is not None and (h_best is None or g["wall"] <= h_best["wall"])
        out.append(
            {
                "target": f"t = 1000 to 1e-11 in no more wall time than heyoka ({name})",
                "geomech": None
                if g is None
                else {"method": g["method"], "value": g["value"], "wall": g["wall"], "error": g["error"]},
                "heyoka": None
                if h_best is None
                else {"tol": h_best["value"], "wall": h_best["wall"], "error": h_best["error"]},
                "met": bool(met) if hey else None,
            }
        )
    hey_l = [r for r in red["long"] if r["solver"] == "heyoka"]
    hb = fastest_to(hey_l, 1e-9)
    for name, pool in (
        (
            "fixed-step geomech",
            [r for r in red["long"] if r["solver"] == "geomech" and r["method"] not in EXACT + ADAPTIVE],
        ),
        ("quadrature propagator", [r for r in red["long"] if r["method"] == "quadrature"]),
        ("periodic-orbit propagator", [r for r in red["long"] if r["method"] == "periodic_orbit"]),
    ):
        gb = fastest_to(pool, 1e-9)
        bounded = gb is not None and gb["drift"] < 1.5
        out.append(
            {
                "target": f"t = 1e5 to 1e-9, energy error bounded, in less wall time than heyoka ({name})",
                "geomech": None
                if gb is None
                else {
                    "method": gb["method"],
                    "value": gb["value"],
                    "wall": gb["wall"],
                    "error": gb["error"],
                    "energy_error": gb["energy_error"],
                    "drift": gb["drift"],
                },
                "heyoka": None if hb is None else {"tol": hb["value"], "wall": hb["wall"], "error": hb["error"]},
                "met": bool(gb is not None and bounded and (hb is None or gb["wall"] < hb["wall"])) if hey_l else None,
            }
        )
    ns = results["midpoint_step"]["ns_per_step"]
    out.append({"target": "implicit midpoint at h = 1e-3 in <= 100 ns a step", "value": ns, "met": ns <= 100})
    for key in ("strang", "splitting_4_yoshida", "splitting_4_suzuki"):
        rate = max(r["rate"] for r in results["splitting"] if r["system"] == "closed loop H_c" and r["method"] == key)
        out.append(
            {
                "target": f"Lie-Poisson splitting ({key}), batch 1e5, >= 2e7 trajectory-steps/s on 2 cores",
                "value": rate,
                "met": rate >= 2e7,
            }
        )
    return out


def markdown(results: dict) -> str:
    parts = []
    for p in results["problems"].values():
        parts.append(
            f"### {p['label']}: t = {T_SHORT:g}\n\nReference: {p['reference']['source_short']}; checks: "
            + ", ".join(f"{k} = {v:.1e}" for k, v in p["reference"]["check"].items() if not isinstance(v, dict))
            + "\n\n"
            + table(p["short"])
        )
        parts.append(
            f"### {p['label']}: t = {T_LONG:g}\n\nReference: {p['reference']['source_long']}\n\n" + table(p["long"])
        )
    m = results["midpoint_step"]
    parts.append(
        f"### Implicit midpoint cost\n\n{m['ns_per_step']:.1f} ns per step at h = 1e-3 ({m['n_steps']} steps, "
        f"{m['newton_per_step']:.2f} Newton iterations per step)."
    )
    rows = ["| system | method | threads | trajectory-steps/s |", "|---|---|---|---|"]
    rows += [f"| {r['system']} | {r['method']} | {r['threads']} | {r['rate']:.3g} |" for r in results["splitting"]]
    parts.append("### Lie-Poisson splitting on a batch of 1e5 initial conditions\n\n" + "\n".join(rows))
    rows = ["| target | measured | met |", "|---|---|---|"]
    for t in results["targets"]:
        if "value" in t:
            meas = f"{t['value']:.3g}"
        else:
            g, h = t["geomech"], t["heyoka"]
            meas = (
                "geomech: none reached it"
                if g is None
                else f"geomech {g['method']} ({g['value']:g}): {g['error']:.1e} in {g['wall'] * 1e3:.3g} ms"
            )
            meas += "; " + (
                ("heyoka: none reached it" if t["met"] is not None else "heyoka: not run")
                if h is None
                else f"heyoka (tol {h['tol']:g}): {h['error']:.1e} in {h['wall'] * 1e3:.3g} ms"
            )
        rows.append(f"| {t['target']} | {meas} | {'yes' if t['met'] else ('no' if t['met'] is not None else 'n/a')} |")
    parts.append("### Targets of issue 4, item 3\n\n" + "\n".join(rows))
    return "\n\n".join(parts) + "\n"


if __name__ == "__main__":
    sys.exit(main())
