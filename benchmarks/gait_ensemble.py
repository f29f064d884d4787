"""An ensemble of snakeboard gaits in one call: geomech's compiled BKMM loop over a batch of gait coefficients,
beside heyoka's batch (SIMD) Taylor integrator over the same ensemble on the same threads.

    PYTHONPATH=src python benchmarks/gait_ensemble.py          # 10,000 gaits, about a minute
    PYTHONPATH=src python benchmarks/gait_ensemble.py --quick  # 1,000 gaits

Not part of the test suite; needs heyoka (``pip install "heyoka>=7,<8"``, the ``bench`` extra).

The problem (issue 16, item 4): the snakeboard of ``nonholonomic.py`` (m = 1, r = 0.5, J = 0.18, J0 = 0.05,
J1 = 0.01) from rest, five periods (t = 5), on the gaits psi = a sin(2 pi t), phi = b sin(2 pi t + c) with
a in [0.5, 1.5] (25 values), b in [0.2, 0.8] (20), c in [0, 2 pi) (20): 10,000 members. geomech:
``solve(s, BKMM(), shapes=..., parameters={"a": ..., "b": ..., "c": ...}, threads=2)`` (DOP853) and the same with
``BKMM(solver="taylor")``, one call from Python to the Solution (the final states, energies and shape forces of
every member), and by Taylor's method without the work of the shape forces (``work=False``: the equations heyoka
integrates). heyoka: the reduced equations in closed
form of ``nonholonomic.py`` with a, b, c as its run-time parameters (``par[0..2]``), a ``taylor_adaptive_batch`` of
the recommended SIMD width per thread, each thread propagating its half of the members batch by batch (the state
and time reset, the parameters set), 1 and 2 threads. The error is the max-norm error of (x, y, theta, p) at t = 5
over a sample of members (spread over the grid) against heyoka in quadruple precision on each. Compilation apart
on both sides. Writes ``results/gait_ensemble.json`` and ``results/gait_ensemble.md``.
"""

from __future__ import annotations

import argparse
import copy
import itertools
import json
import os
import platform
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from nonholonomic import CASES, T_SYMBOL, heyoka_equations
from work_precision import best_of, quadruple_reference

import geomech as gm
from geomech.integrators import BKMM, solve

HERE = Path(__file__).resolve().parent
SAMPLE = 6
A, B, C = sp.symbols("a b c", real=True)
FORMULAS = {"psi": A * sp.sin(2 * sp.pi * T_SYMBOL), "phi": B * sp.sin(2 * sp.pi * T_SYMBOL + C)}
GAIT = {"psi": "a*sin(2*pi*t)", "phi": "b*sin(2*pi*t + c)"}
GEOMECH_TOLS = [1e-8, 1e-10, 1e-12]
#: the compiled BKMM equations by the embedded pair and by Taylor's method; without the shape forces' work, the
#: equations heyoka is given (group motion and momentum)
METHODS = {"DOP853": BKMM(), "Taylor": BKMM(solver="taylor"), "Taylor, work=False": BKMM(solver="taylor", work=False)}
HEYOKA_TOLS = [1e-6, 1e-9, 1e-12, 1e-15]


def grid(quick: bool) -> dict[str, np.ndarray]:
    na, nb, nc = (10, 10, 10) if quick else (25, 20, 20)
    a, b, c = np.meshgrid(
        np.linspace(0.5, 1.5, na),
        np.linspace(0.2, 0.8, nb),
        np.linspace(0, 2 * np.pi, nc, endpoint=False),
        indexing="ij",
    )
    return {"a": a.ravel(), "b": b.ravel(), "c": c.ravel()}


def heyoka_batch(hy: Any, equations: list, values: dict[str, np.ndarray], T: float, tol: float, threads: int) -> tuple:
    """The final states of every member by heyoka's batch integrator over ``threads`` threads, the wall time (best
    of 3) and the integrator's construction and JIT time."""
    width = hy.recommended_simd_size()
    n_eq = len(equations)
    t = time.perf_counter()
    ta = hy.taylor_adaptive_batch(equations, np.zeros((n_eq, width)), pars=np.zeros((3, width)), tol=tol)
    jit = time.perf_counter() - t
    N = values["a"].size
    P = np.stack([values["a"], values["b"], values["c"]])
    out = np.empty((n_eq, N))
    copies = [copy.deepcopy(ta) for _ in range(threads)]
    bounds = np.linspace(0, N // width, threads + 1).astype(int) * width

    def part(i: int) -> None:
        local = copies[i]
        for j in range(bounds[i], bounds[i + 1], width):
            local.set_time(0.0)
            local.state[:] = 0.0
            local.pars[:] = P[:, j : j + width]
            local.propagate_until(T)
            out[:, j : j + width] = local.state

    def run() -> np.ndarray:
        if threads == 1:
            part(0)
        else:
            with ThreadPoolExecutor(threads) as pool:
                list(pool.map(part, range(threads)))
        return out.T.copy()

    wall, final = best_of(run, 3, budget=20.0)
    return wall, final, jit


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1,000 gaits instead of 10,000")
    args = ap.parse_args(argv)
    try:
        import heyoka as hy
    except ImportError:
        print("gait_ensemble.py: heyoka is not installed (pip install 'heyoka>=7,<8')", file=sys.stderr)
        return 2
    case = dict(CASES["snakeboard"], formulas=FORMULAS)
    s = case["build"](**case["parameters"])
    T = case["T"]
    values = grid(args.quick)
    N = values["a"].size
    threads = min(2, os.cpu_count() or 1)
    sample = np.linspace(0, N - 1, SAMPLE).astype(int)
    # the references: heyoka in quadruple precision on the sampled members, their numbers written in
    refs = []
    for i in sample:
        numbers = {A: sp.Float(values["a"][i], 34), B: sp.Float(values["b"][i], 34), C: sp.Float(values["c"][i], 34)}
        member = dict(case, formulas={k: e.xreplace(numbers) for k, e in FORMULAS.items()})
        refs.append(quadruple_reference(hy, heyoka_equations(hy, s, member), np.zeros(4), T))
    ref = np.array([r[0] for r in refs])
    cross = max(r[1] for r in refs)
    equations = heyoka_equations(hy, s, case, pars={A: hy.par[0], B: hy.par[1], C: hy.par[2]})

    def error(final: np.ndarray) -> float:
        return float(np.abs(final[sample] - ref).max())

    rows: list[dict[str, Any]] = []
    k = s.k
    for (label, method), tol in itertools.product(METHODS.items(), GEOMECH_TOLS):
        kw = dict(t_final=T, saveat=[T], shapes=GAIT, parameters=values, rtol=tol, atol=tol * 1e-2, threads=threads)
        first = solve(s, method, **kw)  # compiles (or loads the disk cache)
        wall, sol = best_of(lambda kw=kw, method=method: solve(s, method, **kw), 3, budget=30.0)
        loop = min(solve(s, method, **kw).stats["loop_time"] for _ in range(2))
        final = np.concatenate([sol.q[:, -1, :k], sol.p[:, -1]], axis=1)
        rows.append(
            dict(
                who=f"geomech BKMM compiled ({label}), {threads} threads",
                tol=tol,
                error=error(final),
                wall_s=wall,
                loop_s=loop,
                n_rhs=sol.stats["n_rhs"],
                compile_s=first.stats["compile_time"],
            )
        )
    for tol in HEYOKA_TOLS:
        for n_threads in sorted({1, threads}):
            wall, final, jit = heyoka_batch(hy, equations, values, T, tol, n_threads)
            rows.append(
                dict(
                    who=f"heyoka taylor_adaptive_batch (SIMD {hy.recommended_simd_size()}), {n_threads} thread(s)",
                    tol=tol,
                    error=error(final),
                    wall_s=wall,
                    compile_s=jit,
                    threads=n_threads,
                )
            )
    # geomech against heyoka on the same threads at the loosest tolerance that reaches geomech's error
    ratios = []
    for r in rows:
        if not r["who"].startswith("geomech"):
            continue
        match = [h for h in rows if h.get("threads") == threads and h["error"] <= r["error"]]
        peer = min(match, key=lambda h: -h["tol"]) if match else None
        ratios.append(
            dict(
                tol=r["tol"],
                error=r["error"],
                geomech_s=r["wall_s"],
                heyoka_tol=None if peer is None else peer["tol"],
                heyoka_error=None if peer is None else peer["error"],
                heyoka_s=None if peer is None else peer["wall_s"],
                ratio=None if peer is None else r["wall_s"] / peer["wall_s"],
            )
        )
    out = dict(
        machine=f"{platform.machine()} {platform.processor()}, {platform.python_version()}, {os.cpu_count()} CPUs",
        versions=dict(geomech=gm.__version__, heyoka=hy.__version__, numpy=np.__version__),
        command="PYTHONPATH=src python benchmarks/gait_ensemble.py" + (" --quick" if args.quick else ""),
        members=N,
        sample=sample.tolist(),
        reference="heyoka real128, tol 1e-32, on the sampled members",
        cross_check_long_double=cross,
        rows=rows,
        ratios=ratios,
    )
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    (results / "gait_ensemble.json").write_text(json.dumps(out, indent=1) + "\n")
    lines = [
        f"### {N} snakeboard gaits, t = {T:g} (reference cross-check: {cross:.1e})",
        "",
        "| integrator | tolerance | error | wall time from the Python call (s) | compiled loop alone (s) "
        "| evaluations |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        loop = f"{r['loop_s']:.3f}" if "loop_s" in r else ""
        lines.append(
            f"| {r['who']} | {r['tol']:.0e} | {r['error']:.1e} | {r['wall_s']:.3f} | {loop} | {r.get('n_rhs', '')} |"
        )
    lines += [
        "",
        f"geomech / heyoka ({threads} threads each) at equal or smaller error:",
        "",
        "| geomech tolerance | error | geomech (s) | heyoka tolerance | heyoka error | heyoka (s) | ratio |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in ratios:
        if r["ratio"] is None:
            lines.append(f"| {r['tol']:.0e} | {r['error']:.1e} | {r['geomech_s']:.3f} | (none as accurate) | | | |")
        else:
            lines.append(
                f"| {r['tol']:.0e} | {r['error']:.1e} | {r['geomech_s']:.3f} | {r['heyoka_tol']:.0e} | "
                f"{r['heyoka_error']:.1e} | {r['heyoka_s']:.3f} | {r['ratio']:.2f} |"
            )
    table = "\n".join(lines) + "\n"
    (results / "gait_ensemble.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
