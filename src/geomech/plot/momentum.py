"""The momentum sphere and the reduced (Serret-Andoyer) phase plane."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import ShapeError


def momentum_sphere(m: Any, *, ax: Any = None, title: str | None = None, energy_curves: Any = None,
                    color: str = "C3") -> Any:
    """Draw body momenta ``m`` (shape ``(n, 3)``) on the sphere ``|m| = G`` (3-D axes).

    Parameters
    ----------
    m : (n, 3) a trajectory of the body angular momentum.
    ax : a 3-D matplotlib axes, or None for a new figure.
    energy_curves : optional callable ``H(m)`` (vectorised); its level sets on the sphere are drawn
        faintly, which shows the phase portrait of Euler's equations on the momentum sphere.
    """
    import matplotlib.pyplot as plt

    m = V.trailing_shape(m, "m", (3,))
    if m.ndim != 2:
        raise ShapeError(f"Expected `m` to have shape (n, 3), got {m.shape}.")
    G = float(np.linalg.norm(m[0]))
    if ax is None:
        fig = plt.figure(figsize=(5.5, 5.5))
        ax = fig.add_subplot(projection="3d")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 73), np.linspace(0, np.pi, 37))
    xs, ys, zs = G * np.cos(u) * np.sin(v), G * np.sin(u) * np.sin(v), G * np.cos(v)
    ax.plot_wireframe(xs, ys, zs, color="0.85", linewidth=0.4)
    if energy_curves is not None:
        pts = np.stack([xs, ys, zs], -1)
        E = energy_curves(pts)
        for level in np.linspace(E.min(), E.max(), 14)[1:-1]:
            mask = np.abs(E - level) < 0.004 * (E.max() - E.min())
            ax.scatter(xs[mask], ys[mask], zs[mask], s=0.5, color="0.5")
    ax.plot(m[:, 0], m[:, 1], m[:, 2], color=color, linewidth=1.6)
    ax.scatter(*m[0], color=color, s=20)
    ax.set_xlabel("$m_1$")
    ax.set_ylabel("$m_2$")
    ax.set_zlabel("$m_3$")
    ax.set_box_aspect((1, 1, 1))
    if title:
        ax.set_title(title)
    return ax


def reduced_phase_portrait(sa: Any, G: float, *, axis: int = 2, ax: Any = None, levels: int = 30,
                           trajectory: Any = None) -> Any:
    """Level curves of the reduced Hamiltonian :math:`h_p(l, L)` (eq. 21) on the Serret-Andoyer plane.

    Parameters
    ----------
    sa : a :class:`~geomech.reduction.GeneralizedSerretAndoyer`.
    G : the momentum magnitude.
    axis : the chart's body axis (0-based).
    trajectory : optional ``ReducedTrajectory``; its points in this chart are overlaid.
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
        sel = trajectory.axis == axis
        lw = np.angle(np.exp(1j * trajectory.l[sel]))
        ax.plot(lw, trajectory.L[sel], ".", color="C3", markersize=2, label="trajectory")
        ax.legend(loc="upper right")
    ax.set_xlabel("$l$")
    ax.set_ylabel("$L$")
    ax.set_title(f"Serret-Andoyer plane, chart about body axis {axis + 1}, G = {G:.3g}")
    return ax
