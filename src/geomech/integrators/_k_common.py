"""Loop template: helpers shared by every integrator loop (status codes, saving, Newton, small solves).

Template modules (``_k_*.py``) are not imported as such by the solver: :mod:`._codegen` concatenates
them, minus their preamble, after the generated model functions and compiles the result with numba
(or runs it as Python). Every loop has the signature

``run(FP, Y0, h, nsteps, save_every, OUT, INFO, tol, maxit, P, prm)``

with ``FP`` the addresses of the model's functions (``MODEL_FUNCTIONS`` below; the loops call them through
:mod:`._fptr`, so that a loop compiles once for every model), ``Y0`` the initial states ``(B, d)``, ``OUT`` the
saved states ``(B, n_save, d)`` (state 0, every ``save_every`` steps, and the last), ``INFO`` ``(B, 5)``:
status, failing step, residual, Newton iterations, right-hand-side evaluations, ``P`` the method's constants
and ``prm`` the model's parameter
values, which every model function takes last (one compiled module serves every value of them).
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)


def kernel(f):
    return f


#: a kernel numba inlines where it is called (its own IR in the caller's), for the helpers of a loop's step: a call
#: compiled apart still handles each of its array arguments (the Taylor step's helpers, their arrays borrowed: a
#: sixth of the ensemble's loop)
inlined = kernel


# <<< template preamble

ST_OK = 0
ST_NEWTON = 1
ST_NONFINITE = 2
ST_SINGULAR = 3
EPS = 2.220446049250313e-16
# Integers passed to the helpers as int64 values: numba compiles a function once more for each literal argument
# (store(OUT, b, 0, y) and store(OUT, b, k, y) would be two compilations).
SAVE0 = np.int64(0)
STAGE1 = np.int64(1)
# The model functions a loop may call, in the order of the address array ``FP`` the loops shared by all models
# take (geomech.integrators._fptr): ``call_model(FP[F_RHS], y, out, prm)`` is ``rhs(y, out, prm)``.
# Each takes its arrays, then ``prm``; MODEL_ARRAYS gives the arrays' number of dimensions: a vector as long as the
# first, or a square matrix of that size.
MODEL_ARRAYS = {
    "rhs": (1, 1),
    "fjac": (1, 1, 2),
    "grad": (1, 1),
    "ghess": (1, 1, 2),
    "gf_all": (1, 1, 2, 1, 2),
    "gf_grads": (1, 1, 1),
    "ghess3": (1, 1, 2),
    # the event functions g(y) of a run, their values in the first entries of the output (the others ignored)
    "event": (1, 1),
}
MODEL_FUNCTIONS = tuple(MODEL_ARRAYS)
F_RHS = 0
F_FJAC = 1
F_GRAD = 2
F_GHESS = 3
F_GF_ALL = 4
F_GF_GRADS = 5
F_GHESS3 = 6
F_EVENT = 7


@kernel
def param_row(PRM, b):
    """The parameter values of trajectory ``b``: ``PRM`` has one row for all trajectories, or one for each."""
    return PRM[0] if PRM.shape[0] == 1 else PRM[b]


@kernel
def finite(y):
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return False
    return True


@kernel
def load(y, Y0, b):
    """y = Y0[b], element by element (a slice assignment would compile numba's shape-mismatch error path)."""
    for i in range(y.shape[0]):
        y[i] = Y0[b, i]


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


@kernel
def lu_factor(A, piv, n):
    """LU factorisation with partial pivoting of the leading ``n x n`` block of ``A``, in place (the unit lower
    factor's multipliers below the diagonal), the row exchanges in ``piv``; for several solves with one matrix
    (:func:`lu_apply`). Returns False if a pivot is zero or not finite."""
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        if not (amax > 0.0) or not math.isfinite(amax):
            return False
        piv[k] = p
        if p != k:
            for j in range(n):
                t = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = t
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            A[i, k] = f
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
    return True


@kernel
def lu_apply(A, piv, x, n):
    """Solve in place with the factors of :func:`lu_factor` (``x`` holds the right-hand side)."""
    for k in range(n):
        p = piv[k]
        if p != k:
            t = x[k]
            x[k] = x[p]
            x[p] = t
        xk = x[k]
        if xk != 0.0:
            for i in range(k + 1, n):
                x[i] -= A[i, k] * xk
    for k in range(n - 1, -1, -1):
        t = x[k]
        for j in range(k + 1, n):
            t -= A[k, j] * x[j]
        x[k] = t / A[k, k]


@kernel
def solve_checked(A, x, n, rcond):
    """:func:`lu_solve`, and False also where the matrix is singular to working precision: a pivot of the
    elimination below ``rcond`` times the largest entry of ``A`` (the generated equations of motion solve their
    accelerations and multipliers with it, and report a singular state instead of an unbounded one)."""
    amax = 0.0
    for i in range(n):
        for j in range(n):
            a = abs(A[i, j])
            if a > amax or a != a:
                amax = a
    if not math.isfinite(amax):
        return False
    if n == 2:
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        if not (abs(det) > rcond * amax * amax):
            return False
        return lu_solve(A, x, n)
    if not lu_solve(A, x, n):
        return False
    for k in range(n):
        if not (abs(A[k, k]) > rcond * amax):
            return False
    return True
