r"""
The momentum equation as parallel transport
===========================================

Holonomy equals the enclosed curvature (BKMM; eq. 1.2 of the nonholonomic seed). A point on the plane rolls along
the direction of its shape angle :math:`r_1` (one nonholonomic constraint), its mass along :math:`x` changes with a
second shape :math:`r_2`, and :math:`x` is coupled to :math:`r_2`:

.. math::

    L = \tfrac12 (1 + k r_2^2)\dot x^2 + \tfrac12\dot y^2 + \tfrac12(\dot r_1^2 + \dot r_2^2) + c\,\dot x\dot r_2 .

Its momentum equation :math:`\dot p = \dot r^a K_a(r)\, p + \dot r^T H(r)\,\dot r` is affine in :math:`p`, so a gait
maps the momentum by :math:`p(T) = \Phi\, p(0) + b`: :math:`\Phi` is the holonomy of the connection
:math:`K_a\,dr^a` on the bundle of momenta (geometric: it depends on the loop, not on how fast it is run), :math:`b`
the momentum the forcing builds (it does depend on the timing). With one momentum, Stokes' theorem gives
:math:`\log\Phi = \iint F`, the curvature :math:`F = dK` integrated over the enclosed region.

The script draws the curvature over the shape plane with a family of elliptic gaits, and compares, for each gait,
:math:`\log\Phi` from integrating the momentum equation with the curvature integrated over the ellipse (scipy's
``dblquad``): the points lie on the diagonal. The forcing part :math:`b` is shown for the same loops run at two
speeds (:math:`b` scales with one over the period).

Run: ``python examples/momentum_transport.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.integrate import dblquad

from geomech.analysis import momentum_curvature, momentum_transport
from geomech.lie.groups import Rn
from geomech.systems import NonholonomicSystem


def build() -> NonholonomicSystem:
    return NonholonomicSystem.from_lagrangian(
        "(1 + k*r2**2)*x_dot**2/2 + y_dot**2/2 + (r1_dot**2 + r2_dot**2)/2 + c*x_dot*r2_dot",
        Rn("x", "y"),
        ["r1", "r2"],
        ["-sin(r1)*x_dot + cos(r1)*y_dot"],
        parameters={"k": 0.8, "c": 0.3},
        name="rolling point with a shape-dependent mass",
    )


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    system = build()
    centre = np.array([0.6, 0.5])
    sizes = np.linspace(0.1, 0.5, 5)
    rows = []
    for s in sizes:
        a, b = s, 0.8 * s
        loop = {"r1": f"{centre[0]} + {a}*cos(2*pi*t/T)", "r2": f"{centre[1]} + {b}*sin(2*pi*t/T)"}
        fast = momentum_transport(system, loop, period=1.0)
        slow = momentum_transport(system, loop, period=3.0)

        def F(theta: float, rho: float, a: float = a, b: float = b) -> float:
            r = centre + np.array([a * rho * np.cos(theta), b * rho * np.sin(theta)])
            return float(momentum_curvature(system, r)[0, 1]) * a * b * rho

        enclosed, _ = dblquad(F, 0.0, 1.0, 0.0, 2 * np.pi, epsabs=1e-13, epsrel=1e-11)
        rows.append((s, float(np.log(fast.holonomy[0, 0])), enclosed, float(fast.offset[0]), float(slow.offset[0])))
    rows_a = np.array(rows)

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4.6), gridspec_kw={"width_ratios": [1.25, 1, 1]})
    r1, r2 = np.meshgrid(np.linspace(-0.2, 1.4, 81), np.linspace(-0.2, 1.2, 71))
    curv = momentum_curvature(system, np.stack([r1, r2], -1))[..., 0, 1]
    lim = np.abs(curv).max()
    mesh = ax1.pcolormesh(r1, r2, curv, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
    fig.colorbar(mesh, ax=ax1, label="F_12 = dK_2/dr1 - dK_1/dr2")
    th = np.linspace(0, 2 * np.pi, 200)
    for s in sizes:
        ax1.plot(centre[0] + s * np.cos(th), centre[1] + 0.8 * s * np.sin(th), color="k", lw=1)
    ax1.set_aspect("equal")
    ax1.set_xlabel("r1")
    ax1.set_ylabel("r2")
    ax1.set_title("curvature of K, with the gaits")
    ax2.plot(rows_a[:, 2], rows_a[:, 1], "o", color="C0", label="gaits")
    span = np.array([rows_a[:, 1:3].min(), rows_a[:, 1:3].max()])
    ax2.plot(span, span, color="0.5", lw=1, label="log holonomy = enclosed curvature")
    ax2.set_xlabel("curvature integrated over the enclosed region")
    ax2.set_ylabel("log of the holonomy (momentum equation)")
    ax2.set_title("Stokes: holonomy from the curvature")
    ax2.legend(fontsize=8)
    ax3.plot(sizes, rows_a[:, 3], "o-", label="period 1")
    ax3.plot(sizes, 3 * rows_a[:, 4], "x--", label="period 3, times 3")
    ax3.set_xlabel("semi-axis of the gait (r1)")
    ax3.set_ylabel("forcing part b(T) of the momentum")
    ax3.set_title("the forcing part depends on the timing")
    ax3.legend(fontsize=8)
    for ax in (ax2, ax3):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    summary = {
        "largest |log holonomy - enclosed curvature|": float(np.abs(rows_a[:, 1] - rows_a[:, 2]).max()),
        "largest |b(T=1) - 3 b(T=3)|": float(np.abs(rows_a[:, 3] - 3 * rows_a[:, 4]).max()),
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "momentum_transport.png", dpi=120)
        plt.close("all")
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    main(parser.parse_args().out)
