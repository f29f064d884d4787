"""
Snakeboard gaits: the phase between rotor and steering decides where the board goes
===================================================================================

The snakeboard of section 1 of the nonholonomic seed (BKMM's normalisation ``snakeboard_bkmm``: board and rotor on
two wheel pairs that cannot slip sideways) is driven by the gait :math:`\\psi = a\\sin\\omega t` (rotor),
:math:`\\phi = b\\sin(\\omega t + \\delta)` (steering), from rest. The script draws the board's path in the plane for
a few phase offsets :math:`\\delta`, and, over :math:`0 \\le \\delta \\le \\pi`, the displacement of the first period
and the nonholonomic momentum gained per period. Along the gait the momentum equation (1.2) reads
:math:`\\frac{d}{dt}(p/\\cos\\phi) = 2J_0\\cos\\phi\\,\\dot\\phi\\dot\\psi`, so each period adds
:math:`\\Delta p = 4\\pi J_0 a\\omega J_1(b)\\cos\\delta\\,\\cos(b\\sin\\delta)` (:math:`J_1` the Bessel function): the
board accelerates unless :math:`\\delta = \\pi/2`, where the momentum returns and every period is the same rigid
motion.

Checks: the reduced simulation (momentum equation and reconstruction, eqs. 1.1-1.2, ``BKMM``) and the full
Lagrange-d'Alembert simulation with multipliers (``LagrangeDAlembert``) of the same gait agree in the planar
position; the momentum gained per period in the full simulations agrees with the Bessel formula.

Run: ``python examples/snakeboard_gaits.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.special import jv

from geomech import solve
from geomech.analysis import analyse_gait
from geomech.integrators import BKMM, LagrangeDAlembert
from geomech.plot.interactive import gait_html, write_html
from geomech.reduction import bkmm_reduction
from geomech.systems.nonholonomic_examples import snakeboard_bkmm

A_ROTOR, B_STEER, PERIOD = 1.5, 0.6, 1.0  # rotor amplitude (rad), steering amplitude (rad), period (s)


def gait(delta: float) -> dict[str, str]:
    return {
        "psi": f"{A_ROTOR}*sin(2*pi*t/{PERIOD})",
        "phi": f"{B_STEER}*sin(2*pi*t/{PERIOD} + {float(delta)!r})",
    }


def draw_board(ax, x: float, y: float, theta: float, r: float, color: str) -> None:
    """The board as a segment between its wheel axles, the front axle marked."""
    c, s = np.cos(theta), np.sin(theta)
    ax.plot([x - r * c, x + r * c], [y - r * s, y + r * s], color=color, lw=2.6, solid_capstyle="round", alpha=0.85)
    ax.plot(x + r * c, y + r * s, "o", color=color, ms=4.5, mec="k", mew=0.5)


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    board = snakeboard_bkmm(m=1.0, r=0.5, J0=0.05, J1=0.01)
    J0, r = board.parameters["J0"], board.parameters["r"]
    red = bkmm_reduction(board)
    print(f"momentum equation (1.2) of the snakeboard: p1' = {red.momentum_rhs[0]}")
    omega = 2 * np.pi / PERIOD

    # Paths of a few gaits, full Lagrange-d'Alembert simulation, four periods from rest.
    periods = 3
    shown = {r"$\delta = 0$": 0.0, r"$\delta = \pi/4$": np.pi / 4, r"$\delta = \pi/2$": np.pi / 2}
    shown[r"$\delta = 3\pi/4$"] = 3 * np.pi / 4
    paths = {
        label: solve(board, LagrangeDAlembert(), t_final=periods * PERIOD, shapes=gait(d), saveat=periods * 100 + 1)
        for label, d in shown.items()
    }

    # Check 1: the reduced equations (1.1)-(1.2) against the full simulation, same gait, same saved times.
    full = paths[r"$\delta = \pi/4$"]
    reduced = solve(board, BKMM(), t_final=full.t[-1], shapes=gait(np.pi / 4), saveat=full.t, backend="python")
    xy_gap = float(np.abs(reduced.q[:, :2] - full.q[:, :2]).max())

    # Sweep of the phase: displacement g(0)^-1 g(T) of the first period and momentum gained in it.
    deltas = np.linspace(0.0, np.pi, 13)
    rows = []
    for d in deltas:
        one = solve(board, LagrangeDAlembert(), t_final=PERIOD, shapes=gait(d), saveat=2)
        x, y, th = one.q[-1, :3]
        rows.append((x, y, th, one.p[-1, 0] - one.p[0, 0]))
    rows_a = np.array(rows)
    bessel = 4 * np.pi * J0 * A_ROTOR * omega * jv(1, B_STEER) * np.cos(deltas) * np.cos(B_STEER * np.sin(deltas))
    dp_gap = float(np.abs(rows_a[:, 3] - bessel).max())

    fig = plt.figure(figsize=(12.5, 7.6))
    grid = fig.add_gridspec(2, 2, height_ratios=[0.85, 1], hspace=0.32, wspace=0.22)
    ax = fig.add_subplot(grid[0, :])
    for i, (label, sol) in enumerate(paths.items()):
        color = f"C{i}"
        ax.plot(sol.q[:, 0], sol.q[:, 1], color=color, lw=1.5, label=label)
        for k in range(100, sol.t.size, 100):
            draw_board(ax, *sol.q[k, :3], r, color)
    draw_board(ax, 0.0, 0.0, 0.0, r, "k")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(x=0.02, y=0.08)
    ax.set_xlabel("$x$ (m)")
    ax.set_ylabel("$y$ (m)")
    ax.set_title(
        rf"board's path, {periods} periods of $\psi = {A_ROTOR}\sin\omega t$, $\phi = {B_STEER}\sin(\omega t + \delta)$"
        "\n(the board drawn at the start of each period, black at t = 0; the dot marks its front axle)",
        fontsize=10,
    )
    ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=9, title="phase offset", borderaxespad=0)
    ax.grid(alpha=0.3)

    ax2 = fig.add_subplot(grid[1, 0])
    ax2.plot(deltas, rows_a[:, 0], "o-", ms=4, label=r"$\Delta x$ (m)")
    ax2.plot(deltas, rows_a[:, 1], "s-", ms=4, label=r"$\Delta y$ (m)")
    ax2.plot(deltas, rows_a[:, 2], "^-", ms=4, label=r"$\Delta\theta$ (rad)")
    ax2.axhline(0, color="0.5", lw=0.8)
    ax2.set_xlabel(r"phase offset $\delta$ (rad)")
    ax2.set_ylabel("displacement in the first period")
    ax2.set_title(r"net motion $g(0)^{-1}g(T)$ of the first period, from rest", fontsize=10)
    ax2.legend(fontsize=8, loc="lower right", ncol=3)
    ax3 = fig.add_subplot(grid[1, 1], sharex=ax2)
    fine = np.linspace(0.0, np.pi, 200)
    ax3.plot(
        fine,
        4 * np.pi * J0 * A_ROTOR * omega * jv(1, B_STEER) * np.cos(fine) * np.cos(B_STEER * np.sin(fine)),
        color="0.4",
        lw=1.2,
        label=r"$4\pi J_0 a\omega J_1(b)\cos\delta\cos(b\sin\delta)$",
    )
    ax3.plot(deltas, rows_a[:, 3], "o", color="C3", ms=5, label="full simulation")
    ax3.axhline(0, color="0.5", lw=0.8)
    ax3.set_xlabel(r"phase offset $\delta$ (rad)")
    ax3.set_ylabel(r"$\Delta p$ per period")
    ax3.set_title("nonholonomic momentum gained per period", fontsize=10)
    ax3.legend(fontsize=8, loc="upper right")
    ax3.set_xticks(np.arange(5) * np.pi / 4, ["0", r"$\pi/4$", r"$\pi/2$", r"$3\pi/4$", r"$\pi$"])
    for a in (ax2, ax3):
        a.grid(alpha=0.3)
    fig.subplots_adjust(left=0.06, right=0.88, top=0.93, bottom=0.07)

    summary = {
        "max |reduced - full| planar position (m)": xy_gap,
        "max |momentum gain per period - Bessel formula|": dp_gap,
        "momentum gain per period at delta = 0": float(rows_a[0, 3]),
        "distance travelled per period at delta = pi/2 (m)": float(np.hypot(*rows_a[6, :2])),
    }
    # The gait at delta = pi/2, animated: the board moving along its path, with its shape variables.
    half_pi = analyse_gait(
        board,
        {"psi": f"{A_ROTOR}*sin(2*pi*t/T)", "phi": f"{B_STEER}*sin(2*pi*t/T + pi/2)"},
        period=PERIOD,
        periods=2,
    )
    animation = gait_html(half_pi, title="snakeboard, delta = pi/2: the board along its path (press play)")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "snakeboard_gaits.png", dpi=120)
        write_html(animation, out / "snakeboard_gait.html")
        plt.close("all")
    else:
        animation.show()  # in the gallery: the animation
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    main(parser.parse_args().out)
