"""The BKMM equations and the Lagrange-d'Alembert equations with multipliers compiled (straight-line code for the
system's sizes, run by the compiled Dormand-Prince loops) against the same equations evaluated in Python by scipy's
DOP853: two implementations of the linear algebra (loops over named values, or an elimination in the compiled
function; numpy on arrays) and two drivers. The compiled paths are also the default of the other nonholonomic tests,
where they meet exact solutions and each other."""

import weakref

import numpy as np
import pytest

from geomech import Gait, solve
from geomech.errors import InputError
from geomech.integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert, Status
from geomech.systems.nonholonomic_examples import (
    chaplygin_sleigh,
    kinematic_car,
    roller_racer,
    rolling_disk,
    simplified_bicycle,
    snakeboard,
)

SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
GAIT = {"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}

CASES = {
    # prescribed shapes only (a gait)
    "snakeboard": (lambda: snakeboard(**SNAKE), dict(shapes=GAIT)),
    # a free shape driven by a torque in t and the state
    "roller_racer": (
        lambda: roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6),
        dict(tau={"phi": "0.3*sin(3*t) - 0.05*phi_dot"}, q0={"phi": 0.2}),
    ),
    # one shape prescribed, one free (the lean), a potential, and a momentum
    "bicycle": (
        lambda: simplified_bicycle(m=1.0, h=0.8, c=0.3, b=1.0, g=9.81, J_s=0.05),
        dict(shapes={"sigma": "0.05*sin(2*t)"}, q0={"phi": 0.02}, p0=[1.0]),
    ),
    # a free shape, no torque
    "rolling_disk": (lambda: rolling_disk(m=1.2, R=0.4, I=0.7, J=0.3), dict(rdot0={"phi": 1.3}, p0=[0.6])),
    # no shape at all: the momentum equation is the dynamics (two momenta)
    "chaplygin_sleigh": (lambda: chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6), dict(p0=[0.3, 0.5])),
}


METHODS = {"bkmm": BKMM(), "lda": LagrangeDAlembert(), "lda_baumgarte": LagrangeDAlembert(baumgarte=5.0)}


@pytest.mark.parametrize(
    "name, method",
    [(name, "bkmm") for name in CASES]
    + [(name, "lda") for name in ("roller_racer", "bicycle", "chaplygin_sleigh")]
    + [("rolling_disk", "lda_baumgarte")],
)
def test_compiled_and_python_equations_agree(name, method):
    build, kw = CASES[name]
    s = build()
    a = solve(s, METHODS[method], t_final=3.0, saveat=31, backend="python", rtol=1e-11, atol=1e-12, **kw)
    b = solve(s, METHODS[method], t_final=3.0, saveat=31, rtol=1e-11, atol=1e-12, **kw)
    assert a.stats["backend"] == "python" and b.stats["backend"] == "numba"
    scale = max(1.0, float(np.abs(a.q).max()))
    # the two runs take different steps to the same tolerance: they agree to it, not to round-off
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(b.qdot, a.qdot, rtol=0, atol=1e-8 * max(1.0, float(np.abs(a.qdot).max())))
    np.testing.assert_allclose(b.p, a.p, rtol=0, atol=1e-8 * max(1.0, float(np.abs(a.p).max())))
    np.testing.assert_allclose(b.work, a.work, rtol=0, atol=1e-8 * max(1.0, float(np.abs(a.energy).max())))
    np.testing.assert_allclose(b.energy, a.energy, rtol=0, atol=1e-8 * max(1.0, float(np.abs(a.energy).max())))
    tau_a, tau_b = a.quantities["tau"], b.quantities["tau"]
    np.testing.assert_allclose(tau_b, tau_a, rtol=0, atol=1e-7 * max(1.0, float(np.abs(tau_a).max(initial=0.0))))
    residual = b.quantities["constraint_residual"]
    assert np.abs(residual).max(initial=0.0) <= 1e-8 * max(1.0, float(np.abs(a.qdot).max()))
    assert abs(b.stats["n_internal_steps"] - a.stats["n_internal_steps"]) <= 0.05 * a.stats["n_internal_steps"] + 2


def test_parameter_values_and_gait_numbers_share_one_compilation():
    first = solve(snakeboard(**SNAKE), BKMM(), t_final=1.0, shapes=GAIT)
    heavier = solve(snakeboard(**{**SNAKE, "m": 2.0, "J": 0.3}), BKMM(), t_final=1.0, shapes=GAIT)
    assert first.stats["backend"] == heavier.stats["backend"] == "numba"
    assert heavier.stats["compile_time"] == 0.0  # the same compiled module: nothing compiled or loaded
    assert np.abs(first.q[-1] - heavier.q[-1]).max() > 1e-3  # and the values were read at run time
    python = solve(snakeboard(**{**SNAKE, "m": 2.0, "J": 0.3}), BKMM(), t_final=1.0, shapes=GAIT, backend="python")
    np.testing.assert_allclose(heavier.q, python.q, rtol=0, atol=1e-8)
    # another amplitude (1 written or not), offset, frequency and phase of one form of gait: the same module
    other = {"psi": "1.3*sin(3*pi*t + 0.2)", "phi": "0.4*sin(3*pi*t)"}
    base = {"psi": "sin(2*pi*t + 0.7)", "phi": "0.5*sin(2*pi*t) + 0.1"}
    solve(snakeboard(**SNAKE), BKMM(), t_final=0.5, shapes=base)
    a = solve(snakeboard(**SNAKE), BKMM(), t_final=1.0, shapes=other)
    b = solve(snakeboard(**SNAKE), BKMM(), t_final=1.0, shapes=other, backend="python")
    assert a.stats["compile_time"] == 0.0
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-8)


@pytest.mark.parametrize("method", ["bkmm", "lda"])
def test_a_singular_shape_is_a_failure_where_it_is(method):
    # the kinematic car's steering reaches pi/2 at t = pi/2: its constraints are singular there
    car = kinematic_car(m=1.0, I=0.2, R=0.3, ell=1.0, J=0.1, K=0.1)
    sol = solve(car, METHODS[method], t_final=3.0, shapes={"psi": "t", "phi": "t"}, saveat=31, raise_on_failure=False)
    assert sol.stats["backend"] == "numba" and sol.status is Status.ADAPTIVE_FAILED
    assert abs(sol.failures[0].time - np.pi / 2) < 1e-6 and "singularity" in sol.message
    reached = sol.t < np.pi / 2
    assert np.all(np.isfinite(sol.q[reached])) and np.all(np.isnan(sol.q[~reached]))


def test_what_cannot_be_compiled_runs_in_python_or_is_refused_by_name():
    s = snakeboard(**SNAKE)
    callable_gait = Gait.from_callable(
        lambda t: [np.sin(2 * np.pi * t), 0.5 * np.sin(2 * np.pi * t)],
        lambda t: [2 * np.pi * np.cos(2 * np.pi * t), np.pi * np.cos(2 * np.pi * t)],
        rddot=lambda t: [-4 * np.pi**2 * np.sin(2 * np.pi * t), -2 * np.pi**2 * np.sin(2 * np.pi * t)],
        names=["psi", "phi"],
    )
    by_formula = solve(s, BKMM(), t_final=1.0, shapes=GAIT)
    by_callable = solve(s, BKMM(), t_final=1.0, shapes=callable_gait)
    assert by_callable.stats["backend"] == "python"
    np.testing.assert_allclose(by_callable.q, by_formula.q, rtol=0, atol=1e-8)
    with pytest.raises(InputError, match="formulas .* Python callable"):
        solve(s, BKMM(), t_final=1.0, shapes=callable_gait, backend="numba")
    assert solve(s, BKMM(solver="Radau"), t_final=0.1, shapes=GAIT).stats["backend"] == "python"
    with pytest.raises(InputError, match=r"solvers \['DOP853', 'RK45'\].*got solver 'Radau'"):
        solve(s, BKMM(solver="Radau"), t_final=0.1, shapes=GAIT, backend="numba")
    with pytest.raises(InputError, match="`backend`"):
        solve(s, BKMM(), t_final=0.1, shapes=GAIT, backend="cuda")


def test_torques_given_as_a_gait_of_formulas_compile():
    s = roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6)
    as_gait = solve(s, BKMM(), t_final=2.0, tau=Gait.from_expressions({"phi": "0.3*sin(3*t)"}), saveat=5)
    as_mapping = solve(s, BKMM(), t_final=2.0, tau={"phi": "0.3*sin(3*t)"}, saveat=5, backend="python")
    assert as_gait.stats["backend"] == "numba"
    np.testing.assert_allclose(as_gait.q, as_mapping.q, rtol=0, atol=1e-8)
    assert abs(as_gait.work[-1]) > 1e-3


def test_the_checked_solve_refuses_a_matrix_singular_to_working_precision():
    """The elimination the compiled Lagrange-d'Alembert equations solve with: the solution where the matrix is
    regular, and a refusal (a NaN derivative in the equations) where a pivot is below 1e-13 of the largest entry."""
    from geomech.integrators._codegen import python_helpers

    solve_checked = python_helpers()["solve_checked"]
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 5):
        A = rng.normal(size=(n, n)) + 3 * np.eye(n)
        b = rng.normal(size=n)
        x = b.copy()
        assert solve_checked(A.copy(), x, n, 1e-13)
        np.testing.assert_allclose(A @ x, b, rtol=0, atol=1e-12 * np.abs(b).max())
        S = A.copy()
        S[-1] = S[0] * (1 + 1e-15) if n > 1 else 0.0  # rows equal to round-off, or a zero
        assert not solve_checked(S, b.copy(), n, 1e-13)
        N = A.copy()
        N[0, 0] = np.nan
        assert not solve_checked(N, b.copy(), n, 1e-13)


@pytest.mark.parametrize("name", ["snakeboard", "roller_racer", "bicycle", "chaplygin_sleigh"])
def test_the_compiled_discrete_map_takes_the_python_steps(name):
    """The discrete Lagrange-d'Alembert map (midpoint) compiled takes the steps of the Python engine: the same
    guesses, residuals, Newton's tests and node velocities, so that the two agree to round-off, not to a tolerance
    (gaits, torques on free shapes, a potential, no shape; a system written in the tests in
    test_a_new_system_through_solve.py)."""
    build, kw = CASES[name]
    s = build()
    run = dict(t_final=2.0, h=0.01, saveat=21, **kw)
    a = solve(s, "discrete_lagrange_dalembert", backend="python", **run)
    b = solve(s, "discrete_lagrange_dalembert", **run)
    assert a.stats["backend"] == "python" and b.stats["backend"] == "numba"
    # the same Newton iterations, at least one a step (round-off may decide a stopping test at its threshold
    # differently now and then)
    assert b.stats["n_newton"] >= b.stats["n_steps"]
    assert abs(a.stats["n_newton"] - b.stats["n_newton"]) <= 0.01 * a.stats["n_newton"]
    for x, y in [(a.q, b.q), (a.qdot, b.qdot), (a.work, b.work), (a.quantities["tau"], b.quantities["tau"])]:
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-11 * max(1.0, float(np.abs(x).max(initial=0.0))))
    # and the compiled map is the scheme of second order: h / 2 is four times closer to the adaptive solution
    fine = solve(s, "discrete_lagrange_dalembert", **{**run, "h": 0.005})
    exact = solve(s, BKMM(), t_final=2.0, saveat=21, rtol=1e-12, atol=1e-13, **kw)
    e1, e2 = (np.abs(x.q[-1] - exact.q[-1]).max() for x in (b, fine))
    assert 3.0 < e1 / e2 < 5.0


@pytest.mark.parametrize("max_newton", [1, 2])
def test_the_compiled_discrete_map_reports_a_failed_step(max_newton):
    """A Newton failure at the first or the second step (the end of the constraint residual's stencil), with saved
    times of the user's: the compiled run keeps the saved nodes only, and they are the Python run's."""
    s = snakeboard(**SNAKE)
    run = dict(t_final=1.0, h=0.05, shapes=GAIT, max_newton=max_newton, raise_on_failure=False)
    run["saveat"] = [0.0, 0.05, 0.1, 0.5, 1.0]
    a, b = (solve(s, "discrete_lagrange_dalembert", backend=k, **run) for k in ("python", "numba"))
    assert a.status == b.status == Status.NEWTON_FAILED
    assert a.failures[0].step == b.failures[0].step == max_newton
    assert a.failures[0].time == b.failures[0].time
    for key in ("energy", "momentum", "tau", "work", "constraint_residual"):
        x, y = a.quantities[key], b.quantities[key]
        assert np.array_equal(np.isnan(x), np.isnan(y)), key
        np.testing.assert_allclose(y[np.isfinite(y)], x[np.isfinite(x)], rtol=0, atol=1e-12)
    assert np.isnan(b.q[-1]).all() and np.isfinite(b.q[max_newton - 1]).all()
    by_callable = Gait.from_callable(
        lambda t: [np.sin(2 * np.pi * t), 0.5 * np.sin(2 * np.pi * t)],
        lambda t: [2 * np.pi * np.cos(2 * np.pi * t), np.pi * np.cos(2 * np.pi * t)],
        rddot=lambda t: [-4 * np.pi**2 * np.sin(2 * np.pi * t), -2 * np.pi**2 * np.sin(2 * np.pi * t)],
        names=["psi", "phi"],
    )
    for disc in ("midpoint", "group"):
        with pytest.raises(InputError, match="backend='numba'"):
            solve(s, DiscreteLagrangeDAlembert(disc), t_final=0.1, h=0.05, shapes=by_callable, backend="numba")


def test_a_later_process_loads_the_generated_equations_from_disk(monkeypatch, tmp_path):
    """The generated source of the compiled equations and BKMM's basis and blocks are kept on disk with the
    derivations: with the process's memory emptied, the same run generates nothing and derives no basis, and its
    states are the same numbers."""
    from geomech.integrators.nonholonomic import _compiled
    from geomech.reduction import nonholonomic as nh
    from geomech.symbolic import cache as ns

    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(tmp_path))
    build, kw = CASES["roller_racer"]
    for fresh in (False, True):
        monkeypatch.setattr(ns, "_SHARED", {})
        monkeypatch.setattr(_compiled, "_SOURCES", weakref.WeakKeyDictionary())
        monkeypatch.setattr(_compiled, "_MADE", weakref.WeakKeyDictionary())
        nh._bkmm_fields.cache_clear()
        if fresh:
            monkeypatch.setattr(_compiled, "_generate", lambda *a, **k: pytest.fail("the source was generated again"))
            monkeypatch.setattr(nh, "_derive_bkmm_fields", lambda *a: pytest.fail("the basis was derived again"))
        sol = solve(build(), BKMM(), t_final=1.0, saveat=5, rtol=1e-10, atol=1e-12, **kw)
        assert sol.stats["backend"] == "numba"
        if not fresh:
            first = sol.q.copy()
    np.testing.assert_array_equal(sol.q, first)
    assert any(tmp_path.rglob("*.pkl"))


@pytest.mark.parametrize("solver", ["DOP853", "taylor"])
def test_bkmm_starts_from_the_given_momentum_as_given(solver):
    """The compiled BKMM state starts from `p0` itself, not from the momentum of the velocities computed from it
    (a round trip through eq. (1.1) that changed it by a few units of the last place); the velocities still follow
    from it by eq. (1.1), so the constraints hold at the start."""
    s = snakeboard(**SNAKE)
    gait = {"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t) + 0.3"}
    for p0 in (0.3, 1.1, -0.37, 2.9):
        sol = solve(s, BKMM(solver=solver), t_final=0.5, saveat=2, shapes=gait, p0=[p0])
        assert sol.p[0, 0] == p0
        assert np.abs(sol.quantities["constraint_residual"][0]).max() <= 1e-13 * max(1.0, abs(p0))
