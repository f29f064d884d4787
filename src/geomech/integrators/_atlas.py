"""The Serret-Andoyer atlas in time: the reduced canonical flow (l, L) with the reconstruction angle phi,
integrated chart by chart and switched where a chart nears its pole (the engine of
:class:`~geomech.integrators.SerretAndoyerAtlas`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..reduction.serret_andoyer import GeneralizedSerretAndoyer, spatial_frame
from .solution import Failure, Status


@dataclass
class AtlasRun:
    """One trajectory: ``m`` (n, 3), ``R`` (n, 3, 3), ``lLphi`` (n, 3) in the chart in use, ``axis`` (n,)
    1-based (NaN where not reached), the chart ``switches`` (time, from axis, to axis; 1-based), the failure
    :class:`Failure` (``step`` the index of the first time not reached, ``time`` the last time reached) or
    None, and the evaluations."""

    m: np.ndarray
    R: np.ndarray
    lLphi: np.ndarray
    axis: np.ndarray
    switches: list[tuple[float, int, int]]
    failure: Failure | None
    nfev: int


def run_atlas(
    sa: GeneralizedSerretAndoyer,
    m0: np.ndarray,
    R0: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    first_axis: int | None = None,
) -> AtlasRun:
    """Integrate from ``(m0, R0)`` at ``t0``, saving at ``times``: DOP853 with dense output in each chart,
    stopped by an event where :math:`|L|/G` reaches ``sa.switch_at``, and restarted in the chart about the
    body axis with the smallest :math:`|m_k|` (where :math:`|L|/G \\le 1/\\sqrt 3`)."""
    from scipy.integrate import solve_ivp

    rtol, atol = tolerances
    G = float(np.linalg.norm(m0))
    S = spatial_frame(R0 @ m0)
    axis = sa.first_chart(m0, first_axis)
    y = sa.chart_coordinates(S, R0, m0, G, axis)
    t_end = float(times[-1]) if len(times) else t0
    sign = 1.0 if t_end >= t0 else -1.0
    start = t0
    segments: list[tuple[float, float, int, Any]] = []
    switches: list[tuple[float, int, int]] = []
    nfev = 0
    stop: tuple[float, str] | None = None
    while True:

        def rhs(_t: float, z: np.ndarray, axis: int = axis) -> np.ndarray:
            f = sa.reduced_vector_field(z[:2], G, axis)
            return np.array([f[0], f[1], sa.phi_rate(z[:2], G, axis)])

        def leave(_t: float, z: np.ndarray) -> float:
            return abs(z[1]) - sa.switch_at * G

        leave.terminal = True  # type: ignore[attr-defined]  # event attributes read by solve_ivp
        leave.direction = 1  # type: ignore[attr-defined]
        if t_end == start:
            segments.append(
                (start, start, axis, lambda t, y=y: np.asarray(y)[:, None] * np.ones_like(np.atleast_1d(t)))
            )
            break
        sol = solve_ivp(
            rhs, (start, t_end), y, method="DOP853", rtol=rtol, atol=atol * G, dense_output=True, events=leave
        )
        nfev += sol.nfev
        t1 = float(sol.t[-1])
        segments.append((start, t1, axis, sol.sol))
        if sol.status < 0:
            stop = (t1, f"in the chart about axis {axis + 1}: {sol.message}")
            break
        if sol.status == 0:
            break
        z = sol.y[:, -1]
        m1 = sa.charts[axis].inverse(z[:2], G)
        R1 = sa.attitude(S, z[2], z[1], z[0], G, axis)
        new = int(np.argmin(np.abs(m1)))
        switches.append((t1, axis + 1, new + 1))
        y = sa.chart_coordinates(S, R1, m1, G, new)
        axis, start = new, t1
    n = len(times)
    lLphi = np.full((n, 3), np.nan)
    axes = np.full(n, -1)
    done = np.zeros(n, dtype=bool)
    for k, (a, b, ax, dense) in enumerate(segments):
        last = k == len(segments) - 1
        u, lo, hi = sign * times, sign * a, sign * b
        sel = (~done) & (u >= lo) & ((u <= hi) if last else (u < hi))
        if np.any(sel):
            lLphi[sel] = np.asarray(dense(times[sel])).T
            axes[sel] = ax
            done |= sel
    m = np.full((n, 3), np.nan)
    R = np.full((n, 3, 3), np.nan)
    for ax in range(3):
        sel = done & (axes == ax)
        if np.any(sel):
            l, L, phi = lLphi[sel, 0], lLphi[sel, 1], lLphi[sel, 2]
            m[sel] = sa.charts[ax].inverse(np.stack([l, L], -1), G)
            R[sel] = sa.attitude(S, phi, L, l, G, ax)
    failure = None
    if stop is not None:
        k = int(np.argmin(done)) if not done.all() else n
        failure = Failure(Status.ADAPTIVE_FAILED, (), k, stop[0], float("nan"), stop[1])
    return AtlasRun(m, R, lLphi, np.where(done, axes + 1.0, np.nan), switches, failure, nfev)
