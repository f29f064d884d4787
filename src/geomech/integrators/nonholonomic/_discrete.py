"""The discrete Lagrange-d'Alembert integrator (:class:`~geomech.integrators.DiscreteLagrangeDAlembert`, the
midpoint discrete Lagrangian), the engine of :func:`~geomech.solve` for it."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import sympy as sp

from ...reduction import lagrange_dalembert
from ...symbolic.compile import compile_vector
from ...systems.nonholonomic import NonholonomicSystem
from .._k_common import newton_done
from ..solution import Failure, Status
from ._inputs import _Setup
from ._trajectory import _accelerations, _Raw


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


def run_discrete(
    setup: _Setup,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    h: float,
    nsteps: int,
    newton_tol: float,
    max_newton: int,
    parameters: Mapping[str, float] | None,
) -> _Raw:
    r"""The discrete Lagrange-d'Alembert integrator with the midpoint rule on the grid ``t0 + k h``, k = 0..nsteps.

    The velocity reported at a node is the discrete Legendre transform :math:`D_2L_d + \tfrac h2\bar F`,
    projected on :math:`\mathcal D` with the kinetic metric; the work is
    :math:`\sum_k h\,\tau_{k+1/2}\cdot(r_{k+1} - r_k)/h`. A Newton failure ends the run: the later nodes are
    NaN and the failure is returned as data.
    """
    system = s = setup.system
    tol, max_iter = newton_tol, max_newton
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
        dprev = 0.0
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
            except np.linalg.LinAlgError:
                raise _StepFailed(Status.SINGULAR_JACOBIAN, float(np.abs(R).max()), "") from None
            q1 = q1.copy()
            q1[fr] += dz[:nf]
            lam = lam + dz[nf:]
            dnorm = float(np.abs(dz).max(initial=0.0))
            if newton_done(dnorm, dprev, it, max(1.0, float(np.abs(q1).max())), tol):
                return q1, lam
            dprev = dnorm
        raise _StepFailed(
            Status.NEWTON_FAILED,
            float(np.abs(R).max()),
            f"no convergence in {max_iter} iterations (step {h:.3g}); reduce h or raise max_newton",
        )

    lda = lagrange_dalembert(system).numeric(parameters)
    times = t0 + h * np.arange(nsteps + 1)
    Q = np.full((nsteps + 1, n), np.nan)
    Q[0] = q_init
    p_plus = ker.Lv(np.r_[q_init, qd_init])
    tau_mid = np.full((nsteps, s.sigma), np.nan)
    work = np.full(nsteps + 1, np.nan)
    work[0] = 0.0
    failure: Failure | None = None
    reached = nsteps
    for k in range(nsteps):
        # First step: the continuous momentum p0 stands for D2 L_d of a previous step; half the impulse.
        try:
            if k == 0:
                q1, _ = newton(Q[0], Q[0] + h * qd_init, p_plus, times[1], h / 2)
            else:
                base = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
                q1, _ = newton(Q[k], 2 * Q[k] - Q[k - 1], base, times[k + 1], h)
        except _StepFailed as why:
            failure = Failure(why.status, (), k + 1, float(times[k]), why.residual, why.detail)
            reached = k
            break
        if not np.all(np.isfinite(q1)):
            failure = Failure(Status.NONFINITE, (), k + 1, float(times[k]), float("nan"))
            reached = k
            break
        Q[k + 1] = q1
    # Node velocities from the discrete Legendre transform, projected on D; shape forces at midpoints.
    QD = np.full_like(Q, np.nan)
    QD[0] = qd_init
    for k in range(1, reached + 1):
        pk = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
        M = lda.mass_matrix(Q[k])
        A = lda.constraint_matrix(Q[k]).reshape(c, n)
        Kmat = np.block([[M, -A.T], [A, np.zeros((c, c))]])
        QD[k] = np.linalg.solve(Kmat, np.r_[pk, np.zeros(c)])[:n]
    for k in range(reached):
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
    # The projected node velocities satisfy the constraints exactly; the honest residual of the scheme is that of
    # the centred difference quotient, A(q_k)(q_{k+1} - q_{k-1}) / 2h = O(h^2) (one-sided at the ends).
    residual = np.full((nsteps + 1, c), np.nan)
    if reached >= 2:
        V_fd = np.gradient(Q[: reached + 1], times[: reached + 1], axis=0, edge_order=2)
        residual[: reached + 1] = lda.constraint_residual(Q[: reached + 1], V_fd).reshape(reached + 1, c)
    elif reached >= 0:
        residual[: reached + 1] = lda.constraint_residual(Q[: reached + 1], QD[: reached + 1]).reshape(-1, c)
    return _Raw(Q, QD, TAU, work, failure, reached, residual)


class _StepFailed(Exception):
    def __init__(self, status: Status, residual: float, detail: str):
        self.status, self.residual, self.detail = status, residual, detail
