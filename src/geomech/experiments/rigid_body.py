"""The free rigid body three ways: the exact elliptic solution, the integrated Serret-Andoyer reduced
system with its atlas, and the quadrature of eq. (11) for the period."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError
from ..integrators import SerretAndoyerAtlas, Solution, solve
from ..systems import RigidBody


def _inertia(values: Any) -> Any:
    arr = V.finite(values, "inertia")
    return arr.reshape(3, 3) if arr.size == 9 else arr


def run_rigid_body(
    inertia: Any,
    momentum: Any,
    *,
    t_final: float = 50.0,
    samples: int = 1001,
    rtol: float = 1e-12,
    max_turns: float = 2000.0,
) -> tuple[dict[str, Any], Solution]:
    """Run the comparison and return a JSON-ready summary and the reduced trajectory.

    The integration's cost grows with the number of turns of the body, ``t_final |omega| / 2 pi`` with
    ``|omega| <= |m| / I_min``: a run of more than ``max_turns`` (about 60 ms each at ``rtol = 1e-12``) is
    refused before it starts."""
    body = RigidBody(_inertia(inertia))
    m0 = V.exact_shape(momentum, "momentum", (3,))
    if not np.any(m0):
        raise InputError("Expected `momentum` to be nonzero: the momentum sphere |m| = G needs G > 0.")
    t_final = float(V.finite(t_final, "t_final"))
    if t_final <= 0:
        raise InputError(f"Expected `t_final` to be positive, got {t_final}.")
    if not (0 < rtol < 1e-3):
        raise InputError(f"Expected `rtol` in (0, 1e-3), got {rtol}.")
    turns = t_final * float(np.linalg.norm(m0)) / float(body.principal_moments.min()) / (2.0 * math.pi)
    V.work_budget(
        turns,
        float(max_turns),
        f"The number of turns of the body to t_final = {t_final:g} at |omega| "
        f"up to {2 * math.pi * turns / t_final:.3g} rad/s",
        "max_turns (--max-turns)",
        "shorten t_final (--t-final)",
        seconds_each=0.06,
    )
    t = np.linspace(0.0, t_final, int(samples))
    exact = body.exact_solution(m0)
    traj = solve(body, SerretAndoyerAtlas(), t_final=t_final, saveat=t, m0=m0, R0=np.eye(3), rtol=rtol, atol=rtol)
    E0, C0 = float(body.energy(m0)), float(body.casimir(m0))
    E, C = body.energy(traj.m), body.casimir(traj.m)
    p = np.einsum("nij,nj->ni", traj.R, traj.m)
    m_exact = exact.momentum(t[-1])
    period_exact = float(exact.period) if exact.period is not None else math.inf
    quadrature = _quadrature_period(body, m0, period_exact)
    summary: dict[str, Any] = {
        "family": exact.family,
        "period": _finite_or_none(period_exact),
        "m_error_max": float(np.abs(traj.m - exact.momentum(t)).max()),
        "drift": {
            "energy_relative": float(np.abs(E - E0).max() / abs(E0)),
            "casimir_relative": float(np.abs(C - C0).max() / C0),
            "spatial_momentum": float(np.abs(p - p[0]).max() / math.sqrt(C0)),
        },
    }
    detail: dict[str, Any] = {
        "inertia": {"tensor": body.tensor.tolist(), "principal_moments": body.principal_moments.tolist()},
        "m0": m0.tolist(),
        "t_final": t_final,
        "energy": E0,
        "casimir": C0,
        "m_final": traj.m[-1].tolist(),
        "m_exact_final": m_exact.tolist(),
        "period_quadrature": quadrature,
        "chart_switches": traj.stats["chart_switches"],
        "chart_switch_times": traj.events["chart_switch"][:, 1].tolist(),
        "rhs_evaluations": traj.stats["n_rhs"],
        "rtol": rtol,
    }
    return {"summary": summary, **detail}, traj


def _finite_or_none(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _quadrature_period(body: RigidBody, m0: np.ndarray, period_exact: float) -> dict[str, Any]:
    from ..errors import GeomechError
    from ..reduction.classical import period_of_l_from_momentum

    mp = body.to_principal(m0)
    try:
        res = period_of_l_from_momentum(body.principal_moments, mp)
    except GeomechError as exc:
        return {"quadrature_eq11": None, "quadrature_note": str(exc)}
    out: dict[str, Any] = {"quadrature_eq11": float(res.period), "l_motion": res.kind}
    if math.isfinite(period_exact):
        out["relative_difference"] = abs(res.period - period_exact) / period_exact
    return out


def summary_text(s: dict[str, Any]) -> str:
    """A readable rendering of :func:`run_rigid_body`'s result."""
    fmt = lambda v: "[" + ", ".join(f"{x: .12f}" for x in v) + "]"  # noqa: E731
    head, quad = s["summary"], s["period_quadrature"]
    period = "none (a separatrix or an equilibrium)" if head["period"] is None else f"{head['period']:.12g} s"
    drift = head["drift"]
    lines = [
        "free rigid body, principal moments "
        + ", ".join(f"{x:g}" for x in s["inertia"]["principal_moments"])
        + ", m0 = ("
        + ", ".join(f"{x:g}" for x in s["m0"])
        + ")",
        f"  energy {s['energy']:.12g}, |m|^2 {s['casimir']:.12g}, motion: {head['family']}",
        f"  m({s['t_final']:g}) exact (elliptic)  {fmt(s['m_exact_final'])}",
        f"  m({s['t_final']:g}) reduced (l, L)    {fmt(s['m_final'])}",
        f"  max |difference| over the run   {head['m_error_max']:.2e}",
        f"  drift: energy {drift['energy_relative']:.2e}, Casimir {drift['casimir_relative']:.2e}, "
        f"spatial momentum {drift['spatial_momentum']:.2e}",
        f"  period: elliptic {period}; eq. (11) quadrature "
        + (
            f"{quad['quadrature_eq11']:.12g} s"
            if quad.get("quadrature_eq11") is not None
            else f"none ({quad.get('quadrature_note', '')})"
        )
        + (f" (relative difference {quad['relative_difference']:.1e})" if "relative_difference" in quad else ""),
        f"  chart switches: {s['chart_switches']}",
    ]
    return "\n".join(lines)
