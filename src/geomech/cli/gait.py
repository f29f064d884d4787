"""``geomech gait``: the net displacement of a periodic gait of a nonholonomic system, and its parts.

MODEL is a built-in example (``snakeboard``, ``snakeboard_bkmm``, ``roller_racer``, ...) or a model file as
``geomech simulate --model`` takes it (docs/nonholonomic.md). The gait gives each shape variable as a
formula in ``t`` (and ``T``, the period); it must be closed over the period. Prints a summary (or JSON with
``--json``); with ``--out DIR`` also writes gait.json, gait.nc (NetCDF) and the figures. Bad input (an open
loop, a loop of the wrong dimension, an unknown shape variable, a singular locked inertia) raises a
:class:`~geomech.errors.GeomechError`, which ``geomech``'s entry point prints as one line on stderr with
exit status 2.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Any

import click

from ..errors import InputError
from ._args import (
    FloatVector,
    Outputs,
    document,
    emit,
    html_option,
    model_argument,
    one_model,
    out_option,
    parse_params,
    parse_range,
    parse_shape_loop,
    study_options,
)
from ._progress import activity

__all__ = ["gait_cmd"]


def _system(model: str, params: dict[str, float]) -> Any:
    from .nonholonomic import nonholonomic_system, require_values

    system = nonholonomic_system(model, params)
    require_values(system)
    return system


def _shape_loop(system: Any, items: tuple[str, ...]) -> dict[str, str]:
    return parse_shape_loop(items, [r.name for r in system.shape], "--shape-loop", system.name)


def _named(system: Any, items: tuple[str, ...], option: str) -> dict[str, float]:
    values = parse_params(items, option)
    names = [c.name for c in system.group.coordinates]
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise InputError(f"`{option}` names {unknown}, which are not group coordinates of {system.name} ({names}).")
    return values


def _text(s: dict[str, Any]) -> str:
    def fmt(d: dict) -> str:
        return ", ".join(f"{k} {v:.10g}" for k, v in d.items())

    head = s["summary"]
    lines = [
        f"{s['system']} on {s['group']}, shape ({', '.join(s['shape'])}), T = {s['period']:g}, "
        f"{s['periods']} period(s), p0 = {s['p0']}",
        f"net displacement g(0)^-1 g(NT)          : {fmt(head['net_displacement'])}",
    ]
    for j, d in enumerate(s["displacement_per_period"]):
        lines.append(f"  period {j + 1}: g(t0)^-1 g(t0 + T)        : {fmt(d)}")
    lines += [
        f"connection term -A^nh r' alone          : {fmt(s['connection_alone'])}",
        f"momentum term I^-1 p alone              : {fmt(s['momentum_alone'])}",
    ]
    change = head["momentum_change_per_period"]
    if change and change[0]:
        lines.append(
            "momentum change per period p((j+1)T) - p(jT): "
            + "; ".join("[" + ", ".join(f"{x:.6g}" for x in d) + "]" for d in change)
        )
    else:
        lines.append("no nonholonomic momentum (S_q = 0): the connection term is the whole motion")
    lines += textwrap.wrap("note: " + s["note"], 120, subsequent_indent="  ")
    return "\n".join(lines)


def _figures(analysis: Any, out: Path) -> Outputs:
    """The figures and the data of ``--out`` (gait.json joins them when the document is emitted)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..plot.gaits import gait_momentum, gait_paths
    from ..plot.phases import connection_field, curvature_map

    outputs = Outputs(out)

    def save(ax: Any, name: str) -> None:
        outputs.figure(name, ax, dpi=120, bbox_inches="tight")

    save(gait_paths(analysis), "gait_path.png")
    save(gait_momentum(analysis), "gait_momentum.png")
    if analysis.model.sigma == 2 and not any(analysis.winding):
        for c in range(analysis.model.k):
            name = analysis.model.group.algebra_names[c]
            save(connection_field(analysis, component=c), f"connection_{name}.png")
            save(curvature_map(analysis, component=c), f"curvature_{name}.png")
        save(curvature_map(analysis), "curvature.png")  # the default component (the rotation on SE(2))
    outputs.dataset("gait.nc", analysis.to_dataset())
    plt.close("all")
    return outputs


@click.command("gait")
@model_argument("a NonholonomicSystem (docs/nonholonomic.md)")
@click.option(
    "--shape-loop",
    "shape_loop",
    multiple=True,
    metavar="NAME=EXPR",
    required=True,
    help="A shape variable as a formula in t (and T, the period), e.g. 'psi=sin(2*pi*t/T)'; one per shape variable.",
)
@click.option("--period", type=float, required=True, help="Period T of the gait.")
@click.option(
    "--periods", type=click.IntRange(1, 10**4), default=1, show_default=True, help="Number of periods to integrate."
)
@click.option(
    "--p0",
    type=FloatVector(*range(1, 65)),
    default=None,
    help="Initial nonholonomic momentum, comma-separated (default 0; basis of docs/nonholonomic.md).",
)
@click.option("--g0", "g0", multiple=True, metavar="NAME=VALUE", help="An initial group coordinate (default 0).")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE", help="A parameter value (repeatable).")
@click.option(
    "--samples", type=click.IntRange(3, 10**5), default=201, show_default=True, help="Output times per period."
)
@click.option(
    "--sweep",
    "sweeps",
    multiple=True,
    metavar="NAME=START:STOP:N",
    help="Sweep a parameter of the model or a coefficient of the --shape-loop formulas (repeatable: a grid); "
    "writes the net displacement of every gait to OUT/gait_sweep.nc, from a study resumable in OUT/gait_sweep.zarr.",
)
@study_options("gait_sweep.zarr")
@html_option("the gait as an interactive figure: the motion in the plane animated beside the shape variables (SE(2))")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@out_option("Directory for gait.json, gait.nc and the figures (path, momentum, connection, curvature).")
def gait_cmd(
    model: str | None,
    model_file: str | None,
    shape_loop: tuple,
    period: float,
    periods: int,
    p0: tuple | None,
    g0: tuple,
    params: tuple,
    samples: int,
    sweeps: tuple,
    resume: bool,
    scheduler: str | None,
    chunk: int | None,
    html: Path | None,
    as_json: bool,
    out: Path | None,
) -> None:
    """Net displacement of a periodic gait of a nonholonomic MODEL, with the connection and momentum terms.

    Integrates the momentum equation (1.2) along the gait and the reconstruction equation (1.1) on the
    group; prints g(0)^-1 g(T) per period and over all periods, the change of the nonholonomic momentum per
    period, and the displacement the connection term -A^nh r' and the momentum term I^-1 p give alone. These
    two do not add up to the net displacement on a non-abelian group, and are not a geometric/dynamic phase
    split (open for nonholonomic systems).
    """
    from ..analysis.gaits import analyse_gait

    if not (math.isfinite(period) and period > 0):
        raise InputError(f"Expected `--period` to be positive, got {period}.")
    given = parse_params(params)
    if sweeps and html is not None:
        raise InputError("`--html` animates one gait; a `--sweep` writes its grid to OUT/gait_sweep.nc instead.")
    if sweeps:
        _sweep(
            one_model(model, model_file),
            given,
            shape_loop,
            period,
            periods,
            p0,
            g0,
            sweeps,
            resume,
            scheduler,
            chunk,
            as_json,
            out,
        )
        return
    if resume or scheduler is not None or chunk is not None:
        raise InputError("`--resume`, `--scheduler` and `--chunk` run a study: give `--sweep`.")
    system = _system(one_model(model, model_file), given)
    loop = _shape_loop(system, shape_loop)
    with activity(f"gait of {system.name}: deriving and integrating"):
        analysis = analyse_gait(
            system,
            loop,
            period=period,
            periods=periods,
            p0=p0,
            g0=_named(system, g0, "--g0"),
            samples_per_period=samples,
        )
    detail = analysis.summary()
    head = {k: detail.pop(k) for k in ("net_displacement", "momentum_change_per_period")}
    doc = document("gait", head, detail)
    outputs = _figures(analysis, out) if out is not None else None
    written_too = []
    if html is not None:
        from ..plot.interactive import gait_html

        if analysis.model.group.name != "SE(2)":
            raise InputError(f"`--html` animates a planar gait; {system.name} moves on {analysis.model.group.name}.")
        gait_html(analysis, path=html)
        written_too.append(html)
    emit(doc, as_json, _text(doc), outputs, "gait", written_too)


def _sweep(
    model: str,
    given: dict[str, float],
    shape_loop: tuple,
    period: float,
    periods: int,
    p0: tuple | None,
    g0: tuple,
    sweeps: tuple,
    resume: bool,
    scheduler: str | None,
    chunk: int | None,
    as_json: bool,
    out: Path | None,
) -> None:
    """``--sweep``: the net displacement over a grid of parameters and coefficients, as a study on dask."""
    import numpy as np

    from ..analysis import GaitSweep
    from ._progress import study_progress

    if out is None:
        raise InputError("`--sweep` writes its study to `--out DIR`: give it.")
    if g0:
        raise InputError("`--g0` does not change a displacement g(0)^-1 g(nT); a sweep starts at the identity.")
    axes: dict[str, Any] = {}
    for spec in sweeps:
        name, values = parse_range(spec, "'--sweep'", max_n=100_000)
        if name in axes:
            raise InputError(f"`--sweep` gives {name!r} twice.")
        axes[name] = values
    from .nonholonomic import nonholonomic_system, require_values

    # a swept parameter of the model needs no --param: its first value stands in while the model is built
    system = nonholonomic_system(model, given)
    swept_own = {q.name for q in system.parameter_symbols} & set(axes)
    stand_in = {k: float(axes[k][0]) for k in swept_own if k not in given}
    if stand_in:
        system = nonholonomic_system(model, {**given, **stand_in})
    require_values(system)
    loop = _shape_loop(system, shape_loop)
    fixed = {k: v for k, v in given.items() if k not in axes}
    study = GaitSweep(
        system,
        {k: str(e) for k, e in loop.items()},
        period=period,
        periods=periods,
        p0=p0,
        parameters={**{q.name: v for q, v in system.parameter_values({}).items() if q.name not in swept_own}, **fixed},
    )
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with study_progress("gait sweep") as progress:
        ds = study.run(
            out=out / "gait_sweep.zarr",
            resume=resume,
            scheduler=scheduler,
            chunk=1024 if chunk is None else chunk,
            progress=progress,
            **axes,
        ).load()
    net = ds["net_displacement"]
    members = int(np.prod([len(v) for v in axes.values()]))
    extremes = {}
    for c in net["coordinate"].values.tolist():
        v = net.sel(coordinate=c)
        if bool(np.isfinite(v.values).any()):
            where = np.unravel_index(int(np.nanargmax(np.abs(v.values))), v.shape)
            extremes[c] = {
                "value": float(v.values[where]),
                **{d: float(ds[d].values[i]) for d, i in zip(v.dims, where)},
            }
    summary = {
        "members": members,
        "failed": int((ds["failed"].values != 0).sum() + (ds["status"].values != 0).sum()),
        "largest_net_displacement": extremes,
    }
    detail = {
        "system": system.name,
        "loop": study.loop,
        "period": period,
        "periods": periods,
        "sweep": {k: {"start": float(v[0]), "stop": float(v[-1]), "n": len(v)} for k, v in axes.items()},
    }
    outputs = Outputs(out)
    outputs.dataset("gait_sweep.nc", ds)
    doc = document("gait sweep", summary, detail)
    text = f"gait sweep of {system.name}: {members} gaits, {summary['failed']} failed\nlargest |net displacement|: " + (
        ", ".join(f"{c} {e['value']:.6g}" for c, e in extremes.items()) or "none"
    )
    emit(doc, as_json, text, outputs, "gait_sweep")
