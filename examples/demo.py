"""
A short tour of geomech
=======================

The free rigid body and a user's own left-invariant system, reduced by the generalized Serret-Andoyer
transformation, simulated through chart switches, and checked; Montgomery's phase; a long-time propagation by the
period; the snakeboard derived from its Lagrangian and driven through a gait.

Run with ``make demo`` (or ``python examples/demo.py [--out DIR]``); figures go to DIR (without it they stay open,
as the documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.experiments.rigid_body import run_rigid_body, summary_text
from geomech.plot import momentum_sphere, reduced_phase_portrait


def _save(fig, out: Path | None, name: str) -> None:
    """Write ``fig`` to ``out/name`` when a directory was given; else leave it open (the gallery collects it)."""
    if out is not None:
        fig.savefig(out / name, dpi=120)


def main(out: Path | None = None) -> None:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if out is not None:
        out.mkdir(parents=True, exist_ok=True)

    print("1. Free rigid body: exact elliptic solution vs the integrated reduced system (l, L)")
    summary, traj = run_rigid_body([3.0, 2.0, 1.0], [1.0, 0.3, 0.2], t_final=50.0)
    print(summary_text(summary))

    print("\n2. A system of your own: H(m) = m1^2/6 + m2^2/4 + m3^2/2 + m3^4/10 + m1 + m2 + m3")
    m1, m2, m3 = gm.M_SYMBOLS
    system = gm.LeftInvariantSystem.from_expression(
        m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3**4 / 10 + m1 + m2 + m3, name="gyrostat-like body"
    )
    sa = gm.GeneralizedSerretAndoyer(system)
    print("   reduced Hamiltonian h_p(l, L) =", sa.h_p(axis=2))
    m0, R0 = np.array([0.2, 0.9, 0.3]), gm.lie.so3.exp(np.array([0.3, -0.2, 1.1]))
    t = np.linspace(0.0, 40.0, 2001)
    red = gm.solve(system, gm.integrators.SerretAndoyerAtlas(axis=3), t_final=40.0, saveat=t, m0=m0, R0=R0)

    def rhs(_t, y):
        dR, dm = system.vector_field(y[:9].reshape(3, 3), y[9:])
        return np.concatenate([dR.ravel(), dm])

    ref = solve_ivp(rhs, (0, 40), np.concatenate([R0.ravel(), m0]), method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    print(f"   chart switches: {red.stats['chart_switches']} through all three charts (no pole is an equilibrium here)")
    print(
        f"   max |m - m_direct| = {np.abs(red.m - ref.y[9:].T).max():.2e}, "
        f"max |R - R_direct| = {np.abs(red.R - ref.y[:9].T.reshape(-1, 3, 3)).max():.2e}"
    )
    p = np.einsum("nij,nj->ni", red.R, red.m)
    print(f"   spatial momentum p = R m kept to {np.abs(p - p[0]).max():.2e}")

    fig = plt.figure(figsize=(11, 4.8))
    ax1 = fig.add_subplot(1, 2, 1, projection="3d")
    momentum_sphere(
        traj.m, ax=ax1, title="free rigid body I = (3, 2, 1)", energy_curves=gm.RigidBody([3.0, 2.0, 1.0]).energy
    )
    ax2 = fig.add_subplot(1, 2, 2, projection="3d")
    momentum_sphere(
        red.m,
        ax=ax2,
        title=f"gyrostat-like body: {red.stats['chart_switches']} chart switches",
        energy_curves=system.hamiltonian,
        chart=red.chart_axis - 1,
    )
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=0.9, wspace=0.0)
    _save(fig, out, "momentum_spheres.png")
    ax = reduced_phase_portrait(sa, float(np.linalg.norm(m0)), axis=2, trajectory=red)
    _save(ax.figure, out, "serret_andoyer_plane.png")
    if out is not None:
        plt.close("all")

    print("\n3. Montgomery's phase: after one period of m, the attitude turns about the spatial momentum by")
    print("   -(solid angle enclosed by m/|m|) + 2 E T / |mu|")
    from geomech.analysis import rigid_body_phase

    ph = rigid_body_phase(gm.RigidBody([3.0, 2.0, 1.0]), [1.0, 0.3, 0.2], reconstructed=False)
    print(f"   T = {ph.period:.12f}, geometric {ph.geometric:+.12f}, dynamic {ph.dynamic:+.12f}")
    print(f"   formula (wrapped) {ph.total_wrapped:+.12f} vs direct integration of R: {ph.direct_wrapped:+.12f}")

    print("\n4. Long times: the reduced system (l, L) is periodic, so the state at t = 1e5 costs one period")
    hp = sa.reduced_system(G=1.0, axis=2)
    sol = gm.solve(hp, "periodic_orbit", y0=[0.3, 0.2], saveat=1001, t_final=1e5)  # every 100
    print(f"   {sol.message}")
    check = solve_ivp(lambda _t, y: hp.vector_field(y), (0, 1000), [0.3, 0.2], method="DOP853", rtol=1e-13, atol=1e-13)
    drift = abs(hp.hamiltonian(check.y[:, -1]) - hp.hamiltonian(np.array([0.3, 0.2])))
    gap = np.abs(sol.states[10] - check.y[:, -1]).max()
    print(
        f"   at t = 1000 it differs from DOP853 (rtol 1e-13) by {gap:.1e}, DOP853's energy having drifted by "
        f"{drift:.1e};\n   the period's energy error up to t = 1e5 is {np.abs(sol.energy_error).max():.1e} "
        "(the tests check this state against a\n   quadruple-precision Taylor integration)"
    )

    print("\n5. A nonholonomic system from its Lagrangian: the snakeboard (BKMM 1996)")
    from geomech.analysis.gaits import analyse_gait
    from geomech.plot.gaits import gait_paths
    from geomech.reduction import almost_poisson, bkmm_reduction
    from geomech.systems.nonholonomic_examples import snakeboard_bkmm

    board = snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)
    bkmm = bkmm_reduction(board)
    print("   momentum equation p' =", bkmm.momentum_rhs[0], "  (derived, BKMM's form)")
    print("   Jacobi identity of the almost-Poisson bracket holds:", almost_poisson(board).satisfies_jacobi)
    gait = analyse_gait(board, {"psi": "sin(4*pi*t/T)", "phi": "0.4*sin(2*pi*t/T)"}, period=1.0, periods=3)
    print(
        "   rotor at twice the steering frequency, 3 periods: net (dx, dy, dtheta) =",
        np.round(gait.net_displacement, 6).tolist(),
    )
    ax = gait_paths(gait)
    _save(ax.figure, out, "snakeboard_gait.png")
    if out is not None:
        plt.close("all")
        figures = ("momentum_spheres.png", "serret_andoyer_plane.png", "snakeboard_gait.png")
        names = ", ".join(f"{out}/{n}" for n in figures)
        print(f"\nfigures written to {names}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None)
    main(parser.parse_args().out)
