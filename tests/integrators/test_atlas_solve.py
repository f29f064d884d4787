"""The Serret-Andoyer atlas as a method of solve(): batches, backwards, any output times, its charts."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.integrators import IncompatibleMethodError, SerretAndoyerAtlas
from geomech.lie import so3
from geomech.systems import CanonicalSystem


def test_a_batch_forwards_and_backwards_follows_the_exact_free_body():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    m0 = np.array([[0.2, 0.9, 0.3], [1.0, 0.1, 0.05]])  # the second starts near the pole of the seed's chart
    R0 = so3.exp(np.array([[0.3, -0.2, 1.1], [0.0, 0.4, 0.0]]))
    for t_final, saveat in ((30.0, np.array([1.0, 7.5, 30.0])), (-12.0, 7)):
        sol = gm.solve(body, SerretAndoyerAtlas(), t_final=t_final, saveat=saveat, m0=m0, R0=R0)
        assert sol.states.shape == (2, len(sol.t), 12) and sol.success
        for b in range(2):
            exact = body.exact_solution(m0[b]).momentum(sol.t)
            assert np.abs(sol.m[b] - exact).max() < 1e-9
        assert sol.casimir_error.max() < 1e-14 * np.linalg.norm(m0, axis=1).max()
        assert sol.momentum_error.max() < 1e-9
    # the second body started in another chart than the seed's (|m3| is small but |m1| ~ G)
    first = gm.solve(body, SerretAndoyerAtlas(), t_final=1.0, saveat=2, m0=m0, R0=R0)
    assert first.chart_axis[0, 0] == 3 and first.chart_axis[1, 0] in (2, 3)
    G = np.linalg.norm(m0, axis=1)
    assert np.all(np.abs(first.serret_andoyer[:, 0, 1]) < 0.9 * G)  # |L| < 0.9 G in the chart in use


def test_a_body_that_crosses_every_chart_agrees_with_eulers_equations_and_keeps_its_attitude_continuous():
    m1, m2, m3 = gm.M_SYMBOLS
    system = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3**4 / 10 + m1 + m2 + m3)
    m0 = np.array([0.2, 0.9, 0.3])
    sol = gm.solve(system, "serret_andoyer_atlas", t_final=40.0, saveat=2001, m0=m0, R0=np.eye(3))
    assert sol.stats["chart_switches"] >= 2 and set(np.unique(sol.chart_axis)) == {1.0, 2.0, 3.0}

    def euler(_t, m):  # dm/dt = m x grad H, integrated in m directly: an independent route
        return np.cross(m, system.gradient(m))

    ref = solve_ivp(euler, (0.0, 40.0), m0, method="DOP853", rtol=1e-13, atol=1e-14, t_eval=sol.t, dense_output=True)
    assert np.abs(sol.m - ref.y.T).max() < 1e-8
    assert np.abs(np.diff(sol.R, axis=0)).max() < 0.1  # a sample every 0.02: no jump at the switches
    assert sol.momentum_error.max() < 1e-9
    # each switch located in time: there the momentum, from Euler's equations, has |m . e_from| = 0.9 G (the rule
    # of the atlas), and the new axis is the one m is farthest from; the saved chart axes agree on either side
    switches = sol.events["chart_switch"]
    assert switches.shape == (sol.stats["chart_switches"], 4) and np.all(switches[:, 0] == 0)
    t_s = switches[:, 1]
    assert np.all(np.diff(t_s) > 0) and 0 < t_s[0] and t_s[-1] < 40.0
    G = np.linalg.norm(m0)
    for _, t, a, b in switches:
        m = ref.sol(t)
        assert abs(abs(m[int(a) - 1]) - 0.9 * G) < 1e-8 and int(b) - 1 == np.argmin(np.abs(m))
        before, after = np.searchsorted(sol.t, t) - 1, np.searchsorted(sol.t, t)
        assert sol.chart_axis[before] == a and sol.chart_axis[after] == b


def test_it_needs_a_left_invariant_system_and_a_nonzero_momentum():
    q, p = sp.symbols("q p", real=True)
    canonical = CanonicalSystem.from_expression(p**2 / 2 + q**2 / 2, (q,), (p,))
    with pytest.raises(IncompatibleMethodError, match="Lie-Poisson"):
        gm.solve(canonical, "serret_andoyer_atlas", t_final=1.0, y0=[1.0, 0.0])
    with pytest.raises(gm.errors.InputError, match="nonzero"):
        gm.solve(gm.RigidBody([3.0, 2.0, 1.0]), "serret_andoyer_atlas", t_final=1.0, m0=[0.0, 0.0, 0.0])
    with pytest.raises(gm.errors.InputError, match="switch_at"):
        SerretAndoyerAtlas(switch_at=0.99999 + 1)
