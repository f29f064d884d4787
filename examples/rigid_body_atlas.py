"""
The free rigid body on the Serret-Andoyer atlas, against the exact elliptic solution
====================================================================================

The free rigid body with inertia :math:`(3, 2, 1)` is simulated by the reduced Serret-Andoyer flow
:math:`(l, L)` of eqs. (20, 21) of the Serret-Andoyer seed, with the reconstruction angle of its Theorem 3, on an
atlas of three charts (``geomech.solve(body, "serret_andoyer_atlas", m0=..., R0=...)``): each chart, about one body
axis, is singular at that axis's poles :math:`L = \\pm G`, and the run switches to another chart where
:math:`|L|/G` reaches 0.9. Five initial momenta on the sphere :math:`|m| = 1` cover both families of orbits: two
that encircle the axis of the largest moment (one of them near the separatrix), three that encircle the axis of
the smallest moment (one near the separatrix, one that crosses into the cap :math:`|m_3| > 0.9` and so switches
charts, one that starts inside that cap and so starts in another chart).

The body momentum is checked against the exact solution in Jacobi elliptic functions
(``RigidBody.exact_solution``), an independent route that involves no chart. The attitude is checked at every
whole period :math:`T` of the body momentum, where Montgomery's formula gives it exactly: the attitude has turned
about the spatial momentum :math:`\\mu` by :math:`\\Delta\\theta = 2ET/|\\mu| - \\Lambda` per period, with
:math:`\\Lambda` the solid angle enclosed by the orbit (``geomech.analysis.rigid_body_phase``). The Casimir
:math:`|m|` and the energy :math:`E` are conserved quantities whose drift is printed too.

Run: ``python examples/rigid_body_atlas.py [--out DIR]`` (figures go to DIR; without it they stay open, as the
documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import geomech as gm
from geomech.analysis import rigid_body_phase
from geomech.lie import so3
from geomech.plot.interactive import momentum_sphere_html, write_html

T_FINAL = 50.0


def initial_momenta() -> list[tuple[str, np.ndarray]]:
    """Five starts on |m| = 1: major family (about axis 1), minor family (about axis 3), two near the separatrix."""
    rows = []
    for a in (45.0, 84.0):
        r = np.radians(a)
        rows.append((f"major, m0 = (cos {a:g}°, sin {a:g}°, 0)", np.array([np.cos(r), np.sin(r), 0.0])))
    for a in (84.0, 28.0, 15.0):
        r = np.radians(a)
        rows.append((f"minor, m0 = (0, sin {a:g}°, cos {a:g}°)", np.array([0.0, np.sin(r), np.cos(r)])))
    return rows


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geomech.plot import momentum_sphere

    body = gm.RigidBody([3.0, 2.0, 1.0])
    R0 = so3.exp([0.3, -0.2, 1.1])  # body to space at t = 0
    grid = np.linspace(0.0, T_FINAL, 1001)
    runs = []
    for label, m0 in initial_momenta():
        exact = body.exact_solution(m0)
        phase = rigid_body_phase(body, m0, R0=R0, direct=False, reconstructed=False)
        whole = exact.period * np.arange(1, int(T_FINAL // exact.period) + 1)
        t = np.union1d(grid, whole)
        traj = gm.solve(body, "serret_andoyer_atlas", m0=m0, R0=R0, t_final=T_FINAL, saveat=t)
        mu = R0 @ m0
        at_periods = np.isin(t, whole)
        # Montgomery: R(kT) = exp(k dtheta mu^/|mu|) R0, the rotation about the spatial momentum.
        R_exact = np.stack([so3.exp(k * phase.total * mu / np.linalg.norm(mu)) @ R0 for k in range(1, whole.size + 1)])
        chart = traj.chart_axis
        switch = np.flatnonzero(np.diff(chart) != 0) + 1
        runs.append(
            {
                "label": label,
                "family": exact.family,
                "period": exact.period,
                "t": t,
                "m": traj.m,
                "chart": chart,
                "switches": switch,
                "m_error": np.linalg.norm(traj.m - exact.momentum(t), axis=-1),
                "R_error": np.linalg.norm(traj.R[at_periods] - R_exact, axis=(-2, -1), ord=2),
                "casimir": float(traj.casimir_error),
                "energy": float(traj.energy_error),
                "n_switches": int(traj.stats["chart_switches"]),
            }
        )

    elev, azim = 28.0, 40.0
    view = np.array([np.cos(np.radians(elev)) * np.cos(np.radians(azim)),
                     np.cos(np.radians(elev)) * np.sin(np.radians(azim)), np.sin(np.radians(elev))])  # fmt: skip
    colours = ["C3", "C4", "C5", "C6", "C9"]
    label_box = {"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.8}
    fig = plt.figure(figsize=(13.5, 5.8))
    grid_spec = fig.add_gridspec(1, 2, width_ratios=[1.0, 1.15])
    ax1 = fig.add_subplot(grid_spec[0], projection="3d")
    ax2 = fig.add_subplot(grid_spec[1])
    # The sphere, the energy's level sets (the orbits of Euler's equations) and the axes; the runs are drawn below.
    momentum_sphere(runs[0]["m"][:1], ax=ax1, energy_curves=body.energy, n_levels=6, color="none")
    # The separatrix 2 E = |m|^2 / I_2: the two great circles through +-e_2 with m_3 / m_1 = +-sqrt(slope).
    I1, I2, I3 = body.principal_moments
    slope = (1 / I2 - 1 / I1) / (1 / I3 - 1 / I2)
    s = np.linspace(0.0, 2 * np.pi, 400)
    for sign in (1.0, -1.0):
        c = np.stack([np.cos(s), np.zeros_like(s), sign * np.sqrt(slope) * np.cos(s)], -1)
        circle = c / np.linalg.norm(c[0]) + np.stack([0 * s, np.sin(s), 0 * s], -1)
        for side, alpha in ((circle @ view >= 0, 0.9), (circle @ view < 0, 0.25)):
            ax1.plot(*(np.where(side, 1.0, np.nan)[:, None] * circle).T, "k--", lw=0.9, alpha=alpha)
    for k, run in enumerate(runs):
        m, chart = run["m"], run["chart"]
        front = m @ view >= 0.0
        for a in range(3):
            for side, alpha in ((front, 1.0), (~front, 0.25)):
                seg = np.where((chart == a + 1) & side, 1.0, np.nan)[:, None] * m
                ax1.plot(*seg.T, color=f"C{a}", linewidth=2.0, alpha=alpha)
        # each orbit's number at its point nearest a direction in front (lower for the major family, upper for
        # the minor one), so that nested orbits are labelled apart
        lift = np.array([0.0, 0.0, -0.6 if run["family"] == "major" else 0.9])
        tag = m[np.argmax(m @ (view + lift))]
        ax1.text(*(1.16 * tag), str(k + 1), fontsize=11, weight="bold", color=colours[k], bbox=label_box)
        ax1.scatter(*m[0], color="k", s=14, depthshade=False)
        for i in run["switches"]:
            ax1.scatter(*m[i], marker="X", color="k", s=70, depthshade=False, zorder=5)
    for a in range(3):
        ax1.plot([], [], color=f"C{a}", lw=2.0, label=f"chart about body axis {a + 1}")
    ax1.scatter([], [], marker="X", color="k", s=60, label="chart switch")
    ax1.scatter([], [], color="k", s=14, label="m(0)")
    ax1.plot([], [], "k--", lw=0.9, label="separatrix")
    ax1.legend(loc="upper left", fontsize=8, bbox_to_anchor=(0.0, 1.0))
    ax1.view_init(elev=elev, azim=azim)
    ax1.set_box_aspect((1, 1, 1), zoom=1.3)
    ax1.set_title(
        "body momentum on |m| = 1, coloured by the chart in use\n(far side faded; grey: other orbits)", pad=18
    )

    for k, run in enumerate(runs):
        t = run["t"]
        ax2.semilogy(
            t, np.maximum.accumulate(run["m_error"]), color=colours[k], lw=1.6, label=f"{k + 1}: {run['label']}"
        )
        tk = run["period"] * np.arange(1, run["R_error"].size + 1)
        ax2.semilogy(tk, run["R_error"], "D", color=colours[k], ms=6, mec="k", mew=0.6)
        for i in run["switches"]:
            ax2.axvline(t[i], color=colours[k], ls=":", lw=1.4)
    ax2.plot([], [], "D", color="0.6", mec="k", mew=0.6, label="attitude error at whole periods (Montgomery)")
    ax2.plot([], [], ":", color="0.3", label="chart switch")
    ax2.set_xlabel("t")
    ax2.set_ylabel(r"$\max_{s \leq t} |m(s) - m_{\mathrm{exact}}(s)|$ ;  $\|R(kT) - R_{\mathrm{exact}}(kT)\|_2$")
    ax2.set_title("errors against the elliptic solution and Montgomery's formula")
    ax2.set_ylim(1e-14, 1e-8)
    ax2.grid(alpha=0.3, which="major")
    ax2.legend(fontsize=8, loc="upper left", ncols=2)
    fig.tight_layout()

    summary = {
        "max |m - m_exact|": max(float(r["m_error"].max()) for r in runs),
        "max attitude error at whole periods (Montgomery)": max(float(r["R_error"].max()) for r in runs),
        "max Casimir drift ||m| - |m0||": max(r["casimir"] for r in runs),
        "max energy drift |E - E0|": max(r["energy"] for r in runs),
        "chart switches": float(sum(r["n_switches"] for r in runs)),
    }
    for k, run in enumerate(runs):
        print(
            f"# {k + 1} {run['label']}: {run['family']}, period {run['period']:.4g}, "
            f"{run['n_switches']} chart switch(es), charts used {sorted({int(c) for c in run['chart']})}"
        )
    sphere = momentum_sphere_html(
        [r["m"] for r in runs],
        hamiltonian=lambda m: 0.5 * (m**2 / np.array([3.0, 2.0, 1.0])).sum(axis=-1),
        labels=[f"{k + 1}: {r['label']}" for k, r in enumerate(runs)],
        title="free rigid body: m(t) on |m| = 1 with the level curves of H and the charts' poles (drag to turn)",
    )
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "rigid_body_atlas.png", dpi=120)
        write_html(sphere, out / "momentum_sphere.html")
        plt.close("all")
    else:
        sphere.show()  # in the gallery: the sphere, rotatable
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure")
    main(parser.parse_args().out)
