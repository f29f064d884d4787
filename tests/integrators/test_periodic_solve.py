"""``solve(..., "periodic_orbit")``: the periodic-orbit propagator behind the common interface."""

import numpy as np
import pytest

import geomech as gm
from geomech.errors import NumericalError
from geomech.integrators import IncompatibleMethodError, PeriodicOrbit, solve
from geomech.reduction import GeneralizedSerretAndoyer, SerretAndoyerChart

CHART = SerretAndoyerChart(2)


def test_solve_periodic_orbit_matches_the_elliptic_solution_for_a_batch():
    body = gm.RigidBody([1.0, 2.0, 3.0])
    m0 = np.array([[0.3, 0.5, 0.8], [0.5, -0.4, 0.77]])  # same |m|: one reduced system
    m0[1] *= np.linalg.norm(m0[0]) / np.linalg.norm(m0[1])
    G = float(np.linalg.norm(m0[0]))
    red = GeneralizedSerretAndoyer(body).reduced_system(G)
    y0 = CHART.forward(m0)
    sol = solve(red, PeriodicOrbit(L_bounds=(-G, G)), y0=y0, saveat=21, t_final=1000.0)
    assert sol.status == "success" and sol.states.shape == (2, 21, 2)
    for b in range(2):
        exact = body.exact_solution(m0[b]).momentum(sol.t)
        np.testing.assert_allclose(CHART.inverse(sol.states[b], G), exact, atol=1e-11)
    assert np.abs(sol.energy_error).max() < 1e-13  # bounded: the error of one period, not of 1000 time units
    assert sol.stats["n_internal_steps"] < 2000  # one period per trajectory, whatever t_final is


def test_periodic_orbit_refuses_systems_and_reports_a_separatrix():
    body = gm.RigidBody([1.0, 2.0, 3.0])
    with pytest.raises(IncompatibleMethodError, match="canonical"):
        solve(body, "periodic_orbit", m0=[1.0, 0.3, 0.2], saveat=11, t_final=1.0)
    # on the separatrix E = G^2 / (2 I2): no period; status data with the reason, raised by default
    G = 1.0
    red = GeneralizedSerretAndoyer(body).reduced_system(G)
    I1, I2, I3 = 1.0, 2.0, 3.0
    a = np.sqrt((1 / I2 - 1 / I3) / (1 / I1 - 1 / I3))  # m1^2/I1 + m3^2/I3 = 1/I2 with m1^2 + m3^2 = 1
    m_sep = np.array([a, 0.0, np.sqrt(1 - a * a)])
    sol = solve(
        red, PeriodicOrbit(L_bounds=(-G, G)), y0=CHART.forward(m_sep), saveat=6, t_final=5.0, raise_on_failure=False
    )
    assert sol.status == "not_periodic" and "separatrix" in sol.message
    with pytest.raises(NumericalError, match="separatrix"):
        solve(red, PeriodicOrbit(L_bounds=(-G, G)), y0=CHART.forward(m_sep), saveat=6, t_final=5.0)


def test_a_users_system_at_t_1000_against_a_quadruple_precision_reference():
    # The demo's gyrostat-like H, reduced about axis 3 at G = 1, from (l, L) = (0.3, 0.2). Reference: heyoka's
    # taylor_adaptive in real128 (tolerance 1e-32) on dl/dt = dh/dL, dL/dt = -dh/dl written by hand, t = 1000;
    # its 80-bit run agrees to 2e-19. DOP853 at rtol 1e-14 is 5.5e-11 off there (its energy drifts).
    m1, m2, m3 = gm.M_SYMBOLS
    H = gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3**4 / 10 + m1 + m2 + m3)
    hp = GeneralizedSerretAndoyer(H).reduced_system(G=1.0, axis=2)
    reference = np.array([1.06372235899792973734668062106347905, 0.139836427795311357602754631055249157])
    sol = solve(hp, PeriodicOrbit(tol=1e-15), y0=[0.3, 0.2], saveat=11, t_final=1000.0)
    np.testing.assert_allclose(sol.states[-1], reference, atol=1e-12)


def test_solve_by_quadrature_matches_the_elliptic_solution_and_the_periodic_orbit():
    body = gm.RigidBody([1.0, 2.0, 3.0])
    m0 = np.array([0.3, 0.5, 0.8])
    G = float(np.linalg.norm(m0))
    red = GeneralizedSerretAndoyer(body).reduced_system(G)
    sol = solve(red, gm.integrators.Quadrature(L_bounds=(-G, G)), y0=CHART.forward(m0), saveat=5, t_final=1000.0)
    assert sol.status == "success" and "time-of-flight" in sol.message
    np.testing.assert_allclose(CHART.inverse(sol.states, G), body.exact_solution(m0).momentum(sol.t), atol=1e-10)
    assert np.abs(sol.energy_error).max() < 1e-13
    by_period = solve(red, PeriodicOrbit(L_bounds=(-G, G)), y0=CHART.forward(m0), saveat=5, t_final=1000.0)
    np.testing.assert_allclose(sol.states, by_period.states, atol=1e-10)


def test_quadrature_reports_a_separatrix_as_status_data():
    body = gm.RigidBody([1.0, 2.0, 3.0])
    red = GeneralizedSerretAndoyer(body).reduced_system(1.0)
    a = np.sqrt((1 / 2.0 - 1 / 3.0) / (1 / 1.0 - 1 / 3.0))
    m_sep = np.array([a, 0.0, np.sqrt(1 - a * a)])
    sol = solve(
        red,
        gm.integrators.Quadrature(L_bounds=(-1.0, 1.0)),
        y0=CHART.forward(m_sep),
        saveat=6,
        t_final=5.0,
        raise_on_failure=False,
    )
    assert sol.status == "not_periodic" and "separatrix" in sol.message
    assert np.all(np.isnan(sol.states[1:])) and np.all(sol.states[0] == CHART.forward(m_sep))
