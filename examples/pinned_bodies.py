r"""
Two pinned bodies: the geometric and the dynamic phase
======================================================

Two planar rigid bodies are pinned together at their centres of mass (section 2.2 of the nonholonomic seed):
the group is :math:`S^1`, the angle :math:`\theta` of body 1, and the shape is the hinge angle :math:`\psi`, with
:math:`L = \tfrac12 I_1\dot\theta^2 + \tfrac12 I_2(\dot\theta + \dot\psi)^2`. The angular momentum
:math:`\mu = (I_1 + I_2)\dot\theta + I_2\dot\psi` is conserved. When body 2 turns once relative to body 1 in
time :math:`T`, the shape runs once around its circle and body 1 turns by (Theorem 2.2, eq. 2.3)

.. math::

    \Delta\theta = \underbrace{-\oint A_{loc}\,d\psi}_{\text{geometric}}
                 + \underbrace{\mu\int_0^T \mathbb I^{-1}\,dt}_{\text{dynamic}}
                 = -\frac{2\pi I_2}{I_1 + I_2} + \frac{\mu T}{I_1 + I_2}.

The mechanical connection :math:`A_{loc} = I_2/(I_1 + I_2)\,d\psi` is flat (its curvature vanishes) and the shape
space is a circle, so the loop encloses no region: the geometric phase is the holonomy of the connection around
the circle the shape winds once, and it does not depend on how the hinge is driven. (The dynamic factor is the
inverse locked inertia :math:`1/(I_1 + I_2)`, not the seed's printed :math:`I_2/(I_1 + I_2)`; see
``docs/conventions.md``.)

The script computes the split with ``geomech.analysis.phases`` for a range of momenta :math:`\mu`, along a hinge
motion :math:`\psi = 2\pi t/T + 0.6\sin(2\pi t/T)` that is not uniform, and checks the total against two
direct integrations of the Euler-Lagrange equations of the full system (``geomech.solve`` with
``"lagrange_dalembert"``): with the hinge driven along that motion, and free (no hinge torque, so that
:math:`\dot\psi` is constant) from a start chosen so that :math:`\psi` gains :math:`2\pi` in time :math:`T`.

Run: ``python examples/pinned_bodies.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from geomech import solve
from geomech.analysis import Gait, phases
from geomech.plot import phase_split
from geomech.systems.holonomic_examples import two_pinned_bodies

I1, I2 = 1.0, 3.0
PERIOD = 5.5


def simulate(system, mu: float, loop: Gait | None, psi_rate: float = 0.0) -> tuple[float, float, float]:
    """The turns of body 1 and of the hinge over one period from the Euler-Lagrange equations of the full system,
    with the hinge driven along ``loop`` (or free, spinning at ``psi_rate``), and the largest drift of the angular
    momentum from ``mu``."""
    r0, rd0 = (loop.r(0.0), loop.rdot(0.0)) if loop is not None else (np.zeros(1), np.array([psi_rate]))
    theta_rate = system.group_velocity(np.zeros(1), r0, rd0, [mu])
    sol = solve(
        system,
        "lagrange_dalembert",
        q0=np.r_[0.0, r0],
        qdot0=np.r_[theta_rate, rd0],
        shapes=loop,
        t_final=PERIOD,
        saveat=np.array([0.0, PERIOD]),
        rtol=1e-12,
        atol=1e-12,
    )
    drift = float(np.abs(sol.spatial_momentum - mu).max())
    turn, hinge = sol.q[-1] - sol.q[0]
    return float(turn), float(hinge), drift


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    system = two_pinned_bodies(I1, I2)
    loop = Gait.from_expressions({"psi": "2*pi*t/T + 0.6*sin(2*pi*t/T)"}, PERIOD)
    mus = np.linspace(-3.0, 3.0, 7)
    rows = []
    for mu in mus:
        split = phases(system, loop, mu)
        driven, _, drift_driven = simulate(system, mu, loop)
        free, hinge_free, drift_free = simulate(system, mu, None, psi_rate=2 * np.pi / PERIOD)
        closed = -2 * np.pi * I2 / (I1 + I2) + mu * PERIOD / (I1 + I2)
        drift = max(drift_driven, drift_free)
        rows.append((mu, split.geometric, split.dynamic, split.total, driven, free, closed, hinge_free, drift))
    rows_a = np.array(rows)
    mu_shown = -2.5

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.8), gridspec_kw={"width_ratios": [1, 1.1]})
    phase_split(system, loop, mu_shown, ax=ax1)
    ax1.set_title(
        f"one period at $\\mu$ = {mu_shown}: the turn of body 1 split over time\n"
        f"($\\psi = 2\\pi t/T + 0.6\\sin(2\\pi t/T)$, T = {PERIOD}, $I_1$ = {I1:g}, $I_2$ = {I2:g})",
        fontsize=10,
    )
    ax1.grid(alpha=0.3)
    ax2.plot(mus, rows_a[:, 1], "-", color="C0", lw=2, label="geometric $-\\oint A\\,d\\psi$")
    ax2.plot(mus, rows_a[:, 2], "-", color="C1", lw=2, label="dynamic $\\mu\\int_0^T \\mathbb{I}^{-1}dt$")
    ax2.plot(mus, rows_a[:, 3], "-", color="k", lw=2.5, alpha=0.45, label="geometric + dynamic")
    ax2.plot(mus, rows_a[:, 4], "x", color="k", ms=9, mew=1.6, label="full simulation, hinge driven")
    ax2.plot(mus, rows_a[:, 5], "o", color="k", ms=11, mfc="none", label="full simulation, hinge free")
    ax2.axhline(0.0, color="0.75", lw=0.8)
    ax2.set_xlabel("angular momentum $\\mu$")
    ax2.set_ylabel("turn of body 1 over one period, $\\Delta\\theta$ (rad)")
    ax2.set_title("the split for several momenta: the geometric phase does not change", fontsize=10)
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8, loc="upper left")
    fig.tight_layout()

    summary = {
        "geometric phase (rad)": float(rows_a[0, 1]),
        "largest |geometric + dynamic - driven simulation| (rad)": float(np.abs(rows_a[:, 3] - rows_a[:, 4]).max()),
        "largest |geometric + dynamic - free simulation| (rad)": float(np.abs(rows_a[:, 3] - rows_a[:, 5]).max()),
        "largest |geometric + dynamic - closed form| (rad)": float(np.abs(rows_a[:, 3] - rows_a[:, 6]).max()),
        "largest |turn of the free hinge - 2 pi| (rad)": float(np.abs(rows_a[:, 7] - 2 * np.pi).max()),
        "largest drift of the angular momentum in the simulations": float(rows_a[:, 8].max()),
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "pinned_bodies.png", dpi=120)
        plt.close("all")
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    args = parser.parse_args()
    main(args.out)
