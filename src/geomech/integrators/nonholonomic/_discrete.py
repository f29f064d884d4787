"""The discrete Lagrange-d'Alembert integrator, :func:`simulate_discrete` (midpoint discrete Lagrangian)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import sympy as sp

from ... import _validate as V
from ...errors import ConvergenceError, InputError, NumericalError
from ...reduction import lagrange_dalembert
from ...symbolic.compile import compile_vector
from ...systems.nonholonomic import NonholonomicSystem
from ._inputs import _setup, initial_state
from ._trajectory import NonholonomicTrajectory, _accelerations, _finish


# --------------------------------------------------------------------------------------------------
# (c) discrete Lagrange-d'Alembert
# --------------------------------------------------------------------------------------------------
class _DiscreteKernels:
    """Compiled derivatives of L and A for the midpoint discrete Lagrangian."""

    def __init__(self, system: NonholonomicSystem, parameters: Mapping | None):
        s = system
        pv = s.parameter_values(parameters)
        L = s.lagrangian.subs(pv)
        q, v = list(s.q), list(s.qdot)
        Lq = sp.Matrix([sp.diff(L, a) for a in q])
        Lv = sp.Matrix([sp.diff(L, a) for a in v])
        x = q + v
        self.Lq = compile_vector(list(Lq), x)
        self.Lv = compile_vector(list(Lv), x)
        self.Lqq = compile_vector(Lq.jacobian(q).tolist(), x)
        self.Lqv = compile_vector(Lq.jacobian(v).tolist(), x)
        self.Lvv = compile_vector(Lv.jacobian(v).tolist(), x)
        A = sp.Matrix(s.constraint_matrix).subs(pv)
        self.A = compile_vector(A.tolist(), q)
        dA = [[[sp.diff(A[a, i], qj) for qj in q] for i in range(s.n)] for a in range(s.c)]
        self.dA = compile_vector(dA, q) if s.c else None


def simulate_discrete(
    system: NonholonomicSystem,
    t_final: float,
    h: float,
    *,
    shapes: Any = None,
    tau: Any = None,
    q0: Any = None,
    qd0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    t0: float = 0.0,
    parameters: Mapping[str, float] | None = None,
    tol: float = 1e-12,
    max_iter: int = 30,
    max_steps: int = 1_000_000,
) -> NonholonomicTrajectory:
    r"""The discrete Lagrange-d'Alembert integrator with the midpoint rule, method (c); second order.

    Fixed step ``h`` (``t_final - t0`` is rounded to a whole number of steps). The velocity reported at a node
    is the discrete Legendre transform :math:`D_2L_d + \tfrac h2\bar F`, projected on :math:`\mathcal D` with
    the kinetic metric; the work is :math:`\sum_k h\,\tau_{k+1/2}\cdot(r_{k+1} - r_k)/h`.
    """
    setup = _setup(system, shapes, tau)
    s = system
    h = float(h)
    if not np.isfinite(h) or h <= 0:
        raise InputError(f"Expected the step `h` to be positive, got {h!r}.")
    span = (float(V.finite(t_final, "t_final")) - float(V.finite(t0, "t0"))) / h
    V.work_budget(
        span,
        float(max_steps),
        f"The number of steps (t_final - t0 = {span * h:.3g} over h = {h:.3g})",
        "max_steps",
        "take a larger h or a shorter span",
        seconds_each=2e-4,
    )
    nsteps = int(round(span))
    if nsteps < 1:
        raise InputError(f"Expected t_final - t0 >= h, got t_final = {t_final}, t0 = {t0}, h = {h}.")
    h = (float(t_final) - t0) / nsteps
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qd0=qd0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    ker = _DiscreteKernels(system, parameters)
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    shape_free = [s.k + i for i in setup.free_shapes]
    nf, c, n = len(fr), s.c, s.n

    def mid(q0_: np.ndarray, q1_: np.ndarray) -> np.ndarray:
        return np.r_[(q0_ + q1_) / 2, (q1_ - q0_) / h]

    def D1(q0_, q1_):
        x = mid(q0_, q1_)
        return h / 2 * ker.Lq(x) - ker.Lv(x)

    def D2(q0_, q1_):
        x = mid(q0_, q1_)
        return h / 2 * ker.Lq(x) + ker.Lv(x)

    def forcing(t_mid: float, q0_, q1_) -> np.ndarray:
        F = np.zeros(n)
        x = mid(q0_, q1_)
        F[shape_free] = setup.torques(t_mid, x[:n], x[n:])
        return F

    def dD1_dq1(q0_, q1_):
        x = mid(q0_, q1_)
        Lqq, Lqv, Lvv = ker.Lqq(x), ker.Lqv(x), ker.Lvv(x)
        return h / 2 * (Lqq / 2 + Lqv / h) - (Lqv.T / 2 + Lvv / h)

    def prescribed_at(t: float) -> np.ndarray:
        return setup.gait(t)[0]

    def newton(q0_, guess, base, t_next, lam_weight):
        """Solve base + D1(q0, q1) + h/2 F(k+1/2) + lam_weight A(q0)^T lam = 0 (free rows), A(mid)(q1 - q0) = 0."""
        q1 = guess.copy()
        q1[pr] = prescribed_at(t_next)
        lam = np.zeros(c)
        A0 = ker.A(q0_).reshape(c, n)
        for it in range(max_iter):
            tm = t_next - h / 2
            R1 = base + D1(q0_, q1) + h / 2 * forcing(tm, q0_, q1) + lam_weight * A0.T @ lam
            qm = (q0_ + q1) / 2
            Am = ker.A(qm).reshape(c, n)
            R2 = Am @ (q1 - q0_)
            R = np.r_[R1[fr], R2]
            scale = 1.0 + np.abs(base).max(initial=0.0)
            if np.abs(R).max(initial=0.0) < tol * scale and it > 0:
                return q1, lam
            J = np.zeros((nf + c, nf + c))
            J[:nf, :nf] = dD1_dq1(q0_, q1)[np.ix_(fr, fr)]
            J[:nf, nf:] = lam_weight * A0.T[fr]
            if c:
                dA = ker.dA(qm).reshape(c, n, n)
                J[nf:, :nf] = (Am + 0.5 * np.einsum("aij,i->aj", dA, q1 - q0_))[:, fr]
            try:
                dz = np.linalg.solve(J, -R)
            except np.linalg.LinAlgError as exc:
                raise NumericalError(f"simulate_discrete: singular Newton matrix at t = {t_next:.6g}.") from exc
            q1 = q1.copy()
            q1[fr] += dz[:nf]
            lam = lam + dz[nf:]
        raise ConvergenceError(
            f"simulate_discrete: Newton did not converge in {max_iter} iterations at "
            f"t = {t_next:.6g} (step {h:.3g}, residual {np.abs(R).max():.3g}); reduce h."
        )

    lda = lagrange_dalembert(system).numeric(parameters)
    times = t0 + h * np.arange(nsteps + 1)
    Q = np.empty((nsteps + 1, n))
    Q[0] = q_init
    p_plus = ker.Lv(np.r_[q_init, qd_init])
    tau_mid = np.zeros((nsteps, s.sigma))
    work = np.zeros(nsteps + 1)
    for k in range(nsteps):
        # First step: the continuous momentum p0 stands for D2 L_d of a previous step; half the impulse.
        if k == 0:
            q1, _ = newton(Q[0], Q[0] + h * qd_init, p_plus, times[1], h / 2)
        else:
            base = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
            q1, _ = newton(Q[k], 2 * Q[k] - Q[k - 1], base, times[k + 1], h)
        Q[k + 1] = q1
    # Node velocities from the discrete Legendre transform, projected on D; shape forces at midpoints.
    QD = np.empty_like(Q)
    QD[0] = qd_init
    for k in range(1, nsteps + 1):
        pk = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
        M = lda.mass_matrix(Q[k])
        A = lda.constraint_matrix(Q[k]).reshape(c, n)
        Kmat = np.block([[M, -A.T], [A, np.zeros((c, c))]])
        QD[k] = np.linalg.solve(Kmat, np.r_[pk, np.zeros(c)])[:n]
    for k in range(nsteps):
        x = mid(Q[k], Q[k + 1])
        tm = times[k] + h / 2
        tau_v = np.zeros(s.sigma)
        tau_v[setup.free_shapes] = setup.torques(tm, x[:n], x[n:])
        if pr:
            # Forces realising the gait, from the continuous equations at the midpoint state (O(h^2) accurate).
            _, _, rdd_p = setup.gait(tm)
            _, _, tau_full = _accelerations(setup, lda.funcs, tm, x[:n], x[n:], rdd_p)
            tau_v[setup.prescribed] = tau_full[setup.prescribed]
        tau_mid[k] = tau_v
        work[k + 1] = work[k] + tau_v @ (Q[k + 1, s.k :] - Q[k, s.k :])
    TAU = np.vstack([tau_mid, tau_mid[-1:]]) if nsteps else np.zeros((1, s.sigma))
    out = _finish(
        setup,
        f"discrete Lagrange-d'Alembert (midpoint, h = {h:.3g})",
        times,
        Q,
        QD,
        TAU,
        work,
        parameters,
        0,
        "",
        nsteps,
    )
    # The projected node velocities satisfy the constraints exactly; the honest residual of the scheme is that of
    # the centred difference quotient, A(q_k)(q_{k+1} - q_{k-1}) / 2h = O(h^2) (one-sided at the ends).
    V_fd = np.gradient(Q, times, axis=0, edge_order=2) if nsteps >= 2 else QD
    residual = lda.constraint_residual(Q, V_fd).reshape(nsteps + 1, c)
    return NonholonomicTrajectory(
        out.system,
        out.t,
        out.q,
        out.qd,
        out.p,
        out.tau,
        out.energy,
        residual,
        out.work,
        out.method,
        out.status,
        out.message,
        out.nfev,
    )
