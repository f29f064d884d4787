"""The figures of the Serret-Andoyer study (:mod:`.serret_andoyer_study`): figure 5 (the errors of every
approach), figure 6 (the trajectories on the momentum sphere) and figure 7 (the reduced flow in (l, L)), drawn
from the study's dataset."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["chart_coordinates", "figure5", "figure6", "figure7"]


def _styles(keys: list[str]) -> dict[str, dict[str, Any]]:
    seed_colors = {
        "full6d_adams": "C0",
        "euler_adams": "C1",
        "reduced_adams": "C2",
        "reduced_generating": "C3",
        "reduced_midpoint": "C4",
    }
    extra = iter(["C5", "C6", "C7", "C8", "C9"])
    return {
        k: {
            "color": seed_colors.get(k) or next(extra),
            "linestyle": "-" if k in seed_colors else "--",
            "linewidth": 1.2,
        }
        for k in keys
    }


def figure5(ds: Any) -> Any:
    """Energy error (a) and momentum error (b) of each approach, log scale (the seed's figure 5)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    keys = list(ds.approach.values)
    style = _styles(keys)
    floor = np.finfo(float).eps * 1e-2
    for var, ax, title in (
        ("energy_error", axes[0], "(a) energy error $|H_c(t) - H_c(0)|$"),
        ("momentum_error", axes[1], "(b) momentum error $|\\,|m(t)| - G\\,|$"),
    ):
        for k, lab in zip(keys, ds.label.values):
            ax.semilogy(ds.time, np.maximum(ds[var].sel(approach=k), floor), label=str(lab), **style[k])
        ax.set_title(title, loc="left")
        ax.grid(True, which="major", alpha=0.3)
    axes[1].set_xlabel("t [s]")
    axes[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return fig


def figure6(ds: Any, G: float) -> Any:
    """Body momentum trajectories: three projections and a 3-D view on the sphere (the seed's figure 6), and
    below them the signed drift off the sphere, ``|m(t)| - G``, of every approach on a symmetric log scale: at
    the scale of the projections the drift (1e-4 at most) cannot be seen, and its sign (outward or inward) is
    what the seed's claim is about."""
    import matplotlib.pyplot as plt
    from matplotlib.gridspec import GridSpec

    from ..plot import momentum_sphere

    fig = plt.figure(figsize=(10, 12))
    grid = GridSpec(3, 2, figure=fig, height_ratios=(1.0, 1.0, 0.75))
    keys = list(ds.approach.values)
    style = _styles(keys)
    pairs = ((0, 1), (1, 2), (0, 2))
    for i, (a, b) in enumerate(pairs):
        ax = fig.add_subplot(grid[i // 2, i % 2])
        for k, lab in zip(keys, ds.label.values):
            m = ds.m.sel(approach=k).values
            ax.plot(m[:, a], m[:, b], label=str(lab), **style[k])
        ax.set_xlabel(f"$m_{a + 1}$")
        ax.set_ylabel(f"$m_{b + 1}$")
        ax.set_aspect("equal", adjustable="datalim")
    fig.axes[0].legend(fontsize=6)
    ax3 = fig.add_subplot(grid[1, 1], projection="3d")
    momentum_sphere(ds.m.sel(approach="reduced_midpoint").values, ax=ax3, title=f"on the sphere |m| = {G:g}")
    drift_ax = fig.add_subplot(grid[2, :])
    drifts = {str(k): np.linalg.norm(ds.m.sel(approach=k).values, axis=-1) - G for k in keys}
    scale = max(float(np.max(np.abs(d))) for d in drifts.values())
    for k, lab in zip(keys, ds.label.values):
        drift_ax.plot(ds.time, drifts[str(k)], label=str(lab), **style[str(k)])
    # linear within a few ulps of G, logarithmic beyond: both the round-off of the reduced forms and the
    # drift of the others are visible, with their signs
    drift_ax.set_yscale("symlog", linthresh=8 * np.finfo(float).eps * G)
    decades = [10.0**e * G for e in range(-14, 1, 3) if 10.0**e * G <= 10 * max(scale, 1e-14 * G)]
    drift_ax.set_yticks([-d for d in decades[::-1]] + [0.0] + decades)  # sparse enough not to overlap
    drift_ax.axhline(0.0, color="0.3", linewidth=0.6)
    drift_ax.set_xlabel("t [s]")
    drift_ax.set_ylabel("$|m(t)| - G$")
    drift_ax.set_title(
        f"the drift off the momentum sphere, signed (> 0: outward); largest {scale:.2g}", loc="left", fontsize=9
    )
    drift_ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def chart_coordinates(m: np.ndarray) -> np.ndarray:
    """``(l, L)`` of body momenta ``m`` in the Serret-Andoyer chart about body axis 3 (eq. 20:
    ``m = (sqrt(G^2 - L^2) sin l, sqrt(G^2 - L^2) cos l, L)``), whatever ``|m|``: for an approach that does not
    keep ``|m| = G`` the point moves across the level curves of ``h_p``, which is what figure 7 shows."""
    m = np.asarray(m, dtype=float)
    return np.stack([np.arctan2(m[..., 0], m[..., 1]), m[..., 2]], -1)


def figure7(ds: Any, cfg: Any) -> Any:
    """The reduced flow in (l, L): level sets of h_p and every approach's states (the seed's figure 7), the
    reduced ones from their own (l, L), the others mapped by the chart (:func:`chart_coordinates`)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    ll, LL = np.meshgrid(ds.l_grid.values, ds.L_grid.values)
    hp = ds.h_p.values
    cs = ax.contour(ll, LL, hp, levels=40, cmap="viridis", linewidths=0.8)
    fig.colorbar(cs, ax=ax, label="$h_p(l, L)$")
    ax.contour(ll, LL, hp, levels=[cfg.Hc], colors="k", linewidths=1.0, linestyles="--", zorder=4)
    style = _styles(list(ds.approach.values))
    markers = ["o", "s", "^", "v", "D", "x", "+", "<", ">", "p", "h", "*"]
    reduced = {str(k) for k in ds.reduced_approach.values}
    for i, k in enumerate(str(k) for k in ds.approach.values):
        if k in reduced:
            lL = ds.lL.sel(reduced_approach=k).values
        else:
            lL = chart_coordinates(ds.m.sel(approach=k).values)
        label = str(ds.label.sel(approach=k).values) + ("" if k in reduced else " (mapped by the chart)")
        ax.plot(
            np.angle(np.exp(1j * lL[::7, 0])),
            lL[::7, 1],
            markers[i % len(markers)],
            color=style[k]["color"],
            markersize=2.0,
            markerfacecolor="none",
            markeredgewidth=0.5,
            linestyle="none",
            label=label,
        )
    ax.axhline(cfg.G, color="0.3", linestyle=":")
    ax.axhline(-cfg.G, color="0.3", linestyle=":")
    ax.set_xlabel("$l$ [rad]")
    ax.set_ylabel("$L$ [kg m$^2$/s]")
    ax.set_title(
        f"every approach in (l, L), chart about body axis 3, G = {cfg.G:g}; dashed: $h_p = H_c = {cfg.Hc:g}$",
        loc="left",
        fontsize=9,
    )
    ax.legend(loc="upper right", fontsize=6, markerscale=3)
    fig.tight_layout()
    return fig
