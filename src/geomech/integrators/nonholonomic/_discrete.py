"""The discrete Lagrange-d'Alembert integrator (:class:`~geomech.integrators.DiscreteLagrangeDAlembert`, with the
midpoint discrete Lagrangian in the coordinates or the group's through its exponential), the engine of
:func:`~geomech.solve` for it."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import sympy as sp

from ...errors import InputError
from ...reduction import lagrange_dalembert
from ...symbolic.compile import compile_vector
from ...systems.nonholonomic import NonholonomicSystem
from .._k_common import newton_done
from ..solution import Failure, Status
from ._compiled_discrete import dlda_module, no_convergence, run_compiled_discrete
from ._inputs import _Setup
from ._trajectory import _accelerations, _Raw


# --------------------------------------------------------------------------------------------------
# (c) discrete Lagrange-d'Alembert
# --------------------------------------------------------------------------------------------------
class _Midpoint:
    """The midpoint discrete Lagrangian in the coordinates, :math:`hL(\\bar q, (q_1 - q_0)/h)`, its constraint
    :math:`A(\\bar q)(q_1 - q_0)`, and their exact derivatives in :math:`q_1` (from the second derivatives of L)."""

    def __init__(self, system: NonholonomicSystem, parameters: Mapping | None, h: float):
        s = system
        self.h, self.n, self.c = h, s.n, s.c
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

    def mid(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        return np.r_[(q0 + q1) / 2, (q1 - q0) / self.h]

    def momentum(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """:math:`\\partial L/\\partial\\dot q`."""
        return self.Lv(np.r_[q, qd])

    def D1(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        x = self.mid(q0, q1)
        return self.h / 2 * self.Lq(x) - self.Lv(x)

    def D2(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        x = self.mid(q0, q1)
        return self.h / 2 * self.Lq(x) + self.Lv(x)

    #: Newton's Jacobian is exact and cheap: refreshed at every iteration
    chord = False

    def residual(self, q0: np.ndarray, q1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:math:`D_1L_d(q_0, q_1)` and the discrete constraint."""
        return self.D1(q0, q1), self.A((q0 + q1) / 2).reshape(self.c, self.n) @ (q1 - q0)

    def jacobians(self, q0: np.ndarray, q1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:math:`\\partial D_1L_d/\\partial q_1` (n x n) and the constraint's derivative in :math:`q_1` (c x n)."""
        h, c, n = self.h, self.c, self.n
        x = self.mid(q0, q1)
        Lqq, Lqv, Lvv = self.Lqq(x), self.Lqv(x), self.Lvv(x)
        JD = h / 2 * (Lqq / 2 + Lqv / h) - (Lqv.T / 2 + Lvv / h)
        JC = np.zeros((c, n))
        if self.dA is not None:
            qm = (q0 + q1) / 2
            JC = self.A(qm).reshape(c, n) + 0.5 * np.einsum("aij,i->aj", self.dA(qm).reshape(c, n, n), q1 - q0)
        return JD, JC


class _GroupLagrangian:
    """The discrete Lagrangian through the group's exponential, :math:`h\\,\\ell(\\bar r, \\chi/h, (r_1 - r_0)/h)`
    with :math:`\\chi = \\log(g_0^{-1}g_1)` and :math:`\\ell` the reduced (body) Lagrangian, and the constraint in
    the body frame :math:`A_\\xi(\\bar r)\\chi + A_r(\\bar r)(r_1 - r_0)`: both invariant under :math:`g \\mapsto
    \\eta g`, whatever the chart. With :math:`\\delta\\chi = J_r^{-1}(\\chi)\\Lambda(q_1)\\delta q_1 -
    J_l^{-1}(\\chi)\\Lambda(q_0)\\delta q_0` (the group's Jacobians of exp; :math:`\\Lambda` the body-velocity
    matrix of the chart),

    .. math::

        D_1L_d = \\bigl(-\\Lambda(q_0)^TJ_l^{-T}(\\chi)\\ell_\\xi,\\ \\tfrac h2\\ell_r - \\ell_{\\dot r}\\bigr),
        \\qquad D_2L_d = \\bigl(\\Lambda(q_1)^TJ_r^{-T}(\\chi)\\ell_\\xi,\\ \\tfrac h2\\ell_r + \\ell_{\\dot r}\\bigr).

    Their derivatives in :math:`q_1` (for Newton) are central differences."""

    def __init__(self, system: NonholonomicSystem, parameters: Mapping | None, h: float):
        s = system
        self.h, self.n, self.c, self.k, self.sigma = h, s.n, s.c, s.k, s.sigma
        self.group = s.group.numeric
        coordinates = list(s.group.coordinates)
        self._g = compile_vector(sp.Matrix(s.group.matrix).tolist(), coordinates)
        self._ginv = compile_vector(sp.Matrix(s.group.inverse).tolist(), coordinates)
        values = {p: sp.Float(v) for p, v in s.parameter_values(parameters).items()}
        ell = s.body_lagrangian.xreplace(values)
        x = list(s.shape) + list(s.xi) + list(s.qdot[s.k :])
        self.grad = compile_vector([sp.diff(ell, v) for v in x], x)
        Axi, Ar = s.body_constraints
        self.A = compile_vector(
            sp.Matrix.hstack(sp.Matrix(Axi), sp.Matrix(Ar)).xreplace(values).tolist(), list(s.shape)
        )
        self.Lam = compile_vector(sp.Matrix(s.group.body_velocity_matrix).tolist(), coordinates)
        L = s.lagrangian.xreplace(values)
        self.Lv = compile_vector([sp.diff(L, v) for v in s.qdot], list(s.q) + list(s.qdot))

    def momentum(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """:math:`\\partial L/\\partial\\dot q`."""
        return self.Lv(np.r_[q, qd])

    #: Newton's Jacobian is a difference quotient: computed once a step (a chord iteration)
    chord = True

    def _parts(self, q0: np.ndarray, q1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:math:`\\chi = \\log(g_0^{-1}g_1)` and :math:`\\ell_r, \\ell_\\xi, \\ell_{\\dot r}` at the step."""
        k, h = self.k, self.h
        chi = self.group.log(self._ginv(q0[:k]) @ self._g(q1[:k]))
        rbar, rd = (q0[k:] + q1[k:]) / 2, (q1[k:] - q0[k:]) / h
        d = self.grad(np.r_[rbar, chi / h, rd])
        return chi, d[: self.sigma], d[self.sigma : self.sigma + k], d[self.sigma + k :]

    def _lam(self, qG: np.ndarray) -> np.ndarray:
        return self.Lam(qG).reshape(self.k, self.k)

    def D2(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        chi, lr, lxi, lrd = self._parts(q0, q1)
        group = self._lam(q1[: self.k]).T @ (self.group.right_jacobian_inverse(chi).T @ lxi)
        return np.r_[group, self.h / 2 * lr + lrd]

    def residual(self, q0: np.ndarray, q1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:math:`D_1L_d(q_0, q_1)` and the discrete constraint."""
        k = self.k
        chi, lr, lxi, lrd = self._parts(q0, q1)
        group = -self._lam(q0[:k]).T @ (self.group.left_jacobian_inverse(chi).T @ lxi)
        constraint = self.A((q0[k:] + q1[k:]) / 2).reshape(self.c, self.n) @ np.r_[chi, q1[k:] - q0[k:]]
        return np.r_[group, self.h / 2 * lr - lrd], constraint

    def jacobians(self, q0: np.ndarray, q1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n, c = self.n, self.c
        JD, JC = np.empty((n, n)), np.empty((c, n))
        for j in range(n):
            e = np.zeros(n)
            e[j] = 1e-6 * (1.0 + abs(q1[j]))
            (Dp, Cp), (Dm, Cm) = self.residual(q0, q1 + e), self.residual(q0, q1 - e)
            JD[:, j], JC[:, j] = (Dp - Dm) / (2 * e[j]), (Cp - Cm) / (2 * e[j])
        return JD, JC


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
    discretization: str = "midpoint",
    backend: str = "auto",
    keep: np.ndarray | None = None,
) -> _Raw:
    r"""The discrete Lagrange-d'Alembert integrator with the ``discretization``'s discrete Lagrangian ("midpoint" or
    "group") on the grid ``t0 + k h``, k = 0..nsteps.

    The velocity reported at a node is the discrete Legendre transform :math:`D_2L_d + \tfrac h2\bar F`,
    projected on :math:`\mathcal D` with the kinetic metric, the prescribed shapes' rates the gait's; the work is
    :math:`\sum_k h\,\tau_{k+1/2}\cdot(r_{k+1} - r_k)/h`, the shape forces :math:`\tau_{k+1/2}` those of the
    continuous equations at the midpoint (the free coordinates' midpoint and difference quotient, the gait at
    :math:`t_{k+1/2}`). A Newton failure ends the run: the later nodes are NaN and the failure is returned as data.
    The map runs compiled (:mod:`._compiled_discrete`) where the gait and torques are formulas (and, for the group's
    discrete Lagrangian, the group has closed-form kernels), unless ``backend`` is "python".
    """
    system = s = setup.system
    compiled = dlda_module(setup, discretization) if backend != "python" else None
    if compiled is None and backend == "numba":
        raise InputError(
            "backend='numba' runs the discrete Lagrange-d'Alembert map where the gait and torques are formulas (and "
            "numba is installed), with the group's discrete Lagrangian on SO(2), R^n, SE(2), SO(3), SE(3) and their "
            f"products ({system.group.name} here): give backend='auto' or 'python' to run it in Python."
        )
    keep = np.arange(nsteps + 1) if keep is None else np.asarray(keep, dtype=int)
    if compiled is not None:
        module, made = compiled
        return run_compiled_discrete(
            module, made, setup, q_init, qd_init, t0, h, nsteps, keep, newton_tol, max_newton, parameters
        )
    tol, max_iter = newton_tol, max_newton
    disc = (_GroupLagrangian if discretization == "group" else _Midpoint)(system, parameters, h)
    lda = lagrange_dalembert(system).numeric(parameters)
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    shape_free = [s.k + i for i in setup.free_shapes]
    nf, c, n = len(fr), s.c, s.n
    D2 = disc.D2

    def forcing(t_mid: float, q0_, q1_) -> np.ndarray:
        F = np.zeros(n)
        F[shape_free] = setup.torques(t_mid, (q0_ + q1_) / 2, (q1_ - q0_) / h)
        return F

    def prescribed_at(t: float) -> np.ndarray:
        return setup.gait(t)[0]

    iterations = 0  # Newton's linear solves, over the run

    def newton(q0_, guess, base, t_next, lam_weight):
        """Solve base + D1(q0, q1) + h/2 F(k+1/2) + lam_weight A(q0)^T lam = 0 (free rows), C(q0, q1) = 0."""
        nonlocal iterations
        q1 = guess.copy()
        q1[pr] = prescribed_at(t_next)
        lam = np.zeros(c)
        dprev = 0.0
        A0 = lda.constraint_matrix(q0_).reshape(c, n)
        J = None
        finishing = False
        for it in range(max_iter):
            tm = t_next - h / 2
            D, C = disc.residual(q0_, q1)
            R1 = base + D + h / 2 * forcing(tm, q0_, q1) + lam_weight * A0.T @ lam
            R = np.r_[R1[fr], C]
            scale = 1.0 + np.abs(base).max(initial=0.0)
            if np.abs(R).max(initial=0.0) < tol * scale and it > 0:
                return q1, lam
            if J is None or not disc.chord:
                JD, JC = disc.jacobians(q0_, q1)
                J = np.zeros((nf + c, nf + c))
                J[:nf, :nf] = JD[np.ix_(fr, fr)]
                J[:nf, nf:] = lam_weight * A0.T[fr]
                J[nf:, :nf] = JC[:, fr]
            try:
                dz = np.linalg.solve(J, -R)
                iterations += 1
            except np.linalg.LinAlgError:
                raise _StepFailed(Status.SINGULAR_JACOBIAN, float(np.abs(R).max()), "") from None
            q1 = q1.copy()
            q1[fr] += dz[:nf]
            lam = lam + dz[nf:]
            if finishing:
                return q1, lam
            dnorm = float(np.abs(dz).max(initial=0.0))
            if newton_done(dnorm, dprev, it, max(1.0, float(np.abs(q1).max())), tol):
                if not disc.chord:
                    return q1, lam
                # a chord iteration converges linearly: one more makes the residual (a momentum, dz's size
                # times |D1| / h) round-off too, so that the discrete momentum map is kept to round-off
                finishing = True
            dprev = dnorm
        raise _StepFailed(
            Status.NEWTON_FAILED,
            float(np.abs(R).max()),
            no_convergence(max_iter, h),
        )

    times = t0 + h * np.arange(nsteps + 1)
    Q = np.full((nsteps + 1, n), np.nan)
    Q[0] = q_init
    p_plus = disc.momentum(q_init, qd_init)
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
    # Node velocities from the discrete Legendre transform, projected on D: the momentum's free rows, the gait's
    # rates for the prescribed shapes (whose rows hold the unknown force realising the gait: were they read from
    # the momentum, the force's missing impulse h/2 tau would make the velocity, and the energy, O(h) wrong).
    QD = np.full_like(Q, np.nan)
    QD[0] = qd_init
    for k in range(1, reached + 1):
        pk = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
        M = lda.mass_matrix(Q[k])
        A = lda.constraint_matrix(Q[k]).reshape(c, n)
        qd = np.zeros(n)
        qd[pr] = setup.gait(times[k])[1]
        Kmat = np.block([[M[np.ix_(fr, fr)], -A.T[fr]], [A[:, fr], np.zeros((c, c))]])
        rhs = np.r_[pk[fr] - M[np.ix_(fr, pr)] @ qd[pr], -A[:, pr] @ qd[pr]]
        qd[fr] = np.linalg.solve(Kmat, rhs)[:nf]
        QD[k] = qd
    for k in range(reached):
        # the midpoint state: the free coordinates' midpoint and difference quotient, the gait at t_k+1/2
        x = np.r_[(Q[k] + Q[k + 1]) / 2, (Q[k + 1] - Q[k]) / h]
        tm = times[k] + h / 2
        r_p, rd_p, rdd_p = setup.gait(tm)
        x[pr], x[[n + i for i in pr]] = r_p, rd_p
        tau_v = np.zeros(s.sigma)
        tau_v[setup.free_shapes] = setup.torques(tm, x[:n], x[n:])
        if pr:
            # Forces realising the gait, from the continuous equations at the midpoint state (O(h^2) accurate).
            _, _, tau_full = _accelerations(setup, lda.funcs, tm, x[:n], x[n:], rdd_p)
            tau_v[setup.prescribed] = tau_full[setup.prescribed]
        tau_mid[k] = tau_v
        work[k + 1] = work[k] + tau_v @ (Q[k + 1, s.k :] - Q[k, s.k :])
    residual = _residual(lda, Q, QD, times, reached)
    TAU = _node_forces(tau_mid, nsteps, s.sigma)
    raw = _Raw(Q[keep], QD[keep], TAU[keep], work[keep], failure, reached, residual[keep])
    raw.newton = iterations
    return raw


def _node_forces(tau_mid: np.ndarray, nsteps: int, sigma: int) -> np.ndarray:
    """The shape forces of the steps' midpoints as a row per node (the last repeated)."""
    return np.vstack([tau_mid[:nsteps], tau_mid[nsteps - 1 : nsteps]]) if nsteps else np.zeros((1, sigma))


def _residual(lda: Any, Q: np.ndarray, QD: np.ndarray, times: np.ndarray, reached: int) -> np.ndarray:
    """The projected node velocities satisfy the constraints exactly; the honest residual of the scheme is that of
    the centred difference quotient, A(q_k)(q_{k+1} - q_{k-1}) / 2h = O(h^2) (one-sided at the ends)."""
    N, c = len(Q), lda.system.c
    residual = np.full((N, c), np.nan)
    if reached >= 2:
        V_fd = np.gradient(Q[: reached + 1], times[: reached + 1], axis=0, edge_order=2)
        residual[: reached + 1] = lda.constraint_residual(Q[: reached + 1], V_fd).reshape(reached + 1, c)
    elif reached >= 0:
        residual[: reached + 1] = lda.constraint_residual(Q[: reached + 1], QD[: reached + 1]).reshape(-1, c)
    return residual


class _StepFailed(Exception):
    def __init__(self, status: Status, residual: float, detail: str):
        self.status, self.residual, self.detail = status, residual, detail
