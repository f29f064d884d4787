"""``geomech derive`` and ``geomech simulate``: nonholonomic systems with symmetry from the command line.

``derive`` prints the derived objects of an example or of a user's model file (see docs/nonholonomic.md for
the file's contract); ``simulate`` integrates one with prescribed shape motions (gaits) or shape torques.
Both print readable text, or JSON with ``--json``; bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

import shlex
import sys
from typing import Any

import click

from ..errors import InputError, NumericalError
from ..lie.groups import SE2
from ..symbolic.formula import parse_formula
from ..systems.models import example_system, load_model
from ._args import (
    FloatVector,
    Outputs,
    document,
    emit,
    events_json,
    html_option,
    is_model_file,
    model_argument,
    one_model,
    out_option,
)
from ._progress import activity

__all__ = ["derive_cmd", "simulate_cmd"]


def _pairs(items: tuple[str, ...], option: str, numeric: bool) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        name, sep, val = item.partition("=")
        if not sep or not name.strip() or not val.strip():
            raise click.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint=f"'{option}'")
        if name.strip() in out:
            raise click.BadParameter(f"{name.strip()} is given twice", param_hint=f"'{option}'")
        if numeric:
            try:
                out[name.strip()] = float(val)
            except ValueError:
                raise click.BadParameter(
                    f"{name.strip()} = {val!r} is not a number", param_hint=f"'{option}'"
                ) from None
        else:
            out[name.strip()] = parse_formula(val, f"{option} {name.strip()}")
    return out


def nonholonomic_system(model: str, params: dict[str, float]):
    """A built-in example by name (any of ``geomech.systems.models.EXAMPLES``), or the system a model file
    defines (``system``, or ``build(**params)``)."""
    if is_model_file(model):
        return load_model(model, params)
    return example_system(model, params)


def require_values(system) -> None:
    """Numeric commands need every parameter: name the missing ones as ``--param`` options."""
    missing = sorted(p.name for p in system.parameter_symbols if p.name not in system.parameters)
    if missing:
        raise InputError(
            f"{system.name} needs a value for parameter(s) {missing}: add "
            + " ".join(f"--param {m}=VALUE" for m in missing)
            + "."
        )


def derivation(
    system,
    sections: tuple[str, ...] = ("system", "lagrange_dalembert", "bkmm", "almost_poisson", "poisson_reduction"),
    forms: tuple[str, ...] = ("text", "latex"),
) -> dict[str, Any]:
    """All derived objects of ``system`` as a JSON-ready dict: text and LaTeX of each, or the ``forms`` given."""
    import sympy as sp

    from ..reduction import bkmm_reduction, lagrange_dalembert
    from ..reduction.almost_poisson import almost_poisson, poisson_reduction

    out: dict[str, Any] = {}
    if "system" in sections:
        constraints = list(system.constraint_matrix * sp.Matrix(system.qdot))
        names = system.latex_names
        out["system"] = {
            "name": system.name,
            "description": system.description,
            "group": system.group.name,
            "group_coordinates": [c.name for c in system.group.coordinates],
            "shape": [r.name for r in system.shape],
            "velocities": [v.name for v in system.qdot],
            "lagrangian": str(system.lagrangian),
            "constraints": [str(e) for e in constraints],
            "parameters": [p.name for p in system.parameter_symbols],
            "invariance": system.check_invariance().to_dict(),
            "latex": {
                "lagrangian": sp.latex(system.lagrangian, symbol_names=names),
                "constraints": [sp.latex(e, symbol_names=names) for e in constraints],
            },
        }
    if "lagrange_dalembert" in sections:
        out["lagrange_dalembert"] = lagrange_dalembert(system).to_dict(forms)
    if "bkmm" in sections:
        out["bkmm"] = bkmm_reduction(system).to_dict(forms)
    if "almost_poisson" in sections:
        out["almost_poisson"] = almost_poisson(system).to_dict(forms)
    if "poisson_reduction" in sections:
        out["poisson_reduction"] = poisson_reduction(system).to_dict(forms)
    return out


_SECTIONS = ("system", "lagrange_dalembert", "bkmm", "almost_poisson", "poisson_reduction")


@click.command("derive")
@model_argument("a NonholonomicSystem (docs/nonholonomic.md)")
@click.option(
    "--param",
    "params",
    multiple=True,
    metavar="NAME=VALUE",
    help="A parameter of a --model file's build(**params) (repeatable); derivations are symbolic.",
)
@click.option(
    "--section",
    "sections",
    multiple=True,
    type=click.Choice(_SECTIONS),
    help="Derive only these parts (repeatable; default all).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON (text and LaTeX of every object).")
@click.option("--latex", "as_latex", is_flag=True, help="Print LaTeX.")
def derive_cmd(model, model_file, params, sections, as_json, as_latex) -> None:
    """Derive the nonholonomic structure of an example (snakeboard, roller_racer, ...) or of --model FILE.py.

    The Lagrange-d'Alembert equations, their projection on D (no multipliers) and the multipliers along D, in
    (q, rdot, p, tau); the BKMM reduction (body-fixed basis,
    nonholonomic momentum, connection, locked inertia, reconstruction eq. 1.1, momentum equation 1.2 with
    H, K, D, shape equations 1.3); the almost-Poisson bracket on FL(D) with the curvature of D and every
    Jacobiator of coordinate functions by its indices; the Poisson reduction of Theorems 1.1-1.2. Derivations
    are cached on disk ($GEOMECH_CACHE_DIR, default ~/.cache/geomech; "off" disables it).
    """
    values = _pairs(params, "--param", True)
    spec = one_model(model, model_file)
    if values and not is_model_file(spec):
        raise click.BadParameter(
            "the derivation is symbolic in every parameter of a built-in example, so values "
            "would not change it; drop --param (it applies to simulate and gait, and to a "
            "--model file's build(**params))",
            param_hint="'--param'",
        )
    system = nonholonomic_system(spec, values)
    with activity(f"deriving {system.name}"):
        forms = ("text", "latex") if as_json else ("latex",) if as_latex else ("text",)
        data = derivation(system, tuple(sections) or _SECTIONS, forms)
    if as_json:
        rest = {k: v for k, v in data.items() if k != "system"}
        head = {"system": system.name, "sections": list(rest)}
        definition = {"definition": data["system"]} if "system" in data else {}
        emit(document("derive", head, {**definition, **rest}), True, "", None, "derive")
        return
    lines: list[str] = []
    for key, val in data.items():
        lines.append(f"== {key} ==")
        if key == "system":
            tex = val["latex"]
            for k, v in val.items():
                if k == "latex":
                    continue
                if as_latex and k == "lagrangian":
                    lines.append(f"L = {tex['lagrangian']}")
                elif as_latex and k == "constraints":
                    lines.append(r"\text{constraints: } " + r",\; ".join(f"{c} = 0" for c in tex["constraints"]))
                else:
                    lines += _rendered(k, v, ":")
            continue
        items = val["latex"] if as_latex else val["text"]
        for k, v in items.items():
            lines += [f"{k} = {v}"] if as_latex else _rendered(k, v, " =")
    click.echo("\n".join(lines))


def _rendered(name: str, value: Any, sep: str, width: int = 120) -> list[str]:
    """``name`` and a derived value as text lines of at most ``width`` characters where they can be broken: a
    list as its items (a matrix row by row), a dict as its entries, a long formula wrapped at its spaces."""
    import textwrap

    def wrap(line: str, indent: str) -> list[str]:
        return textwrap.wrap(
            line, width, subsequent_indent=indent + "    ", break_long_words=False, break_on_hyphens=False
        ) or [line]

    if isinstance(value, dict):
        out = [f"{name}{sep}"]
        for k, v in value.items():
            shown = (", ".join(map(_plain, v)) or "none") if isinstance(v, list) else v
            out += wrap(f"  {k}: {shown}", "  ")
        return out
    while isinstance(value, list) and len(value) == 1 and isinstance(value[0], list) and _depth(value) > 2:
        value = value[0]  # a matrix wrapped in a list of one
    if isinstance(value, list):
        if value and all(isinstance(row, list) for row in value):
            cells = [[_plain(c) for c in row] for row in value]
            head = f"{name}{sep} ({len(cells)} x {len(cells[0]) if cells else 0})"
            if _depth(value) > 2:  # a list of matrices (structure constants): one matrix a line, rows split by ;
                head = f"{name}{sep} ({len(value)} matrices)"
                flat = [f"  {_plain(row)}" for row in value]
            else:
                flat = [f"  [{', '.join(row)}]" for row in cells]
            if all(len(r) <= width for r in flat):
                return [head, *flat]
            out = [head]
            for i, row in enumerate(cells):
                for j, c in enumerate(row):
                    out += wrap(f"  [{i + 1},{j + 1}] {c}", "  ")
            return out
        items = [_plain(v) for v in value]
        one = f"{name}{sep} {', '.join(items)}"
        if len(one) <= width:
            return [one]
        out = [f"{name}{sep}"]
        for i, v in enumerate(items):
            out += wrap(f"  [{i + 1}] {v}", "  ")
        return out
    return wrap(f"{name}{sep} {value}", "")


def _depth(value: Any) -> int:
    return 1 + max((_depth(v) for v in value), default=0) if isinstance(value, list) else 0


def _plain(value: Any) -> str:
    """A nested list as text without quotes, a matrix by rows: ``[a, b; c, d]``."""
    if isinstance(value, list):
        if value and all(isinstance(row, list) for row in value):
            return "[" + "; ".join(", ".join(_plain(c) for c in row) for row in value) + "]"
        return "[" + ", ".join(_plain(c) for c in value) + "]"
    return str(value)


@click.command("simulate")
@model_argument("a NonholonomicSystem (docs/nonholonomic.md)")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE", help="A parameter value (repeatable).")
@click.option(
    "--shape",
    "shapes",
    multiple=True,
    metavar="NAME=F(t)",
    help="A prescribed shape motion, e.g. 'psi=sin(2*pi*t)' (repeatable); other shapes are free.",
)
@click.option(
    "--tau",
    "taus",
    multiple=True,
    metavar="NAME=F(t, q, qdot)",
    help="A torque on a free shape variable, a formula in t, the coordinates and velocities (repeatable).",
)
@click.option("--q0", "q0s", multiple=True, metavar="NAME=VALUE", help="An initial coordinate (default 0).")
@click.option(
    "--rdot0",
    "rdot0s",
    multiple=True,
    metavar="NAME=VALUE",
    help="An initial velocity of a free shape variable (default 0).",
)
@click.option(
    "--p0",
    type=FloatVector(*range(1, 65)),
    default=None,
    help="Initial nonholonomic momentum, comma-separated (default 0; basis of docs/nonholonomic.md).",
)
@click.option("--t-final", type=float, default=1.0, show_default=True, help="Final time.")
@click.option(
    "--method",
    default="full",
    show_default=True,
    help="full: Lagrange-d'Alembert with multipliers; reduced: BKMM eqs. 1.1-1.3 (DOP853); reduced-taylor: the "
    "same by Taylor's method (compiled); discrete: midpoint DLA; "
    "discrete-group: DLA with the group's discrete Lagrangian; almost-poisson, bates-sniatycki, full-tensor: "
    "Hamilton's equations on FL(D) (free shapes: --tau, not --shape). With "
    "--hamiltonian any method of geomech.solve that fits (`geomech methods --hamiltonian ...`); full: the "
    "Serret-Andoyer atlas.",
)
@click.option(
    "--hamiltonian",
    default=None,
    help="Instead of MODEL: a left-invariant H(m1, m2, m3) as a formula, integrated from --momentum.",
)
@click.option("--momentum", type=FloatVector(3), default=None, help="With --hamiltonian: the initial m1 m2 m3.")
@click.option("--attitude", is_flag=True, help="With --hamiltonian: integrate the attitude R from the identity too.")
@click.option("--rtol", type=float, default=1e-10, show_default=True, help="With --hamiltonian: adaptive tolerance.")
@click.option("--h", "step", type=float, default=1e-3, show_default=True, help="Step of the discrete method.")
@click.option("--samples", type=click.IntRange(2, 10**6), default=201, show_default=True, help="Output times.")
@click.option(
    "--max-evaluations",
    type=click.IntRange(1, None),
    default=200_000,
    show_default=True,
    help="Stop the full and reduced methods past this many evaluations of the equations.",
)
@click.option(
    "--max-steps",
    type=click.IntRange(1, None),
    default=1_000_000,
    show_default=True,
    help="Refuse discrete runs of more steps ((t_final) / h).",
)
@click.option(
    "--event",
    "event_specs",
    multiple=True,
    metavar="NAME=FORMULA",
    help="Locate the zeros of FORMULA in the state (e.g. 'back=psi', 'east=x - 1') and list their times and states "
    "(repeatable; --method reduced, reduced-taylor, full, or the Hamiltonian forms almost-poisson, bates-sniatycki, "
    "full-tensor; with --hamiltonian the adaptive methods dop853, dopri5, taylor and solve_ivp).",
)
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary.")
@out_option("Directory for trajectory.csv, trajectory.nc (NetCDF), summary.json and path.png.")
@html_option(
    "the motion as an interactive figure: for a system on SE(2), the path in the plane animated with the shape "
    "variables; with --hamiltonian, m(t) on its sphere with the level curves of H"
)
def simulate_cmd(
    model,
    model_file,
    params,
    shapes,
    taus,
    q0s,
    rdot0s,
    p0,
    t_final,
    method,
    hamiltonian,
    momentum,
    attitude,
    rtol,
    step,
    samples,
    max_evaluations,
    max_steps,
    event_specs,
    as_json,
    out,
    html,
) -> None:
    """Simulate an example or --model FILE.py with gaits (--shape) and torques (--tau).

    Prints the final configuration, the nonholonomic momentum, the constraint residual and the work done by
    the shape inputs. Unless told otherwise (--p0, --q0) the group starts at the identity and at rest
    (for the snakeboard x' = y' = theta' = 0) while the shapes follow their gaits; where rest violates
    the constraints (constraints on the shape velocities) it starts with nonholonomic momentum 0 instead,
    and the summary says so.
    """
    from ..integrators import BKMM, TAYLOR, Kind, get_method, solve

    events = _pairs(event_specs, "--event", False) or None
    if hamiltonian is not None:
        from .hamiltonian import simulate_hamiltonian

        if model is not None or model_file is not None:
            raise click.UsageError("give MODEL (or --model) or --hamiltonian, not both")
        extra = [o for o, v in (("--shape", shapes), ("--tau", taus), ("--q0", q0s), ("--rdot0", rdot0s)) if v]
        if extra or p0 is not None:
            raise click.UsageError(f"{', '.join(extra or ['--p0'])} apply to a MODEL, not to --hamiltonian")
        simulate_hamiltonian(
            hamiltonian,
            _pairs(params, "--param", True),
            momentum,
            attitude,
            method,
            t_final,
            step,
            rtol,
            samples,
            max_steps,
            as_json,
            out,
            html,
            events,
        )
        return
    if method not in _MODEL_METHODS:
        raise click.BadParameter(
            f"{method!r}: choose one of {', '.join(_MODEL_METHODS)} for a MODEL", param_hint="'--method'"
        )
    if momentum is not None or attitude:
        raise click.UsageError("--momentum and --attitude apply to --hamiltonian")
    system = nonholonomic_system(one_model(model, model_file), _pairs(params, "--param", True))
    kw: dict[str, Any] = dict(
        shapes=_pairs(shapes, "--shape", False),
        tau=_pairs(taus, "--tau", False),
        q0=_pairs(q0s, "--q0", True),
        rdot0=_pairs(rdot0s, "--rdot0", True),
        p0=None if p0 is None else list(p0),
    )
    if events is not None:
        kw["events"] = events
    require_values(system)
    if html is not None and system.group.name != "SE(2)":
        raise InputError(
            f"--html draws a motion in the plane, and {system.name} moves on {system.group.name}; drop --html (the "
            "trajectory is in --out DIR/trajectory.nc)."
        )
    start = "momentum p0 as given"
    if p0 is None:
        from ..integrators.nonholonomic import initial_state

        try:
            initial_state(system, kw["shapes"], q0=kw["q0"], rdot0=kw["rdot0"], qdot0="rest")
            kw["qdot0"], start = "rest", "at rest (group velocity 0)"
        except InputError as exc:
            if "cannot start at rest" not in str(exc):
                raise
            start = "nonholonomic momentum 0 (rest violates the constraints)"
    with activity(f"simulating {system.name} ({method}) to t = {t_final:g}"):
        integrator = BKMM(solver=TAYLOR) if method == "reduced-taylor" else get_method(_MODEL_METHODS[method])
        if integrator.kind is Kind.FIXED_STEP:
            sol = solve(
                system,
                integrator,
                t_final=t_final,
                h=step,
                max_steps=max_steps,
                raise_on_failure=False,
                **kw,
            )
        else:
            sol = solve(
                system,
                integrator,
                t_final=t_final,
                saveat=samples,
                max_evaluations=max_evaluations,
                raise_on_failure=False,
                **kw,
            )
    if not sol.success:
        raise NumericalError(sol.message)
    label = _method_label(sol, step)
    detail = _summary(sol, label)
    if events is not None:
        detail["events"] = events_json(sol)
    head = {k: detail.pop(k) for k in _HEADLINE}
    doc = document("simulate", head, {"initial_state": start, **detail})
    outputs = None
    if out is not None:
        outputs = Outputs(out)
        outputs.file("trajectory.csv", sol.to_csv)
        ds = sol.to_dataset()
        argv = (click.get_current_context().obj or {}).get("argv", sys.argv[1:])
        ds.attrs["command"] = "geomech " + " ".join(shlex.quote(a) for a in argv)
        ds.attrs["initial_state"] = start
        outputs.dataset("trajectory.nc", ds)
        outputs.figure("path.png", _plot_path(sol, label), dpi=110)
    fc = ", ".join(f"{k} = {v:.6g}" for k, v in head["final_configuration"].items())
    text = (
        f"{detail['system']} by {detail['method']} to t = {detail['t_final']:g}\n"
        f"final configuration: {fc}\n"
        f"nonholonomic momentum: {detail['nonholonomic_momentum']}\n"
        f"constraint residual |A(q) qdot|: max {head['constraint_residual_max']:.3g}, "
        f"final {detail['constraint_residual_final']:.3g}\n"
        f"work by shape inputs: {detail['work_by_shape_inputs']:.6g} "
        f"(energy change {detail['energy_final'] - detail['energy_initial']:.6g})"
    )
    written_too = []
    if html is not None:
        from ..plot.interactive import gait_html

        gait_html(sol, path=html)
        written_too.append(html)
    emit(doc, as_json, text, outputs, "summary", written_too)


#: ``simulate --method`` for a MODEL, with the method's key in the registry (the fixed-step ones take ``--h``).
_MODEL_METHODS = {
    "full": "lagrange_dalembert",
    "reduced": "bkmm",
    "reduced-taylor": "bkmm",  # BKMM(solver="taylor")
    "discrete": "discrete_lagrange_dalembert",
    "discrete-group": "discrete_lagrange_dalembert_group",
    "almost-poisson": "almost_poisson",
    "bates-sniatycki": "bates_sniatycki",
    "full-tensor": "full_almost_poisson",
}

#: What a nonholonomic run's summary block holds; the rest of :func:`_summary` is the detail.
_HEADLINE = ("status", "final_configuration", "constraint_residual_max", "energy_change_minus_work")


def _method_label(sol, step: float) -> str:
    """The method as the summary names it: the CLI's ``--method`` with the solver or the step."""
    from ..integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert, NonholonomicHamilton

    m = sol.method
    if isinstance(m, LagrangeDAlembert):
        return f"full ({m.solver})"
    if isinstance(m, BKMM):
        return f"reduced ({m.solver})"
    if isinstance(m, NonholonomicHamilton):
        return f"Hamilton's equations on FL(D), {m.form.replace('_', '-')} form ({m.solver})"
    assert isinstance(m, DiscreteLagrangeDAlembert)
    return f"discrete Lagrange-d'Alembert ({m.discretization}, h = {step:.3g})"


def _summary(sol, label: str) -> dict[str, Any]:
    """The JSON summary of a nonholonomic run (a :class:`~geomech.Solution` of one trajectory)."""
    import numpy as np

    s = sol.system
    residual = np.abs(sol.constraint_residual)
    return {
        "system": s.name,
        "method": label,
        "t_final": float(sol.t[-1]),
        "initial_velocity": {v.name: float(x) for v, x in zip(s.qdot, sol.qdot[0])},
        "initial_momentum": [float(x) for x in sol.p[0]],
        "final_configuration": {c.name: float(x) for c, x in zip(s.q, sol.q[-1])},
        "final_velocity": {v.name: float(x) for v, x in zip(s.qdot, sol.qdot[-1])},
        "nonholonomic_momentum": [float(x) for x in sol.p[-1]],
        "constraint_residual_max": float(residual.max(initial=0.0)),
        "constraint_residual_final": float(residual[-1].max(initial=0.0)),
        "work_by_shape_inputs": float(sol.work[-1]),
        "energy_initial": float(sol.energy[0]),
        "energy_final": float(sol.energy[-1]),
        "energy_change_minus_work": float(sol.energy[-1] - sol.energy[0] - sol.work[-1]),
        "status": sol.status.value,
        "message": sol.message,
    }


def _plot_path(sol, label: str) -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    import numpy as np

    s = sol.system
    fig, ax = plt.subplots(figsize=(5, 5))
    if isinstance(s.group.numeric, SE2):  # the planar picture: the path with its headings
        x, y, th = sol.q[:, 0], sol.q[:, 1], sol.q[:, 2]
        ax.plot(x, y, lw=1.5)
        step = max(1, len(x) // 12)
        arrow = 0.05 * max(np.ptp(x), np.ptp(y), 1e-3)
        ax.quiver(
            x[::step],
            y[::step],
            arrow * np.cos(th[::step]),
            arrow * np.sin(th[::step]),
            angles="xy",
            scale_units="xy",
            scale=1,
            width=0.004,
        )
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(s.q[0].name)
        ax.set_ylabel(s.q[1].name)
    else:
        for j, c in enumerate(s.group.coordinates):
            ax.plot(sol.t, sol.q[:, j], label=c.name)
        ax.set_xlabel("t")
        ax.legend()
    ax.set_title(f"{s.name}: {label}")
    fig.tight_layout()
    return fig
