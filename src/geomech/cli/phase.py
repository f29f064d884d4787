"""``geomech phase``: geometric and dynamic phases (section 2 of the nonholonomic paper).

Subcommands: ``two-bodies`` (the pinned planar bodies of section 2.2), ``rigid-body`` (Montgomery's
formula for the free rigid body) and ``loop`` (a shape loop for a built-in holonomic model). Each prints
a readable summary, or JSON with ``--json``; ``--out DIR`` writes the summary and figures. Bad input
(a loop that is not closed, a loop of the wrong dimension, a singular locked inertia) raises a
:class:`~geomech.errors.GeomechError`, which ``geomech``'s entry point prints as one line on stderr with
exit status 2.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click
import numpy as np

from ..errors import InputError
from ._args import (
    FloatVector,
    Outputs,
    document,
    emit,
    html_option,
    is_model_file,
    model_argument,
    one_model,
    out_option,
    parse_params,
    parse_shape_loop,
)
from ._progress import activity

__all__ = ["phase"]

#: The parts of a phase every phase command reports (in its summary's ``phase``).
_PHASE = ("geometric", "dynamic", "total", "total_wrapped")

_WRAP_NOTE = (
    "geometric, dynamic and total are unwrapped real numbers; '*_wrapped' values are reduced to "
    "(-pi, pi]; an angle read off an attitude matrix is defined only modulo 2 pi and is wrapped"
)


def _save(outputs: Outputs, ax: Any, name: str) -> None:
    outputs.figure(name, ax, dpi=120, bbox_inches="tight")


@click.group("phase", context_settings={"help_option_names": ["-h", "--help"]})
def phase() -> None:
    """Geometric and dynamic phases over closed shape loops, and Montgomery's rigid-body formula."""


@phase.command("two-bodies")
@click.option("--I1", "I1", type=float, default=1.0, show_default=True, help="Moment of inertia of body 1.")
@click.option("--I2", "I2", type=float, default=3.0, show_default=True, help="Moment of inertia of body 2.")
@click.option("--mu", type=float, default=0.0, show_default=True, help="Total angular momentum.")
@click.option(
    "--period",
    type=float,
    default=1.0,
    show_default=True,
    help="Time T in which body 2 makes its turns relative to body 1.",
)
@click.option(
    "--turns",
    type=int,
    default=1,
    show_default=True,
    help="Signed turns of body 2 relative to body 1 during the period (counterclockwise positive).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@out_option("Directory for two_bodies.json and figures of theta(t) and its geometric and dynamic parts.")
@html_option("theta(t) and psi(t) over the period as an interactive figure")
def two_bodies_cmd(
    I1: float, I2: float, mu: float, period: float, turns: int, as_json: bool, out: Path | None, html: Path | None
) -> None:
    """Two planar bodies pinned at their centres of mass (section 2.2 of the nonholonomic paper).

    Body 2 turns uniformly `--turns` times relative to body 1 in time `--period`; prints the geometric,
    dynamic and total phase of body 1 from eq. (2.3), the closed form
    -2 pi turns I2/(I1 + I2) + mu T/(I1 + I2) (from the conservation law
    (I1 + I2) theta' + I2 psi' = mu), and theta(T) - theta(0) reconstructed on the group.
    """
    from ..analysis import Gait, phases, reconstruct
    from ..systems.holonomic_examples import two_pinned_bodies

    if not (math.isfinite(period) and period > 0):
        raise InputError(f"Expected `--period` to be positive, got {period}.")
    if not math.isfinite(mu):
        raise InputError(f"Expected `--mu` to be finite, got {mu}.")
    system = two_pinned_bodies(I1, I2)
    loop = Gait.from_expressions([f"2*pi*({turns})*t/T"], period)
    split = phases(system, loop, mu)
    rec = reconstruct(system, loop, mu, t_eval=np.linspace(0.0, period, 201))
    closed = -2 * math.pi * turns * I2 / (I1 + I2) + mu * period / (I1 + I2)
    phase_json = {k: v for k, v in split.to_json().items() if k in _PHASE}
    reconstructed = float(rec.path.g[-1, 0] - rec.path.g[0, 0])
    doc = document(
        "phase two-bodies",
        {"phase": phase_json, "closed_form": closed, "reconstructed": reconstructed},
        {"I1": I1, "I2": I2, "mu": [mu], "period": period, "turns": turns, "note": _WRAP_NOTE},
    )
    outputs = None
    if out is not None:
        from ..plot.phases import group_path, phase_split

        outputs = Outputs(out)
        _save(outputs, group_path(rec), "two_bodies_theta.png")
        _save(outputs, phase_split(system, loop, mu), "two_bodies_phases.png")
    text = (
        f"two pinned bodies, I1 = {I1:g}, I2 = {I2:g}, mu = {mu:g}, T = {period:g}, turns = {turns}\n"
        f"geometric phase  -oint A dpsi      = {split.geometric:.12g}\n"
        f"dynamic phase    mu int 1/I dt     = {split.dynamic:.12g}\n"
        f"total phase of body 1 (unwrapped)  = {split.total:.12g}   (wrapped: {split.total_wrapped:.12g})\n"
        f"closed form                        = {closed:.12g}\n"
        f"reconstructed on the group         = {reconstructed:.12g}"
    )
    written_too = []
    if html is not None:
        from ..plot.interactive import reconstruction_html

        reconstruction_html(system, rec, path=html)
        written_too.append(html)
    emit(doc, as_json, text, outputs, "two_bodies", written_too)


@phase.command("rigid-body")
@click.option(
    "--inertia",
    type=FloatVector(3, 9),
    required=True,
    help="Principal moments I1 I2 I3, or the 9 entries of the inertia tensor (row by row).",
)
@click.option("--momentum", type=FloatVector(3), required=True, help="Initial body angular momentum m1 m2 m3.")
@click.option(
    "--attitude",
    type=FloatVector(3),
    default=None,
    help="Initial attitude as a rotation vector (default the identity).",
)
@click.option("--rtol", type=float, default=1e-12, show_default=True, help="Tolerance of the direct integration.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@html_option("one period of the body momentum on its sphere with the level curves of H, as an interactive figure")
@out_option("Directory for rigid_body_phase.json and a figure of the enclosed solid angle.")
def rigid_body_cmd(
    inertia: tuple,
    momentum: tuple,
    attitude: tuple | None,
    rtol: float,
    as_json: bool,
    html: Path | None,
    out: Path | None,
) -> None:
    """Montgomery's formula: the rotation about the spatial momentum after one period of the body momentum.

    Prints the period T, the oriented solid angle Lambda enclosed by m(t) on the momentum sphere, the
    geometric phase -Lambda, the dynamic phase 2 E T/|mu|, their sum, and the rotation read off a direct
    integration of the attitude.
    """
    from ..analysis.rigid_body_phase import rigid_body_phase
    from ..lie import so3
    from ..systems import RigidBody

    if not (0 < rtol < 1e-3):
        raise InputError(f"Expected `--rtol` in (0, 1e-3), got {rtol}.")
    arr = np.asarray(inertia, dtype=float)
    body = RigidBody(arr.reshape(3, 3) if arr.size == 9 else arr)
    R0 = None if attitude is None else so3.exp(np.asarray(attitude, dtype=float))
    res = rigid_body_phase(body, np.asarray(momentum, dtype=float), R0=R0, rtol=rtol)
    res_json = res.to_json()
    head = {
        "phase": {k: res_json.pop(k) for k in _PHASE},
        "direct_wrapped": res_json.pop("direct_wrapped"),
        "difference": res_json.pop("difference"),
    }
    res_json["axis"] = res.axis + 1  # 1-based, as on the command line
    detail = {
        "inertia": {"tensor": body.tensor.tolist(), "principal_moments": body.principal_moments.tolist()},
        "m0": [float(x) for x in momentum],
        **res_json,
        "note": _WRAP_NOTE,
    }
    doc = document("phase rigid-body", head, detail)
    outputs = None
    if out is not None:
        from ..plot.phases import momentum_solid_angle

        outputs = Outputs(out)
        _save(outputs, momentum_solid_angle(res), "rigid_body_solid_angle.png")
    text = (
        f"free rigid body, {res.family} orbit about principal axis {res.axis + 1}, |mu| = {res.momentum:.12g}\n"
        f"period T                            = {res.period:.12g}\n"
        f"solid angle Lambda (oriented)       = {res.solid_angle:.12g}\n"
        f"geometric phase -Lambda             = {res.geometric:.12g}\n"
        f"dynamic phase 2 E T/|mu|            = {res.dynamic:.12g}\n"
        f"total (unwrapped)                   = {res.total:.12g}\n"
        f"total, wrapped to (-pi, pi]         = {res.total_wrapped:.12g}\n"
        f"direct integration, wrapped         = {res.direct_wrapped:.12g}\n"
        f"difference (wrapped)                = {res.difference:.3g}"
    )
    written_too = []
    if html is not None:
        from ..plot.interactive import momentum_sphere_html
        from ..systems import as_left_invariant

        title = f"one period of m(t): solid angle {res.solid_angle:.6g}, total phase {res.total_wrapped:.6g}"
        curve = res.momentum_curve(400)
        momentum_sphere_html(
            curve, hamiltonian=as_left_invariant(body).hamiltonian, labels=["m(t)"], title=title, path=html
        )
        written_too.append(html)
    emit(doc, as_json, text, outputs, "rigid_body_phase", written_too)


def _holonomic_system(model: str, params: dict[str, float]) -> Any:
    """A built-in example without constraints, or a model file defining a HolonomicSystem."""
    from ..systems.holonomic import HolonomicSystem
    from ..systems.models import example_system, load_model

    if is_model_file(model):
        return load_model(model, params, kind=HolonomicSystem)
    return example_system(model, params, kind=HolonomicSystem, purpose="phase loop (Theorem 2.2)")


@phase.command("loop")
@model_argument("a HolonomicSystem (docs/phases.md)")
@click.option(
    "--shape",
    "shapes",
    multiple=True,
    metavar="NAME=EXPR",
    required=True,
    help="A shape coordinate as a formula in t (and T, the period), e.g. 'alpha1=0.8*cos(2*pi*t/T)'.",
)
@click.option("--period", type=float, default=1.0, show_default=True, help="Period T of the loop.")
@click.option(
    "--mu",
    type=FloatVector(1, 3),
    default=None,
    help="Spatial momentum: one number for S^1, 'px,py,L' for SE(2), three for SO(3) (default 0).",
)
@click.option(
    "--param", "params", multiple=True, metavar="NAME=VALUE", help="A parameter value of the model (repeatable)."
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@out_option("Directory for loop.json and figures (connection, curvature with the loop, path).")
@html_option(
    "the reconstructed motion as an interactive figure: on SE(2) the path in the plane animated, on other groups "
    "the group coordinates and the shapes against time"
)
def loop_cmd(
    model: str | None,
    model_file: str | None,
    shapes: tuple,
    period: float,
    mu: tuple | None,
    params: tuple,
    as_json: bool,
    out: Path | None,
    html: Path | None,
) -> None:
    """Phases and reconstruction for a closed shape loop of a MODEL without constraints: a built-in one
    (two_bodies, three_link, three_link_middle, planar_3_body, spacecraft; dashes for underscores also work) or
    a model file (.py) that defines ``system`` (a HolonomicSystem) or ``build(**params)`` returning one
    (docs/phases.md).

    Prints the geometric, dynamic and total phase (eq. 2.3) of the rotation where the formula holds,
    the curvature integral over the enclosed area (Stokes) on a 2-D shape space, and the net motion
    g(0)^-1 g(T) reconstructed on the group (eq. 2.2).
    """
    from ..analysis import Gait, curvature_integral, phases, reconstruct

    if not (math.isfinite(period) and period > 0):
        raise InputError(f"Expected `--period` to be positive, got {period}.")
    model = one_model(model, model_file)
    system = _holonomic_system(model, parse_params(params))
    names = [str(s) for s in system.shape]
    given = parse_shape_loop(shapes, names, "--shape", model)
    loop = Gait.from_expressions({n: given[n] for n in names}, period)
    mu_arr = np.zeros(1 if system.group.dim == 1 else system.group.dim) if mu is None else np.asarray(mu, float)
    if mu_arr.size != (1 if system.group.dim == 1 else system.group.dim):
        raise InputError(
            f"Expected `--mu` with {system.group.dim} component(s) for {system.group.name}, got "
            f"{mu_arr.size}: {mu_arr.tolist()}."
        )
    detail: dict[str, Any] = {
        "system": system.name,
        "loop": {n: str(given[n]) for n in names},
        "period": period,
        "mu": mu_arr.tolist(),
        "group": system.group.name,
    }
    phase_json: dict[str, Any] | None
    try:
        with activity("phases over the loop"):
            split = phases(system, loop, mu_arr)
        phase_json = split.to_json()
    except InputError as exc:
        # A phase formula needs an abelian rotation; say why not and still reconstruct.
        if "Theorem 2.2" not in str(exc) and "rotational phase formula" not in str(exc):
            raise
        phase_json = None
        detail["phase_unavailable"] = str(exc)
    if system.sigma == 2:
        B = curvature_integral(system, loop) if not np.any(_winding(system, loop)) else None
        detail["curvature_integral"] = None if B is None else B.tolist()
    with activity("reconstruction on the group"):
        rec = reconstruct(system, loop, mu_arr)
    detail["note"] = _WRAP_NOTE
    head: dict[str, Any] = {"phase": phase_json, "net_displacement": rec.path.net_motion()}
    doc = document("phase loop", head, detail)
    outputs = None
    if out is not None:
        from ..plot.phases import connection_field, curvature_map, group_path

        outputs = Outputs(out)
        if system.sigma == 2:
            _save(outputs, connection_field(system, loop=loop), "connection.png")
            _save(outputs, curvature_map(system, loop=loop), "curvature.png")
        _save(outputs, group_path(rec), "path.png")
    lines = [f"{model}: {system.name}, G = {system.group.name}, T = {period:g}, mu = {mu_arr.tolist()}"]
    if phase_json is not None:
        lines += [
            f"geometric phase ({phase_json['component']}) = {phase_json['geometric']:.12g}",
            f"dynamic phase                = {phase_json['dynamic']:.12g}",
            f"total phase (unwrapped)      = {phase_json['total']:.12g}",
        ]
    else:
        lines.append(f"phase formula: not available ({detail['phase_unavailable']})")
    if detail.get("curvature_integral") is not None:
        lines.append(f"iint B over the enclosed area = {detail['curvature_integral']}")
    lines.append(
        "net motion (reconstructed)   = " + ", ".join(f"{k} {v:.12g}" for k, v in head["net_displacement"].items())
    )
    written_too = []
    if html is not None:
        from ..plot.interactive import reconstruction_html

        reconstruction_html(system, rec, path=html)
        written_too.append(html)
    emit(doc, as_json, "\n".join(lines), outputs, "loop", written_too)


def _winding(system: Any, loop: Any) -> np.ndarray:
    from ..analysis.shape_loops import bind_loop

    return bind_loop(system, loop)
