"""Work that may be huge is bounded before it starts; values that overflow are errors, not NaN."""

import resource

import numpy as np
import pytest

import geomech as gm
from geomech.errors import InputError, NumericalError, SymbolicError

m1, m2, m3 = gm.M_SYMBOLS


@pytest.fixture(scope="module")
def reduced():
    sys = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3**4 / 10)
    return gm.GeneralizedSerretAndoyer(sys).reduced_system(G=1.0)


def test_solve_refuses_an_output_that_would_not_fit_before_allocating_it(reduced):
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(InputError, match=r"22.4 GiB.*save fewer times \(`saveat`\)"):
        gm.solve(reduced, "rk4", y0=[0.3, 0.2], h=1e-9, t_final=1.0)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # kB: nothing was allocated


@pytest.mark.parametrize(
    "kw, needle",
    [
        (dict(h=1e-300, t_final=1.0), "above the limit `max_steps`"),
        (dict(h=1e-3, t_final=1e308), "not a finite number of steps"),
        (dict(h=1e-3, t_final=1.0, max_steps=100), "above the limit `max_steps` = 100"),
        (dict(h=1e-3, t_final=1.0, memory_limit=1000.0), "above the limit `memory_limit`"),
    ],
)
def test_solve_refuses_oversized_runs_with_the_knob_that_raises_the_bound(reduced, kw, needle):
    with pytest.raises(InputError, match=needle):
        gm.solve(reduced, "rk4", y0=[0.3, 0.2], **kw)


def test_raising_the_bound_runs_it(reduced):
    sol = gm.solve(reduced, "rk4", y0=[0.3, 0.2], h=1e-3, t_final=1.0, saveat=np.linspace(0, 1, 11), max_steps=1000)
    assert sol.status == "success" and len(sol.t) == 11


@pytest.mark.parametrize(
    "fn, arg",
    [
        (gm.lie.so3.exp, [1e308, 0.0, 0.0]),
        (gm.lie.so3.exp, [[0.1, 0.2, 0.3], [0.0, -2e15, 0.0]]),
        (gm.lie.se3.exp, [0.0, 0.0, 0.0, 0.0, 1e300, 0.0]),
        (gm.lie.se2.exp, [0.0, 0.0, 1e200]),
        (gm.lie.quaternion.exp, [0.0, 0.0, 1e16]),
    ],
)
def test_exponentials_refuse_angles_beyond_their_meaning(fn, arg):
    with pytest.raises(InputError, match="modulo 2 pi"):
        fn(arg)


def test_large_but_meaningful_angles_are_exact_rotations():
    v = np.array([3e14, -1e14, 2e14])
    R = gm.lie.so3.exp(v)
    assert np.all(np.isfinite(R)) and np.abs(R.T @ R - np.eye(3)).max() < 1e-14
    # the rotation about the axis by |v| modulo 2 pi
    theta = np.linalg.norm(v)
    axis = v / theta
    np.testing.assert_allclose(R @ axis, axis, atol=1e-12)
    np.testing.assert_allclose(np.trace(R), 1 + 2 * np.cos(theta), atol=1e-12)


def test_rigid_body_refuses_runs_of_too_many_turns():
    from geomech.experiments.rigid_body import run_rigid_body

    with pytest.raises(InputError, match=r"3.18e\+08 .*`max_turns \(--max-turns\)`"):
        run_rigid_body([3, 2, 1], [1, 0.3, 1e9], t_final=2.0)


def test_a_parameter_that_makes_the_formula_infinite_is_named():
    with pytest.raises(SymbolicError, match="not finite at the parameter values I1 = 0"):
        gm.LeftInvariantSystem.from_expression("m1**2/(2*I1) + m2**2/4", {"I1": 0.0})


def test_an_overflowing_hessian_is_a_numerical_error_not_nan():
    from geomech.analysis.equilibria import find_equilibria

    sys = gm.LeftInvariantSystem.from_expression("k*m1**2 + m2**2/4 + m3**2/2", {"k": -1e308})
    with pytest.raises(NumericalError, match="not resolved in double precision|not finite"):
        find_equilibria(sys, 1.0)


@pytest.mark.parametrize("method", ["rk4", "implicit_midpoint", "adams"])  # dop853: test_embedded_pairs
def test_a_trajectory_that_reaches_the_end_of_its_chart_is_a_failure_where_it_does(method):
    """H = -l drives L' = 1: from L = 0 the chart L in (-1, 1) ends at t = 1."""
    import sympy as sp

    from geomech.integrators import Kind, get_method
    from geomech.systems import CanonicalSystem

    l, L = sp.symbols("l L", real=True)
    sys = CanonicalSystem.from_expression(-l + 0 * L, (l,), (L,), chart=((1, -1.0, 1.0),))
    # a step of 0.01, or (adaptive) output times 0.01 apart
    times = {"h": 0.01} if get_method(method).kind is Kind.FIXED_STEP else {"saveat": 201}
    sol = gm.solve(sys, method, y0=[0.0, 0.0], **times, t_final=2.0, raise_on_failure=False)
    assert sol.status == "left_chart" and "end of its chart" in sol.message
    assert abs(sol.failures[0].time - 1.0) <= 0.011
    with pytest.raises(NumericalError, match="end of its chart"):
        gm.solve(sys, method, y0=[0.0, 0.0], **times, t_final=2.0)
    assert gm.solve(sys, method, y0=[0.0, 0.0], **times, t_final=0.5).status == "success"


def test_the_serret_andoyer_reduced_system_knows_its_chart():
    sys = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2)
    assert gm.GeneralizedSerretAndoyer(sys).reduced_system(G=2.0).chart == ((1, -2.0, 2.0),)


SNAKE = {"m": 1.0, "r": 0.5, "J": 0.18, "J0": 0.05, "J1": 0.01}
GAIT = {"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}


def test_nonholonomic_simulations_are_bounded_by_their_projected_cost():
    from geomech.integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert
    from geomech.systems.nonholonomic_examples import snakeboard

    s = snakeboard(**SNAKE)
    # the default budgets: 2e5 evaluations of Python equations, 1e8 of compiled ones (BKMM's here)
    for method, limit in ((LagrangeDAlembert(), 200_000), (BKMM(), 100_000_000), (BKMM(), 200_000)):
        backend = "python" if limit == 200_000 else "auto"
        with pytest.raises(InputError, match=rf"needs about .* evaluations .* above `max_evaluations` = {limit}"):
            gm.solve(s, method, t_final=1e6 if limit == 200_000 else 1e9, shapes=GAIT, backend=backend)
    # a run just past its budget is stopped where it is, and says so
    for backend in ("python", "numba"):
        with pytest.raises(NumericalError, match=r"stopped after \d+ evaluations, of 10: .* raise `max_evaluations`"):
            gm.solve(s, BKMM(), t_final=10.0, shapes=GAIT, max_evaluations=3000, backend=backend)
        assert gm.solve(s, BKMM(), t_final=1.0, shapes=GAIT, max_evaluations=50_000, backend=backend).t[-1] == 1.0
    with pytest.raises(InputError, match=r"above the limit `max_steps` = 1e\+06"):
        gm.solve(s, DiscreteLagrangeDAlembert(), t_final=1e9, h=1e-3, shapes=GAIT)


def test_a_stability_map_grid_is_bounded_before_any_work():
    from geomech.analysis import stability_map

    calls = []

    def family(**kw):
        calls.append(kw)
        raise AssertionError("no model should be built")

    with pytest.raises(InputError, match=r"1000 x 1000 points\) is 1e\+06 .*`max_points`"):
        stability_map(family, ("k", np.linspace(0, 1, 1000)), ("c", np.linspace(0, 1, 1000)))
    assert not calls
