"""Loop template: integrators on so(3)* and SO(3) for left-invariant systems. The state is ``m`` (d = 3) or
``(m, R)`` with R row-major (d = 12).

- ``split_run``: splitting of H = f1(m1) + f2(m2) + f3(m3); each part's flow is an exact rotation about a
  body axis. Model: ``dh0, dh1, dh2`` (the scalar derivatives f_i').
- ``mv_run``: the discrete Moser-Veselov rigid body (free body, P = inertia tensor, row-major).
- ``lgvi_run``: the Lie-group variational integrator for a hyperregular H. Model: ``ghess3(m, g, Hm, prm)``.
- ``cg_run``: explicit Crouch-Grossman methods (products of rotations). Model: ``ghess3``.

See ``_k_common.py`` for the common loop signature.
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ._fptr import borrowed, call_model4, kept
from ._k_common import (
    F_GHESS3,
    SAVE0,
    ST_NEWTON,
    ST_NONFINITE,
    fail,
    finish_step,
    is_save,
    kernel,
    load,
    max_abs,
    newton_update,
    param_row,
    store,
)


def dh0(x, prm):
    raise NotImplementedError


def dh1(x, prm):
    raise NotImplementedError


def dh2(x, prm):
    raise NotImplementedError


# <<< template preamble


@kernel
def cosm1_sin(t):
    """(cos t - 1, sin t). Rotations are applied as increments, x + ((cos t - 1) x + sin t y): forming
    cos t = 1 - t^2/2 + ... first would round the same way step after step at small t and make |m|
    drift by a few 1e-17 a step. Taylor polynomials for |t| <= 0.1 (truncation below 1e-19 relative),
    libm otherwise."""
    if abs(t) <= 0.1:
        t2 = t * t
        s = t * (1.0 + t2 * (-1.0 / 6 + t2 * (1.0 / 120 + t2 * (-1.0 / 5040 + t2 * (1.0 / 362880)))))
        c = t2 * (-0.5 + t2 * (1.0 / 24 + t2 * (-1.0 / 720 + t2 * (1.0 / 40320 + t2 * (-1.0 / 3628800)))))
        return c, s
    sh = math.sin(0.5 * t)
    return -2.0 * sh * sh, math.sin(t)


@kernel
def axis_flow(y, axis, tau, attitude, prm):
    """Exact flow for time ``tau`` of H_i = f_i(m_i): m_i is constant, so w = f_i'(m_i) is, and
    m(t) = exp(-t w e_i^) m, R(t) = R exp(t w e_i^)."""
    if axis == 0:
        w = dh0(y[0], prm)
    elif axis == 1:
        w = dh1(y[1], prm)
    else:
        w = dh2(y[2], prm)
    c, s = cosm1_sin(tau * w)
    j = (axis + 1) % 3
    k = (axis + 2) % 3
    a = y[j]
    bb = y[k]
    y[j] = a + (c * a + s * bb)
    y[k] = bb + (c * bb - s * a)
    if attitude:
        for row in range(3):
            a = y[3 + 3 * row + j]
            bb = y[3 + 3 * row + k]
            y[3 + 3 * row + j] = a + (c * a + s * bb)
            y[3 + 3 * row + k] = bb + (c * bb - s * a)


@kernel
def flow_block(A, axis, tau, n, T, prm):
    """axis_flow for the momenta of a block of trajectories, A of shape (3, K) (structure of arrays):
    simple loops over contiguous lanes, which LLVM vectorises. The angles and their maximum come in one
    pass; f_i' is a scalar call per lane (libm's tan, for the closed loop, is most of the cost: numba has
    no vector math library without SVML)."""
    tmax = 0.0
    if axis == 0:
        for q in range(n):
            T[q] = tau * dh0(A[0, q], prm)
            tmax = max(tmax, abs(T[q]))
    elif axis == 1:
        for q in range(n):
            T[q] = tau * dh1(A[1, q], prm)
            tmax = max(tmax, abs(T[q]))
    else:
        for q in range(n):
            T[q] = tau * dh2(A[2, q], prm)
            tmax = max(tmax, abs(T[q]))
    j = (axis + 1) % 3
    k = (axis + 2) % 3
    if tmax <= 0.1:
        for q in range(n):
            t = T[q]
            t2 = t * t
            s = t * (1.0 + t2 * (-1.0 / 6 + t2 * (1.0 / 120 + t2 * (-1.0 / 5040 + t2 * (1.0 / 362880)))))
            c = t2 * (-0.5 + t2 * (1.0 / 24 + t2 * (-1.0 / 720 + t2 * (1.0 / 40320 + t2 * (-1.0 / 3628800)))))
            a = A[j, q]
            b = A[k, q]
            A[j, q] = a + (c * a + s * b)
            A[k, q] = b + (c * b - s * a)
    else:
        for q in range(n):
            c, s = cosm1_sin(T[q])
            a = A[j, q]
            b = A[k, q]
            A[j, q] = a + (c * a + s * b)
            A[k, q] = b + (c * b - s * a)


@kernel
def split_m_run(Y0, h, nsteps, save_every, OUT, INFO, P, prm):
    """split_run for d = 3 (no attitude), by blocks of 256 trajectories: the throughput loop."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, prm = borrowed((Y0, OUT, INFO, P, prm))
    B = Y0.shape[0]
    J = int(P[0])
    axes_ = np.empty(J, np.int64)
    axes = borrowed(axes_)
    taus_ = np.empty(J)
    taus = borrowed(taus_)
    for j in range(J):
        axes[j] = int(P[1 + j])
        taus[j] = P[1 + J + j] * h
    fsal = J > 1 and axes[0] == axes[J - 1]
    merged = taus[0] + taus[J - 1]
    K = 256
    A_ = np.empty((3, K))
    A = borrowed(A_)
    T_ = np.empty(K)
    T = borrowed(T_)
    for start in range(0, B, K):
        n = min(K, B - start)
        for q in range(n):
            for i in range(3):
                A[i, q] = Y0[start + q, i]
                OUT[start + q, 0, i] = A[i, q]
        isave = 1
        pending = False
        for k in range(1, nsteps + 1):
            flow_block(A, axes[0], merged if pending else taus[0], n, T, prm)
            for j in range(1, J - 1):
                flow_block(A, axes[j], taus[j], n, T, prm)
            saving = is_save(k, nsteps, save_every)
            if J > 1:
                pending = fsal and k < nsteps and not saving
                if not pending:
                    flow_block(A, axes[J - 1], taus[J - 1], n, T, prm)
            if saving:
                for q in range(n):
                    for i in range(3):
                        OUT[start + q, isave, i] = A[i, q]
                isave += 1
        for q in range(n):
            b = start + q
            INFO[b, 4] = nsteps * J
            for j in range(OUT.shape[1]):
                if not (math.isfinite(OUT[b, j, 0]) and math.isfinite(OUT[b, j, 1]) and math.isfinite(OUT[b, j, 2])):
                    fail(OUT, INFO, b, j, (j - 1) * save_every + 1, ST_NONFINITE, np.nan)
                    break
    kept((axes_, taus_, A_, T_))


@kernel
def split_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """One step is the composition P = (J, axes[J], coefficients[J]); when the first and last sub-flows
    are about the same axis, the last one of a step is merged with the first one of the next (the flows
    of one f_i commute) except where a state is saved."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, PRM = borrowed((Y0, OUT, INFO, P, PRM))
    B, d = Y0.shape
    if d == 3 and PRM.shape[0] == 1:
        split_m_run(Y0, h, nsteps, save_every, OUT, INFO, P, PRM[0])
        return
    attitude = d == 12
    J = int(P[0])
    axes = P[1 : 1 + J]
    coef = P[1 + J : 1 + 2 * J]
    fsal = J > 1 and axes[0] == axes[J - 1]
    y_ = np.empty(d)
    y = borrowed(y_)
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        pending = 0.0
        for k in range(1, nsteps + 1):
            axis_flow(y, int(axes[0]), (coef[0] + pending) * h, attitude, prm)
            for j in range(1, J - 1):
                axis_flow(y, int(axes[j]), coef[j] * h, attitude, prm)
            if J > 1:
                if fsal and k < nsteps and not is_save(k, nsteps, save_every):
                    pending = coef[J - 1]
                else:
                    axis_flow(y, int(axes[J - 1]), coef[J - 1] * h, attitude, prm)
                    pending = 0.0
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nsteps * J
    kept((y_,))


@kernel
def rotate_by(y, E, attitude, tmp):
    """m <- F^T m and R <- R F for F = I + E (the discrete momentum p = R m is unchanged), applied as
    increments (see cosm1_sin for why)."""
    for i in range(3):
        tmp[i] = E[0, i] * y[0] + E[1, i] * y[1] + E[2, i] * y[2]
    for i in range(3):
        y[i] += tmp[i]
    if attitude:
        for row in range(3):
            for i in range(3):
                tmp[i] = y[3 + 3 * row] * E[0, i] + y[4 + 3 * row] * E[1, i] + y[5 + 3 * row] * E[2, i]
            for i in range(3):
                y[3 + 3 * row + i] += tmp[i]


@kernel
def add_hat(M, c, v):
    """M += c v^ (the skew matrix of v, v^ x = v x x)."""
    M[0, 1] -= c * v[2]
    M[1, 0] += c * v[2]
    M[0, 2] += c * v[1]
    M[2, 0] -= c * v[1]
    M[1, 2] -= c * v[0]
    M[2, 1] += c * v[0]


@kernel
def cayley_e(X, F):
    """F = cay(X) - I, where cay(X) = (I - X^/2)^{-1} (I + X^/2) = I + (X^ + X^2/2) / (1 + |X|^2/4)."""
    n2 = X[0] * X[0] + X[1] * X[1] + X[2] * X[2]
    s = 1.0 / (1.0 + 0.25 * n2)
    for i in range(3):
        for j in range(3):
            F[i, j] = 0.5 * s * (X[i] * X[j] - (n2 if i == j else 0.0))
    add_hat(F, s, X)


@kernel
def _series(t2, first, nterms, deriv):
    """sum_k (-1)^k c_k t^(2k) with c_k = 1/(first + 2k)! (deriv: 2(k+1)/(first + 2k + 2)!, the series of
    the function's derivative divided by t)."""
    total = 0.0
    p = 1.0
    for k in range(nterms):
        kk = k + 1 if deriv else k
        fact = math.gamma(first + 2 * kk + 1.0)
        ck = (2.0 * kk if deriv else 1.0) / fact
        total += (-1.0) ** k * ck * p
        p *= t2
    return total


@kernel
def exp_coefficients(t):
    """a = (1 - cos t)/t^2, b = (t - sin t)/t^3 and a'(t)/t, b'(t)/t, by series below t = 1 where the
    closed forms cancel."""
    if t < 1.0:
        t2 = t * t
        return (
            _series(t2, 2, 11, False),
            _series(t2, 3, 11, False),
            _series(t2, 2, 11, True),
            _series(t2, 3, 11, True),
        )
    c, s = math.cos(t), math.sin(t)
    a = (1.0 - c) / t**2
    b = (t - s) / t**3
    da = (t * s - 2.0 * (1.0 - c)) / t**4
    db = (3.0 * s - t * c - 2.0 * t) / t**5
    return a, b, da, db


@kernel
def exp_so3_e(X, F):
    """exp(X^) - I = (sin t/t) X^ + ((1 - cos t)/t^2) X^2, t = |X| (Rodrigues)."""
    t = math.sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2])
    a, b, _, _ = exp_coefficients(t)
    sc = 1.0 - t * t * b  # sin t / t
    n2 = t * t
    for i in range(3):
        for j in range(3):
            F[i, j] = a * (X[i] * X[j] - (n2 if i == j else 0.0))
    add_hat(F, sc, X)


@kernel
def cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@kernel
def lgvi_mu(X, m, param, mu, D, u, v):
    """mu = J_r(X) m and its Jacobian D = d mu / dX, for the Cayley (param 0) or exponential (1) map;
    J_r is the right-trivialised tangent of the map (F^{-1} dF = J_r(X) dX)."""
    cross(X, m, u)  # u = X x m
    n2 = X[0] * X[0] + X[1] * X[1] + X[2] * X[2]
    if param == 0:
        s = 1.0 / (1.0 + 0.25 * n2)
        for i in range(3):
            v[i] = m[i] - 0.5 * u[i]
            mu[i] = s * v[i]
        # d(X x m)/dX = -m^, so d(m - X x m/2)/dX = m^/2
        for i in range(3):
            for j in range(3):
                D[i, j] = -0.5 * s * s * v[i] * X[j]
        add_hat(D, 0.5 * s, m)
        return
    t = math.sqrt(n2)
    a, b, da, db = exp_coefficients(t)
    cross(X, u, v)  # v = X x (X x m) = X (X.m) - m |X|^2
    xm = X[0] * m[0] + X[1] * m[1] + X[2] * m[2]
    for i in range(3):
        mu[i] = m[i] - a * u[i] + b * v[i]
        for j in range(3):
            D[i, j] = -da * u[i] * X[j] + db * v[i] * X[j] + b * (X[i] * m[j] - 2.0 * m[i] * X[j])
        D[i, i] += b * xm
    add_hat(D, a, m)


@kernel
def lgvi_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """Discrete Euler-Lagrange equations of L_d = h l(tau^{-1}(R_k^T R_{k+1}) / h) in momentum form:
    find X with X = h grad H(J_r(X) m_k); then F = tau(X), R_{k+1} = R_k F, m_{k+1} = F^T m_k."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, PRM = borrowed((Y0, OUT, INFO, P, PRM))
    B, d = Y0.shape
    attitude = d == 12
    param = int(P[0])
    y_, m_, X_, Xp_, Xpp_, r_ = np.empty(d), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    y, m, X, Xp, Xpp, r = borrowed((y_, m_, X_, Xp_, Xpp_, r_))
    mu_, g_, u_, v_, tmp_ = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    mu, g, u, v, tmp = borrowed((mu_, g_, u_, v_, tmp_))
    D_, hm_, A_, F_ = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    D, hm, A, F = borrowed((D_, hm_, A_, F_))
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        for i in range(3):
            m[i] = y[i]
        call_model4(FP[F_GHESS3], m, g, hm, prm)
        nrhs = 1
        nnewton = 0
        for i in range(3):
            Xp[i] = h * g[i]
            Xpp[i] = Xp[i]
        for k in range(1, nsteps + 1):
            for i in range(3):
                m[i] = y[i]
                X[i] = 2.0 * Xp[i] - Xpp[i] if k > 2 else Xp[i]
            scale = max(1.0, max_abs(X))
            dprev = 0.0
            code = ST_NEWTON
            resid = np.inf
            for it in range(maxit):
                lgvi_mu(X, m, param, mu, D, u, v)
                call_model4(FP[F_GHESS3], mu, g, hm, prm)
                nrhs += 1
                nnewton += 1
                for i in range(3):
                    r[i] = h * g[i] - X[i]
                    for j in range(3):
                        A[i, j] = -h * (hm[i, 0] * D[0, j] + hm[i, 1] * D[1, j] + hm[i, 2] * D[2, j])
                    A[i, i] += 1.0
                resid = max_abs(r)
                state, dprev = newton_update(A, r, X, 3, dprev, it, scale, tol)
                if state >= 0:
                    code = state
                    break
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            if param == 0:
                cayley_e(X, F)
            else:
                exp_so3_e(X, F)
            rotate_by(y, F, attitude, tmp)
            for i in range(3):
                Xpp[i] = Xp[i]
                Xp[i] = X[i]
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = nnewton
        INFO[b, 4] = nrhs
    kept((y_, m_, X_, Xp_, Xpp_, r_, mu_, g_, u_, v_, tmp_, D_, hm_, A_, F_))


@kernel
def cg_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """An explicit Crouch-Grossman method for m' = m x w, R' = R w^, w = grad H(m): every stage and the step
    are products of the rotations exp(h a_ij w_j^) (m <- F^T m, R <- R F), so |m|, R in SO(3) and R m are kept
    to round-off. P = (s, A (row-major, strictly lower), b)."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, PRM = borrowed((Y0, OUT, INFO, P, PRM))
    B, d = Y0.shape
    attitude = d == 12
    s = int(P[0])
    a = P[1 : 1 + s * s]
    bw = P[1 + s * s : 1 + s * s + s]
    y_, m_, X_, tmp_ = np.empty(d), np.empty(3), np.empty(3), np.empty(3)
    y, m, X, tmp = borrowed((y_, m_, X_, tmp_))
    W_ = np.empty((s, 3))
    W = borrowed(W_)
    E_, hm_ = np.empty((3, 3)), np.empty((3, 3))
    E, hm = borrowed((E_, hm_))
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        nrhs = 0
        for k in range(1, nsteps + 1):
            for i in range(s):
                for u in range(3):
                    m[u] = y[u]
                for j in range(i):
                    if a[i * s + j] != 0.0:
                        for u in range(3):
                            X[u] = h * a[i * s + j] * W[j, u]
                        exp_so3_e(X, E)
                        rotate_by(m, E, False, tmp)
                call_model4(FP[F_GHESS3], m, W[i], hm, prm)
            nrhs += s
            for j in range(s):
                for u in range(3):
                    X[u] = h * bw[j] * W[j, u]
                exp_so3_e(X, E)
                rotate_by(y, E, attitude, tmp)
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nrhs
    kept((y_, m_, X_, tmp_, W_, E_, hm_))


@kernel
def mv_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """Moser-Veselov: h m_k^ = F J_d - J_d F^T with J_d = tr(I)/2 - I; with F = cay(2 f) this reads
    h m + h m x f + f (f . h m) - 2 I f = 0 (Lee, Leok & McClamroch 2007), solved for f by Newton;
    then m_{k+1} = F^T m_k, R_{k+1} = R_k F."""
    # every array borrowed (see erk_run): the arguments, the work arrays kept to the end
    Y0, OUT, INFO, P, PRM = borrowed((Y0, OUT, INFO, P, PRM))
    B, d = Y0.shape
    attitude = d == 12
    inertia_ = np.empty((3, 3))
    inertia = borrowed(inertia_)
    for i in range(3):
        for j in range(3):
            inertia[i, j] = P[3 * i + j]
    y_, m_, f_, fp_, fpp_, r_ = np.empty(d), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    y, m, f, fp, fpp, r = borrowed((y_, m_, f_, fp_, fpp_, r_))
    u_, tmp_, X_ = np.empty(3), np.empty(3), np.empty(3)
    u, tmp, X = borrowed((u_, tmp_, X_))
    A_, F_, Iinv_ = np.empty((3, 3)), np.empty((3, 3)), np.linalg.inv(inertia)
    A, F, Iinv = borrowed((A_, F_, Iinv_))
    for b in range(B):
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        nnewton = 0
        for i in range(3):
            fp[i] = 0.5 * h * (Iinv[i, 0] * y[0] + Iinv[i, 1] * y[1] + Iinv[i, 2] * y[2])
            fpp[i] = fp[i]
        for k in range(1, nsteps + 1):
            for i in range(3):
                m[i] = h * y[i]
                f[i] = 2.0 * fp[i] - fpp[i] if k > 2 else fp[i]
            scale = max(1.0, max_abs(f))
            dprev = 0.0
            code = ST_NEWTON
            resid = np.inf
            for it in range(maxit):
                cross(m, f, u)
                fm = f[0] * m[0] + f[1] * m[1] + f[2] * m[2]
                for i in range(3):
                    r[i] = -(
                        m[i]
                        + u[i]
                        + f[i] * fm
                        - 2.0 * (inertia[i, 0] * f[0] + inertia[i, 1] * f[1] + inertia[i, 2] * f[2])
                    )
                    for j in range(3):
                        A[i, j] = f[i] * m[j] - 2.0 * inertia[i, j]
                    A[i, i] += fm
                # d(m x f)/df = m^
                add_hat(A, 1.0, m)
                nnewton += 1
                resid = max_abs(r)
                state, dprev = newton_update(A, r, f, 3, dprev, it, scale, tol)
                if state >= 0:
                    code = state
                    break
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            for i in range(3):
                X[i] = 2.0 * f[i]
                fpp[i] = fp[i]
                fp[i] = f[i]
            cayley_e(X, F)
            rotate_by(y, F, attitude, tmp)
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = nnewton
    kept((inertia_, y_, m_, f_, fp_, fpp_, r_, u_, tmp_, X_, A_, F_, Iinv_))
