"""The adaptive simulators, :func:`simulate_full` (Lagrange-d'Alembert in coordinates) and
:func:`simulate_reduced` (the BKMM equations), with their work bounded before and during the run."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ... import _validate as V
from ...errors import InputError, NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from ...systems.nonholonomic import NonholonomicSystem
from ._inputs import _group_rates, _setup, initial_state
from ._trajectory import NonholonomicTrajectory, _accelerations, _finish, _time_grid

#: Default ceiling on right-hand-side evaluations of the adaptive simulators (tens of seconds of work).
MAX_EVALUATIONS = 200_000

#: Evaluations after which the pace of the integration is measured and the whole run's cost projected.
_PILOT = 2_000


class _OverBudget(Exception):
    def __init__(self, t: float, count: int, projected: float | None = None):
        self.t, self.count, self.projected = t, count, projected


def _budgeted(rhs: Callable, max_evaluations: Any, t_span: tuple[float, float]) -> Callable:
    """``rhs`` that stops the integration (raising :class:`_OverBudget`) past ``max_evaluations`` calls, or
    early, after a pilot of :data:`_PILOT` calls, when the pace so far projects a total far above it."""
    limit = int(V.positive_scalar(max_evaluations, "max_evaluations"))
    t_start, t_end = t_span
    count = 0
    t_max = t_start

    def counted(t: float, y: np.ndarray) -> np.ndarray:
        nonlocal count, t_max
        count += 1
        t_max = max(t_max, t)
        if count == _PILOT and limit > _PILOT and t_max > t_start:
            projected = count * (t_end - t_start) / (t_max - t_start)
            if projected > 2.0 * limit:
                raise _OverBudget(t, count, projected)
        if count > limit:
            raise _OverBudget(t, count - 1)
        return rhs(t, y)

    return counted


def _integrate(name: str, rhs: Callable, te: np.ndarray, y0: np.ndarray, max_evaluations: Any, **kw: Any) -> Any:
    """solve_ivp within a budget of evaluations; a failure or an exhausted budget says where and why."""
    try:
        sol = solve_ivp(_budgeted(rhs, max_evaluations, (te[0], te[-1])), (te[0], te[-1]), y0, t_eval=te, **kw)
    except _OverBudget as stop:
        if stop.projected is not None:
            raise InputError(
                f"{name}: at the pace of its first {stop.count} evaluations (to t = {stop.t:.6g}) the run to "
                f"{te[-1]:.6g} needs about {min(stop.projected, 1e300):.3g} evaluations of the equations, above "
                f"`max_evaluations` = {int(max_evaluations)}; shorten t_final or raise `max_evaluations`."
            ) from None
        raise NumericalError(
            f"{name}: stopped after {stop.count} evaluations of the equations at t = {stop.t:.6g} of "
            f"{te[-1]:.6g} (`max_evaluations`): the motion is faster, or the time span longer, than the budget "
            "allows; shorten t_final or raise `max_evaluations`."
        ) from None
    if sol.status < 0:
        raise NumericalError(f"{name}: the integrator failed at t = {sol.t[-1]:.6g}: {sol.message}")
    return sol


def simulate_full(
    system: NonholonomicSystem,
    t_final: float | None = None,
    *,
    shapes: Any = None,
    tau: Any = None,
    q0: Any = None,
    qd0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    t0: float = 0.0,
    t_eval: Any = None,
    samples: int = 201,
    parameters: Mapping[str, float] | None = None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    baumgarte: float = 0.0,
    max_evaluations: int = MAX_EVALUATIONS,
) -> NonholonomicTrajectory:
    """Integrate the Lagrange-d'Alembert equations with multipliers (the index-reduced DAE), method (a).

    Parameters
    ----------
    system : NonholonomicSystem
    t_final : float
        Final time (or give ``t_eval``).
    shapes : mapping or Gait, optional
        Prescribed shapes, ``{"psi": "sin(2*pi*t)"}``; the others are free.
    tau : mapping, optional
        Torques on free shapes, formulas in ``t``, coordinates and velocities, or callables ``f(t, q, qd)``.
    q0, qd0, rdot0, p0 :
        Initial state, see :func:`initial_state`.
    parameters : mapping, optional
        Parameter values not stored in the system.
    method, rtol, atol :
        Passed to :func:`scipy.integrate.solve_ivp`.
    baumgarte : float
        :math:`\\alpha \\ge 0` of the stabilised constraint :math:`A\\ddot q + \\dot A\\dot q + 2\\alpha A\\dot q = 0`.
    max_evaluations : int
        Ceiling on evaluations of the equations (default 200,000, tens of seconds): past it the integration
        stops with a :class:`~geomech.errors.NumericalError` saying at which time.

    Returns
    -------
    NonholonomicTrajectory
    """
    setup = _setup(system, shapes, tau)
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qd0=qd0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    te = _time_grid(t_final, t_eval, samples, t0)
    funcs = lagrange_dalembert(system).numeric(parameters).funcs
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    nf = len(fr)

    def full_state(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd = np.empty(system.n), np.empty(system.n)
        q[fr], qd[fr] = y[:nf], y[nf : 2 * nf]
        r_p, rd_p, rdd_p = setup.gait(t)
        q[pr], qd[pr] = r_p, rd_p
        return q, qd, rdd_p

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, rdd_p = full_state(t, y)
        a, _, tau_v = _accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)
        return np.r_[qd[fr], a, tau_v @ qd[system.k :]]

    y0 = np.r_[q_init[fr], qd_init[fr], 0.0]
    sol = _integrate("simulate_full", rhs, te, y0, max_evaluations, method=method, rtol=rtol, atol=atol)
    Q, QD, TAU = [], [], []
    for t, y in zip(sol.t, sol.y.T):
        q, qd, rdd_p = full_state(t, y)
        TAU.append(_accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)[2])
        Q.append(q)
        QD.append(qd)
    return _finish(
        setup,
        f"full ({method})",
        sol.t,
        np.array(Q),
        np.array(QD),
        np.array(TAU).reshape(len(sol.t), -1),
        sol.y[-1],
        parameters,
        sol.status,
        sol.message,
        sol.nfev,
    )


# --------------------------------------------------------------------------------------------------
# (b) reduced equations
# --------------------------------------------------------------------------------------------------
def simulate_reduced(
    system: NonholonomicSystem,
    t_final: float | None = None,
    *,
    shapes: Any = None,
    tau: Any = None,
    q0: Any = None,
    qd0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    t0: float = 0.0,
    t_eval: Any = None,
    samples: int = 201,
    parameters: Mapping[str, float] | None = None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_evaluations: int = MAX_EVALUATIONS,
) -> NonholonomicTrajectory:
    """Integrate the BKMM equations (1.1)-(1.3): momentum, shape and reconstruction, method (b).

    Same arguments as :func:`simulate_full`. The state is ``(g, r_free, rdot_free, p, W)``; the group
    coordinates follow :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi(r, \\dot r, p)`.
    """
    setup = _setup(system, shapes, tau)
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qd0=qd0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    te = _time_grid(t_final, t_eval, samples, t0)
    red = bkmm_reduction(system)
    rn = red.numeric(parameters)
    rates = _group_rates(system)
    k, sigma, m = system.k, system.sigma, red.m
    F, P = setup.free_shapes, setup.prescribed
    nF = len(F)

    def unpack(t: float, y: np.ndarray):
        g = y[:k]
        r, rd = np.empty(sigma), np.empty(sigma)
        r[F], rd[F] = y[k : k + nF], y[k + nF : k + 2 * nF]
        r_p, rd_p, rdd_p = setup.gait(t)
        r[P], rd[P] = r_p, rd_p
        p = y[k + 2 * nF : k + 2 * nF + m]
        return g, r, rd, rdd_p, p

    def evaluate(t: float, y: np.ndarray):
        g, r, rd, rdd_p, p = unpack(t, y)
        xi = rn.xi(r, rd, p)
        q, qd = np.r_[g, r], np.r_[rates(g) @ xi, rd]
        tau_f = setup.torques(t, q, qd)
        M, delta = rn.shape_mass(r, rd, p), rn.delta(r, rd, p)
        # Unknowns: free shape accelerations and the forces that realise the gait.
        K = np.zeros((sigma, sigma))
        K[:, :nF] = M[:, F]
        for j, i in enumerate(P):
            K[i, nF + j] = -1.0
        b = delta.copy()
        b[F] += tau_f
        b -= M[:, P] @ rdd_p
        z = np.linalg.solve(K, b) if sigma else np.zeros(0)
        tau_v = np.zeros(sigma)
        tau_v[F], tau_v[P] = tau_f, z[nF:]
        return q, qd, xi, z[:nF], tau_v, rn.pdot(r, rd, p)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, _, rdd_f, tau_v, pdot = evaluate(t, y)
        return np.r_[qd[:k], qd[k:][F], rdd_f, pdot, tau_v @ qd[k:]]

    p_init = rn.momentum(q_init, qd_init)
    y0 = np.r_[q_init[:k], q_init[k:][F], qd_init[k:][F], p_init, 0.0]
    sol = _integrate("simulate_reduced", rhs, te, y0, max_evaluations, method=method, rtol=rtol, atol=atol)
    Q, QD, TAU = [], [], []
    for t, y in zip(sol.t, sol.y.T):
        q, qd, _, _, tau_v, _ = evaluate(t, y)
        Q.append(q)
        QD.append(qd)
        TAU.append(tau_v)
    return _finish(
        setup,
        f"reduced ({method})",
        sol.t,
        np.array(Q),
        np.array(QD),
        np.array(TAU).reshape(len(sol.t), -1),
        sol.y[-1],
        parameters,
        sol.status,
        sol.message,
        sol.nfev,
    )
