"""The Runge-Kutta-Munthe-Kaas methods compiled, for a :class:`~geomech.systems.GroupFlow` whose body velocity is
given as formulas on a group with closed-form kernels (``_k_groups.py``): the generated module has

- ``gf_xi(t, G, out, prm)``: the body velocity's formulas at time t and element G (straight-line code);
- ``gf_field(t, u, Gc, out, prm)``: :math:`\\dot u = J_r(u)^{-1}\\xi(t, g_c\\exp u)` about the centre ``Gc``;
- ``rhs(y, out, prm)``: the same on the state ``y = (u, t)`` (``t' = 1``) with the centre read from ``prm``'s tail,
  the model the embedded pairs' shared steps (``_k_explicit.py``, ``_k_embedded.py``) evaluate by its address;
- ``rkmk4_run``: the classical RKMK4, a new centre every step (the Python engine's steps);
- ``rkmk_run``: the adaptive method, the Dormand-Prince pair's own control logic (``erk_*``) on ``(u, t)`` from
  ``u = 0``, the chart the box ``|u_i| <= chart_radius``: where a step leaves it, its continuous extension gives
  the exit, the centre moves there and the pair starts again (as the Python engine restarts scipy's solver); the
  saved states are ``g_c exp(u)`` at the saved times, the angles of the angle components carried unwrapped.
"""

from __future__ import annotations

import time
import weakref
from typing import Any

import numpy as np
import sympy as sp

from ..symbolic.compile import StraightLine
from ..systems.gait import T_SYMBOL
from . import _codegen
from ._group_code import exp_lines, group_kernels, jacobian_lines
from ._native import loop_of
from .methods._embedded import compiled_pair

__all__ = ["group_flow_module", "run_rkmk4", "run_rkmk"]


#: each flow's module (or None), made once: generating the source prints its formulas (a millisecond)
_MODULES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def group_flow_module(system: Any) -> Any | None:
    """The compiled module of ``system``'s body velocity, or None where it cannot be compiled (a callable body
    velocity, a group without kernels, numba missing, a function numba lacks)."""
    if system.formulas is None or not _codegen.numba_available():
        return None
    if system not in _MODULES:
        kernels = group_kernels(system.group.numeric)
        try:
            source = None if kernels is None else _source(system, kernels)
        except NotImplementedError:
            source = None
        _MODULES[system] = None if source is None else _codegen.compiled_module(source, "gf")
    return _MODULES[system]


def _source(system: Any, kernels: list) -> str:
    k, N = system.k, int(system.group.numeric.matrix_size)
    code = StraightLine()
    entries = system.entries
    used = set().union(*(e.free_symbols for e in system.formulas))
    reads = ["_t = t"] + [f"_{g} = G[{i // N}, {i % N}]" for i, g in enumerate(entries) if g in used]
    code.line("\n".join(reads))
    names = {T_SYMBOL: sp.Symbol("_t"), **{g: sp.Symbol(f"_{g}") for g in entries}}
    values = code.values([e.xreplace(names) for e in system.formulas])
    code.line("\n".join(f"out[{a}] = {code.code(values[a])}" for a in range(k)))
    xi = "@kernel\ndef gf_xi(t, G, out, prm):\n" + code.body()
    exp = "\n    ".join(exp_lines(kernels, "u", "E"))
    jac = "\n    ".join(jacobian_lines(kernels, "u", -1.0, "J"))
    text = xi + _FIELD.replace("EXP_LINES", exp).replace("JAC_LINES", jac) + _LOOPS
    scratch = 2 * N * N + k * k + k
    return text.replace("GF_SCRATCH", str(scratch)).replace("KDIM", str(k)).replace("NMAT", str(N))


_FIELD = """

@kernel
def gf_exp(u, E):
    for i in range(E.shape[0]):
        for j in range(E.shape[1]):
            E[i, j] = 0.0
    EXP_LINES


@kernel
def gf_field(t, u, Gc, out, prm, buf):
    # u' = J_r(u)^-1 xi(t, Gc exp(u)), in the scratch array buf (exp(u), the element, J_r^-1, xi), the caller's
    # (carved by shaped: numba's reshape calls a helper of its run time, which a loop loaded without numba lacks)
    E = shaped(buf, 0, (NMAT, NMAT))
    G = shaped(buf, NMAT * NMAT, (NMAT, NMAT))
    J = shaped(buf, 2 * NMAT * NMAT, (KDIM, KDIM))
    w = buf[2 * NMAT * NMAT + KDIM * KDIM :]
    gf_exp(u, E)
    gk_matmul(Gc, E, G)
    gf_xi(t, G, w, prm)
    for i in range(KDIM):
        for j in range(KDIM):
            J[i, j] = 0.0
    JAC_LINES
    for i in range(KDIM):
        s = 0.0
        for j in range(KDIM):
            s += J[i, j] * w[j]
        out[i] = s


@kernel
def rhs(y, out, prm):
    # the state (u, t), the centre in prm's last NMAT^2 entries, the field's scratch array the entries before it
    # (the run's own copy: an array made at each evaluation cost a third of RKMK4's loop)
    base = prm.shape[0] - NMAT * NMAT
    gf_field(y[KDIM], y, shaped(prm, base, (NMAT, NMAT)), out, prm, prm[base - GF_SCRATCH : base])
    out[KDIM] = 1.0
"""

_LOOPS = """

@kernel
def gf_move(Gc, u, ang, AC, OUTG, OUTA, row, E, T):
    # the element Gc exp(u) (and the unwrapped angles ang + u[AC]) into row `row` of OUTG, OUTA (row < 0: none)
    gf_exp(u, E)
    gk_matmul(Gc, E, T)
    if row >= 0:
        for i in range(NMAT):
            for j in range(NMAT):
                OUTG[row, i, j] = T[i, j]
        for j in range(AC.shape[0]):
            OUTA[row, j] = ang[j] + u[AC[j]]


@kernel
def rkmk4_run(G0, A0, AC, t0, h, nsteps, KEEP, OUTG, OUTA, INFO, prm):
    # RKMK4 from G0 (angles A0) at t0, nsteps steps of h, the nodes KEEP (sorted step indices) kept;
    # INFO = (status, the first row not reached, evaluations); returns the steps done
    # every array borrowed (geomech.integrators._fptr.borrowed): the arguments, the work arrays kept to the end
    AC, KEEP, OUTG, OUTA, INFO, prm = borrowed((AC, KEEP, OUTG, OUTA, INFO, prm))
    Gc_, ang_ = G0.copy(), A0.copy()
    V_ = np.zeros((6, KDIM))
    M_ = np.empty((2, NMAT, NMAT))
    buf_ = np.empty(GF_SCRATCH)
    Gc, ang, V, M, buf = borrowed((Gc_, ang_, V_, M_, buf_))
    z, k1, k2, k3, k4, u = V[0], V[1], V[2], V[3], V[4], V[5]
    E, T = M[0], M[1]
    nk = KEEP.shape[0]
    ik = 0
    while ik < nk and KEEP[ik] == 0:
        gf_move(Gc, z, ang, AC, OUTG, OUTA, ik, E, T)
        ik += 1
    for step in range(1, nsteps + 1):
        t = t0 + (step - 1) * h
        gf_field(t, z, Gc, k1, prm, buf)
        for i in range(KDIM):
            u[i] = 0.5 * h * k1[i]
        gf_field(t + 0.5 * h, u, Gc, k2, prm, buf)
        for i in range(KDIM):
            u[i] = 0.5 * h * k2[i]
        gf_field(t + 0.5 * h, u, Gc, k3, prm, buf)
        for i in range(KDIM):
            u[i] = h * k3[i]
        gf_field(t + h, u, Gc, k4, prm, buf)
        INFO[2] += 4.0
        for i in range(KDIM):
            u[i] = h * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) / 6.0
        if not finite(u):
            INFO[0] = 2.0
            INFO[1] = ik
            kept((Gc_, ang_, V_, M_, buf_))
            return step - 1
        gf_move(Gc, u, ang, AC, OUTG, OUTA, -1, E, T)
        for i in range(NMAT):
            for j in range(NMAT):
                Gc[i, j] = T[i, j]
        for j in range(AC.shape[0]):
            ang[j] += u[AC[j]]
        while ik < nk and KEEP[ik] == step:
            gf_move(Gc, z, ang, AC, OUTG, OUTA, ik, E, T)
            ik += 1
    INFO[1] = ik
    kept((Gc_, ang_, V_, M_, buf_))
    return nsteps


@kernel
def rkmk_run(fp, G0, A0, AC, t0, TS, OUTG, OUTA, INFO, rtol, atol, max_evals, A, B, E, E2, D, ns, q, dop853, CH, prm0):
    # the adaptive RKMK from G0 (angles A0) at t0, saving at TS (monotone, away from t0 but for its first entries);
    # INFO = (status, the first time not reached, evaluations, accepted steps, rejected steps, time reached, centres)
    n = TS.shape[0]
    d = KDIM + 1
    # every array borrowed (geomech.integrators._fptr.borrowed): the arguments, the work arrays kept to the end
    AC, TS, OUTG, OUTA, INFO, A, B, E, E2, D, CH = borrowed((AC, TS, OUTG, OUTA, INFO, A, B, E, E2, D, CH))
    prm_, Gc_, ang_ = prm0.copy(), G0.copy(), A0.copy()
    Y0_, OUT_, I1_ = np.zeros((1, d)), np.full((1, n, d), np.nan), np.zeros((1, 8))
    K_, F_, W_, S_ = np.empty((A.shape[0], d)), np.empty((D.shape[0], d)), np.empty((10, d)), np.empty(EK_SIZE)
    M_ = np.empty((2, NMAT, NMAT))
    prm, Gc, ang, Y0, OUT, I1 = borrowed((prm_, Gc_, ang_, Y0_, OUT_, I1_))
    K, F, W, S, M = borrowed((K_, F_, W_, S_, M_))
    Em, T = M[0], M[1]
    base = prm.shape[0] - NMAT * NMAT
    no_dir = np.zeros(0)
    no_evt = np.zeros((1, 0, 2 + d))
    no_count = np.zeros(1)
    first = 0
    tc = t0
    nfev = 0.0
    status = 0.0
    for i in range(INFO.shape[0]):
        INFO[i] = 0.0
    while True:
        for i in range(NMAT):
            for j in range(NMAT):
                prm[base + NMAT * i + j] = Gc[i, j]
        for i in range(KDIM):
            Y0[0, i] = 0.0
        Y0[0, KDIM] = tc
        TSs = TS[first:]
        OUTs = OUT[:, first:]
        budget = max_evals - nfev
        action = erk_begin(0, Y0, tc, TSs, OUTs, I1, W, S, CH)
        while action != ERK_DONE:
            erk_evaluate(action, fp, A, B, ns, K, W, S, prm)
            action = erk_after(
                action, 0, tc, TSs, OUTs, I1, rtol, atol, budget, E, E2, D, ns, q, dop853, CH, K, F, W, S,
                0, no_dir, no_dir, no_evt, no_count, prm,
            )
        saved = int(S[EK_K])
        for j in range(saved):
            gf_move(Gc, OUTs[0, j], ang, AC, OUTG, OUTA, first + j, Em, T)
        first += saved
        nfev += S[EK_NFEV]
        INFO[3] += S[EK_STEPS]
        INFO[4] += S[EK_REJECTED]
        status = S[EK_STATUS]
        if status != 6.0:
            INFO[5] = S[EK_T]
            break
        if not (S[EK_EXTENDED] and S[EK_PHASE] == 1):
            # left the chart where f was not finite (no crossing of the box located): the run ends there
            status = 2.0
            INFO[5] = tc
            break
        # the exit: the last point of the step's continuous extension inside the box; the centre moves there
        chart_exit(W[EW_Y], F, dop853, CH, W[EW_OUT])
        t_exit = W[EW_OUT, KDIM]
        if t_exit == tc:
            status = 4.0
            INFO[5] = tc
            break
        gf_move(Gc, W[EW_OUT], ang, AC, OUTG, OUTA, -1, Em, T)
        for i in range(NMAT):
            for j in range(NMAT):
                Gc[i, j] = T[i, j]
        for j in range(AC.shape[0]):
            ang[j] += W[EW_OUT, AC[j]]
        tc = t_exit
        INFO[6] += 1.0
        # outputs within a few units of round-off of the new centre's time are its element (the pair cannot step
        # there: its step would be below the resolution of t)
        ulp = abs(math.nextafter(tc, math.inf) - tc)
        while first < n and abs(TS[first] - tc) <= 16.0 * ulp:
            gf_move(Gc, Y0[0], ang, AC, OUTG, OUTA, first, Em, T)
            first += 1
        if first >= n:
            status = 0.0
            INFO[5] = tc
            break
    INFO[0] = status
    INFO[1] = first
    INFO[2] = nfev
    kept((prm_, Gc_, ang_, Y0_, OUT_, I1_, K_, F_, W_, S_, M_))
"""


def run_rkmk4(
    module: Any, G0: np.ndarray, A0: np.ndarray, AC: np.ndarray, t0: float, h: float, nsteps: int, keep: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, float, float]:
    """The nodes ``keep`` of a compiled RKMK4 run: (elements, angles, INFO, steps done, compile time, loop time)."""
    N, n_ac = G0.shape[0], AC.shape[0]
    OUTG, OUTA = np.full((len(keep), N, N), np.nan), np.full((len(keep), n_ac), np.nan)
    INFO, prm = np.zeros(3), np.zeros(0)
    KEEP = np.ascontiguousarray(keep, dtype=np.int64)
    G0, A0, AC = np.ascontiguousarray(G0, dtype=float), np.ascontiguousarray(A0, dtype=float), np.ascontiguousarray(AC)

    def warm_up() -> None:
        module.rkmk4_run(G0, A0, AC, 0.0, 1.0, 0, KEEP[:0], OUTG.copy(), OUTA.copy(), np.zeros(3), prm)

    args = (G0, A0, AC, float(t0), float(h), int(nsteps), KEEP, OUTG, OUTA, INFO, prm)
    loop, compile_time = loop_of(module, "rkmk4_run", args, warm_up)
    start = time.perf_counter()
    done = loop(*args)
    return OUTG, OUTA, INFO, int(done), compile_time, time.perf_counter() - start


def run_rkmk(
    module: Any,
    method: Any,
    k: int,
    G0: np.ndarray,
    A0: np.ndarray,
    AC: np.ndarray,
    t0: float,
    times: np.ndarray,
    tolerances: tuple[float, float],
    max_evaluations: float,
    radius: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """A compiled adaptive RKMK run saving at ``times``: (elements, angles, INFO, compile time, loop time)."""
    pair = compiled_pair(method.solver)
    assert pair is not None  # the caller checked
    tab = pair.tableau()
    N, n_ac = G0.shape[0], AC.shape[0]
    OUTG, OUTA = np.full((len(times), N, N), np.nan), np.full((len(times), n_ac), np.nan)
    INFO = np.zeros(8)
    CH = np.array([(i, -radius, radius) for i in range(k)] if np.isfinite(radius) else [], dtype=float)
    CH = CH.reshape(-1, 3)
    prm = np.zeros(2 * N * N + k * k + k + N * N)  # the field's scratch array, the centre (``rhs``)
    A, b, e, e2, dense = (np.ascontiguousarray(a, dtype=float) for a in (tab.A, tab.b, tab.e, tab.e2, tab.dense))
    args = (A, b, e, e2, dense, int(tab.n_stages), int(tab.error_order), int(tab.alternating), CH, prm)
    rtol, atol = tolerances
    G0, A0, AC = np.ascontiguousarray(G0, dtype=float), np.ascontiguousarray(A0, dtype=float), np.ascontiguousarray(AC)
    times = np.ascontiguousarray(times, dtype=float)
    fp = _codegen.rhs_address(module)

    def warm_up() -> None:
        probe = np.array([t0, t0 + (times[-1] - t0) * 1e-9])
        module.rkmk_run(
            fp, G0, A0, AC, t0, probe, OUTG[:2].copy(), OUTA[:2].copy(), np.zeros(8), rtol, atol, 1.0, *args
        )

    every = (fp, G0, A0, AC, float(t0), times, OUTG, OUTA, INFO, float(rtol), float(atol), float(max_evaluations))
    loop, compile_time = loop_of(module, "rkmk_run", every + args, warm_up)
    start = time.perf_counter()
    loop(*every, *args)
    return OUTG, OUTA, INFO, compile_time, time.perf_counter() - start
