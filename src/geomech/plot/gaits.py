"""Pictures of gaits of nonholonomic systems (:mod:`geomech.analysis.gaits`).

Each function takes ``ax=None`` (a new figure is made), draws, and returns the axes; none calls
``plt.show()``. matplotlib is imported lazily. The helpers of :mod:`geomech.plot.phases` (shape-space grid,
loop with direction arrows, winding numbers, group paths) are shared with the holonomic pictures.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..lie.groups import SE2
from .phases import group_path

__all__ = ["gait_paths", "gait_momentum"]

_STYLE = {
    "connection": dict(color="C2", ls="--", label=r"connection term $-\mathcal{A}^{nh}\dot r$ alone"),
    "momentum": dict(color="C1", ls=":", label=r"momentum term $\mathbb{I}^{-1}p$ alone"),
}


def gait_paths(analysis: Any, *, ax: Any = None, arrows: int = 12, parts: bool = True) -> Any:
    """The reconstructed path of a :class:`~geomech.analysis.gaits.GaitAnalysis` (SE(2): position with
    headings), with the paths the connection term and the momentum term give alone drawn over it (same
    axes, same start, dashed and dotted).

    The parts are integrated from the same start; they do not compose to the full path (SE(2) is not
    abelian), which the picture shows.
    """
    ax = group_path(analysis.path, ax=ax, arrows=arrows)
    if not isinstance(analysis.model.group.numeric, SE2):  # the planar picture with headings
        return ax
    if parts:
        span = float(np.ptp(analysis.path.g[:, :2], axis=0).max()) or 1.0
        for name, path in analysis.alone.items():
            xy, th = path.g[:, :2], path.g[:, 2]
            st = _STYLE[name]
            ax.plot(xy[:, 0], xy[:, 1], color=st["color"], ls=st["ls"], lw=1.4, label=st["label"])
            idx = np.linspace(0, len(th) - 1, max(arrows // 2, 2)).astype(int)
            ax.quiver(
                xy[idx, 0],
                xy[idx, 1],
                np.cos(th[idx]),
                np.sin(th[idx]),
                color=st["color"],
                angles="xy",
                scale_units="xy",
                scale=8.0 / span,
                width=0.003,
                alpha=0.7,
            )
    idx = analysis.boundary_indices
    xy = analysis.path.g[idx, :2]
    ax.plot(xy[:, 0], xy[:, 1], "s", color="C0", ms=4, label="full motion (period ends)")
    ax.plot([], [], color="C3", marker=r"$\rightarrow$", ls="none", ms=10, label="heading (full motion)")
    ax.margins(0.12)  # the heading arrows stick out of the path's bounding box
    # below the axes, off the data
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=7, frameon=False)
    d = analysis.net_displacement
    ax.set_title(
        f"{analysis.system.name}: {analysis.periods} period(s), net g(0)$^{{-1}}$g(NT) = "
        f"({d[0]:.3g}, {d[1]:.3g}, {d[2]:.3g})",
        fontsize=9,
    )
    return ax


def gait_momentum(analysis: Any, *, ax: Any = None) -> Any:
    """The nonholonomic momentum :math:`p(t)` along the gait, period boundaries dotted."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 3.6))
    if analysis.p.shape[1] == 0:
        ax.text(
            0.5,
            0.5,
            r"$S_q = 0$: no nonholonomic momentum" "\n(principally kinematic)",
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
    for i in range(analysis.p.shape[1]):
        ax.plot(analysis.t, analysis.p[:, i], label=f"$p_{{{i + 1}}}$")
    for tb in analysis.t[analysis.boundary_indices]:
        ax.axvline(tb, color="0.6", lw=0.8, ls=":")
    ax.set_xlabel("$t$")
    ax.set_ylabel("nonholonomic momentum")
    if analysis.p.shape[1]:
        ax.legend(loc="best", fontsize=8)
        dp = analysis.momentum_change
        ax.set_title(f"{analysis.system.name}: change per period {(np.round(dp[0], 6) + 0.0).tolist()}", fontsize=9)
    return ax
