"""Loop template: symplectic methods that use the canonical splitting y = (q, p) of the state: symplectic
Euler (both variants), Stormer-Verlet, and the seed's second-order generating-function method.

The model supplies ``grad(y, g, prm)`` (g = (H_q, H_p)), ``ghess(y, g, Hm, prm)`` (with the Hessian), and for the
generating-function method ``gf_all(y, g, Hm, gw, Hw, prm)`` and ``gf_grads(y, g, gw, prm)``, where
``W = sum_i H_{q_i} H_{p_i}``. See ``_k_common.py`` for the common loop signature.
"""

import numpy as np

# >>> template preamble (removed when compiled)
from ._fptr import borrowed, call_model, kept
from ._k_common import (
    F_GRAD,
    SAVE0,
    ST_NEWTON,
    fail,
    finish_step,
    kernel,
    load,
    max_abs,
    newton_update,
    param_row,
    store,
)


def grad(y, g, prm):
    raise NotImplementedError


def ghess(y, g, hm, prm):
    raise NotImplementedError


def gf_all(y, g, hm, gw, hw, prm):
    raise NotImplementedError


def gf_grads(y, g, gw, prm):
    raise NotImplementedError


# <<< template preamble


@kernel
def _implicit_half(y, x, tmp, g, hm, gw, hw, A, r, n, h, variant, tol, maxit, scale, counts, prm):
    """Newton for the implicit half of symplectic Euler or of the generating-function method.

    variant 0 (Euler A):  x = p_{n+1} solving x = p_n - h H_q(q_n, x).
    variant 1 (Euler B):  x = q_{n+1} solving x = q_n + h H_p(x, p_n).
    variant 2 (generating function): x = q_{n+1} solving x = q_n + h H_p(x, p_n) - h^2/2 W_p(x, p_n).
    Returns (status, residual); ``x`` holds the solution.
    """
    dprev = 0.0
    resid = np.inf
    hh2 = 0.5 * h * h
    for it in range(maxit):
        if variant == 0:
            for i in range(n):
                tmp[i] = y[i]
                tmp[n + i] = x[i]
            ghess(tmp, g, hm, prm)
            for i in range(n):
                r[i] = y[n + i] - h * g[i] - x[i]
                for j in range(n):
                    A[i, j] = h * hm[i, n + j]
                A[i, i] += 1.0
        else:
            for i in range(n):
                tmp[i] = x[i]
                tmp[n + i] = y[n + i]
            if variant == 1:
                ghess(tmp, g, hm, prm)
                for i in range(n):
                    r[i] = y[i] + h * g[n + i] - x[i]
                    for j in range(n):
                        A[i, j] = -h * hm[n + i, j]
                    A[i, i] += 1.0
            else:
                gf_all(tmp, g, hm, gw, hw, prm)
                for i in range(n):
                    r[i] = y[i] + h * g[n + i] - hh2 * gw[n + i] - x[i]
                    for j in range(n):
                        A[i, j] = -h * hm[n + i, j] + hh2 * hw[n + i, j]
                    A[i, i] += 1.0
        counts[0] += 1
        counts[1] += 1
        resid = max_abs(r)
        state, dprev = newton_update(A, r, x, n, dprev, it, scale, tol)
        if state >= 0:
            return state, resid
    return ST_NEWTON, resid


@kernel
def _symplectic_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, variant, PRM):
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, PRM = borrowed((Y0, OUT, INFO, PRM))
    B, d = Y0.shape
    n = d // 2
    y_, tmp_, g_, gw_ = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    y, tmp, g, gw = borrowed((y_, tmp_, g_, gw_))
    x_, xprev_, r_ = np.empty(n), np.empty(n), np.empty(n)
    x, xprev, r = borrowed((x_, xprev_, r_))
    hm_, hw_ = np.empty((d, d)), np.empty((d, d))
    hm, hw = borrowed((hm_, hw_))
    A_ = np.empty((n, n))
    A = borrowed(A_)
    counts_ = np.zeros(2)  # rhs evaluations, Newton iterations
    counts = borrowed(counts_)
    off = n if variant == 0 else 0  # the implicit unknown is p (variant 0) or q
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        counts[:] = 0.0
        grad(y, g, prm)
        counts[0] += 1
        for i in range(n):
            xprev[i] = y[off + i]
            # explicit Euler predictor for the first step, then the last increment
            x[i] = y[n + i] - h * g[i] if variant == 0 else y[i] + h * g[n + i]
        for k in range(1, nsteps + 1):
            if k > 1:
                for i in range(n):
                    x[i] = 2.0 * y[off + i] - xprev[i]
            for i in range(n):
                xprev[i] = y[off + i]
            scale = max(1.0, max_abs(y))
            code, resid = _implicit_half(y, x, tmp, g, hm, gw, hw, A, r, n, h, variant, tol, maxit, scale, counts, prm)
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            if variant == 0:
                for i in range(n):
                    tmp[i] = y[i]
                    tmp[n + i] = x[i]
                grad(tmp, g, prm)
                for i in range(n):
                    y[i] += h * g[n + i]
                    y[n + i] = x[i]
            else:
                for i in range(n):
                    tmp[i] = x[i]
                    tmp[n + i] = y[n + i]
                if variant == 1:
                    grad(tmp, g, prm)
                    for i in range(n):
                        y[n + i] -= h * g[i]
                else:
                    gf_grads(tmp, g, gw, prm)
                    for i in range(n):
                        y[n + i] += -h * g[i] + 0.5 * h * h * gw[i]
                for i in range(n):
                    y[i] = x[i]
            counts[0] += 1
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = counts[1]
        INFO[b, 4] = counts[0]
    kept((y_, tmp_, g_, gw_, x_, xprev_, r_, hm_, hw_, A_, counts_))


@kernel
def symplectic_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """P[0]: 0 symplectic Euler A, 1 symplectic Euler B, 2 the generating-function method (a runtime value,
    so that numba compiles one loop for the three). The loop calls the model by name, so that the compiler
    drops what the variant does not read (e.g. H_pp for Euler A): through the addresses the method was 1.6
    times slower on the reduced closed loop."""
    _symplectic_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, int(P[0]), PRM)


@kernel
def verlet_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """Stormer-Verlet for H = T(p) + V(q): p_{1/2} = p - h/2 V'(q), q' = q + h T'(p_{1/2}),
    p' = p_{1/2} - h/2 V'(q'); H_q at the new q is reused by the next step."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, PRM = borrowed((Y0, OUT, INFO, P, PRM))
    B, d = Y0.shape
    n = d // 2
    y_, g_, gq_ = np.empty(d), np.empty(d), np.empty(n)
    y, g, gq = borrowed((y_, g_, gq_))
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        call_model(FP[F_GRAD], y, g, prm)
        nrhs = 1
        for i in range(n):
            gq[i] = g[i]
        for k in range(1, nsteps + 1):
            for i in range(n):
                y[n + i] -= 0.5 * h * gq[i]
            call_model(FP[F_GRAD], y, g, prm)
            for i in range(n):
                y[i] += h * g[n + i]
            call_model(FP[F_GRAD], y, g, prm)
            nrhs += 2
            for i in range(n):
                gq[i] = g[i]
                y[n + i] -= 0.5 * h * gq[i]
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nrhs
    kept((y_, g_, gq_))
