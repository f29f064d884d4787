"""Loop template: implicit Runge-Kutta methods for any ODE with a Jacobian: the implicit midpoint rule and
Gauss-Legendre collocation, solved by Newton's method with the exact Jacobian ``fjac``.

See ``_k_common.py`` for the template mechanism and the common loop signature.
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ._fptr import borrowed, call_model, call_model4, kept
from ._k_common import (
    F_FJAC,
    F_RHS,
    SAVE0,
    ST_NEWTON,
    ST_SINGULAR,
    fail,
    finish_step,
    kernel,
    load,
    lu_apply,
    lu_factor,
    max_abs,
    newton_done,
    newton_update,
    param_row,
    store,
)

# <<< template preamble


@kernel
def midpoint_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """y_{n+1} = y_n + h f((y_n + y_{n+1})/2), as Z = (y_{n+1} - y_n)/2 solving Z = (h/2) f(y_n + Z).

    The predictor extrapolates the last two increments (error O(h^3)), so Newton usually stops after two
    iterations at h small.
    """
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, PRM = borrowed((Y0, OUT, INFO, PRM))
    B, d = Y0.shape
    if d == 2:
        midpoint_run_2(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, PRM)
        return
    f_rhs, f_jac = FP[F_RHS], FP[F_FJAC]
    hh = 0.5 * h
    y_, Z_, Z1_, Z2_ = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    y, Z, Z1, Z2 = borrowed((y_, Z_, Z1_, Z2_))
    f_, r_, tmp_ = np.empty(d), np.empty(d), np.empty(d)
    f, r, tmp = borrowed((f_, r_, tmp_))
    J_, A_ = np.empty((d, d)), np.empty((d, d))
    J, A = borrowed((J_, A_))
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        call_model(f_rhs, y, f, prm)
        nrhs = 1
        nnewton = 0
        for i in range(d):
            Z1[i] = hh * f[i]
            Z2[i] = Z1[i]
        for k in range(1, nsteps + 1):
            for i in range(d):
                Z[i] = 2.0 * Z1[i] - Z2[i] if k > 2 else Z1[i]
            scale = max(1.0, max_abs(y))
            dprev = 0.0
            code = ST_NEWTON
            resid = np.inf
            for it in range(maxit):
                for i in range(d):
                    tmp[i] = y[i] + Z[i]
                call_model4(f_jac, tmp, f, J, prm)
                nrhs += 1
                nnewton += 1
                for i in range(d):
                    r[i] = hh * f[i] - Z[i]
                    for j in range(d):
                        A[i, j] = -hh * J[i, j]
                    A[i, i] += 1.0
                resid = max_abs(r)
                state, dprev = newton_update(A, r, Z, d, dprev, it, scale, tol)
                if state >= 0:
                    code = state
                    break
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            for i in range(d):
                y[i] += 2.0 * Z[i]
                Z2[i] = Z1[i]
                Z1[i] = Z[i]
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = nnewton
        INFO[b, 4] = nrhs
    kept((y_, Z_, Z1_, Z2_, f_, r_, tmp_, J_, A_))


@kernel
def midpoint_run_2(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, PRM):
    """midpoint_run for d = 2 (one degree of freedom, the reduced Serret-Andoyer systems) on scalars."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, PRM = borrowed((Y0, OUT, INFO, PRM))
    f_rhs, f_jac = FP[F_RHS], FP[F_FJAC]
    B = Y0.shape[0]
    hh = 0.5 * h
    f_, J_, y_ = np.empty(2), np.empty((2, 2)), np.empty(2)
    f, J, y = borrowed((f_, J_, y_))
    for b in range(B):
        prm = param_row(PRM, b)
        y0, y1 = Y0[b, 0], Y0[b, 1]
        OUT[b, 0, 0], OUT[b, 0, 1] = y0, y1
        isave = 1
        y[0], y[1] = y0, y1
        call_model(f_rhs, y, f, prm)
        nrhs = 1
        nnewton = 0
        p0, p1 = hh * f[0], hh * f[1]  # the last two increments, for the predictor
        q0, q1 = p0, p1
        for k in range(1, nsteps + 1):
            z0, z1 = (2.0 * p0 - q0, 2.0 * p1 - q1) if k > 2 else (p0, p1)
            scale = max(1.0, abs(y0), abs(y1))
            dprev = 0.0
            code = ST_NEWTON
            resid = np.inf
            for it in range(maxit):
                y[0], y[1] = y0 + z0, y1 + z1
                call_model4(f_jac, y, f, J, prm)
                nrhs += 1
                nnewton += 1
                r0, r1 = hh * f[0] - z0, hh * f[1] - z1
                a00, a01 = 1.0 - hh * J[0, 0], -hh * J[0, 1]
                a10, a11 = -hh * J[1, 0], 1.0 - hh * J[1, 1]
                resid = max(abs(r0), abs(r1))
                det = a00 * a11 - a01 * a10
                if not (abs(det) > 1e-14 * max(abs(a00 * a11), abs(a01 * a10))):
                    code = ST_SINGULAR
                    break
                d0 = (a11 * r0 - a01 * r1) / det
                d1 = (a00 * r1 - a10 * r0) / det
                z0 += d0
                z1 += d1
                dn = max(abs(d0), abs(d1))
                if not math.isfinite(dn):
                    break
                if newton_done(dn, dprev, it, scale, tol):
                    code = 0
                    break
                dprev = dn
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            y0 += 2.0 * z0
            y1 += 2.0 * z1
            q0, q1, p0, p1 = p0, p1, z0, z1
            y[0], y[1] = y0, y1
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = nnewton
        INFO[b, 4] = nrhs
    kept((f_, J_, y_))


@kernel
def stage_point(y, Z, i, out):
    """The state at stage i of a collocation step from y: y + Z_i (Z the stages' increments, one after another)."""
    d = y.shape[0]
    for u in range(d):
        out[u] = y[u] + Z[i * d + u]


#: The stage unknowns s d from which Gauss-Legendre factors Newton's matrix in A's eigenbasis (see gauss_run).
BLOCKS_MIN = 24


@kernel
def gauss_blocks_solve(Cc, pivc, Wc, Tc, Tic, partner, r, s, d):
    """Newton's correction (I - h A (x) J)^-1 r in place, by the factored blocks I - h lam_k J of A's eigenbasis:
    W = (T^-1 (x) I) r, W_k solved by block k (the other of a conjugate pair its conjugate), r = Re (T (x) I) W."""
    for k in range(s):
        if partner[k] < -1.5:
            continue
        for u in range(d):
            acc = 0j
            for j in range(s):
                acc += Tic[k, j] * r[j * d + u]
            Wc[k, u] = acc
        lu_apply(Cc[k], pivc[k], Wc[k], d)
        if partner[k] > -0.5:
            other = int(partner[k])
            for u in range(d):
                Wc[other, u] = Wc[k, u].conjugate()
    for i in range(s):
        for u in range(d):
            acc = 0j
            for k in range(s):
                acc += Tc[i, k] * Wc[k, u]
            r[i * d + u] = acc.real


@kernel
def gauss_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """s-stage Gauss-Legendre collocation in the stage increments Z_i = Y_i - y_n:
    Z_i = h sum_j a_ij f(y_n + Z_j), solved by Newton's method, then y_{n+1} = y_n + h sum_i b_i f(y_n + Z_i)
    with f evaluated afresh at the converged stages and the sum compensated. The update by d = b^T A^{-1},
    y_{n+1} = y_n + sum_i d_i Z_i, saves those s evaluations but carries the Newton and round-off errors of
    the Z_i into the map unsymmetrically: on problem 1 of benchmarks/README.md its energy error drifts
    linearly (2e-13 after 1.25e5 steps of 0.8 with s = 6), while the update by b keeps it at round-off
    (6e-16, bounded), as for Hairer, McLachlan & Razakarivony (BIT 48, 2008), whose Brouwer's law it is. A
    step is the composition of J such steps of sizes gamma_1 h, ..., gamma_J h (J = 1, gamma = 1: one step);
    the collocation polynomial of one sub-step, extrapolated, starts Newton's method at the next (a third
    fewer iterations at large steps than its increments rescaled).

    Where the stages hold BLOCKS_MIN unknowns or more (s d >= 24), Newton's matrix of the first iterate is
    I - h A (x) J with one Jacobian J, at the stages' b-weighted mean, in the eigenbasis of A (A = T diag(lam)
    T^-1): s/2 complex systems I - h lam_k J of size d, one for each of lam's conjugate pairs (and a real one for
    s odd), several times cheaper to factor than the s d x s d matrix ([HNW] IV.8). The iteration then contracts
    a little slower than from the stage Jacobians (2 to 3 iterations a step where there were 2), which the
    cheaper factorisation pays for only on larger systems: measured, 2.2 to 2.7 times faster at d = 12 and 18 (a
    body with attitude, with three rotors) and at s d = 36 (d = 6, s = 6), slower at s d = 12 and 18 (d = 6 with
    s = 2 and 3; d = 3 with s = 3), a tie at d = 3, s = 6. Smaller systems build the s d x s d matrix from the s
    exact stage Jacobians. Either way, where the corrections contract slowly, or a block is singular, the step
    goes on with Newton's full method on the s d unknowns, the stage Jacobians exact, the matrix rebuilt at every
    iterate.

    P = (s, A (row-major), b, c, J, gamma_1..gamma_J, lam, T, T^-1 (each entry's real and imaginary part), each
    eigenvalue's partner: methods._canonical.gauss_transform).
    """
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, PRM = borrowed((Y0, OUT, INFO, P, PRM))
    B, d = Y0.shape
    f_rhs, f_jac = FP[F_RHS], FP[F_FJAC]
    s = int(P[0])
    a = P[1 : 1 + s * s]
    bw = P[1 + s * s : 1 + s * s + s]
    c = P[1 + s * s + s : 1 + s * s + 2 * s]
    J = int(P[1 + s * s + 2 * s])
    gam = P[2 + s * s + 2 * s : 2 + s * s + 2 * s + J]
    n = s * d
    # A's eigenbasis: the blocks I - h lam_k J (one of each conjugate pair: partner[k] >= -1)
    o = 2 + s * s + 2 * s + J
    lam_ = np.empty(s, np.complex128)
    lam = borrowed(lam_)
    Tc_ = np.empty((s, s), np.complex128)
    Tc = borrowed(Tc_)
    Tic_ = np.empty((s, s), np.complex128)
    Tic = borrowed(Tic_)
    for e in range(s):
        lam[e] = complex(P[o + 2 * e], P[o + 2 * e + 1])
    o += 2 * s
    for i in range(s):
        for j in range(s):
            Tc[i, j] = complex(P[o + 2 * (i * s + j)], P[o + 2 * (i * s + j) + 1])
            Tic[i, j] = complex(P[o + 2 * s * s + 2 * (i * s + j)], P[o + 2 * s * s + 2 * (i * s + j) + 1])
    partner = P[o + 4 * s * s : o + 4 * s * s + s]
    Cc_ = np.empty((s, d, d), np.complex128)
    Cc = borrowed(Cc_)
    pivc_ = np.empty((s, d), np.int64)
    pivc = borrowed(pivc_)
    Wc_ = np.empty((s, d), np.complex128)
    Wc = borrowed(Wc_)
    J0_ = np.empty((d, d))
    J0 = borrowed(J0_)
    blocks = n >= BLOCKS_MIN
    ntol = 0.01 * tol / J  # Newton's stop (below)
    y_, tmp_, f0_ = np.empty(d), np.empty(d), np.empty(d)
    y, tmp, f0 = borrowed((y_, tmp_, f0_))
    Z_, r_ = np.empty(n), np.empty(n)
    Z, r = borrowed((Z_, r_))
    F_ = np.empty((s, d))
    F = borrowed(F_)
    Js_ = np.empty((s, d, d))
    Js = borrowed(Js_)
    M_ = np.empty((n, n))
    M = borrowed(M_)
    piv_ = np.empty(n, np.int64)
    piv = borrowed(piv_)
    # the predictor's weights E[jj, i, j]: the collocation polynomial of sub-step jj (through (0, 0) and
    # (c_j, Z_j)) at 1 + rho c_i, rho the ratio of the next sub-step to this one; fixed by the composition
    EX_ = np.empty((J, s, s))
    EX = borrowed(EX_)
    for jj in range(J):
        rho = gam[(jj + 1) % J] / gam[jj]
        for i in range(s):
            th = 1.0 + rho * c[i]
            for j in range(s):
                w = th / c[j]
                for m in range(s):
                    if m != j:
                        w *= (th - c[m]) / (c[j] - c[m])
                EX[jj, i, j] = w
    tmp2_, dy_, comp_ = np.empty(s), np.empty(d), np.empty(d)
    tmp2, dy, comp = borrowed((tmp2_, dy_, comp_))
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        comp[:] = 0.0
        store(OUT, b, SAVE0, y)
        isave = 1
        call_model(f_rhs, y, f0, prm)
        nrhs = 1
        nnewton = 0
        hprev = h * gam[0]
        for i in range(s):
            for u in range(d):
                Z[i * d + u] = c[i] * hprev * f0[u]
        for k in range(1, nsteps + 1):
            code = 0
            resid = 0.0
            for jj in range(J):
                hh = h * gam[jj]
                if hh != hprev:
                    ratio = hh / hprev
                    for q in range(n):
                        Z[q] *= ratio
                    hprev = hh
                scale = max(1.0, max_abs(y))
                dprev = 0.0
                code = ST_NEWTON
                resid = np.inf
                # Newton's matrix is built from the stage Jacobians at the first iterate and kept while the
                # corrections contract fast: from the extrapolated predictor its error is of the size of the first
                # correction, so the next iterations converge as with Newton's full method, at one factorisation
                # a step; when the contraction is slow (the first step, a large step) the step goes on with Newton's
                # full method, the matrix rebuilt at every iterate, so that a hard step converges as before
                fresh = True
                full = False
                for it in range(maxit):
                    exact = full or not blocks  # the s d x s d matrix from the stage Jacobians
                    if fresh and exact:
                        for i in range(s):
                            stage_point(y, Z, i, tmp)
                            call_model4(f_jac, tmp, F[i], Js[i], prm)
                    else:
                        for i in range(s):
                            stage_point(y, Z, i, tmp)
                            call_model(f_rhs, tmp, F[i], prm)
                        if fresh:  # one Jacobian, at the stages' b-weighted mean, for the blocks in A's eigenbasis
                            for u in range(d):
                                acc = y[u]
                                for i in range(s):
                                    acc += bw[i] * Z[i * d + u]
                                tmp[u] = acc
                            call_model4(f_jac, tmp, dy, J0, prm)
                            nrhs += 1
                    nrhs += s
                    nnewton += 1
                    for i in range(s):
                        for u in range(d):
                            acc = 0.0
                            for j in range(s):
                                acc += a[i * s + j] * F[j, u]
                            r[i * d + u] = hh * acc - Z[i * d + u]
                    resid = max_abs(r)
                    if fresh and not exact:
                        singular = False
                        for e in range(s):  # (k is the step)
                            if partner[e] < -1.5:
                                continue
                            for u in range(d):
                                for v in range(d):
                                    Cc[e, u, v] = -hh * lam[e] * J0[u, v]
                                Cc[e, u, u] += 1.0
                            if not lu_factor(Cc[e], pivc[e], d):
                                singular = True
                        if singular:
                            # a block singular at the one Jacobian (where I - h A (x) J(mean) is, which the stage
                            # Jacobians' matrix need not be): the step goes on with Newton's full method
                            full = True
                            exact = True
                            for i in range(s):
                                stage_point(y, Z, i, tmp)
                                call_model4(f_jac, tmp, F[i], Js[i], prm)
                            nrhs += s
                    if fresh and exact:
                        for i in range(s):
                            for u in range(d):
                                for j in range(s):
                                    hij = -hh * a[i * s + j]
                                    for v in range(d):
                                        M[i * d + u, j * d + v] = hij * Js[j, u, v]
                                M[i * d + u, i * d + u] += 1.0
                        if not lu_factor(M, piv, n):
                            code = ST_SINGULAR
                            break
                    if exact:
                        lu_apply(M, piv, r, n)
                    else:
                        gauss_blocks_solve(Cc, pivc, Wc, Tc, Tic, partner, r, s, d)
                    for q in range(n):
                        Z[q] += r[q]
                    dn = max_abs(r)
                    if not math.isfinite(dn):
                        break
                    # with a kept matrix the convergence is linear: stopping where the rate's estimate of the
                    # remaining error reaches tol leaves errors of that size in every step, a bias of the map
                    # (problem 1 of benchmarks/README.md at h = 1: an energy error of 2e-13 after 1e5 steps, 6e-15
                    # stopping lower), so it stops a hundred times lower, or at the round-off floor; a composition's
                    # J sub-steps add their leftovers (midpoint_s35_10 at h = 0.8: 6e-13 after 1e5 steps, 1e-14
                    # with the J-th part), so each stops J times lower again
                    if newton_done(dn, dprev, it, scale, ntol):
                        code = 0
                        break
                    if it > 0 and dn > 0.1 * dprev:
                        full = True
                    fresh = full
                    dprev = dn
                if code != 0:
                    break
                for i in range(s):
                    stage_point(y, Z, i, tmp)
                    call_model(f_rhs, tmp, F[i], prm)
                nrhs += s
                for u in range(d):
                    acc = 0.0
                    for i in range(s):
                        acc += bw[i] * F[i, u]
                    acc *= hh
                    dy[u] = acc  # the step's increment y_{n+1} - y_n
                    # compensated sum (Kahan): the low bits the state's rounding dropped are added back at the
                    # next step, so that round-off does not accumulate in the phase over millions of steps
                    inc = acc + comp[u]
                    ynew = y[u] + inc
                    comp[u] = (y[u] - ynew) + inc
                    y[u] = ynew
                # Newton starts the next (sub-)step from the collocation polynomial u of this one, extrapolated
                # (Hairer & Wanner II, IV.8): Z_i = u(1 + rho c_i) - u(1), in units of this step, rho the ratio of
                # the next step to it; u - y_n is the Lagrange interpolant of (0, 0), (c_j, Z_j).
                E = EX[jj]
                for u in range(d):
                    for j in range(s):
                        tmp2[j] = Z[j * d + u]
                    for i in range(s):
                        acc = -dy[u]
                        for j in range(s):
                            acc += E[i, j] * tmp2[j]
                        Z[i * d + u] = acc
                hprev = h * gam[(jj + 1) % J]
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = nnewton
        INFO[b, 4] = nrhs
    kept((lam_, Tc_, Tic_, Cc_, pivc_, Wc_, J0_, y_, tmp_, f0_, Z_, r_, F_, Js_, M_, piv_, EX_, tmp2_, dy_, comp_))
