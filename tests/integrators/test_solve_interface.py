"""The interface of solve(): registry and traits, early rejection of incompatible pairs, input errors,
failures as data, batches, backends, the Solution object."""

import enum
import json

import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.errors import ConvergenceError, InputError, NumericalError, ShapeError
from geomech.integrators import PeriodicOrbit, Quadrature, Status
from geomech.integrators.methods import (
    REGISTRY,
    AdaptiveAdams,
    GaussLegendre,
    IncompatibleMethodError,
    Kind,
    LiePoissonSplitting,
    Method,
    get_method,
    methods_table,
)
from geomech.integrators.solve import compatible_methods, solve
from geomech.lie import so3


# -- registry ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("key", sorted(REGISTRY))
def test_every_method_documents_order_traits_structure_cost_reference(key):
    method = REGISTRY[key]
    doc = type(method).__doc__
    # an exact propagator has no order: it documents its kind (and what its accuracy is) instead
    first = "Kind: exact propagator" if method.kind is Kind.EXACT else "Order"
    for word in (first, "Structure", "Cost", "Reference"):
        assert word in doc, (key, word)
    assert method.key == key and get_method(key) is method
    row = method.describe()
    assert row["kind"] == method.kind.value and isinstance(method.kind, Kind)
    if method.kind is Kind.EXACT:
        # an exact propagator has no truncation error and takes no steps: no order, neither explicit nor implicit
        assert row["order"] is None is method.order and row["explicit"] is None is method.explicit
    else:
        assert row["order"] == method.order >= 1
        assert isinstance(row["explicit"], bool)
    assert row["structure"] == method.structure.value
    for trait in ("symplectic", "symmetric", "preserves_casimirs"):
        assert isinstance(row[trait], bool)


def test_registry_traits_are_those_of_the_theory():
    assert GaussLegendre(3).order == 6 and GaussLegendre(1).order == 2
    assert LiePoissonSplitting(order=4).order == 4
    assert not REGISTRY["rk4"].symplectic and REGISTRY["rk4"].explicit
    assert REGISTRY["stormer_verlet"].explicit and REGISTRY["stormer_verlet"].symplectic
    assert not REGISTRY["generating_function"].symmetric and REGISTRY["generating_function"].symplectic
    assert len(methods_table()) == len(REGISTRY)
    # VODE's Adams correctors are implicit (fixed-point iteration) and its order varies from 1 to 12
    assert REGISTRY["adams"].variable_order and not REGISTRY["adams"].explicit
    assert not any(m.variable_order for k, m in REGISTRY.items() if k != "adams")
    # Taylor's method: its order is that of the tolerances, fixed along a run (15 at the defaults)
    assert REGISTRY["taylor"].order == 15 and REGISTRY["taylor"].explicit
    # the kinds: fixed step, adaptive (told rtol/atol), exact propagators (told neither)
    assert REGISTRY["rk4"].kind is Kind.FIXED_STEP and REGISTRY["adams"].kind is Kind.ADAPTIVE
    assert REGISTRY["periodic_orbit"].kind is REGISTRY["quadrature"].kind is Kind.EXACT
    assert PeriodicOrbit().order is None and Quadrature().explicit is None and Quadrature().implicit is None
    with pytest.raises(InputError, match="rk4"):
        get_method("rk5")
    with pytest.raises(InputError, match="stages"):
        GaussLegendre(7)
    with pytest.raises(InputError, match="order"):
        LiePoissonSplitting(order=3)


def test_methods_are_immutable_values():
    m = GaussLegendre(2)
    with pytest.raises(AttributeError):
        m.stages = 3
    assert m == GaussLegendre(2) and hash(m) == hash(GaussLegendre(2))
    assert isinstance(m, Method)


# -- incompatible pairs ------------------------------------------------------------------------------------
def test_stormer_verlet_rejects_a_non_separable_hamiltonian_early(closed_loop_reduced):
    # raised before the initial state is even looked at
    with pytest.raises(IncompatibleMethodError) as info:
        solve(closed_loop_reduced, "stormer_verlet", y0=None, h=0.1, t_final=1.0)
    msg = str(info.value)
    assert "StormerVerlet" in msg and "closed-loop h_p" in msg and "not separable" in msg
    assert "implicit_midpoint" in msg and "generating_function" in msg
    assert isinstance(info.value, InputError) and isinstance(info.value, ValueError)


def test_splitting_rejects_a_hamiltonian_that_is_not_a_sum_of_one_variable_terms():
    m1, m2, m3 = gm.M_SYMBOLS
    coupled = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m1 * m2 / 10, name="coupled")
    with pytest.raises(IncompatibleMethodError, match=r"not a sum f1\(m1\) \+ f2\(m2\) \+ f3\(m3\).*dm1 dm2"):
        solve(coupled, "strang", m0=[1.0, 0.2, 0.3], h=0.1, t_final=1.0)
    assert "strang" not in compatible_methods(coupled) and "lgvi" in compatible_methods(coupled)


def test_moser_veselov_needs_a_free_body(closed_loop, body):
    with pytest.raises(IncompatibleMethodError, match="not quadratic"):
        solve(closed_loop, "moser_veselov", m0=[1.0, 0.2, 0.3], h=0.1, t_final=1.0)
    m1, m2, m3 = gm.M_SYMBOLS
    gyrostat = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3 / 3, name="gyrostat")
    with pytest.raises(IncompatibleMethodError, match="linear in m"):
        solve(gyrostat, "moser_veselov", m0=[1.0, 0.2, 0.3], h=0.1, t_final=1.0)
    assert "moser_veselov" in compatible_methods(body)


def test_lie_group_integrator_needs_hyperregularity():
    m1, m2, _ = gm.M_SYMBOLS
    degenerate = gm.LeftInvariantSystem.from_expression(m1**2 / 2 + m2**2 / 2, name="degenerate")
    with pytest.raises(IncompatibleMethodError, match="not hyperregular"):
        solve(degenerate, "lgvi", m0=[1.0, 0.2, 0.3], h=0.1, t_final=1.0)


def test_structures_of_other_kinds_are_rejected(closed_loop_reduced, body):
    with pytest.raises(IncompatibleMethodError, match="not a left-invariant system"):
        solve(closed_loop_reduced, "lgvi", y0=[0.3, 0.2], h=0.1, t_final=1.0)
    with pytest.raises(IncompatibleMethodError, match="reduced_system"):
        solve(body, "symplectic_euler", m0=[1.0, 0.2, 0.3], h=0.1, t_final=1.0)
    with pytest.raises(InputError, match="CanonicalSystem, a left-invariant system"):
        solve("not a system", "rk4", y0=[1.0], h=0.1, t_final=0.1)


def test_generating_function_needs_a_formula():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    core = body.system
    from_callable = gm.LeftInvariantSystem.from_callable(core.hamiltonian, core.gradient, core.hessian, name="cb")
    red = gm.GeneralizedSerretAndoyer(from_callable).reduced_system(1.0)
    with pytest.raises(IncompatibleMethodError, match="no formula"):
        solve(red, "generating_function", y0=[0.3, 0.2], h=0.1, t_final=1.0)
    with pytest.raises(IncompatibleMethodError, match="separability cannot be checked"):
        solve(red, "stormer_verlet", y0=[0.3, 0.2], h=0.1, t_final=1.0)


# -- input errors ---------------------------------------------------------------------------------------
def test_input_errors_name_the_argument_and_the_fix(closed_loop_reduced, body):
    red = closed_loop_reduced
    with pytest.raises(InputError, match=r"whole number of steps.*choose h"):
        solve(red, "rk4", y0=[0.3, 0.2], h=0.3, t_final=1.0)
    with pytest.raises(TypeError, match="t_final"):
        solve(red, "rk4", y0=[0.3, 0.2], h=0.1)  # t_final is required
    with pytest.raises(InputError, match="Expected `t_final`"):
        solve(red, "rk4", y0=[0.3, 0.2], h=0.1, t_final=None)
    with pytest.raises(ShapeError, match=r"`y0` to have shape \(\.\.\., 2\)"):
        solve(red, "rk4", y0=[0.3, 0.2, 0.1], h=0.1, t_final=0.2)
    with pytest.raises(InputError, match="`y0`"):
        solve(red, "rk4", m0=[0.3, 0.2, 0.1], h=0.1, t_final=0.2)
    with pytest.raises(InputError, match="`m0`"):
        solve(body, "rk4", y0=[0.3, 0.2, 0.1], h=0.1, t_final=0.2)
    with pytest.raises(InputError, match="rotation matrix"):
        solve(body, "rk4", m0=[0.3, 0.2, 0.1], R0=2 * np.eye(3), h=0.1, t_final=0.2)
    with pytest.raises(InputError, match="`R0` applies to left-invariant"):
        solve(red, "rk4", y0=[0.3, 0.2], R0=np.eye(3), h=0.1, t_final=0.2)
    with pytest.raises(InputError, match="`saveat`"):
        solve(red, "rk4", y0=[0.3, 0.2], h=0.1, t_final=0.2, saveat=0)
    with pytest.raises(InputError, match="`newton_tol`"):
        solve(red, "implicit_midpoint", y0=[0.3, 0.2], h=0.1, t_final=0.2, newton_tol=-1.0)
    with pytest.raises(InputError, match="`h`"):
        solve(red, "rk4", y0=[0.3, 0.2], h=np.nan, t_final=0.2)
    with pytest.raises(InputError, match="`backend`"):
        solve(red, "rk4", y0=[0.3, 0.2], h=0.1, t_final=0.2, backend="cuda")
    with pytest.raises(InputError, match="`rtol`"):
        solve(body, AdaptiveAdams(), m0=[0.3, 0.2, 0.1], t_final=1.0, rtol=0.0)
    with pytest.raises(TypeError, match="rtol"):
        AdaptiveAdams(rtol=1e-6)  # the tolerances are solve()'s


# -- times: t_final, saveat, and h (fixed step) or rtol/atol (adaptive) ---------------------------------
def test_saveat_as_a_number_or_as_times_on_the_grid_gives_the_states_of_the_full_run(closed_loop_reduced):
    red, y0 = closed_loop_reduced, [0.3, 0.2]
    full = solve(red, "implicit_midpoint", y0=y0, h=0.1, t_final=6.0)
    assert full.t.shape == (61,) and full.stats["n_steps"] == 60  # no saveat: every step
    by_number = solve(red, "implicit_midpoint", y0=y0, h=0.1, t_final=6.0, saveat=4)
    np.testing.assert_allclose(by_number.t, [0.0, 2.0, 4.0, 6.0], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(by_number.states, full.states[[0, 20, 40, 60]])
    np.testing.assert_array_equal(by_number.energy, full.energy[[0, 20, 40, 60]])
    # times on the grid t0 + k h, unequally spaced, without t0 or t_final
    times = np.array([0.3, 0.5, 2.4, 5.9])
    by_times = solve(red, "implicit_midpoint", y0=y0, h=0.1, t_final=6.0, saveat=times)
    np.testing.assert_allclose(by_times.t, times, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(by_times.states, full.states[[3, 5, 24, 59]])
    assert by_times.stats["n_steps"] == 60  # the run still goes to t_final
    # an adaptive method saves at exactly the times asked for, whatever they are
    body = gm.RigidBody([3.0, 2.0, 1.0])
    odd = np.array([0.0, 0.37, 1.1, 2.0])
    adams = solve(body, "adams", m0=[1.0, 0.3, 0.2], t_final=2.0, saveat=odd, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(adams.t, odd)
    np.testing.assert_allclose(adams.m, body.exact_solution([1.0, 0.3, 0.2]).momentum(odd), atol=1e-8)
    assert solve(body, "adams", m0=[1.0, 0.3, 0.2], t_final=2.0).t.shape == (gm.integrators.DEFAULT_SAVEAT,)


def test_saveat_off_the_step_grid_or_outside_the_span_is_refused(closed_loop_reduced):
    red, y0 = closed_loop_reduced, [0.3, 0.2]
    with pytest.raises(InputError, match=r"`saveat` time 0\.25 is not on the step grid"):
        solve(red, "rk4", y0=y0, h=0.1, t_final=1.0, saveat=[0.0, 0.25, 1.0])
    with pytest.raises(InputError, match="`saveat`.*not on the step grid"):
        solve(red, "rk4", y0=y0, h=0.1, t_final=1.0, saveat=7)  # spacing 1/6: not a multiple of h
    with pytest.raises(InputError, match=r"`saveat` time within \[0, 1\]"):
        solve(red, "rk4", y0=y0, h=0.1, t_final=1.0, saveat=[0.0, 1.1])
    with pytest.raises(InputError, match="`saveat` to be strictly increasing"):
        solve(red, "rk4", y0=y0, h=0.1, t_final=1.0, saveat=[0.5, 0.2])
    with pytest.raises(InputError, match="`saveat`, a number of output times"):
        solve(red, "rk4", y0=y0, h=0.1, t_final=1.0, saveat=1)


def test_each_kind_of_method_is_told_its_own_times(body, closed_loop_reduced):
    m0 = [1.0, 0.3, 0.2]
    with pytest.raises(InputError, match="AdaptiveAdams chooses its own steps: do not give `h`"):
        solve(body, "adams", m0=m0, h=0.1, t_final=1.0)
    with pytest.raises(InputError, match="takes fixed steps: give the step `h`, not `rtol`/`atol`"):
        solve(body, "rk4", m0=m0, h=0.1, t_final=1.0, rtol=1e-8)
    with pytest.raises(InputError, match="not `rtol`/`atol`"):
        solve(body, "strang", m0=m0, h=0.1, t_final=1.0, atol=1e-8)
    with pytest.raises(InputError, match="give the step `h`"):
        solve(body, "rk4", m0=m0, t_final=1.0)
    red, y0 = closed_loop_reduced, [0.3, 0.2]
    for method in (PeriodicOrbit(L_bounds=(-1, 1)), Quadrature(L_bounds=(-1, 1))):
        with pytest.raises(InputError, match="takes no steps in time: do not give `h`"):
            solve(red, method, y0=y0, h=0.1, t_final=1.0)
        with pytest.raises(InputError, match="exact propagator.*not `rtol`/`atol`"):
            solve(red, method, y0=y0, t_final=1.0, rtol=1e-8)
    # each told its own way: the exact propagator at any times, against a fine Gauss-Legendre run
    times = [0.0, 3.7, 10.0]
    exact = solve(red, PeriodicOrbit(L_bounds=(-1, 1)), y0=y0, t_final=10.0, saveat=times)
    np.testing.assert_array_equal(exact.t, times)
    fine = solve(red, "gauss_legendre_3", y0=y0, h=0.01, t_final=10.0, saveat=times)
    np.testing.assert_allclose(exact.states, fine.states, rtol=0, atol=1e-10)


def test_backward_integration_with_saveat(closed_loop_reduced, body):
    red = closed_loop_reduced
    forward = solve(red, "gauss_legendre_2", y0=[0.3, 0.2], h=0.05, t_final=2.0)
    back = solve(red, "gauss_legendre_2", y0=forward.states[-1], h=0.05, t0=2.0, t_final=0.0, saveat=5)
    np.testing.assert_allclose(back.t, [2.0, 1.5, 1.0, 0.5, 0.0], rtol=0, atol=1e-14)
    # Gauss-Legendre is symmetric: stepping back by -h retraces the forward steps
    np.testing.assert_allclose(back.states, forward.states[[40, 30, 20, 10, 0]], rtol=0, atol=1e-12)
    times = [2.0, 1.2, 0.35]
    some = solve(red, "gauss_legendre_2", y0=forward.states[-1], h=0.05, t0=2.0, t_final=0.0, saveat=times)
    np.testing.assert_allclose(some.t, times, rtol=0, atol=1e-14)
    np.testing.assert_allclose(some.states, forward.states[[40, 24, 7]], rtol=0, atol=1e-12)
    with pytest.raises(InputError, match=r"strictly decreasing \(t_final < t0\)"):
        solve(red, "gauss_legendre_2", y0=[0.3, 0.2], h=0.05, t0=2.0, t_final=0.0, saveat=[0.0, 2.0])
    # adaptive, backwards from the exact state at t = 3
    exact = body.exact_solution(np.array([1.0, 0.3, 0.2]))
    t_back = np.array([3.0, 1.0, 0.0])
    sol = solve(body, "adams", m0=exact.momentum(3.0), t0=3.0, t_final=0.0, saveat=t_back, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(sol.t, t_back)
    np.testing.assert_allclose(sol.m, exact.momentum(t_back), rtol=0, atol=1e-8)


# -- failures as data -----------------------------------------------------------------------------------
def test_newton_failure_is_reported_with_step_time_and_residual(pendulum):
    with pytest.raises(ConvergenceError) as info:
        solve(pendulum, "implicit_midpoint", y0=[3.0, 1.0], h=2.0, t_final=100.0)
    msg = str(info.value)
    assert "step 8" in msg and "t = 14" in msg and "residual" in msg and "Reduce h" in msg
    sol = info.value.solution
    assert sol.status == "newton_failed" and not sol.success
    (failure,) = sol.failures
    assert failure.step == 8 and failure.time == 14.0 and 1e-6 < failure.residual < 1e3
    # the states up to the failure are kept, the later ones are NaN (flagged, not silent)
    assert np.all(np.isfinite(sol.states[:8])) and np.all(np.isnan(sol.states[8:]))


def test_failure_as_status_data_in_a_batch(pendulum):
    y0 = np.array([[0.5, 0.1], [3.0, 1.0], [1.0, 0.0]])
    sol = solve(pendulum, "implicit_midpoint", y0=y0, h=2.0, t_final=100.0, raise_on_failure=False)
    assert sol.status == "newton_failed"
    assert [f.batch_index for f in sol.failures] == [(1,)]
    assert np.all(np.isfinite(sol.states[[0, 2]]))
    assert "1 of 3 trajectories failed" in sol.message


def test_newton_tolerance_is_the_callers(closed_loop_reduced):
    # a step large enough that Newton needs more than its two iterations at the tight tolerance
    y0 = [0.3, 0.2]
    for key in ("implicit_midpoint", "gauss_legendre_2"):
        loose = solve(closed_loop_reduced, key, y0=y0, h=0.5, t_final=10.0, newton_tol=1e-6)
        tight = solve(closed_loop_reduced, key, y0=y0, h=0.5, t_final=10.0)
        assert loose.stats["n_newton"] < tight.stats["n_newton"]
        assert np.abs(loose.states - tight.states).max() < 1e-6


def test_max_newton_one_fails_at_the_first_step(closed_loop_reduced):
    with pytest.raises(ConvergenceError, match="step 1, t = 0"):
        solve(closed_loop_reduced, "implicit_midpoint", y0=[0.3, 0.2], h=0.1, t_final=0.5, max_newton=1)


def test_blow_up_is_a_numerical_error():
    q, p = sp.symbols("q p", real=True)
    quartic = gm.CanonicalSystem.from_expression(p**2 / 2 - q**4 / 4, (q,), (p,), name="quartic")
    with pytest.raises(NumericalError, match="non-finite at step"):
        solve(quartic, "rk4", y0=[1.0, 1.0], h=0.01, t_final=5.0, backend="python")


# -- batches and backends ---------------------------------------------------------------------------------
@pytest.mark.parametrize("key", ["rk4", "implicit_midpoint", "gauss_legendre_3", "symplectic_euler"])
def test_canonical_batch_equals_one_by_one(key, closed_loop_reduced, rng):
    y0 = np.column_stack([rng.uniform(-1, 1, 6), rng.uniform(-0.5, 0.5, 6)]).reshape(2, 3, 2)
    # 6 x 4000 steps: large enough for the batch to be split over threads
    batch = solve(closed_loop_reduced, key, y0=y0, h=0.01, t_final=40.0, saveat=5)
    assert batch.states.shape == (2, 3, 5, 2) and batch.energy.shape == (2, 3, 5)
    for idx in np.ndindex(2, 3):
        one = solve(closed_loop_reduced, key, y0=y0[idx], h=0.01, t_final=40.0, saveat=5)
        np.testing.assert_array_equal(batch.states[idx], one.states)


@pytest.mark.parametrize("key", ["strang", "lgvi", "moser_veselov", "rk4"])
def test_lie_poisson_batch_equals_one_by_one(key, body, rng):
    m0 = rng.normal(size=(5, 3))
    R0 = so3.exp(rng.normal(size=(5, 3)))
    batch = solve(body, key, m0=m0, R0=R0, h=0.01, t_final=50.0, saveat=3)
    for b in range(5):
        one = solve(body, key, m0=m0[b], R0=R0[b], h=0.01, t_final=50.0, saveat=3)
        np.testing.assert_array_equal(batch.states[b], one.states)
    # one attitude broadcast against many momenta
    shared = solve(body, key, m0=m0, R0=R0[0], h=0.01, t_final=0.1)
    assert shared.R.shape == (5, 11, 3, 3)


def test_splitting_batch_of_many_momenta(closed_loop, rng):
    m0 = rng.normal(size=(3000, 3))
    m0 /= np.linalg.norm(m0, axis=1, keepdims=True)  # H_c has log cos(m3): |m3| < pi/2
    sol = solve(closed_loop, "strang", m0=m0, h=0.01, t_final=1.0, saveat=2)
    one = solve(closed_loop, "strang", m0=m0[1234], h=0.01, t_final=1.0, saveat=2)
    np.testing.assert_allclose(sol.m[1234], one.m, rtol=0, atol=1e-15)
    assert np.abs(sol.casimir[:, -1] - np.linalg.norm(m0, axis=1)).max() < 1e-14


def test_gauss_legendre_one_stage_is_the_midpoint_rule(closed_loop_reduced):
    # two code paths (the s-stage loop and the midpoint loop) for one map
    a = solve(closed_loop_reduced, "gauss_legendre_1", y0=[0.3, 0.2], h=0.05, t_final=20.0)
    b = solve(closed_loop_reduced, "implicit_midpoint", y0=[0.3, 0.2], h=0.05, t_final=20.0)
    np.testing.assert_allclose(a.states, b.states, rtol=0, atol=1e-13)


@pytest.mark.parametrize("key", ["implicit_midpoint", "stormer_verlet"])
def test_python_backend_agrees_with_the_compiled_one(key, pendulum):
    compiled = solve(pendulum, key, y0=[1.0, 0.5], h=0.05, t_final=10.0)
    python = solve(pendulum, key, y0=[1.0, 0.5], h=0.05, t_final=10.0, backend="python")
    assert compiled.stats["backend"] == "numba" and python.stats["backend"] == "python"
    np.testing.assert_allclose(compiled.states, python.states, rtol=0, atol=1e-13)


def test_system_from_callables_runs_on_the_python_backend(body):
    core = body.system
    from_callable = gm.LeftInvariantSystem.from_callable(core.hamiltonian, core.gradient, name="callable body")
    m0 = np.array([1.0, 0.3, 0.2])
    a = solve(from_callable, "lgvi", m0=m0, R0=np.eye(3), h=0.05, t_final=2.0)  # Hessian by finite differences
    b = solve(body, "lgvi", m0=m0, R0=np.eye(3), h=0.05, t_final=2.0)
    assert a.stats["backend"] == "python"
    np.testing.assert_allclose(a.m, b.m, atol=1e-9)


# -- the adaptive Adams method ----------------------------------------------------------------------------
@pytest.mark.parametrize("solver", ["vode", "lsoda"])
def test_adaptive_adams_meets_its_tolerance(solver, body):
    m0 = np.array([1.0, 0.3, 0.2])
    exact = body.exact_solution(m0)
    errors = []
    for rtol in (1e-6, 1e-9):
        sol = solve(body, AdaptiveAdams(solver=solver), m0=m0, rtol=rtol, atol=rtol * 1e-2, saveat=501, t_final=5.0)
        errors.append(np.abs(sol.m - exact.momentum(sol.t)).max())
        assert sol.t.shape == (501,) and sol.stats["n_rhs"] > 0
    assert errors[1] < 1e-6 < errors[0] * 1e3 and errors[1] < errors[0] / 30


def test_adaptive_adams_failure_is_reported(body):
    with pytest.raises(ConvergenceError, match="adaptive solver gave up") as info:
        solve(body, AdaptiveAdams(max_steps=1), rtol=1e-12, atol=1e-14, m0=[1.0, 0.3, 0.2], saveat=6, t_final=5.0)
    sol = info.value.solution
    assert sol.status is Status.ADAPTIVE_FAILED
    (failure,) = sol.failures
    # `step` is the index of the first output time not reached, `time` the last one reached
    k = failure.step
    assert 1 <= k < 6 and failure.time == sol.t[k - 1]
    assert np.all(np.isfinite(sol.states[:k])) and np.all(np.isnan(sol.states[k:]))


# -- the solution object --------------------------------------------------------------------------------
def test_solution_views_and_immutability(body, closed_loop_reduced):
    sol = solve(body, "strang", m0=[1.0, 0.3, 0.2], R0=np.eye(3), h=0.1, t_final=2.5, saveat=[0.0, 1.0, 2.0, 2.5])
    np.testing.assert_allclose(sol.t, [0.0, 1.0, 2.0, 2.5])
    assert sol.m.shape == (4, 3) and sol.R.shape == (4, 3, 3) and sol.spatial_momentum.shape == (4, 3)
    np.testing.assert_allclose(sol.R[0], np.eye(3))
    np.testing.assert_allclose(sol.energy, body.energy(sol.m))
    with pytest.raises(ValueError):
        sol.states[0, 0] = 1.0
    with pytest.raises(AttributeError, match="layout"):
        _ = sol.q
    assert "Strang" in repr(sol.method) or "LiePoissonSplitting" in repr(sol)
    red = solve(closed_loop_reduced, "rk4", y0=[0.3, 0.2], h=0.1, t_final=0.3)
    assert red.q.shape == (4, 1) and red.p.shape == (4, 1) and "casimir" not in red.quantities
    with pytest.raises(AttributeError, match="casimir"):
        _ = red.casimir
    with pytest.raises(AttributeError, match="R0"):
        _ = solve(body, "rk4", m0=[1.0, 0.3, 0.2], h=0.1, t_final=0.3, backend="python").momentum_error
    assert red.stats["n_steps"] == 3 and red.stats["n_rhs"] == 12 and red.stats["backend"] == "numba"


def test_solution_to_dataset_is_self_describing(body):
    sol = solve(body, "strang", m0=[1.0, 0.3, 0.2], h=0.1, t_final=1.0, saveat=3)
    ds = sol.to_dataset()
    assert ds["m"].dims == ("t", "axis") and ds["energy"].dims == ("t",) and ds["casimir"].dims == ("t",)
    np.testing.assert_array_equal(ds["t"].values, sol.t)
    np.testing.assert_array_equal(ds["m"].values, sol.m)
    np.testing.assert_array_equal(ds["energy"].values, sol.energy)
    np.testing.assert_array_equal(ds["casimir"].values, sol.casimir)
    assert ds.attrs["geomech_version"] == gm.__version__
    assert json.loads(ds.attrs["parameters"]) == {"I1": 3.0, "I2": 2.0, "I3": 1.0}
    assert ds.attrs["status"] == "success"
    batch = solve(body, "strang", m0=[[1.0, 0.3, 0.2], [0.2, 0.3, 1.0]], h=0.1, t_final=1.0, saveat=3).to_dataset()
    assert batch["m"].dims == ("batch_0", "t", "axis") and batch["casimir"].dims == ("batch_0", "t")


def test_status_is_an_enumeration_equal_to_its_string(pendulum):
    assert issubclass(Status, enum.Enum) and isinstance(Status.SUCCESS, str)
    assert Status.NEWTON_FAILED == "newton_failed" and str(Status.NEWTON_FAILED) == "newton_failed"
    assert Status("not_periodic") is Status.NOT_PERIODIC and Status.SUCCESS != "newton_failed"
    ok = solve(pendulum, "implicit_midpoint", y0=[1.0, 0.5], h=0.1, t_final=1.0)
    assert ok.status is Status.SUCCESS and ok.status == "success" and ok.success
    bad = solve(pendulum, "implicit_midpoint", y0=[3.0, 1.0], h=2.0, t_final=100.0, raise_on_failure=False)
    assert bad.status is Status.NEWTON_FAILED and bad.status == "newton_failed" and not bad.success
    assert bad.failures[0].kind is Status.NEWTON_FAILED and isinstance(bad.failures[0].detail, str)


def test_compiled_model_is_cached_by_expression():
    from geomech.integrators import _codegen
    from geomech.integrators._problem import make_problem

    q, p = sp.symbols("q p", real=True)
    expr = p**2 / 2 - sp.cos(q) + q**4 / 48
    a = gm.CanonicalSystem.from_expression(expr, (q,), (p,), name="a")
    b = gm.CanonicalSystem.from_expression(expr, (q,), (p,), name="b")  # another object, the same formula
    first = solve(a, "rk4", y0=[1.0, 0.0], h=0.1, t_final=1.0)
    second = solve(b, "rk4", y0=[1.0, 0.0], h=0.1, t_final=1.0)
    np.testing.assert_array_equal(first.states, second.states)
    assert second.stats["compile_time"] == 0.0  # compiled once per process
    mod_a, _ = make_problem(a, attitude=False).module(frozenset(), "auto")
    mod_b, _ = make_problem(b, attitude=False).module(frozenset(), "auto")
    assert mod_a is mod_b
    # the generated source lives in the kernel cache directory, where numba keeps its machine code
    assert any(path.name.startswith("gm_c_") for path in _codegen.cache_dir().iterdir())
    assert "def rhs(y, out0, prm):" in open(mod_a.__file__).read()


def test_helpers_that_never_call_the_model_by_name_are_compiled_once_for_all_models():
    from geomech.integrators import _codegen
    from geomech.integrators._problem import make_problem

    q, p = sp.symbols("q p", real=True)
    systems = [
        gm.CanonicalSystem.from_expression(expr, (q,), (p,), name=str(expr))
        for expr in (p**2 / 2 - sp.cos(q), p**2 / 2 + q**4 / 4)
    ]
    a, b = (make_problem(s, attitude=False).module(frozenset(), "auto")[0] for s in systems)
    assert a is not b
    shared_src, model_src, names = _codegen._template_split()
    # the Newton solve, the saving and the failure bookkeeping: one object in both modules
    for name in ("lu_solve", "newton_update", "finish_step", "fail", "ST_NEWTON"):
        assert name in names
        assert getattr(a, name) is getattr(b, name)
    # the splitting's loops reach the model's scalar derivatives by name (inlined in the throughput loop), and
    # symplectic Euler its gradient and Hessian (the compiler drops what a variant does not read): compiled per model
    for loop in ("split_run", "axis_flow", "flow_block", "symplectic_run"):
        assert f"def {loop}(" in model_src and f"def {loop}(" not in shared_src
        assert getattr(a, loop) is not getattr(b, loop)
    for model_function in ("rhs(", "fjac(", "grad(", "ghess(", "dh0("):
        assert model_function not in shared_src
    # every other loop calls the model's functions through the addresses of their C twins: one loop for all models
    for loop in ("erk_run", "erk_stages", "orbit_return", "orbit_states", "rk4_run", "midpoint_run", "gauss_run"):
        assert loop in names and getattr(a, loop) is getattr(b, loop)
    for loop in ("verlet_run", "lgvi_run", "abm4_run", "mv_run"):
        assert loop in names
    assert _codegen.rhs_address(a) != _codegen.rhs_address(b)
    assert _codegen.model_functions("gauss_run") == ("rhs", "fjac")
    assert _codegen.model_functions("lgvi_run") == ("ghess3",)
    # and the split changes no arithmetic: the compiled run agrees with the plain-Python one to round-off
    for method in ("implicit_midpoint", "rk4", "dop853"):
        times = {"rtol": 1e-10, "atol": 1e-10} if method == "dop853" else {"h": 0.1}
        compiled = solve(systems[0], method, y0=[1.0, 0.0], t_final=2.0, **times)
        python = solve(systems[0], method, y0=[1.0, 0.0], t_final=2.0, backend="python", **times)
        assert compiled.stats["backend"] == "numba"
        np.testing.assert_allclose(compiled.states, python.states, rtol=0, atol=1e-13)


def test_systems_that_differ_only_in_parameter_values_share_one_compilation():
    from geomech.integrators._problem import make_problem

    bodies = [gm.RigidBody(inertia=I) for I in ((3.0, 2.0, 1.0), (3.5, 2.5, 1.25))]
    modules = {make_problem(b, attitude=True).module(frozenset(), "auto")[0] for b in bodies}
    assert len(modules) == 1  # the inertias are read at run time
    # and folded as the values would have been: m2 m3 (1/I3 - 1/I2) is one product with a derived parameter
    source = open(next(iter(modules)).__file__).read()
    rhs = source[source.index("def rhs(") : source.index("@kernel", source.index("def rhs("))]
    assert "/" not in rhs and "_p" in rhs
    m0, R0 = [1.0, 0.3, 0.2], np.eye(3)
    for body in bodies:
        compiled = solve(body, "implicit_midpoint", m0=m0, R0=R0, h=0.05, t_final=2.0)
        # the Python backend evaluates the formula with the values substituted: a second route
        python = solve(body, "implicit_midpoint", m0=m0, R0=R0, h=0.05, t_final=2.0, backend="python")
        assert compiled.stats["backend"] == "numba"
        np.testing.assert_allclose(compiled.states, python.states, rtol=0, atol=1e-12)
    # the reduced (l, L) systems of several bodies and momenta G too: one compilation for all
    reduced = [gm.GeneralizedSerretAndoyer(b).reduced_system(G) for b in bodies for G in (1.0, 1.3)]
    assert len({id(make_problem(r, attitude=False).module(frozenset(), "auto")[0]) for r in reduced}) == 1
    for r in reduced:
        y0 = [0.3, 0.2 * r.chart[0][2]]
        got = solve(r, "gauss_legendre_2", y0=y0, h=0.1, t_final=1.0).states
        want = solve(r, "gauss_legendre_2", y0=y0, h=0.1, t_final=1.0, backend="python").states
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # and the two bodies do move differently
    a, b = (solve(body, "rk4", m0=m0, h=0.05, t_final=2.0).states[-1] for body in bodies)
    assert np.max(np.abs(a - b)) > 0.02  # |m| = 1.06: far above any round-off


def test_the_compiled_loops_time_is_stated_apart_from_the_python_around_it():
    """``loop_time`` is the calls into the compiled loop alone: part of ``run_time`` (the set-up, the bound on the
    work and the quantities are the rest), for the fixed-step, embedded and Taylor loops and the compiled
    Lagrangian runs; a run in Python has none."""
    from geomech.integrators import BKMM
    from geomech.systems.nonholonomic_examples import chaplygin_sleigh

    body = gm.RigidBody((3.0, 2.0, 1.0))
    sleigh = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
    runs = [
        solve(body, "implicit_midpoint", m0=[1.0, 0.3, 0.2], h=0.01, t_final=1.0),
        solve(body, "dop853", m0=[1.0, 0.3, 0.2], rtol=1e-10, atol=1e-10, t_final=1.0),
        solve(body, "taylor", m0=[1.0, 0.3, 0.2], rtol=1e-10, atol=1e-10, t_final=1.0),
        solve(sleigh, BKMM(), p0=[0.3, 0.5], rtol=1e-10, atol=1e-10, t_final=1.0),
        solve(sleigh, BKMM(solver="taylor"), p0=[0.3, 0.5], rtol=1e-10, atol=1e-10, t_final=1.0),
    ]
    for sol in runs:
        assert sol.stats["backend"] == "numba"
        assert 0.0 < sol.stats["loop_time"] <= sol.stats["run_time"], (sol.method, sol.stats)
    python = solve(body, "implicit_midpoint", m0=[1.0, 0.3, 0.2], h=0.01, t_final=1.0, backend="python")
    assert "loop_time" not in python.stats


def test_models_sharing_a_compilation_run_each_with_its_own_values():
    """Two bodies of one model (its derived parameters computed once per set of values and kept) solved in turn,
    each against scipy's integration of its own Euler equations."""
    from scipy.integrate import solve_ivp

    m0 = np.array([1.0, 0.3, 0.2])
    for inertia in [(3.0, 2.0, 1.0), (3.0, 2.0, 1.5), (3.0, 2.0, 1.0), (2.5, 2.0, 1.0)]:
        sol = solve(gm.RigidBody(inertia), "dop853", m0=m0, rtol=1e-12, atol=1e-12, t_final=5.0)
        inv = 1.0 / np.array(inertia)
        ref = solve_ivp(
            lambda t, m, inv=inv: np.cross(m, inv * m), (0.0, 5.0), m0, method="DOP853", rtol=1e-12, atol=1e-12
        ).y[:, -1]
        np.testing.assert_allclose(sol.states[-1], ref, rtol=0, atol=1e-9, err_msg=str(inertia))
