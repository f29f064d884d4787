"""``geomech``: the command line.

Every command prints a readable summary, or JSON with ``--json``; bad input prints one line on stderr
and exits with status 2.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path

import click

from .._version import __version__
from ..errors import GeomechError
from ._args import FloatVector, gather_vectors, parse_params
from .gait import gait_cmd
from .nonholonomic import derive_cmd, simulate_cmd
from .phase import phase
from .reproduce import reproduce
from .stability import stability_cmd, stability_map_cmd


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="geomech")
def cli() -> None:
    """geomech: computational geometric mechanics.

    Reduction, stability and structure-preserving simulation of mechanical systems with symmetry.
    Run `geomech COMMAND --help` for a command's options.
    """


def _emit(summary: dict, as_json: bool, text: str, out: Path | None, name: str) -> None:
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / f"{name}.json").write_text(json.dumps(summary, indent=2) + "\n")
    click.echo(json.dumps(summary, indent=2) if as_json else text)


@cli.command("rigid-body")
@click.option("--inertia", type=FloatVector(3, 9), required=True,
              help="Principal moments I1 I2 I3, or the 9 entries of the inertia tensor (row by row).")
@click.option("--momentum", type=FloatVector(3), required=True, help="Initial body angular momentum m1 m2 m3.")
@click.option("--t-final", type=float, default=50.0, show_default=True, help="Final time.")
@click.option("--samples", type=click.IntRange(2, 10**6), default=1001, show_default=True,
              help="Times at which invariants are checked.")
@click.option("--rtol", type=float, default=1e-12, show_default=True, help="Relative tolerance of the integration.")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Directory for rigid_body.json and a figure of the momentum on its sphere.")
def rigid_body_cmd(inertia, momentum, t_final, samples, rtol, as_json, out) -> None:
    """The free rigid body: exact elliptic solution vs the integrated Serret-Andoyer reduced system.

    Prints the momentum at the final time from both, the energy and Casimir drift of the integration,
    and the period of the motion from the quadrature of eq. (11) and from the elliptic solution.
    """
    from ..experiments.rigid_body import run_rigid_body, summary_text

    summary, traj = run_rigid_body(inertia, momentum, t_final=t_final, samples=samples, rtol=rtol)
    if out is not None:
        from ..plot import momentum_sphere

        fig_ax = momentum_sphere(traj.m, title=f"I = {summary['inertia']['principal_moments']}")
        out.mkdir(parents=True, exist_ok=True)
        fig_ax.figure.savefig(out / "rigid_body_momentum.png", dpi=120)
    _emit(summary, as_json, summary_text(summary), out, "rigid_body")


@cli.command("reduce")
@click.option("--hamiltonian", "hamiltonian", required=True,
              help="H(m1, m2, m3) as a formula, e.g. 'm1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)'.")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE", help="A parameter value (repeatable).")
@click.option("--axis", type=click.IntRange(1, 3), default=3, show_default=True,
              help="Body axis of the Serret-Andoyer chart (3 is the paper's).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option("--latex", "as_latex", is_flag=True, help="Print LaTeX.")
def reduce_cmd(hamiltonian, params, axis, as_json, as_latex) -> None:
    """The generalized Serret-Andoyer reduction of a left-invariant H(m) (Theorem 3).

    Prints the reduced Hamiltonian h_p(l, L) = H(U_p(l, L)) (eq. 21), the canonical equations
    l' = dh_p/dL, L' = -dh_p/dl, and whether H is hyperregular.
    """
    import sympy as sp

    from ..reduction import GeneralizedSerretAndoyer
    from ..reduction.serret_andoyer import L_SYM, l_SYM
    from ..systems import LeftInvariantSystem

    values = parse_params(params)
    system = LeftInvariantSystem.from_expression(hamiltonian, values)
    sa = GeneralizedSerretAndoyer(system)
    h = sa.reduced_expression(axis - 1)
    ldot, Ldot = sp.simplify(sp.diff(h, L_SYM)), sp.simplify(-sp.diff(h, l_SYM))
    summary = {
        "hamiltonian": str(system.expression),
        "parameters": system.parameters,
        "chart_axis": axis,
        "reduced_hamiltonian": str(h),
        "l_dot": str(ldot),
        "L_dot": str(Ldot),
        "latex": {"h_p": sp.latex(h), "l_dot": sp.latex(ldot), "L_dot": sp.latex(Ldot)},
        "hyperregular": system.hyperregularity(),
    }
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    elif as_latex:
        click.echo(f"h_p(l, L) = {summary['latex']['h_p']}\n\\dot l = {summary['latex']['l_dot']}\n"
                   f"\\dot L = {summary['latex']['L_dot']}")
    else:
        click.echo(f"H(m)       = {summary['hamiltonian']}\nchart      : about body axis {axis}\n"
                   f"h_p(l, L)  = {h}\nl'         = {ldot}\nL'         = {Ldot}\n"
                   f"hyperregular: {summary['hyperregular']}")


cli.add_command(derive_cmd)
cli.add_command(gait_cmd)
cli.add_command(simulate_cmd)
cli.add_command(phase)
cli.add_command(reproduce)
cli.add_command(stability_cmd)
cli.add_command(stability_map_cmd)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: run the command line, turning input errors into one line on stderr and status 2."""
    args = gather_vectors(list(sys.argv[1:] if argv is None else argv))
    try:
        cli.main(args=args, prog_name="geomech", standalone_mode=False, obj={"argv": list(args)})
    except click.exceptions.NoArgsIsHelpError as exc:
        click.echo(exc.ctx.get_help() if exc.ctx else exc.format_message())
        return 0
    except click.exceptions.Exit as exc:
        return int(exc.exit_code or 0)
    except click.exceptions.Abort:
        click.echo("geomech: aborted", err=True)
        return 1
    except click.ClickException as exc:
        click.echo(f"geomech: error: {exc.format_message()}", err=True)
        return 2
    except GeomechError as exc:
        click.echo(f"geomech: error: {exc}".replace("\n", " "), err=True)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
