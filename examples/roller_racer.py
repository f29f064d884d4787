"""
The roller racer propelled by its steering joint
================================================

The roller racer of the nonholonomic seed (section 1; Krishnaprasad and Tsakiris): two planar bodies joined by a
pivot, each on a wheel pair that cannot slip sideways. Rocking the joint angle about a bias,
:math:`\\phi = \\phi_0 + b\\sin\\omega t`, makes it roll forward and turn; the nonholonomic momentum :math:`p` (along
the one direction of :math:`S_q`) builds up from rest by the same amount every period, so the racer accelerates.

The script simulates the full Lagrange-d'Alembert equations (multipliers solved at every step), draws the path
in the plane with the racer at a few instants, and prints the reduced equations the BKMM reduction derives: the
momentum equation :math:`\\dot p = H(\\phi)\\dot\\phi^2 + K(\\phi)\\dot\\phi\\,p` (eq. 1.2) and the reconstruction
:math:`g^{-1}\\dot g = -\\mathcal A^{nh}(\\phi)\\dot\\phi + e(\\phi)\\mathbb I^{-1}(\\phi)p` (eq. 1.1). Checks: these
printed equations, integrated with scipy's ``solve_ivp`` along the gait, give the momentum and the planar position
of the full simulation; and the energy changes by the work the joint torque does, :math:`E(t) - E(0) = W(t)`.

Run: ``python examples/roller_racer.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from geomech import solve
from geomech.integrators import LagrangeDAlembert
from geomech.reduction import bkmm_reduction
from geomech.systems.nonholonomic_examples import roller_racer

BIAS, AMPLITUDE, PERIOD, PERIODS = 0.2, 0.6, 1.0, 8  # joint angle phi = BIAS + AMPLITUDE sin(2 pi t / PERIOD)


def draw_racer(ax, x: float, y: float, theta: float, phi: float, d1: float, d2: float, color: str) -> None:
    """Body 1 from its nose to the pivot, body 2 from the pivot to its tail; the wheel axles at the centres of
    mass."""
    u1 = np.array([np.cos(theta), np.sin(theta)])
    u2 = np.array([np.cos(theta + phi), np.sin(theta + phi)])
    c1 = np.array([x, y])
    pivot = c1 - d1 * u1
    c2 = pivot - d2 * u2
    nose, tail = c1 + 0.35 * u1, c2 - 0.2 * u2
    ax.plot(*np.c_[nose, pivot], color=color, lw=2.4, solid_capstyle="round")
    ax.plot(*np.c_[pivot, tail], color=color, lw=2.4, solid_capstyle="round", alpha=0.6)
    ax.plot(*pivot, "o", color="w", mec=color, ms=4)
    for c, u in ((c1, u1), (c2, u2)):
        n = np.array([-u[1], u[0]])
        ax.plot(*np.c_[c - 0.15 * n, c + 0.15 * n], color="k", lw=1.6)


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    racer = roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6)
    values = racer.parameter_values()
    omega = 2 * np.pi / PERIOD
    gait = {"phi": f"{BIAS} + {AMPLITUDE}*sin(2*pi*t/{PERIOD})"}

    full = solve(racer, LagrangeDAlembert(), t_final=PERIODS * PERIOD, shapes=gait, saveat=PERIODS * 100 + 1)

    # The reduced equations, with the parameter values inserted, as printed.
    red = bkmm_reduction(racer)
    phi, phid, p = red.r[0], red.rdot[0], red.p[0]
    H, K, _ = red.momentum_coefficients
    H_num, K_num = (sp.simplify(c[0][0, 0].subs(values)) for c in (H, K))
    xi_num = [sp.simplify(e.subs(values)) for e in red.reconstruction]
    print("momentum equation (1.2)   p' = H(phi) phi_dot**2 + K(phi) phi_dot p, with")
    print(f"    H(phi) = {sp.N(H_num, 6)}")
    print(f"    K(phi) = {sp.N(K_num, 6)}")
    print("reconstruction (1.1)      g^-1 g' = (v_x, v_y, omega), with")
    for name, e in zip(("v_x", "v_y", "omega"), xi_num):
        print(f"    {name} = {sp.N(e, 6)}")

    # Check 1: the printed equations integrated by scipy along the gait, from rest at the identity.
    pdot_f = sp.lambdify((phi, phid, p), H_num * phid**2 + K_num * phid * p, "numpy")
    xi_f = sp.lambdify((phi, phid, p), xi_num, "numpy")

    def rhs(t: float, z: np.ndarray) -> list[float]:
        x, y, th, pp = z
        ph = BIAS + AMPLITUDE * np.sin(omega * t)
        phd = AMPLITUDE * omega * np.cos(omega * t)
        vx, vy, om = xi_f(ph, phd, pp)
        return [np.cos(th) * vx - np.sin(th) * vy, np.sin(th) * vx + np.cos(th) * vy, om, pdot_f(ph, phd, pp)]

    ivp = solve_ivp(rhs, (0.0, full.t[-1]), np.zeros(4), method="DOP853", t_eval=full.t, rtol=1e-11, atol=1e-12)
    p_gap = float(np.abs(ivp.y[3] - full.p[:, 0]).max())
    xy_gap = float(np.abs(ivp.y[:2].T - full.q[:, :2]).max())
    # Check 2: energy balance of the full simulation.
    energy_gap = float(np.abs(full.energy - full.energy[0] - full.work).max())

    fig = plt.figure(figsize=(13.0, 5.6))
    grid = fig.add_gridspec(2, 2, width_ratios=[1.15, 1], hspace=0.45, wspace=0.2)
    ax = fig.add_subplot(grid[:, 0])
    ax.plot(full.q[:, 0], full.q[:, 1], color="C0", lw=1.5, label="path of body 1's centre of mass")
    d1, d2 = racer.parameters["d1"], racer.parameters["d2"]
    for k in (0, 400, 600, 800):  # t = 0, 4, 6, 8 s (the racer hardly moves in the first two seconds)
        draw_racer(ax, *full.q[k, :4], d1, d2, "C3")
        ax.annotate(
            f"t = {full.t[k]:.0f} s", full.q[k, :2], xytext=(8, 6), textcoords="offset points", fontsize=8, color="C3"
        )
    ax.plot([], [], color="C3", lw=2.4, label="racer (front body solid, axles black)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.08)
    ax.set_xlabel("$x$ (m)")
    ax.set_ylabel("$y$ (m)")
    ax.set_title(
        rf"path from rest, joint angle $\phi = {BIAS} + {AMPLITUDE}\sin(2\pi t/T)$, $T = {PERIOD:g}$ s", fontsize=10
    )
    ax.legend(loc="lower left", fontsize=8)
    ax.grid(alpha=0.3)

    ax2 = fig.add_subplot(grid[0, 1])
    ax2.plot(full.t, full.p[:, 0], color="C0", lw=1.5, label="full Lagrange-d'Alembert")
    ax2.plot(ivp.t[::10], ivp.y[3, ::10], "o", color="C1", ms=3, label="printed eq. (1.2), scipy")
    ax2.set_ylabel("nonholonomic momentum $p$")
    ax2.set_title("momentum along the gait: the same change every period", fontsize=10)
    ax2.legend(fontsize=8, loc="lower left")
    ax3 = fig.add_subplot(grid[1, 1], sharex=ax2)
    ax3.plot(full.t, full.energy - full.energy[0], color="C2", lw=2.5, alpha=0.6, label="$E(t) - E(0)$")
    ax3.plot(full.t, full.work, color="k", lw=1.0, ls="--", label=r"$W(t) = \int_0^t \tau_\phi\dot\phi\,dt$")
    ax3.set_xlabel("$t$ (s)")
    ax3.set_ylabel("energy (J)")
    ax3.set_title("energy balance: the joint torque's work is the energy gained", fontsize=10)
    ax3.legend(fontsize=8, loc="upper left")
    for a in (ax2, ax3):
        a.grid(alpha=0.3)
        for tb in np.arange(PERIODS + 1) * PERIOD:
            a.axvline(tb, color="0.7", lw=0.6, ls=":")
    fig.subplots_adjust(left=0.06, right=0.98, top=0.93, bottom=0.09)

    summary = {
        "max |p printed equations - p full|": p_gap,
        "max |position printed equations - full| (m)": xy_gap,
        "max |E(t) - E(0) - W(t)| (J)": energy_gap,
        "work done over the run (J)": float(full.work[-1]),
        "momentum gained per period": float(full.p[100, 0] - full.p[0, 0]),
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "roller_racer.png", dpi=120)
        plt.close("all")
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    main(parser.parse_args().out)
