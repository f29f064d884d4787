r"""
Spin stabilisation about the intermediate axis with one momentum wheel
======================================================================

A spacecraft spinning about its intermediate principal axis tumbles. A wheel on body axis 3 driven by the
structure-preserving feedback :math:`u = \varphi'(m_3)\,\dot m_3` (eq. 29a of the Serret-Andoyer paper, sign
corrected) turns the closed loop into a left-invariant Hamiltonian system :math:`H_c` (eq. 29b), and Theorem 5 says
the spin about axis 2 becomes stable once :math:`\varphi'(0) > 1 - I_3/\lambda_2`. This script designs such a
control with a bounded wheel momentum, checks it (existence of :math:`H_c`, Lemma 4, hyperregularity, three
stability verdicts, the stability boundary), simulates the open-loop equations (26) with the feedback, and plots
the reduced phase portrait with the level sets of :math:`h_p` and the equilibria marked.

Run: ``python examples/spacecraft_control.py [--out DIR]`` (figures and a JSON summary go to DIR; without it the
figures stay open, as the documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import geomech as gm
from geomech.analysis import analyse_stability, perturbation_growth, stability_boundary
from geomech.reduction.rotor_closed_forms import locked_rotor_control, theorem5_boundary
from geomech.systems.control import StructurePreservingControl
from geomech.systems.rotors import RotorBody


def _save(fig, out: Path | None, name: str) -> None:
    """Write ``fig`` to ``out/name`` when a directory was given; else leave it open (the gallery collects it)."""
    if out is not None:
        fig.savefig(out / name, dpi=120)


def main(out: Path, t_final: float = 1500.0) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geomech.plot.stability import equilibria_phase_portrait

    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    # Locked inertias about axes 1, 2 (kg m^2), the bus's own moment about the wheel axis, the wheel's axial
    # moment: lambda1 > lambda2 > I3 + J3, so axis 2 is the intermediate axis of the locked spacecraft.
    lam1, lam2, I3, J3 = 1200.0, 1000.0, 700.0, 50.0
    body = RotorBody.one_rotor(lam1, lam2, I3, J3)
    G = 100.0  # N m s, a spin of about 0.1 rad/s about axis 2
    spin = np.array([0.0, G, 0.0])

    print("1. Uncontrolled (wheel locked to the bus): the intermediate-axis spin")
    locked = locked_rotor_control(body).closed_loop()
    rep = analyse_stability(locked, G).nearest(spin)
    print(
        f"   Lagrange-Dirichlet: {rep.lagrange_dirichlet.verdict}; energy-Casimir: {rep.energy_casimir.verdict}; "
        f"linearisation: {rep.linearisation.verdict} ({rep.linearisation.reason})"
    )

    print("\n2. Design: phi(v) = h_max tanh(k v / h_max), wheel momentum |Gamma| < h_max, phi'(0) = k")
    k_min = theorem5_boundary(lam2, I3)
    k, h_max = 2.0 * k_min, 25.0
    control = StructurePreservingControl.one_rotor(
        body, "h_max*tanh(k*v/h_max)", parameters={"k": k, "h_max": h_max}, probe_radius=G
    )
    print(f"   Theorem 5 needs phi'(0) > 1 - I3/lambda2 = {k_min:.4g}; chosen k = {k:.4g}")
    print(f"   closed-loop Hamiltonian H_c = {control.H_c}")
    lemma = control.lemma4_check()
    hyp = control.hyperregularity()
    print(f"   existence of H_c: {control.condition.detail}")
    print(f"   Lemma 4, grad H_c = D1 H_f on the loop: max relative error {lemma.max_relative_error:.2e}")
    print(f"   hyperregular: {hyp.status} ({hyp.where})")

    print("\n3. Check: all relative equilibria on |m| = G and three verdicts on each")
    system = control.closed_loop()
    analysis = analyse_stability(system, G)
    print(f"   {analysis.equilibria.message}")
    for r in analysis:
        print(
            f"   m = {np.round(r.equilibrium.m, 3) + 0.0}: LD {r.lagrange_dirichlet.verdict}, "
            f"EC {r.energy_casimir.verdict}, linearisation {r.linearisation.verdict}"
        )
    target = analysis.nearest(spin)
    boundary = stability_boundary(control.family(), "k", (0.5 * k_min, 2.0 * k_min), G=G)
    print(
        f"   boundary found by the tool: k = {boundary.value:.10f} (closed form {k_min:.10f}), stable "
        f"{boundary.stable_side}"
    )
    below = perturbation_growth(control.family()(k=0.8 * k_min), spin, delta=1e-3, t_final=t_final)
    above = perturbation_growth(system, spin, delta=1e-3, t_final=t_final)
    print(
        f"   simulated growth of a 1e-3 perturbation: k = 0.8 k_min -> x{below.ratio:.0f}, "
        f"k = {k:.3g} -> x{above.ratio:.2f}"
    )

    print("\n4. The controlled spacecraft: open-loop equations (26) with the feedback, from a perturbed spin")
    m0 = G * np.array([0.03, 1.0, 0.02]) / np.linalg.norm([0.03, 1.0, 0.02])
    t = np.linspace(0.0, t_final, 1501)
    run = dict(t_final=t_final, saveat=t, rtol=1e-12, atol=1e-12)
    wheel_locked = locked_rotor_control(body)
    free = gm.solve(body, "solve_ivp", m0=m0, Gamma0=wheel_locked.rotor_momentum(m0), tau=wheel_locked, **run)
    ctrl = gm.solve(body, "solve_ivp", m0=m0, Gamma0=control.rotor_momentum(m0), tau=control, **run)
    tilt = lambda m: np.degrees(np.arccos(np.clip(m[:, 1] / G, -1.0, 1.0)))  # noqa: E731
    p_drift = np.abs(control.conserved_p(ctrl.m, ctrl.Gamma) - control.conserved_p(m0, ctrl.Gamma[0])).max()
    pi = ctrl.spatial_momentum
    print(
        f"   max angle between m and body axis 2: locked wheel {tilt(free.m).max():.1f} deg, "
        f"controlled {tilt(ctrl.m).max():.2f} deg"
    )
    print(
        f"   wheel momentum max |Gamma| = {np.abs(ctrl.Gamma).max():.3g} N m s (bound {h_max}), "
        f"max torque {np.abs(ctrl.tau).max():.3g} N m"
    )
    print(f"   p = Gamma - phi(m3) kept to {p_drift:.1e}; spatial momentum R m kept to {np.abs(pi - pi[0]).max():.1e}")
    Hc = system.hamiltonian(ctrl.m)
    print(f"   closed-loop energy H_c kept to {np.abs(Hc - Hc[0]).max() / abs(Hc[0]):.1e} (relative)")

    # A larger perturbation for the picture: 25 degrees off the spin axis, still inside the stable island.
    big = G * np.array([np.sin(np.radians(25.0)), np.cos(np.radians(25.0)), 0.0])
    reduced = gm.solve(system, "serret_andoyer_atlas", t_final=600.0, saveat=2001, m0=big)
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6))
    equilibria_phase_portrait(system, G, analysis, ax=axes[0], trajectory=reduced)
    axes[0].set_title(f"closed loop: h_p level sets, k = {k:.3g}")
    equilibria_phase_portrait(locked, G, ax=axes[1])
    axes[1].set_title("wheel locked: h_p level sets")
    fig.tight_layout()
    _save(fig, out, "spacecraft_phase_portrait.png")
    fig2, ax = plt.subplots(figsize=(6.5, 3.8))
    ax.plot(t, tilt(free.m), label="wheel locked")
    ax.plot(t, tilt(ctrl.m), label=f"phi = h_max tanh(k v/h_max), k = {k:.3g}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("angle of m from body axis 2 (deg)")
    ax.legend()
    fig2.tight_layout()
    _save(fig2, out, "spacecraft_tilt.png")
    if out is not None:
        plt.close("all")
    summary = {
        "k_min_closed_form": k_min,
        "k_boundary_found": boundary.value,
        "k": k,
        "h_max": h_max,
        "verdicts_at_spin": {
            "lagrange_dirichlet": target.lagrange_dirichlet.verdict,
            "energy_casimir": target.energy_casimir.verdict,
            "linearisation": target.linearisation.verdict,
        },
        "locked_verdict": rep.verdict,
        "growth_ratio_below": below.ratio,
        "growth_ratio_above": above.ratio,
        "max_tilt_deg": {"locked": float(tilt(free.m).max()), "controlled": float(tilt(ctrl.m).max())},
        "max_wheel_momentum": float(np.abs(ctrl.Gamma).max()),
        "p_drift": float(p_drift),
        "lemma4_relative_error": lemma.max_relative_error,
        "hyperregular": hyp.status,
    }
    if out is not None:
        (out / "spacecraft_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        print(f"\nfigures: {out}/spacecraft_phase_portrait.png, {out}/spacecraft_tilt.png")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None)
    main(parser.parse_args().out)
