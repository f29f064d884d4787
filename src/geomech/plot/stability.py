"""Pictures of stability: the stability map over two parameters, and the reduced (Serret-Andoyer) phase
portrait of a closed loop with its relative equilibria marked by verdict."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = ["stability_map_plot", "equilibria_phase_portrait"]

_STYLE = {
    "stable": {"color": "#1a9850", "marker": "o", "label": "stable"},
    "unstable": {"color": "#d73027", "marker": "X", "label": "unstable"},
    "inconclusive": {"color": "#fdae61", "marker": "s", "label": "inconclusive"},
}


def stability_map_plot(
    ds: Any, *, variable: str = "verdict", ax: Any = None, title: str | None = None, boundary: bool = True
) -> Any:
    """Draw a stability map made by :func:`geomech.analysis.stability_map`.

    The verdict codes are drawn as coloured cells (green stable, red unstable, orange inconclusive, grey no
    equilibrium); with ``boundary`` the zero level of ``ec_determinant`` (the computed boundary) is drawn
    in black and, when the dataset has one, the zero level of ``closed_form_margin`` (the closed-form
    prediction) dashed in white over it; black dots mark where the continuation jumped to another branch.
    """
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    if variable not in ds:
        raise InputError(f"Expected `variable` to be one of {list(ds.data_vars)}, got {variable!r}.")
    yname, xname = ds[variable].dims
    xs, ys = ds[xname].values, ds[yname].values
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.8))
    cmap = ListedColormap(
        ["#bdbdbd", _STYLE["unstable"]["color"], _STYLE["inconclusive"]["color"], _STYLE["stable"]["color"]]
    )
    norm = BoundaryNorm([-10, -5, -0.5, 0.5, 1.5], cmap.N)
    ax.pcolormesh(xs, ys, ds[variable].values.astype(float), cmap=cmap, norm=norm, shading="nearest")
    handles: list[Artist] = [Patch(color=_STYLE[k]["color"], label=k) for k in ("stable", "unstable", "inconclusive")]
    if boundary and "ec_determinant" in ds:
        det = ds["ec_determinant"].values
        if np.nanmin(det) < 0 < np.nanmax(det):
            ax.contour(xs, ys, det, levels=[0.0], colors="k", linewidths=1.6)
            handles.append(plt.Line2D([], [], color="k", linewidth=1.6, label="computed boundary"))
    if boundary and "closed_form_margin" in ds:
        mg = ds["closed_form_margin"].values
        if np.any(np.isfinite(mg)) and np.nanmin(mg) < 0 < np.nanmax(mg):
            ax.contour(xs, ys, mg, levels=[0.0], colors="w", linewidths=1.2, linestyles="--")
            handles.append(plt.Line2D([], [], color="w", linestyle="--", label="closed form"))
    if "branch_jump" in ds:
        jj, ii = np.nonzero(ds["branch_jump"].values == 1)
        if jj.size:
            ax.plot(xs[ii], ys[jj], "k.", markersize=3)
            handles.append(
                plt.Line2D([], [], color="k", marker=".", linestyle="none", label="continuation jumped branch")
            )
    if np.any(ds[variable].values == -9):
        handles.append(Patch(color="#bdbdbd", label="no equilibrium"))
    leg = ax.legend(handles=handles, loc="best", fontsize=8, framealpha=0.8)
    leg.get_frame().set_facecolor("0.85")
    ax.set_xlabel(xname)
    ax.set_ylabel(yname)
    ax.set_title(title or ds.attrs.get("description") or f"{variable.replace('_', ' ')}")
    return ax


def equilibria_phase_portrait(
    system: Any,
    G: float,
    analysis: Any = None,
    *,
    axis: int = 2,
    ax: Any = None,
    levels: int = 30,
    trajectory: Any = None,
) -> Any:
    """Level sets of :math:`h_p` in the Serret-Andoyer plane with the relative equilibria marked by verdict.

    Parameters
    ----------
    system : a :class:`~geomech.LeftInvariantSystem` (e.g. ``control.closed_loop()``).
    G : the momentum magnitude.
    analysis : a :class:`~geomech.analysis.StabilityAnalysis` for ``system`` and ``G`` (computed if None).
    axis : the chart's body axis, 0-based (2 is the seed's); equilibria at its poles are drawn on the lines
        :math:`L = \\pm G`.
    trajectory : an optional :class:`~geomech.Solution` of the Serret-Andoyer atlas (one trajectory), overlaid.
    """
    from ..analysis import analyse_stability
    from ..reduction import GeneralizedSerretAndoyer
    from .momentum import reduced_phase_portrait

    if analysis is None:
        analysis = analyse_stability(system, G)
    ax = reduced_phase_portrait(GeneralizedSerretAndoyer(system), G, axis=axis, ax=ax, levels=levels)
    if trajectory is not None:
        sel = np.asarray(trajectory.chart_axis) == axis + 1
        lL = np.asarray(trajectory.serret_andoyer)
        l = np.where(sel, np.angle(np.exp(1j * lL[:, 0])), np.nan)
        L = np.where(sel, lL[:, 1], np.nan)
        # Break the line where l wraps around, so that no segment crosses the plane.
        l[1:][np.abs(np.diff(l)) > np.pi] = np.nan
        ax.plot(l, L, "-", color="C3", linewidth=1.4, label="trajectory (this chart)")
    seen = set()
    for rep in analysis:
        eq = rep.equilibrium
        style = _STYLE[rep.verdict]
        lL = eq.coordinates(axis)
        if lL is None:
            pts = [(x, float(np.sign(eq.m[axis])) * G) for x in (-np.pi, 0.0, np.pi)]
        else:
            l0 = float(np.angle(np.exp(1j * lL[0])))
            pts = [(l0, float(lL[1]))] + (
                [(l0 - 2 * np.pi * np.sign(l0), float(lL[1]))] if abs(abs(l0) - np.pi) < 1e-9 else []
            )
        for x, y in pts:
            label = style["label"] if rep.verdict not in seen else None
            seen.add(rep.verdict)
            ax.plot(
                x,
                y,
                linestyle="none",
                marker=style["marker"],
                color=style["color"],
                markersize=9,
                markeredgecolor="k",
                label=label,
                clip_on=False,
                zorder=5,
            )
    ax.legend(loc="upper right", fontsize=8)
    return ax
