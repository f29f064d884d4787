r"""
The three-link chain: reorientation at zero angular momentum
============================================================

Three equal slender links joined end to end by two pin joints float freely in the plane (the falling-cat
mechanism of section 2 of the nonholonomic seed; ``geomech.systems.three_link_chain``). The group is
:math:`SE(2)`: the centre of mass and the angle :math:`\theta` of the middle link; the shape is the two joint
angles :math:`(\alpha_1, \alpha_2)`. With zero momentum the centre of mass stays put, and when the joints run a
closed loop the chain turns by the geometric phase alone (Theorem 2.2 with :math:`\mu = 0`):

.. math::

    \Delta\theta = -\oint A_\theta(\alpha)\,d\alpha = -\iint_D B_\theta\,d\alpha_1\,d\alpha_2,

with :math:`A_\theta` the rotational row of the mechanical connection and :math:`B_\theta` its curvature (the
rotational part of the se(2) bracket vanishes, so :math:`B_\theta = dA_\theta`). The script draws the curvature
over the shape plane with four elliptic loops, and the chain itself along the first loop.

Three routes give each loop's net rotation: the line integral of the connection (``geometric_phase``), the
curvature integrated over the enclosed ellipse by scipy's ``dblquad`` (Stokes' theorem; the curvature evaluated
pointwise from ``ReducedNumeric.curvature_2d``, the region in polar coordinates of the ellipse), and a full
simulation of the chain's Euler-Lagrange equations in coordinates (``geomech.solve`` with
``"lagrange_dalembert"``, the joints driven along the loop, from a start with zero momentum), which knows nothing
of connections.

Run: ``python examples/three_link_chain.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.integrate import dblquad

from geomech import solve
from geomech.analysis import Gait, geometric_phase
from geomech.plot import curvature_map
from geomech.reduction import bkmm_reduction
from geomech.systems.holonomic_examples import three_link_chain, three_link_positions

PERIOD = 2.0
#: (label, centre, semi-axes, tilt, counterclockwise) of the elliptic joint loops
LOOPS = [
    ("A", (1.45, 1.45), (1.0, 1.0), 0.0, True),
    ("B", (-1.3, -1.3), (1.1, 0.6), np.pi / 4, True),
    ("C", (0.0, 0.0), (0.9, 0.9), 0.0, True),
    ("D", (2.2, -1.2), (0.8, 1.6), 0.0, False),
]


def ellipse_curvature_integral(curvature, centre, radii, tilt) -> tuple[float, float]:
    """The integral of ``curvature(point)`` over the filled ellipse, by dblquad in its polar coordinates
    ``r = c + R(tilt) (a rho cos phi, b rho sin phi)``, area element ``a b rho``; with the error estimate."""
    c, (a, b) = np.asarray(centre), radii
    R = np.array([[np.cos(tilt), -np.sin(tilt)], [np.sin(tilt), np.cos(tilt)]])

    def f(phi: float, rho: float) -> float:
        point = c + R @ np.array([a * rho * np.cos(phi), b * rho * np.sin(phi)])
        return curvature(point) * a * b * rho

    return dblquad(f, 0.0, 1.0, 0.0, 2 * np.pi, epsabs=1e-10, epsrel=1e-10)


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chain = three_link_chain(origin="com")
    connection = bkmm_reduction(chain).numeric()  # the mechanical connection, its curvature, the locked inertia
    t = np.linspace(0.0, PERIOD, 121)
    loops = []
    for label, centre, radii, tilt, ccw in LOOPS:
        loop = Gait.ellipse(centre, radii, PERIOD, tilt=tilt, clockwise=not ccw)
        area, area_error = ellipse_curvature_integral(lambda r: connection.curvature_2d(r)[2], centre, radii, tilt)
        sim = solve(
            chain,
            "lagrange_dalembert",
            q0=np.r_[0.0, 0.0, 0.0, loop.r(0.0)],
            p0=np.zeros(3),  # zero body momentum at the start, from the mass matrix of the Lagrangian
            shapes=loop,
            t_final=PERIOD,
            saveat=t,
            rtol=1e-12,
            atol=1e-12,
        )
        loops.append(
            {
                "label": label,
                "loop": loop,
                "line": float(geometric_phase(connection, loop)[2]),  # -oint A_theta
                "stokes": -area if ccw else area,  # -iint B_theta over the region, by its orientation
                "quadrature error": area_error,
                "sim": sim,
                "momentum": float(np.abs(sim.spatial_momentum).max()),
            }
        )

    fig = plt.figure(figsize=(13, 9.6))
    grid = fig.add_gridspec(2, 2, height_ratios=[1.2, 0.62], width_ratios=[1.1, 1])
    ax_map, ax_rot, ax_body = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, :])

    curvature_map(connection, bounds=(-np.pi, np.pi, -np.pi, np.pi), n=161, ax=ax_map)
    for row in loops:
        pts = row["loop"].r(np.linspace(0.0, PERIOD, 300))
        ax_map.plot(pts[:, 0], pts[:, 1], color="k", lw=1.6)
        ax_map.annotate("", xy=pts[43], xytext=pts[40], arrowprops=dict(arrowstyle="-|>", color="k", lw=1.4))
        ax_map.text(*pts.mean(0), row["label"], ha="center", va="center", fontsize=12, weight="bold")
    ax_map.set_xlabel("$\\alpha_1$ (rad)")
    ax_map.set_ylabel("$\\alpha_2$ (rad)")
    ax_map.set_title("curvature $B_\\theta$ of the mechanical connection,\nwith four loops of the joint angles")

    for k, row in enumerate(loops):
        theta = row["sim"].q[:, 2]
        label = f"{row['label']}: $\\Delta\\theta$ = {theta[-1]:+.4f} rad"
        ax_rot.plot(row["sim"].t, theta, color=f"C{k}", lw=1.8, label=label)
        ax_rot.plot(PERIOD, row["line"], "o", color=f"C{k}", ms=9, mfc="none")
        ax_rot.plot(PERIOD, row["stokes"], "x", color=f"C{k}", ms=9)
    ax_rot.plot([], [], "-", color="0.3", label="full simulation, $\\theta(t)$")
    ax_rot.plot([], [], "o", color="0.3", mfc="none", label="$-\\oint A_\\theta$ (line integral)")
    ax_rot.plot([], [], "x", color="0.3", label="$-\\iint B_\\theta$ (dblquad over the ellipse)")
    ax_rot.axhline(0.0, color="0.75", lw=0.8)
    ax_rot.set_xlabel("$t$")
    ax_rot.set_ylabel("$\\theta(t) - \\theta(0)$, middle link (rad)")
    ax_rot.set_title(f"orientation over one period (T = {PERIOD:g}) at zero angular momentum")
    ax_rot.grid(alpha=0.3)
    low, high = min(r["sim"].q[:, 2].min() for r in loops), max(r["sim"].q[:, 2].max() for r in loops)
    ax_rot.set_ylim(low - 0.05 * (high - low), high + 0.33 * (high - low))  # room for the legend above the curves
    ax_rot.legend(fontsize=8, loc="upper center", ncol=2)

    first, spacing = loops[0], 3.2
    q = first["sim"].q
    frames = np.linspace(0, len(t) - 1, 5).astype(int)
    shift = np.arange(len(frames))[:, None] * np.array([spacing, 0.0])  # each instant drawn to the right
    shots = three_link_positions(chain, q[frames]) + shift[:, None, :]
    start = three_link_positions(chain, q[0]) + shift[-1]  # the start, drawn under the end
    ax_body.plot(start[:, 0], start[:, 1], "-", color="0.6", alpha=0.5, lw=6, solid_capstyle="round")
    for pts in shots:
        for a, b, color in ((0, 2, "C0"), (1, 3, "C3"), (2, 4, "C0")):
            ax_body.plot(pts[a:b, 0], pts[a:b, 1], "-", color=color, lw=4, solid_capstyle="round")
        ax_body.plot(pts[1:3, 0], pts[1:3, 1], "o", color="k", ms=4)
    com = q[frames, :2] + shift
    ax_body.plot(com[:, 0], com[:, 1], "+", color="k", ms=9, mew=1.5)
    low, high = shots[..., 1].min(), shots[..., 1].max()
    for (x, _), i in zip(com, frames):
        ax_body.text(x, low - 0.45, f"t = {t[i]:.2f}", ha="center", fontsize=9)
    ax_body.set_aspect("equal")
    ax_body.set_xlim(shots[..., 0].min() - 0.4, shots[..., 0].max() + 0.4)
    ax_body.set_ylim(low - 0.6, high + 0.2)
    ax_body.set_xlabel("$x$ (link lengths; each instant shifted to the right)")
    ax_body.set_ylabel("$y$")
    ax_body.set_title(
        f"loop {first['label']}: the chain at five instants (middle link red, centre of mass +); at t = T it has "
        f"the shape of the start (grey) turned by {q[-1, 2]:+.3f} rad",
        fontsize=10,
    )
    fig.tight_layout()

    summary = {f"net rotation, loop {r['label']} (rad)": r["line"] for r in loops}
    summary |= {
        "largest |line integral - curvature integral| (rad)": max(abs(r["line"] - r["stokes"]) for r in loops),
        "largest dblquad error estimate (rad)": max(r["quadrature error"] for r in loops),
        "largest |line integral - full simulation| (rad)": max(abs(r["line"] - r["sim"].q[-1, 2]) for r in loops),
        "largest |spatial momentum| in the simulations": max(r["momentum"] for r in loops),
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "three_link_chain.png", dpi=120)
        plt.close("all")
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    args = parser.parse_args()
    main(args.out)
