"""``geomech simulate --hamiltonian``: a left-invariant system of one's own, H(m) as a formula, through solve()."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Any

import click
import numpy as np

from ..errors import InputError, NumericalError
from ..symbolic.formula import parse_formula
from ._args import Outputs, document, emit, events_json
from ._progress import activity

__all__ = ["simulate_hamiltonian"]

_NONHOLONOMIC = ("full", "reduced", "discrete")


def simulate_hamiltonian(
    hamiltonian: str,
    params: dict[str, float],
    momentum: tuple | None,
    attitude: bool,
    method: str,
    t_final: float,
    step: float,
    rtol: float,
    samples: int,
    max_steps: int,
    as_json: bool,
    out: Path | None,
    html: Path | None = None,
    events: dict[str, Any] | None = None,
) -> None:
    """Integrate Euler's equation m' = m x grad H(m) (and R' = R hat(grad H) with ``attitude``) from ``momentum``
    by ``method`` (any key of geomech.solve that fits; ``geomech methods --hamiltonian ...`` lists them)."""
    from ..integrators import REGISTRY, Kind, compatible_methods, solve
    from ..systems import LeftInvariantSystem

    if momentum is None:
        raise InputError("--hamiltonian needs an initial momentum: add --momentum m1 m2 m3.")
    system = LeftInvariantSystem.from_expression(parse_formula(hamiltonian, "--hamiltonian"), params)
    key = "serret_andoyer_atlas" if method in ("full",) else method
    if key in _NONHOLONOMIC or key not in REGISTRY:
        fits = compatible_methods(system, attitude=attitude)
        raise InputError(f"Unknown --method {method!r} for a Hamiltonian H(m); choose one of {', '.join(fits)}.")
    kind = REGISTRY[key].kind
    kw: dict[str, Any] = {"m0": np.asarray(momentum, dtype=float), "t_final": t_final, "raise_on_failure": False}
    if attitude:
        kw["R0"] = np.eye(3)
    if events is not None:
        kw["events"] = events
    if kind is Kind.FIXED_STEP:
        n = t_final / step
        if not abs(n - round(n)) <= 1e-9 * max(1.0, n):
            raise InputError(f"--t-final {t_final:g} is not a whole number of steps --h {step:g}; adjust either.")
        if round(n) > max_steps:
            raise InputError(f"{round(n)} steps exceed --max-steps {max_steps}; raise it or take a larger --h.")
        kw.update(h=step, saveat=min(samples, round(n) + 1))
    elif kind is Kind.ADAPTIVE:
        kw.update(rtol=rtol, atol=rtol, saveat=samples)
    else:
        kw.update(saveat=samples)
    with activity(f"integrating {system.name} ({key}) to t = {t_final:g}"):
        sol = solve(system, key, **kw)
    if not sol.success:
        raise NumericalError(sol.message)
    m = np.asarray(sol.m)
    E = system.hamiltonian(m)
    C = np.linalg.norm(m, axis=-1)
    head: dict[str, Any] = {
        "status": sol.status.value,
        "m_final": m[-1].tolist(),
        "drift": {
            "energy": float(np.abs(E - E[0]).max()),
            "casimir": float(np.abs(C - C[0]).max()),
        },
    }
    detail: dict[str, Any] = {
        "system": system.name,
        "hamiltonian": str(system.expression),
        "parameters": system.parameters,
        "method": key,
        "t_final": t_final,
        "m0": m[0].tolist(),
        "attitude": bool(attitude),
        "stats": {k: v for k, v in sol.stats.items() if isinstance(v, (int, float, str))},
    }
    if events is not None:
        detail["events"] = events_json(sol)
    if attitude:
        R = np.asarray(sol.R)
        pi = np.einsum("nij,nj->ni", R, m)
        head["drift"]["spatial_momentum"] = float(np.abs(pi - pi[0]).max())
        detail["R_final"] = R[-1].tolist()
    doc = document("simulate", head, detail)
    outputs = None
    if out is not None:
        outputs = Outputs(out)
        ds = sol.to_dataset()
        argv = (click.get_current_context().obj or {}).get("argv", sys.argv[1:])
        ds.attrs["command"] = "geomech " + " ".join(shlex.quote(a) for a in argv)
        outputs.dataset("trajectory.nc", ds)
        outputs.file("trajectory.csv", sol.to_csv)
    drift = head["drift"]
    lines = [
        f"{system.name} = {detail['hamiltonian']} by {key} to t = {t_final:g}",
        f"m(0) = {np.round(m[0], 12).tolist()}",
        f"m(T) = {np.round(m[-1], 12).tolist()}",
        f"drift over the run: energy {drift['energy']:.3g}, Casimir |m| {drift['casimir']:.3g}"
        + (f", spatial momentum {drift['spatial_momentum']:.3g}" if attitude else ""),
    ]
    written_too = []
    if html is not None:
        from ..plot.interactive import momentum_sphere_html

        title = f"{system.name}: m(t) for 0 <= t <= {t_final:g} by {key}, with the level curves of H"
        momentum_sphere_html(m, hamiltonian=system.hamiltonian, labels=["m(t)"], title=title, path=html)
        written_too.append(html)
    emit(doc, as_json, "\n".join(lines), outputs, "summary", written_too)
