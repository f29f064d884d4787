"""The stability map compiled against the map point by point in Python (issue 16, item 4: a map at <= 50 us a
grid point on the 2 cores, every verdict identical).

    PYTHONPATH=src python benchmarks/stability_map.py           # maps of 100 x 100, 200 x 200 and 1000 x 1000
    PYTHONPATH=src python benchmarks/stability_map.py --quick   # 100 x 100 only

Not part of the test suite. The problem: one rotor on axis 3 of the body diag(3, 2, 1) under phi(v) = k v + a v^3
with p = 0.1 (no closed-form boundary), G = 1, over k in [0.05, 0.95] and a in [-0.9, 0.9]; at each point every
relative equilibrium is found (continued along the row, searched afresh at a row's start and where the continued set
fails the Poincare-Hopf check) and the one nearest to the intermediate-axis spin is assessed three ways.

For each grid: the wall time of ``stability_map`` from the call to the Dataset in memory (dask's threaded scheduler
on every core, blocks written to a temporary Zarr store and read back), the compiled kernel alone on one core (the
whole grid in one call, no store), and the compile time apart (the first call of the process, cold: an empty
kernel cache). The Python map (``backend="python"``, the path of every family without a formula) runs on the
100 x 100 grid in the same run, and the verdicts of the two are compared point by point. Writes
``results/stability_map.json`` and ``results/stability_map.md``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent


def axes(n: int) -> tuple[tuple[str, np.ndarray], tuple[str, np.ndarray]]:
    return ("k", np.linspace(0.05, 0.95, n)), ("a", np.linspace(-0.9, 0.9, n))


def timed_map(fam: Any, n: int, backend: str) -> tuple[float, Any]:
    from geomech.analysis import stability_map

    x, y = axes(n)
    t = time.perf_counter()
    ds = stability_map(fam, x, y, backend=backend, max_points=10**7)
    return time.perf_counter() - t, ds


def kernel_alone(fam: Any, n: int) -> float:
    """The compiled search and verdicts of the whole grid in one call on one core (no dask, no store)."""
    S = importlib.import_module("geomech.analysis.stability_map")
    (_, xs), (_, ys) = axes(n)
    X, Y = np.meshgrid(xs, ys)
    t = time.perf_counter()
    S._assess_points(fam, "k", "a", {}, 1.0, np.array([0.0, 1.0, 0.0]), None, 600, True, k=X.ravel(), a=Y.ravel())
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the 100 x 100 map only")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        # a cold kernel cache of this run's own: the compile time is measured, the user's cache untouched
        os.environ["GEOMECH_CACHE_DIR"] = str(Path(scratch) / "cache")
        os.environ["NUMBA_CACHE_DIR"] = str(Path(scratch) / "numba")
        from studies import control_family  # the studies' map, imported once the caches are set

        fam = control_family()
        t = time.perf_counter()
        timed_map(fam, 2, "numba")
        compile_s = time.perf_counter() - t
        sizes = [100] if args.quick else [100, 200, 1000]
        rows = []
        maps = {}
        for n in sizes:
            wall, ds = timed_map(fam, n, "numba")
            maps[n] = ds
            alone = kernel_alone(fam, n)
            rows.append(
                {
                    "grid": f"{n} x {n}",
                    "points": n * n,
                    "wall_s": wall,
                    "us_per_point": 1e6 * wall / n**2,
                    "kernel_one_core_s": alone,
                    "kernel_us_per_point": 1e6 * alone / n**2,
                }
            )
            print(rows[-1], flush=True)
        wall_py, py = timed_map(fam, 100, "python")
        ref = maps[100]
        same = {
            name: int((ref[name].values != py[name].values).sum())
            for name in ("verdict", "lagrange_dirichlet", "energy_casimir", "linearisation", "branch_jump", "complete")
        }
        m_gap = float(np.nanmax(np.abs(ref["m"].values - py["m"].values)))
    result = {
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "python": sys.version.split()[0]},
        "compile_s_cold": compile_s,
        "compiled": rows,
        "python_100x100": {"wall_s": wall_py, "us_per_point": 1e6 * wall_py / 100**2},
        "differences_100x100": same,
        "max_m_difference_100x100": m_gap,
    }
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    (out / "stability_map.json").write_text(json.dumps(result, indent=2) + "\n")
    lines = [
        "| grid | points | map, wall (s) | us a point | kernel alone, one core (s) | us a point |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['grid']} | {r['points']:,} | {r['wall_s']:.2f} | {r['us_per_point']:.1f} | "
            f"{r['kernel_one_core_s']:.2f} | {r['kernel_us_per_point']:.1f} |"
        )
    lines.append(f"| 100 x 100, Python | 10,000 | {wall_py:.1f} | {1e6 * wall_py / 1e4:.0f} | | |")
    lines.append("")
    lines.append(
        f"Compile, cold: {compile_s:.1f} s. Points where the compiled and the Python 100 x 100 maps differ: "
        + ", ".join(f"{k} {v}" for k, v in same.items())
        + f"; largest difference of the equilibria assessed {m_gap:.1e}."
    )
    (out / "stability_map.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
