"""Pictures of connections, curvature, gaits and phases (section 2 of the nonholonomic paper).

Each function takes ``ax=None`` (a new figure is made), draws, and returns the axes; none calls
``plt.show()``. matplotlib is imported lazily.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, ShapeError
from ..lie._common import wrap_angle
from ..lie.groups import SE2

__all__ = ["connection_field", "curvature_map", "group_path", "momentum_solid_angle", "winding_numbers"]


def winding_numbers(loop_points: Any, points: Any) -> np.ndarray:
    """Winding number of the closed polygon ``loop_points`` ``(m, 2)`` around each of ``points`` ``(..., 2)``."""
    P = V.trailing_shape(loop_points, "loop_points", (2,))
    X = V.trailing_shape(points, "points", (2,))
    d = P[None, :, :] - X.reshape(-1, 1, 2)
    ang = np.arctan2(d[..., 1], d[..., 0])
    dang = np.diff(np.concatenate([ang, ang[:, :1]], 1), axis=1)
    w = np.round(wrap_angle(dang).sum(1) / (2 * np.pi))
    return w.reshape(X.shape[:-1]).astype(int)


def _component(system: Any, component: Any, field: Any = None) -> int:
    """The algebra component to draw: ``component`` by index or name; by default the rotation of S^1 and
    SE(2), and on other groups the component where ``field`` (``(..., k, ...)`` over the grid, component on
    axis ``-1`` after moving) is largest, so that the default picture is not of a vanishing component."""
    names = system.group.algebra_names
    coords = tuple(c.name for c in system.group.coordinates)
    if component is None:
        if len(system.group.angle_components) == 1:
            return system.group.angle_components[0]
        if field is None:
            return 0
        return int(np.argmax(np.abs(np.asarray(field)).reshape(-1, system.group.dim).max(0)))
    if isinstance(component, str):
        for seq in (names, coords):
            if component in seq:
                return seq.index(component)
        raise InputError(f"Expected `component` to be one of {list(names)} or {list(coords)}, got {component!r}.")
    c = int(component)
    if not 0 <= c < system.group.dim:
        raise InputError(f"Expected `component` in 0..{system.group.dim - 1}, got {c}.")
    return c


def _grid(system: Any, bounds: Any, loop: Any, n: int) -> tuple[np.ndarray, np.ndarray, tuple]:
    if system.sigma != 2:
        raise ShapeError(f"Expected a 2-D shape space to draw, {system.name} has {system.sigma} coordinates.")
    if bounds is None:
        if loop is not None:
            pts = loop.r(np.linspace(0.0, loop.T, 200))
            lo, hi = pts.min(0), pts.max(0)
            pad = 0.35 * np.maximum(hi - lo, 1e-3)
            bounds = (lo[0] - pad[0], hi[0] + pad[0], lo[1] - pad[1], hi[1] + pad[1])
        else:
            bounds = (-np.pi, np.pi, -np.pi, np.pi) if system.shape_angles else (-1.0, 1.0, -1.0, 1.0)
    b = V.exact_shape(bounds, "bounds", (4,))
    x, y = np.linspace(b[0], b[1], n), np.linspace(b[2], b[3], n)
    X, Y = np.meshgrid(x, y)
    return X, Y, tuple(b)


def _labels(ax: Any, system: Any) -> None:
    s = system.shape
    ax.set_xlabel(f"${_tex(s[0])}$")
    ax.set_ylabel(f"${_tex(s[1])}$")
    ax.set_aspect("equal", adjustable="box")


def _tex(sym: Any) -> str:
    import sympy as sp

    return sp.latex(sym)


def _draw_loop(ax: Any, loop: Any, color: str = "k") -> np.ndarray:
    t = np.linspace(0.0, loop.T, 400)
    pts = loop.r(t)
    ax.plot(pts[:, 0], pts[:, 1], color=color, linewidth=1.6)
    for frac in (0.0, 0.25, 0.5, 0.75):
        i = int(frac * (len(t) - 1))
        d = pts[i + 1] - pts[i]
        ax.annotate("", xy=pts[i] + d, xytext=pts[i], arrowprops=dict(arrowstyle="-|>", color=color, lw=1.4))
    ax.plot(*pts[0], "o", color=color, markersize=4)
    return pts


def _curvature_panel(
    ax: Any,
    system: Any,
    X: np.ndarray,
    Y: np.ndarray,
    B: np.ndarray,
    b: tuple,
    c: int,
    loop: Any,
    shade: bool,
    what: str,
    value: float | None,
) -> None:
    """Heat map of ``B`` (diverging, centred on 0), the loop, and the region it encloses hatched by its
    winding number (``//`` counterclockwise, ``\\\\`` clockwise, outlined, with a legend) and annotated with
    ``value``, the exact :math:`-\\iint w B` (Stokes, from the loop: not a sum over the grid), which is the phase
    only for abelian components (S^1, the rotation of SE(2))."""
    from matplotlib.patches import Patch

    vmax = float(np.abs(B).max()) or 1.0
    # purple-orange for the curvature, so the hatching of the enclosed region reads apart from it
    im = ax.pcolormesh(X, Y, B, cmap="PuOr_r", vmin=-vmax, vmax=vmax, shading="auto")
    name = system.group.algebra_names[c]
    ax.figure.colorbar(im, ax=ax, label=f"$B_{{12}}$ ({name})")
    if loop is None:
        return
    pts = _draw_loop(ax, loop)
    w = winding_numbers(pts, np.stack([X, Y], -1))
    if not (shade and np.any(w != 0)):
        return
    handles = []
    for sign, hatch, color, text in ((1, "//", "tab:red", "counterclockwise"), (-1, "\\\\", "tab:blue", "clockwise")):
        mask = np.sign(w) == sign
        if not mask.any():
            continue
        ax.contourf(X, Y, mask.astype(float), levels=[0.5, 1.5], colors="none", hatches=[hatch])
        ax.contour(X, Y, mask.astype(float), levels=[0.5], colors=color, linewidths=1.0)
        wins = sorted(set(w[mask].tolist()), key=abs)
        handles.append(
            Patch(
                facecolor="none",
                edgecolor=color,
                hatch=hatch,
                label=f"enclosed {text} (winding {', '.join(f'{k:+d}' for k in wins)})",
            )
        )
    exact = system.group.abelian or c in system.group.angle_components
    note = what if exact else "a phase only to leading order (non-abelian)"
    ax.legend(handles=handles, loc="upper right", fontsize=7, framealpha=0.85)
    if value is None:
        return
    ax.text(
        0.02,
        0.02,
        f"$-\\iint w\\,B =$ {value:.6g}\n({note})",
        transform=ax.transAxes,
        fontsize=8,
        bbox=dict(facecolor="white", alpha=0.85, lw=0),
    )


def _numeric(system: Any) -> Any:
    """The numeric reduction behind ``system`` (a Lagrangian system on G x S, its ReducedNumeric, or an analysis
    holding one as ``model``)."""
    from ..reduction import reduced_numeric

    return system.model if hasattr(system, "model") else reduced_numeric(system)


def _connection_tex(model: Any) -> str:
    return r"\mathcal{A}^{nh}" if model.c else "A_{loc}"


def connection_field(
    system: Any, *, component: Any = None, loop: Any = None, bounds: Any = None, n: int = 21, ax: Any = None
) -> Any:
    """The row ``component`` of :math:`-\\mathcal A(r)` (the mechanical connection, or the nonholonomic one for
    a system with constraints) as a vector field on a 2-D shape space.

    ``system``: a Lagrangian system on G x S, its :class:`~geomech.reduction.ReducedNumeric`, or a GaitAnalysis
    (its loop is drawn unless another is given). Following the convention of gait design, the arrows are the
    body velocity (in that component) a unit shape velocity along each axis would produce, so a loop that runs
    along the arrows gains :math:`-\\oint\\mathcal A` in it. ``component`` is an index or a name (``"theta"``,
    ``"x"``, ``"omega"``...); default the rotation. ``loop`` (a :class:`~geomech.systems.Gait`) is drawn on top.
    """
    import matplotlib.pyplot as plt

    if loop is None and hasattr(system, "loop"):
        loop = system.loop
    model = _numeric(system)
    X, Y, _ = _grid(model, bounds, loop, n)
    A_all = model.connection(np.stack([X, Y], -1))
    c = _component(model, component, np.moveaxis(A_all, -2, -1))
    A = A_all[..., c, :]
    if ax is None:
        _, ax = plt.subplots(figsize=(5.2, 4.8))
    mag = np.hypot(A[..., 0], A[..., 1])
    name = model.group.algebra_names[c]
    tex = _connection_tex(model)
    # a component zero in exact arithmetic comes out at round-off of the others: below that it is drawn as zero
    if mag.max() > 1e-12 * max(1.0, float(np.abs(A_all).max())):
        q = ax.quiver(X, Y, -A[..., 0], -A[..., 1], mag, cmap="viridis", pivot="mid")
        ax.figure.colorbar(q, ax=ax, label=f"$|{tex}|$ ({name})")
    else:
        # a zero field has no arrows to scale (matplotlib would divide by zero)
        ax.text(0.5, 0.92, f"the {name} component vanishes here", ha="center", transform=ax.transAxes)
    if loop is not None:
        _draw_loop(ax, loop)
    _labels(ax, model)
    ax.set_title(f"{model.name}:\n$-{tex}$, {name} component", fontsize=10)
    return ax


def curvature_map(
    system: Any,
    *,
    component: Any = None,
    loop: Any = None,
    bounds: Any = None,
    n: int = 121,
    ax: Any = None,
    shade: bool = True,
) -> Any:
    """The curvature :math:`B_{12}` (component ``component``) of the mechanical or nonholonomic connection as a
    heat map on a 2-D shape space, with the gait ``loop`` drawn and the region it encloses hatched by its signed
    winding number (``//`` and a red outline counterclockwise, ``\\\\`` and a blue outline clockwise, with a
    legend), annotated with :math:`-\\iint w B`: the geometric phase (without constraints) or the turn of the
    connection term alone (with constraints) for the abelian components. By default the rotation component
    (S^1, SE(2)), else the component of largest curvature. ``system`` as for :func:`connection_field`."""
    import matplotlib.pyplot as plt

    if loop is None and hasattr(system, "loop"):
        loop = system.loop
    model = _numeric(system)
    X, Y, b = _grid(model, bounds, loop, n)
    B_all = model.curvature_2d(np.stack([X, Y], -1))
    c = _component(model, component, B_all)
    if ax is None:
        _, ax = plt.subplots(figsize=(5.6, 4.8))
    what = "the connection-alone turn" if model.c else "the geometric phase"
    value = None
    if loop is not None:
        from ..analysis.phases import curvature_integral

        try:  # exact (Stokes over the cone of the loop); none for a loop winding around an angle coordinate
            value = -float(curvature_integral(model, loop)[c])
        except InputError:
            value = None
    _curvature_panel(ax, model, X, Y, B_all[..., c], b, c, loop, shade, what, value)
    _labels(ax, model)
    name = model.group.algebra_names[c]
    ax.set_title(f"{model.name}:\ncurvature of ${_connection_tex(model)}$, {name} component", fontsize=10)
    return ax


def phase_split(system: Any, loop: Any, mu: Any = 0.0, *, g0: Any = None, ax: Any = None) -> Any:
    """Theorem 2.2 over time: the geometric part :math:`-\\int_0^t A\\,dr`, the dynamic part
    :math:`\\mu\\int_0^t \\mathbb I^{-1}` and their sum (:func:`~geomech.analysis.phase_history`), with the angle
    reconstructed on the group drawn over the sum and the three values at T (:func:`~geomech.analysis.phases`)
    marked and written in the legend: the figure shows the split the text reports."""
    import matplotlib.pyplot as plt

    from ..analysis.phases import phase_history, phases, reconstruct

    split = phases(system, loop, mu, g0=g0)
    hist = phase_history(system, loop, mu, g0=g0)
    t = hist["t"]
    rec = reconstruct(system, loop, mu, g0=g0, t_eval=t)
    c = [s.name for s in system.group.coordinates].index(split.component)
    angle = rec.path.g[:, c] - rec.path.g[0, c]
    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.2))
    ax.plot(t, hist["geometric"], color="C0", label=f"geometric $-\\oint A$ = {split.geometric:.6g}")
    ax.plot(t, hist["dynamic"], color="C1", label=f"dynamic $\\mu\\int \\mathbb{{I}}^{{-1}}$ = {split.dynamic:.6g}")
    ax.plot(t, hist["total"], color="k", lw=2.2, alpha=0.45, label=f"total = {split.total:.6g}")
    ax.plot(t, angle, color="k", ls="--", lw=1.0, label="reconstructed on the group")
    T = loop.T
    ax.plot([T, T, T], [split.geometric, split.dynamic, split.total], "o", color="k", ms=3)
    ax.axhline(0.0, color="0.8", lw=0.8)
    ax.set_xlabel("$t$")
    ax.set_ylabel(f"${_tex(system.group.coordinates[c])}(t) - {_tex(system.group.coordinates[c])}(0)$")
    ax.legend(fontsize=8, loc="best")
    ax.set_title(f"{system.name}: geometric and dynamic phase (eq. 2.3)", fontsize=10)
    return ax


def _planar_figsize(xy: np.ndarray, width: float = 7.0) -> tuple[float, float]:
    """A figure whose height follows the path's extent at equal aspect (a long, flat path gets a wide, low
    figure, not a square one with two empty bands), within limits that keep the title and labels readable."""
    dx, dy = (float(v) for v in np.ptp(xy, axis=0))
    ratio = (dy + 0.15 * max(dx, dy)) / (dx + 0.15 * max(dx, dy)) if max(dx, dy) > 0 else 1.0
    return width, float(np.clip(width * ratio + 1.2, 3.0, 6.5))


def group_path(reconstruction: Any, *, ax: Any = None, arrows: int = 12) -> Any:
    """The reconstructed path in the group: for SE(2) the position with the heading drawn along it, for any
    other group its chart coordinates against time (angles unwrapped: S^1; SO(3): 3-1-3 Euler angles)."""
    import matplotlib.pyplot as plt

    path = getattr(reconstruction, "path", reconstruction)
    G = path.system.group
    planar = isinstance(G.numeric, SE2)
    xy = path.g[:, :2]
    if ax is None:
        _, ax = plt.subplots(figsize=_planar_figsize(xy) if planar else (5.6, 4.4), layout="constrained")
    if planar and float(np.ptp(xy, axis=0).max()) <= 1e-9 * max(1.0, float(np.abs(xy).max())):
        # the position does not move (centre-of-mass frame, zero linear momentum): show the rotation
        ax.plot(path.t, path.g[:, 2], color="C0")
        ax.set_xlabel("$t$")
        ax.set_ylabel(r"$\theta$ (unwrapped)")
        ax.set_title(
            f"SE(2), position fixed at ({xy[0, 0]:.3g}, {xy[0, 1]:.3g}): net rotation "
            f"{path.g[-1, 2] - path.g[0, 2]:.4g} rad"
        )
    elif planar:
        from matplotlib.collections import LineCollection

        th = path.g[:, 2]
        ax.plot(xy[:, 0], xy[:, 1], color="0.7", linewidth=0.8, zorder=1)
        # coloured by time, so that a path that doubles back on itself (a board rocking to and fro) can be followed
        strokes = LineCollection(list(np.stack([xy[:-1], xy[1:]], axis=1)), cmap="viridis", linewidths=1.8, zorder=2)
        strokes.set_array(np.asarray(path.t[:-1], dtype=float))
        ax.add_collection(strokes)
        ax.figure.colorbar(strokes, ax=ax, label="$t$", fraction=0.04, pad=0.02)
        idx = np.linspace(0, len(th) - 1, max(arrows, 2)).astype(int)
        span = float(np.ptp(xy, axis=0).max()) or 1.0
        ax.quiver(
            xy[idx, 0],
            xy[idx, 1],
            np.cos(th[idx]),
            np.sin(th[idx]),
            color="C3",
            angles="xy",
            scale_units="xy",
            scale=8.0 / span,
            width=0.004,
        )
        ax.plot(*xy[0], "ko", markersize=4)
        ax.set_xlabel("$x$")
        ax.set_ylabel("$y$")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"path in SE(2): net rotation {th[-1] - th[0]:.4g} rad (unwrapped)")
    else:  # any other group: its chart coordinates against time
        q = path.g
        for i, c in enumerate(G.coordinates):
            ax.plot(path.t, q[:, i], label=f"${sp.latex(c)}$")
        ax.legend(loc="best", fontsize=8)
        ax.set_xlabel("$t$")
        unwrapped = set(G.angle_components)
        wrapped = any(i not in unwrapped for i in G.angles)
        ax.set_ylabel(
            "group coordinates, angles " + ("wrapped" if wrapped else "unwrapped") if G.angles else "group coordinates"
        )
        net = f": net {q[-1, 0] - q[0, 0]:.4g}" if q.shape[1] == 1 else ""
        ax.set_title(f"path in {G.name}{net}")
    return ax


def momentum_solid_angle(phase: Any, *, ax: Any = None, n: int = 400) -> Any:
    """The free rigid body's momentum curve on its sphere with the enclosed cap shaded, from a
    :class:`~geomech.analysis.RigidBodyPhase`; the title gives the solid angle and the phases."""
    import matplotlib.pyplot as plt

    from .momentum import momentum_sphere

    m = phase.momentum_curve(n)
    G = phase.momentum
    if ax is None:
        fig = plt.figure(figsize=(5.8, 5.8))
        ax = fig.add_subplot(projection="3d")
    momentum_sphere(m, ax=ax)
    body = phase.body
    Q = body.principal_axes
    pole = phase.pole_sign * Q[:, phase.axis]
    # the cap: straight lines in the tangent direction from the pole to each curve point, on the sphere
    u = m / np.linalg.norm(m, axis=1, keepdims=True)
    s = np.linspace(0.0, 1.0, 24)[:, None, None]
    ang = np.arccos(np.clip(u @ pole, -1.0, 1.0))[None, :, None]
    perp = u - (u @ pole)[:, None] * pole
    perp = perp / np.maximum(np.linalg.norm(perp, axis=1, keepdims=True), 1e-300)
    pts = G * (np.cos(s * ang) * pole + np.sin(s * ang) * perp[None])
    color = "tab:red" if phase.solid_angle > 0 else "tab:blue"
    ax.plot_surface(pts[..., 0], pts[..., 1], pts[..., 2], color=color, alpha=0.35, linewidth=0, shade=False)
    ax.set_title(
        f"$\\Lambda$ = {phase.solid_angle:.6g} sr, geometric {phase.geometric:.6g}, dynamic "
        f"{phase.dynamic:.6g}\ntotal {phase.total_wrapped:.6g} (wrapped to (-$\\pi$, $\\pi$])",
        fontsize=9,
    )
    return ax
