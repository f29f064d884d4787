"""``geomech methods``: the registered integrators with their traits, and which of them fit a system."""

from __future__ import annotations

import textwrap
from typing import Any

import click

from ..symbolic.formula import parse_formula
from ._args import document, emit, is_model_file, parse_params

__all__ = ["methods_cmd"]

_TRAITS = (("symplectic", "symplectic"), ("symmetric", "symmetric"), ("preserves_casimirs", "Casimirs"))


def _system(model: str | None, hamiltonian: str | None, params: dict[str, float]) -> Any:
    from ..errors import InputError

    if model is not None and hamiltonian is not None:
        raise InputError("Give either MODEL or --hamiltonian, not both.")
    if hamiltonian is not None:
        from ..systems import LeftInvariantSystem

        return LeftInvariantSystem.from_expression(parse_formula(hamiltonian, "--hamiltonian"), params)
    if model is None:
        if params:
            raise InputError("--param needs a system: give MODEL or --hamiltonian.")
        return None
    from ..systems.models import example_system, load_model

    if is_model_file(model):
        from ..systems import LeftInvariantSystem, NonholonomicSystem, RigidBody, RotorBody

        return load_model(model, params, kind=(NonholonomicSystem, LeftInvariantSystem, RigidBody, RotorBody))
    return example_system(model, params)


_NEEDS_AT = 82  # the column where "needs" starts; it wraps within a line of 120


def _row(d: dict[str, Any]) -> str:
    order = "-" if d["order"] is None else str(d["order"]) + ("+" if d.get("variable_order") else "")
    traits = ", ".join(label for key, label in _TRAITS if d.get(key)) or "-"
    line = f"{d['key']:<28} {d['kind']:<11} {order:>5}  {traits:<33} {d['structure']}"
    return "\n".join(textwrap.wrap(line, width=120, subsequent_indent=" " * _NEEDS_AT))


@click.command("methods")
@click.argument("model", required=False)
@click.option("--hamiltonian", default=None, help="A left-invariant H(m1, m2, m3) as a formula (instead of MODEL).")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE", help="A parameter value (repeatable).")
@click.option("--attitude", is_flag=True, help="With the attitude R integrated beside m (left-invariant systems).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def methods_cmd(model: str | None, hamiltonian: str | None, params: tuple, attitude: bool, as_json: bool) -> None:
    """The integrators of geomech.solve with their traits (kind, order, the structure they need, what they
    preserve); for a system (MODEL: a built-in example or a model file; or --hamiltonian with --param) also which
    of them fit it and, for the others, why not. Nothing is integrated."""
    from ..integrators import methods_for, methods_table

    system = _system(model, hamiltonian, parse_params(params))
    rows = methods_table() if system is None else methods_for(system, attitude=attitude)
    if as_json:
        head: dict[str, Any] = {
            "system": None if system is None else getattr(system, "name", str(system)),
            "fit": None if system is None else [d["key"] for d in rows if d["fits"]],
        }
        emit(document("methods", head, {"methods": rows}), True, "", None, "methods")
        return
    header = f"{'method':<28} {'kind':<11} {'order':>5}  {'preserves':<33} needs"
    lines = []
    if system is None:
        lines += [header, *(_row(d) for d in rows)]
    else:
        name = getattr(system, "name", type(system).__name__)
        fit, other = [d for d in rows if d["fits"]], [d for d in rows if not d["fits"]]
        lines += [f"methods that fit {name} ({len(fit)} of {len(rows)}):", header, *(_row(d) for d in fit)]
        if other:
            lines += ["", "not for this system:"]
            for d in other:
                lines += textwrap.wrap(
                    f"{d['key']}: {d['why_not']}", width=110, initial_indent="  ", subsequent_indent="      "
                )
    click.echo("\n".join(lines))
