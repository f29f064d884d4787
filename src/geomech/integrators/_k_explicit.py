"""Loop template: explicit methods for any ODE ``y' = rhs(y, prm)`` (classical RK4, Adams-Bashforth-Moulton 4,
the stages, error norms and continuous extensions of embedded Runge-Kutta pairs, one period of a periodic orbit;
the adaptive loop of the pairs is ``_k_embedded.py``).

See ``_k_common.py`` for the template mechanism and the common loop signature.
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ._fptr import borrowed, call_model, kept
from ._k_common import (
    F_RHS,
    SAVE0,
    STAGE1,
    finish_step,
    finite,
    kernel,
    load,
    param_row,
    store,
)

# <<< template preamble


@kernel
def rk4_step(fp, y, h, k1, k2, k3, k4, tmp, prm):
    d = y.shape[0]
    call_model(fp, y, k1, prm)
    for i in range(d):
        tmp[i] = y[i] + 0.5 * h * k1[i]
    call_model(fp, tmp, k2, prm)
    for i in range(d):
        tmp[i] = y[i] + 0.5 * h * k2[i]
    call_model(fp, tmp, k3, prm)
    for i in range(d):
        tmp[i] = y[i] + h * k3[i]
    call_model(fp, tmp, k4, prm)
    for i in range(d):
        y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@kernel
def rk4_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    B, d = Y0.shape
    fp = FP[F_RHS]
    Y0, OUT, INFO, PRM = borrowed(Y0), borrowed(OUT), borrowed(INFO), borrowed(PRM)  # see erk_run
    W_ = np.empty((6, d))
    W = borrowed(W_)
    y, k1, k2, k3, k4, tmp = W[0], W[1], W[2], W[3], W[4], W[5]
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        done = 0
        for k in range(1, nsteps + 1):
            rk4_step(fp, y, h, k1, k2, k3, k4, tmp, prm)
            done = k
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = 4.0 * done
    kept((W_,))


@kernel
def abm4_run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, PRM):
    """Adams-Bashforth-Moulton PECE of order 4, started by three RK4 steps.

    P: y* = y_n + h/24 (55 f_n - 59 f_{n-1} + 37 f_{n-2} - 9 f_{n-3});  E: f* = f(y*);
    C: y_{n+1} = y_n + h/24 (9 f* + 19 f_n - 5 f_{n-1} + f_{n-2});  E: f_{n+1} = f(y_{n+1}).
    """
    B, d = Y0.shape
    Y0, OUT, INFO, PRM = borrowed(Y0), borrowed(OUT), borrowed(INFO), borrowed(PRM)  # see erk_run
    W_ = np.empty((11, d))
    W = borrowed(W_)
    y, k1, k2, k3, k4, tmp, fstar = W[0], W[1], W[2], W[3], W[4], W[5], W[6]
    F = W[7:11]  # F[j] = f_{n-j}
    fp = FP[F_RHS]
    for b in range(B):
        prm = param_row(PRM, b)
        load(y, Y0, b)
        store(OUT, b, SAVE0, y)
        isave = 1
        nrhs = 1
        call_model(fp, y, F[0], prm)
        for k in range(1, nsteps + 1):
            if k <= 3:
                rk4_step(fp, y, h, k1, k2, k3, k4, tmp, prm)
                nrhs += 4
            else:
                for i in range(d):
                    tmp[i] = y[i] + h / 24.0 * (55.0 * F[0, i] - 59.0 * F[1, i] + 37.0 * F[2, i] - 9.0 * F[3, i])
                call_model(fp, tmp, fstar, prm)
                for i in range(d):
                    y[i] += h / 24.0 * (9.0 * fstar[i] + 19.0 * F[0, i] - 5.0 * F[1, i] + F[2, i])
                nrhs += 1
            for j in range(3, 0, -1):
                for i in range(d):
                    F[j, i] = F[j - 1, i]
            call_model(fp, y, F[0], prm)
            nrhs += 1
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nrhs
    kept((W_,))


# -- periodic orbits: one period by an embedded Runge-Kutta pair of order 8(5,3) -------------------------
# The tableau (A, B) and the error weights (E5, E3, on the 12 stages and f at the new point) come in as
# arrays: Dormand & Prince's DOP853 (Hairer, Norsett & Wanner, Solving ODEs I, II.10).


@kernel
def erk_stages(fp, y, h, A, K, tmp, first, stop, prm):
    """Stages first..stop-1 of an explicit Runge-Kutta step of size h from y (K[0] holds f(y), and every
    stage before ``first`` is computed); the model's right-hand side at the address ``fp``."""
    d = y.shape[0]
    for s in range(first, stop):
        for i in range(d):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            tmp[i] = y[i] + h * acc
        call_model(fp, tmp, K[s], prm)


@kernel
def erk_increment(h, B, K, ns, i):
    acc = 0.0
    for j in range(ns):
        acc += B[j] * K[j, i]
    return h * acc


@kernel
def first_step_guess(y0, f0, rtol, atol):
    """Hairer's first guess of the initial step, h0, and the scaled RMS size of f(y0), d1 ([HNW] II.4)."""
    d = y0.shape[0]
    d0 = 0.0
    d1 = 0.0
    for i in range(d):
        sc = atol + rtol * abs(y0[i])
        d0 += (y0[i] / sc) ** 2
        d1 += (f0[i] / sc) ** 2
    d0 = math.sqrt(d0 / d)
    d1 = math.sqrt(d1 / d)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    return h0, d1


@kernel
def first_step(y0, f0, f1, h0, d1, rtol, atol, q):
    """The initial step from f0 = f(y0) and f1 = f(y0 + h0 f0), for an error estimate of order q."""
    d = y0.shape[0]
    d2 = 0.0
    for i in range(d):
        sc = atol + rtol * abs(y0[i])
        d2 += ((f1[i] - f0[i]) / sc) ** 2
    d2 = math.sqrt(d2 / d) / h0
    if max(d1, d2) <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (q + 1.0))
    return min(100.0 * h0, h1)


@kernel
def erk_error_norm(y, ynew, K, E, E2, n, h, rtol, atol, combined):
    """The scaled error estimate of a step: the RMS of h E.K / (atol + rtol max(|y|, |y1|)), or with
    ``combined`` DOP853's blend of its 5th- and 3rd-order estimates, |h| e5^2 / sqrt((e5^2 + e3^2 / 100) d).
    Infinite where the estimate is not finite."""
    d = y.shape[0]
    a = 0.0
    c = 0.0
    for i in range(d):
        sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
        e = 0.0
        e2 = 0.0
        for j in range(n):
            e += E[j] * K[j, i]
            e2 += E2[j] * K[j, i]
        a += (e / sc) ** 2
        c += (e2 / sc) ** 2
    if not (math.isfinite(a) and math.isfinite(c)):
        return np.inf
    if combined:
        if a == 0.0 and c == 0.0:
            return 0.0
        return abs(h) * a / math.sqrt((a + 0.01 * c) * d)
    return abs(h) * math.sqrt(a / d)


@kernel
def dense_coefficients(h, D, K, F):
    """F[k] = h sum_j D[k, j] K[j]: the vectors of a step's continuous extension."""
    for k in range(D.shape[0]):
        for i in range(F.shape[1]):
            acc = 0.0
            for j in range(D.shape[1]):
                acc += D[k, j] * K[j, i]
            F[k, i] = h * acc


@kernel
def dense_value(y, F, theta, alternating, out):
    """The continuous extension at theta: y + sum_k F_k theta^(k+1), or Hairer's nested form
    theta (F_0 + (1 - theta)(F_1 + theta (F_2 + ...)))."""
    npow = F.shape[0]
    for i in range(y.shape[0]):
        acc = 0.0
        for q in range(npow):
            acc += F[npow - 1 - q, i]
            if not alternating or q % 2 == 0:
                acc *= theta
            else:
                acc *= 1.0 - theta
        out[i] = y[i] + acc


@kernel
def chart_margin(y, CH):
    """How far y is inside the chart CH (rows: component, lower, upper bound): the smallest distance to a
    bound, negative outside (or NaN); +inf without a chart."""
    m = np.inf
    for r in range(CH.shape[0]):
        v = y[int(CH[r, 0])]
        m = min(m, v - CH[r, 1], CH[r, 2] - v)
        if v != v:
            return np.nan
    return m


@kernel
def chart_exit(y, F, dop853, CH, out):
    """The fraction theta in (0, 1] of a step at which its continuous extension leaves the chart CH (y is
    inside, the end of the step is not): bisection to the resolution of doubles; ``out`` holds the state at
    the last theta inside."""
    lo = 0.0
    hi = 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        dense_value(y, F, mid, dop853, out)
        if chart_margin(out, CH) > 0.0:
            lo = mid
        else:
            hi = mid
    dense_value(y, F, lo, dop853, out)
    return hi


@kernel
def section_value(f0, y, y0, shift, w):
    """g_w(y) = f(y0) . (y - y0 - w shift): the section through y0 (shifted by w angle periods) normal to
    the flow at y0; the orbit crosses it increasingly at its return."""
    g = 0.0
    for i in range(y.shape[0]):
        g += f0[i] * (y[i] - y0[i] - w * shift[i])
    return g


@kernel
def orbit_return(fp, y0, A, B, E5, E3, tol, shift, lo, hi, max_steps, TM, YM, INFO, prm):
    """Integrate y' = f(y) from y0 until the first return to y0 (to y0 + w shift, w = +-1, for a rotation
    of an angle coordinate), adaptive steps of the 8th-order solution, errors estimated as DOP853 does.

    The accepted mesh (TM[k], YM[k]) is kept: the state at any time in [0, T) is then one Runge-Kutta
    step from a mesh point. The return time is the root of the section function on the last step, found
    by Newton's method in the step size (each iterate one Runge-Kutta step). Time and state are summed
    with compensation (Kahan), so that round-off stays at a few ulps over the period.

    INFO: status (0 returned, 1 step budget spent, 2 non-finite or p left (lo, hi), 3 step size
    underflow), mesh points, period, winding, local error estimates summed and divided by |f(y0)| (a
    bound on the error of the period), evaluations of f,
    min and max of |f| along the orbit, the index of the mesh point where |f| is smallest.
    """
    d = y0.shape[0]
    ns = 12
    K = np.empty((ns + 1, d))
    y = np.empty(d)
    ynew = np.empty(d)
    comp = np.empty(d)
    dy = np.empty(d)
    tmp = np.empty(d)
    f0 = np.empty(d)
    z = np.empty(d)
    fz = np.empty(d)
    for i in range(d):
        y[i] = y0[i]
        comp[i] = 0.0
        YM[0, i] = y0[i]
    TM[0] = 0.0
    call_model(fp, y, f0, prm)
    for i in range(d):
        K[0, i] = f0[i]
    nfev = 1
    INFO[0] = 0.0
    for j in range(INFO.shape[0]):
        INFO[j] = 0.0
    f00 = 0.0
    for i in range(d):
        f00 += f0[i] * f0[i]
    fmin = math.sqrt(f00)
    fmax = fmin
    imin = 0
    if not (f00 > 0.0) or not math.isfinite(f00):
        INFO[0] = 3.0
        INFO[5] = nfev
        return
    # initial step (Hairer, Norsett & Wanner II.4): a first-order guess, then the order-8 rule
    h0, d1 = first_step_guess(y0, f0, tol, tol)
    for i in range(d):
        tmp[i] = y0[i] + h0 * f0[i]
    call_model(fp, tmp, fz, prm)
    nfev += 1
    h = first_step(y0, f0, fz, h0, d1, tol, tol, np.int64(7))
    t = 0.0
    tcomp = 0.0
    errsum = 0.0
    k = 0
    periodic = shift[0] != 0.0 or (d > 1 and shift[1] != 0.0)
    while True:
        if k >= max_steps:
            INFO[0] = 1.0
            break
        erk_stages(fp, y, h, A, K, tmp, STAGE1, ns, prm)
        for i in range(d):
            dy[i] = erk_increment(h, B, K, ns, i) + comp[i]
            ynew[i] = y[i] + dy[i]
        call_model(fp, ynew, K[ns], prm)
        nfev += ns
        ok = finite(ynew)
        if not ok:
            h *= 0.25
            if h < 1e-14 * max(1.0, t):
                INFO[0] = 2.0
                break
            continue
        err = erk_error_norm(y, ynew, K, E5, E3, ns + 1, h, tol, tol, True)
        if err > 1.0:
            h *= max(0.2, 0.9 * err ** (-1.0 / 8.0))
            if h < 1e-14 * max(1.0, t):
                INFO[0] = 3.0
                break
            continue
        if d > 1 and not (lo < ynew[d - 1] < hi):
            INFO[0] = 2.0
            break
        errsum += err * tol
        # the return: the section about the nearest copy of y0 is crossed upwards near it
        w = 0.0
        if periodic:
            w = float(round((ynew[0] - y0[0]) / shift[0])) if shift[0] != 0.0 else 0.0
            w = max(-1.0, min(1.0, w))
        ga = section_value(f0, y, y0, shift, w)
        gb = section_value(f0, ynew, y0, shift, w)
        found = False
        if ga < 0.0 <= gb and (k > 0 or w != 0.0):
            chord = 0.0
            da = 0.0
            db = 0.0
            for i in range(d):
                chord += (ynew[i] - y[i]) ** 2
                da += (y[i] - y0[i] - w * shift[i]) ** 2
                db += (ynew[i] - y0[i] - w * shift[i]) ** 2
            if da <= 4.0 * chord and db <= 4.0 * chord:
                tau = h * (-ga) / (gb - ga)
                for _newton in range(8):
                    erk_stages(fp, y, tau, A, K, tmp, STAGE1, ns, prm)
                    for i in range(d):
                        z[i] = y[i] + (erk_increment(tau, B, K, ns, i) + comp[i])
                    call_model(fp, z, fz, prm)
                    nfev += ns
                    gz = section_value(f0, z, y0, shift, w)
                    slope = 0.0
                    for i in range(d):
                        slope += f0[i] * fz[i]
                    dtau = -gz / slope
                    tau += dtau
                    if abs(dtau) <= 4e-16 * (t + tau):
                        break
                dist = 0.0
                for i in range(d):
                    dist += (z[i] - y0[i] - w * shift[i]) ** 2
                if dist <= 1e-12 * chord:
                    found = True
                    INFO[2] = t + (tau + tcomp)
                    INFO[3] = w
                    k += 1
                    TM[k] = INFO[2]
                    for i in range(d):
                        YM[k, i] = z[i]
                    break
                # else a crossing away from y0 (the curve is not convex): accept the step and go on
        if found:
            break
        # accept: compensated sums of time and state
        dt = h + tcomp
        tn = t + dt
        tcomp = (t - tn) + dt
        t = tn
        for i in range(d):
            comp[i] = (y[i] - ynew[i]) + dy[i]
            y[i] = ynew[i]
        k += 1
        TM[k] = t
        fn = 0.0
        for i in range(d):
            YM[k, i] = y[i]
            K[0, i] = K[ns, i]
            fn += K[ns, i] * K[ns, i]
        fn = math.sqrt(fn)
        if fn < fmin:
            fmin = fn
            imin = k
        fmax = max(fmax, fn)
        h *= min(10.0, 0.9 * err ** (-1.0 / 8.0)) if err > 0.0 else 10.0
    INFO[1] = k + 1
    INFO[4] = errsum / math.sqrt(f00)
    INFO[5] = nfev
    INFO[6] = fmin
    INFO[7] = fmax
    INFO[8] = imin


@kernel
def orbit_states(fp, YM, TM, idx, tau, A, B, OUT, prm):
    """OUT[j] = one Runge-Kutta step of size tau[j] from the mesh point idx[j] (dense output)."""
    d = YM.shape[1]
    ns = 12
    K = np.empty((ns + 1, d))
    y = np.empty(d)
    tmp = np.empty(d)
    last = -1
    for j in range(idx.shape[0]):
        m = idx[j]
        if m != last:
            for i in range(d):
                y[i] = YM[m, i]
            call_model(fp, y, K[0], prm)
            last = m
        if tau[j] == 0.0:
            for i in range(d):
                OUT[j, i] = y[i]
            continue
        erk_stages(fp, y, tau[j], A, K, tmp, STAGE1, ns, prm)
        for i in range(d):
            OUT[j, i] = y[i] + erk_increment(tau[j], B, K, ns, i)
