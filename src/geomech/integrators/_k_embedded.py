"""Loop template: the adaptive loop of the embedded Runge-Kutta pairs (Dormand-Prince 8(5,3) and 5(4)), with
error control, outputs by the continuous extension, the exit of the system's chart and the events (zeros of
functions of the state, located on the continuous extension); the stages, error norms and extensions it uses are
in ``_k_explicit.py``.

See ``_k_common.py`` for the template mechanism.
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ._fptr import borrowed, call_model, shaped
from ._k_common import (
    STAGE1,
    fail,
    finite,
    kernel,
    param_row,
    store,
)
from ._k_explicit import (
    chart_exit,
    chart_margin,
    dense_coefficients,
    dense_value,
    erk_error_norm,
    erk_increment,
    erk_stages,
    first_step,
    first_step_guess,
)

# <<< template preamble


# -- adaptive integration by an embedded pair, with dense output ------------------------------------------
# The loop is split in two: ``erk_run`` only evaluates the model (through its address) where the control logic
# asks for it; the control logic (step size, error control, saving by the continuous extension, the chart's exit,
# failures) is a state machine of helpers, resumed after each evaluation with the state in S and the work vectors
# in W. Both are compiled once for every model.
# What to evaluate next:
ERK_DONE = 0  # nothing: the trajectory has ended
ERK_F0 = 1  # f(y) into K[0]
ERK_F1 = 2  # f(tmp) into K[1] (the probe of the first step)
ERK_STEP = 3  # the stages 1..ns-1 of a step of size h from y, then f(ynew) into K[ns]
ERK_EXTEND = 4  # the extra stages of the continuous extension
# S[...]: the state of a trajectory between evaluations
EK_T = 0  # time reached
EK_HABS = 1  # size of the next step
EK_H = 2  # the step being taken (signed)
EK_TNEW = 3  # its end
EK_TSTOP = 4  # where the outputs stop (the end of the step, or the chart's exit)
EK_FACTOR = 5  # growth of the step after this one
EK_K = 6  # index of the next output time
EK_STATUS = 7
EK_NFEV = 8
EK_STEPS = 9
EK_REJECTED = 10
EK_RETRY = 11  # the last step was rejected
EK_EXTENDED = 12  # the continuous extension of this step is computed
EK_DIR = 13  # direction of time
EK_H0 = 14  # the first step's probe and Hairer's d1
EK_D1 = 15
EK_NONFINITE = 16  # the last attempt was not finite
EK_LEFT = 17  # ... and outside the chart
EK_PHASE = 18  # why the extension is computed: 1 the chart's exit, 2 an output inside the step, 3 an event
EK_SIZE = 19
# W[...]: the work vectors
EW_Y = 0
EW_YNEW = 1
EW_DY = 2
EW_COMP = 3
EW_TMP = 4
EW_OUT = 5
EW_GOLD = 6  # the event functions at the start of the step
EW_GNEW = 7  # ... at its end
EW_GMID = 8  # ... inside it (the root search)
EW_THETA = 9  # where each event function's zero is in the step (2 where it has none)
ST_TERMINAL = 9  # the status of a run ended by a terminal event (reported as a success)


@kernel
def erk_begin(b, Y0, t0, TS, OUT, INFO, W, S, CH):
    """Start trajectory b: outputs at t0, the state reset; returns what to evaluate first."""
    n = TS.shape[0]
    for j in range(INFO.shape[1]):
        INFO[b, j] = 0.0
    for i in range(Y0.shape[1]):
        W[EW_Y, i] = Y0[b, i]
        W[EW_COMP, i] = 0.0
    k = 0
    while k < n and TS[k] == t0:
        store(OUT, b, k, W[EW_Y])
        k += 1
    for j in range(EK_SIZE):
        S[j] = 0.0
    S[EK_T] = t0
    S[EK_K] = k
    S[EK_DIR] = 1.0 if TS[n - 1] >= t0 else -1.0
    if k < n and not (chart_margin(W[EW_Y], CH) > 0.0):
        S[EK_STATUS] = 6
    if k < n and S[EK_STATUS] == 0:
        return ERK_F0
    return erk_finish(b, OUT, INFO, S)


@kernel
def erk_head(b, TS, OUT, INFO, max_evals, ns, S):
    """The head of the step loop: the next step's size and end, or the end of the trajectory."""
    n = TS.shape[0]
    k = int(S[EK_K])
    if k < n and S[EK_STATUS] == 0:
        t = S[EK_T]
        direction = S[EK_DIR]
        if S[EK_NFEV] + ns > max_evals:
            S[EK_STATUS] = 8
        elif not (S[EK_HABS] >= 10.0 * abs(math.nextafter(t, direction * math.inf) - t)):
            # steps that kept ending outside the chart, where f is not finite: the run reached its end
            S[EK_STATUS] = 6 if S[EK_LEFT] else (2 if S[EK_NONFINITE] else 4)
        else:
            tnew = t + direction * S[EK_HABS]
            if direction * (tnew - TS[n - 1]) > 0.0:
                tnew = TS[n - 1]
            S[EK_TNEW] = tnew
            S[EK_H] = tnew - t
            return ERK_STEP
    return erk_finish(b, OUT, INFO, S)


@kernel
def erk_finish(b, OUT, INFO, S):
    """End trajectory b: a failure flagged (its outputs from the first time not reached NaN), the counters."""
    k = int(S[EK_K])
    if S[EK_STATUS] != 0:
        fail(OUT, INFO, b, k, k, int(S[EK_STATUS]), np.nan)
    INFO[b, 4] = S[EK_NFEV]
    INFO[b, 5] = S[EK_T]
    INFO[b, 6] = S[EK_STEPS]
    INFO[b, 7] = S[EK_REJECTED]
    return ERK_DONE


@kernel
def erk_combine(W, K, B, ns, h):
    """The end of a step from its stages: dy (with the compensation of the sum) and ynew."""
    for i in range(W.shape[1]):
        W[EW_DY, i] = erk_increment(h, B, K, ns, i) + W[EW_COMP, i]
        W[EW_YNEW, i] = W[EW_Y, i] + W[EW_DY, i]


@kernel
def erk_outputs(b, TS, OUT, INFO, max_evals, ns, dop853, K, F, W, S):
    """Save the outputs inside the accepted step (by the continuous extension, asked for when first needed),
    then accept it and go to the next, or end the trajectory at the chart's exit."""
    n = TS.shape[0]
    k = int(S[EK_K])
    direction = S[EK_DIR]
    t_stop = S[EK_TSTOP]
    tnew = S[EK_TNEW]
    left = S[EK_STATUS] == 6
    stopped = left or S[EK_STATUS] == ST_TERMINAL
    while k < n and direction * (TS[k] - t_stop) <= 0.0 and not (left and TS[k] == t_stop):
        if TS[k] == tnew and not stopped:
            store(OUT, b, k, W[EW_YNEW])
        else:
            if not S[EK_EXTENDED]:
                S[EK_K] = k
                S[EK_PHASE] = 2
                return ERK_EXTEND
            dense_value(W[EW_Y], F, (TS[k] - S[EK_T]) / S[EK_H], dop853, W[EW_OUT])
            store(OUT, b, k, W[EW_OUT])
        k += 1
    S[EK_K] = k
    if stopped:
        S[EK_T] = t_stop
    else:
        for i in range(W.shape[1]):
            W[EW_COMP, i] = (W[EW_Y, i] - W[EW_YNEW, i]) + W[EW_DY, i]
            W[EW_Y, i] = W[EW_YNEW, i]
            W[EW_GOLD, i] = W[EW_GNEW, i]
            K[0, i] = K[ns, i]  # first same as last: f(ynew) starts the next step
        S[EK_T] = tnew
        S[EK_STEPS] += 1
        S[EK_HABS] = abs(S[EK_H]) * S[EK_FACTOR]
        S[EK_RETRY] = 0.0
    return erk_head(b, TS, OUT, INFO, max_evals, ns, S)


@kernel
def erk_crossed(g0, g1, direction):
    """Whether an event function went from g0 to g1 through zero in its direction (+1 rising, -1 falling, 0 both):
    from a nonzero value to zero or past it (a zero at the start of a step is the previous step's)."""
    rising = g0 < 0.0 and g1 >= 0.0
    falling = g0 > 0.0 and g1 <= 0.0
    return (rising and direction >= 0.0) or (falling and direction <= 0.0)


@kernel
def erk_events(b, h, dop853, F, W, S, efp, EDIR, ETERM, EVT, ECOUNT, prm):
    """The events of the accepted step: each event function's zero on the continuous extension (bisection to the
    resolution of doubles), recorded in time order in EVT[b] (event, t, state) up to and including the first
    terminal one; returns the fraction of the step where a terminal event stops the run, or 2 (none)."""
    ne = EDIR.shape[0]
    for j in range(ne):
        W[EW_THETA, j] = 2.0
        if not erk_crossed(W[EW_GOLD, j], W[EW_GNEW, j], EDIR[j]):
            continue
        lo = 0.0
        hi = 1.0
        below = W[EW_GOLD, j] < 0.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            dense_value(W[EW_Y], F, mid, dop853, W[EW_OUT])
            call_model(efp, W[EW_OUT], W[EW_GMID], prm)
            g = W[EW_GMID, j]
            if (g < 0.0) == below and g != 0.0:
                lo = mid
            else:
                hi = mid
        W[EW_THETA, j] = hi
    stop = 2.0
    for j in range(ne):
        if ETERM[j] != 0.0 and W[EW_THETA, j] < stop:
            stop = W[EW_THETA, j]
    # record in time order, those at or before the stop (events at the same fraction in their order)
    last = -1.0
    while True:
        th = 2.0
        for j in range(ne):
            if last < W[EW_THETA, j] <= min(stop, 1.0) and W[EW_THETA, j] < th:
                th = W[EW_THETA, j]
        if th > 1.0:
            break
        dense_value(W[EW_Y], F, th, dop853, W[EW_OUT])
        for j in range(ne):
            if W[EW_THETA, j] == th:
                c = int(ECOUNT[b])
                if c < EVT.shape[1]:
                    EVT[b, c, 0] = j
                    EVT[b, c, 1] = S[EK_T] + th * h
                    for i in range(W.shape[1]):
                        EVT[b, c, 2 + i] = W[EW_OUT, i]
                ECOUNT[b] = c + 1
        last = th
    return stop


@kernel
def erk_after(
    action,
    b,
    t0,
    TS,
    OUT,
    INFO,
    rtol,
    atol,
    max_evals,
    E,
    E2,
    D,
    ns,
    q,
    dop853,
    CH,
    K,
    F,
    W,
    S,
    efp,
    EDIR,
    ETERM,
    EVT,
    ECOUNT,
    prm,
):
    """The control logic after the evaluation ``action``: returns what to evaluate next (ERK_DONE at the end
    of the trajectory, INFO then filled)."""
    n = TS.shape[0]
    direction = S[EK_DIR]
    if action == ERK_F0:
        S[EK_NFEV] = 1
        h0, d1 = first_step_guess(W[EW_Y], K[0], rtol, atol)
        h0 = min(h0, abs(TS[n - 1] - t0))
        for i in range(W.shape[1]):
            W[EW_TMP, i] = W[EW_Y, i] + direction * h0 * K[0, i]
        S[EK_H0] = h0
        S[EK_D1] = d1
        return ERK_F1
    if action == ERK_F1:
        S[EK_NFEV] += 1
        h_abs = min(first_step(W[EW_Y], K[0], K[1], S[EK_H0], S[EK_D1], rtol, atol, q), abs(TS[n - 1] - t0))
        S[EK_HABS] = h_abs
        if not (finite(K[0]) and math.isfinite(h_abs)):
            S[EK_STATUS] = 2
        return erk_head(b, TS, OUT, INFO, max_evals, ns, S)
    h = S[EK_H]
    if action == ERK_STEP:
        S[EK_NFEV] += ns
        err = erk_error_norm(W[EW_Y], W[EW_YNEW], K, E, E2, ns + 1, h, rtol, atol, dop853)
        nonfinite = not (finite(W[EW_YNEW]) and math.isfinite(err))
        S[EK_NONFINITE] = 1.0 if nonfinite else 0.0
        S[EK_LEFT] = 1.0 if nonfinite and not (chart_margin(W[EW_YNEW], CH) > 0.0) else 0.0
        if nonfinite or err >= 1.0:
            S[EK_HABS] = abs(h) * (0.2 if nonfinite else max(0.2, 0.9 * err ** (-1.0 / (q + 1.0))))
            S[EK_REJECTED] += 1
            S[EK_RETRY] = 1.0
            return erk_head(b, TS, OUT, INFO, max_evals, ns, S)
        factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / (q + 1.0)))
        if S[EK_RETRY]:
            factor = min(1.0, factor)
        S[EK_FACTOR] = factor
        S[EK_EXTENDED] = 0.0
        S[EK_TSTOP] = S[EK_TNEW]
        if not (chart_margin(W[EW_YNEW], CH) > 0.0):
            # the step leaves the chart: end the run where its continuous extension crosses the bound
            S[EK_PHASE] = 1
            return ERK_EXTEND
        if EDIR.shape[0] > 0:
            call_model(efp, W[EW_YNEW], W[EW_GNEW], prm)
            for j in range(EDIR.shape[0]):
                if erk_crossed(W[EW_GOLD, j], W[EW_GNEW, j], EDIR[j]):
                    S[EK_PHASE] = 3
                    return ERK_EXTEND
        return erk_outputs(b, TS, OUT, INFO, max_evals, ns, dop853, K, F, W, S)
    # ERK_EXTEND: the continuous extension of the step
    S[EK_NFEV] += K.shape[0] - ns - 1
    dense_coefficients(h, D, K, F)
    S[EK_EXTENDED] = 1.0
    if S[EK_PHASE] == 1:
        S[EK_TSTOP] = S[EK_T] + chart_exit(W[EW_Y], F, dop853, CH, W[EW_OUT]) * h
        S[EK_STATUS] = 6
    elif S[EK_PHASE] == 3:
        stop = erk_events(b, h, dop853, F, W, S, efp, EDIR, ETERM, EVT, ECOUNT, prm)
        if stop <= 1.0:
            S[EK_TSTOP] = S[EK_T] + stop * h
            S[EK_STATUS] = ST_TERMINAL
    return erk_outputs(b, TS, OUT, INFO, max_evals, ns, dop853, K, F, W, S)


@kernel
def erk_evaluate(action, fp, A, B, ns, K, W, S, prm):
    """The evaluations of the model (at the address ``fp``) that the control logic asked for (``action``)."""
    if action == ERK_F0:
        call_model(fp, W[EW_Y], K[0], prm)
    elif action == ERK_F1:
        call_model(fp, W[EW_TMP], K[1], prm)
    elif action == ERK_STEP:
        erk_stages(fp, W[EW_Y], S[EK_H], A, K, W[EW_TMP], STAGE1, ns, prm)
        erk_combine(W, K, B, ns, S[EK_H])
        call_model(fp, W[EW_YNEW], K[ns], prm)
    else:
        erk_stages(fp, W[EW_Y], S[EK_H], A, K, W[EW_TMP], ns + 1, A.shape[0], prm)


@kernel
def erk_run(
    fp,
    Y0,
    t0,
    TS,
    OUT,
    INFO,
    rtol,
    atol,
    max_evals,
    A,
    B,
    E,
    E2,
    D,
    ns,
    q,
    dop853,
    CH,
    efp,
    EDIR,
    ETERM,
    EVT,
    ECOUNT,
    PRM,
    FW,
):
    """Integrate each row of Y0 from t0 by the embedded pair (A, B; error weights E, E2 on the stages and
    f(y1); continuous extension D, its extra stages the rows of A past ns), saving at the times TS (monotone,
    away from t0) by the continuous extension, or exactly where a step ends on one. ``q`` is the order of the
    error estimate; ``dop853`` selects DOP853's blended error estimate and nested continuous extension. A
    state that leaves the chart CH (rows: component, lower, upper bound; none: shape (0, 3)) ends the run
    where the continuous extension crosses the bound (status 6), the outputs before it kept. The event functions
    at the address ``efp`` (their directions EDIR and terminal flags ETERM; none: length 0) are located on the
    continuous extension of each accepted step and recorded in EVT[b] (event, t, state), counted in ECOUNT[b]
    (beyond EVT's capacity, counted only); a terminal event ends the run there (status 9), the outputs after it NaN.

    INFO[b]: status (0, 2 non-finite, 4 step size underflow, 6 left the chart, 8 evaluation budget spent), the
    index of the first time of TS not reached, NaN, 0, evaluations of f, the time reached, accepted and
    rejected steps. Only the model's evaluations are here; the control logic is the shared ``erk_*`` helpers.
    The work arrays are carved out of FW (:func:`erk_work` entries): the loop allocates nothing. Returns 0 (1 where
    FW is too short, nothing run).
    """
    nb, d = Y0.shape
    # every array borrowed (:func:`~geomech.integrators._fptr.borrowed`: numba would count its references
    # atomically at each call that passes it): the arguments, which the caller holds
    Y0, TS, OUT, INFO, A, B, E, E2, D, CH, EDIR, ETERM, EVT, ECOUNT, PRM, FW = borrowed(
        (Y0, TS, OUT, INFO, A, B, E, E2, D, CH, EDIR, ETERM, EVT, ECOUNT, PRM, FW)
    )
    if FW.shape[0] < erk_work(A.shape[0], D.shape[0], d):
        return 1
    K = shaped(FW, 0, (A.shape[0], d))
    at = A.shape[0] * d
    F = shaped(FW, at, (D.shape[0], d))
    at += D.shape[0] * d
    W = shaped(FW, at, (10, d))
    S = shaped(FW, at + 10 * d, EK_SIZE)
    for b in range(nb):
        prm = param_row(PRM, b)
        action = erk_begin(b, Y0, t0, TS, OUT, INFO, W, S, CH)
        ECOUNT[b] = 0.0
        if EDIR.shape[0] > 0:
            call_model(efp, W[EW_Y], W[EW_GOLD], prm)
        while action != ERK_DONE:
            erk_evaluate(action, fp, A, B, ns, K, W, S, prm)
            action = erk_after(
                action,
                b,
                t0,
                TS,
                OUT,
                INFO,
                rtol,
                atol,
                max_evals,
                E,
                E2,
                D,
                ns,
                q,
                dop853,
                CH,
                K,
                F,
                W,
                S,
                efp,
                EDIR,
                ETERM,
                EVT,
                ECOUNT,
                prm,
            )
    return 0


@kernel
def erk_work(n_stages, n_dense, d):
    """The entries of the float64 work buffer of :func:`erk_run` for a pair of ``n_stages`` stages (the rows of
    its A, the extension's extra stages among them) and ``n_dense`` rows of its continuous extension."""
    return (n_stages + n_dense + 10) * d + EK_SIZE
