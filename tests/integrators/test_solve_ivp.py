"""scipy's adaptive solvers through solve(): any system, dense output at saveat, failures as data."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.integrators import SolveIVP
from geomech.systems import CanonicalSystem


@pytest.mark.parametrize("solver", ["DOP853", "Radau"])
def test_a_batch_of_free_bodies_follows_the_exact_solution(solver):
    body = gm.RigidBody([3.0, 2.0, 1.0])
    m0 = np.array([[1.0, 0.3, 0.2], [0.2, 1.0, -0.4]])
    sol = gm.solve(body, SolveIVP(solver), t_final=8.0, saveat=17, m0=m0, rtol=1e-11, atol=1e-13)
    assert sol.states.shape == (2, 17, 3) and sol.success
    for b in range(2):
        exact = body.exact_solution(m0[b]).momentum(sol.t)
        assert np.abs(sol.m[b] - exact).max() < 1e-8
    assert np.all(np.abs(sol.m[:, -1] - m0) > 1e-2)  # the bodies did move
    assert sol.stats["n_rhs"] > 0 and sol.method.order == (8 if solver == "DOP853" else 5)


def test_a_canonical_system_saved_at_any_times_and_a_blow_up_is_data():
    q, p = sp.symbols("q p", real=True)
    oscillator = CanonicalSystem.from_expression(p**2 / 2 + q**2 / 2, (q,), (p,))
    times = np.array([0.0, 0.3, 1.1, np.pi])  # not on any grid
    sol = gm.solve(oscillator, "solve_ivp", t_final=np.pi, saveat=times, y0=[1.0, 0.0])
    np.testing.assert_allclose(sol.q[:, 0], np.cos(times), atol=1e-9)
    np.testing.assert_allclose(sol.p[:, 0], -np.sin(times), atol=1e-9)
    # dq/dt = q^2 blows up at t = 1 from q = 1: the solver stops short, the rest is NaN
    blow = CanonicalSystem.from_expression(p * q**2, (q,), (p,))
    out = gm.solve(blow, "solve_ivp", t_final=2.0, saveat=20, y0=[1.0, 0.0], raise_on_failure=False)
    assert not out.success and out.status in ("adaptive_failed", "nonfinite", "budget_exhausted")
    when = out.failures[0].time
    assert 0.9 < when < 1.0 + 1e-6  # the last time the solver reached, at the blow-up
    early = out.t < 0.9
    np.testing.assert_allclose(out.q[early, 0], 1.0 / (1.0 - out.t[early]), rtol=1e-7)
    assert np.all(np.isnan(out.q[out.t > when]))


def test_the_traits_of_a_scipy_stepped_method_follow_its_solver():
    from geomech.integrators import BKMM, LagrangeDAlembert

    for cls in (SolveIVP, LagrangeDAlembert, BKMM):
        assert cls().explicit and cls().order == 8 and not cls().variable_order
        assert not cls("Radau").explicit and cls("Radau").order == 5
        assert cls("LSODA").variable_order and not cls("BDF").explicit
        with pytest.raises(gm.errors.InputError, match="`solver`"):
            cls("euler")
