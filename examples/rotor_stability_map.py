"""
Stabilising the intermediate-axis spin with a momentum wheel: stability maps
============================================================================

A spacecraft with locked inertias :math:`\\lambda_1 = 3 > \\lambda_2`, bus moment :math:`I_3 = 1` about the wheel
axis and one momentum wheel on body axis 3 spins about its intermediate axis. The wheel is driven by a
structure-preserving feedback that keeps :math:`p = \\Gamma - \\varphi(m_3)` constant (section 6 of the
Serret-Andoyer seed), so the closed loop is the left-invariant system :math:`H_c` of eq. (29b), and the stability
of the spin is read off the reduced Hamiltonian :math:`h_p(l, L)` on the momentum sphere :math:`|m| = 1`
(``geomech.analysis.stability_map``: at each grid point the relative equilibrium nearest to :math:`(0, 1, 0)`,
judged by Lagrange-Dirichlet, energy-Casimir and the linearisation).

Two maps are drawn. For the linear feedback :math:`\\varphi = kv` over :math:`(k, \\lambda_2)`, Theorem 5 gives the
boundary in closed form: the spin is stable exactly when :math:`k > 1 - I_3/\\lambda_2`; the script counts the grid
points where the map's verdict disagrees with it. For the cubic feedback :math:`\\varphi = kv + av^3` with a bias
:math:`p = 0.1` over :math:`(k, a)`, the spin moves off the axis and no closed form gives the boundary. On the
meridian :math:`l = 0` the equilibrium sits at the root :math:`L^*` of :math:`L(1 - I_3/\\lambda_2) = \\varphi(L) + p`
nearest :math:`L = 0`, and :math:`h_p` there has the diagonal Hessian with entries
:math:`(G^2 - L^{*2})(1/\\lambda_1 - 1/\\lambda_2) < 0` and :math:`(1 - I_3/\\lambda_2 - \\varphi'(L^*))/I_3`, so
the spin is stable exactly when :math:`\\varphi'(L^*) > 1 - I_3/\\lambda_2`: a second, independent route (the roots of
a cubic), against which the nonlinear map is counted too, wherever that root lies inside the sphere.

Run: ``python examples/rotor_stability_map.py [--out DIR]`` (figures and the interactive map
``stability_map.html`` go to DIR; without it the figures stay open, as the documentation's gallery collects them).
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path

import numpy as np

import geomech as gm
from geomech.analysis import VERDICT_CODES, stability_map, theorem5_margin
from geomech.plot.interactive import stability_map_html, write_html

LAMBDA1, LAMBDA2, I3 = 3.0, 2.0, 1.0
G = 1.0
P = 0.1


def meridian_margin(values: Mapping[str, float]) -> float:
    """:math:`\\varphi'(L^*) - (1 - I_3/\\lambda_2)` for :math:`\\varphi = kv + av^3`, :math:`L^*` the root of
    :math:`aL^3 + (k - c)L + p = 0` of least modulus, NaN when no root lies in :math:`|L| < G`."""
    k, a, p = values["k"], values["a"], values.get("p", P)
    c = 1.0 - I3 / values.get("lambda2", LAMBDA2)
    # np.roots drops the leading zeros: a linear (a = 0) or constant (a = 0, k = c: no root) equation is handled too
    roots = np.roots([a, 0.0, k - c, p])
    roots = roots[np.abs(roots.imag) < 1e-12].real
    roots = roots[np.abs(roots) < G]
    if roots.size == 0:
        return float("nan")
    L = roots[np.argmin(np.abs(roots))]
    return float(k + 3.0 * a * L * L - c)


def disagreements(ds, on_boundary: float = 1e-9) -> tuple[int, int]:
    """Grid points where the verdict is not the closed form's (stable where the margin is positive, unstable
    where it is negative, inconclusive on the boundary itself, where the Hessian of :math:`h_p` is singular), and
    the number of points where the closed form applies."""
    margin = ds["closed_form_margin"].values
    verdict = ds["verdict"].values
    known = np.isfinite(margin)
    expected = np.where(margin > on_boundary, VERDICT_CODES["stable"], VERDICT_CODES["unstable"])
    expected = np.where(np.abs(margin) <= on_boundary, VERDICT_CODES["inconclusive"], expected)
    return int(np.sum(known & (verdict != expected))), int(known.sum())


def main(out: Path | None = None) -> dict:
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geomech.plot import stability_map_plot

    body = gm.RotorBody.one_rotor(LAMBDA1, LAMBDA2, I3)

    # phi = k v: Theorem 5's closed form. Each point continues every relative equilibrium on the sphere (6 here, 10
    # for the cubic feedback) by Newton's method, compiled: a few thousand points take well under a second.
    linear = gm.StructurePreservingControl.one_rotor(body, "k*v", parameters={"k": 0.5}, probe_radius=G)
    ks = np.linspace(0.0, 0.8, 41)
    lambda2s = np.linspace(1.25, 2.75, 31)
    ds_lin = stability_map(
        linear.family(), ("k", ks), ("lambda2", lambda2s), G=G, closed_form=theorem5_margin(linear),
        description="phi = k v",
    ).load()  # fmt: skip
    bad_lin, n_lin = disagreements(ds_lin)

    # phi = k v + a v^3 with a bias p: no closed-form boundary; the meridian root is the second route.
    cubic = gm.StructurePreservingControl.one_rotor(
        body, "k*v + a*v**3", parameters={"k": 0.5, "a": 0.0}, p=P, probe_radius=G
    )
    ks_nl = np.linspace(0.0, 0.8, 41)
    a_nl = np.linspace(0.0, 2.1, 36)
    ds_nl = stability_map(
        cubic.family(), ("k", ks_nl), ("a", a_nl), G=G, closed_form=meridian_margin,
        description=f"phi = k v + a v^3, p = {P}",
    ).load()  # fmt: skip
    bad_nl, n_nl = disagreements(ds_nl)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 5.0))
    stability_map_plot(ds_lin, ax=ax1, title=r"$\varphi = kv$: verdicts, and Theorem 5's $k = 1 - I_3/\lambda_2$")
    ax1.set_xlabel(r"feedback gain $k = \varphi'(0)$")
    ax1.set_ylabel(r"locked inertia $\lambda_2$ (with $\lambda_1 = 3$, $I_3 = 1$)")
    stability_map_plot(
        ds_nl, ax=ax2, title=rf"$\varphi = kv + av^3$, $p = {P}$: verdicts, and $\varphi'(L^*) = 1 - I_3/\lambda_2$"
    )
    from matplotlib.patches import Patch, Rectangle

    # hatch the cells where the meridian root leaves the sphere (the second route says nothing there)
    dk, da = ks_nl[1] - ks_nl[0], a_nl[1] - a_nl[0]
    for j, i in np.argwhere(~np.isfinite(ds_nl["closed_form_margin"].values)):
        corner = (ks_nl[i] - dk / 2, a_nl[j] - da / 2)
        ax2.add_patch(Rectangle(corner, dk, da, facecolor="none", edgecolor="k", hatch="///", linewidth=0))

    # the plot's own legend, moved off the boundary, with the hatching added
    handles = ax2.get_legend().legend_handles + [Patch(facecolor="none", hatch="///", label="no root L* in |L| < G")]
    ax2.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    ax1.legend(handles=ax1.get_legend().legend_handles, loc="lower right", fontsize=8, framealpha=0.9)
    ax2.set_xlabel(r"feedback gain $k = \varphi'(0)$")
    ax2.set_ylabel(r"cubic coefficient $a$ (with $\lambda_2 = 2$)")
    fig.tight_layout()

    summary = {
        "linear map: points where the verdict disagrees with Theorem 5": float(bad_lin),
        "linear map: points compared": float(n_lin),
        "cubic map: points where the verdict disagrees with the meridian root": float(bad_nl),
        "cubic map: points compared": float(n_nl),
        "points where the assessment failed": float((ds_lin["status"] != 0).sum() + (ds_nl["status"] != 0).sum()),
        "cubic map: stable fraction": float(np.mean(ds_nl["verdict"].values == VERDICT_CODES["stable"])),
    }
    interactive = stability_map_html(ds_nl, title="cubic feedback: verdict on the spin over (k, a), hover for values")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "rotor_stability_map.png", dpi=120)
        write_html(interactive, out / "stability_map.html")
        plt.close("all")
    else:
        interactive.show()  # in the gallery: the map, with the verdict and the margins on hover
    for key, value in summary.items():
        print(f"{key}: {value:.3g}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").strip().partition("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="directory for the figure and the interactive map")
    main(parser.parse_args().out)
