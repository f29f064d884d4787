"""Cold symbolic derivation: ``geomech derive NAME`` for every built-in nonholonomic example (issue 16, item 5).

Each example runs in a fresh process with the derivation cache off (``GEOMECH_CACHE_DIR=off``), so nothing is
reused: the time to import geomech, the time of the derivation (every section, printed as ``derive`` prints it),
and a digest of the printed text (two runs whose digests agree printed the same formulas, so neither is larger).
Best of ``--repeats`` runs. Writes ``results/derivation.json`` and ``results/derivation.md``.

    PYTHONPATH=src python benchmarks/derivation.py [--repeats 2] [--limit 120] [--only snakeboard ...]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
#: One cold run: the import, then the derivation of every section, timed apart; prints one JSON line.
CHILD = r"""
import contextlib, hashlib, io, json, sys, time
t0 = time.perf_counter()
from geomech.cli.main import main
t1 = time.perf_counter()
out = io.StringIO()
with contextlib.redirect_stdout(out):
    try:
        main(["derive", sys.argv[1]])
    except SystemExit as exc:
        code = exc.code
    else:
        code = 0
t2 = time.perf_counter()
text = out.getvalue()
from sympy.external.gmpy import GROUND_TYPES
print(json.dumps(dict(code=code, import_s=t1 - t0, derive_s=t2 - t1, chars=len(text),
                      digest=hashlib.sha256(text.encode()).hexdigest()[:16], ground_types=GROUND_TYPES)))
"""


def examples() -> list[str]:
    from geomech.systems.models import EXAMPLES

    return list(EXAMPLES)


def one(name: str, limit: float) -> dict[str, Any]:
    env = {**os.environ, "GEOMECH_CACHE_DIR": "off"}
    try:
        done = subprocess.run(
            [sys.executable, "-c", CHILD, name], env=env, capture_output=True, text=True, timeout=limit, check=False
        )
    except subprocess.TimeoutExpired:
        return dict(code=None, error=[f"more than {limit:g} s"])
    if done.returncode != 0 or not done.stdout.strip():
        return dict(code=done.returncode, error=done.stderr.strip().splitlines()[-1:] or ["no output"])
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--limit", type=float, default=120.0, help="seconds an example may take")
    args = parser.parse_args(argv)
    rows = []
    for name in args.only or examples():
        runs = [one(name, args.limit) for _ in range(args.repeats)]
        ok = [r for r in runs if r.get("code") == 0]
        if not ok:
            print(f"{name}: not derivable here ({runs[0].get('error') or runs[0].get('code')})", file=sys.stderr)
            continue
        best = min(ok, key=lambda r: r["import_s"] + r["derive_s"])
        row = dict(example=name, **best, total_s=best["import_s"] + best["derive_s"])
        rows.append(row)
        print(f"{name}: import {best['import_s']:.2f} s, derive {best['derive_s']:.2f} s", file=sys.stderr)
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    meta = dict(python=platform.python_version(), machine=platform.machine(), processor=platform.processor())
    (results / "derivation.json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=1) + "\n")
    lines = [
        "| example | `geomech derive` cold (s) | import (s) | derivation (s) | printed characters | digest |",
        "|---|---|---|---|---|---|",
    ]
    lines += [
        f"| {r['example']} | {r['total_s']:.2f} | {r['import_s']:.2f} | {r['derive_s']:.2f} | {r['chars']} | "
        f"`{r['digest']}` |"
        for r in rows
    ]
    (results / "derivation.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
