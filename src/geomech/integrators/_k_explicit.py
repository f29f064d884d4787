"""Loop template: explicit methods for any ODE ``y' = rhs(y)`` (classical RK4, Adams-Bashforth-Moulton 4).

See ``_k_common.py`` for the template mechanism and the common loop signature.
"""

import numpy as np

# >>> template preamble (removed when compiled)
from ._k_common import (
    finish_step,
    kernel,
    store,
)


def rhs(y, out):
    raise NotImplementedError


# <<< template preamble


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
