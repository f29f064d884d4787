import math
import numpy as np
import numba

kernel = numba.njit(cache=True, nogil=True, error_model='numpy')

@kernel
def ham(y):
    _a0 = y[0]
    _a1 = y[1]
    _c0 = _a1**2
    return 0.5*_c0 + (0.5 - 0.5*_c0)*(0.3333333333333333*math.sin(_a0)**2 + 0.5*math.cos(_a0)**2) + 2.0*math.log(math.cos(1.0*_a1))


@kernel
def grad(y, out0):
    _a0 = y[0]
    _a1 = y[1]
    _c0 = math.cos(_a0)
    _c1 = math.sin(_a0)
    _c2 = 1.0*_a1
    out0[0] = -0.33333333333333337*_c0*_c1*(0.5 - 0.5*_a1**2)
    out0[1] = -_a1*(0.5*_c0**2 + 0.3333333333333333*_c1**2) + 1.0*_a1 - 2.0*math.sin(_c2)/math.cos(_c2)


@kernel
def ghess(y, out0, out1):
    _a0 = y[0]
    _a1 = y[1]
    _c0 = 0.16666666666666669 - 0.16666666666666669*_a1**2
    _c1 = math.cos(_a0)
    _c2 = math.sin(_a0)
    _c3 = _c1*_c2
    _c4 = _c1**2
    _c5 = _c2**2
    _c6 = 0.5*_c4 + 0.3333333333333333*_c5
    _c7 = 1.0*_a1
    _c8 = math.cos(_c7)
    _c9 = math.sin(_c7)
    _c10 = 0.33333333333333337*_a1*_c3
    out0[0] = -_c0*_c3
    out0[1] = -_a1*_c6 + 1.0*_a1 - 2.0*_c9/_c8
    out1[0, 0] = -_c0*_c4 + _c0*_c5
    out1[0, 1] = _c10
    out1[1, 0] = _c10
    out1[1, 1] = -_c6 - 1.0 - 2.0*_c9**2/_c8**2


@kernel
def rhs(y, out0):
    _a0 = y[0]
    _a1 = y[1]
    _c0 = math.cos(_a0)
    _c1 = math.sin(_a0)
    _c2 = 1.0*_a1
    out0[0] = -_a1*(0.5*_c0**2 + 0.3333333333333333*_c1**2) + 1.0*_a1 - 2.0*math.sin(_c2)/math.cos(_c2)
    out0[1] = 0.33333333333333337*_c0*_c1*(0.5 - 0.5*_a1**2)


@kernel
def fjac(y, out0, out1):
    _a0 = y[0]
    _a1 = y[1]
    _c0 = math.cos(_a0)
    _c1 = _c0**2
    _c2 = math.sin(_a0)
    _c3 = _c2**2
    _c4 = 0.5*_c1 + 0.3333333333333333*_c3
    _c5 = 1.0*_a1
    _c6 = math.cos(_c5)
    _c7 = math.sin(_c5)
    _c8 = 0.5 - 0.5*_a1**2
    _c9 = 0.33333333333333337*_c8
    _c10 = _c0*_c2
    _c11 = 0.33333333333333337*_a1*_c10
    out0[0] = -_a1*_c4 + 1.0*_a1 - 2.0*_c7/_c6
    out0[1] = _c10*_c9
    out1[0, 0] = _c11
    out1[0, 1] = -_c4 - 1.0 - 2.0*_c7**2/_c6**2
    out1[1, 0] = 0.33333333333333337*_c1*_c8 - _c3*_c9
    out1[1, 1] = -_c11


@kernel
def gf_all(y, out0, out1, out2, out3):
    return


@kernel
def gf_grads(y, out0, out1):
    return


# ---- _k_common.py ----
"""Loop template: helpers shared by every integrator loop (status codes, saving, Newton, small solves).

Template modules (``_k_*.py``) are not imported as such by the solver: :mod:`._codegen` concatenates
them, minus their preamble, after the generated model functions and compiles the result with numba
(or runs it as Python). Every loop has the signature

``run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P)``

with ``Y0`` the initial states ``(B, d)``, ``OUT`` the saved states ``(B, n_save, d)`` (state 0, every
``save_every`` steps, and the last), ``INFO`` ``(B, 5)``: status, failing step, residual, Newton
iterations, right-hand-side evaluations, and ``P`` the method's constants.
"""

import math

import numpy as np


ST_OK = 0
ST_NEWTON = 1
ST_NONFINITE = 2
ST_SINGULAR = 3
EPS = 2.220446049250313e-16


@kernel
def finite(y):
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return False
    return True


@kernel
def store(OUT, b, isave, y):
    for i in range(y.shape[0]):
        OUT[b, isave, i] = y[i]


@kernel
def is_save(k, nsteps, save_every):
    return k % save_every == 0 or k == nsteps


@kernel
def fail(OUT, INFO, b, isave, k, code, residual):
    """Mark trajectory ``b`` failed at step ``k``: its later saved states are NaN, flagged in INFO."""
    INFO[b, 0] = code
    INFO[b, 1] = k
    INFO[b, 2] = residual
    for j in range(isave, OUT.shape[1]):
        for i in range(OUT.shape[2]):
            OUT[b, j, i] = np.nan


@kernel
def finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y):
    """After step k: flag a non-finite state (returns -1), else save it when due; returns the next save
    index."""
    if not finite(y):
        fail(OUT, INFO, b, isave, k, ST_NONFINITE, np.nan)
        return -1
    if is_save(k, nsteps, save_every):
        store(OUT, b, isave, y)
        return isave + 1
    return isave


@kernel
def max_abs(v):
    r = 0.0
    for i in range(v.shape[0]):
        a = abs(v[i])
        if a > r or a != a:
            r = a
    return r


@kernel
def newton_done(dnorm, dprev, it, scale, tol):
    """Newton stopping test on the size of the correction, relative to ``scale = max(1, |y|)``.

    Converged when the correction is below ``tol * scale``, or when the contraction rate
    ``theta = |d_k| / |d_{k-1}|`` predicts that the remaining error ``theta/(1-theta) |d_k|`` is (Hairer &
    Wanner, Solving ODEs II, IV.8), or when the corrections stopped decreasing at the round-off floor.
    """
    if dnorm <= tol * scale:
        return True
    if it > 0 and dprev > 0.0:
        theta = dnorm / dprev
        if theta < 1.0:
            return theta / (1.0 - theta) * dnorm <= tol * scale
        return dnorm <= 64.0 * EPS * scale
    return False


@kernel
def newton_update(A, r, x, n, dprev, it, scale, tol):
    """One Newton correction: solve A d = r (``r`` is overwritten by d), x += d. Returns (state, |d|) with
    state 0 converged, -1 not yet, ST_SINGULAR or ST_NEWTON (a non-finite correction) on failure."""
    if not lu_solve(A, r, n):
        return ST_SINGULAR, np.inf
    for i in range(n):
        x[i] += r[i]
    dn = max_abs(r)
    if not math.isfinite(dn):
        return ST_NEWTON, dn
    if newton_done(dn, dprev, it, scale, tol):
        return 0, dn
    return -1, dn


@kernel
def lu_solve(A, x, n):
    """Solve ``A x = b`` in place (``x`` holds ``b``), Gaussian elimination with partial pivoting on the
    leading ``n x n`` block; ``A`` is overwritten. Returns False if a pivot is zero or not finite."""
    if n == 2:
        # one-degree-of-freedom systems, the common case: Cramer's rule, scaled against overflow
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        scale = max(abs(A[0, 0]) * abs(A[1, 1]), abs(A[0, 1]) * abs(A[1, 0]))
        if not (abs(det) > 1e-14 * scale) or not math.isfinite(det):
            return False
        x0 = (A[1, 1] * x[0] - A[0, 1] * x[1]) / det
        x[1] = (A[0, 0] * x[1] - A[1, 0] * x[0]) / det
        x[0] = x0
        return True
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        if not (amax > 0.0) or not math.isfinite(amax):
            return False
        if p != k:
            for j in range(n):
                t = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = t
            t = x[k]
            x[k] = x[p]
            x[p] = t
        piv = A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] / piv
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                x[i] -= f * x[k]
    for k in range(n - 1, -1, -1):
        s = x[k]
        for j in range(k + 1, n):
            s -= A[k, j] * x[j]
        x[k] = s / A[k, k]
    return True


# ---- _k_explicit.py ----
"""Loop template: explicit methods for any ODE ``y' = rhs(y)`` (classical RK4, Adams-Bashforth-Moulton 4).

See ``_k_common.py`` for the template mechanism and the common loop signature.
"""

import math

import numpy as np



@kernel
def rk4_step(y, h, k1, k2, k3, k4, tmp):
    d = y.shape[0]
    rhs(y, k1)
    for i in range(d):
        tmp[i] = y[i] + 0.5 * h * k1[i]
    rhs(tmp, k2)
    for i in range(d):
        tmp[i] = y[i] + 0.5 * h * k2[i]
    rhs(tmp, k3)
    for i in range(d):
        tmp[i] = y[i] + h * k3[i]
    rhs(tmp, k4)
    for i in range(d):
        y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@kernel
def rk4_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    B, d = Y0.shape
    y = np.empty(d)
    k1, k2, k3, k4, tmp = np.empty(d), np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        done = 0
        for k in range(1, nsteps + 1):
            rk4_step(y, h, k1, k2, k3, k4, tmp)
            done = k
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = 4.0 * done


@kernel
def abm4_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """Adams-Bashforth-Moulton PECE of order 4, started by three RK4 steps.

    P: y* = y_n + h/24 (55 f_n - 59 f_{n-1} + 37 f_{n-2} - 9 f_{n-3});  E: f* = f(y*);
    C: y_{n+1} = y_n + h/24 (9 f* + 19 f_n - 5 f_{n-1} + f_{n-2});  E: f_{n+1} = f(y_{n+1}).
    """
    B, d = Y0.shape
    y = np.empty(d)
    F = np.empty((4, d))  # F[j] = f_{n-j}
    k1, k2, k3, k4, tmp = np.empty(d), np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    fp = np.empty(d)
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        nrhs = 1
        rhs(y, F[0])
        for k in range(1, nsteps + 1):
            if k <= 3:
                rk4_step(y, h, k1, k2, k3, k4, tmp)
                nrhs += 4
            else:
                for i in range(d):
                    tmp[i] = y[i] + h / 24.0 * (55.0 * F[0, i] - 59.0 * F[1, i] + 37.0 * F[2, i] - 9.0 * F[3, i])
                rhs(tmp, fp)
                for i in range(d):
                    y[i] += h / 24.0 * (9.0 * fp[i] + 19.0 * F[0, i] - 5.0 * F[1, i] + F[2, i])
                nrhs += 1
            for j in range(3, 0, -1):
                F[j, :] = F[j - 1, :]
            rhs(y, F[0])
            nrhs += 1
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nrhs


# -- periodic orbits: one period by an embedded Runge-Kutta pair of order 8(5,3) -------------------------
# The tableau (A, B) and the error weights (E5, E3, on the 12 stages and f at the new point) come in as
# arrays: Dormand & Prince's DOP853 (Hairer, Norsett & Wanner, Solving ODEs I, II.10).


@kernel
def erk_stages(y, h, A, K, tmp, ns):
    """Stages 1..ns-1 of an explicit Runge-Kutta step of size h from y (K[0] holds f(y))."""
    d = y.shape[0]
    for s in range(1, ns):
        for i in range(d):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            tmp[i] = y[i] + h * acc
        rhs(tmp, K[s])


@kernel
def erk_increment(h, B, K, ns, i):
    acc = 0.0
    for j in range(ns):
        acc += B[j] * K[j, i]
    return h * acc


@kernel
def section_value(f0, y, y0, shift, w):
    """g_w(y) = f(y0) . (y - y0 - w shift): the section through y0 (shifted by w angle periods) normal to
    the flow at y0; the orbit crosses it increasingly at its return."""
    g = 0.0
    for i in range(y.shape[0]):
        g += f0[i] * (y[i] - y0[i] - w * shift[i])
    return g


@kernel
def orbit_return(y0, A, B, E5, E3, tol, shift, lo, hi, max_steps, TM, YM, INFO):
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
    rhs(y, f0)
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
    d0 = 0.0
    d1 = 0.0
    for i in range(d):
        sc = tol + tol * abs(y0[i])
        d0 += (y0[i] / sc) ** 2
        d1 += (f0[i] / sc) ** 2
    d0 = math.sqrt(d0 / d)
    d1 = math.sqrt(d1 / d)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    for i in range(d):
        tmp[i] = y0[i] + h0 * f0[i]
    rhs(tmp, fz)
    nfev += 1
    d2 = 0.0
    for i in range(d):
        sc = tol + tol * abs(y0[i])
        d2 += ((fz[i] - f0[i]) / sc) ** 2
    d2 = math.sqrt(d2 / d) / h0
    if max(d1, d2) <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    h = min(100.0 * h0, h1)
    t = 0.0
    tcomp = 0.0
    errsum = 0.0
    k = 0
    periodic = shift[0] != 0.0 or (d > 1 and shift[1] != 0.0)
    while True:
        if k >= max_steps:
            INFO[0] = 1.0
            break
        erk_stages(y, h, A, K, tmp, ns)
        for i in range(d):
            dy[i] = erk_increment(h, B, K, ns, i) + comp[i]
            ynew[i] = y[i] + dy[i]
        rhs(ynew, K[ns])
        nfev += ns
        err5 = 0.0
        err3 = 0.0
        ok = True
        for i in range(d):
            sc = tol + tol * max(abs(y[i]), abs(ynew[i]))
            e5 = 0.0
            e3 = 0.0
            for j in range(ns + 1):
                e5 += E5[j] * K[j, i]
                e3 += E3[j] * K[j, i]
            err5 += (e5 / sc) ** 2
            err3 += (e3 / sc) ** 2
            if not math.isfinite(ynew[i]):
                ok = False
        if not ok:
            h *= 0.25
            if h < 1e-14 * max(1.0, t):
                INFO[0] = 2.0
                break
            continue
        if err5 == 0.0 and err3 == 0.0:
            err = 0.0
        else:
            err = abs(h) * err5 / math.sqrt((err5 + 0.01 * err3) * d)
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
                    erk_stages(y, tau, A, K, tmp, ns)
                    for i in range(d):
                        z[i] = y[i] + (erk_increment(tau, B, K, ns, i) + comp[i])
                    rhs(z, fz)
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
def orbit_states(YM, TM, idx, tau, A, B, OUT):
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
            rhs(y, K[0])
            last = m
        if tau[j] == 0.0:
            for i in range(d):
                OUT[j, i] = y[i]
            continue
        erk_stages(y, tau[j], A, K, tmp, ns)
        for i in range(d):
            OUT[j, i] = y[i] + erk_increment(tau[j], B, K, ns, i)


# ---- _k_implicit.py ----
"""Loop template: implicit Runge-Kutta methods for any ODE with a Jacobian: the implicit midpoint rule and
Gauss-Legendre collocation, solved by Newton's method with the exact Jacobian ``fjac``.

See ``_k_common.py`` for the template mechanism and the common loop signature.
"""

import math

import numpy as np



@kernel
def midpoint_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """y_{n+1} = y_n + h f((y_n + y_{n+1})/2), as Z = (y_{n+1} - y_n)/2 solving Z = (h/2) f(y_n + Z).

    The predictor extrapolates the last two increments (error O(h^3)), so Newton usually stops after two
    iterations at h small.
    """
    B, d = Y0.shape
    if d == 2:
        midpoint_run_2(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit)
        return
    hh = 0.5 * h
    y, Z, Z1, Z2 = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    f, r, tmp = np.empty(d), np.empty(d), np.empty(d)
    J, A = np.empty((d, d)), np.empty((d, d))
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        rhs(y, f)
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
                fjac(tmp, f, J)
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


@kernel
def midpoint_run_2(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit):
    """midpoint_run for d = 2 (one degree of freedom, the reduced Serret-Andoyer systems) on scalars."""
    B = Y0.shape[0]
    hh = 0.5 * h
    f, J, y = np.empty(2), np.empty((2, 2)), np.empty(2)
    for b in range(B):
        y0, y1 = Y0[b, 0], Y0[b, 1]
        OUT[b, 0, 0], OUT[b, 0, 1] = y0, y1
        isave = 1
        y[0], y[1] = y0, y1
        rhs(y, f)
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
                fjac(y, f, J)
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


@kernel
def gauss_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """s-stage Gauss-Legendre collocation in the stage increments Z_i = Y_i - y_n:
    Z_i = h sum_j a_ij f(y_n + Z_j), y_{n+1} = y_n + sum_i d_i Z_i with d = b^T A^{-1} (Hairer & Wanner
    II, IV.8: no extra evaluations of f, and no amplification of the Newton error by h f').

    P = (s, A (row-major), d, c).
    """
    B, d = Y0.shape
    s = int(P[0])
    a = P[1 : 1 + s * s]
    dc = P[1 + s * s : 1 + s * s + s]
    c = P[1 + s * s + s : 1 + s * s + 2 * s]
    n = s * d
    y, tmp, f0 = np.empty(d), np.empty(d), np.empty(d)
    Z, r = np.empty(n), np.empty(n)
    F = np.empty((s, d))
    Js = np.empty((s, d, d))
    M = np.empty((n, n))
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        rhs(y, f0)
        nrhs = 1
        nnewton = 0
        for i in range(s):
            for u in range(d):
                Z[i * d + u] = c[i] * h * f0[u]
        for k in range(1, nsteps + 1):
            scale = max(1.0, max_abs(y))
            dprev = 0.0
            code = ST_NEWTON
            resid = np.inf
            for it in range(maxit):
                for i in range(s):
                    for u in range(d):
                        tmp[u] = y[u] + Z[i * d + u]
                    fjac(tmp, F[i], Js[i])
                nrhs += s
                nnewton += 1
                for i in range(s):
                    for u in range(d):
                        acc = 0.0
                        for j in range(s):
                            acc += a[i * s + j] * F[j, u]
                        r[i * d + u] = h * acc - Z[i * d + u]
                        for j in range(s):
                            hij = -h * a[i * s + j]
                            for v in range(d):
                                M[i * d + u, j * d + v] = hij * Js[j, u, v]
                        M[i * d + u, i * d + u] += 1.0
                resid = max_abs(r)
                state, dprev = newton_update(M, r, Z, n, dprev, it, scale, tol)
                if state >= 0:
                    code = state
                    break
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            for u in range(d):
                acc = 0.0
                for i in range(s):
                    acc += dc[i] * Z[i * d + u]
                y[u] += acc
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 3] = nnewton
        INFO[b, 4] = nrhs


# ---- _k_canonical.py ----
"""Loop template: symplectic methods that use the canonical splitting y = (q, p) of the state: symplectic
Euler (both variants), Stormer-Verlet, and the seed's second-order generating-function method.

The model supplies ``grad(y, g)`` (g = (H_q, H_p)), ``ghess(y, g, Hm)`` (with the Hessian), and for the
generating-function method ``gf_all(y, g, Hm, gw, Hw)`` and ``gf_grads(y, g, gw)``, where
``W = sum_i H_{q_i} H_{p_i}``. See ``_k_common.py`` for the common loop signature.
"""


import numpy as np



@kernel
def _implicit_half(y, x, tmp, g, hm, gw, hw, A, r, n, h, variant, tol, maxit, scale, counts):
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
            ghess(tmp, g, hm)
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
                ghess(tmp, g, hm)
                for i in range(n):
                    r[i] = y[i] + h * g[n + i] - x[i]
                    for j in range(n):
                        A[i, j] = -h * hm[n + i, j]
                    A[i, i] += 1.0
            else:
                gf_all(tmp, g, hm, gw, hw)
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
def _symplectic_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, variant):
    B, d = Y0.shape
    n = d // 2
    y, tmp, g, gw = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    x, xprev, r = np.empty(n), np.empty(n), np.empty(n)
    hm, hw = np.empty((d, d)), np.empty((d, d))
    A = np.empty((n, n))
    counts = np.zeros(2)  # rhs evaluations, Newton iterations
    off = n if variant == 0 else 0  # the implicit unknown is p (variant 0) or q
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        counts[:] = 0.0
        grad(y, g)
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
            code, resid = _implicit_half(y, x, tmp, g, hm, gw, hw, A, r, n, h, variant, tol, maxit, scale, counts)
            if code != 0:
                fail(OUT, INFO, b, isave, k, code, resid)
                break
            if variant == 0:
                for i in range(n):
                    tmp[i] = y[i]
                    tmp[n + i] = x[i]
                grad(tmp, g)
                for i in range(n):
                    y[i] += h * g[n + i]
                    y[n + i] = x[i]
            else:
                for i in range(n):
                    tmp[i] = x[i]
                    tmp[n + i] = y[n + i]
                if variant == 1:
                    grad(tmp, g)
                    for i in range(n):
                        y[n + i] -= h * g[i]
                else:
                    gf_grads(tmp, g, gw)
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


@kernel
def symplectic_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """P[0]: 0 symplectic Euler A, 1 symplectic Euler B, 2 the generating-function method (a runtime value,
    so that numba compiles one loop for the three)."""
    _symplectic_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, int(P[0]))


@kernel
def verlet_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """Stormer-Verlet for H = T(p) + V(q): p_{1/2} = p - h/2 V'(q), q' = q + h T'(p_{1/2}),
    p' = p_{1/2} - h/2 V'(q'); H_q at the new q is reused by the next step."""
    B, d = Y0.shape
    n = d // 2
    y, g, gq = np.empty(d), np.empty(d), np.empty(n)
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        grad(y, g)
        nrhs = 1
        for i in range(n):
            gq[i] = g[i]
        for k in range(1, nsteps + 1):
            for i in range(n):
                y[n + i] -= 0.5 * h * gq[i]
            grad(y, g)
            for i in range(n):
                y[i] += h * g[n + i]
            grad(y, g)
            nrhs += 2
            for i in range(n):
                gq[i] = g[i]
                y[n + i] -= 0.5 * h * gq[i]
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nrhs


# ---- _k_liepoisson.py ----
"""Loop template: integrators on so(3)* and SO(3) for left-invariant systems. The state is ``m`` (d = 3) or
``(m, R)`` with R row-major (d = 12).

- ``split_run``: splitting of H = f1(m1) + f2(m2) + f3(m3); each part's flow is an exact rotation about a
  body axis. Model: ``dh0, dh1, dh2`` (the scalar derivatives f_i').
- ``mv_run``: the discrete Moser-Veselov rigid body (free body, P = inertia tensor, row-major).
- ``lgvi_run``: the Lie-group variational integrator for a hyperregular H. Model: ``ghess3(m, g, Hm)``.

See ``_k_common.py`` for the common loop signature.
"""

import math

import numpy as np



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
def axis_flow(y, axis, tau, attitude):
    """Exact flow for time ``tau`` of H_i = f_i(m_i): m_i is constant, so w = f_i'(m_i) is, and
    m(t) = exp(-t w e_i^) m, R(t) = R exp(t w e_i^)."""
    if axis == 0:
        w = dh0(y[0])
    elif axis == 1:
        w = dh1(y[1])
    else:
        w = dh2(y[2])
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
def flow_block(A, axis, tau, n, T):
    """axis_flow for the momenta of a block of trajectories, A of shape (3, K) (structure of arrays):
    simple loops over contiguous lanes, which LLVM vectorises. The angles and their maximum come in one
    pass; f_i' is a scalar call per lane (libm's tan, for the closed loop, is most of the cost: numba has
    no vector math library without SVML)."""
    tmax = 0.0
    if axis == 0:
        for q in range(n):
            T[q] = tau * dh0(A[0, q])
            tmax = max(tmax, abs(T[q]))
    elif axis == 1:
        for q in range(n):
            T[q] = tau * dh1(A[1, q])
            tmax = max(tmax, abs(T[q]))
    else:
        for q in range(n):
            T[q] = tau * dh2(A[2, q])
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
def split_m_run(Y0, h, nsteps, save_every, OUT, INFO, P):
    """split_run for d = 3 (no attitude), by blocks of 256 trajectories: the throughput loop."""
    B = Y0.shape[0]
    J = int(P[0])
    axes = np.empty(J, np.int64)
    taus = np.empty(J)
    for j in range(J):
        axes[j] = int(P[1 + j])
        taus[j] = P[1 + J + j] * h
    fsal = J > 1 and axes[0] == axes[J - 1]
    merged = taus[0] + taus[J - 1]
    K = 256
    A = np.empty((3, K))
    T = np.empty(K)
    for start in range(0, B, K):
        n = min(K, B - start)
        for q in range(n):
            for i in range(3):
                A[i, q] = Y0[start + q, i]
                OUT[start + q, 0, i] = A[i, q]
        isave = 1
        pending = False
        for k in range(1, nsteps + 1):
            flow_block(A, axes[0], merged if pending else taus[0], n, T)
            for j in range(1, J - 1):
                flow_block(A, axes[j], taus[j], n, T)
            saving = is_save(k, nsteps, save_every)
            if J > 1:
                pending = fsal and k < nsteps and not saving
                if not pending:
                    flow_block(A, axes[J - 1], taus[J - 1], n, T)
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


@kernel
def split_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """One step is the composition P = (J, axes[J], coefficients[J]); when the first and last sub-flows
    are about the same axis, the last one of a step is merged with the first one of the next (the flows
    of one f_i commute) except where a state is saved."""
    B, d = Y0.shape
    if d == 3:
        split_m_run(Y0, h, nsteps, save_every, OUT, INFO, P)
        return
    attitude = d == 12
    J = int(P[0])
    axes = P[1 : 1 + J]
    coef = P[1 + J : 1 + 2 * J]
    fsal = J > 1 and axes[0] == axes[J - 1]
    y = np.empty(d)
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        pending = 0.0
        for k in range(1, nsteps + 1):
            axis_flow(y, int(axes[0]), (coef[0] + pending) * h, attitude)
            for j in range(1, J - 1):
                axis_flow(y, int(axes[j]), coef[j] * h, attitude)
            if J > 1:
                if fsal and k < nsteps and not is_save(k, nsteps, save_every):
                    pending = coef[J - 1]
                else:
                    axis_flow(y, int(axes[J - 1]), coef[J - 1] * h, attitude)
                    pending = 0.0
            isave = finish_step(OUT, INFO, b, isave, k, nsteps, save_every, y)
            if isave < 0:
                break
        INFO[b, 4] = nsteps * J


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
        return (_series(t2, 2, 11, False), _series(t2, 3, 11, False),
                _series(t2, 2, 11, True), _series(t2, 3, 11, True))
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
def lgvi_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """Discrete Euler-Lagrange equations of L_d = h l(tau^{-1}(R_k^T R_{k+1}) / h) in momentum form:
    find X with X = h grad H(J_r(X) m_k); then F = tau(X), R_{k+1} = R_k F, m_{k+1} = F^T m_k."""
    B, d = Y0.shape
    attitude = d == 12
    param = int(P[0])
    y, m, X, Xp, Xpp, r = np.empty(d), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    mu, g, u, v, tmp = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    D, hm, A, F = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
        isave = 1
        for i in range(3):
            m[i] = y[i]
        ghess3(m, g, hm)
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
                ghess3(mu, g, hm)
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


@kernel
def mv_run(Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P):
    """Moser-Veselov: h m_k^ = F J_d - J_d F^T with J_d = tr(I)/2 - I; with F = cay(2 f) this reads
    h m + h m x f + f (f . h m) - 2 I f = 0 (Lee, Leok & McClamroch 2007), solved for f by Newton;
    then m_{k+1} = F^T m_k, R_{k+1} = R_k F."""
    B, d = Y0.shape
    attitude = d == 12
    inertia = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            inertia[i, j] = P[3 * i + j]
    y, m, f, fp, fpp, r = np.empty(d), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    u, tmp, X = np.empty(3), np.empty(3), np.empty(3)
    A, F, Iinv = np.empty((3, 3)), np.empty((3, 3)), np.linalg.inv(inertia)
    for b in range(B):
        y[:] = Y0[b]
        store(OUT, b, 0, y)
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
                    r[i] = -(m[i] + u[i] + f[i] * fm
                             - 2.0 * (inertia[i, 0] * f[0] + inertia[i, 1] * f[1] + inertia[i, 2] * f[2]))
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
