"""``geomech``: the command line.

Every command prints a readable summary, or JSON with ``--json``; bad input prints one line on stderr
and exits with status 2.
"""

from __future__ import annotations

import contextlib
import os
import sys
import traceback
import warnings
from collections.abc import Sequence
from typing import Any

import click

from .._version import __version__
from ..errors import GeomechError, NumericalError, SingularityError
from ..symbolic.formula import parse_formula
from ._args import (
    FloatVector,
    Outputs,
    document,
    emit,
    gather_vectors,
    html_option,
    out_option,
    parse_params,
    repeated_option,
)
from ._progress import activity
from .gait import gait_cmd
from .methods import methods_cmd
from .nonholonomic import derive_cmd, simulate_cmd
from .phase import phase
from .reproduce import reproduce
from .show import show_cmd
from .stability import stability_cmd, stability_map_cmd


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="geomech")
def cli() -> None:
    """geomech: computational geometric mechanics.

    Reduction, stability and structure-preserving simulation of mechanical systems with symmetry.
    Run `geomech COMMAND --help` for a command's options.
    """


@cli.command("rigid-body")
@click.option(
    "--inertia",
    type=FloatVector(3, 9),
    required=True,
    help="Principal moments I1 I2 I3, or the 9 entries of the inertia tensor (row by row).",
)
@click.option("--momentum", type=FloatVector(3), required=True, help="Initial body angular momentum m1 m2 m3.")
@click.option("--t-final", type=float, default=50.0, show_default=True, help="Final time.")
@click.option(
    "--samples",
    type=click.IntRange(2, 10**6),
    default=1001,
    show_default=True,
    help="Times at which invariants are checked.",
)
@click.option("--rtol", type=float, default=1e-12, show_default=True, help="Relative tolerance of the integration.")
@click.option(
    "--max-turns",
    type=float,
    default=2000.0,
    show_default=True,
    help="Refuse runs of more turns of the body (t_final |omega| / 2 pi), about 60 ms each.",
)
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary.")
@html_option("the trajectory on the momentum sphere with the level curves of H, as an interactive figure")
@out_option(
    "Directory for rigid_body.json, the trajectory rigid_body.nc (m, R, invariants; NetCDF) and a figure of "
    "the momentum on its sphere."
)
def rigid_body_cmd(inertia, momentum, t_final, samples, rtol, max_turns, as_json, html, out) -> None:
    """The free rigid body: exact elliptic solution vs the integrated Serret-Andoyer reduced system.

    Prints the momentum at the final time from both, the energy and Casimir drift of the integration,
    and the period of the motion from the quadrature of eq. (11) and from the elliptic solution.
    """
    from ..experiments.rigid_body import run_rigid_body, summary_text

    with activity(f"integrating the reduced system to t = {t_final:g}"):
        result, traj = run_rigid_body(
            inertia, momentum, t_final=t_final, samples=samples, rtol=rtol, max_turns=max_turns
        )
    head = result.pop("summary")
    doc = document("rigid-body", head, result)
    outputs = None
    if out is not None:
        from ..plot import momentum_sphere

        outputs = Outputs(out)
        fig_ax = momentum_sphere(traj.m, title=f"I = {doc['inertia']['principal_moments']}")
        outputs.figure("rigid_body_momentum.png", fig_ax, dpi=120)
        outputs.dataset("rigid_body.nc", traj.to_dataset())
    written_too = []
    if html is not None:
        from ..plot.interactive import momentum_sphere_html
        from ..systems import as_left_invariant

        H = as_left_invariant(traj.system)
        title = f"free rigid body, I = {doc['inertia']['principal_moments']}"
        momentum_sphere_html(traj.m, hamiltonian=H.hamiltonian, labels=["m(t)"], title=title, path=html)
        written_too.append(html)
    emit(doc, as_json, summary_text(doc), outputs, "rigid_body", written_too)


@cli.command("reduce")
@click.option(
    "--hamiltonian",
    "hamiltonian",
    required=True,
    help="H(m1, m2, m3) as a formula, e.g. 'm1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)'.",
)
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE", help="A parameter value (repeatable).")
@click.option(
    "--axis",
    type=click.IntRange(1, 3),
    default=3,
    show_default=True,
    help="Body axis of the Serret-Andoyer chart (3 is the paper's).",
)
@click.option(
    "--symbolic",
    is_flag=True,
    help="Keep the parameters without a --param value as symbols (h_p and the equations only; no verdicts).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option("--latex", "as_latex", is_flag=True, help="Print LaTeX.")
def reduce_cmd(hamiltonian, params, axis, symbolic, as_json, as_latex) -> None:
    """The generalized Serret-Andoyer reduction of a left-invariant H(m) (Theorem 3).

    Prints the reduced Hamiltonian h_p(l, L) = H(U_p(l, L)) (eq. 21), the canonical equations
    l' = dh_p/dL, L' = -dh_p/dl, and whether H is hyperregular.
    """
    import sympy as sp

    from ..reduction.serret_andoyer import reduced_formulas
    from ..symbolic.compile import M_SYMBOLS
    from ..systems import LeftInvariantSystem
    from ..systems._hyperregularity import HyperregularityReport

    values = parse_params(params)
    expr = parse_formula(hamiltonian, "--hamiltonian")
    free = sorted({s.name for s in expr.free_symbols} - {s.name for s in M_SYMBOLS} - set(values))
    if symbolic and free:
        # h_p = H o U_p with the given values substituted and the rest left as symbols; nothing numeric follows
        unknown = sorted(set(values) - {s.name for s in expr.free_symbols})
        if unknown:
            raise click.BadParameter(f"{unknown} do not appear in the Hamiltonian", param_hint="'--param'")
        system = None
    else:
        system = LeftInvariantSystem.from_expression(expr, values)
    h, ldot, Ldot = reduced_formulas(expr, values, axis - 1)
    head: dict[str, Any] = {
        "reduced_hamiltonian": str(h),
        "hyperregularity": (
            HyperregularityReport("unknown", f"the parameters {free} are symbolic", ()).to_json()
            if system is None
            else system.hyperregularity().to_json()
        ),
    }
    summary = document(
        "reduce",
        head,
        {
            "hamiltonian": str(expr if system is None else system.expression),
            "parameters": values if system is None else system.parameters,
            "symbolic_parameters": free if system is None else [],
            "chart_axis": axis,
            "l_dot": str(ldot),
            "L_dot": str(Ldot),
            "latex": {"h_p": sp.latex(h), "l_dot": sp.latex(ldot), "L_dot": sp.latex(Ldot)},
        },
    )
    if as_json:
        emit(summary, True, "", None, "reduce")
    elif as_latex:
        click.echo(
            f"h_p(l, L) = {summary['latex']['h_p']}\n\\dot l = {summary['latex']['l_dot']}\n"
            f"\\dot L = {summary['latex']['L_dot']}"
        )
    else:
        click.echo(
            f"H(m)       = {summary['hamiltonian']}\nchart      : about body axis {axis}\n"
            f"h_p(l, L)  = {h}\nl'         = {ldot}\nL'         = {Ldot}\n"
            f"hyperregular: {head['hyperregularity']['status']}"
            + (f" ({head['hyperregularity']['where']})" if head["hyperregularity"]["where"] else "")
        )


cli.add_command(derive_cmd)
cli.add_command(gait_cmd)
cli.add_command(methods_cmd)
cli.add_command(show_cmd)
cli.add_command(simulate_cmd)
cli.add_command(phase)
cli.add_command(reproduce)
cli.add_command(stability_cmd)
cli.add_command(stability_map_cmd)


def _say(kind: str, message: object) -> None:
    """One line on stderr."""
    line = " ".join(str(message).split())
    click.echo(f"geomech: {kind}: {line}" if kind else f"geomech: {line}", err=True)


#: API argument names that a command's option spells differently (used only where the command has that option).
_ALIASES = {
    "expression": "--hamiltonian",
    "hamiltonian": "--hamiltonian",
    "parameters": "--param",
    "m0": "--momentum",
    "momentum": "--momentum",
    "shapes": "--shape",
    "tau": "--tau",
    "phi": "--phi",
    "period": "--period",
    "expressions": "--shape",
}


def _command_of(args: list[str]) -> click.Command:
    """The (sub)command that ``args`` invoke."""
    command: click.Command = cli
    ctx = click.Context(cli)
    for word in args:
        if not isinstance(command, click.Group):
            break
        sub = command.get_command(ctx, word)
        if sub is None:
            continue
        command = sub
    return command


def _options_of(args: list[str]) -> set[str]:
    """The long options of the (sub)command that ``args`` invoke."""
    return {opt for p in _command_of(args).params for opt in p.opts if opt.startswith("--")}


def _check_values_are_not_options(args: list[str]) -> None:
    """``--out --json`` would take ``--json`` as the directory's name: an option's value that is another of the
    command's options is refused."""
    params = {opt: p for p in _command_of(args).params if isinstance(p, click.Option) for opt in p.opts}
    for option, value in zip(args, args[1:]):
        p = params.get(option)
        if p is not None and not p.is_flag and not p.count and value in params:
            raise click.UsageError(
                f"{option} takes a value, but the next word is the option {value}; give "
                f"{option} its value (a value that starts with - can be written {option}=VALUE)."
            )


def _with_option_names(exc: GeomechError, args: list[str]) -> None:
    """Rewrite the API argument names in ``exc``'s message as the command's options: `t_final` is
    `--t-final`, `expression` is `--hamiltonian`, `parameters={'I1': ...}` is --param I1=VALUE."""
    import re

    options = _options_of(args)
    text = str(exc)

    def option(name: str) -> str | None:
        base = name.split("[", 1)[0]
        for candidate in (_ALIASES.get(base), "--" + base.replace("_", "-")):
            if candidate in options:
                return candidate + name[len(base) :]
        return None

    text = re.sub(
        r"`([A-Za-z_][A-Za-z0-9_]*(?:\[[^\]`]*\])?)`",
        lambda m: f"`{option(m.group(1))}`" if option(m.group(1)) else m.group(0),
        text,
    )
    if "--param" in options:
        text = re.sub(
            r"pass(?: them as)? parameters=\{([^}]*)\}",
            lambda m: (
                "add " + " ".join(f"--param {k.strip(chr(39))}=VALUE" for k in re.findall(r"'[^']+'", m.group(1)))
            ),
            text,
        )
    if text != str(exc):
        exc.args = (text,)


def _run(args: list[str]) -> int:
    try:
        _check_values_are_not_options(args)
        with cli.make_context("geomech", args, obj={"argv": list(args)}) as ctx:
            try:
                cli.invoke(ctx)
            except GeomechError as exc:
                _with_option_names(exc, args)
                raise
    except click.exceptions.NoArgsIsHelpError as exc:
        click.echo(exc.ctx.get_help() if exc.ctx else exc.format_message())
    except click.exceptions.Exit as exc:
        return int(exc.exit_code or 0)
    except click.ClickException as exc:
        _say("error", exc.format_message())
        return 2
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: run the command line with every failure as one line on stderr.

    Exit status: 0 success; 2 bad input (the line names the option and the fix; a singular point the input
    reaches is one); 1 a numerical failure
    (where and why) or an internal error; 130 interrupted (Ctrl-C). ``--debug`` anywhere on the command
    line also prints the traceback. Warnings raised during a successful run are printed one line each;
    after a failure only the error is.
    """
    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args
    args = [a for a in args if a != "--debug"]
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            # numpy's overflow and invalid-value warnings mean the numbers that follow are not to be trusted:
            # the run stops there (the package silences them with errstate where they are expected).
            warnings.simplefilter("error", RuntimeWarning)
            twice = repeated_option(args, cli)
            if twice is not None:
                _say("error", f"Option '{twice}' is given twice; give it once (it takes one value).")
                return 2
            code = _run(gather_vectors(args, cli))
        if code == 0:
            for message in dict.fromkeys(str(w.message) for w in caught):
                _say("warning", message)
        return code
    except KeyboardInterrupt:
        _debug(debug)
        _say("", "interrupted")
        return 130
    except NumericalError as exc:
        _debug(debug)
        if isinstance(exc, SingularityError):  # the input reaches a singular point: the input must change
            _say("error", exc)
            return 2
        _say("numerical failure", exc)
        return 1
    except GeomechError as exc:
        _debug(debug)
        _say("error", exc)
        return 2
    except RuntimeWarning as exc:
        _debug(debug)
        _say(
            "numerical failure",
            f"{exc}: a value left the range of double precision (an input too large or too small for this computation)",
        )
        return 1
    except BrokenPipeError:
        # stdout closed early (| head): nothing more to say, and Python must not complain at exit
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except MemoryError:
        _debug(debug)
        _say("error", "out of memory; reduce the problem's size (samples, steps, grid)")
        return 1
    except (Exception, SystemExit) as exc:  # a bug of geomech's: still one line, the traceback on request
        _debug(debug)
        what = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        _say("internal error", f"{what} (run again with --debug for the traceback, and please report it)")
        return 1


def _debug(debug: bool) -> None:
    if debug:
        traceback.print_exc(file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
