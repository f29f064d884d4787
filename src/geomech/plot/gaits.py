"""Pictures of gaits of nonholonomic systems (:mod:`geomech.analysis.gaits`).

Each function takes ``ax=None`` (a new figure is made), draws, and returns the axes; none calls
``plt.show()``. matplotlib is imported lazily. The helpers of :mod:`geomech.plot.phases` (shape-space grid,
loop with direction arrows, winding numbers, group paths) are shared with the holonomic pictures.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..lie.groups import SE2
from .phases import _component, _curvature_panel, _draw_loop, _grid, _labels, group_path

__all__ = ["gait_paths", "gait_momentum", "gait_connection_field", "gait_curvature_map"]

_STYLE = {
    "connection": dict(color="C2", ls="--", label=r"connection term $-\mathcal{A}^{nh}\dot r$ alone"),
    "momentum": dict(color="C1", ls=":", label=r"momentum term $\mathbb{I}^{-1}p$ alone"),
}


def _model(system: Any) -> Any:
    from ..reduction import ReducedNumeric, bkmm_reduction

    if isinstance(system, ReducedNumeric):
        return system
    if hasattr(system, "model"):
        return system.model
    return bkmm_reduction(system).numeric()


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
    ax.legend(loc="best", fontsize=7, framealpha=0.85)
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
        ax.set_title(f"{analysis.system.name}: change per period {np.round(dp[0], 6).tolist()}", fontsize=9)
    return ax


def gait_connection_field(
    system: Any, *, component: Any = None, loop: Any = None, bounds: Any = None, n: int = 21, ax: Any = None
) -> Any:
    """A row of :math:`-\\mathcal A^{nh}(r)` as a vector field on a 2-D shape space, the gait ``loop`` on top.

    ``system``: a NonholonomicSystem, a :class:`~geomech.reduction.ReducedNumeric` or a GaitAnalysis (its loop
    is drawn unless another is given). As for holonomic systems (:func:`~geomech.plot.phases.connection_field`)
    the arrows are the body velocity a unit shape velocity along each axis produces, so a loop that runs with
    the arrows gains in that component through the connection term. ``component``: an index or a name
    (``"omega"``, ``"v_x"``, ``"theta"``...), default the rotation.
    """
    import matplotlib.pyplot as plt

    if loop is None and hasattr(system, "loop"):
        loop = system.loop
    model = _model(system)
    X, Y, _ = _grid(model, bounds, loop, n)
    A_all = model.connection(np.stack([X, Y], -1))
    c = _component(model, component, np.moveaxis(A_all, -2, -1))
    A = A_all[..., c, :]
    if ax is None:
        _, ax = plt.subplots(figsize=(5.2, 4.8))
    mag = np.hypot(A[..., 0], A[..., 1])
    name = model.group.algebra_names[c]
    if mag.max() > 0:
        q = ax.quiver(X, Y, -A[..., 0], -A[..., 1], mag, cmap="viridis", pivot="mid")
        ax.figure.colorbar(q, ax=ax, label=f"$|A^{{nh}}|$ ({name})")
    else:
        # a zero field has no arrows to scale (matplotlib would divide by zero)
        ax.text(0.5, 0.92, f"the {name} component vanishes here", ha="center", transform=ax.transAxes)
    if loop is not None:
        _draw_loop(ax, loop)
    _labels(ax, model)
    ax.set_title(f"{model.name}:\n$-\\mathcal{{A}}^{{nh}}$, {name} component", fontsize=10)
    return ax


def gait_curvature_map(
    system: Any,
    *,
    component: Any = None,
    loop: Any = None,
    bounds: Any = None,
    n: int = 121,
    ax: Any = None,
    shade: bool = True,
) -> Any:
    """The curvature :math:`B_{12}` of the nonholonomic connection (one component) as a heat map on a 2-D
    shape space, the gait drawn and the enclosed region shaded by its signed winding number.

    For the rotation of SE(2), :math:`-\\iint B` is the turn the connection term gives alone (exactly); for
    the other components only to leading order in the loop's size.
    """
    import matplotlib.pyplot as plt

    if loop is None and hasattr(system, "loop"):
        loop = system.loop
    model = _model(system)
    X, Y, b = _grid(model, bounds, loop, n)
    B_all = model.curvature(np.stack([X, Y], -1))[..., 0, 1]
    c = _component(model, component, B_all)
    if ax is None:
        _, ax = plt.subplots(figsize=(5.6, 4.8))
    _curvature_panel(ax, model, X, Y, B_all[..., c], b, c, loop, shade, "the connection-alone turn")
    _labels(ax, model)
    ax.set_title(
        f"{model.name}:\ncurvature of $\\mathcal{{A}}^{{nh}}$, {model.group.algebra_names[c]} component", fontsize=10
    )
    return ax
