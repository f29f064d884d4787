"""The result of a nonholonomic simulation, :class:`NonholonomicTrajectory`, and how the simulators fill it
(times, accelerations and multipliers, constraint forces, energy and work)."""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ... import _validate as V
from ...errors import InputError, NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from ...systems.nonholonomic import NonholonomicSystem
from ._inputs import _Setup


# --------------------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class NonholonomicTrajectory:
    """A simulated motion.

    Attributes
    ----------
    t : (N,) times; q, qd : (N, n) coordinates and velocities; p : (N, m) nonholonomic momentum;
    tau : (N, sigma) shape forces (given, or required by the gait); energy : (N,);
    residual : (N, c) constraint residual :math:`A(q)\\dot q`; work : (N,) work done by the shape forces;
    method, status (0 = success), message, nfev.
    """

    system: NonholonomicSystem = field(repr=False)
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    p: np.ndarray
    tau: np.ndarray
    energy: np.ndarray
    residual: np.ndarray
    work: np.ndarray
    method: str
    status: int = 0
    message: str = ""
    nfev: int = 0

    @property
    def max_residual(self) -> float:
        return float(np.abs(self.residual).max(initial=0.0))

    def final(self) -> dict[str, float]:
        """Final coordinates by name."""
        return {s.name: float(v) for s, v in zip(self.system.q, self.q[-1])}

    def summary(self) -> dict[str, Any]:
        s = self.system
        return {
            "system": s.name,
            "method": self.method,
            "t_final": float(self.t[-1]),
            "initial_velocity": {v.name: float(x) for v, x in zip(s.qdot, self.qd[0])},
            "initial_momentum": [float(x) for x in self.p[0]],
            "final_configuration": self.final(),
            "final_velocity": {v.name: float(x) for v, x in zip(s.qdot, self.qd[-1])},
            "nonholonomic_momentum": [float(x) for x in self.p[-1]],
            "constraint_residual_max": self.max_residual,
            "constraint_residual_final": float(np.abs(self.residual[-1]).max(initial=0.0)),
            "work_by_shape_inputs": float(self.work[-1]),
            "energy_initial": float(self.energy[0]),
            "energy_final": float(self.energy[-1]),
            "energy_change_minus_work": float(self.energy[-1] - self.energy[0] - self.work[-1]),
            "status": self.status,
            "message": self.message,
        }

    def to_dataset(self) -> Any:
        """The trajectory as a self-describing :class:`xarray.Dataset` (write it with ``.to_netcdf``)."""
        import xarray as xr

        from ..._version import __version__

        s = self.system
        return xr.Dataset(
            {
                "q": (("t", "coordinate"), self.q, {"long_name": "generalized coordinates (group, then shape)"}),
                "qdot": (("t", "coordinate"), self.qd, {"long_name": "generalized velocities"}),
                "p": (("t", "momentum_index"), self.p, {"long_name": "nonholonomic momentum (BKMM basis)"}),
                "tau": (("t", "shape"), self.tau, {"long_name": "generalized force on each shape variable"}),
                "energy": ("t", self.energy, {"long_name": "energy (kinetic plus potential)"}),
                "work": ("t", self.work, {"long_name": "work done by the shape inputs since the start"}),
                "constraint_residual": (("t", "constraint"), self.residual, {"long_name": "A(q) qdot"}),
            },
            coords={
                "t": ("t", self.t, {"long_name": "time"}),
                "coordinate": [x.name for x in s.q],
                "shape": [r.name for r in s.shape],
                "momentum_index": np.arange(self.p.shape[1]) + 1,
                "constraint": np.arange(s.c) + 1,
            },
            attrs={
                "system": s.name,
                "group": s.group.name,
                "method": self.method,
                "status": self.status,
                "message": self.message,
                "geomech_version": __version__,
                "parameters": json.dumps({str(k): float(v) for k, v in s.parameters.items()}),
            },
        )

    def to_csv(self, path: str | Path) -> Path:
        """Write the trajectory (one row per time) to ``path``."""
        s = self.system
        cols = (
            ["t"]
            + [x.name for x in s.q]
            + [v.name for v in s.qdot]
            + [f"p{i + 1}" for i in range(self.p.shape[1])]
            + [f"tau_{r.name}" for r in s.shape]
            + ["energy", "work"]
            + [f"residual{a + 1}" for a in range(s.c)]
        )
        data = np.column_stack([self.t, self.q, self.qd, self.p, self.tau, self.energy, self.work, self.residual])
        path = Path(path)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            w.writerows(data.tolist())
        return path


def _finish(
    setup: _Setup,
    method: str,
    t: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    work: np.ndarray,
    parameters: Mapping | None,
    status: int = 0,
    message: str = "",
    nfev: int = 0,
) -> NonholonomicTrajectory:
    s = setup.system
    lda = lagrange_dalembert(s).numeric(parameters)
    rn = bkmm_reduction(s).numeric(parameters)
    return NonholonomicTrajectory(
        s,
        t,
        q,
        qd,
        rn.momentum(q, qd).reshape(len(t), -1),
        tau,
        lda.energy(q, qd),
        lda.constraint_residual(q, qd).reshape(len(t), s.c),
        work,
        method,
        status,
        message,
        nfev,
    )


def _time_grid(t_final: float | None, t_eval: Any, samples: int, t0: float) -> np.ndarray:
    if t_eval is not None:
        te = V.finite(t_eval, "t_eval").ravel()
        if te.size < 2 or np.any(np.diff(te) <= 0):
            raise InputError("Expected `t_eval` to be increasing with at least two times.")
        return te
    if t_final is None:
        raise InputError("Expected `t_final` or `t_eval`: give the end time of the simulation or its output times.")
    tf = float(t_final)
    if not np.isfinite(tf) or tf <= t0:
        raise InputError(f"Expected `t_final` > t0 = {t0}, got {t_final!r}.")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 2 <= samples <= 10**7:
        raise InputError(f"Expected `samples` to be an integer from 2 to 1e7, got {samples!r}.")
    te = np.linspace(t0, tf, int(samples))
    if np.any(np.diff(te) <= 0):
        raise InputError(
            f"Expected `t_final` - t0 = {tf - t0:.3g} to be resolvable into {samples} distinct times "
            "in double precision; take a longer span or fewer samples."
        )
    return te


# --------------------------------------------------------------------------------------------------
# (a) full equations with multipliers
# --------------------------------------------------------------------------------------------------
def _accelerations(
    setup: _Setup, funcs: dict, t: float, q: np.ndarray, qd: np.ndarray, rdd_p: np.ndarray, baumgarte: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Accelerations of the free coordinates, multipliers and the full shape-force vector at one state."""
    s = setup.system
    x = np.r_[q, qd]
    M, f, A, Adq = funcs["M"](x), funcs["f"](x)[:, 0], funcs["A"](x).reshape(s.c, s.n), funcs["Adq"](x)[:, 0]
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    tau_f = setup.torques(t, q, qd)
    F = f.copy()
    F[[s.k + i for i in setup.free_shapes]] += tau_f
    nf, c, npr = len(fr), s.c, len(pr)
    K = np.zeros((s.n + c, nf + c + npr))
    K[: s.n, :nf] = M[:, fr]
    K[: s.n, nf : nf + c] = -A.T
    for j, i in enumerate(pr):
        K[i, nf + c + j] = -1.0
    K[s.n :, :nf] = A[:, fr]
    rhs = np.r_[F - M[:, pr] @ rdd_p, -Adq - A[:, pr] @ rdd_p - 2.0 * baumgarte * (A @ qd)]
    try:
        z = np.linalg.solve(K, rhs)
    except np.linalg.LinAlgError as exc:
        raise NumericalError(f"The constrained equations are singular at t = {t:.6g}, q = {q}.") from exc
    tau = np.zeros(s.sigma)
    tau[setup.free_shapes] = tau_f
    tau[setup.prescribed] = z[nf + c :]
    return z[:nf], z[nf : nf + c], tau
