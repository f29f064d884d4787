"""
Work and precision of the fixed-step integrators on the free rigid body
=======================================================================

Section 8 of the Serret-Andoyer seed compares integrators by how well they keep the energy and the momentum, and
names the Lie-Poisson integrators of Euler's equations without using them. Here the free rigid body with inertia
:math:`(3, 2, 1)`, whose exact solution is known, is integrated with ``geomech.solve`` by six fixed-step methods: the
implicit midpoint rule (Gauss-Legendre collocation with one stage) and Gauss-Legendre with two and three stages,
the Lie-Poisson splitting of order 2 (Strang) and its fourth-order Yoshida composition, and the classical explicit
Runge-Kutta method of order 4. A batch of 256 initial momenta on the sphere :math:`|m| = 1` is integrated to
:math:`t = 20` with a range of step sizes; the error at the end is measured against the exact solution in Jacobi
elliptic functions (``RigidBody.exact_solution``), an independent route, and drawn against the step size and
against the wall time of the compiled loop (timed after the first call, which compiles it).

Checks: the order fitted to the error by least squares in log-log (points in the asymptotic range, the round-off
floor dropped) agrees with the order that ``geomech.integrators.methods_table()`` states for each method. And over
a long run (100 periods of the momentum) the energy error of the symplectic methods stays bounded: the
Gauss-Legendre methods keep the quadratic energy to round-off, the splittings keep it within an oscillation of
size :math:`O(h^p)` (order :math:`p`), while the energy of Runge-Kutta 4 drifts linearly in time.

Run: ``python examples/work_precision.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import geomech as gm

T_FINAL = 20.0
LONG_RUN = 2000.0  # about 100 periods of the body momentum
BATCH = 256
# method key: (label, short label, range of the number of steps over T_FINAL, step of the long run)
METHODS = {
    "gauss_legendre_1": ("implicit midpoint (Gauss-Legendre s = 1)", "midpoint", (10, 1280), 0.1),
    "gauss_legendre_2": ("Gauss-Legendre s = 2", "GL s = 2", (10, 640), 0.2),
    "gauss_legendre_3": ("Gauss-Legendre s = 3", "GL s = 3", (8, 128), 0.4),
    "strang": ("Lie-Poisson splitting, Strang", "Strang", (20, 2560), 0.1),
    "splitting_4_yoshida": ("Lie-Poisson splitting, Yoshida 4", "Yoshida 4", (20, 2560), 0.1),
    "rk4": ("Runge-Kutta 4 (explicit)", "RK4", (20, 1280), 0.1),
}


def step_counts(lo: int, hi: int) -> np.ndarray:
    """Numbers of steps from ``lo`` to ``hi`` in ratios of about sqrt(2)."""
    n = int(round(2 * np.log2(hi / lo))) + 1
    return np.unique(np.round(lo * 2.0 ** (np.arange(n) / 2)).astype(int))


def fitted_order(h: np.ndarray, err: np.ndarray, floor: float = 1e-11, ceiling: float = 1e-2) -> float:
    """Slope of log(err) against log(h) over the points between the round-off floor and the pre-asymptotic
    ceiling."""
    keep = (err > floor) & (err < ceiling)
    return float(np.polyfit(np.log(h[keep]), np.log(err[keep]), 1)[0])


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    body = gm.RigidBody([3.0, 2.0, 1.0])
    rng = np.random.default_rng(7)
    m0 = rng.normal(size=(BATCH, 3))
    m0 /= np.linalg.norm(m0, axis=-1, keepdims=True)
    exact = np.stack([body.exact_solution(m).momentum(T_FINAL) for m in m0])
    orders = {row["key"]: row for row in gm.integrators.methods_table()}

    study = {}
    for key, (label, _, (lo, hi), _) in METHODS.items():
        rows = []
        gm.solve(body, key, m0=m0[:1], h=T_FINAL / lo, t_final=T_FINAL)  # the first call compiles the method
        for n in step_counts(lo, hi):
            run = dict(m0=m0, h=T_FINAL / n, t_final=T_FINAL, saveat=2)
            # the best of a few timed calls (up to 5, while they add up to less than 50 ms): the machine is shared
            walls: list[float] = []
            while len(walls) < 5 and sum(walls) < 0.05:
                start = time.perf_counter()
                sol = gm.solve(body, key, **run)
                walls.append(time.perf_counter() - start)
            wall = min(walls)
            err = float(np.linalg.norm(sol.m[:, -1] - exact, axis=-1).max())
            rows.append((T_FINAL / n, err, wall))
        h, err, wall = (np.array(c) for c in zip(*rows))
        study[key] = {"label": label, "h": h, "err": err, "wall": wall, "order": orders[key]["order"]}
        study[key]["fitted"] = fitted_order(h, err)

    # The long run: one initial momentum, 100 periods, the energy error along the way.
    m_long = np.array([1.0, 0.3, 0.2])
    long_runs = {}
    for key, (_, short, _, h_long) in METHODS.items():
        sol = gm.solve(body, key, m0=m_long, h=h_long, t_final=LONG_RUN, saveat=1001)
        dE = np.abs(sol.energy - sol.energy[0])
        half = dE.size // 2
        long_runs[key] = {
            "t": sol.t,
            "dE": dE,
            "h": h_long,
            "max": float(dE.max()),
            # a bounded error has about the same maximum in both halves of the run; a linear drift doubles it
            "growth": float(dE[half:].max() / max(dE[:half].max(), np.finfo(float).tiny)),
            "label": short,
        }

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(16, 5.6))
    colours = dict(zip(METHODS, ["C0", "C1", "C2", "C3", "C4", "C7"]))
    marks = dict(zip(METHODS, ["o", "s", "^", "v", "D", "x"]))
    for key, s in study.items():
        style = {"color": colours[key], "marker": marks[key], "ms": 5, "lw": 1.3}
        ax1.loglog(s["h"], s["err"], label=f"{s['label']}: order {s['order']}, fitted {s['fitted']:.2f}", **style)
        ax2.loglog(s["wall"] * 1e3, s["err"], **style)
    ax1.axhspan(1e-17, 1e-11, color="0.92", zorder=0)
    ax1.set_xlabel("step size h")
    ax1.set_ylabel(r"final error $\max_{\mathrm{batch}} |m(20) - m_{\mathrm{exact}}(20)|$")
    ax1.set_title("convergence: error against step size")
    ax1.set_ylim(1e-13, 1.0)
    from matplotlib.patches import Patch

    handles, _ = ax1.get_legend_handles_labels()
    handles.append(Patch(color="0.92", label="below 1e-11: round-off, not fitted"))

    ax2.set_xlabel(f"wall time of one call, {BATCH} trajectories (ms)")
    ax2.set_ylabel("final error")
    ax2.set_title("work-precision: error against wall time")
    ax2.set_ylim(1e-13, 1.0)
    for key, r in long_runs.items():
        ax3.semilogy(
            r["t"], np.maximum(r["dE"], 1e-17), color=colours[key], lw=1.0, label=f"{r['label']}, h = {r['h']:g}"
        )
    ax3.set_xlabel("t")
    ax3.set_ylabel(r"energy error $|E(t) - E(0)|$")
    ax3.set_title(f"energy over {LONG_RUN:g} time units (about 100 periods)")
    ax3.set_ylim(1e-17, 1e-1)
    ax3.legend(fontsize=7.5, loc="upper left", ncols=3)
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3, which="major")
    fig.legend(handles=handles, loc="lower center", ncols=4, fontsize=8.5, frameon=False)
    fig.tight_layout(rect=(0.0, 0.1, 1.0, 1.0))

    summary: dict[str, float] = {}
    for key, s in study.items():
        summary[f"{key} fitted order (stated {s['order']})"] = s["fitted"]
    summary["largest |fitted - stated order|"] = max(abs(s["fitted"] - s["order"]) for s in study.values())
    for key, r in long_runs.items():
        summary[f"{key} long-run max energy error"] = r["max"]
        summary[f"{key} energy error growth, second half / first half"] = r["growth"]
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "work_precision.png", dpi=120)
        plt.close("all")
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    main(parser.parse_args().out)
