"""The compiled Dormand-Prince pairs: their tableaux and continuous extensions against the order conditions,
runs against the exact free body (at step ends and between them), against scipy's solvers of the same names
(the same arithmetic, another implementation), backwards in time, in batches and threads, on the Python
backend, and their failures (a blow-up at its known time, a spent budget) as data."""

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.integrators import DormandPrince, SolveIVP, Status
from geomech.integrators.methods import embedded_pair

PAIRS = ["DOP853", "DOPRI5"]
M0 = np.array([1.0, 0.3, 0.2])


def _hairer_weights(pair, theta):
    """w_j(theta), the weights of the stages in the continuous extension y(t_n + theta h) = y_n + h w . K,
    from Hairer's nested form (DOP853's CONTD8) or the monomial one (Shampine's DOPRI5)."""
    F = pair.dense  # F_k = h sum_j dense[k, j] K_j
    if pair.alternating:
        s, s1 = theta, 1.0 - theta
        return s * (F[0] + s1 * (F[1] + s * (F[2] + s1 * (F[3] + s * (F[4] + s1 * (F[5] + s * F[6]))))))
    return sum(F[k] * theta ** (k + 1) for k in range(F.shape[0]))


@pytest.mark.parametrize("name", PAIRS)
def test_tableau_and_continuous_extension_satisfy_the_order_conditions(name):
    pair = embedded_pair(name)
    A, b, c, ns = pair.A, pair.b, pair.c, pair.n_stages
    assert np.all(np.triu(A) == 0)
    # the quadrature conditions b . c^k = 1/(k+1), k < order, and one non-bushy tree of order 4 and 5
    for k in range(pair.order):
        assert b @ c[:ns] ** k == pytest.approx(1 / (k + 1), abs=1e-14), k
    Ac = A[:ns, :ns] @ c[:ns]
    assert b @ (c[:ns] * Ac) == pytest.approx(1 / 8, abs=1e-14)
    assert b @ (A[:ns, :ns] @ Ac) == pytest.approx(1 / 24, abs=1e-14)
    # the error weights vanish on constants and do not on the next power (they estimate a real error)
    assert abs(pair.e.sum()) < 1e-14
    assert abs(pair.e @ c[: ns + 1] ** (pair.error_order + 1)) > 1e-6
    # the continuous extension: w(1) = b (it ends on the step), w(0) = 0, and at any theta the
    # conditions w(theta) . c^k = theta^(k+1)/(k+1) up to its order
    np.testing.assert_allclose(_hairer_weights(pair, 1.0)[:ns], b, atol=1e-14)
    assert np.abs(_hairer_weights(pair, 1.0)[ns:]).max() < 1e-14
    for theta in (0.0, 0.17, 0.5, 0.83):
        w = _hairer_weights(pair, theta)
        for k in range(pair.dense_order):
            assert w @ c**k == pytest.approx(theta ** (k + 1) / (k + 1), abs=1e-13), (theta, k)


def test_coefficients_are_scipys_bit_for_bit():
    # geomech keeps the published coefficients itself (a run does not import scipy's integrators): they must be the
    # doubles scipy's solvers of these names use, another transcription of Hairer's and Shampine's decimals
    from scipy.integrate import DOP853, RK45

    p = embedded_pair("DOP853")
    ns = DOP853.n_stages
    assert p.n_stages == ns and p.A.shape == (ns + 1 + DOP853.A_EXTRA.shape[0],) * 2
    assert np.array_equal(p.A[:ns, :ns], DOP853.A) and np.array_equal(p.A[ns, :ns], DOP853.B)
    assert np.array_equal(p.A[ns + 1 :], DOP853.A_EXTRA) and np.array_equal(p.b, DOP853.B)
    assert np.array_equal(p.e, DOP853.E5) and np.array_equal(p.e2, DOP853.E3)
    assert np.array_equal(p.dense[3:], DOP853.D)
    # the row sums are the nodes (entries up to 30 in size: round-off of their sums some 1e-14)
    np.testing.assert_allclose(p.c[: ns + 1], np.r_[DOP853.C, 1.0], rtol=0, atol=1e-13)
    q = embedded_pair("DOPRI5")
    ns = RK45.n_stages
    assert np.array_equal(q.A[:ns, : ns - 1], RK45.A) and np.array_equal(q.b, RK45.B) and np.array_equal(q.e, RK45.E)
    assert np.array_equal(q.dense, np.asarray(RK45.P).T)


@pytest.mark.parametrize("name", PAIRS)
def test_the_exact_free_body_at_step_ends_and_between(name):
    body = gm.RigidBody([3.0, 2.0, 1.0])
    exact = body.exact_solution(M0)
    errors = []
    for tol in (1e-7, 1e-10, 1e-13):
        # 401 output times: most fall between steps, so the continuous extension is what is compared
        sol = gm.solve(body, DormandPrince(name), m0=M0, t_final=50.0, rtol=tol, atol=tol, saveat=401)
        assert sol.status is Status.SUCCESS and sol.stats["backend"] == "numba"
        if tol == 1e-7:
            assert sol.stats["n_internal_steps"] < 200
        errors.append(np.abs(sol.m - exact.momentum(sol.t)).max())
    # the error follows the tolerance (a global error some tens of local tolerances over 50 s)
    assert errors[0] > errors[1] > errors[2]
    assert errors[0] < 1e-4 and errors[1] < 2e-7 and errors[2] < 5e-10


def test_long_runs_keep_the_eighth_order_accuracy():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    sol = gm.solve(body, "dop853", m0=M0, t_final=1000.0, rtol=1e-13, atol=1e-13)
    assert np.abs(sol.m[-1] - body.exact_solution(M0).momentum(1000.0)).max() < 1e-9


@pytest.mark.parametrize("name, solver", [("DOP853", "DOP853"), ("DOPRI5", "RK45")])
def test_same_steps_and_states_as_scipys_solver_of_the_same_name(name, solver):
    body = gm.RigidBody([3.0, 2.0, 1.0])
    for tol in (1e-6, 1e-10):
        mine = gm.solve(body, DormandPrince(name), m0=M0, t_final=20.0, rtol=tol, atol=tol, saveat=41)
        ref = gm.solve(body, SolveIVP(solver), m0=M0, t_final=20.0, rtol=tol, atol=tol, saveat=41)
        assert abs(mine.stats["n_internal_steps"] - ref.stats["n_internal_steps"]) <= 1
        np.testing.assert_allclose(mine.states, ref.states, rtol=0, atol=10 * tol)


def test_backwards_in_time_and_back():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    back = gm.solve(body, "dop853", m0=M0, t_final=-7.0, rtol=1e-12, atol=1e-12, saveat=[0.0, -0.3, -7.0])
    np.testing.assert_allclose(back.t, [0.0, -0.3, -7.0])
    exact = body.exact_solution(M0).momentum(back.t)
    np.testing.assert_allclose(back.m, exact, rtol=0, atol=1e-10)
    forth = gm.solve(body, "dop853", m0=back.m[-1], t0=-7.0, t_final=0.0, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(forth.m[-1], M0, rtol=0, atol=1e-10)


def test_batches_threads_and_the_python_backend_agree():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    rng = np.random.default_rng(7)
    m0 = rng.normal(size=(2, 3, 3))
    R0 = np.broadcast_to(np.eye(3), (2, 3, 3, 3))
    opts = dict(t_final=5.0, rtol=1e-11, atol=1e-11, saveat=11)
    batch = gm.solve(body, "dop853", m0=m0, R0=R0, threads=2, **opts)
    assert batch.states.shape == (2, 3, 11, 12)
    one = gm.solve(body, "dop853", m0=m0[1, 2], R0=np.eye(3), threads=1, **opts)
    np.testing.assert_array_equal(batch.states[1, 2], one.states)  # each row integrated alone: bit for bit
    python = gm.solve(body, "dop853", m0=m0[1, 2], R0=np.eye(3), backend="python", **opts)
    assert python.stats["backend"] == "python"
    np.testing.assert_allclose(python.states, one.states, rtol=0, atol=1e-12)
    # the attitude stays a rotation to the tolerance, and the spatial momentum R m is kept
    R = one.states[-1, 3:].reshape(3, 3)
    assert np.abs(R.T @ R - np.eye(3)).max() < 1e-9
    assert np.abs(R @ one.states[-1, :3] - m0[1, 2]).max() < 1e-9


def test_a_blow_up_is_a_failure_at_its_time_with_the_states_before_it():
    # H = -q p^2 / 2: p' = p^2 / 2, so p = 2 / (2 / p0 - t) blows up at t = 2 / p0 = 2 for p0 = 1
    q, p = sp.symbols("q p", real=True)
    system = gm.CanonicalSystem.from_expression(-q * p**2 / 2, (q,), (p,), name="blow-up")
    sol = gm.solve(system, "dop853", y0=[1.0, 1.0], t_final=3.0, saveat=31, raise_on_failure=False)
    assert sol.status is Status.ADAPTIVE_FAILED
    failure = sol.failures[0]
    assert abs(failure.time - 2.0) < 1e-6 and "singularity" in failure.detail
    before = sol.t < 2.0
    np.testing.assert_allclose(sol.states[before, 1], 2.0 / (2.0 - sol.t[before]), rtol=1e-8)
    assert np.all(np.isnan(sol.states[sol.t > failure.time]))
    with pytest.raises(gm.errors.ConvergenceError, match="singularity"):
        gm.solve(system, "dop853", y0=[1.0, 1.0], t_final=3.0)


def test_a_spent_budget_keeps_the_states_reached():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    sol = gm.solve(body, "dopri5", m0=M0, t_final=100.0, saveat=101, max_evaluations=600, raise_on_failure=False)
    assert sol.status is Status.BUDGET_EXHAUSTED
    reached = sol.failures[0].time
    assert 1.0 < reached < 100.0 and "max_evaluations" in sol.failures[0].detail
    ok = sol.t <= reached
    np.testing.assert_allclose(sol.m[ok], body.exact_solution(M0).momentum(sol.t[ok]), atol=1e-8)
    assert np.all(np.isnan(sol.m[~ok])) and sol.stats["n_rhs"] <= 600


def test_a_users_ode_against_scipy_at_tight_tolerance():
    # the pendulum H = p^2/2 - cos q, through a different code path: scipy's own DOP853 on the same formula
    q, p = sp.symbols("q p", real=True)
    system = gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum")
    t = np.linspace(0.0, 30.0, 61)
    sol = gm.solve(system, "dop853", y0=[2.5, 0.0], t_final=30.0, saveat=t, rtol=1e-12, atol=1e-12)
    ref = solve_ivp(
        lambda _t, y: [y[1], -np.sin(y[0])], (0, 30), [2.5, 0.0], method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t
    )
    np.testing.assert_allclose(sol.states, ref.y.T, rtol=0, atol=1e-9)
    energy = sol.states[:, 1] ** 2 / 2 - np.cos(sol.states[:, 0])
    assert np.ptp(energy) < 1e-10


@pytest.mark.parametrize("name", PAIRS)
def test_leaving_the_chart_is_located_by_the_continuous_extension(name):
    # the blow-up system H = -q p^2 / 2, p = 2 / (2 - t) from p0 = 1, on the chart p < 1.5: it ends at
    # t = 2 - 2/1.5 = 2/3, where q = (1 - t/2)^2 (q' = -q p); the chart is read at run time (one compiled module)
    q, p = sp.symbols("q p", real=True)
    system = gm.CanonicalSystem.from_expression(-q * p**2 / 2, (q,), (p,), name="blow-up", chart=((1, -10.0, 1.5),))
    opts = dict(t_final=3.0, saveat=31, rtol=1e-12, atol=1e-12, raise_on_failure=False)
    sol = gm.solve(system, DormandPrince(name), y0=[1.0, 1.0], **opts)
    assert sol.status is Status.LEFT_CHART
    failure = sol.failures[0]
    assert abs(failure.time - 2.0 / 3.0) < 1e-12 and failure.step == 7  # the first output not reached: t = 0.7
    inside = sol.t < 2.0 / 3.0
    np.testing.assert_allclose(sol.states[inside, 0], (1 - sol.t[inside] / 2) ** 2, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sol.states[inside, 1], 2 / (2 - sol.t[inside]), rtol=0, atol=1e-10)
    assert np.all(np.isnan(sol.states[~inside]))
    # a start outside the chart is refused at once, and a run that stays inside is a success
    outside = gm.solve(system, DormandPrince(name), y0=[1.0, 1.6], t_final=1.0, raise_on_failure=False)
    assert outside.status is Status.LEFT_CHART and outside.failures[0].time == 0.0
    assert gm.solve(system, DormandPrince(name), y0=[1.0, 0.5], t_final=1.5).status is Status.SUCCESS


def test_bad_pairs_and_budgets_are_refused_with_what_exists():
    with pytest.raises(gm.errors.InputError, match="DOP853"):
        DormandPrince("RK45")
    body = gm.RigidBody([3.0, 2.0, 1.0])
    with pytest.raises(gm.errors.InputError, match="max_evaluations"):
        gm.solve(body, "dop853", m0=M0, t_final=1.0, max_evaluations=0)
    with pytest.raises(gm.errors.InputError, match="h"):
        gm.solve(body, "dop853", m0=M0, t_final=1.0, h=0.1)
