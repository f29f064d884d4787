"""A body velocity on a Lie group (the reconstruction equation g^-1 g' = xi(t, g)): geomech's Runge-Kutta-Munthe-Kaas
methods, compiled (a ``GroupFlow`` of formulas) and in Python (scipy's solve_ivp under the same method), beside
heyoka's Taylor integrator and scipy's DOP853 on the attitude equation in matrices, R' = R hat(xi(t, R)).

    PYTHONPATH=src python benchmarks/group_flow.py          # about a minute
    PYTHONPATH=src python benchmarks/group_flow.py --quick  # fewer tolerances and repeats

Not part of the test suite; needs heyoka (``pip install "heyoka>=7,<8"``, the ``bench`` extra).

Problem: on SO(3), xi(t, R) = (sin 3t, 1 + R_31 / 2, cos(t) R_12) (it depends on the time and on the attitude: no
closed form), from R = exp((0.3, -0.2, 0.5)^), t = 20. The reference is heyoka in quadruple precision (real128,
tolerance 1e-32) on the matrix equation, cross-checked against heyoka in long double. The exact flow of the
matrix equation stays on SO(3); the integrators of the matrix equation leave it by their error, RKMK does not
(to round-off): the last column, |R^T R - I| at t = 20.

Measured in one run: the max-norm error of R(20) against the wall time from the Python call to the Solution (best
of several repeats), the compiled loop alone (``stats["loop_time"]``), heyoka's ``propagate_until`` from a reset
state (its construction and JIT compilation apart, as geomech's compilation is). Writes
``results/group_flow.json`` and ``results/group_flow.md``.
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from work_precision import best_of, heyoka_timed, peer_options, quadruple_reference

import geomech as gm
from geomech import GroupFlow, solve
from geomech.integrators import RKMK, RKMK4
from geomech.lie import SO3

HERE = Path(__file__).resolve().parent
T = 20.0
R0 = SO3().exp([0.3, -0.2, 0.5])
XI = ["sin(3*t)", "1 + 0.5*g31", "cos(t)*g12"]
TOLS = [1e-6, 1e-8, 1e-10, 1e-12]
STEPS = [0.05, 0.01, 0.002]
HEYOKA_TOLS = [1e-6, 1e-9, 1e-12, 1e-15]
SCIPY_TOLS = [1e-8, 1e-12]


def xi_numpy(t: float, R: np.ndarray) -> np.ndarray:
    return np.array([np.sin(3 * t), 1 + 0.5 * R[2, 0], np.cos(t) * R[0, 1]])


def heyoka_system(hy: Any) -> list:
    R = hy.make_vars(*[f"r{i}{j}" for i in range(3) for j in range(3)])
    M = [[R[3 * i + j] for j in range(3)] for i in range(3)]
    t = hy.time
    w = [hy.sin(3.0 * t), 1.0 + 0.5 * M[2][0], hy.cos(t) * M[0][1]]
    W = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
    return [(M[i][j], sum(M[i][k] * W[k][j] for k in range(3) if W[k][j] != 0.0)) for i in range(3) for j in range(3)]


def orthogonality(R: np.ndarray) -> float:
    return float(np.abs(R.T @ R - np.eye(3)).max())


def main(argv: list[str] | None = None) -> int:
    args, hy = peer_options(__doc__, "group_flow.py", argv)
    if hy is None:
        return 2
    repeats = 3 if args.quick else 7
    system = heyoka_system(hy)
    ref_flat, cross = quadruple_reference(hy, system, R0.ravel(), T)
    ref = ref_flat.reshape(3, 3)
    flow = GroupFlow(SO3(), XI, "attitude-dependent spin")
    callable_flow = GroupFlow(SO3(), xi_numpy, "attitude-dependent spin (callable)")
    rows = []

    def add(who: str, tol: float, R: np.ndarray, wall: float, **extra: Any) -> None:
        rows.append(
            dict(
                who=who, tol=tol, error=float(np.abs(R - ref).max()), orth=orthogonality(R), wall_ms=wall * 1e3, **extra
            )
        )

    for tol in TOLS[1::2] if args.quick else TOLS:
        kw = dict(t_final=T, saveat=2, g0=R0, rtol=tol, atol=tol * 1e-2)
        first = solve(flow, RKMK(), **kw)
        wall, sol = best_of(lambda kw=kw: solve(flow, RKMK(), **kw), repeats)
        loop = min(solve(flow, RKMK(), **kw).stats["loop_time"] for _ in range(repeats))
        add(
            "geomech RKMK compiled (DOP853)",
            tol,
            sol.element[-1],
            wall,
            loop_ms=loop * 1e3,
            n_rhs=sol.stats["n_rhs"],
            compile_s=first.stats["compile_time"],
        )
    for tol in SCIPY_TOLS:
        kw = dict(t_final=T, saveat=2, g0=R0, rtol=tol, atol=tol * 1e-2)
        wall, sol = best_of(lambda kw=kw: solve(callable_flow, RKMK(), **kw), 2, budget=10.0)
        add("geomech RKMK Python (scipy DOP853, a callable xi)", tol, sol.element[-1], wall, n_rhs=sol.stats["n_rhs"])
    for h in STEPS[:2] if args.quick else STEPS:
        kw = dict(t_final=T, h=h, saveat=2, g0=R0)
        first = solve(flow, RKMK4(), **kw)
        wall, sol = best_of(lambda kw=kw: solve(flow, RKMK4(), **kw), repeats)
        loop = min(solve(flow, RKMK4(), **kw).stats["loop_time"] for _ in range(repeats))
        add(
            f"geomech RKMK4 compiled (h = {h:g})",
            h,
            sol.element[-1],
            wall,
            loop_ms=loop * 1e3,
            n_rhs=sol.stats["n_rhs"],
            compile_s=first.stats["compile_time"],
        )
    kw = dict(t_final=T, h=STEPS[0], saveat=2, g0=R0)
    wall, sol = best_of(lambda kw=kw: solve(callable_flow, RKMK4(), **kw), 2, budget=10.0)
    add(
        f"geomech RKMK4 Python (h = {STEPS[0]:g}, a callable xi)",
        STEPS[0],
        sol.element[-1],
        wall,
        n_rhs=sol.stats["n_rhs"],
    )
    for tol in SCIPY_TOLS:

        def matrix_ode(tol: float = tol) -> Any:
            return solve_ivp(
                lambda t, y: (y.reshape(3, 3) @ SO3().hat(xi_numpy(t, y.reshape(3, 3)))).ravel(),
                (0.0, T),
                R0.ravel(),
                method="DOP853",
                rtol=tol,
                atol=tol * 1e-2,
            )

        wall, out = best_of(matrix_ode, 2, budget=10.0)
        add("scipy DOP853 on R' = R hat(xi)", tol, out.y[:, -1].reshape(3, 3), wall, n_rhs=int(out.nfev))
    for tol in HEYOKA_TOLS[1::2] if args.quick else HEYOKA_TOLS:
        wall, state, _, jit = heyoka_timed(hy, system, R0.ravel(), T, tol, repeats)
        add("heyoka taylor_adaptive on R' = R hat(xi)", tol, np.asarray(state).reshape(3, 3), wall, compile_s=jit)
    out = dict(
        machine=f"{platform.machine()} {platform.processor()}, {platform.python_version()}",
        versions=dict(geomech=gm.__version__, heyoka=hy.__version__, numpy=np.__version__),
        command="PYTHONPATH=src python benchmarks/group_flow.py" + (" --quick" if args.quick else ""),
        when=time.strftime("%Y-%m-%d"),
        t_final=T,
        reference="heyoka real128, tol 1e-32",
        cross_check_long_double=cross,
        rows=rows,
    )
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    (results / "group_flow.json").write_text(json.dumps(out, indent=1) + "\n")
    lines = [
        f"### attitude-dependent spin on SO(3), t = {T:g} (reference cross-check: {cross:.1e})",
        "",
        "| integrator | tolerance or h | error of R(20) | abs(R^T R - I) | wall time from the Python call (ms) "
        "| compiled loop alone (ms) | evaluations |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        loop = f"{r['loop_ms']:.3f}" if "loop_ms" in r else ""
        lines.append(
            f"| {r['who']} | {r['tol']:.0e} | {r['error']:.1e} | {r['orth']:.1e} | {r['wall_ms']:.3f} | {loop} "
            f"| {r.get('n_rhs', '')} |"
        )
    table = "\n".join(lines) + "\n"
    (results / "group_flow.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
