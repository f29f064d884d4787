"""Interactive figures as self-contained HTML files (plotly, with plotly.js embedded: no network to open them).

- :func:`momentum_sphere_html`: trajectories on the momentum sphere with the level curves of H and the poles of
  the Serret-Andoyer charts, to turn and zoom;
- :func:`stability_map_html`: a stability map with the verdicts and the numbers behind them on hover;
- :func:`gait_html`: a planar gait animated, the body's heading drawn along its path, beside its shape variables.

Each returns the plotly figure and, given ``path``, writes it atomically (complete or not at all).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .. import _validate as V
from .._storage import write_atomic
from ..errors import InputError, ShapeError
from .momentum import _sphere_level_curves

__all__ = [
    "gait_html",
    "momentum_sphere_html",
    "reconstruction_html",
    "series_html",
    "stability_map_html",
    "write_html",
]

_VERDICT_COLOURS = {"no equilibrium": "#bdbdbd", "unstable": "#d73027", "inconclusive": "#fdae61", "stable": "#1a9850"}


def _go() -> Any:
    try:
        import plotly.graph_objects as go
    except ImportError as exc:  # pragma: no cover - plotly is a dependency
        raise InputError("Interactive figures need plotly: pip install plotly.") from exc
    return go


def write_html(fig: Any, path: str | Path) -> Path:
    """Write ``fig`` as one self-contained HTML file (plotly.js embedded), atomically."""
    html = fig.to_html(include_plotlyjs=True, full_html=True, config={"displaylogo": False, "responsive": True})
    return write_atomic(Path(path), html, binary=False)


def momentum_sphere_html(
    m: Any,
    *,
    hamiltonian: Any = None,
    labels: Any = None,
    title: str = "Body angular momentum on the sphere |m| = G",
    n_levels: int = 16,
    path: str | Path | None = None,
) -> Any:
    """Trajectories ``m`` (``(n, 3)`` or a list of them, on one sphere) on the momentum sphere, rotatable.

    ``hamiltonian``: a vectorised ``H(m)`` whose level curves on the sphere (the trajectories of Euler's equation)
    are drawn in grey; ``labels``: one name per trajectory. The poles of the three Serret-Andoyer charts
    (:math:`\\pm G e_k`, where the chart about axis k is singular) are marked.
    """
    go = _go()
    curves = [m] if isinstance(m, np.ndarray) and np.ndim(m) == 2 else list(m)
    curves = [V.trailing_shape(c, "m", (3,)) for c in curves]
    if not curves or any(c.ndim != 2 for c in curves):
        raise ShapeError("Expected `m` to be an (n, 3) trajectory or a list of them.")
    G = float(np.linalg.norm(curves[0][0]))
    if G == 0:
        raise InputError("Expected a nonzero momentum: the sphere |m| = 0 is a point.")
    names = list(labels) if labels is not None else [f"trajectory {i + 1}" for i in range(len(curves))]
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 61), np.linspace(0, np.pi, 31))
    fig = go.Figure()
    fig.add_trace(
        go.Surface(
            x=0.995 * G * np.cos(u) * np.sin(v),
            y=0.995 * G * np.sin(u) * np.sin(v),
            z=0.995 * G * np.cos(v),
            showscale=False,
            opacity=0.35,
            colorscale=[[0, "#f0f0f0"], [1, "#f0f0f0"]],
            hoverinfo="skip",
            name="sphere",
        )
    )
    if hamiltonian is not None:
        xs, ys, zs = [], [], []
        for line in _sphere_level_curves(hamiltonian, G, n_levels):
            xs += [*line[:, 0], None]
            ys += [*line[:, 1], None]
            zs += [*line[:, 2], None]
        fig.add_trace(
            go.Scatter3d(
                x=xs, y=ys, z=zs, mode="lines", line={"color": "#8c8c8c", "width": 2}, name="level curves of H"
            )
        )
    for c, name in zip(curves, names):
        fig.add_trace(
            go.Scatter3d(
                x=c[:, 0],
                y=c[:, 1],
                z=c[:, 2],
                mode="lines",
                line={"width": 6},
                name=str(name),
                hovertemplate="m = (%{x:.4f}, %{y:.4f}, %{z:.4f})<extra>" + str(name) + "</extra>",
            )
        )
    poles = np.concatenate([G * np.eye(3), -G * np.eye(3)])
    fig.add_trace(
        go.Scatter3d(
            x=poles[:, 0],
            y=poles[:, 1],
            z=poles[:, 2],
            mode="markers+text",
            marker={"size": 4, "color": "black"},
            text=["+m1", "+m2", "+m3", "-m1", "-m2", "-m3"],
            name="chart poles (+-G e_k)",
            hovertemplate="pole of the chart about this axis<extra></extra>",
        )
    )
    fig.update_layout(
        title=title,
        scene={"xaxis_title": "m1", "yaxis_title": "m2", "zaxis_title": "m3", "aspectmode": "data"},
        legend={"x": 0.0, "y": 1.0},
        margin={"l": 0, "r": 0, "t": 50, "b": 0},
    )
    if path is not None:
        write_html(fig, path)
    return fig


def stability_map_html(ds: Any, *, title: str | None = None, path: str | Path | None = None) -> Any:
    """A stability map (:func:`geomech.analysis.stability_map`) as a heat map of the verdicts, with each cell's
    verdicts by the three methods, its equilibrium, growth rate and energy-Casimir determinant on hover."""
    go = _go()
    if "verdict" not in ds:
        raise InputError("Expected a stability map (a Dataset with a `verdict` variable).")
    yname, xname = ds["verdict"].dims
    xs, ys = ds[xname].values, ds[yname].values
    codes = ds["verdict"].values.astype(float)
    meanings = str(ds["verdict"].attrs.get("flag_meanings", "")).split()
    values = [int(v) for v in np.atleast_1d(ds["verdict"].attrs.get("flag_values", []))]
    name_of = dict(zip(values, meanings))
    order = sorted(values)
    z = np.full(codes.shape, np.nan)
    for i, code in enumerate(order):
        z[codes == code] = i
    hover = np.empty(codes.shape, dtype=object)
    parts = {k: ds[k].values for k in ("lagrange_dirichlet", "energy_casimir", "linearisation") if k in ds}
    growth = ds["growth_rate"].values if "growth_rate" in ds else None
    det = ds["ec_determinant"].values if "ec_determinant" in ds else None
    mvals = ds["m"].values if "m" in ds else None
    for j in range(codes.shape[0]):
        for i in range(codes.shape[1]):
            lines = [f"{xname} = {xs[i]:.4g}, {yname} = {ys[j]:.4g}", f"verdict: {name_of.get(int(codes[j, i]), '?')}"]
            lines += [f"{k.replace('_', ' ')}: {name_of.get(int(v[j, i]), '?')}" for k, v in parts.items()]
            if mvals is not None and np.all(np.isfinite(mvals[j, i])):
                lines.append("m = (" + ", ".join(f"{c:.4f}" for c in mvals[j, i]) + ")")
            if growth is not None and np.isfinite(growth[j, i]):
                lines.append(f"growth rate: {growth[j, i]:.3g}")
            if det is not None and np.isfinite(det[j, i]):
                lines.append(f"EC determinant: {det[j, i]:.3g}")
            hover[j, i] = "<br>".join(lines)
    n = max(len(order), 1)
    colours = [_VERDICT_COLOURS.get(name_of.get(c, ""), "#7570b3") for c in order] or ["#bdbdbd"]
    scale = []
    for k, colour in enumerate(colours):
        scale += [[k / n, colour], [(k + 1) / n, colour]]
    fig = go.Figure(
        go.Heatmap(
            x=xs,
            y=ys,
            z=z,
            zmin=-0.5,
            zmax=n - 0.5,
            colorscale=scale,
            text=hover,
            hoverinfo="text",
            colorbar={
                "tickvals": list(range(len(order))),
                "ticktext": [name_of.get(c, str(c)).replace("_", " ") for c in order],
                "title": "verdict",
            },
        )
    )
    fig.update_layout(
        title=title or ds.attrs.get("description") or "stability map",
        xaxis_title=xname,
        yaxis_title=yname,
    )
    if path is not None:
        write_html(fig, path)
    return fig


def _planar_motion(motion: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str], str]:
    """``(t, g, r, shape names, default title)`` of a gait analysis or a simulated motion on SE(2)."""
    if isinstance(motion, _Motion):
        return motion.t, motion.g, motion.r, motion.shape_names, motion.title
    if hasattr(motion, "model") and hasattr(motion, "periods"):  # a GaitAnalysis
        group, g = motion.model.group.name, np.asarray(motion.path.g, dtype=float)
        t, r = np.asarray(motion.t), np.asarray(motion.r)
        title = f"{motion.system.name}: {motion.periods} period(s) of the gait"
    elif getattr(motion, "layout", None) == "qv" and np.ndim(motion.states) == 2:  # one simulated trajectory
        group, g = motion.system.group.name, np.asarray(motion.g, dtype=float)
        t, r = np.asarray(motion.t), np.asarray(motion.r)
        title = f"{motion.system.name}: 0 <= t <= {t[-1]:g}"
    else:
        group, g, t, r, title = "", np.empty((0, 0)), np.empty(0), np.empty((0, 0)), ""
    if group != "SE(2)" or g.ndim != 2 or g.shape[1] != 3:
        raise InputError(
            "gait_html draws a planar motion: a GaitAnalysis, or one simulated trajectory (a Solution of layout "
            "'qv'), of a system on SE(2)."
        )
    return t, g, r, [s.name for s in motion.system.shape], title


class _Motion:
    """A motion on SE(2) given by its arrays (a reconstruction along a shape loop)."""

    def __init__(self, t: np.ndarray, g: np.ndarray, r: np.ndarray, shape_names: list[str], title: str):
        self.t, self.g, self.r, self.shape_names, self.title = t, g, r, shape_names, title


def reconstruction_html(
    system: Any, reconstruction: Any, *, title: str | None = None, path: str | Path | None = None
) -> Any:
    """The motion on the group along a shape path (a :class:`~geomech.analysis.Reconstruction` of ``system``, a
    Lagrangian system on G x S): on SE(2), with the position moving, the path in the plane animated as by
    :func:`gait_html`; on any other group (or SE(2) turning in place), the group's chart coordinates and the shape
    variables against time, side by side, with their values on hover (angles unwrapped)."""
    go = _go()
    from plotly.subplots import make_subplots

    G = system.group
    t, g, r = np.asarray(reconstruction.t), np.asarray(reconstruction.path.g), np.asarray(reconstruction.r)
    shapes = [s.name for s in system.shape]
    heading = title or f"{system.name}: the motion on {G.name} along the shape loop"
    moves = G.name == "SE(2)" and float(np.ptp(g[:, :2], axis=0).max()) > 1e-9 * max(1.0, float(np.abs(g).max()))
    if moves:
        return gait_html(_Motion(t, g, r, shapes, heading), path=path)
    fig = make_subplots(rows=1, cols=2, subplot_titles=(f"group coordinates ({G.name})", "shape variables"))
    for i, c in enumerate(G.coordinates):
        fig.add_trace(go.Scatter(x=t, y=g[:, i], mode="lines", name=str(c)), 1, 1)
    for k, name in enumerate(shapes):
        fig.add_trace(go.Scatter(x=t, y=r[:, k], mode="lines", name=name, line={"dash": "dot"}), 1, 2)
    fig.update_xaxes(title_text="t")
    fig.update_layout(title=heading, hovermode="x unified", legend={"orientation": "h", "y": -0.15})
    if path is not None:
        write_html(fig, path)
    return fig


def series_html(t: Any, variables: Any, *, title: str = "", components: int = 9, path: str | Path | None = None) -> Any:
    """Quantities over time, one panel each with a shared time axis and the values on hover: ``variables`` maps a
    name to an array whose first axis is ``t`` (a vector quantity shows its first ``components`` components)."""
    go = _go()
    from plotly.subplots import make_subplots

    t = np.asarray(t, dtype=float)
    names = list(variables)
    if t.ndim != 1 or not names:
        raise InputError("series_html draws quantities over a 1-D time axis: give t and at least one variable.")
    fig = make_subplots(rows=len(names), cols=1, shared_xaxes=True, subplot_titles=names, vertical_spacing=0.04)
    for row, name in enumerate(names, start=1):
        y = np.asarray(variables[name], dtype=float).reshape(len(t), -1)
        for j in range(min(y.shape[1], components)):
            label = name if y.shape[1] == 1 else f"{name}[{j}]"
            fig.add_trace(go.Scatter(x=t, y=y[:, j], mode="lines", name=label), row, 1)
    fig.update_xaxes(title_text="t", row=len(names), col=1)
    fig.update_layout(title=title, height=220 * len(names) + 120, hovermode="x unified", showlegend=False)
    if path is not None:
        write_html(fig, path)
    return fig


def gait_html(analysis: Any, *, frames: int = 120, title: str | None = None, path: str | Path | None = None) -> Any:
    """A planar gait animated: the path in the plane at equal aspect with the body's position and heading moving
    along it, and the shape variables against time with a marker at the same instant (play, pause and a time
    slider). ``analysis``: a :class:`~geomech.analysis.GaitAnalysis` on SE(2), or one trajectory of a Lagrangian
    system on SE(2) x S simulated by :func:`~geomech.solve` (a :class:`~geomech.Solution` of layout ``"qv"``)."""
    go = _go()
    from plotly.subplots import make_subplots

    t, g, r, names, default_title = _planar_motion(analysis)
    span = float(np.ptp(g[:, :2], axis=0).max()) or 1.0
    arrow = 0.08 * span
    idx = np.unique(np.linspace(0, len(t) - 1, max(2, int(frames))).astype(int))
    fig = make_subplots(
        rows=1, cols=2, column_widths=[0.6, 0.4], subplot_titles=("path in the plane", "shape variables")
    )
    fig.add_trace(go.Scatter(x=g[:, 0], y=g[:, 1], mode="lines", name="path", line={"color": "#4c72b0"}), 1, 1)
    for k, name in enumerate(names):
        fig.add_trace(go.Scatter(x=t, y=r[:, k], mode="lines", name=name), 1, 2)

    def body(i: int) -> tuple[Any, Any]:
        x, y, th = g[i]
        return (
            go.Scatter(
                x=[x, x + arrow * np.cos(th)],
                y=[y, y + arrow * np.sin(th)],
                mode="lines+markers",
                marker={"size": [10, 4], "color": "#c44e52"},
                line={"color": "#c44e52", "width": 3},
                name="body (heading)",
            ),
            go.Scatter(
                x=[t[i]] * len(names),
                y=list(r[i]),
                mode="markers",
                marker={"size": 9, "color": "#c44e52"},
                name="now",
            ),
        )

    first = body(int(idx[0]))
    fig.add_trace(first[0], 1, 1)
    fig.add_trace(first[1], 1, 2)
    moving = [len(fig.data) - 2, len(fig.data) - 1]
    fig.frames = [go.Frame(data=list(body(int(i))), traces=moving, name=f"{t[i]:.3f}") for i in idx]
    pad = 0.15 * span
    fig.update_xaxes(range=[g[:, 0].min() - pad, g[:, 0].max() + pad], title_text="x", row=1, col=1)
    fig.update_yaxes(range=[g[:, 1].min() - pad, g[:, 1].max() + pad], title_text="y", scaleanchor="x", row=1, col=1)
    fig.update_xaxes(title_text="t", row=1, col=2)
    fig.update_layout(
        title=title or default_title,
        updatemenus=[
            {
                "type": "buttons",
                "x": 0.0,
                "y": -0.12,
                "buttons": [
                    {
                        "label": "play",
                        "method": "animate",
                        "args": [None, {"frame": {"duration": 40, "redraw": False}, "fromcurrent": True}],
                    },
                    {
                        "label": "pause",
                        "method": "animate",
                        "args": [[None], {"frame": {"duration": 0}, "mode": "immediate"}],
                    },
                ],
            }
        ],
        sliders=[
            {
                "currentvalue": {"prefix": "t = "},
                "y": -0.05,
                "steps": [
                    {"label": f.name, "method": "animate", "args": [[f.name], {"mode": "immediate"}]}
                    for f in fig.frames
                ],
            }
        ],
        legend={"orientation": "h", "y": 1.12},
    )
    if path is not None:
        write_html(fig, path)
    return fig
