"""Loop template: the closed-form groups' logarithms and the inverses of their Jacobians, on one element or
vector at a time, for the compiled maps on a group (the discrete Lagrange-d'Alembert map with the group's
discrete Lagrangian). The same formulas, series branches and switch points as :mod:`geomech.lie` (SO(2),
R^n, SE(2), SO(3), SE(3)); the series' coefficients and switch points are those of :mod:`geomech.lie._common`
(a test compares them), written out here because a template is compiled as text.

Each function reads or writes one factor of a product group: the element's diagonal block at row and column
``o`` of ``P``, the algebra vector's entries from ``a``; the Jacobians ``J_l^{-1}(s u)`` into the block at
``(a, a)`` of ``J`` (``s = -1`` gives the right Jacobian's inverse, :math:`J_r^{-1}(u) = J_l^{-1}(-u)`).
"""

import math

import numpy as np

# >>> template preamble (removed when compiled)
from ._k_common import kernel

# <<< template preamble

# sin t / t, (t/2) cot(t/2), (1 - (t/2) cot(t/2)) / t^2, t / sin t, (1 - cos t) / t^2, (t - sin t) / t^3,
# (t^2 + 2 cos t - 2) / (2 t^4), (2 t - 3 sin t + t cos t) / (2 t^5): the Taylor coefficients of t^0, t^2, ...
# used below the switch point, the closed form above (lie._common's EvenSeries of the same names)
GK_SINC = (1.0, -0.16666666666666666, 0.008333333333333333)
GK_SINC_TOL = 0.010189318248006183
GK_HALF_COT_HALF = (
    1.0,
    -0.08333333333333333,
    -0.001388888888888889,
    -3.306878306878307e-05,
    -8.267195767195768e-07,
    -2.08767569878681e-08,
)
GK_HALF_COT_HALF_TOL = 0.294185874344111
GK_JINV_D = (
    0.08333333333333333,
    0.001388888888888889,
    3.306878306878307e-05,
    8.267195767195768e-07,
    2.08767569878681e-08,
    5.284190138687493e-10,
    1.3382536530684679e-11,
    3.3896802963225827e-13,
    8.586062056277845e-15,
    2.174868698558062e-16,
    5.5090028283602295e-18,
    1.3954464685812522e-19,
)
GK_JINV_D_TOL = 1.4287439293274373
GK_T_OVER_SIN = (1.0, 0.16666666666666666, 0.019444444444444445)
GK_T_OVER_SIN_TOL = 0.006904067898109976
GK_ONE_MINUS_COS_T2 = (0.5, -0.041666666666666664, 0.001388888888888889)
GK_ONE_MINUS_COS_T2_TOL = 0.012837736544740939
GK_T_MINUS_SIN_T3 = (
    0.16666666666666666,
    -0.008333333333333333,
    0.0001984126984126984,
    -2.7557319223985893e-06,
    2.505210838544172e-08,
    -1.6059043836821613e-10,
    7.647163731819816e-13,
    -2.8114572543455206e-15,
    8.22063524662433e-18,
    -1.9572941063391263e-20,
    3.868170170630684e-23,
    -6.446950284384474e-26,
)
GK_T_MINUS_SIN_T3_TOL = 3.044759472361276
GK_SE3_C2 = (
    0.041666666666666664,
    -0.001388888888888889,
    2.48015873015873e-05,
    -2.755731922398589e-07,
    2.08767569878681e-09,
    -1.1470745597729725e-11,
    4.779477332387385e-14,
    -1.5619206968586225e-16,
    4.110317623312165e-19,
    -8.896791392450574e-22,
    1.6117375710961184e-24,
    -2.4795962632247976e-27,
)
GK_SE3_C2_TOL = 3.301911346035104
GK_SE3_C3 = (
    0.008333333333333333,
    -0.0003968253968253968,
    8.267195767195768e-06,
    -1.0020843354176688e-07,
    8.029521918410807e-10,
    -4.58829823909189e-12,
    1.9680200780418645e-14,
    -6.576508197299464e-17,
    1.7615646957052136e-19,
    -3.868170170630684e-22,
    7.091645312822921e-25,
    -1.1020427836554655e-27,
)
GK_SE3_C3_TOL = 3.192718303113447
GK_TINY = 2.2250738585072014e-308


@kernel
def gk_even(t, C):
    """sum_i C[i] t^(2i) (Horner in t^2)."""
    t2 = t * t
    v = 0.0
    for i in range(len(C) - 1, -1, -1):
        v = v * t2 + C[i]
    return v


@kernel
def gk_sinc(t):
    if abs(t) < GK_SINC_TOL:
        return gk_even(t, GK_SINC)
    return math.sin(t) / t


@kernel
def gk_half_cot_half(t):
    if abs(t) < GK_HALF_COT_HALF_TOL:
        return gk_even(t, GK_HALF_COT_HALF)
    return 0.5 * t * math.cos(0.5 * t) / math.sin(0.5 * t)


@kernel
def gk_jinv_d(t):
    if abs(t) < GK_JINV_D_TOL:
        return gk_even(t, GK_JINV_D)
    return (1.0 - 0.5 * t * math.cos(0.5 * t) / math.sin(0.5 * t)) / (t * t)


@kernel
def gk_t_over_sin(t):
    if abs(t) < GK_T_OVER_SIN_TOL:
        return gk_even(t, GK_T_OVER_SIN)
    return t / math.sin(t)


@kernel
def gk_one_minus_cos_t2(t):
    if abs(t) < GK_ONE_MINUS_COS_T2_TOL:
        return gk_even(t, GK_ONE_MINUS_COS_T2)
    return 2.0 * math.sin(0.5 * t) ** 2 / (t * t)


@kernel
def gk_t_minus_sin_t3(t):
    if abs(t) < GK_T_MINUS_SIN_T3_TOL:
        return gk_even(t, GK_T_MINUS_SIN_T3)
    return (t - math.sin(t)) / t**3


@kernel
def gk_se3_c2(t):
    if abs(t) < GK_SE3_C2_TOL:
        return gk_even(t, GK_SE3_C2)
    return (t * t + 2.0 * math.cos(t) - 2.0) / (2.0 * t**4)


@kernel
def gk_se3_c3(t):
    if abs(t) < GK_SE3_C3_TOL:
        return gk_even(t, GK_SE3_C3)
    return (2.0 * t - 3.0 * math.sin(t) + t * math.cos(t)) / (2.0 * t**5)


# -- exponentials: the factor's block of E (zero elsewhere: E is set to zero by the caller) ---------------------------
@kernel
def exp_so2(u, a, E, o):
    c, s = math.cos(u[a]), math.sin(u[a])
    E[o, o] = c
    E[o, o + 1] = -s
    E[o + 1, o] = s
    E[o + 1, o + 1] = c


@kernel
def exp_rn(u, a, m, E, o):
    for i in range(m + 1):
        E[o + i, o + i] = 1.0
    for i in range(m):
        E[o + i, o + m] = u[a + i]


@kernel
def exp_se2(u, a, E, o):
    """[[R(omega), V(omega) v], [0, 1]], V = A I + B J, A = sin(w)/w, B = (1 - cos w)/w."""
    vx, vy, w = u[a], u[a + 1], u[a + 2]
    A = gk_sinc(w)
    B = w * gk_one_minus_cos_t2(w)
    c, s = math.cos(w), math.sin(w)
    E[o, o] = c
    E[o, o + 1] = -s
    E[o + 1, o] = s
    E[o + 1, o + 1] = c
    E[o, o + 2] = A * vx - B * vy
    E[o + 1, o + 2] = B * vx + A * vy
    E[o + 2, o + 2] = 1.0


@kernel
def exp_so3(u, a, E, o):
    """Rodrigues: cos(theta) I + (sin(theta)/theta) v^ + ((1 - cos theta)/theta^2) v v^T."""
    x, y, z = u[a], u[a + 1], u[a + 2]
    theta = math.sqrt(x * x + y * y + z * z)
    A = gk_sinc(theta)
    B = gk_one_minus_cos_t2(theta)
    c = math.cos(theta)
    E[o, o] = c + B * x * x
    E[o, o + 1] = -A * z + B * x * y
    E[o, o + 2] = A * y + B * x * z
    E[o + 1, o] = A * z + B * y * x
    E[o + 1, o + 1] = c + B * y * y
    E[o + 1, o + 2] = -A * x + B * y * z
    E[o + 2, o] = -A * y + B * z * x
    E[o + 2, o + 1] = A * x + B * z * y
    E[o + 2, o + 2] = c + B * z * z


@kernel
def exp_se3(u, a, E, o):
    """[[exp(omega^), J_l(omega) v], [0, 1]] for u = (v, omega), J_l = A I + B omega^ + C omega omega^T."""
    exp_so3(u, a + 3, E, o)
    x, y, z = u[a + 3], u[a + 4], u[a + 5]
    theta = math.sqrt(x * x + y * y + z * z)
    A = gk_sinc(theta)
    B = gk_one_minus_cos_t2(theta)
    C = gk_t_minus_sin_t3(theta)
    v0, v1, v2 = u[a], u[a + 1], u[a + 2]
    wv = x * v0 + y * v1 + z * v2
    # A v + B (omega x v) + C omega (omega . v)
    E[o, o + 3] = A * v0 + B * (y * v2 - z * v1) + C * x * wv
    E[o + 1, o + 3] = A * v1 + B * (z * v0 - x * v2) + C * y * wv
    E[o + 2, o + 3] = A * v2 + B * (x * v1 - y * v0) + C * z * wv
    E[o + 3, o + 3] = 1.0


# -- logarithms ----------------------------------------------------------------------------------------------------
@kernel
def log_so2(P, o, u, a):
    u[a] = math.atan2(P[o + 1, o], P[o, o])


@kernel
def log_rn(P, o, m, u, a):
    for i in range(m):
        u[a + i] = P[o + i, o + m]


@kernel
def log_se2(P, o, u, a):
    """(v_x, v_y, omega) with omega in (-pi, pi] and v = V(omega)^-1 t."""
    w = math.atan2(P[o + 1, o], P[o, o])
    if w <= -math.pi:
        w = math.pi
    alpha = gk_half_cot_half(w)
    tx, ty = P[o, o + 2], P[o + 1, o + 2]
    u[a] = alpha * tx + 0.5 * w * ty
    u[a + 1] = -0.5 * w * tx + alpha * ty
    u[a + 2] = w


@kernel
def log_so3(P, o, u, a):
    """The rotation vector, angle in [0, pi]: (theta / sin theta) vee(R) up to pi/2, past it the axis from the
    symmetric part's largest diagonal entry with the sign of vee(R)."""
    w0 = 0.5 * (P[o + 2, o + 1] - P[o + 1, o + 2])
    w1 = 0.5 * (P[o, o + 2] - P[o + 2, o])
    w2 = 0.5 * (P[o + 1, o] - P[o, o + 1])
    s = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    ct = 0.5 * (P[o, o] + P[o + 1, o + 1] + P[o + 2, o + 2] - 1.0)
    theta = math.atan2(s, ct)
    if ct >= 0.0:
        f = gk_t_over_sin(theta)
        u[a] = f * w0
        u[a + 1] = f * w1
        u[a + 2] = f * w2
        return
    k = 0
    dk = P[o, o] - ct
    for i in range(1, 3):
        if P[o + i, o + i] - ct > dk:
            k = i
            dk = P[o + i, o + i] - ct
    denom = math.sqrt(max(dk * (1.0 - ct), GK_TINY))
    for i in range(3):
        col = 0.5 * (P[o + i, o + k] + P[o + k, o + i]) - (ct if i == k else 0.0)
        u[a + i] = col / denom
    dot = u[a] * w0 + u[a + 1] * w1 + u[a + 2] * w2
    f = -theta if dot < 0.0 else theta
    for i in range(3):
        u[a + i] *= f


@kernel
def log_se3(P, o, u, a):
    """(v, omega): omega = log R, v = J_l(omega)^-1 t."""
    log_so3(P, o, u, a + 3)
    J = np.zeros((3, 3))
    jlinv_so3(u, a + 3, 1.0, J, 0)
    for i in range(3):
        u[a + i] = J[i, 0] * P[o, o + 3] + J[i, 1] * P[o + 1, o + 3] + J[i, 2] * P[o + 2, o + 3]


# -- the inverses of the left Jacobians, J_l^-1(s u) --------------------------------------------------------------
@kernel
def jlinv_identity(m, J, a):
    for i in range(m):
        J[a + i, a + i] = 1.0


@kernel
def jlinv_se2(u, a, s, J, b):
    """[[V^-1, -V^-1 c], [0, 1]] at xi = s u, c the third column of J_l (b: the block's row and column)."""
    vx, vy, w = s * u[a], s * u[a + 1], s * u[a + 2]
    P = gk_one_minus_cos_t2(w)
    Q = w * gk_t_minus_sin_t3(w)
    c0 = P * vy + Q * vx
    c1 = -P * vx + Q * vy
    alpha = gk_half_cot_half(w)
    J[b, b] = alpha
    J[b, b + 1] = 0.5 * w
    J[b + 1, b] = -0.5 * w
    J[b + 1, b + 1] = alpha
    J[b, b + 2] = -(alpha * c0 + 0.5 * w * c1)
    J[b + 1, b + 2] = -(-0.5 * w * c0 + alpha * c1)
    J[b + 2, b] = 0.0
    J[b + 2, b + 1] = 0.0
    J[b + 2, b + 2] = 1.0


@kernel
def jlinv_so3(u, a, s, J, b):
    """(theta/2) cot(theta/2) I - v^/2 + D v v^T at v = s u."""
    x, y, z = s * u[a], s * u[a + 1], s * u[a + 2]
    theta = math.sqrt(x * x + y * y + z * z)
    alpha = gk_half_cot_half(theta)
    D = gk_jinv_d(theta)
    v0, v1, v2 = x, y, z
    J[b, b] = alpha + D * v0 * v0
    J[b, b + 1] = 0.5 * v2 + D * v0 * v1
    J[b, b + 2] = -0.5 * v1 + D * v0 * v2
    J[b + 1, b] = -0.5 * v2 + D * v1 * v0
    J[b + 1, b + 1] = alpha + D * v1 * v1
    J[b + 1, b + 2] = 0.5 * v0 + D * v1 * v2
    J[b + 2, b] = 0.5 * v1 + D * v2 * v0
    J[b + 2, b + 1] = -0.5 * v0 + D * v2 * v1
    J[b + 2, b + 2] = alpha + D * v2 * v2


@kernel
def gk_hat(v0, v1, v2, W):
    W[0, 0] = 0.0
    W[0, 1] = -v2
    W[0, 2] = v1
    W[1, 0] = v2
    W[1, 1] = 0.0
    W[1, 2] = -v0
    W[2, 0] = -v1
    W[2, 1] = v0
    W[2, 2] = 0.0


@kernel
def gk_mul3(A, B, C):
    for i in range(3):
        for j in range(3):
            C[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@kernel
def gk_matmul(A, B, C):
    """C = A B for square matrices (C apart from A and B)."""
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += A[i, k] * B[k, j]
            C[i, j] = s


@kernel
def jlinv_se3(u, a, s, J, b):
    """[[J^-1, -J^-1 Q J^-1], [0, J^-1]] at xi = s u = (v, omega): J the SO(3) Jacobian of omega, Q Barfoot's."""
    W = np.empty((3, 3))
    V = np.empty((3, 3))
    gk_hat(s * u[a + 3], s * u[a + 4], s * u[a + 5], W)
    gk_hat(s * u[a], s * u[a + 1], s * u[a + 2], V)
    theta = math.sqrt(u[a + 3] ** 2 + u[a + 4] ** 2 + u[a + 5] ** 2)
    WV = np.empty((3, 3))
    VW = np.empty((3, 3))
    WVW = np.empty((3, 3))
    WW = np.empty((3, 3))
    T = np.empty((3, 3))
    gk_mul3(W, V, WV)
    gk_mul3(V, W, VW)
    gk_mul3(WV, W, WVW)
    gk_mul3(W, W, WW)
    c1 = gk_t_minus_sin_t3(theta)
    c2 = gk_se3_c2(theta)
    c3 = gk_se3_c3(theta)
    Q = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            Q[i, j] = 0.5 * V[i, j] + c1 * (WV[i, j] + VW[i, j] + WVW[i, j])
    gk_mul3(WW, V, T)
    for i in range(3):
        for j in range(3):
            Q[i, j] += c2 * (T[i, j] - 3.0 * WVW[i, j])
    gk_mul3(V, WW, T)
    for i in range(3):
        for j in range(3):
            Q[i, j] += c2 * T[i, j]
    gk_mul3(WVW, W, T)
    for i in range(3):
        for j in range(3):
            Q[i, j] += c3 * T[i, j]
    gk_mul3(W, WVW, T)
    for i in range(3):
        for j in range(3):
            Q[i, j] += c3 * T[i, j]
    Ji = np.zeros((3, 3))
    jlinv_so3(u, a + 3, s, Ji, 0)
    gk_mul3(Ji, Q, T)
    gk_mul3(T, Ji, Q)
    for i in range(3):
        for j in range(3):
            J[b + i, b + j] = Ji[i, j]
            J[b + 3 + i, b + 3 + j] = Ji[i, j]
            J[b + i, b + 3 + j] = -Q[i, j]
            J[b + 3 + i, b + j] = 0.0
