"""``geomech reproduce``: the papers' numerical studies as one-command, reproducible experiments."""

from __future__ import annotations

import shlex
import sys

import click

from ._args import (
    FloatVector,
    Outputs,
    check_document,
    document,
    emit,
    html_option,
    out_option,
    parse_range,
    study_options,
    written,
)

__all__ = ["reproduce"]


@click.group("reproduce")
def reproduce() -> None:
    """Reproduce a paper's numerical study: figures, data file (NetCDF) and summary.json."""


_PRESET_NAMES = ("default", "cross-checked")  # experiments.serret_andoyer_study.PRESETS (checked by the tests)


@reproduce.command("serret-andoyer")
@out_option(
    "Directory for figure5_errors.png, figure6_trajectories.png, figure7_reduced_flow.png, "
    "serret_andoyer_study.nc and summary.json.",
    required=True,
)
@click.option("--t-final", type=float, default=100.0, show_default=True, help="Duration [s] (the seed gives none).")
@click.option("--h", "h", type=float, default=1e-3, show_default=True, help="Step, and Adams' output interval [s].")
@click.option(
    "--save-every",
    type=click.IntRange(1, None),
    default=10,
    show_default=True,
    help="Keep every n-th step in the data file and the figures.",
)
@click.option(
    "--preset",
    type=click.Choice(sorted(_PRESET_NAMES)),
    default=None,
    help="Named inertias: default (lambda 1.2 1.0, I3 0.6, J3 0.2) or cross-checked (lambda 1.5 1.0, I3 0.6, "
    "J3 0.3: an orbit of period 7.0155791512 s computed independently). Not with --lambda, --I3, --J3.",
)
@click.option(
    "--lambda",
    "lambdas",
    type=FloatVector(2),
    default=None,
    help="lambda1 lambda2: locked inertias about axes 1 and 2 (the seed gives none) [default: 1.2 1.0].",
)
@click.option("--I3", "I3", type=float, default=None, help="The body's own moment about axis 3 [default: 0.6].")
@click.option("--J3", "J3", type=float, default=None, help="The rotor's axial moment [default: 0.2].")
@click.option(
    "--max-steps",
    type=float,
    default=1e8,
    show_default=True,
    help="Refuse runs of more steps (t_final / h) per approach.",
)
@click.option("--no-extras", is_flag=True, help="Only the seed's five approaches.")
@click.option(
    "--sweep",
    "sweeps",
    multiple=True,
    metavar="NAME=START:STOP:N",
    help="Sweep the step h or an inertia (lambda1, lambda2, I3, J3; repeatable: a grid): every approach's largest "
    "energy and momentum errors at each member, to OUT/integrator_sweep.nc, from a study resumable in "
    "OUT/integrator_sweep.zarr.",
)
@study_options("integrator_sweep.zarr")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json to stdout.")
@html_option("every approach's m(t) on the momentum sphere with the level curves of H_c, as an interactive figure")
@click.pass_context
def serret_andoyer_cmd(
    ctx,
    out,
    t_final,
    h,
    save_every,
    preset,
    lambdas,
    I3,
    J3,
    max_steps,
    no_extras,
    sweeps,
    resume,
    scheduler,
    chunk,
    as_json,
    html,
) -> None:
    """Section 8.1 of the Serret-Andoyer paper: five simulations of the controlled rigid body with one rotor
    (phi(v) = 2 tan(v/G), p = 0, G = 1, H_c = 0.47), and geomech's Lie-Poisson and Gauss-Legendre methods."""
    from ..experiments.serret_andoyer_study import (
        StudyConfig,
        prepare_output,
        run_study,
        terminal_progress,
        write_study,
    )

    given = {k: v for k, v in (("--lambda", lambdas), ("--I3", I3), ("--J3", J3)) if v is not None}
    if preset is not None and given:
        raise click.UsageError(f"--preset sets the inertias; drop {', '.join(given)} or --preset")
    inertias: dict[str, float] = {}
    if lambdas is not None:
        inertias.update(lambda1=lambdas[0], lambda2=lambdas[1])
    inertias.update({k: v for k, v in (("I3", I3), ("J3", J3)) if v is not None})
    cfg = StudyConfig.preset(
        preset or "default",
        **inertias,
        h=h,
        t_final=t_final,
        save_every=save_every,
        max_steps=max_steps,
        extras=not no_extras,
    )
    argv = (ctx.obj or {}).get("argv", sys.argv[1:])
    command = "geomech " + " ".join(shlex.quote(a) for a in argv)
    cfg.validate()
    if sweeps:
        if html is not None:
            raise click.UsageError("--html draws one study's trajectories; drop it with --sweep")
        _sweep(cfg, sweeps, out, resume, scheduler, chunk, as_json)
        return
    if resume or scheduler is not None or chunk is not None:
        raise click.UsageError("--resume, --scheduler and --chunk run a study: give --sweep")
    prepare_output(out)
    ds, result, model = run_study(cfg, progress=terminal_progress, command=command)
    head = {"orbit": result.pop("orbit"), "claims": result.pop("claims")}
    summary = document("reproduce serret-andoyer", head, result)
    check_document(summary)
    files = write_study(out, ds, summary, model, cfg)
    written_too = []
    if html is not None:
        from ..plot.interactive import momentum_sphere_html

        keys = list(ds.approach.values)
        every = max(1, ds.time.size // 2000)  # at most about 2000 points a curve: the file stays light
        momentum_sphere_html(
            [ds.m.sel(approach=k).values[::every] for k in keys],
            hamiltonian=model.system.hamiltonian,
            labels=[str(label) for label in ds.label.values],
            title=f"section 8.1 of the Serret-Andoyer paper: m(t) of every approach, 0 <= t <= {cfg.t_final:g} s",
            path=html,
        )
        written_too.append(html)
    if as_json:
        emit(summary, True, "", None, "summary", written_too)
        return
    o = head["orbit"]
    click.echo(f"orbit: {o['kind']}, period {o['period_s']:.10g} s ({o['periods_in_run']:.4g} periods in the run)")
    w = max(len(a["label"]) for a in summary["approaches"].values())
    click.echo(f"{'approach':<{w}} {'max energy err':>15} {'max |m| err':>12} {'|m(T)| - G':>11} {'time [s]':>9}")
    for a in summary["approaches"].values():
        click.echo(
            f"{a['label']:<{w}} {a['max_energy_error']:>15.3e} {a['max_momentum_error']:>12.3e} "
            f"{a['momentum_drift_final']:>+11.2e} {a['wall_time_s']:>9.3f}"
        )
    for name, c in head["claims"].items():
        click.echo(f"claim {name}: {'holds' if c['holds'] else 'does not hold'}")
    click.echo(written(out, files))
    for f in written_too:
        click.echo(f"interactive figure: {f}")


def _sweep(cfg, sweeps, out, resume, scheduler, chunk, as_json) -> None:
    """``--sweep``: every approach's largest errors over a grid of step sizes and inertias, as a study on dask."""
    from pathlib import Path

    import numpy as np

    from ..experiments.serret_andoyer_sweep import SWEPT, IntegratorSweep
    from ._progress import study_progress

    axes = {}
    for spec in sweeps:
        name, values = parse_range(spec, "'--sweep'")
        if name not in SWEPT:
            raise click.BadParameter(f"sweep one of {', '.join(SWEPT)}, got {name!r}", param_hint="'--sweep'")
        if name in axes:
            raise click.BadParameter(f"{name!r} is swept twice", param_hint="'--sweep'")
        axes[name] = values
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    study = IntegratorSweep(cfg)
    with study_progress("integrator sweep") as progress:
        ds = study.run(
            out=out / "integrator_sweep.zarr",
            resume=resume,
            scheduler=scheduler,
            chunk=1 if chunk is None else chunk,
            progress=progress,
            **axes,
        ).load()
    worst = {
        a: {
            "max_energy_error": float(np.nanmax(ds["max_energy_error"].sel(approach=a).values)),
            "max_momentum_error": float(np.nanmax(ds["max_momentum_error"].sel(approach=a).values)),
        }
        for a in study.keys
        if np.isfinite(ds["max_energy_error"].sel(approach=a).values).any()
    }
    members = int(np.prod([len(v) for v in axes.values()]))
    summary = {"members": members, "failed": int((ds["status"].values != 0).sum()), "worst": worst}
    detail = {"t_final": cfg.t_final, "sweep": {k: v.tolist() for k, v in axes.items()}}
    outputs = Outputs(out)
    outputs.dataset("integrator_sweep.nc", ds)
    doc = document("reproduce serret-andoyer sweep", summary, detail)
    text = f"integrator sweep: {members} members, {summary['failed']} failed; largest energy error over the grid:\n" + (
        "\n".join(f"  {a}: {w['max_energy_error']:.3e}" for a, w in worst.items()) or "  none"
    )
    emit(doc, as_json, text, outputs, "integrator_sweep")
