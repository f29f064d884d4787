"""Kernel template: the stability map's points compiled, for a left-invariant system given by a formula.

The search and the verdicts of :mod:`.equilibria` and :mod:`.stability`, step for step (the same starting points,
Levenberg-Marquardt iteration, chart switches, merging tolerances, Poincare-Hopf check and thresholds), on the
model's compiled gradient and Hessian ``ghess3(m, g, D2H, prm)`` called through its address (:mod:`geomech.
integrators._fptr`): one compiled loop serves every model. Not imported as such: :func:`geomech.integrators.
_codegen.template_module` compiles it without its preamble, after the shared helpers of the integrator loops.

:func:`stability_points` assesses a block of grid points, each with its row of model parameters, in order: the
relative equilibria are continued from the previous point's and searched afresh at a row's first point (``RESTART``)
and wherever the continued set fails the Poincare-Hopf check or has fewer members than the previous one.
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ..integrators._fptr import call_model4
from ..integrators._k_common import F_GHESS3


def kernel(f):
    return f


# <<< template preamble

#: As in :mod:`.stability`: a symmetric 2 x 2 or restricted matrix is degenerate below this relative eigenvalue.
EQ_DEGENERATE = 1e-9
#: Error codes of a block (the Python search raises NumericalError on both).
EQ_OK = 0
EQ_TOO_MANY_MINIMA = 1
EQ_NONFINITE_HESSIAN = 2
#: Verdict codes (``VERDICT_CODES`` of :mod:`.stability`).
V_STABLE = 1
V_INCONCLUSIVE = 0
V_UNSTABLE = -1


@kernel
def eq_sym_eig2(a, b, c):
    """Eigenvalues, ascending, of the symmetric [[a, b], [b, c]]."""
    mean = 0.5 * (a + c)
    d = math.hypot(0.5 * (a - c), b)
    return mean - d, mean + d


@kernel
def eq_definiteness(e0, e1):
    """0 degenerate, 1 positive, -1 negative, 2 indefinite (``_definiteness`` of :mod:`.stability`)."""
    big = max(abs(e0), abs(e1))
    scale = max(big, 1e-300)
    if min(abs(e0), abs(e1)) <= EQ_DEGENERATE * scale or big == 0.0:
        return 0
    if e0 > 0.0 and e1 > 0.0:
        return 1
    if e0 < 0.0 and e1 < 0.0:
        return -1
    return 2


@kernel
def eq_index(hess):
    """Poincare-Hopf index of a critical point of h_p from its Hessian: +1, -1, or 0 if degenerate; -2 when the
    Hessian is not finite (``Equilibrium.index``)."""
    if not (math.isfinite(hess[0, 0]) and math.isfinite(hess[0, 1]) and math.isfinite(hess[1, 1])):
        return -2
    e0, e1 = eq_sym_eig2(hess[0, 0], hess[0, 1], hess[1, 1])
    scale = max(max(abs(e0), abs(e1)), 1e-300)
    if min(abs(e0), abs(e1)) <= EQ_DEGENERATE * scale:
        return 0
    return 1 if e0 * e1 > 0.0 else -1


@kernel
def eq_best_axis(m):
    """The chart farthest from its poles: the axis of the smallest |m_k| (the first of equals)."""
    k = 0
    for j in range(1, 3):
        if abs(m[j]) < abs(m[k]):
            k = j
    return k


@kernel
def eq_derivatives(FP, prm, m, axis, lL, grad, hess, g, D2):
    """(l, L), grad h_p and the Hessian of h_p at ``m`` in the chart about ``axis`` (``_derivatives`` of
    :mod:`.equilibria`), with grad H and D2H in ``g`` and ``D2``. False at the chart's pole."""
    G = math.sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
    i0 = (axis + 1) % 3
    i1 = (axis + 2) % 3
    p0 = m[i0]
    p1 = m[i1]
    p2 = m[axis]
    s = math.hypot(p0, p1)
    if s <= 1e-9 * G:
        return False
    lL[0] = math.atan2(p0, p1)
    lL[1] = p2
    sL = -p2 / s
    sLL = -(G * G) / (s * s * s)
    sn = p0 / s
    cs = p1 / s
    call_model4(FP[F_GHESS3], m, g, D2, prm)
    # the chart's tangents in the permuted frame (mp = (m[i0], m[i1], m[axis])); the third row of U_l is 0
    u00 = s * cs
    u10 = -s * sn
    u01 = sL * sn
    u11 = sL * cs
    g0 = g[i0]
    g1 = g[i1]
    g2 = g[axis]
    a00 = D2[i0, i0]
    a01 = D2[i0, i1]
    a02 = D2[i0, axis]
    a11 = D2[i1, i1]
    a12 = D2[i1, axis]
    a22 = D2[axis, axis]
    a10 = D2[i1, i0]
    a20 = D2[axis, i0]
    a21 = D2[axis, i1]
    grad[0] = g0 * u00 + g1 * u10
    grad[1] = g0 * u01 + g1 * u11 + g2
    # D2 U1 (3 x 2), then U1^T D2 U1
    b00 = a00 * u00 + a01 * u10
    b10 = a10 * u00 + a11 * u10
    b01 = a00 * u01 + a01 * u11 + a02
    b11 = a10 * u01 + a11 * u11 + a12
    b21 = a20 * u01 + a21 * u11 + a22
    b20 = a20 * u00 + a21 * u10
    h00 = u00 * b00 + u10 * b10
    h01 = u00 * b01 + u10 * b11
    h10 = u01 * b00 + u11 * b10 + b20
    h11 = u01 * b01 + u11 * b11 + b21
    h00 += g0 * (-s * sn) + g1 * (-s * cs)
    gll = g0 * (sL * cs) + g1 * (-sL * sn)
    h01 += gll
    h10 += gll
    h11 += g0 * (sLL * sn) + g1 * (sLL * cs)
    off = 0.5 * (h01 + h10)
    hess[0, 0] = h00
    hess[0, 1] = off
    hess[1, 0] = off
    hess[1, 1] = h11
    return True


@kernel
def eq_chart_point(lL, G, axis, m):
    """The momentum at (l, L) of the chart about ``axis`` (``SerretAndoyerChart.inverse``)."""
    L = lL[1]
    s = math.sqrt(max(G * G - L * L, 0.0))
    m[(axis + 1) % 3] = s * math.sin(lL[0])
    m[(axis + 2) % 3] = s * math.cos(lL[0])
    m[axis] = L


@kernel
def eq_state(FP, prm, m, axis, G, lL, r, J, g, D2, grad, hess):
    """Levenberg-Marquardt's residual r = S grad h_p and its Jacobian J = S hess S, S = diag(1, G), at ``m``;
    returns the residual's scale (or -1 at the chart's pole)."""
    if not eq_derivatives(FP, prm, m, axis, lL, grad, hess, g, D2):
        return -1.0
    r[0] = grad[0]
    r[1] = G * grad[1]
    J[0, 0] = hess[0, 0]
    J[0, 1] = G * hess[0, 1]
    J[1, 0] = G * hess[1, 0]
    J[1, 1] = G * G * hess[1, 1]
    big = 0.0
    for i in range(3):
        for j in range(3):
            big = max(big, abs(D2[i, j]))
    return G * max(max(math.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]), G * big), 1e-300)


@kernel
def eq_abs_max2(J):
    return max(max(abs(J[0, 0]), abs(J[0, 1])), max(abs(J[1, 0]), abs(J[1, 1])))


@kernel
def eq_refine(FP, prm, m0, G, tol, max_iter, m_out, lL_out, hess_out, W):
    """``refine_equilibrium``: Newton (Levenberg-Marquardt) on grad h_p = 0 from ``m0`` projected to |m| = G.
    Returns the chart of the result (0-2; the seed's chart about axis 3 unless the point is near its poles) with
    the equilibrium in ``m_out``, its (l, L) and Hessian of h_p there, or -1 when none is reached. ``W`` is work
    space (42 numbers), distinct from the other arguments."""
    m = W[0:3]
    nm = math.sqrt(m0[0] * m0[0] + m0[1] * m0[1] + m0[2] * m0[2])
    if nm == 0.0:
        return -1
    for k in range(3):
        m[k] = G * m0[k] / nm
    lL = W[3:5]
    r = W[5:7]
    g = W[7:10]
    grad = W[10:12]
    m_new = W[12:15]
    lL_new = W[15:17]
    r_new = W[17:19]
    new = W[19:21]
    J = W[21:25].reshape((2, 2))
    J_new = W[25:29].reshape((2, 2))
    hess = W[29:33].reshape((2, 2))
    D2 = W[33:42].reshape((3, 3))
    axis = eq_best_axis(m)
    scale = eq_state(FP, prm, m, axis, G, lL, r, J, g, D2, grad, hess)
    if scale < 0.0:
        return -1
    mu = 1e-6 * max(eq_abs_max2(J) ** 2, 1e-300)
    res = math.hypot(r[0], r[1])
    for _ in range(max_iter):
        if res <= tol * scale:
            if axis != 2 and abs(m[2]) <= 0.9 * G:
                axis = 2
            if not eq_derivatives(FP, prm, m, axis, lL_out, grad, hess_out, g, D2):
                return -1
            for k in range(3):
                m_out[k] = m[k]
            return axis
        accepted = False
        for _ in range(30):
            # (J^T J + mu I) step = J^T r
            a00 = J[0, 0] * J[0, 0] + J[1, 0] * J[1, 0] + mu
            a01 = J[0, 0] * J[0, 1] + J[1, 0] * J[1, 1]
            a11 = J[0, 1] * J[0, 1] + J[1, 1] * J[1, 1] + mu
            b0 = J[0, 0] * r[0] + J[1, 0] * r[1]
            b1 = J[0, 1] * r[0] + J[1, 1] * r[1]
            det = a00 * a11 - a01 * a01
            s0 = (a11 * b0 - a01 * b1) / det
            s1 = (a00 * b1 - a01 * b0) / det
            size = max(abs(s0), abs(s1))
            if size > 0.5:
                s0 *= 0.5 / size
                s1 *= 0.5 / size
            new[0] = lL[0] - s0
            new[1] = min(max(lL[1] - s1 * G, -0.95 * G), 0.95 * G)
            eq_chart_point(new, G, axis, m_new)
            ax_new = eq_best_axis(m_new) if abs(new[1]) > 0.8 * G else axis
            scale_new = eq_state(FP, prm, m_new, ax_new, G, lL_new, r_new, J_new, g, D2, grad, hess)
            if scale_new < 0.0:
                return -1  # a pole of the chart (InputError in the Python search): this start fails
            res_new = math.hypot(r_new[0], r_new[1])
            if res_new < res:
                for k in range(3):
                    m[k] = m_new[k]
                axis = ax_new
                lL[0] = lL_new[0]
                lL[1] = lL_new[1]
                r[0] = r_new[0]
                r[1] = r_new[1]
                J[0, 0] = J_new[0, 0]
                J[0, 1] = J_new[0, 1]
                J[1, 0] = J_new[1, 0]
                J[1, 1] = J_new[1, 1]
                scale = scale_new
                res = res_new
                mu = max(mu / 5.0, 1e-14 * max(eq_abs_max2(J) ** 2, 1e-300))
                accepted = True
                break
            mu *= 6.0
        if not accepted:
            break
    return -1


@kernel
def eq_distance(a, b):
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


@kernel
def eq_add(FP, prm, start, G, tol, max_iter, n, EM, EA, EL, EH, m_out, lL_out, hess_out, W):
    """Refine ``start`` and append the equilibrium to the set (``EM`` momenta, ``EA`` charts, ``EL`` (l, L), ``EH``
    Hessians; ``n`` members) unless one within 1e-7 G is there; returns the new count."""
    axis = eq_refine(FP, prm, start, G, tol, max_iter, m_out, lL_out, hess_out, W)
    if axis < 0:
        return n
    for j in range(n):
        if eq_distance(m_out, EM[j]) <= 1e-7 * G:
            return n
    if n >= EM.shape[0]:
        return n  # no room (never with the capacity the callers give)
    for k in range(3):
        EM[n, k] = m_out[k]
    EA[n] = axis
    EL[n, 0] = lL_out[0]
    EL[n, 1] = lL_out[1]
    for i in range(2):
        for j in range(2):
            EH[n, i, j] = hess_out[i, j]
    return n + 1


@kernel
def eq_check(EH, n):
    """(complete, error): Poincare-Hopf's check of a set (every member nondegenerate, indices adding up to 2), and
    EQ_NONFINITE_HESSIAN if a member's Hessian is not finite."""
    total = 0
    degenerate = False
    for j in range(n):
        idx = eq_index(EH[j])
        if idx == -2:
            return False, EQ_NONFINITE_HESSIAN
        if idx == 0:
            degenerate = True
        total += idx
    return (not degenerate) and total == 2, EQ_OK


@kernel
def eq_find(FP, prm, G, tol, pts1, nbr1, pts2, nbr2, EM, EA, EL, EH, r, W):
    """``find_equilibria``: Newton from the six points +-G e_k and from the local minima of |m x grad H| over the
    quasi-uniform ``pts1`` (compared with their neighbours ``nbr1``), then, if Poincare-Hopf fails, from those of the
    six times denser ``pts2``. Returns (members, complete, error). ``W``: work space of 72 numbers."""
    m_out = W[42:45]
    lL_out = W[45:47]
    hess_out = W[47:51].reshape((2, 2))
    g = W[51:54]
    start = W[54:57]
    D2 = W[57:66].reshape((3, 3))
    n = 0
    complete = False
    for stage in range(2):
        pts = pts1 if stage == 0 else pts2
        nbr = nbr1 if stage == 0 else nbr2
        npts = pts.shape[0]
        for k in range(npts):
            call_model4(FP[F_GHESS3], pts[k], g, D2, prm)
            c0 = pts[k, 1] * g[2] - pts[k, 2] * g[1]
            c1 = pts[k, 2] * g[0] - pts[k, 0] * g[2]
            c2 = pts[k, 0] * g[1] - pts[k, 1] * g[0]
            v = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            r[k] = v if math.isfinite(v) else math.inf
        n_min = 0
        for k in range(npts):
            low = math.inf
            for j in range(1, nbr.shape[1]):
                low = min(low, r[nbr[k, j]])
            if r[k] <= low:
                n_min += 1
        if n_min > max(200, npts // 20):
            return n, False, EQ_TOO_MANY_MINIMA
        if stage == 0:
            for sign in (1.0, -1.0):
                for axis in range(3):
                    start[0] = 0.0
                    start[1] = 0.0
                    start[2] = 0.0
                    start[axis] = sign * G
                    near_one = False
                    for j in range(n):
                        if eq_distance(start, EM[j]) < 1e-9 * G:
                            near_one = True
                    if not near_one:
                        n = eq_add(FP, prm, start, G, tol, 80, n, EM, EA, EL, EH, m_out, lL_out, hess_out, W)
        for k in range(npts):
            low = math.inf
            for j in range(1, nbr.shape[1]):
                low = min(low, r[nbr[k, j]])
            if not r[k] <= low:
                continue
            near_one = False
            for j in range(n):
                if eq_distance(pts[k], EM[j]) < 1e-9 * G:
                    near_one = True
            if not near_one:
                n = eq_add(FP, prm, pts[k], G, tol, 80, n, EM, EA, EL, EH, m_out, lL_out, hess_out, W)
        complete, err = eq_check(EH, n)
        if err != EQ_OK:
            return n, False, err
        if complete:
            break
    return n, complete, EQ_OK


@kernel
def eq_continue(FP, prm, G, tol, near, PM, n_prev, EM, EA, EL, EH, W):
    """``continue_equilibria`` without its fallback: Newton (12 iterations at most) from each previous equilibrium
    ``PM[:n_prev]`` and from ``near``. Returns (members, complete, error). ``W``: work space of 72 numbers."""
    m_out = W[42:45]
    lL_out = W[45:47]
    hess_out = W[47:51].reshape((2, 2))
    n = 0
    for j in range(n_prev):
        n = eq_add(FP, prm, PM[j], G, tol, 12, n, EM, EA, EL, EH, m_out, lL_out, hess_out, W)
    if near[0] != 0.0 or near[1] != 0.0 or near[2] != 0.0:
        n = eq_add(FP, prm, near, G, tol, 12, n, EM, EA, EL, EH, m_out, lL_out, hess_out, W)
    complete, err = eq_check(EH, n)
    return n, complete, err


@kernel
def eq_nearest(EM, n, near, G, prefer, have_prefer):
    """``nearest_index`` of :mod:`.equilibria`: the member closest to ``near``; ties (to 1e-9 G) go to the one
    closest to ``prefer`` (when ``have_prefer``), then to the largest components."""
    dmin = math.inf
    for j in range(n):
        dmin = min(dmin, eq_distance(EM[j], near))
    best = -1
    for j in range(n):
        if not eq_distance(EM[j], near) <= dmin + 1e-9 * G:
            continue
        if best < 0:
            best = j
            continue
        a = eq_distance(EM[j], prefer) if have_prefer else 0.0
        b = eq_distance(EM[best], prefer) if have_prefer else 0.0
        if a < b or (a == b and (-EM[j, 0], -EM[j, 1], -EM[j, 2]) < (-EM[best, 0], -EM[best, 1], -EM[best, 2])):
            best = j
    return max(best, 0)


@kernel
def eq_tangent_determinant(m, g, D2):
    """(eigenvalues of the energy-Casimir second variation D2H - mu I on m^perp, its determinant / max|D2H|^2):
    ``energy_casimir`` and ``_ec_determinant`` of :mod:`.stability`, in an orthonormal basis of m^perp (the
    eigenvalues and the determinant do not depend on which)."""
    G2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2]
    mu = (g[0] * m[0] + g[1] * m[1] + g[2] * m[2]) / G2
    nm = math.sqrt(G2)
    u = np.empty(3)
    for k in range(3):
        u[k] = m[k] / nm
    # the basis vector from the axis u is farthest from, made orthogonal to u; the second u x b1
    k = eq_best_axis(u)
    b1 = np.empty(3)
    for j in range(3):
        b1[j] = -u[k] * u[j]
    b1[k] += 1.0
    nb = math.sqrt(b1[0] * b1[0] + b1[1] * b1[1] + b1[2] * b1[2])
    for j in range(3):
        b1[j] /= nb
    b2 = np.empty(3)
    b2[0] = u[1] * b1[2] - u[2] * b1[1]
    b2[1] = u[2] * b1[0] - u[0] * b1[2]
    b2[2] = u[0] * b1[1] - u[1] * b1[0]
    q00 = 0.0
    q01 = 0.0
    q10 = 0.0
    q11 = 0.0
    big = 0.0
    for i in range(3):
        for j in range(3):
            a = D2[i, j] - (mu if i == j else 0.0)
            big = max(big, abs(D2[i, j]))
            q00 += b1[i] * a * b1[j]
            q01 += b1[i] * a * b2[j]
            q10 += b2[i] * a * b1[j]
            q11 += b2[i] * a * b2[j]
    off = 0.5 * (q01 + q10)
    e0, e1 = eq_sym_eig2(q00, off, q11)
    det = (q00 * q11 - q01 * q10) / max(big * big, 1e-300)
    return e0, e1, det


@kernel
def stability_points(
    FP, PRM, G, near, RESTART, tol, pts1, nbr1, pts2, nbr2, CODES, M, HEV, GROWTH, ECDET, JUMP, COMPLETE, INFO
):
    """The stability map's ``_assess_points`` over a block: for point ``i`` (model parameters ``PRM[i]``), all
    equilibria (continued or searched afresh), the one nearest to ``near`` assessed. Outputs per point: ``CODES``
    (verdict, Lagrange-Dirichlet, energy-Casimir, linearisation; left as they are where no equilibrium is found),
    ``M``, ``HEV`` (eigenvalues of the Hessian of h_p), ``GROWTH``, ``ECDET``, ``JUMP`` and ``COMPLETE``. ``INFO``
    is (error code, point) of the first point whose search failed numerically (the block then stops there)."""
    npts = PRM.shape[0]
    cap = 6 + max(200, pts2.shape[0] // 20) + max(200, pts1.shape[0] // 20) + 2
    PM = np.empty((cap, 3))
    EM = np.empty((cap, 3))
    EA = np.empty(cap, dtype=np.int64)
    EL = np.empty((cap, 2))
    EH = np.empty((cap, 2, 2))
    r = np.empty(pts2.shape[0])
    W = np.empty(72)
    g = np.empty(3)
    D2 = np.empty((3, 3))
    last = np.empty(3)
    have_last = False
    n_prev = -1  # no previous set: search afresh
    INFO[0] = EQ_OK
    INFO[1] = -1
    for i in range(npts):
        prm = PRM[i]
        if RESTART[i]:
            n_prev = -1
            have_last = False
        if n_prev < 0:
            n, complete, err = eq_find(FP, prm, G, tol, pts1, nbr1, pts2, nbr2, EM, EA, EL, EH, r, W)
        else:
            n, complete, err = eq_continue(FP, prm, G, tol, near, PM, n_prev, EM, EA, EL, EH, W)
            if err == EQ_OK and not (complete and n == n_prev):
                n, complete, err = eq_find(FP, prm, G, tol, pts1, nbr1, pts2, nbr2, EM, EA, EL, EH, r, W)
        if err != EQ_OK:
            INFO[0] = err
            INFO[1] = i
            return
        if n == 0:
            n_prev = -1
            continue
        best = eq_nearest(EM, n, near, G, last, have_last)
        m = EM[best]
        JUMP[i] = 1 if have_last and eq_distance(m, last) > 0.25 * G else 0
        for j in range(n):
            for k in range(3):
                PM[j, k] = EM[j, k]
        n_prev = n
        for k in range(3):
            last[k] = m[k]
            M[i, k] = m[k]
        have_last = True
        COMPLETE[i] = 1 if complete else 0
        hess = EH[best]
        # Lagrange-Dirichlet on the Hessian of h_p
        e0, e1 = eq_sym_eig2(hess[0, 0], hess[0, 1], hess[1, 1])
        HEV[i, 0] = e0
        HEV[i, 1] = e1
        ld = V_STABLE if abs(eq_definiteness(e0, e1)) == 1 else V_INCONCLUSIVE
        # energy-Casimir on m^perp
        call_model4(FP[F_GHESS3], m, g, D2, prm)
        q0, q1, ec_det = eq_tangent_determinant(m, g, D2)
        ECDET[i] = ec_det
        ec = V_STABLE if abs(eq_definiteness(q0, q1)) == 1 else V_INCONCLUSIVE
        # the linearisation: eigenvalues +-sqrt(-det) of [[H10, H11], [-H00, -H01]]
        det = hess[0, 0] * hess[1, 1] - hess[0, 1] * hess[1, 0]
        big = max(max(abs(hess[0, 0]), abs(hess[0, 1])), max(abs(hess[1, 0]), abs(hess[1, 1])))
        scale = max(big * big, 1e-300)
        lin = V_UNSTABLE if det < -EQ_DEGENERATE * scale else V_INCONCLUSIVE
        GROWTH[i] = math.sqrt(-det) if det < 0.0 else 0.0
        CODES[i, 1] = ld
        CODES[i, 2] = ec
        CODES[i, 3] = lin
        if ld == V_STABLE or ec == V_STABLE:
            CODES[i, 0] = V_STABLE
        elif lin == V_UNSTABLE:
            CODES[i, 0] = V_UNSTABLE
        else:
            CODES[i, 0] = V_INCONCLUSIVE
