"""A rigid body with three rotors under a structure-preserving control: geomech's compiled open-loop equations beside
heyoka's Taylor integrator on the same equations.

    PYTHONPATH=src python benchmarks/rotors.py          # about a minute
    PYTHONPATH=src python benchmarks/rotors.py --quick  # fewer tolerances

Not part of the test suite; needs heyoka (``pip install "heyoka>=7,<8"``, the ``bench`` extra).

The problem (issue 16, item 4): three rotors on the principal axes, Lambda = diag(3, 2, 1.2) (body and rotors,
the rotors' axial moments left out), rotor axial moments J = (0.1, 0.2, 0.3); the diagonal control of Corollary 2,
phi_i(v) = 2 tan(v / G) with G = 2 and p = 0, i.e. the torques u = Dphi(m) m'; from m = (0.4, 1.0, -0.3), the
attitude R = exp((0.2, -0.4, 1.0)^), the rotors at Gamma = phi(m), gamma = 0; to t = 100. The integrated state is
the open loop's (m, R, Gamma, gamma), 18 numbers (the 12 of momentum and attitude, and the rotors' 6).

heyoka integrates the equations written here by hand in its own expressions (w = Lambda^-1 (m - Gamma),
m' = m x w, R' = R w^, Gamma' = Dphi(m) m', gamma' = Gamma / J - w): an independent route from geomech's, which
derives them from H_f and the control's phi. The reference is heyoka in quadruple precision (real128, tolerance
1e-32), cross-checked against heyoka in long double.

Measured, in one run: the max-norm error of the state at t = 100 against the wall time, best of several
repeats: ``solve(body, method, tau=control, ...)`` from the Python call to the Solution, the same from a problem
prepared once (``prepare(body, method, attitude=True, ...).solve(m0=..., R0=..., Gamma0=...)``, as heyoka's
integrator is built once), the compiled loop alone (``stats["loop_time"]``), and heyoka's ``propagate_until`` from
a reset state (its construction and JIT compilation apart, as geomech's compilation is). Writes
``results/rotors.json`` and ``results/rotors.md``.
"""

from __future__ import annotations

import json
import platform
from pathlib import Path
from typing import Any

import numpy as np
from work_precision import (  # the harness of the work-precision benchmark (this script's directory)
    best_of,
    heyoka_rows,
    peer_options,
    quadruple_reference,
)

import geomech as gm
from geomech.lie import so3
from geomech.systems.control import StructurePreservingControl
from geomech.systems.rotors import RotorBody

HERE = Path(__file__).resolve().parent
LAMBDA = (3.0, 2.0, 1.2)
J = (0.1, 0.2, 0.3)
G = 2.0
M0 = np.array([0.4, 1.0, -0.3])
AXIS0 = np.array([0.2, -0.4, 1.0])
T = 100.0
TOLS = {"dop853": [1e-8, 1e-10, 1e-12, 1e-13], "dopri5": [1e-8, 1e-10], "taylor": [1e-8, 1e-10, 1e-12, 1e-14]}
TOLS_QUICK = {"dop853": [1e-10, 1e-13], "dopri5": [1e-10], "taylor": [1e-10, 1e-14]}
FIXED = {"gauss_legendre_3": [0.1, 0.05], "rk4": [0.01]}
FIXED_QUICK = {"gauss_legendre_3": [0.05]}
PYTHON_TOLS = [1e-8, 1e-12]
HEYOKA_TOLS = [1e-6, 1e-9, 1e-12, 1e-15]


def heyoka_system(hy: Any) -> list:
    m = hy.make_vars("m1", "m2", "m3")
    R = hy.make_vars(*[f"R{i}{j}" for i in range(3) for j in range(3)])
    Gam = hy.make_vars("G1", "G2", "G3")
    gam = hy.make_vars("g1", "g2", "g3")
    w = [(m[i] - Gam[i]) / LAMBDA[i] for i in range(3)]
    mdot = [m[1] * w[2] - m[2] * w[1], m[2] * w[0] - m[0] * w[2], m[0] * w[1] - m[1] * w[0]]
    W = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
    Rdot = [sum(R[3 * i + k] * W[k][j] for k in range(3)) for i in range(3) for j in range(3)]
    # phi_i(v) = 2 tan(v / G): phi_i'(v) = (2 / G)(1 + tan(v / G)^2)
    u = [(2.0 / G) * (1.0 + hy.tan(m[i] / G) ** 2) * mdot[i] for i in range(3)]
    rates = [Gam[i] / J[i] - w[i] for i in range(3)]
    return list(zip([*m, *R, *Gam, *gam], [*mdot, *Rdot, *u, *rates]))


def main(argv: list[str] | None = None) -> int:
    args, hy = peer_options(__doc__, "rotors.py", argv)
    if hy is None:
        return 2
    repeats = 3 if args.quick else 7
    body = RotorBody.three_rotors(list(LAMBDA), list(J))
    control = StructurePreservingControl.diagonal(body, ["2*tan(v/G)"] * 3, parameters={"G": G})
    R0 = so3.exp(AXIS0)
    Gamma0 = control.rotor_momentum(M0)
    common = dict(t_final=T, saveat=2, m0=M0, R0=R0, Gamma0=Gamma0, tau=control)
    y0 = np.r_[M0, R0.ravel(), Gamma0, np.zeros(3)]

    sys_hy = heyoka_system(hy)
    ref, cross = quadruple_reference(hy, sys_hy, y0, T)

    def error(sol: Any) -> float:
        return float(np.abs(sol.states[-1] - ref).max())

    rows: list[dict[str, Any]] = []

    def measure(who: str, method: str, tol: float | None, **kw: Any) -> None:
        # compiles (or loads the disk cache) the loop and, with more saved states than a small run observes as
        # Python, the observation of the states (energy, torques): the steady state of repeated calls
        first = gm.solve(body, method, **kw, **{**common, "saveat": 1001 if "h" in kw else 5000})
        wall, sol = best_of(lambda: gm.solve(body, method, **kw, **common), repeats)
        loop = min(gm.solve(body, method, **kw, **common).stats["loop_time"] for _ in range(repeats))
        # the same run from a problem prepared once (the start given at each call), as heyoka's integrator is
        start = {k: common[k] for k in ("m0", "R0", "Gamma0")}
        prepared = gm.prepare(body, method, attitude=True, **kw, **{k: v for k, v in common.items() if k not in start})
        wall_prepared, again = best_of(lambda: prepared.solve(**start), repeats)
        assert np.array_equal(again.states, sol.states)
        rows.append(
            dict(
                who=who,
                tol=tol,
                h=kw.get("h"),
                error=error(sol),
                wall_ms=wall * 1e3,
                prepared_ms=wall_prepared * 1e3,
                loop_ms=loop * 1e3,
                n_rhs=sol.stats["n_rhs"],
                compile_s=first.stats["compile_time"],
            )
        )

    for method, tols in (TOLS_QUICK if args.quick else TOLS).items():
        for tol in tols:
            measure(f"geomech {method} (compiled)", method, tol, rtol=tol, atol=tol)
    for method, steps in (FIXED_QUICK if args.quick else FIXED).items():
        for h in steps:
            measure(f"geomech {method} (compiled)", method, None, h=h)
    for tol in PYTHON_TOLS:
        kw = dict(rtol=tol, atol=tol, backend="python", **common)
        wall, sol = best_of(lambda kw=kw: gm.solve(body, "solve_ivp", **kw), 2, budget=10.0)
        rows.append(dict(who="geomech solve_ivp (Python, scipy DOP853)", tol=tol, error=error(sol), wall_ms=wall * 1e3))
    rows += heyoka_rows(hy, sys_hy, y0, T, ref, HEYOKA_TOLS[1::2] if args.quick else HEYOKA_TOLS, repeats)
    out = dict(
        machine=f"{platform.machine()} {platform.processor()}, {platform.python_version()}",
        versions=dict(geomech=gm.__version__, heyoka=hy.__version__, numpy=np.__version__),
        command="PYTHONPATH=src python benchmarks/rotors.py" + (" --quick" if args.quick else ""),
        problem=dict(Lambda=LAMBDA, J=J, phi="2 tan(v/G)", G=G, m0=M0.tolist(), R0_axis=AXIS0.tolist(), t_final=T),
        reference="heyoka real128, tol 1e-32",
        cross_check_long_double=cross,
        rows=rows,
    )
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    (results / "rotors.json").write_text(json.dumps(out, indent=1) + "\n")
    lines = [
        f"### three rotors, phi_i = 2 tan(v/G), momentum, attitude and rotors (18 numbers), t = {T:g} "
        f"(reference cross-check: {cross:.1e})",
        "",
        "| integrator | tolerance or step | error | wall time from the Python call (ms) | from a prepared problem's "
        "call (ms) | compiled loop alone (ms) | evaluations |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        what = f"h = {r['h']:g}" if r.get("h") is not None else f"{r['tol']:.0e}"
        loop = f"{r['loop_ms']:.3f}" if "loop_ms" in r else ""
        ready = f"{r['prepared_ms']:.3f}" if "prepared_ms" in r else ""
        lines.append(
            f"| {r['who']} | {what} | {r['error']:.1e} | {r['wall_ms']:.3f} | {ready} | {loop} | {r.get('n_rhs', '')} |"
        )
    table = "\n".join(lines) + "\n"
    (results / "rotors.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
