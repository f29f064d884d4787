"""Cold symbolic derivation: ``geomech derive NAME`` for every built-in nonholonomic example (issue 16, item 5).

Each example runs in a fresh process with the derivation cache off (``GEOMECH_CACHE_DIR=off``), so nothing is
reused, through the command's own entry point (``_geomech_cli.main``, as the ``geomech`` script runs it): the time
of the whole command (the process's wall time, from its start to its exit, measured by this harness), the time to
import geomech and the time of the derivation (every section, printed as ``derive`` prints it), and a digest of the
printed text (two runs whose digests agree printed the same formulas, so neither is larger). Python's bytecode is
compiled once before the timed runs (into a temporary ``PYTHONPYCACHEPREFIX``), as an installed package has it.
A user's model of the same size is timed the same way (``models/tilted_sleigh.py``, its BKMM section and every
section, the tilt a number and a symbol). Best of ``--repeats`` runs; a run past ``--limit`` seconds is not
repeated. Then compiled models (``LOAD_CASES``: Taylor's, Runge-Kutta and fixed-step loops, RKMK on a group, the
periodic-orbit propagator), each in a fresh process whose caches are warm (a private cache directory filled by a
first run): the time to build the system and of the first solve, of which loading the kernels, and of the next
solve, and whether numba was imported.
Writes ``results/derivation.json`` and ``results/derivation.md``.

    PYTHONPATH=src python benchmarks/derivation.py [--repeats 3] [--limit 120] [--only snakeboard ...]
    PYTHONPATH=src python benchmarks/derivation.py --cache empty   # a user's first run: the cache empty, then filled
    PYTHONPATH=src python benchmarks/derivation.py --load-only     # the warm load alone: results/derivation_load.*
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
#: One cold run through the command's entry point: the import, then the derivation of every section, timed apart;
#: prints one JSON line (after the command's own output, which it keeps to hash it).
CHILD = r"""
import contextlib, hashlib, io, json, sys, time
t0 = time.perf_counter()
import _geomech_cli
from geomech.cli.main import main
t1 = time.perf_counter()
sys.argv = ["geomech", "derive", *sys.argv[1:]]
out = io.StringIO()
with contextlib.redirect_stdout(out):
    code = _geomech_cli.main()
t2 = time.perf_counter()
text = out.getvalue()
from sympy.external.gmpy import GROUND_TYPES
print(json.dumps(dict(code=code, import_s=t1 - t0, derive_s=t2 - t1, chars=len(text),
                      digest=hashlib.sha256(text.encode()).hexdigest()[:16], ground_types=GROUND_TYPES)))
"""


def examples() -> list[str]:
    from geomech.systems.models import EXAMPLES

    return list(EXAMPLES)


#: A user's model of the same size as the examples (issue 16): the tilted-blade sleigh with a sliding mass, its
#: BKMM section as the issue times it and every section, the tilt a number and a symbol.
MODEL = str(HERE / "models" / "tilted_sleigh.py")
MODEL_CASES = {
    "tilted_sleigh --section bkmm": [MODEL, "--section", "bkmm"],
    "tilted_sleigh --section bkmm, symbolic tilt": [MODEL, "--section", "bkmm", "--param", "symbolic_tilt=1"],
    "tilted_sleigh": [MODEL],
    "tilted_sleigh, symbolic tilt": [MODEL, "--param", "symbolic_tilt=1"],
}


def one(name: str, limit: float, pycache: str, cache: str = "off") -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as empty:
        env = {**os.environ, "GEOMECH_CACHE_DIR": empty if cache == "empty" else "off", "PYTHONPYCACHEPREFIX": pycache}
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        start = time.perf_counter()
        try:
            done = subprocess.run(
                [sys.executable, "-c", CHILD, *MODEL_CASES.get(name, [name])],
                env=env,
                capture_output=True,
                text=True,
                timeout=limit,
                check=False,
            )
        except subprocess.TimeoutExpired:
            return dict(code=None, error=[f"more than {limit:g} s"])
        wall = time.perf_counter() - start
    if done.returncode != 0 or not done.stdout.strip():
        return dict(code=done.returncode, error=done.stderr.strip().splitlines()[-1:] or ["no output"])
    return {**json.loads(done.stdout.strip().splitlines()[-1]), "command_s": wall}


#: A compiled model in a fresh process whose caches (derivations, generated source, numba's kernels) are warm: the
#: snakeboard's BKMM equations by Taylor's method, the benchmarks' case (nonholonomic.py).
# the compiled models whose load is measured, each in a fresh process: the system built, then its first and second
# solve (a case's name is the child's argument)
LOAD_CASES = {
    "taylor": "snakeboard, BKMM by Taylor's method, 5 periods",
    "dop853": "snakeboard, BKMM by DOP853 (the default), 5 periods",
    "gauss": "free rigid body I = (3, 2, 1), Gauss-Legendre s = 3, h = 0.05, t = 1000",
    "midpoint": "pendulum (canonical), implicit midpoint, h = 0.05, t = 1000",
    "dlda": "snakeboard, the discrete Lagrange-d'Alembert map, h = 0.01, 5 periods",
    "rkmk": "a body velocity on SE(2) as formulas, adaptive RKMK (DOP853), t = 5",
    "periodic": "pendulum (canonical), the periodic-orbit propagator, t = 1000",
}

LOAD_CHILD = r"""
import json, sys, time
case = sys.argv[1]
t0 = time.perf_counter()
import geomech
from geomech.integrators import BKMM, solve
t1 = time.perf_counter()
if case in ("taylor", "dop853", "dlda"):
    from geomech.systems.nonholonomic_examples import snakeboard
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    gait = dict(t_final=5.0, shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, saveat=2)
    if case == "dlda":
        run = lambda: solve(s, "discrete_lagrange_dalembert", h=0.01, **gait)
    else:
        method = BKMM(solver="taylor") if case == "taylor" else BKMM()
        run = lambda: solve(s, method, rtol=1e-13, atol=1e-15, **gait)
elif case == "rkmk":
    from geomech import GroupFlow
    from geomech.lie import SE2
    s = GroupFlow(SE2(), ["v*cos(t)", "0.2 + 0.1*g13", "w"], "SE2", parameters={"v": 1.0, "w": 0.7})
    run = lambda: solve(s, "rkmk", t_final=5.0, saveat=11, g0=s.group.numeric.exp([0.1, 0.25, 0.4]), rtol=1e-10,
                        atol=1e-12)
elif case == "gauss":
    s = geomech.RigidBody([3.0, 2.0, 1.0])
    run = lambda: solve(s, "gauss_legendre_3", m0=[1.0, 0.3, 0.2], h=0.05, t_final=1000.0)
else:
    import sympy as sp
    q, p = sp.symbols("q p", real=True)
    s = geomech.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum")
    if case == "periodic":
        run = lambda: solve(s, "periodic_orbit", y0=[1.0, 0.5], t_final=1000.0, saveat=11)
    else:
        run = lambda: solve(s, "implicit_midpoint", y0=[1.0, 0.5], h=0.05, t_final=1000.0)
t2 = time.perf_counter()
sol = run()
t3 = time.perf_counter()
run()
t4 = time.perf_counter()
print(json.dumps(dict(import_s=t1 - t0, system_s=t2 - t1, first_s=t3 - t2, compile_s=sol.stats["compile_time"],
                      next_ms=(t4 - t3) * 1e3, numba="numba" in sys.modules)))
"""


def load_rows(pycache: str, repeats: int) -> list[dict[str, Any]]:
    """The load of each compiled model of LOAD_CASES from warm caches (a private cache directory, filled by a
    first run), in a fresh process each."""
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "GEOMECH_CACHE_DIR": cache, "PYTHONPYCACHEPREFIX": pycache}
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        for case, label in LOAD_CASES.items():
            runs = []
            for i in range(repeats + 1):
                done = subprocess.run(
                    [sys.executable, "-c", LOAD_CHILD, case],
                    env=env, capture_output=True, text=True, timeout=600, check=True,
                )  # fmt: skip
                if i:  # the first run fills the caches
                    runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
            best = min(runs, key=lambda r: r["system_s"] + r["first_s"])
            print(f"load, {label}: system {best['system_s']:.2f} s, first {best['first_s']:.2f} s", file=sys.stderr)
            rows.append(dict(case=label, **best))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--limit", type=float, default=120.0, help="seconds an example may take")
    parser.add_argument(
        "--cache",
        choices=("off", "empty"),
        default="off",
        help="the derivation cache off, or an empty private directory for each run (a user's first run, which writes "
        "every derivation to it); 'empty' writes results/derivation_empty_cache.*",
    )
    parser.add_argument(
        "--load-only", action="store_true", help="only the compiled model's load from warm caches (derivation_load.*)"
    )
    args = parser.parse_args(argv)
    if args.load_only:
        args.only, args.cache = [], "off"
    rows: list[dict[str, Any]] = []
    slow: list[tuple[str, str]] = []
    with tempfile.TemporaryDirectory() as pycache:
        names = examples() + list(MODEL_CASES) if args.only is None else args.only
        one((names or examples())[0], args.limit, pycache)  # compiles the bytecode of everything a derivation imports
        for name in names:
            runs = [one(name, args.limit, pycache, args.cache)]
            if runs[0].get("code") is not None:  # a run past the limit is not repeated
                runs += [one(name, args.limit, pycache, args.cache) for _ in range(args.repeats - 1)]
            ok = [r for r in runs if r.get("code") == 0]
            if not ok:
                why = runs[0].get("error") or [runs[0].get("code")]
                print(f"{name}: not derived ({why[0]})", file=sys.stderr)
                slow.append((name, str(why[0])))
                continue
            best = min(ok, key=lambda r: r["command_s"])
            rows.append(dict(example=name, **best))
            print(
                f"{name}: command {best['command_s']:.2f} s (import {best['import_s']:.2f} s, "
                f"derivation {best['derive_s']:.2f} s)",
                file=sys.stderr,
            )
        load = load_rows(pycache, args.repeats) if args.cache == "off" else []
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    stem = "derivation_load" if args.load_only else "derivation" if args.cache == "off" else "derivation_empty_cache"
    meta = dict(python=platform.python_version(), machine=platform.machine(), processor=platform.processor())
    meta["cache"] = args.cache
    (results / f"{stem}.json").write_text(
        json.dumps(dict(meta=meta, rows=rows, not_derived=slow, load=load), indent=1) + "\n"
    )
    lines = [
        "| example | `geomech derive` cold, whole command (s) | import (s) | derivation (s) | printed characters "
        "| digest |",
        "|---|---|---|---|---|---|",
    ]
    lines += [
        f"| {r['example']} | {r['command_s']:.2f} | {r['import_s']:.2f} | {r['derive_s']:.2f} | {r['chars']} | "
        f"`{r['digest']}` |"
        for r in rows
    ]
    lines += [f"| {name} | {why} | | | | |" for name, why in slow]
    lines += [
        "",
        "| a compiled model in a fresh process, cache warm | import (s) | system (s) | first solve (s) "
        "| of which loading the kernels (s) | next solve (ms) | numba imported |",
        "|---|---|---|---|---|---|---|",
    ]
    lines += [
        f"| {r['case']} | {r['import_s']:.2f} | {r['system_s']:.2f} | {r['first_s']:.2f} | {r['compile_s']:.2f} | "
        f"{r['next_ms']:.2f} | {'yes' if r.get('numba', True) else 'no'} |"
        for r in load
    ]
    (results / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
