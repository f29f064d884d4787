"""The momentum sphere and the reduced (Serret-Andoyer) phase plane."""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from .. import _validate as V
from ..errors import ShapeError


def _sphere_level_curves(H: Any, G: float, n_levels: int) -> list[np.ndarray]:
    """Level curves of ``H`` on the sphere ``|m| = G`` as 3-D polylines (contours in longitude and
    colatitude, mapped to the sphere)."""
    import contourpy

    lon = np.linspace(-np.pi, np.pi, 241)
    col = np.linspace(0.0, np.pi, 121)
    LON, COL = np.meshgrid(lon, col)
    pts = G * np.stack([np.cos(LON) * np.sin(COL), np.sin(LON) * np.sin(COL), np.cos(COL)], -1)
    E = np.asarray(H(pts), dtype=float)
    gen = contourpy.contour_generator(lon, col, E)
    lines = []
    for level in np.linspace(E.min(), E.max(), n_levels + 2)[1:-1]:
        # the default line type gives a list of (n, 2) arrays; the stubs' return type covers every line type
        for seg in cast("list[np.ndarray]", gen.lines(level)):
            a, c = seg[:, 0], seg[:, 1]
            lines.append(G * np.stack([np.cos(a) * np.sin(c), np.sin(a) * np.sin(c), np.cos(c)], -1))
    return lines


def momentum_sphere(
    m: Any,
    *,
    ax: Any = None,
    title: str | None = None,
    energy_curves: Any = None,
    chart: Any = None,
    color: str = "C3",
    n_levels: int = 16,
) -> Any:
    """Draw body momenta ``m`` (shape ``(n, 3)``) on the momentum sphere ``|m| = G`` (3-D axes).

    Parameters
    ----------
    m : (n, 3) a trajectory of the body angular momentum.
    ax : a 3-D matplotlib axes, or None for a new figure.
    energy_curves : optional vectorised callable ``H(m)``; its level curves on the sphere, which are
        the trajectories of Euler's equation, are drawn in grey.
    chart : optional (n,) ints, the Serret-Andoyer chart (body axis) in use at each point; the
        trajectory is then coloured by chart.
    """
    import matplotlib.pyplot as plt

    m = V.trailing_shape(m, "m", (3,))
    if m.ndim != 2:
        raise ShapeError(f"Expected `m` to have shape (n, 3), got {m.shape}.")
    G = float(np.linalg.norm(m[0]))
    if ax is None:
        fig = plt.figure(figsize=(5.5, 5.5))
        ax = fig.add_subplot(projection="3d")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
    ax.plot_wireframe(G * np.cos(u) * np.sin(v), G * np.sin(u) * np.sin(v), G * np.cos(v), color="0.9", linewidth=0.4)
    if energy_curves is not None:
        for line in _sphere_level_curves(energy_curves, G, n_levels):
            ax.plot(line[:, 0], line[:, 1], line[:, 2], color="0.55", linewidth=0.6)
    if chart is None:
        ax.plot(m[:, 0], m[:, 1], m[:, 2], color=color, linewidth=1.8)
    else:
        chart = np.asarray(chart)
        for k in range(3):
            seg = np.where(chart == k, 1.0, np.nan)[:, None] * m
            ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color=f"C{k}", linewidth=1.8, label=f"chart about axis {k + 1}")
        ax.legend(loc="upper left", fontsize=8)
    ax.scatter(*m[0], color="k", s=18)
    for k, lab in enumerate(("$m_1$", "$m_2$", "$m_3$")):
        end = np.zeros(3)
        end[k] = 1.25 * G
        ax.plot(*np.stack([-end, end], 1), color="0.3", linewidth=0.7)
        ax.text(*(1.32 * end), lab)
    ax.set_axis_off()
    for set_lim in (ax.set_xlim, ax.set_ylim, ax.set_zlim):  # centred: no empty band below the sphere
        set_lim(-1.3 * G, 1.3 * G)
    ax.set_box_aspect((1, 1, 1), zoom=1.35)
    if title:
        ax.set_title(title)
    return ax


def reduced_phase_portrait(
    sa: Any, G: float, *, axis: int = 2, ax: Any = None, levels: int = 30, trajectory: Any = None
) -> Any:
    """Level curves of the reduced Hamiltonian :math:`h_p(l, L)` (eq. 21) on the Serret-Andoyer plane.

    Parameters
    ----------
    sa : a :class:`~geomech.reduction.GeneralizedSerretAndoyer`.
    G : the momentum magnitude.
    axis : the chart's body axis (0-based).
    trajectory : optional :class:`~geomech.Solution` of the Serret-Andoyer atlas; its points in this chart are
        overlaid.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 4.2))
    l = np.linspace(-np.pi, np.pi, 241)
    L = np.linspace(-G, G, 161)[1:-1]
    ll, LL = np.meshgrid(l, L)
    h = sa.reduced_hamiltonian(np.stack([ll, LL], -1), G, axis)
    cs = ax.contour(ll, LL, h, levels=levels, cmap="viridis", linewidths=0.8)
    ax.figure.colorbar(cs, ax=ax, label="$h_p(l, L)$")
    if trajectory is not None:
        sel = np.asarray(trajectory.chart_axis) == axis + 1
        lL = np.asarray(trajectory.serret_andoyer)[sel]
        lw = np.angle(np.exp(1j * lL[:, 0]))
        ax.plot(lw, lL[:, 1], ".", color="C3", markersize=2, label="trajectory (this chart)")
        ax.legend(loc="upper right")
    ax.axhline(G, color="0.3", linestyle=":")
    ax.axhline(-G, color="0.3", linestyle=":")
    ax.set_xlabel("$l$")
    ax.set_ylabel("$L$")
    ax.set_title(f"Serret-Andoyer plane, chart about body axis {axis + 1}, G = {G:.3g}")
    return ax
