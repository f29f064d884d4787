"""Every nonholonomic example against a route that shares no code with geomech's derivations.

The reference is the Lagrange-d'Alembert system written here from the Lagrangian and the constraint one-forms
alone: the Euler-Lagrange expressions come from sympy's time derivatives of L(q(t), q'(t)), the differentiated
constraints from d/dt [A(q(t)) q'(t)], and the accelerations and multipliers from one linear solve,

    M q'' + (d/dt dL/dq' - dL/dq)|_{q''=0} = A^T lambda + B tau,    A q'' + (d/dt A) q' = 0.

Checked against it, at random states on D: the exported symbolic multipliers, accelerations and the short
multipliers on D of :func:`lagrange_dalembert`; the flow of the almost-Poisson bracket on FL(D); Theorem 1.1 (the
reduced Hamilton equations) and the Lagrangian BKMM reduction, the reduced coordinates (r, p~_r, p) being
computed here from (q, q') with the horizontal lift solved numerically and differentiated along the flow by a
complex step. The Jacobiator of the almost-Poisson bracket is evaluated here from its tensor and set against
the Frobenius test of D computed from A alone.
"""

from itertools import combinations

import numpy as np
import pytest
import sympy as sp

from geomech.reduction import bkmm_reduction, lagrange_dalembert
from geomech.reduction.almost_poisson import almost_poisson, poisson_reduction
from geomech.systems.nonholonomic_examples import EXAMPLES

#: Derivations of more than ~5 s (the symbolic multipliers of the roller racer and the ball: 15-30 s).
SLOW = {"roller_racer", "chaplygin_ball", "simplified_bicycle"}
#: Examples whose D is integrable (the geared body); every other example is genuinely nonholonomic.
INTEGRABLE = {"geared_body", "geared_body_scaled"}
CASES = [(name, {}) for name in EXAMPLES] + [("geared_body", {"scaled": True})]
STEP = 1e-30  # complex step: derivatives to round-off, no subtraction


def _id(name, kw):
    return name + ("_scaled" if kw else "")


def _cases(slow=frozenset()):
    return [
        pytest.param(n, kw, id=_id(n, kw), marks=[pytest.mark.slow] if _id(n, kw) in slow else []) for n, kw in CASES
    ]


def _system(name, kw, rng):
    s = EXAMPLES[name](**kw)
    return s.with_parameters(**{p.name: float(rng.uniform(0.6, 1.4)) for p in s.parameter_symbols})


def _lambdify(args, expr):
    """numpy function of ``args`` (complex arguments allowed) returning a float or complex array."""
    f = sp.lambdify(args, expr, "numpy", cse=True)
    shape = sp.Matrix(expr).shape if isinstance(expr, sp.MatrixBase) else None

    def call(*values):
        out = np.asarray(f(*values))
        if shape is not None:
            out = np.broadcast_to(out, shape) if out.ndim == 0 else out.reshape(shape)
        return out

    return call


def _lambdify_sum(args, matrix):
    """Like :func:`_lambdify` for long expanded sums (the roller racer's multipliers have ~10^5 terms): the terms
    are compiled as one flat list and added in numpy (a sum compiled as one expression nests too deep for
    Python's compiler)."""
    matrix = sp.Matrix(matrix)
    terms, owner = [], []
    for i, e in enumerate(matrix):
        parts = sp.Add.make_args(e)
        terms += parts
        owner += [i] * len(parts)
    f = sp.lambdify(args, terms, "numpy")
    owner = np.array(owner)

    def call(*values):
        vals = np.array([complex(v) if np.iscomplexobj(v) else float(v) for v in f(*values)])
        return np.bincount(owner, weights=vals, minlength=len(matrix)).reshape(matrix.shape)

    return call


class Reference:
    """Lagrange-d'Alembert equations of ``system`` from its Lagrangian and constraint matrix only."""

    def __init__(self, system):
        s = self.system = system
        pv = s.parameter_values()
        t = sp.Symbol("t", real=True)
        n = s.n
        fq = [sp.Function(f"Q{i}")(t) for i in range(n)]
        acc = sp.symbols(f"a0:{n}", real=True)
        # Second derivatives first in the dict: xreplace matches the outermost node.
        back = {f.diff(t, 2): a for f, a in zip(fq, acc)}
        back.update({f.diff(t): v for f, v in zip(fq, s.qdot)})
        back.update(dict(zip(fq, s.q)))
        fwd = {q: f for q, f in zip(s.q, fq)}
        fwd.update({v: f.diff(t) for v, f in zip(s.qdot, fq)})
        L = s.lagrangian.subs(pv).xreplace(fwd)
        el = sp.Matrix([sp.diff(sp.diff(L, f.diff(t)), t) - sp.diff(L, f) for f in fq]).xreplace(back)
        cons = (s.constraint_matrix.subs(pv).xreplace(fwd) * sp.Matrix([f.diff(t) for f in fq])).diff(t).xreplace(back)
        zero = {a: 0 for a in acc}
        x = list(s.q) + list(s.qdot)
        self._M = _lambdify(x, el.jacobian(acc))
        self._rest = _lambdify(x, el.subs(zero))
        self._A = _lambdify(list(s.q), cons.jacobian(acc))
        self._drift = _lambdify(x, cons.subs(zero))
        energy = sum(v * sp.diff(s.lagrangian, v) for v in s.qdot) - s.lagrangian
        self._E = _lambdify(x, energy.subs(pv))

    def M(self, q):
        return self._M(*q, *np.zeros_like(q))

    def A(self, q):
        return self._A(*q).reshape(self.system.c, self.system.n)

    def energy(self, q, qd):
        return float(self._E(*q, *qd))

    def solve(self, q, qd, tau=None):
        """``(qddot, lambda)``."""
        s = self.system
        n, c = s.n, s.c
        rhs = -self._rest(*q, *qd).reshape(n).astype(np.result_type(q, qd, float))
        if tau is not None:
            rhs = rhs + np.r_[np.zeros(s.k), tau]
        A = self.A(q)
        K = np.block([[self.M(q), -A.T], [A, np.zeros((c, c))]])
        sol = np.linalg.solve(K, np.r_[rhs, -self._drift(*q, *qd).reshape(c)])
        return sol[:n], sol[n:]

    def random_state(self, rng):
        """Coordinates of size 0.3-1.2 with random signs (away from the 3-1-3 chart's gimbal lock at theta = 0
        and from the steering singularity at pi/2), and a random velocity in D (null space of A by SVD)."""
        s = self.system
        q = rng.choice([-1.0, 1.0], s.n) * rng.uniform(0.3, 1.2, s.n)
        _, _, vt = np.linalg.svd(self.A(q))
        qd = vt[s.c :].T @ rng.uniform(-1.0, 1.0, s.n - s.c)
        assert np.abs(self.A(q) @ qd).max() < 1e-13
        return q, qd


def _se2_rates(theta):
    """Coordinate rates (x', y', theta') of the SE(2) body velocity (v_x, v_y, omega) at heading theta, written
    here (left action: x' + i y' = e^{i theta}(v_x + i v_y))."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0 * c], [s, c, 0 * c], [0 * c, 0 * c, 1 + 0 * c]])


def _check_group(s):
    assert s.group.name == "SE(2)" and s.k == 3  # every example: _se2_rates applies, heading third


class ReducedCoordinates:
    """(r, p~_r, p), the body velocity xi, as functions of (q, q') built from the BKMM basis e_i(r) (a choice
    the reduction is conditioned on, not a result), the kinetic metric and A only: p_i = <M q', (e_i)_Q>,
    p~_alpha = <M q', h_alpha> with h_alpha in D, shape part the unit vector, M-orthogonal to every (e_i)_Q."""

    def __init__(self, ref, red):
        self.ref, s = ref, ref.system
        _check_group(s)
        self.m = red.m
        self._E = _lambdify(list(s.shape), sp.Matrix(red.basis).subs(s.parameter_values()))

    def vertical(self, q):
        s = self.ref.system
        E = self._E(*q[s.k :]).reshape(s.k, self.m)
        return np.vstack([_se2_rates(q[2]) @ E, np.zeros((s.sigma, self.m), dtype=E.dtype)])

    def horizontal(self, q):
        s, ref = self.ref.system, self.ref
        V, M, A = self.vertical(q), ref.M(q), ref.A(q)
        K = np.vstack([A, np.hstack([np.zeros((s.sigma, s.k)), np.eye(s.sigma)]), V.T @ M])
        rhs = np.vstack([np.zeros((s.c, s.sigma)), np.eye(s.sigma), np.zeros((self.m, s.sigma))])
        return np.linalg.solve(K, rhs)

    def z(self, q, qd):
        s = self.ref.system
        Mqd = self.ref.M(q) @ qd
        return np.r_[q[s.k :], self.horizontal(q).T @ Mqd, self.vertical(q).T @ Mqd]

    @staticmethod
    def xi(q, qd):
        return np.linalg.solve(_se2_rates(q[2]), qd[:3])


def _along_flow(fun, q, qd, qdd):
    """d/dt fun(q(t), q'(t)) at t = 0 along q(t) = q + t q' + t^2/2 q'' (exact: complex step)."""
    h = STEP
    return np.imag(fun(q + 1j * h * qd - h * h / 2 * qdd, qd + 1j * h * qdd)) / h


#: The problem's scale: Reference.random_state draws coordinates of size 0.3-1.2 and velocities in [-1, 1], and
#: the parameters are of order 1, so every compared quantity (velocities, momenta, accelerations, multipliers)
#: is of order 1 where it is not zero. A quantity that is zero (the rolling disk's p-tilde rate) is compared
#: at this scale, not at its own round-off (-4.4e-17 once set a tolerance of 4e-26, and the outcome depended on
#: the BLAS build).
PROBLEM_SCALE = 1.0


def _assert_close(actual, desired, rtol=1e-9, what="", scale=None):
    """Equal to ``rtol`` relative to ``scale``: the larger of the problem's scale and the largest entry of
    ``desired`` (never a value that is zero up to round-off)."""
    actual, desired = np.asarray(actual, dtype=float), np.asarray(desired, dtype=float)
    scale = max(np.abs(desired).max(initial=0.0), PROBLEM_SCALE) if scale is None else scale
    np.testing.assert_allclose(actual, desired, rtol=rtol, atol=rtol * scale, err_msg=what)


# --------------------------------------------------------------------------------------------------
# 0. The reference itself can tell a wrong answer
# --------------------------------------------------------------------------------------------------
def test_reference_finds_the_chaplygin_sleigh_by_hand(rng):
    """Sleigh: v' = a w^2, w' = -m a v w / (I_c + m a^2), lateral force lambda = m v w I_c / (I_c + m a^2)."""
    s = _system("chaplygin_sleigh", {}, rng)
    pv = {p.name: v for p, v in s.parameter_values().items()}
    m, a, Ic = pv["m"], pv["a"], pv["I_c"]
    ref = Reference(s)
    q, qd = ref.random_state(rng)
    th = q[2]
    v, w = np.cos(th) * qd[0] + np.sin(th) * qd[1], qd[2]
    qdd, lam = ref.solve(q, qd)
    vdot = np.cos(th) * qdd[0] + np.sin(th) * qdd[1] + w * (-np.sin(th) * qd[0] + np.cos(th) * qd[1])
    _assert_close([vdot, qdd[2]], [a * w * w, -m * a * v * w / (Ic + m * a * a)])
    _assert_close(lam, [m * v * w * Ic / (Ic + m * a * a)])


# --------------------------------------------------------------------------------------------------
# 1. Symbolic multipliers and accelerations
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, kw", _cases(SLOW))
def test_symbolic_multipliers_and_accelerations_against_the_reference(name, kw, rng):
    s = _system(name, kw, rng)
    lda, ref = lagrange_dalembert(s), Reference(s)
    pv = s.parameter_values()
    args = list(s.q) + list(s.qdot) + list(lda.tau) + list(pv)
    lam_fn = _lambdify_sum(args, lda.multipliers)
    acc_fn = _lambdify_sum(args, lda.accelerations)
    for _ in range(3):
        q, qd = ref.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, s.sigma)
        qdd, lam = ref.solve(q, qd, tau)
        x = [*q, *qd, *tau, *pv.values()]
        _assert_close(acc_fn(*x).ravel(), qdd, what=f"{s.name}: accelerations")
        _assert_close(lam_fn(*x).ravel(), lam, what=f"{s.name}: multipliers")
        assert np.abs(lam).max() > 1e-3  # the constraints push: the comparison is not 0 = 0


#: multipliers_on_distribution simplifies the substituted multipliers: minutes for these.
#: The heaviest derivations of the multipliers on D (1-20 s each): marked slow.
SLOW_ON_D = SLOW | {"snakeboard"}


@pytest.mark.parametrize("name, kw", _cases(SLOW_ON_D))
def test_multipliers_on_the_distribution_against_the_reference(name, kw, rng):
    """lambda(q, r', p, tau) with p computed here as <M q', (e_i)_Q>."""
    s = _system(name, kw, rng)
    lda, red, ref = lagrange_dalembert(s), bkmm_reduction(s), Reference(s)
    pv = s.parameter_values()
    args = list(s.q) + list(s.shape_dot) + list(red.p) + list(lda.tau) + list(pv)
    short = sp.Matrix(lda.multipliers_on_distribution())
    assert not short.free_symbols & set(s.qdot[: s.k])
    fn = _lambdify(args, short)
    rc = ReducedCoordinates(ref, red)
    for _ in range(3):
        q, qd = ref.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, s.sigma)
        p = rc.vertical(q).T @ ref.M(q) @ qd
        _assert_close(
            fn(*q, *qd[s.k :], *p, *tau, *pv.values()).ravel(),
            ref.solve(q, qd, tau)[1],
            what=f"{s.name}: multipliers on D",
        )


# --------------------------------------------------------------------------------------------------
# 2. The almost-Poisson bracket: its flow, its Jacobiator
# --------------------------------------------------------------------------------------------------
def _complex_jacobian(fun, z):
    """d fun / d z^l for every l (complex step), stacked last: shape fun(z).shape + (len(z),)."""
    cols = []
    for l in range(len(z)):
        dz = np.zeros(len(z), dtype=complex)
        dz[l] = 1j * STEP
        cols.append(np.imag(fun(z + dz)) / STEP)
    return np.stack(cols, -1)


def _jacobiator(J, dJ, i, j, k):
    """{z^i, {z^j, z^k}} + cyclic = J^{il} d_l J^{jk} + J^{jl} d_l J^{ki} + J^{kl} d_l J^{ij}."""
    return J[i] @ dJ[j, k] + J[j] @ dJ[k, i] + J[k] @ dJ[i, j]


def _frobenius_defect(s, ref, rng, points=2):
    """max |A [X_a, X_b]| over pairs of a basis of D = ker A found here (sympy null space), at random q."""
    A = sp.Matrix(s.constraint_matrix).subs(s.parameter_values())
    X = A.nullspace()
    q = list(s.q)
    brackets = [A * (X[b].jacobian(q) * X[a] - X[a].jacobian(q) * X[b]) for a, b in combinations(range(len(X)), 2)]
    fn = _lambdify(q, sp.Matrix.hstack(*brackets))
    return max(float(np.abs(fn(*ref.random_state(rng)[0])).max()) for _ in range(points))


@pytest.mark.parametrize("name, kw", _cases(SLOW))
def test_almost_poisson_flow_is_the_reference_flow(name, kw, rng):
    """z' = J_M grad H_M at z = (q, X^T M q') is (q', d/dt X^T M q') along the reference flow, and p(z) = M q'."""
    s = _system(name, kw, rng)
    ap, ref = almost_poisson(s), Reference(s)
    X = _lambdify(list(s.q), sp.Matrix(ap.X).subs(s.parameter_values()))
    f = ap.numeric()
    for _ in range(2):
        q, qd = ref.random_state(rng)
        Xq = X(*q)
        assert np.abs(ref.A(q) @ Xq).max() < 1e-12 and np.linalg.matrix_rank(Xq) == s.n - s.c  # a basis of D
        qdd, _ = ref.solve(q, qd)
        pt = Xq.T @ ref.M(q) @ qd
        z = np.r_[q, pt]
        zdot = f["J"](z) @ f["gradH"](z)[:, 0]
        _assert_close(zdot[: s.n], qd, what=f"{s.name}: q'")
        _assert_close(zdot[s.n :], _along_flow(lambda a, b: X(*a).T @ ref.M(a) @ b, q, qd, qdd), what=f"{s.name}: pt'")
        _assert_close(f["p"](z)[:, 0], ref.M(q) @ qd, what=f"{s.name}: FL")


@pytest.mark.parametrize("name, kw", _cases(SLOW))
def test_jacobiator_vanishes_exactly_when_the_constraints_are_integrable(name, kw, rng):
    """Frobenius from A alone decides integrability; the Jacobiator of J_M, evaluated here by complex-step
    derivatives of the tensor, is non-zero for every non-integrable example (kinematic car and Chaplygin ball
    included) and zero for the geared body; where non-zero it equals the curvature formula; satisfies_jacobi
    agrees."""
    s = _system(name, kw, rng)
    integrable = _id(name, kw) in INTEGRABLE
    ref = Reference(s)
    defect = _frobenius_defect(s, ref, rng)
    assert (defect < 1e-12) if integrable else (defect > 1e-2)
    ap = almost_poisson(s)
    pv = s.parameter_values()
    J = _lambdify(ap.z, sp.Matrix(ap.tensor).subs(pv))
    keys = list(ap.jacobiator_curvature)
    curv = _lambdify(ap.z, sp.Matrix([ap.jacobiator_curvature[key] for key in keys]).subs(pv))
    worst = 0.0
    for _ in range(2):
        q, _ = ref.random_state(rng)
        z = np.r_[q, rng.uniform(-1.0, 1.0, len(ap.pt))]
        Jz, dJ = np.real(J(*z)), _complex_jacobian(lambda w: J(*w), z)
        N = len(z)
        jac = np.array([_jacobiator(Jz, dJ, i, j, k) for i, j, k in combinations(range(N), 3)])
        scale = np.abs(Jz).max() * np.abs(dJ).max()  # the size of one term of a Jacobiator
        worst = max(worst, np.abs(jac).max() / scale)
        # the curvature formula gives every Jacobiator of coordinate functions that can be non-zero
        listed = np.array([_jacobiator(Jz, dJ, *key) for key in keys])
        np.testing.assert_allclose(
            listed, curv(*z).ravel(), rtol=1e-9, atol=1e-11 * scale, err_msg=f"{s.name}: Jacobiator"
        )
        others = [_jacobiator(Jz, dJ, *key) for key in combinations(range(N), 3) if key not in set(keys)]
        assert np.abs(others).max(initial=0.0) < 1e-11 * scale
    if integrable:
        assert worst < 1e-12 and ap.satisfies_jacobi
    else:
        assert worst > 1e-3 and not ap.satisfies_jacobi


# --------------------------------------------------------------------------------------------------
# 3. Theorems 1.1 and 1.2 against the reference flow
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, kw", _cases(SLOW))
def test_reduced_hamilton_and_lagrange_equations_follow_the_reference_flow(name, kw, rng):
    """At a random state on D with random shape forces: Theorem 1.1's (r', p~_r', p') + (0, tau, 0) and its
    reconstruction xi, and the Lagrangian reduction's p', r'' and xi (eqs. 1.1-1.3) and the reduced Legendre
    transform p~_r = M(r) r' (Theorem 1.2), all equal the rates computed here along the reference flow; and the
    difference of the two reductions (``lagrangian_form``) vanishes there."""
    s = _system(name, kw, rng)
    red, pr, ref = bkmm_reduction(s), poisson_reduction(s), Reference(s)
    rc = ReducedCoordinates(ref, red)
    pv = s.parameter_values()
    sig, m = s.sigma, red.m
    zdot_fn = pr.numeric()["zdot"]
    recon = _lambdify(pr.z, sp.Matrix(pr.reconstruction).subs(pv))
    lf_syms = list(red.r) + list(red.rdot) + list(red.p)
    lf = _lambdify(lf_syms, sp.Matrix(pr.lagrangian_form()).subs(pv))
    rn = red.numeric()
    for _ in range(3):
        q, qd = ref.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, sig)
        qdd, _ = ref.solve(q, qd, tau)
        z = rc.z(q, qd)
        zdot = _along_flow(rc.z, q, qd, qdd)
        r, rd, ptr, p = q[s.k :], qd[s.k :], z[sig : 2 * sig], z[2 * sig :]
        # Theorem 1.1
        scale = np.abs(zdot).max()  # p' may vanish identically (the ball's spin momentum is conserved)
        _assert_close(zdot_fn(z)[:, 0] + np.r_[np.zeros(sig), tau, np.zeros(m)], zdot, what=f"{s.name}: Thm 1.1")
        _assert_close(recon(*z).ravel(), rc.xi(q, qd), what=f"{s.name}: Thm 1.1 reconstruction")
        # the Lagrangian reduction, eqs. (1.1)-(1.3), and the reduced Legendre transform
        _assert_close(rn.momentum(q, qd), p, what=f"{s.name}: momentum")
        _assert_close(rn.xi(r, rd, p), rc.xi(q, qd), what=f"{s.name}: eq. 1.1")
        _assert_close(rn.pdot(r, rd, p), zdot[2 * sig :], what=f"{s.name}: eq. 1.2", scale=scale)
        _assert_close(rn.rddot(r, rd, p, tau), qdd[s.k :], what=f"{s.name}: eq. 1.3")
        _assert_close(rn.shape_mass(r) @ rd, ptr, what=f"{s.name}: Legendre")
        # Theorem 1.2: the two reductions coincide
        assert np.abs(lf(*r, *rd, *p)).max(initial=0.0) < 1e-9 * max(1.0, scale)
        assert scale > 1e-2
