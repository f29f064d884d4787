"""Loop template: Taylor's method for ``y' = f(y)`` with ``f`` straight-line code, its Taylor coefficients
``taylor_coeffs(X, W, order, prm)`` printed by :meth:`geomech.symbolic.taylor.TaylorTape.source` (the recurrences'
helpers ``tk_*`` below), adaptive in the step at a fixed order, the saved states by the Taylor polynomial.

The step (Jorba & Zou, Experiment. Math. 14 (2005); as heyoka): with the coefficients x^[j] of the order-p
polynomial and the weights ``sc_i = atol + rtol |y_i|``, the last two terms of the series bound the truncation
error, ``h = exp(-0.7 / (p - 1)) min_{j = p-1, p} (1 / max_i |x_i^[j]| / sc_i)^(1/j)``: each of the two terms is
then below ``sc_i``, the factor a margin for the next term. The order is ``p = ceil(-ln(eps) / 2) + 1``,
``eps = min(rtol, atol)``, which balances the cost of the coefficients (p^2) against the number of steps.

See ``_k_common.py`` for the template mechanism.
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ._fptr import borrowed, call_model, shaped
from ._k_common import fail, inlined, kernel, param_row, store
from ._k_embedded import erk_crossed
from ._k_explicit import chart_margin


def taylor_coeffs(X, W, order, prm):  # the model's, generated
    raise NotImplementedError


def taylor_constants(K, prm):  # the model's, generated
    raise NotImplementedError


# <<< template preamble


@kernel
def tk_mul(a, b, k):
    """Order k of a product: sum_{j=0..k} a^[j] b^[k-j]."""
    s = 0.0
    for j in range(k + 1):
        s += a[j] * b[k - j]
    return s


@kernel
def tk_quot(num, w, b, k):
    """Order k of w = a / b, ``num`` the numerator's order k: (a^[k] - sum_{j=1..k} b^[j] w^[k-j]) / b^[0]."""
    s = num
    for j in range(1, k + 1):
        s -= b[j] * w[k - j]
    return s / b[0]


@kernel
def tk_sqrt(w, a, k):
    """Order k >= 1 of w = sqrt(a): (a^[k] - sum_{j=1..k-1} w^[j] w^[k-j]) / (2 w^[0])."""
    s = a[k]
    for j in range(1, k):
        s -= w[j] * w[k - j]
    return s / (2.0 * w[0])


@kernel
def tk_pow(w, a, e, k):
    """Order k >= 1 of w = a^e: sum_{j=0..k-1} (e (k - j) - j) a^[k-j] w^[j] / (k a^[0])."""
    s = 0.0
    for j in range(k):
        s += (e * (k - j) - j) * a[k - j] * w[j]
    return s / (k * a[0])


@kernel
def tk_int(a, r, k):
    """Order k >= 1 of w = F(a), F' = r: (1/k) sum_{j=1..k} j a^[j] r^[k-j]."""
    s = 0.0
    for j in range(1, k + 1):
        s += j * a[j] * r[k - j]
    return s / k


@inlined
def tk_poly(X3, lane, i, tau):
    """Row i of the Taylor polynomial of the lane's coefficients X3[:, :, lane] at tau, read in place."""
    p = X3.shape[1] - 1
    s = X3[i, p, lane]
    for j in range(p - 1, -1, -1):
        s = s * tau + X3[i, j, lane]
    return s


@inlined
def tk_at(X3, lane, tau, out):
    """The lane's Taylor polynomial at tau into out."""
    for i in range(X3.shape[0]):
        out[i] = tk_poly(X3, lane, i, tau)


@inlined
def tk_step(X3, lane, order, rtol, atol):
    """The step size the lane's coefficients allow (inf where the last two vanish; NaN where they are not
    finite)."""
    a1 = 0.0
    a2 = 0.0
    for i in range(X3.shape[0]):
        sc = atol + rtol * abs(X3[i, 0, lane])
        a1 = max(a1, abs(X3[i, order - 1, lane]) / sc)
        a2 = max(a2, abs(X3[i, order, lane]) / sc)
    if not (math.isfinite(a1) and math.isfinite(a2)):
        return math.nan
    h = math.inf
    if a1 > 0.0:
        h = (1.0 / a1) ** (1.0 / (order - 1))
    if a2 > 0.0:
        h = min(h, (1.0 / a2) ** (1.0 / order))
    return h * math.exp(-0.7 / (order - 1))


@inlined
def tk_events(X3, lane, t, hs, b, limit, GOLDS, GNEW, GMID, THETA, YT, efp, EDIR, ETERM, EVT, ECOUNT, prm):
    """The events of a step of size hs from t: each event function's zero on the step's polynomial (bisection to
    the resolution of doubles), recorded in time order in EVT[b] (event, t, state) up to and including the first
    terminal one and up to the fraction ``limit`` of the step (where the run leaves its chart), as the embedded
    pairs' loop does; returns the fraction of the step where a terminal event stops the run, or 2 (none)."""
    ne = EDIR.shape[0]
    for j in range(ne):
        THETA[j] = 2.0
        if not erk_crossed(GOLDS[lane, j], GNEW[j], EDIR[j]):
            continue
        lo = 0.0
        hi = 1.0
        below = GOLDS[lane, j] < 0.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            tk_at(X3, lane, mid * hs, YT)
            call_model(efp, YT, GMID, prm)
            g = GMID[j]
            if (g < 0.0) == below and g != 0.0:
                lo = mid
            else:
                hi = mid
        THETA[j] = hi
    stop = 2.0
    for j in range(ne):
        if ETERM[j] != 0.0 and THETA[j] < stop:
            stop = THETA[j]
    last = -1.0
    while True:
        th = 2.0
        for j in range(ne):
            if last < THETA[j] <= min(stop, limit, 1.0) and THETA[j] < th:
                th = THETA[j]
        if th > 1.0:
            break
        tk_at(X3, lane, th * hs, YT)
        for j in range(ne):
            if THETA[j] == th:
                c = int(ECOUNT[b])
                if c < EVT.shape[1]:
                    EVT[b, c, 0] = j
                    EVT[b, c, 1] = t + th * hs
                    for i in range(YT.shape[0]):
                        EVT[b, c, 2 + i] = YT[i]
                ECOUNT[b] = c + 1
        last = th
    return stop


@inlined
def tk_chart_exit(X3, lane, hs, CH, YT):
    """The fraction of a step of size hs at which its polynomial leaves the chart CH (bisection to the resolution
    of doubles), or 2 where its end is inside."""
    if CH.shape[0] == 0:
        return 2.0
    tk_at(X3, lane, hs, YT)
    if chart_margin(YT, CH) > 0.0:
        return 2.0
    lo = 0.0
    hi = 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        tk_at(X3, lane, mid * hs, YT)
        if chart_margin(YT, CH) > 0.0:
            lo = mid
        else:
            hi = mid
    return hi


@kernel
def tk_begin(Y0, b, t0, TS, OUT, INFO, y, CH, efp, EDIR, GOLD, prm):
    """Start member b: its state into y, the outputs at t0 saved, its event functions into GOLD; returns (the
    index of the first time not reached, status: 0, or 6 where it starts outside the chart)."""
    n = TS.shape[0]
    for j in range(INFO.shape[1]):
        INFO[b, j] = 0.0
    for i in range(y.shape[0]):
        y[i] = Y0[b, i]
    k = 0
    while k < n and TS[k] == t0:
        store(OUT, b, k, y)
        k += 1
    status = 0
    if k < n and not (chart_margin(y, CH) > 0.0):
        status = 6
    if EDIR.shape[0] > 0:
        call_model(efp, y, GOLD, prm)
    return k, status


@inlined
def tk_advance(
    X3, lane, t, k, b, TS, OUT, order, rtol, atol, CH, efp, EDIR, ETERM, EVT, ECOUNT, GOLDS, GNEW, GMID, THETA, YT, prm
):
    """A step of member b from (t, y) by the lane's Taylor coefficients X3[:, :, lane] (column 0 the state y): the
    outputs it passes saved, the step ended early where it leaves the chart CH or at a terminal event; returns (t,
    the index of the first time not reached, status, the steps taken: 0 or 1, the step). Where the status is 0 the
    caller advances y to the step's end (Horner's rule at the step: the lanes' states at once). The lane's entries
    (coefficients, event values GOLDS[lane]) are read in place."""
    n = TS.shape[0]
    ne = EDIR.shape[0]
    t_end = TS[n - 1]
    direction = 1.0 if t_end >= t else -1.0
    h = tk_step(X3, lane, order, rtol, atol)
    if not (h > 0.0):  # NaN: coefficients not finite
        return t, k, 2, 0, 0.0
    remaining = abs(t_end - t)
    last = h >= remaining
    if last:
        h = remaining
    elif not (h >= 10.0 * abs(math.nextafter(t, direction * math.inf) - t)):
        return t, k, 4, 0, 0.0
    hs = direction * h
    t_new = t_end if last else t + hs
    leave = tk_chart_exit(X3, lane, hs, CH, YT)
    stop = 2.0
    if ne > 0:
        tk_at(X3, lane, hs, YT)
        call_model(efp, YT, GNEW, prm)
        stop = tk_events(X3, lane, t, hs, b, leave, GOLDS, GNEW, GMID, THETA, YT, efp, EDIR, ETERM, EVT, ECOUNT, prm)
        for j in range(ne):
            GOLDS[lane, j] = GNEW[j]
    end = min(leave, stop)
    if end <= 1.0:  # the chart's end (the outputs before it) or a terminal event (those up to it)
        status = 6 if leave < stop else 9
        t_stop = t + end * hs
        while k < n and (direction * (TS[k] - t_stop) < 0.0 or (status == 9 and TS[k] == t_stop)):
            tk_at(X3, lane, TS[k] - t, OUT[b, k])
            k += 1
        return t_stop, k, status, 1, 0.0
    while k < n and (last or direction * (TS[k] - t_new) <= 0.0):
        tk_at(X3, lane, TS[k] - t, OUT[b, k])
        k += 1
    return t_new, k, 0, 1, hs


@kernel
def tk_end(OUT, INFO, b, k, status, nfev, t, steps):
    """Member b ended at t with status (its outputs from index k on NaN where it failed)."""
    if status != 0:
        fail(OUT, INFO, b, k, k, status, np.nan)
    INFO[b, 4] = nfev
    INFO[b, 5] = t
    INFO[b, 6] = steps


@kernel
def tk_lane_start(
    lane, nxt, Y0, t0, TS, OUT, INFO, CH, efp, EDIR, PRM, tfp, K, KV, PV, YS, GOLDS, MEMBER, T, KS, STEPS, NFEV
):
    """The lane takes the next member, from index nxt, that has a step to take (those that have none end at once;
    MEMBER[lane] = -1 where none is left); returns the index after it. The member's parameters and constants go
    into the lane's entries of PV and KV."""
    lanes = MEMBER.shape[0]
    n = TS.shape[0]
    nb = Y0.shape[0]
    MEMBER[lane] = -1
    while nxt < nb:
        b = nxt
        nxt += 1
        prm = param_row(PRM, b)
        k, status = tk_begin(Y0, b, t0, TS, OUT, INFO, YS[lane], CH, efp, EDIR, GOLDS[lane], prm)
        if k >= n or status != 0:
            tk_end(OUT, INFO, b, k, status, 0.0, t0, 0)
            continue
        MEMBER[lane] = b
        T[lane] = t0
        KS[lane] = k
        STEPS[lane] = 0
        NFEV[lane] = 0.0
        if tfp != 0:
            taylor_constants(K, prm)
            for j in range(K.shape[0]):
                KV[j * lanes + lane] = K[j]
            for j in range(prm.shape[0]):
                PV[j * lanes + lane] = prm[j]
        break
    return nxt


@kernel
def taylor_work(d, order, lanes, n_rows, n_k, n_prm, n_events):
    """The entries of the float64 work buffer :func:`taylor_run` needs (its int64 buffer: 5 lanes)."""
    stride = order + 1
    n_k1 = max(n_k, 1)
    return (
        d * stride * lanes
        + max(n_rows, 1) * stride
        + n_k1 * (1 + lanes)
        + max(n_prm, 1) * lanes
        + 2 * lanes * d
        + 3 * d
        + max(n_events, 1)
        + 3 * lanes
        + d * lanes
    )


@kernel
def taylor_run(
    Y0,
    t0,
    TS,
    OUT,
    INFO,
    rtol,
    atol,
    order,
    n_rows,
    tfp,
    hfp,
    n_k,
    lanes,
    max_evals,
    CH,
    efp,
    EDIR,
    ETERM,
    EVT,
    ECOUNT,
    PRM,
    FW,
    IW,
):
    """Integrate each row of Y0 from t0 by Taylor's method of order ``order`` (its coefficients the model's
    ``taylor_coeffs``, a work array of ``n_rows`` rows; or, where the address ``tfp`` is not 0, the same unrolled
    for this order and for ``lanes`` members at once, :mod:`geomech.integrators._taylor_llvm`, reading the ``n_k``
    constants of ``taylor_constants``; the lanes' states advanced at once by the code at ``hfp``, Horner's rule on
    vectors of the lanes, or one by one where it is 0), saving at the times TS (monotone, away from t0) by the
    step's Taylor polynomial. Each lane runs a member; where it ends, the lane takes the next (the steps of the
    members in the lanes of a pass differ: only their coefficients and new states are computed together). A state
    that leaves the chart CH (rows: component, lower, upper bound; none: shape (0, 3)) ends the run where the
    polynomial crosses the bound (status 6), the outputs before it kept. The event functions at the address ``efp``
    (their directions EDIR and terminal flags ETERM; none: length 0) are located on each step's polynomial and
    recorded in EVT[b] (event, t, state), counted in ECOUNT[b]; a terminal event ends the run there (status 9), the
    outputs after it NaN. INFO[b] as the embedded pairs' loop: status (0, 2 non-finite, 4 step size underflow, 6
    left the chart, 8 evaluation budget spent, 9 a terminal event), the index of the first time not reached, NaN, 0,
    evaluations (``order`` per step: one pass over the equations per order), the time reached, steps, 0. The work
    arrays are carved out of FW (float64) and IW (int64), the caller's, of at least :func:`taylor_work` entries;
    returns 0, or 1 (nothing done) where they are shorter."""
    nb, d = Y0.shape
    stride = order + 1
    # every array of the loop borrowed (borrowed: numba would count its references atomically at each call that
    # passes it, a third of the loop's time): the arguments, which the caller holds
    Y0, TS, OUT, INFO, CH, EDIR, ETERM, EVT, ECOUNT, PRM, FW, IW = borrowed(
        (Y0, TS, OUT, INFO, CH, EDIR, ETERM, EVT, ECOUNT, PRM, FW, IW)
    )
    # the work arrays, carved out of the caller's buffers FW and IW (the loop allocates nothing: it runs as machine
    # code loaded without numba, geomech.integrators._native), every one borrowed
    need = taylor_work(d, order, lanes, n_rows, n_k, PRM.shape[1], EDIR.shape[0])
    if FW.shape[0] < need or IW.shape[0] < 5 * lanes:
        return 1
    for i in range(need):
        FW[i] = 0.0
    # the coefficients of the lanes, entry (i, j) of lane l at (i stride + j) lanes + l; a lane's are read in place
    XV = shaped(FW, 0, d * stride * lanes)
    X3 = shaped(FW, 0, (d, stride, lanes))
    at = d * stride * lanes
    W = shaped(FW, at, (max(n_rows, 1), stride))
    at += max(n_rows, 1) * stride
    K = shaped(FW, at, max(n_k, 1))
    at += max(n_k, 1)
    KV = shaped(FW, at, max(n_k, 1) * lanes)
    at += max(n_k, 1) * lanes
    PV = shaped(FW, at, max(PRM.shape[1], 1) * lanes)
    at += max(PRM.shape[1], 1) * lanes
    YS = shaped(FW, at, (lanes, d))
    GOLDS = shaped(FW, at + lanes * d, (lanes, d))
    at += 2 * lanes * d
    # the event functions' values (new, at a midpoint), the state at a time
    GNEW, GMID, YT = shaped(FW, at, d), shaped(FW, at + d, d), shaped(FW, at + 2 * d, d)
    at += 3 * d
    THETA = shaped(FW, at, max(EDIR.shape[0], 1))
    at += max(EDIR.shape[0], 1)
    # the lanes' times, evaluations and step sizes (those of the lanes whose state advances)
    T, NFEV, HV = shaped(FW, at, lanes), shaped(FW, at + lanes, lanes), shaped(FW, at + 2 * lanes, lanes)
    at += 3 * lanes
    YV = shaped(FW, at, d * lanes)  # the new states of the stepping lanes, entry i of lane l at i lanes + l
    # the lane's member (-1: none left, -2: not yet given one); whether it has ended, whether its state advances;
    # its first output not reached, its steps
    MEMBER, DONE, PENDING = shaped(IW, 0, lanes), shaped(IW, lanes, lanes), shaped(IW, 2 * lanes, lanes)
    KS, STEPS = shaped(IW, 3 * lanes, lanes), shaped(IW, 4 * lanes, lanes)
    for i in range(5 * lanes):
        IW[i] = -2 if i < lanes else 0
    # the compact coefficients run with one lane
    X1 = X3[:, :, 0]
    prm = PRM[0]
    nxt = 0
    while True:
        running = False
        for lane in range(lanes):
            # a lane not yet given a member, or whose member ended or cannot pay another step (status 8), takes the
            # next member
            while MEMBER[lane] == -2 or (MEMBER[lane] >= 0 and (DONE[lane] or NFEV[lane] + order > max_evals)):
                if MEMBER[lane] >= 0 and not DONE[lane]:
                    tk_end(OUT, INFO, MEMBER[lane], KS[lane], 8, NFEV[lane], T[lane], STEPS[lane])
                DONE[lane] = 0
                nxt = tk_lane_start(
                    lane, nxt, Y0, t0, TS, OUT, INFO, CH, efp, EDIR, PRM, tfp, K, KV, PV, YS, GOLDS, MEMBER, T, KS,
                    STEPS, NFEV
                )  # fmt: skip
            if MEMBER[lane] >= 0:
                running = True
                for i in range(d):
                    XV[i * stride * lanes + lane] = YS[lane, i]
        if not running:
            break
        if tfp != 0:
            call_model(tfp, XV, KV, PV)
        for lane in range(lanes):
            b = MEMBER[lane]
            if b < 0:
                continue
            if PRM.shape[0] > 1 and (tfp == 0 or EDIR.shape[0] > 0):  # the member's parameters, where they are read
                prm = PRM[b]
            if tfp == 0:  # the loop over the orders (one lane)
                taylor_coeffs(X1, W, order, prm)
            NFEV[lane] += order
            t, k, status, stepped, hs = tk_advance(
                X3,
                lane,
                T[lane],
                KS[lane],
                b,
                TS,
                OUT,
                order,
                rtol,
                atol,
                CH,
                efp,
                EDIR,
                ETERM,
                EVT,
                ECOUNT,
                GOLDS,
                GNEW,
                GMID,
                THETA,
                YT,
                prm,
            )
            T[lane] = t
            KS[lane] = k
            STEPS[lane] += stepped
            if status == 0:
                PENDING[lane] = 1
                HV[lane] = hs
            else:
                tk_end(OUT, INFO, b, k, status, NFEV[lane], t, STEPS[lane])
                DONE[lane] = 1
        # the stepping lanes' states advanced to their steps' ends, at once
        if hfp != 0:
            call_model(hfp, XV, HV, YV)
        for lane in range(lanes):
            if not PENDING[lane]:
                continue
            PENDING[lane] = 0
            status = 0
            for i in range(d):
                yi = YV[i * lanes + lane] if hfp != 0 else tk_poly(X3, lane, i, HV[lane])
                YS[lane, i] = yi
                if not math.isfinite(yi):
                    status = 2
            if KS[lane] >= TS.shape[0] or status != 0:
                tk_end(OUT, INFO, MEMBER[lane], KS[lane], status, NFEV[lane], T[lane], STEPS[lane])
                DONE[lane] = 1
    return 0
