"""Methods for canonical systems: convergence orders on the reduced closed loop, the free body through its
reduction, the seed's generating-function method, bounded energy error of the symplectic methods."""

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.integrators.methods import REGISTRY, Kind
from geomech.integrators.solve import solve

Y0 = np.array([0.3, 0.2])
T = 4.0

# (key, numbers of steps over [0, T]) chosen so that the errors lie between ~1e-3 and the round-off floor
ORDER_CASES = [
    ("rk4", [10, 20, 40, 80, 160]),
    ("abm4", [160, 240, 320, 480, 640]),  # the h^5 part of its error is large: asymptotic later
    ("symplectic_euler", [20, 40, 80, 160, 320]),
    ("symplectic_euler_b", [20, 40, 80, 160, 320]),
    ("implicit_midpoint", [20, 40, 80, 160, 320]),
    ("generating_function", [20, 40, 80, 160, 320]),
    ("gauss_legendre_1", [20, 40, 80, 160, 320]),
    ("gauss_legendre_2", [10, 20, 40, 80, 160]),
    ("gauss_legendre_3", [5, 7, 10, 14, 20]),
]


@pytest.fixture(scope="module")
def reference(closed_loop_reduced):
    sol = solve_ivp(
        lambda t, y: closed_loop_reduced.vector_field(y), (0, T), Y0, method="DOP853", rtol=1e-13, atol=1e-14
    )
    return sol.y[:, -1]


def test_test_model_is_the_reduction_of_the_closed_loop(closed_loop, closed_loop_reduced, rng):
    # the formula typed in conftest against the library's own Serret-Andoyer reduction of H_c
    red = gm.GeneralizedSerretAndoyer(closed_loop).reduced_system(1.0)
    y = np.column_stack([rng.uniform(-3, 3, 20), rng.uniform(-0.9, 0.9, 20)])
    np.testing.assert_allclose(red.hamiltonian(y), closed_loop_reduced.hamiltonian(y), rtol=1e-13, atol=1e-14)


@pytest.mark.parametrize("key, steps", ORDER_CASES, ids=[c[0] for c in ORDER_CASES])
def test_convergence_order(key, steps, closed_loop_reduced, reference, fitted_order):
    method = REGISTRY[key]
    errors = [
        np.abs(solve(closed_loop_reduced, method, y0=Y0, h=T / n, t_final=T, saveat=2).states[-1] - reference).max()
        for n in steps
    ]
    order = fitted_order(T / np.array(steps), errors)
    assert abs(order - method.order) < 0.2, (key, order, errors)


def test_stormer_verlet_order_on_a_separable_problem(pendulum, fitted_order):
    y0, t1 = np.array([1.2, 0.3]), 5.0
    ref = solve_ivp(lambda t, y: pendulum.vector_field(y), (0, t1), y0, method="DOP853", rtol=1e-13, atol=1e-14)
    ref = ref.y[:, -1]
    steps = np.array([20, 40, 80, 160, 320])
    errors = [
        np.abs(solve(pendulum, "stormer_verlet", y0=y0, h=t1 / n, t_final=t1).states[-1] - ref).max() for n in steps
    ]
    assert abs(fitted_order(t1 / steps, errors) - 2) < 0.2


def test_generating_function_h2_term_solves_hamilton_jacobi():
    """The map q = dS/dp, P = dS/dQ with S = p Q - h H(Q, p) + h^2/2 H_q H_p (Q, p) agrees with the exact
    flow to O(h^3) (Taylor series of the flow), and without the h^2 term only to O(h^2)."""
    q, p, h, Q, c1, c2 = sp.symbols("q p h Q c1 c2")
    H = q**2 * p + p**3 / 3 + q**3 + q * p**2 / 2 + q**2 * p**2
    Hq, Hp = sp.diff(H, q), sp.diff(H, p)

    def lie(F):
        return sp.diff(F, q) * Hp - sp.diff(F, p) * Hq

    exact_q = q + h * lie(q) + h**2 / 2 * lie(lie(q))
    exact_p = p + h * lie(p) + h**2 / 2 * lie(lie(p))
    residues = []
    for S in (p * Q - h * H.subs(q, Q) + h**2 / 2 * (Hq * Hp).subs(q, Q), p * Q - h * H.subs(q, Q)):
        trial = q + c1 * h + c2 * h**2
        eq = sp.expand((sp.diff(S, p) - q).subs(Q, trial).series(h, 0, 3).removeO())
        sol = sp.solve([eq.coeff(h, 1), eq.coeff(h, 2)], [c1, c2], dict=True)[0]
        new_q = trial.subs(sol)
        new_p = sp.expand(sp.diff(S, Q).subs(Q, new_q).series(h, 0, 3).removeO())
        residues.append((sp.expand(new_q - exact_q), sp.expand(new_p - exact_p)))
    assert residues[0] == (0, 0)
    assert residues[1][0] != 0 and residues[1][1] != 0


def test_generating_function_h2_term_derived_from_the_hamilton_jacobi_equation():
    """Derive the h^2 term: S(p, Q, h) = p.Q + h S1 + h^2 S2 generates the time-h flow (q = S_p, P = S_Q) iff
    dS/dh = -H(Q, S_Q); matching powers of h gives S1 = -H and S2 = -(1/2) H_p . dS1/dQ = (1/2) H_q . H_p,
    the W / 2 that the compiled kernels use. Two degrees of freedom, a generic cubic H."""
    n = 2
    Q = sp.symbols("Q1:3")
    p = sp.symbols("p1:3")
    h = sp.Symbol("h")
    variables = list(Q) + list(p)
    monomials = sorted(sp.itermonomials(variables, 3), key=sp.default_sort_key)
    coeffs = sp.symbols(f"a0:{len(monomials)}")
    H = sum(a * mono for a, mono in zip(coeffs, monomials))
    S1f = [sp.Function(f"S{k}")(*variables) for k in (1, 2)]
    S = sum(Q[i] * p[i] for i in range(n)) + h * S1f[0] + h**2 * S1f[1]
    P = [sp.diff(S, Qi) for Qi in Q]
    hj = sp.diff(S, h) + H.subs(dict(zip(p, P)), simultaneous=True)
    series = sp.expand(sp.series(hj, h, 0, 2).removeO())
    S1 = sp.solve(series.coeff(h, 0), S1f[0])[0]
    S2 = sp.solve(series.coeff(h, 1).subs(S1f[0], S1).doit(), S1f[1])[0]
    assert sp.expand(S1 + H) == 0
    g = [sp.diff(H, v) for v in variables]
    W = sum(g[i] * g[n + i] for i in range(n))  # as in geomech.integrators._problem's "gf" model functions
    assert sp.expand(S2 - W / 2) == 0


def test_generating_function_method_is_not_the_midpoint_rule(closed_loop_reduced):
    diffs = []
    for h in (0.1, 0.05):
        gf = solve(closed_loop_reduced, "generating_function", y0=Y0, h=h, t_final=h).states[-1]
        mp = solve(closed_loop_reduced, "implicit_midpoint", y0=Y0, h=h, t_final=h).states[-1]
        diffs.append(np.abs(gf - mp).max())
    # both are second order, so one step differs at O(h^3), far above round-off
    assert diffs[0] > 1e-6
    assert 2**3 * 0.8 < diffs[0] / diffs[1] < 2**3 * 1.2
    # the midpoint rule is symmetric (a step back undoes a step), the generating-function method is not:
    # there the step back misses by O(h^4) (the h^3 local errors of the two steps cancel)
    for key, symmetric in (("implicit_midpoint", True), ("generating_function", False)):
        gaps = []
        for h in (0.2, 0.1):
            forward = solve(closed_loop_reduced, key, y0=Y0, h=h, t_final=h).states[-1]
            back = solve(closed_loop_reduced, key, y0=forward, h=h, t0=h, t_final=0.0).states[-1]
            gaps.append(np.abs(back - Y0).max())
        if symmetric:
            assert max(gaps) < 1e-14, (key, gaps)
        else:
            assert gaps[0] > 1e-6 and 2**4 * 0.7 < gaps[0] / gaps[1] < 2**4 * 1.3, (key, gaps)
        assert REGISTRY[key].symmetric is symmetric


# (on the Python backend: Taylor's method runs compiled only, tested in tests/integrators/test_taylor.py)
CANONICAL_KEYS = [k for k, m in REGISTRY.items() if m.structure.value in ("any ODE", "canonical") and k != "taylor"]


@pytest.mark.parametrize("key", CANONICAL_KEYS)
def test_agrees_with_the_exact_free_body_through_its_reduction(key, body):
    # on the Python backend: the compiled loops are exercised on the other models, and this keeps the
    # number of loops numba compiles for the suite down
    m0 = np.array([1.0, 0.3, 0.2])
    G = np.linalg.norm(m0)
    chart = gm.SerretAndoyerChart(2)
    red = gm.GeneralizedSerretAndoyer(body).reduced_system(G)
    t1 = 3.0
    exact = body.exact_solution(m0).momentum(t1)
    method = REGISTRY[key]
    n = 100 if method.order < 4 else 20
    errors = []
    for steps in (n, 2 * n):
        # an adaptive method is told its output times (one every t1 / steps), a fixed-step one its step
        times = {"saveat": steps + 1} if method.kind is Kind.ADAPTIVE else {"h": t1 / steps}
        sol = solve(red, method, y0=chart.forward(m0), t_final=t1, backend="python", **times)
        assert sol.stats["backend"] == "python"
        errors.append(np.abs(chart.inverse(sol.states[-1], G) - exact).max())
    tol = {1: 0.1, 2: 1e-3, 4: 1e-6, 5: 1e-7, 6: 1e-8, 8: 1e-8, 10: 1e-8, 12: 1e-5}[method.order]
    assert errors[1] < tol
    if method.kind is Kind.FIXED_STEP and method.order <= 6:  # an adaptive one's error is set by its tolerances
        assert errors[0] / errors[1] > 2**method.order * 0.7


SYMPLECTIC_KEYS = [
    "symplectic_euler",
    "implicit_midpoint",
    "generating_function",
    "gauss_legendre_2",
    "gauss_legendre_3",
]


def _quarters(energy):
    err = np.abs(energy - energy[0])
    q = len(err) // 4
    return err[1:q].max(), err[-q:].max()


@pytest.mark.parametrize("key", SYMPLECTIC_KEYS)
def test_symplectic_energy_error_is_bounded(key, closed_loop_reduced):
    sol = solve(closed_loop_reduced, key, y0=Y0, h=0.1, t_final=2000.0, saveat=2001)
    first, last = _quarters(sol.energy)
    assert last < 1.2 * first + 1e-14, (first, last)


@pytest.mark.parametrize("key", ["rk4", "abm4"])
def test_non_symplectic_energy_error_drifts(key, closed_loop_reduced):
    # the contrast that makes the bounded-error test meaningful: same problem, same step
    sol = solve(closed_loop_reduced, key, y0=Y0, h=0.1, t_final=2000.0, saveat=2001)
    first, last = _quarters(sol.energy)
    assert last > 2.5 * first


# a step for each method at which its energy error (1e-10 to 1e-7 here) is far above round-off, so that a
# drift would show against the 1e-14 allowance instead of hiding in the round-off random walk
LONG_RUN_STEP = {
    "symplectic_euler": 0.01,
    "implicit_midpoint": 0.01,
    "gauss_legendre_1": 0.01,
    "generating_function": 0.01,
    "gauss_legendre_2": 0.1,
    "gauss_legendre_3": 0.4,
}


def test_gauss_legendre_factors_once_a_step_and_keeps_the_energy_at_round_off(closed_loop_reduced):
    """Gauss-Legendre keeps Newton's matrix of the first iterate through a step: at the largest steps of the
    benchmarks (h = 0.8 and 1, s = 6), about two iterations a step. Its energy error over 1e5 steps stays a
    round-off walk (6e-16 and 6e-15 measured) when the iteration runs below the tolerance (stopped by the rate's
    estimate, its leftover drifted the energy to 2e-13 at h = 1) and the step is y_n + h sum b_i f(Y_i) at the
    converged stages (by sum d_i Z_i, d = b^T A^{-1}, the energy drifted linearly to 2e-13 at h = 0.8)."""
    n = 100_000
    for h in (0.8, 1.0):
        sol = solve(closed_loop_reduced, "gauss_legendre_6", y0=Y0, h=h, t_final=n * h, saveat=1001)
        assert sol.stats["n_newton"] < 3.5 * n
        assert np.abs(sol.energy - sol.energy[0]).max() < 5e-14, h


def test_a_composition_stops_each_sub_step_lower_so_that_its_energy_does_not_drift(closed_loop_reduced):
    """The 35 sub-steps of midpoint_s35_10 add their Newton leftovers: stopped as a single step is (a hundredth of
    the tolerance), the energy drifted linearly, 1.1e-13 after these 2e4 steps (6e-13 after 1.25e5); each sub-step
    stopping 35 times lower again, it stays a round-off walk (1.2e-14 measured)."""
    n = 20_000
    sol = solve(closed_loop_reduced, "midpoint_s35_10", y0=Y0, h=0.8, t_final=n * 0.8, saveat=1001)
    assert np.abs(sol.energy - sol.energy[0]).max() < 4e-14


@pytest.mark.slow
@pytest.mark.parametrize("key", SYMPLECTIC_KEYS + ["gauss_legendre_1"])
def test_symplectic_energy_error_is_bounded_over_a_million_steps(key, closed_loop_reduced):
    h = LONG_RUN_STEP[key]
    sol = solve(closed_loop_reduced, key, y0=Y0, h=h, t_final=1_000_000 * h, saveat=10_001)
    first, last = _quarters(sol.energy)
    assert first > 1e-11, first
    assert last < 1.02 * first + 1e-14, (first, last)
    assert np.abs(sol.energy - sol.energy[0]).max() < 10 * h ** REGISTRY[key].order


@pytest.mark.parametrize("s", range(1, 7))
def test_gauss_legendre_eigenbasis_is_that_of_its_pade_denominator(s):
    """A = T diag(lam) T^-1, and lam are the reciprocals of the zeros of the denominator of exp's (s, s) Pade
    approximant, Gauss-Legendre's stability function (an independent route to A's eigenvalues); each complex one
    has its conjugate as partner, with the conjugate eigenvector."""
    from math import factorial

    from geomech.integrators.methods._canonical import _gauss_tableau, gauss_transform

    A = _gauss_tableau(s)[0]
    lam, T, Ti, partner = gauss_transform(A)
    np.testing.assert_allclose(T @ np.diag(lam) @ Ti, A, rtol=0, atol=1e-14)
    # Q(z) = sum_j (2s - j)! s! / ((2s)! j! (s - j)!) (-z)^j; numpy's roots want the highest power first
    q = [
        factorial(2 * s - j) * factorial(s) / (factorial(2 * s) * factorial(j) * factorial(s - j)) * (-1) ** j
        for j in range(s + 1)
    ]
    expected = np.sort_complex(1.0 / np.roots(q[::-1]))
    np.testing.assert_allclose(np.sort_complex(lam), expected, rtol=1e-10)
    solved = [k for k in range(s) if partner[k] > -1.5]
    assert len(solved) == (s + 1) // 2
    for k in solved:
        if partner[k] == -1:
            assert lam[k].imag == 0.0 and np.all(T[:, k].imag == 0.0)
        else:
            other = int(partner[k])
            assert lam[other] == np.conj(lam[k]) and np.all(T[:, other] == np.conj(T[:, k]))


@pytest.mark.parametrize("s", [2, 3, 6])
def test_gauss_legendre_in_the_eigenbasis_is_the_same_collocation(s):
    """With the attitude (12 unknowns a stage: Newton's matrix in A's eigenbasis) and without it (3: the stage
    Jacobians' matrix) Gauss-Legendre solves the same collocation equations for m, which does not depend on R:
    the two m agree to Newton's tolerance, and R stays a rotation carrying the spatial momentum R m."""
    body = gm.RigidBody((3.0, 2.0, 1.0))
    m0 = [1.0, 0.3, 0.2]
    kw = dict(h=0.25, t_final=50.0, saveat=11)
    alone = solve(body, gm.integrators.GaussLegendre(s), m0=m0, **kw)
    with_R = solve(body, gm.integrators.GaussLegendre(s), m0=m0, R0=np.eye(3), **kw)
    np.testing.assert_allclose(with_R.states[:, :3], alone.states, rtol=0, atol=1e-12)
    R = with_R.states[:, 3:].reshape(-1, 3, 3)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), rtol=0, atol=1e-12)
    spatial = np.einsum("nij,nj->ni", R, with_R.states[:, :3])
    np.testing.assert_allclose(spatial, spatial[:1].repeat(len(spatial), 0), rtol=0, atol=1e-12)


@pytest.mark.parametrize("s", [2, 3, 6])
def test_the_eigenbasis_blocks_solve_newtons_system(s):
    """The correction by the blocks I - h lam_k J (the loop's gauss_blocks_solve, run as Python) is
    (I - h A (x) J)^-1 r, numpy's solve of the s d x s d system."""
    from geomech.integrators._k_common import lu_factor
    from geomech.integrators._k_implicit import gauss_blocks_solve
    from geomech.integrators.methods._canonical import _gauss_tableau, gauss_transform

    rng = np.random.default_rng(7)
    d, h = 5, 0.3
    A = _gauss_tableau(s)[0]
    lam, T, Ti, partner = gauss_transform(A)
    Jac = rng.normal(size=(d, d))
    r = rng.normal(size=s * d)
    expected = np.linalg.solve(np.eye(s * d) - h * np.kron(A, Jac), r)
    Cc = np.empty((s, d, d), complex)
    piv = np.empty((s, d), np.int64)
    for k in range(s):
        if partner[k] > -1.5:
            Cc[k] = np.eye(d) - h * lam[k] * Jac
            assert lu_factor(Cc[k], piv[k], d)
    got = r.copy()
    gauss_blocks_solve(Cc, piv, np.empty((s, d), complex), T, Ti, partner, got, s, d)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_a_singular_eigenbasis_block_goes_on_with_the_stage_jacobians(monkeypatch):
    """A block I - h lam_k J of the eigenbasis found singular (here: made to fail once, the loop run as Python)
    does not end the run: that step goes on with Newton's full method on the stage Jacobians, and the run meets
    the one whose blocks all factor."""
    from geomech.integrators import _codegen
    from geomech.integrators._problem import make_problem

    body = gm.RigidBody([3.0, 2.0, 1.0])
    method = gm.integrators.GaussLegendre(3)  # with the attitude, s d = 36: the eigenbasis
    problem = make_problem(body, attitude=True)
    module, used = problem.module(frozenset(method.features & {"gf", "split"}), "python")
    assert used == "python"
    FP = module.addresses(_codegen.model_functions(method.kernel))
    P = np.ascontiguousarray(method.constants(problem), dtype=float)
    Y0 = np.r_[1.0, 0.3, 0.2, np.eye(3).ravel()][None]

    def run():
        OUT, INFO = np.empty((1, 2, 12)), np.zeros((1, 5))
        module.gauss_run(FP, Y0.copy(), 0.1, 4, 4, OUT, INFO, 1e-14, 20, P, problem.prm[None, :])
        return OUT, INFO

    good, info = run()
    assert info[0, 0] == 0
    factor = module.gauss_run.__globals__["lu_factor"]
    failed = []

    def singular_once(M, piv, n):
        if M.dtype == complex and not failed:
            failed.append(n)
            return False
        return factor(M, piv, n)

    monkeypatch.setitem(module.gauss_run.__globals__, "lu_factor", singular_once)
    fallback, info = run()
    assert failed == [12] and info[0, 0] == 0
    np.testing.assert_allclose(fallback, good, rtol=0, atol=1e-12)
