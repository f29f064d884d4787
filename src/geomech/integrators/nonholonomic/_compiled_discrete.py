"""The discrete Lagrange-d'Alembert map with the midpoint discrete Lagrangian
(:class:`~geomech.integrators.DiscreteLagrangeDAlembert`, ``discretization="midpoint"``), compiled: the whole run,
Newton's iteration of every step included, in one numba call.

The module holds the compiled Lagrange-d'Alembert equations of :mod:`._compiled` (their observation gives the
forces that realise the gait at a step's midpoint) and, generated for the system's sizes as straight-line code,

- ``disc(q0, q1, h, tm, prm, D1, D2, JD, C, JC)``: :math:`D_1L_d + \\tfrac h2 F` and :math:`D_2L_d + \\tfrac h2 F`
  of :math:`L_d = hL(\\bar q, (q_1 - q_0)/h)` (F the torques on the free shapes at the midpoint), the derivative
  of :math:`D_1L_d` in :math:`q_1` (from the second derivatives of L), the discrete constraint
  :math:`A(\\bar q)(q_1 - q_0)` and its derivative in :math:`q_1`;
- ``momentum(q, qd, out, prm)``: :math:`\\partial L/\\partial\\dot q`;
- ``mass_constraints(q, M, A, prm)``: the mass matrix and the constraints at a node;
- ``gait_nodes(t, qp, qdp, prm)``: the prescribed shapes and their rates at a node,

and the loop ``dlda_run``, the same steps as the Python engine (:func:`._discrete.run_discrete`): the same
initial guesses, residuals, Newton's stopping tests, node velocities (the discrete Legendre transform projected on
D) and work. The system's parameters, the gait's and the torques' numbers are read from ``prm`` at run time.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import sympy as sp

from ...symbolic import derivative
from ...symbolic.compile import StraightLine
from ...systems.gait import T_SYMBOL
from .._group_code import ABELIAN, group_kernels
from .._native import loop_of
from ..solution import Failure, Status
from ._compiled import _TIME, LagrangianSource, _generate_lda, _made, _module
from ._trajectory import _Raw

__all__ = ["dlda_module", "no_convergence", "run_compiled_discrete"]


def dlda_module(setup: Any, discretization: str = "midpoint") -> tuple[Any, LagrangianSource] | None:
    """The compiled discrete Lagrange-d'Alembert map of ``setup`` with the ``discretization``'s discrete Lagrangian
    ("midpoint" or "group") and the layout of the values ``prm`` it reads, or None where it cannot be compiled (numba
    missing, a callable gait or torque, a function numba lacks, a group without closed-form kernels)."""
    if discretization == "group" and group_kernels(setup.system.group.numeric) is None:
        return None

    def generate(gait: tuple, torques: tuple, n_prm: int, extra: tuple) -> str:
        return _generate_lda(setup, gait, torques, n_prm, sp.Integer(0)) + _generate_discrete(
            setup, gait, torques, n_prm, discretization
        )

    return _module(lambda: _made(setup, ("dlda", discretization), (), generate), "dl")


def _reads(n_prm: int) -> str:
    return "\n".join(f"_p{i} = prm[{i}]" for i in range(n_prm))


def _function(name: str, args: str, code: StraightLine) -> str:
    return f"@kernel\ndef {name}({args}):\n" + code.body()


def _generate_discrete(setup: Any, gait_forms: tuple, torque_forms: tuple, n_prm: int, discretization: str) -> str:
    system = setup.system
    n, c = system.n, system.c
    params = {p: sp.Symbol(f"_p{i}") for i, p in enumerate(system.parameter_symbols)}
    L = sp.sympify(system.lagrangian).xreplace(params)
    q, v = list(system.q), list(system.qdot)
    Lv = [derivative(L, a) for a in v]
    A = sp.Matrix(system.constraint_matrix).xreplace(params) if c else sp.zeros(0, n)
    disc = _midpoint_disc if discretization == "midpoint" else _group_disc
    parts = disc(setup, torque_forms, n_prm, params)

    # momentum: dL/dqdot at (q, qd)
    code = StraightLine()
    code.line("\n".join([f"_q{i} = x[{i}]\n_w{i} = xd[{i}]" for i in range(n)] + [_reads(n_prm)]))
    node = {**{q[i]: sp.Symbol(f"_q{i}") for i in range(n)}, **{v[i]: sp.Symbol(f"_w{i}") for i in range(n)}}
    p = code.values([e.xreplace(node) for e in Lv])
    code.line("\n".join(f"out[{i}] = {code.code(p[i])}" for i in range(n)))
    parts.append(_function("momentum", "x, xd, out, prm", code))

    # mass_constraints: M(q) and A(q) at a node
    code = StraightLine()
    code.line("\n".join([f"_q{i} = x[{i}]" for i in range(n)] + [_reads(n_prm)]))
    M = sp.Matrix(system.mass_matrix).xreplace(params).xreplace(node)
    Mv, Av = code.matrix(M), code.matrix(A.xreplace(node)) if c else sp.zeros(0, n)
    code.line(
        "\n".join(
            [f"M[{i}, {j}] = {code.code(Mv[i, j])}" for i in range(n) for j in range(n)]
            + [f"A[{r}, {j}] = {code.code(Av[r, j])}" for r in range(c) for j in range(n)]
        )
    )
    parts.append(_function("mass_constraints", "x, M, A, prm", code))

    # gait_nodes: the prescribed shapes and their rates at t
    code = StraightLine()
    code.line("_t = t\n" + _reads(n_prm))
    values = code.values(list(gait_forms) + [e.diff(_TIME) for e in gait_forms])
    npr = len(gait_forms)
    code.line(
        "\n".join([f"qp[{j}] = {code.code(values[j])}\nqdp[{j}] = {code.code(values[npr + j])}" for j in range(npr)])
        or "pass"
    )
    parts.append(_function("gait_nodes", "t, qp, qdp, prm", code))
    # the group's Newton matrix is a difference quotient: computed once a step (a chord iteration), as in Python
    chord = "True" if discretization == "group" else "False"
    return "\n\n\n" + "\n\n\n".join(parts) + _LOOP.replace("NC", str(c)).replace("CHORD", chord)


def _midpoint_disc(setup: Any, torque_forms: tuple, n_prm: int, params: dict) -> list[str]:
    """``disc`` of the midpoint discrete Lagrangian: its derivatives exact, from the second derivatives of L."""
    system = setup.system
    n, k, c = system.n, system.k, system.c
    L = sp.sympify(system.lagrangian).xreplace(params)
    q, v = list(system.q), list(system.qdot)
    Lq = [sp.diff(L, a) for a in q]
    Lv = [sp.diff(L, a) for a in v]
    A = sp.Matrix(system.constraint_matrix).xreplace(params) if c else sp.zeros(0, n)
    h, tm = sp.Symbol("_h"), sp.Symbol("_tm")
    parts = []

    # disc: the discrete Lagrangian's derivatives and the discrete constraint at a step (q0, q1)
    code = StraightLine()
    a_ = [sp.Symbol(f"_a{i}") for i in range(n)]
    b_ = [sp.Symbol(f"_b{i}") for i in range(n)]
    code.line(
        "\n".join([f"_a{i} = q0[{i}]\n_b{i} = q1[{i}]" for i in range(n)] + ["_h = h", "_tm = tm", _reads(n_prm)])
    )
    qbar = [code.value((a_[i] + b_[i]) / 2) for i in range(n)]
    vel = [code.value((b_[i] - a_[i]) / h) for i in range(n)]
    at = {T_SYMBOL: tm, **dict(zip(q, qbar)), **dict(zip(v, vel))}
    lq = code.values([e.xreplace(at) for e in Lq])
    lv = code.values([e.xreplace(at) for e in Lv])
    F = [sp.Integer(0)] * n
    for jj, j in enumerate(setup.free_shapes):
        F[k + j] = code.value(torque_forms[jj].xreplace(at).xreplace(params))
    D1 = code.values([h / 2 * (lq[i] + F[i]) - lv[i] for i in range(n)])
    D2 = code.values([h / 2 * (lq[i] + F[i]) + lv[i] for i in range(n)])
    dq = [b_[i] - a_[i] for i in range(n)]
    Abar = A.xreplace(at) if c else A
    C = code.values([sum(Abar[r, i] * dq[i] for i in range(n)) for r in range(c)])
    stores = [f"D1[{i}] = {code.code(D1[i])}\nD2[{i}] = {code.code(D2[i])}" for i in range(n)]
    stores += [f"C[{r}] = {code.code(C[r])}" for r in range(c)]
    # without `jac` (the next step's base, D2 L_d of the step just solved) the derivatives are not needed
    code.line("\n".join(stores) + "\nif not jac:\n    return")
    JD = []
    for i in range(n):
        row = []
        for j in range(n):
            lqq = sp.diff(Lq[i], q[j]).xreplace(at)
            lqv = sp.diff(Lq[i], v[j]).xreplace(at)
            lvq = sp.diff(Lv[i], q[j]).xreplace(at)  # = d Lq[j] / d v[i]
            lvv = sp.diff(Lv[i], v[j]).xreplace(at)
            row.append(code.value(h / 2 * (lqq / 2 + lqv / h) - (lvq / 2 + lvv / h)))
        JD.append(row)
    JC = [
        [
            code.value(Abar[r, j] + sum(sp.diff(A[r, i], q[j]).xreplace(at) * dq[i] for i in range(n)) / 2)
            for j in range(n)
        ]
        for r in range(c)
    ]
    stores = [f"JD[{i}, {j}] = {code.code(JD[i][j])}" for i in range(n) for j in range(n)]
    stores += [f"JC[{r}, {j}] = {code.code(JC[r][j])}" for r in range(c) for j in range(n)]
    code.line("\n".join(stores) or "pass")
    parts.append(_function("disc", "q0, q1, h, tm, prm, D1, D2, JD, C, JC, jac", code))
    return parts


def _group_disc(setup: Any, torque_forms: tuple, n_prm: int, params: dict) -> list[str]:
    """``gresid`` and ``disc`` of the group's discrete Lagrangian :math:`h\\,\\ell(\\bar r, \\chi/h, (r_1 - r_0)/h)`,
    :math:`\\chi = \\log(g_0^{-1}g_1)` (:class:`._discrete._GroupLagrangian`, the same formulas): the element
    :math:`g_0^{-1}g_1` and the body Lagrangian's gradient as straight-line code, the logarithm and the inverse
    Jacobians by the group's kernels (``_k_groups.py``), Newton's derivatives in :math:`q_1` by central differences
    of ``gresid`` (the Python engine's steps)."""
    system = setup.system
    chart = system.group
    n, k, c, sigma = system.n, system.k, system.c, system.sigma
    kernels = group_kernels(chart.numeric)
    assert kernels is not None  # dlda_module checked
    h, tm = sp.Symbol("_h"), sp.Symbol("_tm")
    a_ = [sp.Symbol(f"_a{i}") for i in range(n)]
    b_ = [sp.Symbol(f"_b{i}") for i in range(n)]
    code = StraightLine()
    code.line(
        "\n".join([f"_a{i} = q0[{i}]\n_b{i} = q1[{i}]" for i in range(n)] + ["_h = h", "_tm = tm", _reads(n_prm)])
    )
    coords = list(chart.coordinates)
    at0 = dict(zip(coords, a_[:k]))
    at1 = dict(zip(coords, b_[:k]))
    # chi = log(g0^-1 g1), and J_l^-1(chi), J_r^-1(chi) = J_l^-1(-chi), a factor at a time
    N = int(chart.numeric.matrix_size)
    P = code.matrix(sp.Matrix(chart.inverse).xreplace(at0) * sp.Matrix(chart.matrix).xreplace(at1))
    lines = [f"_P = np.empty(({N}, {N}))"]
    lines += [f"_P[{i}, {j}] = {code.code(P[i, j])}" for i in range(N) for j in range(N)]
    lines += [f"_u = np.empty({k})", f"_Jl = np.zeros(({k}, {k}))", f"_Jr = np.zeros(({k}, {k}))"]
    Jl = sp.zeros(k, k)
    Jr = sp.zeros(k, k)
    for name, row, first, m in kernels:
        if name == "rn":
            lines.append(f"log_rn(_P, {row}, {m}, _u, {first})")
        else:
            lines.append(f"log_{name}(_P, {row}, _u, {first})")
        if name in ABELIAN:  # the Jacobians are the identity
            for i in range(first, first + m):
                Jl[i, i] = Jr[i, i] = sp.Integer(1)
            continue
        lines.append(f"jlinv_{name}(_u, {first}, 1.0, _Jl, {first})\njlinv_{name}(_u, {first}, -1.0, _Jr, {first})")
        for i in range(first, first + m):
            for j in range(first, first + m):
                Jl[i, j], Jr[i, j] = sp.Symbol(f"_jl{i}_{j}"), sp.Symbol(f"_jr{i}_{j}")
                lines.append(f"_jl{i}_{j} = _Jl[{i}, {j}]\n_jr{i}_{j} = _Jr[{i}, {j}]")
    lines += [f"_x{i} = _u[{i}]" for i in range(k)]
    code.line("\n".join(lines))
    chi = [sp.Symbol(f"_x{i}") for i in range(k)]
    # the body Lagrangian's gradient at (r_bar, chi / h, (r1 - r0) / h)
    rbar = [code.value((a_[k + i] + b_[k + i]) / 2) for i in range(sigma)]
    rd = [code.value((b_[k + i] - a_[k + i]) / h) for i in range(sigma)]
    ell = sp.sympify(system.body_lagrangian).xreplace(params)
    x = list(system.shape) + list(system.xi) + list(system.qdot[k:])
    point = {**dict(zip(system.shape, rbar)), **{xi: chi[a] / h for a, xi in enumerate(system.xi)}}
    point.update(zip(system.qdot[k:], rd))
    grad = code.values([derivative(ell, y).xreplace(point) for y in x])
    lr, lxi, lrd = grad[:sigma], sp.Matrix(grad[sigma : sigma + k]), grad[sigma + k :]
    Lam = sp.Matrix(chart.body_velocity_matrix)
    group1 = code.values(list(-(Lam.xreplace(at0).T * (Jl.T * lxi))))
    group2 = code.values(list(Lam.xreplace(at1).T * (Jr.T * lxi)))
    # the torques on the free shapes at the midpoint, as the midpoint discretisation's
    q, v = list(system.q), list(system.qdot)
    mid = {T_SYMBOL: tm}
    mid.update((q[i], (a_[i] + b_[i]) / 2) for i in range(n))
    mid.update((v[i], (b_[i] - a_[i]) / h) for i in range(n))
    F = [sp.Integer(0)] * sigma
    for jj, j in enumerate(setup.free_shapes):
        F[j] = code.value(torque_forms[jj].xreplace(mid).xreplace(params))
    D1 = group1 + code.values([h / 2 * (lr[i] + F[i]) - lrd[i] for i in range(sigma)])
    D2 = group2 + code.values([h / 2 * (lr[i] + F[i]) + lrd[i] for i in range(sigma)])
    stores = [f"D1[{i}] = {code.code(D1[i])}\nD2[{i}] = {code.code(D2[i])}" for i in range(n)]
    if c:
        Axi, Ar = system.body_constraints
        Ab = sp.Matrix.hstack(sp.Matrix(Axi), sp.Matrix(Ar)).xreplace(params).xreplace(dict(zip(system.shape, rbar)))
        step = chi + [b_[k + i] - a_[k + i] for i in range(sigma)]
        C = code.values([sum((Ab[r, i] * step[i] for i in range(n)), sp.Integer(0)) for r in range(c)])
        stores += [f"C[{r}] = {code.code(C[r])}" for r in range(c)]
    code.line("\n".join(stores))
    return [_function("gresid", "q0, q1, h, tm, prm, D1, D2, C", code), _GROUP_DISC]


_GROUP_DISC = """@kernel
def disc(q0, q1, h, tm, prm, D1, D2, JD, C, JC, jac):
    # the residuals at (q0, q1), and (jac) their derivatives in q1 by central differences (steps 1e-6 (1 + |q1_j|))
    gresid(q0, q1, h, tm, prm, D1, D2, C)
    if not jac:
        return
    n = q1.shape[0]
    c = C.shape[0]
    qq = q1.copy()
    Dp = np.empty(n)
    Dm = np.empty(n)
    E = np.empty(n)
    Cp = np.empty(c)
    Cm = np.empty(c)
    for j in range(n):
        e = 1e-6 * (1.0 + abs(q1[j]))
        qq[j] = q1[j] + e
        gresid(q0, qq, h, tm, prm, Dp, E, Cp)
        qq[j] = q1[j] - e
        gresid(q0, qq, h, tm, prm, Dm, E, Cm)
        qq[j] = q1[j]
        for i in range(n):
            JD[i, j] = (Dp[i] - Dm[i]) / (2.0 * e)
        for r in range(c):
            JC[r, j] = (Cp[r] - Cm[r]) / (2.0 * e)
"""


_LOOP = """


@kernel
def constraint_rate(A, x0, x1, x2, w0, w1, w2, h, out):
    # A (w0 x0 + w1 x1 + w2 x2) / (2 h): the constraints on a difference quotient of three nodes
    for a in range(A.shape[0]):
        r = 0.0
        for j in range(A.shape[1]):
            r += A[a, j] * (w0 * x0[j] + w1 * x1[j] + w2 * x2[j])
        out[a] = r / (2.0 * h)


@kernel
def dlda_run(q_init, qd_init, t0, h, nsteps, tol, maxit, FR, PR, prm, KEEP, Q, QD, TAU, WORK, RES, INFO):
    # The discrete Lagrange-d'Alembert run, keeping the nodes KEEP (sorted step indices) only: their nodes Q,
    # velocities QD, the shape forces TAU of the step that starts there (the last node: of the last step), the
    # work, and the constraints on the centred difference quotient RES (one-sided at the ends, as numpy's gradient
    # with edge_order 2); INFO = (status, failing step, residual, Newton's linear solves). Returns the number of
    # steps done.
    n = q_init.shape[0]
    nf = FR.shape[0]
    npr = PR.shape[0]
    c = NC
    sigma = TAU.shape[1]
    kg = n - sigma
    m = nf + c
    D1 = np.empty(n)
    D2 = np.empty(n)
    JD = np.empty((n, n))
    C = np.empty(c)
    JC = np.empty((c, n))
    M = np.empty((n, n))
    A0 = np.empty((c, n))
    Afirst = np.empty((c, n))
    base = np.empty(n)
    prev2 = np.empty(n)
    prev = np.empty(n)
    cur = np.empty(n)
    q1 = np.empty(n)
    lam = np.zeros(c)
    R = np.empty(m)
    J = np.empty((m, m))
    Jk = np.empty((m, m))  # Newton's matrix as assembled (J is overwritten by the solve)
    qp = np.empty(npr)
    qdp = np.empty(npr)
    y = np.empty(2 * nf + 2)
    obs = np.empty(2 * n + sigma + 1 + c)
    qd_cur = np.empty(n)
    res = np.empty(c)
    tau_last = np.full(sigma, np.nan)
    for i in range(n):
        cur[i] = q_init[i]
        prev[i] = q_init[i]
        prev2[i] = q_init[i]
        qd_cur[i] = qd_init[i]
    work = 0.0
    nkeep = KEEP.shape[0]
    ik = 0  # the next entry of KEEP
    row_cur = -1  # the rows of node k and of node 0 (-1: not kept)
    row_first = -1
    if ik < nkeep and KEEP[ik] == 0:
        row_cur = 0
        row_first = 0
        ik += 1
        for i in range(n):
            Q[0, i] = q_init[i]
            QD[0, i] = qd_init[i]
        WORK[0] = 0.0
    # the first step: the continuous momentum stands for D2 L_d of a previous step, with half the impulse
    momentum(q_init, qd_init, base, prm)
    lamw = h / 2
    done = nsteps
    for k in range(nsteps):
        t_next = t0 + (k + 1) * h
        tm = t_next - h / 2
        gait_nodes(t_next, qp, qdp, prm)
        for i in range(n):
            q1[i] = cur[i] + h * qd_init[i] if k == 0 else 2 * cur[i] - prev[i]
        for j in range(npr):
            q1[PR[j]] = qp[j]
        for a in range(c):
            lam[a] = 0.0
        mass_constraints(cur, M, A0, prm)
        if k == 0:
            for a in range(c):
                for j in range(n):
                    Afirst[a, j] = A0[a, j]
        scale = 1.0 + max_abs(base)
        dprev = 0.0
        status = ST_NEWTON
        rmax = np.inf
        finishing = False
        for it in range(maxit):
            fresh = it == 0 or not CHORD
            disc(cur, q1, h, tm, prm, D1, D2, JD, C, JC, fresh)
            for ii in range(nf):
                i = FR[ii]
                r = base[i] + D1[i]
                for a in range(c):
                    r += lamw * A0[a, i] * lam[a]
                R[ii] = -r
            for a in range(c):
                R[nf + a] = -C[a]
            rmax = max_abs(R)
            if it > 0 and rmax < tol * scale:
                status = ST_OK
                break
            if fresh:
                for ii in range(nf):
                    for jj in range(nf):
                        Jk[ii, jj] = JD[FR[ii], FR[jj]]
                    for a in range(c):
                        Jk[ii, nf + a] = lamw * A0[a, FR[ii]]
                for a in range(c):
                    for jj in range(nf):
                        Jk[nf + a, jj] = JC[a, FR[jj]]
                    for b in range(c):
                        Jk[nf + a, nf + b] = 0.0
            for ii in range(m):
                for jj in range(m):
                    J[ii, jj] = Jk[ii, jj]
            if not lu_solve(J, R, m):
                status = ST_SINGULAR
                break
            INFO[3] += 1.0
            for ii in range(nf):
                q1[FR[ii]] += R[ii]
            for a in range(c):
                lam[a] += R[nf + a]
            dn = max_abs(R)
            if not math.isfinite(dn):
                status = ST_NONFINITE
                break
            if finishing:
                status = ST_OK
                break
            if newton_done(dn, dprev, it, max(1.0, max_abs(q1)), tol):
                if not CHORD:
                    status = ST_OK
                    break
                # a chord iteration converges linearly: one more makes the residual (a momentum, dz's size times
                # |D1| / h) round-off too, so that the discrete momentum map is kept to round-off (as in Python)
                finishing = True
            dprev = dn
        if status == ST_OK and not math.isfinite(max_abs(q1)):
            status = ST_NONFINITE
        if status != ST_OK:
            INFO[0] = status
            INFO[1] = k + 1
            INFO[2] = rmax
            done = k
            break
        # the shape forces at the midpoint (the continuous equations there) and their work
        for ii in range(nf):
            i = FR[ii]
            y[ii] = (cur[i] + q1[i]) / 2
            y[nf + ii] = (q1[i] - cur[i]) / h
        y[2 * nf] = 0.0
        y[2 * nf + 1] = tm
        observe(y, obs, prm)
        w = 0.0
        for j in range(sigma):
            tau_last[j] = obs[2 * n + j]
            w += tau_last[j] * (q1[kg + j] - cur[kg + j])
            if row_cur >= 0:
                TAU[row_cur, j] = tau_last[j]
        work += w
        # the constraints on the centred difference quotient at node k, and at node 0 the one-sided one
        if k >= 1 and row_cur >= 0:
            constraint_rate(A0, prev, cur, q1, -1.0, 0.0, 1.0, h, res)
            for a in range(c):
                RES[row_cur, a] = res[a]
        if k == 1 and row_first >= 0:
            constraint_rate(Afirst, prev, cur, q1, -3.0, 4.0, -1.0, h, res)
            for a in range(c):
                RES[row_first, a] = res[a]
        # the next step's base, D2 L_d + h/2 F of this one, is the momentum at the node
        disc(cur, q1, h, tm, prm, D1, D2, JD, C, JC, False)
        for i in range(n):
            base[i] = D2[i]
        lamw = h
        # the node velocity: the momentum projected on D with the kinetic metric, the gait's rates
        mass_constraints(q1, M, A0, prm)
        for ii in range(nf):
            i = FR[ii]
            r = base[i]
            for jj in range(npr):
                r -= M[i, PR[jj]] * qdp[jj]
            R[ii] = r
            for jj in range(nf):
                J[ii, jj] = M[i, FR[jj]]
            for a in range(c):
                J[ii, nf + a] = -A0[a, i]
        for a in range(c):
            r = 0.0
            for jj in range(npr):
                r -= A0[a, PR[jj]] * qdp[jj]
            R[nf + a] = r
            for jj in range(nf):
                J[nf + a, jj] = A0[a, FR[jj]]
            for b in range(c):
                J[nf + a, nf + b] = 0.0
        if not lu_solve(J, R, m):
            INFO[0] = ST_SINGULAR
            INFO[1] = k + 1
            INFO[2] = np.nan
            done = k
            break
        for ii in range(nf):
            qd_cur[FR[ii]] = R[ii]
        for jj in range(npr):
            qd_cur[PR[jj]] = qdp[jj]
        # node k + 1 is reached
        for i in range(n):
            prev2[i] = prev[i]
            prev[i] = cur[i]
            cur[i] = q1[i]
        row_cur = -1
        if ik < nkeep and KEEP[ik] == k + 1:
            row_cur = ik
            ik += 1
            for i in range(n):
                Q[row_cur, i] = cur[i]
                QD[row_cur, i] = qd_cur[i]
            WORK[row_cur] = work
            if k + 1 == nsteps:
                for j in range(sigma):
                    TAU[row_cur, j] = tau_last[j]
    # the last node reached: the one-sided quotient (from three nodes on), else the node velocities' constraints
    if row_cur >= 0:
        mass_constraints(cur, M, A0, prm)
        if done >= 2:
            constraint_rate(A0, prev2, prev, cur, 1.0, -4.0, 3.0, h, res)
        else:
            for a in range(c):
                r = 0.0
                for j in range(n):
                    r += A0[a, j] * qd_cur[j]
                res[a] = r
        for a in range(c):
            RES[row_cur, a] = res[a]
    if done == 1 and row_first >= 0:
        for a in range(c):
            r = 0.0
            for j in range(n):
                r += Afirst[a, j] * qd_init[j]
            RES[row_first, a] = r
    return done
"""


def run_compiled_discrete(
    module: Any,
    made: LagrangianSource,
    setup: Any,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    h: float,
    nsteps: int,
    keep: np.ndarray,
    newton_tol: float,
    max_newton: int,
    parameters: Any,
) -> _Raw:
    """The nodes ``keep`` (sorted step indices) of a compiled run, as the engines' :class:`_Raw`: their nodes,
    velocities, shape forces, work and constraint residual (NaN past a failure, which it holds), the steps done,
    Newton's iterations, the compile time and the loop's time."""
    system = setup.system
    n, sigma, c = system.n, system.sigma, system.c
    N = len(keep)
    out = {
        "q": np.full((N, n), np.nan),
        "qd": np.full((N, n), np.nan),
        "tau": np.full((N, sigma), np.nan),
        "work": np.full(N, np.nan),
        "residual": np.full((N, c), np.nan),
    }
    INFO = np.zeros(4)
    prm = made.rows({**system.parameters, **dict(parameters or {})}, 1)[0]
    FR = np.asarray(setup.free_coordinates(), dtype=np.int64)
    PR = np.asarray(setup.prescribed_coordinates(), dtype=np.int64)
    KEEP = np.ascontiguousarray(keep, dtype=np.int64)
    q0 = np.ascontiguousarray(q_init, dtype=float)
    qd0 = np.ascontiguousarray(qd_init, dtype=float)
    arrays = (out["q"], out["qd"], out["tau"], out["work"], out["residual"], INFO)
    prm = np.ascontiguousarray(prm, dtype=float)

    def warm_up() -> None:  # numba's loop compiled (or loaded from the disk cache) by a run of no step
        module.dlda_run(q0, qd0, 0.0, 1.0, 0, 1.0, 1, FR, PR, prm, KEEP[:0], *[a.copy() for a in arrays])

    args = (q0, qd0, float(t0), float(h), int(nsteps), float(newton_tol), int(max_newton), FR, PR, prm, KEEP, *arrays)
    loop, compile_time = loop_of(module, "dlda_run", args, warm_up)
    start = time.perf_counter()
    done = loop(*args)
    loop_time = time.perf_counter() - start
    failure = None
    if done < nsteps:
        kind = _STATUS.get(int(INFO[0]), Status.NEWTON_FAILED)
        detail = no_convergence(max_newton, h) if kind is Status.NEWTON_FAILED else ""
        failure = Failure(kind, (), int(INFO[1]), float(t0 + h * done), float(INFO[2]), detail)
    raw = _Raw(out["q"], out["qd"], out["tau"], out["work"], failure, int(done), out["residual"])
    raw.backend, raw.compile_time, raw.loop_time = "numba", compile_time, loop_time
    raw.newton = int(INFO[3])
    return raw


#: The compiled loop's status codes (_k_common's ST_*) as the failures' kinds.
_STATUS = {1: Status.NEWTON_FAILED, 2: Status.NONFINITE, 3: Status.SINGULAR_JACOBIAN}


def no_convergence(max_newton: int, h: float) -> str:
    """The detail of a step whose Newton iteration did not converge (both engines)."""
    return f"no convergence in {max_newton} iterations (step {h:.3g}); reduce h or raise max_newton"
