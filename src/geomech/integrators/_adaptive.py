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
    times: np.ndarray,
    tolerances: tuple[float, float],
    OUT: np.ndarray,
    INFO: np.ndarray,
) -> int:
    """Integrate each row of ``Y0`` from ``t0`` with ``method`` (an AdaptiveAdams), saving at ``times`` and
    filling ``OUT`` and ``INFO`` as the compiled loops do (``INFO[b, 1]`` is the index of the first output
    time not reached); returns the number of internal steps taken (summed over the batch)."""
    rhs = module.rhs
    d = Y0.shape[1]
    rtol, atol = tolerances
    steps_total = 0
    for b in range(Y0.shape[0]):
        count = [0]
        buf = np.empty(d)

        def f(_t: float, y: np.ndarray, count: list = count, buf: np.ndarray = buf) -> np.ndarray:
            count[0] += 1
            rhs(np.ascontiguousarray(y, dtype=float), buf)
            return buf.copy()

        solver = ode(f)
        options: dict[str, Any] = {"rtol": rtol, "atol": atol, "nsteps": method.max_steps}
        if method.solver == "vode":
            options["method"] = "adams"
        solver.set_integrator(method.solver, **options)
        solver.set_initial_value(Y0[b], t0)
        for k, t in enumerate(times):
            if t == t0:
                OUT[b, k] = Y0[b]
                continue
            with warnings.catch_warnings():
                # VODE/LSODA report trouble as a warning and an unsuccessful flag; the flag is what counts
                warnings.simplefilter("ignore", UserWarning)
                y = solver.integrate(t)
            if not solver.successful() or not np.all(np.isfinite(y)):
                INFO[b, 0] = 4 if not solver.successful() else 2
                INFO[b, 1] = k
                INFO[b, 2] = np.nan
                OUT[b, k:] = np.nan
                break
            OUT[b, k] = y
        INFO[b, 4] = count[0]
        iwork = getattr(getattr(solver, "_integrator", None), "iwork", None)
        if iwork is not None and len(iwork) > 10:
            steps_total += int(iwork[10])
    return steps_total
