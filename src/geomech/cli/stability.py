"""``geomech stability`` and ``geomech stability-map``: structure-preserving rotor controls, their
closed-loop Hamiltonian, relative equilibria and stability verdicts (sections 6-7 of the Serret-Andoyer
paper). The lead registers them with ``cli.add_command(stability_cmd)`` and
``cli.add_command(stability_map_cmd)``.
"""

from __future__ import annotations

import inspect
import sys
from typing import Any

import click
import numpy as np

from ..symbolic.formula import parse_formula
from ._args import (
    FloatVector,
    Outputs,
    document,
    emit,
    html_option,
    out_option,
    parse_params,
    parse_range,
    study_options,
)

__all__ = ["stability_cmd", "stability_map_cmd"]


def _control(
    lambdas: tuple[float, ...],
    I3: float | None,
    phis: tuple[str, ...],
    params: dict[str, float],
    p: tuple[float, ...] | None,
    G: float,
) -> Any:
    from ..systems.control import StructurePreservingControl
    from ..systems.rotors import RotorBody

    phi_exprs = tuple(parse_formula(f, "--phi") for f in phis)
    if not np.isfinite(G) or G <= 0:
        raise click.BadParameter(f"expected a positive momentum magnitude, got {G}", param_hint="'--G'")
    if len(lambdas) == 2:
        if I3 is None:
            raise click.BadParameter(
                "one rotor (two --lambda values) needs --I3, the body's own moment about the rotor axis",
                param_hint="'--I3'",
            )
        body = RotorBody.one_rotor(lambdas[0], lambdas[1], I3)
        if lambdas[0] <= lambdas[1]:
            raise click.BadParameter(
                f"expected lambda1 > lambda2 (axis 1 the major and axis 2 the intermediate axis of the locked body, "
                f"as in section 6.3), got {lambdas[0]:g} <= {lambdas[1]:g}; relabel the axes",
                param_hint="'--lambda'",
            )
        if len(phi_exprs) != 1:
            raise click.BadParameter(
                f"one rotor takes one --phi (a function of v = m3), got {len(phi_exprs)}", param_hint="'--phi'"
            )
        if p is not None and len(p) != 1:
            raise click.BadParameter(f"one rotor takes one --p value, got {len(p)}", param_hint="'--p'")
        return StructurePreservingControl.one_rotor(
            body, phi_exprs[0], p=0.0 if p is None else p[0], parameters=params, probe_radius=G
        )
    if I3 is not None:
        raise click.BadParameter(
            "--I3 is for one rotor (two --lambda values); with three rotors --lambda gives lambda1 lambda2 lambda3",
            param_hint="'--I3'",
        )
    body = RotorBody.three_rotors(lambdas)
    if len(phi_exprs) != 3:
        raise click.BadParameter(
            f"three rotors take three --phi (each in v, Corollary 2, or each in m1, m2, m3, "
            f"Proposition 5), got {len(phi_exprs)}",
            param_hint="'--phi'",
        )
    pv = (0.0, 0.0, 0.0) if p is None else p
    if len(pv) != 3:
        raise click.BadParameter(f"three rotors take three --p values, got {len(pv)}", param_hint="'--p'")
    # Proposition 5 (phi of m1, m2, m3) or Corollary 2 (each phi_i of v).
    uses_m = any({"m1", "m2", "m3"} & {s.name for s in f.free_symbols} for f in phi_exprs)
    if uses_m:
        return StructurePreservingControl.three_rotors(body, list(phi_exprs), p=pv, parameters=params, probe_radius=G)
    return StructurePreservingControl.diagonal(body, list(phi_exprs), p=pv, parameters=params, probe_radius=G)


_MODEL_KINDS = "a StructurePreservingControl or a left-invariant system (LeftInvariantSystem, RigidBody)"


def _model_kinds() -> tuple[type, ...]:
    from ..systems.control import StructurePreservingControl
    from ..systems.left_invariant import LeftInvariantSystem
    from ..systems.rigid_body import RigidBody

    return (StructurePreservingControl, LeftInvariantSystem, RigidBody)


def _no_rotor_options(lambdas: Any, I3: Any, phis: tuple, p: Any) -> None:
    given = [n for n, v in (("--lambda", lambdas), ("--I3", I3), ("--phi", phis or None), ("--p", p)) if v is not None]
    if given:
        raise click.UsageError(f"give the model as --model FILE.py or as --lambda and --phi, not both ({given[0]})")


def _subject(
    model_file: str | None,
    lambdas: Any,
    I3: Any,
    phis: tuple,
    params: dict[str, float],
    p: Any,
    G: float,
) -> tuple[Any, Any, dict[str, Any]]:
    """(the control or None, the left-invariant system whose equilibria are assessed, the model's JSON)."""
    from ..systems.control import StructurePreservingControl
    from ..systems.left_invariant import as_left_invariant
    from ..systems.models import load_model

    if model_file is None:
        if lambdas is None or not phis:
            raise click.UsageError("give the model: --lambda and --phi (a rotor control), or --model FILE.py")
        control = _control(lambdas, I3, phis, params, p, G)
        return control, control.closed_loop(), _model_json(control, G)
    _no_rotor_options(lambdas, I3, phis, p)
    if not np.isfinite(G) or G <= 0:
        raise click.BadParameter(f"expected a positive momentum magnitude, got {G}", param_hint="'--G'")
    obj = load_model(model_file, params, kind=_model_kinds())
    if isinstance(obj, StructurePreservingControl):
        return obj, obj.closed_loop(), _model_json(obj, G)
    system = as_left_invariant(obj)
    expr = system.expression
    return (
        None,
        system,
        {
            "model": {"file": str(model_file), "G": G, "parameters": dict(system.parameters)},
            "hamiltonian": "a Python callable" if expr is None else str(expr),
        },
    )


def _model_json(control: Any, G: float) -> dict[str, Any]:
    hyp = control.hyperregularity()
    lemma = control.lemma4_check()
    return {
        "model": {
            "rotors": control.n_rotors,
            "kind": control.kind,
            "G": G,
            "inertia_without_rotor_axial_moments": np.diag(control.body.inertia).tolist(),
            "phi": [str(e) for e in (control.phi_of_v or control.phi_expression)],
            "parameters": dict(control.parameters),
        },
        "closed_loop_hamiltonian": str(control.H_c),
        "closed_loop_hamiltonian_closed_form": control.hamiltonian_is_closed_form,
        "existence_condition": {
            "holds": control.condition.holds,
            "method": control.condition.method,
            "detail": control.condition.detail,
        },
        "lemma4": {
            "max_relative_error": lemma.max_relative_error,
            "points": lemma.n_points,
            "gradient_route": lemma.gradient_route,
        },
        "hyperregularity": hyp.to_json(),
    }


def _model_options(f):
    opts = [
        click.option(
            "--lambda",
            "lambdas",
            type=FloatVector(2, 3),
            default=None,
            help="lambda1 lambda2 (one rotor on axis 3: the locked inertias about axes 1, 2) or lambda1 "
            "lambda2 lambda3 (three rotors: Lambda without the rotors' axial moments).",
        ),
        click.option(
            "--I3",
            "I3",
            type=float,
            default=None,
            help="One rotor: the body's own moment of inertia about the rotor axis.",
        ),
        click.option(
            "--phi",
            "phis",
            multiple=True,
            help="phi(v) for one rotor (v = m3); three times for three rotors: each phi_i(v) "
            "(Corollary 2) or each a function of m1, m2, m3 (Proposition 5).",
        ),
        click.option(
            "--model",
            "model_file",
            type=click.Path(dir_okay=False),
            default=None,
            help="Instead of --lambda and --phi: a Python model file defining `system` or `build(**params)` "
            "returning a StructurePreservingControl or a left-invariant system (LeftInvariantSystem, RigidBody).",
        ),
        click.option(
            "--param",
            "params",
            multiple=True,
            metavar="NAME=VALUE",
            help="A parameter of phi, or of a --model file's build(**params) (repeatable).",
        ),
        click.option(
            "--p", "p", type=FloatVector(1, 3), default=None, help="The conserved p = Gamma - phi(m) (default 0)."
        ),
        click.option(
            "--G", "G", type=float, default=1.0, show_default=True, help="Magnitude of the angular momentum |m|."
        ),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


@click.command("stability")
@_model_options
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@out_option("Directory for stability.json and the reduced phase portrait stability_phase_portrait.png.")
def stability_cmd(lambdas, I3, phis, model_file, params, p, G, as_json, out) -> None:
    """Relative equilibria of a rotor control's closed loop and three stability verdicts on each.

    Builds the structure-preserving control (eq. 29a; Proposition 5 / Corollary 2), its closed-loop
    Hamiltonian H_c (eqs. 29b, 41), finds every equilibrium of h_p = H_c o U_p on |m| = G, and reports
    for each its location, the Hessian of h_p and its eigenvalues, the linearisation eigenvalues, and
    the verdicts of Lagrange-Dirichlet, energy-Casimir and linearisation (stable, unstable, inconclusive).
    """
    from ..analysis import analyse_stability

    control, system, model = _subject(model_file, lambdas, I3, phis, parse_params(params), p, G)
    analysis = analyse_stability(system, G)
    detail = analysis.to_json()
    eqs = detail.get("equilibria", [])
    counts: dict[str, int] = {}
    for e in eqs:
        counts[e["verdict"]] = counts.get(e["verdict"], 0) + 1
    head = {
        "n_equilibria": len(eqs),
        "verdict_counts": counts,
        "complete": detail.pop("complete", None),
        "verdicts": [{"m": e["m"], "verdict": e["verdict"]} for e in eqs],
    }
    summary = document("stability", head, {**model, **detail})  # the answer first, the evidence after
    outputs = None
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ..plot.stability import equilibria_phase_portrait

        outputs = Outputs(out)
        outputs.figure("stability_phase_portrait.png", equilibria_phase_portrait(system, G, analysis), dpi=120)
        plt.close("all")
    if as_json:
        emit(summary, True, "", outputs, "stability")
        return
    if control is not None:
        lines = [
            f"closed loop H_c(m) = {summary['closed_loop_hamiltonian']}",
            f"hyperregular: {summary['hyperregularity']['status']} ({summary['hyperregularity']['where'] or 'ok'})",
        ]
    else:
        lines = [f"H(m) = {summary['hamiltonian']}"]
    lines.append(f"equilibria on |m| = {G:g}: {analysis.equilibria.message}")
    for r in analysis:
        e = r.equilibrium
        ev = r.linearisation.eigenvalues
        tiny = 1e-12 * max(np.abs(ev).max(), 1e-300)
        ev = ", ".join(
            f"{(z.real if abs(z.real) > tiny else 0.0):+.4g}{(z.imag if abs(z.imag) > tiny else 0.0):+.4g}i" for z in ev
        )
        lines.append(
            f"  m = {(np.round(e.m, 6) + 0.0).tolist()}  (l, L) = ({e.lL[0]:.6g}, {e.lL[1]:.6g}) in the "
            f"chart about axis {e.axis + 1}"
        )
        lines.append(
            f"    Hessian eigenvalues {(np.round(np.linalg.eigvalsh(e.hessian), 8) + 0.0).tolist()}; linearisation {ev}"
        )
        lines.append(
            f"    Lagrange-Dirichlet: {r.lagrange_dirichlet.verdict}; energy-Casimir: "
            f"{r.energy_casimir.verdict}; linearisation: {r.linearisation.verdict}  => {r.verdict}"
        )
    emit(summary, False, "\n".join(lines), outputs, "stability")


def _check_swept_body(control: Any, lambdas: tuple[float, ...], *sweeps: tuple[str, np.ndarray, str]) -> None:
    """The swept model parameters stay where `stability` accepts them: inertias positive and, for one rotor,
    lambda1 > lambda2 at every grid point (section 6.3's labelling)."""
    for name, values, hint in sweeps:
        if name in ("lambda1", "lambda2", "lambda3", "I3") and values.min() <= 0:
            raise click.BadParameter(
                f"{name} must stay positive, but the sweep reaches {values.min():g}", param_hint=hint
            )
    if control.kind != "one-rotor":
        return
    grid = {name: values for name, values, _ in sweeps}
    l1 = grid.get("lambda1", np.array([lambdas[0]]))
    l2 = grid.get("lambda2", np.array([lambdas[1]]))
    if l1.min() <= l2.max():
        hint = sweeps[0][2] if sweeps[0][0] in ("lambda1", "lambda2") else sweeps[1][2]
        raise click.BadParameter(
            f"the sweep reaches lambda1 = {l1.min():g} <= lambda2 = {l2.max():g}; keep lambda1 "
            "> lambda2 over the whole grid (axis 1 the major, axis 2 the intermediate axis of "
            "the locked body, as `stability` requires)",
            param_hint=hint,
        )


@click.command("stability-map")
@_model_options
@click.option(
    "--x",
    "xspec",
    required=True,
    metavar="NAME=START:STOP:N",
    help="First swept parameter: a parameter of phi or of the model (lambda1, lambda2, I3, p, ...).",
)
@click.option("--y", "yspec", required=True, metavar="NAME=START:STOP:N", help="Second swept parameter.")
@click.option(
    "--near",
    type=FloatVector(3),
    default=None,
    help="Reference body momentum: the equilibrium nearest to it is assessed; default (0, G, 0), the "
    "intermediate-axis spin.",
)
@out_option("Directory for stability_map.png, stability_map.nc and stability_map.json.", required=True)
@click.option(
    "--max-points",
    type=click.IntRange(1, None),
    default=None,
    help="Refuse larger grids; default 1,000,000 points for a model compiled (a rotor control with a closed-form "
    "H_c: about 20 us a point) and 10,000 otherwise (a model file: 10-15 ms a point).",
)
@study_options("stability_map.zarr")
@html_option("the map as an interactive figure, each point's verdicts and numbers on hover")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON summary.")
def stability_map_cmd(
    lambdas,
    I3,
    phis,
    model_file,
    params,
    p,
    G,
    xspec,
    yspec,
    near,
    out,
    max_points,
    resume,
    scheduler,
    chunk,
    html,
    as_json,
) -> None:
    """Stability verdicts over a grid of two parameters, on the relative equilibrium nearest to --near.

    At each grid point all relative equilibria are found (continued from the neighbouring point, searched
    afresh where the Poincare-Hopf check fails) and the one nearest to --near is assessed. Writes the map
    as a figure (computed boundary in black; Theorem 5's closed form dashed where it applies) and as a
    netCDF data file with the verdict codes (1 stable, 0 inconclusive, -1 unstable, -9 no equilibrium),
    the equilibrium and the eigenvalues at every grid point. The grid runs on dask in blocks of rows, written to
    OUT/stability_map.zarr as they complete: an interrupted map continues with --resume.
    """
    import matplotlib

    matplotlib.use("Agg")

    from ..analysis import theorem5_margin

    xname, xs = parse_range(xspec, "'--x'")
    yname, ys = parse_range(yspec, "'--y'")
    given = parse_params(params)
    if model_file is not None:
        _no_rotor_options(lambdas, I3, phis, p)
        family, model = _file_family(model_file, given, G, (xname, "'--x'"), (yname, "'--y'"))
        if xname == yname:
            raise click.BadParameter("--x and --y must sweep two different parameters", param_hint="'--y'")
        study = dict(out=out, resume=resume, scheduler=scheduler, chunk=chunk, model=model)
        ds = _run_map(family, (xname, xs), (yname, ys), G, near, None, f"model file {model_file}", max_points, study)
        _write_map(ds, model, xname, xs, yname, ys, out, as_json, html)
        return
    if lambdas is None or not phis:
        raise click.UsageError("give the model: --lambda and --phi (a rotor control), or --model FILE.py")
    # a swept parameter of phi needs no --param: its first grid value stands in while the model is built
    body_names = {"lambda1", "lambda2", "lambda3", "I3", "p"}
    for name, values in ((xname, xs), (yname, ys)):
        if (
            name not in body_names
            and name not in given
            and any(name in {s.name for s in parse_formula(phi, "--phi").free_symbols} for phi in phis)
        ):
            given[name] = float(values[0])
    control = _control(lambdas, I3, phis, given, p, G)
    known = set(control.parameters)
    for name, hint in ((xname, "'--x'"), (yname, "'--y'")):
        if name not in known:
            raise click.BadParameter(
                f"{name!r} is not a parameter of this model; choose one of {sorted(known)}", param_hint=hint
            )
    if xname == yname:
        raise click.BadParameter("--x and --y must sweep two different parameters", param_hint="'--y'")
    _check_swept_body(control, lambdas, (xname, xs, "'--x'"), (yname, ys, "'--y'"))
    closed = theorem5_margin(control) if control.kind == "one-rotor" else None
    desc = f"phi = {', '.join(str(e) for e in control.phi_expression)}" if control.phi_expression is not None else ""
    model = _model_json(control, G)
    study = dict(out=out, resume=resume, scheduler=scheduler, chunk=chunk, model=model)
    ds = _run_map(control.family(), (xname, xs), (yname, ys), G, near, closed, desc, max_points, study)
    _write_map(ds, model, xname, xs, yname, ys, out, as_json, html)


def _file_family(model_file: str, given: dict[str, float], G: float, *swept: tuple[str, str]) -> tuple[Any, dict]:
    """``family(**values)`` from a model file's ``build(**params)`` (the swept names must be its keywords), and
    the model's JSON."""
    from ..systems.control import StructurePreservingControl
    from ..systems.left_invariant import as_left_invariant
    from ..systems.models import model_builder

    if not np.isfinite(G) or G <= 0:
        raise click.BadParameter(f"expected a positive momentum magnitude, got {G}", param_hint="'--G'")
    build = model_builder(model_file, kind=_model_kinds())
    sig = inspect.signature(build)
    takes_any = any(q.kind is inspect.Parameter.VAR_KEYWORD for q in sig.parameters.values())
    known = [n for n, q in sig.parameters.items() if q.kind is not inspect.Parameter.VAR_KEYWORD]
    for name, hint in swept:
        if not takes_any and name not in known:
            raise click.BadParameter(
                f"{name!r} is not a parameter of the model file's build(**params); choose one of {known or 'none'} "
                "(a file that defines `system` takes none: define build(**params))",
                param_hint=hint,
            )

    def family(**values: float) -> Any:
        obj = build(**{**given, **values})
        return obj.closed_loop() if isinstance(obj, StructurePreservingControl) else as_left_invariant(obj)

    import hashlib
    from pathlib import Path

    digest = hashlib.sha256(Path(model_file).read_bytes()).hexdigest()
    return family, {"model": {"file": str(model_file), "sha256": digest, "G": G, "parameters": dict(given)}}


def _run_map(
    family: Any, x: tuple, y: tuple, G: float, near: Any, closed: Any, desc: str, max_points: int | None, study: dict
) -> Any:
    """The map as a study whose store is OUT/stability_map.zarr (created with OUT)."""
    from pathlib import Path

    from ..analysis import stability_map

    out = Path(study.pop("out"))
    out.mkdir(parents=True, exist_ok=True)
    kw = dict(
        G=G,
        near=near,
        closed_form=closed,
        description=desc,
        max_points=max_points,
        out=out / "stability_map.zarr",
        **study,
    )
    n = x[1].size * y[1].size
    if sys.stderr.isatty():  # a progress bar for a person at a terminal, nothing in scripts and logs
        with click.progressbar(length=n, label="grid points", file=sys.stderr) as bar:

            def advance(done: int) -> None:
                bar.update(done - bar.pos)

            return stability_map(family, x, y, progress=advance, **kw).load()
    return stability_map(family, x, y, **kw).load()


def _write_map(
    ds: Any, model: dict, xname: str, xs: Any, yname: str, ys: Any, out: Any, as_json: bool, html: Any = None
) -> None:
    import matplotlib.pyplot as plt

    from ..plot.stability import stability_map_plot

    outputs = Outputs(out)
    outputs.dataset("stability_map.nc", ds)
    outputs.figure("stability_map.png", stability_map_plot(ds), dpi=120)
    plt.close("all")
    counts = {
        k: int((ds["verdict"].values == v).sum())
        for k, v in (("stable", 1), ("inconclusive", 0), ("unstable", -1), ("none", -9))
    }
    doc = document(
        "stability-map",
        {"points": int(xs.size * ys.size), "verdict_counts": counts},
        {**model, "x": {"name": xname, "values": xs.tolist()}, "y": {"name": yname, "values": ys.tolist()}},
    )
    text = f"stability map over {xname} x {yname} ({xs.size} x {ys.size} points): " + (
        ", ".join(f"{n} {v}" for v, n in counts.items() if n) or "no verdicts"
    )
    written_too = []
    if html is not None:
        from ..plot.interactive import stability_map_html

        stability_map_html(ds, path=html)
        written_too.append(html)
    emit(doc, as_json, text, outputs, "stability_map", written_too)
