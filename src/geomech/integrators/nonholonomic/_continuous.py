"""The adaptive engines of :func:`~geomech.solve` for a Lagrangian system: the Lagrange-d'Alembert equations in
coordinates (:class:`~geomech.integrators.LagrangeDAlembert`) and the BKMM equations
(:class:`~geomech.integrators.BKMM`), stepped by scipy's solvers with their work bounded before and during the
run and their failures returned as data with the states reached."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ...errors import NumericalError
from ...reduction import bkmm_reduction, lagrange_dalembert
from .._adaptive import integrate_ivp
from ..solution import Status
from ._inputs import _group_rates, _Setup
from ._trajectory import _accelerations, _Raw

#: A NumericalError raised by the equations of a Lagrangian run: they became singular.
SINGULAR = Status.SINGULAR_CONSTRAINTS


def _rows(
    setup: _Setup, times: np.ndarray, Y: np.ndarray, evaluate: Callable
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, qd, tau) at each saved state that was reached; NaN rows after a failure."""
    ok = np.all(np.isfinite(Y), axis=1)
    n, sigma = setup.system.n, setup.system.sigma
    out = [np.full((len(times), d), np.nan) for d in (n, n, sigma)]
    for i in np.flatnonzero(ok):
        for arr, x in zip(out, evaluate(times[i], Y[i])):
            arr[i] = x
    return out[0], out[1], out[2]


def run_full(
    setup: _Setup,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    parameters: Mapping[str, float] | None,
) -> _Raw:
    """The Lagrange-d'Alembert equations with multipliers (the index-reduced DAE), by ``method.solver``."""
    system = setup.system
    funcs = lagrange_dalembert(system).numeric(parameters).funcs
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    nf = len(fr)
    baumgarte = float(method.baumgarte)

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

    def evaluate(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, rdd_p = full_state(t, y)
        return q, qd, _accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)[2]

    y0 = np.r_[q_init[fr], qd_init[fr], 0.0]
    Y, failure, nfev, n_steps = integrate_ivp(
        "LagrangeDAlembert", rhs, y0, t0, times, method.solver, tolerances, max_evaluations, SINGULAR
    )
    Q, QD, TAU = _rows(setup, times, Y, evaluate)
    return _Raw(Q, QD, TAU, Y[:, -1], failure, nfev, steps=n_steps)


def run_reduced(
    setup: _Setup,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    parameters: Mapping[str, float] | None,
) -> _Raw:
    """The BKMM equations (1.1)-(1.3): momentum, shape and reconstruction; the state is
    ``(g, r_free, rdot_free, p, W)`` and the group coordinates follow :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi`."""
    system = setup.system
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

    def evaluate_all(t: float, y: np.ndarray):
        g, r, rd, rdd_p, p = unpack(t, y)
        xi = rn.xi(r, rd, p)
        q, qd = np.r_[g, r], np.r_[rates(g) @ xi, rd]
        tau_f = setup.torques(t, q, qd)
        M, delta = rn.shape_mass(r), rn.delta(r, rd, p)
        # Unknowns: free shape accelerations and the forces that realise the gait.
        K = np.zeros((sigma, sigma))
        K[:, :nF] = M[:, F]
        for j, i in enumerate(P):
            K[i, nF + j] = -1.0
        b = delta.copy()
        b[F] += tau_f
        b -= M[:, P] @ rdd_p
        try:
            z = np.linalg.solve(K, b) if sigma else np.zeros(0)
        except np.linalg.LinAlgError as exc:
            raise NumericalError(f"The shape equations are singular at t = {t:.6g}, q = {q}.") from exc
        tau_v = np.zeros(sigma)
        tau_v[F], tau_v[P] = tau_f, z[nF:]
        return q, qd, xi, z[:nF], tau_v, rn.pdot(r, rd, p)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, _, rdd_f, tau_v, pdot = evaluate_all(t, y)
        return np.r_[qd[:k], qd[k:][F], rdd_f, pdot, tau_v @ qd[k:]]

    def evaluate(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, _, _, tau_v, _ = evaluate_all(t, y)
        return q, qd, tau_v

    p_init = rn.momentum(q_init, qd_init)
    y0 = np.r_[q_init[:k], q_init[k:][F], qd_init[k:][F], p_init, 0.0]
    Y, failure, nfev, n_steps = integrate_ivp(
        "BKMM", rhs, y0, t0, times, method.solver, tolerances, max_evaluations, SINGULAR
    )
    Q, QD, TAU = _rows(setup, times, Y, evaluate)
    return _Raw(Q, QD, TAU, Y[:, -1], failure, nfev, steps=n_steps)
