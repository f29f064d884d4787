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
    model_argument,
    one_model,
    out_option,
    parse_params,
    parse_shape_loop,
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
    system = _system(one_model(model, model_file), parse_params(params))
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
    emit(doc, as_json, _text(doc), outputs, "gait")
