"""Nonholonomic systems driven by a gait or coasting: geomech's BKMM equations (compiled, by DOP853 and by Taylor's
method, and in Python) and its Lagrange-d'Alembert equations with multipliers (compiled) beside heyoka's Taylor
integrator on the reduced equations.

    PYTHONPATH=src python benchmarks/nonholonomic.py          # 2 to 3 minutes
    PYTHONPATH=src python benchmarks/nonholonomic.py --quick  # fewer tolerances

Not part of the test suite; needs heyoka (``pip install "heyoka>=7,<8"``, the ``bench`` extra).

Problems (issue 16, item 4):

- ``snakeboard``: m = 1, r = 0.5, J = 0.18, J0 = 0.05, J1 = 0.01, the gait psi = sin(2 pi t),
  phi = 0.5 sin(2 pi t), the board at rest at t = 0, five periods (t = 5);
- ``roller_racer``: m1 = 1, m2 = 0.8, I1 = 0.3, I2 = 0.2, d1 = 0.5, d2 = 0.6, the joint driven by the periodic
  gait phi = 0.4 sin(2 pi t), from rest, five periods;
- ``chaplygin_sleigh``: m = 1.5, I_c = 0.4, a = 0.6, no shape, from the momentum p = (0.3, 0.5), t = 10.

The integrated state is the group coordinates (x, y, theta) and the nonholonomic momentum p. heyoka integrates
the reduced equations in closed form: the reconstruction xi(r, rdot, p) and the momentum equation
pdot(r, rdot, p) of geomech's symbolic reduction (``bkmm_reduction(s).reconstruction`` and ``.momentum_rhs``:
the connection solved and simplified by sympy, a different route from the compiled numeric linear algebra of
``solve``), the gait substituted as functions of ``heyoka.time``. The reference is heyoka in quadruple
precision (real128, tolerance 1e-32), cross-checked against heyoka in long double.

Measured, in one run: the max-norm error of (g, p) at the end against the wall time, best of several repeats:
``solve(s, BKMM(), ...)``, ``solve(s, BKMM(solver="taylor"), ...)`` and ``solve(s, LagrangeDAlembert(), ...)``
from the Python call to the Solution (compiled; BKMM also in Python), the compiled runs also from a problem
prepared once (``prepare(s, method, ...).solve(p0=...)``, as heyoka's integrator is built once), the compiled
discrete Lagrange-d'Alembert map (the midpoint and the group's discrete Lagrangians, and the group's in Python) at
fixed steps, the compiled loop alone (``stats["loop_time"]``), and
heyoka's ``propagate_until`` from a reset state (its construction and JIT compilation apart, as geomech's
compilation is). Writes
``results/nonholonomic.json`` and ``results/nonholonomic.md``.
"""

from __future__ import annotations

import itertools
import json
import platform
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from work_precision import (  # the harness of the work-precision benchmark (this script's directory)
    best_of,
    heyoka_rows,
    peer_options,
    quadruple_reference,
)

import geomech as gm
from geomech.integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert, prepare, solve
from geomech.reduction import bkmm_reduction
from geomech.systems.nonholonomic_examples import chaplygin_sleigh, roller_racer, snakeboard

HERE = Path(__file__).resolve().parent
T_SYMBOL = sp.Symbol("t", real=True)
CASES = {
    "snakeboard": dict(
        build=snakeboard,
        parameters=dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01),
        gait={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"},
        formulas={"psi": sp.sin(2 * sp.pi * T_SYMBOL), "phi": sp.sin(2 * sp.pi * T_SYMBOL) / 2},
        start={},
        T=5.0,
    ),
    "roller_racer": dict(
        build=roller_racer,
        parameters=dict(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6),
        gait={"phi": "0.4*sin(2*pi*t)"},
        formulas={"phi": sp.Rational(2, 5) * sp.sin(2 * sp.pi * T_SYMBOL)},
        start={},
        T=5.0,
    ),
    "chaplygin_sleigh": dict(
        build=chaplygin_sleigh,
        parameters=dict(m=1.5, I_c=0.4, a=0.6),
        gait=None,
        formulas={},
        start=dict(p0=[0.3, 0.5]),
        T=10.0,
    ),
}
TOLS = [1e-6, 1e-8, 1e-10, 1e-12, 1e-13]
TOLS_QUICK = [1e-8, 1e-12]
PYTHON_TOLS = [1e-8, 1e-12]
#: the steps of the discrete Lagrange-d'Alembert map (second order, fixed step: the "tolerance" column is h)
DISCRETE_STEPS = [1e-2, 1e-3]
#: the compiled equations: the reduced ones, and those in coordinates with multipliers
COMPILED = {
    "BKMM": BKMM(),
    "LagrangeDAlembert": LagrangeDAlembert(),
    "BKMM Taylor": BKMM(solver="taylor"),
    # without the shape forces' work: the equations heyoka integrates
    "BKMM Taylor (work=False)": BKMM(solver="taylor", work=False),
}
HEYOKA_TOLS = [1e-6, 1e-9, 1e-12, 1e-15]


def heyoka_equations(hy: Any, s: Any, case: dict, pars: dict | None = None) -> list:
    """(g, p)' from the symbolic reduction, the gait in heyoka.time (its coefficients, where symbols, heyoka's
    run-time parameters ``pars``: symbol -> ``heyoka.par[i]``)."""
    red = bkmm_reduction(s)
    gait = {r: case["formulas"][r.name] for r in red.r}
    values = {p: case["parameters"][p.name] for p in s.parameter_symbols}
    subs = {**values, **gait, **{rd: gait[r].diff(T_SYMBOL) for r, rd in zip(red.r, red.rdot)}}
    xi = sp.Matrix(red.reconstruction).xreplace(subs)
    pdot = sp.Matrix(red.momentum_rhs).xreplace(subs)
    gdot = sp.Matrix(s.group.body_velocity_inverse) * xi
    variables = hy.make_vars(*[c.name for c in s.group.coordinates], *[f"p{i}" for i in range(red.m)])
    table = dict(zip(list(s.group.coordinates) + list(red.p), variables))
    table[T_SYMBOL] = hy.time
    table.update(pars or {})

    def floats(e: sp.Expr) -> sp.Expr:
        # heyoka reads rationals only with power-of-two denominators: the others as 34-digit floats
        return e.xreplace({r: sp.Float(r, 34) for r in e.atoms(sp.Rational) if r.q & (r.q - 1)})

    rhs = [hy.from_sympy(floats(sp.sympify(e)), table) for e in list(gdot) + list(pdot)]
    return list(zip(variables, rhs))


def run_case(hy: Any, name: str, case: dict, quick: bool, repeats: int) -> dict[str, Any]:
    s = case["build"](**case["parameters"])
    T = case["T"]
    common = dict(t_final=T, shapes=case["gait"], saveat=2, **case["start"])
    sys_hy = heyoka_equations(hy, s, case)
    start = solve(s, BKMM(), rtol=1e-13, atol=1e-14, **common)
    k = s.k
    y0 = np.r_[start.q[0, :k], start.p[0]]
    ref, cross = quadruple_reference(hy, sys_hy, y0, T)

    def error(sol: Any) -> float:
        return float(np.abs(np.r_[sol.q[-1, :k], sol.p[-1]] - ref).max())

    rows: list[dict[str, Any]] = []
    for (label, method), tol in itertools.product(COMPILED.items(), TOLS_QUICK if quick else TOLS):
        kw = dict(rtol=tol, atol=tol * 1e-2, **common)
        # compiles (or loads the disk cache) the loop and, with more saved states than a small run observes as
        # Python, the observation of the states: the steady state of repeated calls
        first = solve(s, method, **{**kw, "saveat": 5000})
        wall, sol = best_of(lambda kw=kw, method=method: solve(s, method, **kw), repeats)
        loop = min(solve(s, method, **kw).stats["loop_time"] for _ in range(repeats))
        # the same run from a problem prepared once (the start given at each call), as heyoka's integrator is
        prepared = prepare(s, method, **{k: v for k, v in kw.items() if k != "p0"})
        start_of = {k: v for k, v in kw.items() if k == "p0"}
        wall_prepared, again = best_of(lambda p=prepared, a=start_of: p.solve(**a), repeats)
        assert np.array_equal(again.states, sol.states)
        rows.append(
            dict(
                who=f"geomech {label} compiled" + ("" if method.solver == "taylor" else " (DOP853)"),
                tol=tol,
                error=error(sol),
                wall_ms=wall * 1e3,
                prepared_ms=wall_prepared * 1e3,
                loop_ms=loop * 1e3,
                n_rhs=sol.stats["n_rhs"],
                compile_s=first.stats["compile_time"],
            )
        )
    for tol in PYTHON_TOLS:
        kw = dict(rtol=tol, atol=tol * 1e-2, backend="python", **common)
        wall, sol = best_of(lambda kw=kw: solve(s, BKMM(), **kw), 2, budget=10.0)
        rows.append(
            dict(
                who="geomech BKMM Python (scipy DOP853)",
                tol=tol,
                error=error(sol),
                wall_ms=wall * 1e3,
                n_rhs=sol.stats["n_rhs"],
            )
        )
    for disc, h in itertools.product(("midpoint", "group"), DISCRETE_STEPS[1:] if quick else DISCRETE_STEPS):
        kw = dict(h=h, **common)
        dlda = DiscreteLagrangeDAlembert(disc)
        first = solve(s, dlda, **kw)
        wall, sol = best_of(lambda kw=kw, dlda=dlda: solve(s, dlda, **kw), repeats)
        loop = min(solve(s, dlda, **kw).stats["loop_time"] for _ in range(repeats))
        rows.append(
            dict(
                who=f"geomech discrete Lagrange-d'Alembert compiled ({disc}, h = {h:g})",
                tol=h,
                error=error(sol),
                wall_ms=wall * 1e3,
                loop_ms=loop * 1e3,
                compile_s=first.stats["compile_time"],
            )
        )
    # the group's map in Python, the engine it had before it was compiled
    kw = dict(h=DISCRETE_STEPS[0], backend="python", **common)
    wall, sol = best_of(lambda kw=kw: solve(s, DiscreteLagrangeDAlembert("group"), **kw), 2, budget=10.0)
    rows.append(
        dict(
            who=f"geomech discrete Lagrange-d'Alembert Python (group, h = {DISCRETE_STEPS[0]:g})",
            tol=DISCRETE_STEPS[0],
            error=error(sol),
            wall_ms=wall * 1e3,
        )
    )
    rows += heyoka_rows(hy, sys_hy, y0, T, ref, HEYOKA_TOLS[1::2] if quick else HEYOKA_TOLS, repeats)
    return dict(
        problem=name,
        parameters=case["parameters"],
        gait=case["gait"],
        start=case["start"],
        t_final=T,
        reference="heyoka real128, tol 1e-32",
        cross_check_long_double=cross,
        rows=rows,
    )


def main(argv: list[str] | None = None) -> int:
    args, hy = peer_options(__doc__, "nonholonomic.py", argv)
    if hy is None:
        return 2
    repeats = 3 if args.quick else 7
    cases = [run_case(hy, name, case, args.quick, repeats) for name, case in CASES.items()]
    out = dict(
        machine=f"{platform.machine()} {platform.processor()}, {platform.python_version()}",
        versions=dict(geomech=gm.__version__, heyoka=hy.__version__, numpy=np.__version__),
        command="PYTHONPATH=src python benchmarks/nonholonomic.py" + (" --quick" if args.quick else ""),
        cases=cases,
    )
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    (results / "nonholonomic.json").write_text(json.dumps(out, indent=1) + "\n")
    lines = []
    for case in cases:
        lines += [
            f"### {case['problem']}: t = {case['t_final']:g} "
            f"(reference cross-check: {case['cross_check_long_double']:.1e})",
            "",
            "| integrator | tolerance | error | wall time from the Python call (ms) | from a prepared problem's call "
            "(ms) | compiled loop alone (ms) | evaluations |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in case["rows"]:
            loop = f"{r['loop_ms']:.3f}" if "loop_ms" in r else ""
            ready = f"{r['prepared_ms']:.3f}" if "prepared_ms" in r else ""
            evals = r.get("n_rhs", "")
            lines.append(
                f"| {r['who']} | {r['tol']:.0e} | {r['error']:.1e} | {r['wall_ms']:.3f} | {ready} | {loop} | {evals} |"
            )
        lines.append("")
    table = "\n".join(lines)
    (results / "nonholonomic.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
