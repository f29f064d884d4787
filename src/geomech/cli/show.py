"""``geomech show FILE.nc``: what a NetCDF file geomech wrote holds, read back (and re-plotted with --out)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import numpy as np

from ..errors import InputError
from ._args import Outputs, document, emit, html_option, out_option

__all__ = ["show_cmd"]


def _attr(ds: Any, name: str) -> Any:
    value = ds.attrs.get(name)
    if isinstance(value, str) and value[:1] in "{[":
        try:
            return json.loads(value)
        except ValueError:
            return value
    return value.item() if isinstance(value, np.generic) else value


def _summary(ds: Any, path: Path) -> dict[str, Any]:
    variables = {}
    for name, var in ds.data_vars.items():
        values = np.asarray(var.values, dtype=float) if var.dtype.kind in "fiu" else None
        entry: dict[str, Any] = {"dims": list(var.dims), "shape": list(var.shape)}
        if var.attrs.get("long_name"):
            entry["long_name"] = str(var.attrs["long_name"])
        if var.attrs.get("units"):
            entry["units"] = str(var.attrs["units"])
        if values is not None and values.size:
            finite = values[np.isfinite(values)]
            if finite.size:
                entry["min"], entry["max"] = float(finite.min()), float(finite.max())
            if "t" in var.dims and var.sizes["t"] > 0:
                entry["final"] = np.asarray(var.isel(t=-1).values, dtype=float).tolist()
        variables[name] = entry
    return {
        "file": str(path),
        "attributes": {k: _attr(ds, k) for k in ds.attrs},
        "dims": {k: int(v) for k, v in ds.sizes.items()},
        "variables": variables,
    }


@click.command("show")
@click.argument("path", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@out_option("Directory for show.json and a figure of every variable over time (show.png).")
@html_option("every variable over time as an interactive figure, the values on hover")
def show_cmd(path: str, as_json: bool, out: Path | None, html: Path | None) -> None:
    """Summarise a NetCDF file geomech wrote (a trajectory, a gait, a stability map): the command and
    parameters it records, its dimensions, and each variable with its range and final value."""
    import xarray as xr

    p = Path(path)
    if not p.is_file():
        raise InputError(f"{path!r} does not exist; give a .nc file that geomech wrote (--out of a command).")
    try:
        ds = xr.open_dataset(p).load()
    except (OSError, ValueError) as exc:
        raise InputError(f"{path!r} is not a NetCDF file xarray can read: {exc}") from exc
    outputs = None
    with ds:
        summary = _summary(ds, p)
        series = _series(ds, p.name) if out is not None or html is not None else []
        if out is not None:
            outputs = Outputs(out)
            outputs.figure("show.png", _plot(ds, p.name, series), dpi=110)
        if html is not None:
            from ..plot.interactive import series_html

            t = np.asarray(ds["t"].values, dtype=float)
            series_html(t, {n: np.asarray(ds[n].values, dtype=float) for n in series}, title=p.name, path=html)
    a = summary["attributes"]
    head = {"file": summary.pop("file"), **{k: a.get(k) for k in ("system", "method", "status")}}
    doc = document("show", head, summary)
    lines = [f"{p.name}: " + ", ".join(f"{k} {v}" for k, v in summary["dims"].items())]
    for key in ("command", "system", "method", "status", "geomech_version"):
        if key in a:
            lines.append(f"  {key:<16} {a[key]}")
    if isinstance(a.get("parameters"), dict) and a["parameters"]:
        lines.append("  parameters       " + ", ".join(f"{k} = {v:g}" for k, v in a["parameters"].items()))
    width = max((len(n) for n in summary["variables"]), default=4)
    for name, v in summary["variables"].items():
        rng = f"[{v['min']:.6g}, {v['max']:.6g}]" if "min" in v else ""
        final = v.get("final")
        fin = "" if final is None else f" final {np.round(np.atleast_1d(final), 6).tolist()}"
        lines.append(f"  {name:<{width}} ({', '.join(v['dims'])}) {rng}{fin}")
    emit(doc, as_json, "\n".join(lines), outputs, "show", [html] if html is not None else [])


def _series(ds: Any, title: str) -> list[str]:
    """The numeric variables over time ``t`` (refused, before anything is drawn, when there are none)."""
    series = [n for n, v in ds.data_vars.items() if v.dims and v.dims[0] == "t" and v.dtype.kind in "fiu"]
    if "t" not in ds.coords or not series:
        raise InputError(f"{title} has no variable over time t to draw.")
    return series


def _plot(ds: Any, title: str, series: list[str]) -> Any:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(series), 1, figsize=(6.4, 1.6 * len(series) + 0.6), sharex=True, squeeze=False)
    t = np.asarray(ds["t"].values, dtype=float)
    for ax, name in zip(axes[:, 0], series):
        y = np.asarray(ds[name].values, dtype=float).reshape(len(t), -1)
        ax.plot(t, y[:, :9], lw=1.0)
        ax.set_ylabel(name, fontsize=8)
    axes[-1, 0].set_xlabel("t")
    fig.suptitle(title, fontsize=10)
    return fig
