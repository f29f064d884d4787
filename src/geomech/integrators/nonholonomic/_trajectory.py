"""What the engines of a Lagrangian run share: their raw result, the quantities the Solution carries
(energy, nonholonomic momentum, shape forces, work, constraint residual), and the accelerations, multipliers
and constraint forces at one state."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from ..solution import Failure
from ._inputs import _Setup, body_momentum


@dataclass
class _Raw:
    """What an engine returns: the saved coordinates, velocities and shape forces (NaN rows past a failure),
    the work done, the :class:`~geomech.integrators.Failure` or None,
    the number of evaluations, and, where the scheme defines its own, the constraint residual."""

    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    work: np.ndarray
    failure: Failure | None
    nfev: int
    residual: np.ndarray | None = None
    steps: int = 0
    backend: str = "python"
    compile_time: float = 0.0
    loop_time: float | None = None  # the compiled loop alone, where there is one
    energy: np.ndarray | None = None  # where the engine computed them (a compiled run's observation)
    momentum: np.ndarray | None = None
    events: dict[str, np.ndarray] = field(default_factory=dict)  # Solution.events (a compiled run's)
    newton: int = 0  # Newton's iterations (the discrete map's linear solves), over the run
    variational: dict[str, np.ndarray] = field(default_factory=dict)  # a compiled run's stm and sensitivities


def quantities(setup: _Setup, raw: _Raw, parameters: Mapping | None) -> dict[str, np.ndarray]:
    """The Solution's quantities of a Lagrangian run: energy, nonholonomic momentum, shape forces, work and
    constraint residual, and without constraints the spatial momentum (the momentum map
    :math:`J = \\mathrm{Ad}^*_{g^{-1}}p`, conserved), NaN where the run did not reach."""
    s = setup.system
    N = len(raw.q)
    if raw.energy is not None and raw.momentum is not None and raw.residual is not None:
        energy, momentum, residual = raw.energy, raw.momentum, raw.residual  # a compiled run observed them
    else:
        # without constraints the momentum is the body momentum, computed without deriving the reduction
        m = s.k if s.c == 0 else bkmm_reduction(s).m
        ok = np.all(np.isfinite(raw.q), axis=1) & np.all(np.isfinite(raw.qd), axis=1)
        momentum = np.full((N, m), np.nan)
        energy = np.full(N, np.nan)
        residual = np.full((N, s.c), np.nan)
        if raw.energy is not None and raw.momentum is not None:
            energy, momentum = raw.energy, raw.momentum
        elif ok.any():
            q, qd = raw.q[ok], raw.qd[ok]
            lda = lagrange_dalembert(s).numeric(parameters)
            momentum[ok] = (
                body_momentum(s, lda, q, qd)
                if s.c == 0
                else bkmm_reduction(s).numeric(parameters).momentum(q, qd).reshape(len(q), -1)
            )
            energy[ok] = lda.energy(q, qd)
            residual[ok] = lda.constraint_residual(q, qd).reshape(len(q), s.c)
        if raw.residual is not None:
            residual = raw.residual
    return {
        "energy": energy,
        "momentum": momentum,
        "tau": raw.tau,
        "work": raw.work,
        "constraint_residual": residual,
        **({"spatial_momentum": spatial_momentum(s, raw.q, momentum)} if s.c == 0 else {}),
        **raw.variational,
    }


def spatial_momentum(system: Any, q: np.ndarray, momentum: np.ndarray) -> np.ndarray:
    """The momentum map :math:`J = \\mathrm{Ad}^*_{g^{-1}}p` of a system without constraints at the states
    ``(..., n)`` and body momenta ``(..., k)``, NaN where they are not finite."""
    G, k = system.group, system.k
    out = np.full(momentum.shape, np.nan)
    flat_q, flat_p, flat_out = q.reshape(-1, q.shape[-1]), momentum.reshape(-1, k), out.reshape(-1, k)
    for i in np.flatnonzero(np.all(np.isfinite(flat_q), axis=1) & np.all(np.isfinite(flat_p), axis=1)):
        flat_out[i] = G.numeric.Ad(G.numeric.inverse(G.from_coordinates(flat_q[i, :k]))).T @ flat_p[i]
    return out


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
