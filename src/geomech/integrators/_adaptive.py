"""The variable-order adaptive Adams method, wrapped from scipy's VODE / LSODA, output every ``h``."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from scipy.integrate import ode

__all__ = ["run_adaptive"]


def run_adaptive(
    module: Any,
    method: Any,
    Y0: np.ndarray,
    t0: float,
    h: float,
    nsteps: int,
    save_every: int,
    OUT: np.ndarray,
    INFO: np.ndarray,
) -> int:
    """Integrate each row of ``Y0`` with ``method`` (an AdaptiveAdams), filling ``OUT`` and ``INFO`` as the
    compiled loops do; returns the number of internal steps taken (summed over the batch)."""
    rhs = module.rhs
    d = Y0.shape[1]
    steps_total = 0
    save_steps = list(range(save_every, nsteps + 1, save_every))
    if not save_steps or save_steps[-1] != nsteps:
        save_steps.append(nsteps)
    for b in range(Y0.shape[0]):
        count = [0]
        buf = np.empty(d)

        def f(_t: float, y: np.ndarray, count: list = count, buf: np.ndarray = buf) -> np.ndarray:
            count[0] += 1
            rhs(np.ascontiguousarray(y, dtype=float), buf)
            return buf.copy()

        solver = ode(f)
        options: dict[str, Any] = {"rtol": method.rtol, "atol": method.atol, "nsteps": method.max_steps}
        if method.solver == "vode":
            options["method"] = "adams"
        solver.set_integrator(method.solver, **options)
        solver.set_initial_value(Y0[b], t0)
        OUT[b, 0] = Y0[b]
        reached = 0
        for isave, k in enumerate(save_steps, start=1):
            with warnings.catch_warnings():
                # VODE/LSODA report trouble as a warning and an unsuccessful flag; the flag is what counts
                warnings.simplefilter("ignore", UserWarning)
                y = solver.integrate(t0 + k * h)
            if not solver.successful() or not np.all(np.isfinite(y)):
                INFO[b, 0] = 4 if not solver.successful() else 2
                INFO[b, 1] = reached + 1  # the first step past the last state reached
                INFO[b, 2] = np.nan
                OUT[b, isave:] = np.nan
                break
            OUT[b, isave] = y
            reached = k
        INFO[b, 4] = count[0]
        iwork = getattr(getattr(solver, "_integrator", None), "iwork", None)
        if iwork is not None and len(iwork) > 10:
            steps_total += int(iwork[10])
    return steps_total
