"""
A system of your own: a Chaplygin sleigh carrying a mass on a spring
====================================================================

A nonholonomic system written from scratch with ``NonholonomicSystem.from_lagrangian`` and taken through section 1
of the nonholonomic seed. A sleigh (mass :math:`m`, inertia :math:`J` about its centre of mass) stands on a knife
edge at :math:`(x, y)` pointing along :math:`\\theta`, its centre of mass a distance :math:`a` ahead of the edge. A
point mass :math:`\\mu` slides in a rail across the sleigh through the centre of mass, held by a spring of
stiffness :math:`k`; :math:`s` is its displacement across the sleigh (the shape). With :math:`u = (\\cos\\theta,
\\sin\\theta)`, :math:`n = (-\\sin\\theta, \\cos\\theta)`,

.. math::

    L = \\tfrac m2 |\\dot X + a\\dot\\theta n|^2 + \\tfrac J2\\dot\\theta^2
        + \\tfrac\\mu2 |\\dot X + a\\dot\\theta n - s\\dot\\theta u + \\dot s n|^2 - \\tfrac k2 s^2,
    \\qquad -\\sin\\theta\\,\\dot x + \\cos\\theta\\,\\dot y = 0 ,

invariant under SE(2). The script prints the reduced equations (the momentum equation (1.2) for the two
nonholonomic momenta, the forward and the angular momentum about the edge, and the reconstruction (1.1)), the
curvature of the constraint distribution and the Jacobiators of the almost-Poisson bracket on
:math:`\\mathcal M = \\mathbb FL(\\mathcal D)`, which do not vanish (computed directly from the bracket and from
the curvature formula: they agree). It then lets the free system go: the oscillation of the mass drives the
sleigh, which slows down, backs up and turns round.

Checks: the energy of the free system is conserved by the Lagrange-d'Alembert simulation to the level its
integrator's tolerance sets (shown at two tolerances); the constraint :math:`-\\sin\\theta\\,\\dot x +
\\cos\\theta\\,\\dot y` stays zero along the solution; and the almost-Poisson flow
:math:`\\dot z = J_{\\mathcal M}\\nabla H_{\\mathcal M}`, integrated with scipy, reproduces the motion.

Run: ``python examples/own_nonholonomic.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from geomech import NonholonomicSystem, solve
from geomech.integrators import LagrangeDAlembert
from geomech.lie import SE2
from geomech.reduction import almost_poisson, bkmm_reduction

LAGRANGIAN = (
    "m/2*((x_dot - a*sin(theta)*theta_dot)**2 + (y_dot + a*cos(theta)*theta_dot)**2) + J/2*theta_dot**2"
    " + mu/2*((x_dot - (a*sin(theta) + s*cos(theta))*theta_dot - sin(theta)*s_dot)**2"
    " + (y_dot + (a*cos(theta) - s*sin(theta))*theta_dot + cos(theta)*s_dot)**2)"
    " - k*s**2/2"
)
KNIFE_EDGE = "-sin(theta)*x_dot + cos(theta)*y_dot"
T_FINAL = 48.0


def build() -> NonholonomicSystem:
    return NonholonomicSystem.from_lagrangian(
        LAGRANGIAN,
        SE2("x", "y", "theta"),
        ["s"],
        [KNIFE_EDGE],
        parameters={"m": 1.0, "a": 0.5, "J": 0.2, "mu": 0.3, "k": 4.0},
        name="sleigh with a sprung mass",
    )


def draw_sleigh(ax, x: float, y: float, theta: float, s: float, a: float, color: str) -> None:
    """The sleigh as a triangle pointing forward, the knife edge (black), the rail across it and the mass on it."""
    u, n = np.array([np.cos(theta), np.sin(theta)]), np.array([-np.sin(theta), np.cos(theta)])
    edge, centre = np.array([x, y]), np.array([x, y]) + a * u
    hull = np.array([edge - 0.25 * u + 0.22 * n, centre + 0.4 * u, edge - 0.25 * u - 0.22 * n])
    ax.fill(hull[:, 0], hull[:, 1], color=color, alpha=0.25, lw=0)
    ax.plot(*np.r_[hull, hull[:1]].T, color=color, lw=1.0)
    ax.plot(*np.c_[edge - 0.15 * u, edge + 0.15 * u], color="k", lw=3.5, solid_capstyle="butt")
    ax.plot(*np.c_[centre - 0.4 * n, centre + 0.4 * n], color=color, lw=1.0)
    ax.plot(*(centre + s * n), "o", color=color, mec="k", ms=5)


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sleigh = build()
    values = sleigh.parameter_values()

    def shown(e: sp.Expr) -> sp.Expr:
        return sp.N(sp.together(e.subs(values)), 4)

    # Reduction (BKMM): the basis of S_q is e1 = forward translation, e2 = rotation about the edge.
    red = bkmm_reduction(sleigh)
    print(f"Lagrangian L = {sleigh.lagrangian}")
    print(f"constraint   {KNIFE_EDGE} = 0")
    print(f"basis of S_q (body velocities, columns) = {red.basis.tolist()}")
    print("momentum equation (1.2), parameter values inserted")
    for p, rhs in zip(red.p, red.momentum_rhs):
        print(f"    {p}' = {shown(rhs)}")
    print("reconstruction (1.1)   g^-1 g' = (v_x, v_y, omega)")
    for name, e in zip(("v_x", "v_y", "omega"), red.reconstruction):
        print(f"    {name} = {shown(e)}")

    # The almost-Poisson bracket on M = FL(D) and its Jacobiator.
    ap = almost_poisson(sleigh)
    print(f"induced momenta pt = X^T p, X the basis of D (columns) = {ap.X.tolist()}")
    for idx, K in enumerate(ap.curvature):
        print(f"curvature of D, pair {idx + 1}  K = {sp.simplify(K[0])}")
    jac = ap.jacobiator_values(points=3, seed=1, parameters=sleigh.parameters)  # (points, direct/formula, keys)
    names = [str(v) for v in ap.z]
    print("Jacobiators of coordinate functions at a random state, directly from the bracket:")
    for j, key in enumerate(ap.jacobiator_direct):  # the keys, in the order of jacobiator_values
        print(f"    Jac({', '.join(names[i] for i in key)}) = {jac[0, 0, j]:+.4f}")
    jac_largest = float(np.abs(jac[:, 0]).max())
    jac_gap = float(np.abs(jac[:, 0] - jac[:, 1]).max())

    # The free system: the mass released off-centre, the sleigh moving forward.
    q0, p0 = {"s": 0.3}, [0.5, 0.0]
    sol = solve(sleigh, LagrangeDAlembert(), t_final=T_FINAL, q0=q0, p0=p0, saveat=int(40 * T_FINAL) + 1)
    loose = solve(sleigh, LagrangeDAlembert(), t_final=T_FINAL, q0=q0, p0=p0, saveat=sol.t, rtol=1e-7, atol=1e-9)
    E0 = sol.energy[0]
    drift = np.abs(sol.energy - E0) / E0
    drift_loose = np.abs(loose.energy - E0) / E0
    x, y, th = sol.q[:, :3].T
    xd, yd, thd = sol.qdot[:, :3].T
    lateral = -np.sin(th) * xd + np.cos(th) * yd
    lateral_loose = -np.sin(loose.q[:, 2]) * loose.qdot[:, 0] + np.cos(loose.q[:, 2]) * loose.qdot[:, 1]

    # Second route: the almost-Poisson flow z' = J_M(z) grad H_M(z) in z = (q, pt), integrated with scipy.
    num = ap.numeric()
    z0 = np.r_[sol.q[0], num["pt"](np.r_[sol.q[0], sol.qdot[0]]).ravel()]
    flow = solve_ivp(
        lambda t, z: (num["J"](z) @ num["gradH"](z)).ravel(),
        (0.0, T_FINAL),
        z0,
        method="DOP853",
        t_eval=sol.t,
        rtol=1e-11,
        atol=1e-12,
    )
    flow_gap = float(np.abs(flow.y[:3].T - sol.q[:, :3]).max())

    fig = plt.figure(figsize=(13.5, 5.8))
    grid = fig.add_gridspec(2, 2, width_ratios=[1.35, 1], hspace=0.42, wspace=0.22)
    ax = fig.add_subplot(grid[:, 0])
    ax.plot(x, y, color="C0", lw=1.4, label="knife edge (x, y)")
    a = sleigh.parameters["a"]
    label_offsets = {0.0: (0, -24), 12.0: (0, -24), 30.0: (0, -24), 38.0: (42, -12), 42.0: (0, -24), T_FINAL: (34, -6)}
    for tk, offset in label_offsets.items():
        k = int(np.argmin(np.abs(sol.t - tk)))
        draw_sleigh(ax, x[k], y[k], th[k], sol.q[k, 3], a, "C3")
        ax.annotate(
            f"t = {sol.t[k]:.0f} s", (x[k], y[k]), xytext=offset, textcoords="offset points", fontsize=8, ha="center"
        )
    ax.plot([], [], color="C3", marker="o", mec="k", label="sleigh (pointing forward): edge, rail, mass")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.1)
    ax.set_xlabel("$x$ (m)")
    ax.set_ylabel("$y$ (m)")
    ax.set_title("free motion: the oscillating mass slows the sleigh, backs it up and turns it", fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)

    ax2 = fig.add_subplot(grid[0, 1])
    ax2.plot(sol.t, sol.q[:, 3], color="C0", lw=0.9, label="$s$ (m)")
    ax2.plot(sol.t, np.cos(th) * xd + np.sin(th) * yd, color="C1", lw=1.6, label="$v$ (m/s)")
    ax2.plot(sol.t, thd, color="C2", lw=1.2, label=r"$\dot\theta$ (rad/s)")
    ax2.axhline(0, color="0.5", lw=0.7)
    ax2.set_title(r"the mass across the rail $s$, forward speed $v$, turning rate $\dot\theta$", fontsize=10)
    ax2.legend(fontsize=8, loc="lower left", ncol=3)
    ax2.set_ylim(-1.6, 1.3)
    ax3 = fig.add_subplot(grid[1, 1], sharex=ax2)
    for err, err_loose, color, label in (
        (drift, drift_loose, "C0", r"$|E - E_0|/E_0$"),
        (np.abs(lateral), np.abs(lateral_loose), "C3", r"$|-\sin\theta\,\dot x + \cos\theta\,\dot y|$ (m/s)"),
    ):
        ax3.semilogy(sol.t, np.maximum.accumulate(err), color=color, label=label + r", rtol $10^{-10}$")
        ax3.semilogy(sol.t, np.maximum.accumulate(err_loose), color=color, ls="--", label=label + r", rtol $10^{-7}$")
    ax3.set_ylim(1e-13, 1e-4)
    ax3.set_xlabel("$t$ (s)")
    ax3.set_ylabel("largest error up to $t$")
    ax3.set_title("energy conservation and the constraint, at two tolerances", fontsize=10)
    ax3.legend(fontsize=7, loc="upper left", ncol=2)
    for a_ in (ax2, ax3):
        a_.grid(alpha=0.3)
    fig.subplots_adjust(left=0.06, right=0.98, top=0.93, bottom=0.09)

    summary = {
        "max relative energy drift (rtol 1e-10)": float(drift.max()),
        "max relative energy drift (rtol 1e-7)": float(drift_loose.max()),
        "max constraint residual (m/s)": float(np.abs(lateral).max()),
        "max |almost-Poisson flow - Lagrange-d'Alembert| (x, y, theta)": flow_gap,
        "largest |Jacobiator| at random states": jac_largest,
        "max |Jacobiator direct - curvature formula|": jac_gap,
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "own_nonholonomic.png", dpi=120)
        plt.close("all")
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    main(parser.parse_args().out)
