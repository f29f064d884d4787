"""The periodic-orbit propagator (its tableau is tested with the Dormand-Prince pairs): periods against the elliptic
free-body period, states against the exact free-body solution (any t, negative t), the seed's reduced closed
loop against the independent quadrature propagator, rotations, equilibria, separatrices and bad input."""

import math

import numpy as np
import pytest
import sympy as sp

from geomech import CanonicalSystem, RigidBody
from geomech.errors import InputError, SingularityError
from geomech.integrators.periodic import PeriodicOrbitPropagator
from geomech.integrators.quadrature import QuadraturePropagator
from geomech.reduction import GeneralizedSerretAndoyer, SerretAndoyerChart

CHART = SerretAndoyerChart(2)


def _free_body(inertia, m0):
    m0 = np.asarray(m0, dtype=float)
    G = float(np.linalg.norm(m0))
    return GeneralizedSerretAndoyer(RigidBody(inertia)).reduced_system(G), CHART.forward(m0), G


@pytest.mark.parametrize("inertia", [(1.0, 2.0, 3.0), (3.0, 2.0, 1.0), (2.0, 3.0, 1.5)])
@pytest.mark.parametrize("m0", [(0.35, 0.35, 0.9), (0.9, 0.35, 0.35), (0.35, 0.9, 0.3)])
def test_free_body_period_equals_the_elliptic_one(inertia, m0):
    h, y0, G = _free_body(inertia, m0)
    exact = RigidBody(inertia).exact_solution(np.array(m0))
    orbit = PeriodicOrbitPropagator(h, y0, L_bounds=(-G, G))
    if exact.family == "separatrix":  # (2, 3, 1.5) from (0.9, 0.35, 0.35): E = G^2 / (2 I_mid) exactly
        assert orbit.kind == "separatrix" and orbit.period == np.inf
        return
    assert orbit.kind in ("libration", "rotation")
    assert orbit.period == pytest.approx(exact.period, rel=1e-13)
    assert abs(orbit.period - exact.period) <= orbit.period_error < 1e-12 * orbit.period


@pytest.mark.parametrize("m0", [(0.3, 0.5, 0.8), (0.9, 0.2, 0.3), (0.6, -0.6, 0.5)])
def test_state_equals_the_exact_solution_at_any_time(m0):
    h, y0, G = _free_body((1.0, 2.0, 3.0), m0)
    exact = RigidBody([1.0, 2.0, 3.0]).exact_solution(np.array(m0))
    orbit = PeriodicOrbitPropagator(h, y0, L_bounds=(-G, G))
    nfev = orbit.nfev
    for t, tol in ((0.0, 1e-15), (0.37, 1e-13), (10.0, 1e-13), (-7.5, 1e-13), (1e3, 1e-11), (1e5, 1e-9)):
        np.testing.assert_allclose(CHART.inverse(orbit.state(t), G), exact.momentum(t), atol=tol, err_msg=f"t={t}")
    ts = np.linspace(-50.0, 50.0, 1001).reshape(7, 11, 13)
    y = orbit.state(ts)
    assert y.shape == (7, 11, 13, 2)
    np.testing.assert_allclose(CHART.inverse(y, G), exact.momentum(ts), atol=1e-12)
    assert orbit.nfev == nfev  # building is all the work; states come from the stored period


def test_reduced_closed_loop_agrees_with_the_quadrature_propagator(closed_loop_reduced):
    """Two independent routes (time-of-flight quadrature, and integration over one period)."""
    y0 = np.array([0.3, 0.2])
    fast = PeriodicOrbitPropagator(closed_loop_reduced, y0, L_bounds=(-1, 1))
    quad = QuadraturePropagator(closed_loop_reduced, y0, L_bounds=(-1, 1), tol=1e-14)
    assert fast.kind == quad.kind == "libration"
    assert fast.period == pytest.approx(quad.period, rel=1e-13)
    assert fast.period == pytest.approx(14.578105659261, abs=1e-11)  # benchmarks/README.md
    ts = np.array([0.0, 1.0, 7.3, 14.0, 1000.0])
    np.testing.assert_allclose(fast.state(ts), quad.state(ts), atol=1e-11)
    E = closed_loop_reduced.hamiltonian(fast.state(np.linspace(0, 1000, 501)))
    assert np.max(np.abs(E - fast.energy)) < 1e-14
    # at a looser tolerance the answer is looser but still right, and cheaper
    loose = PeriodicOrbitPropagator(closed_loop_reduced, y0, L_bounds=(-1, 1), tol=1e-10)
    assert loose.n_mesh < fast.n_mesh
    assert abs(loose.period - fast.period) < 1e-8 and abs(loose.period - fast.period) <= loose.period_error


def test_rotation_of_the_pendulum_is_lifted():
    """The pendulum H = p^2/2 - cos q over the separatrix rotates: q(t + T) = q(t) + 2 pi."""
    q, p = sp.symbols("q p", real=True)
    pend = CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), angle_coordinates=(0,))
    y0 = np.array([0.0, 2.5])
    orbit = PeriodicOrbitPropagator(pend, y0)
    assert orbit.kind == "rotation" and orbit.winding == 1
    # T = 2/k K(1/k) for the rotation with k = p0/2 (energy E = p0^2/2 - 1, k^2 = (E + 1)/2)
    from scipy.special import ellipk

    k = 2.5 / 2
    assert orbit.period == pytest.approx(2 / k * ellipk(1 / k**2), rel=1e-13)
    y = orbit.state([orbit.period, 10 * orbit.period + 0.3])
    np.testing.assert_allclose(y[0], [2 * np.pi, 2.5], atol=1e-12)
    np.testing.assert_allclose(y[1] - [20 * np.pi, 0], orbit.state(0.3), atol=1e-11)
    back = PeriodicOrbitPropagator(pend, [0.0, -2.5])
    assert back.winding == -1 and back.period == pytest.approx(orbit.period, rel=1e-14)
    # the libration of the same pendulum (no angle period given: q is then not periodic at all)
    lib = PeriodicOrbitPropagator(pend, [1.0, 0.0], angle_period=None)
    assert lib.kind == "libration"
    assert lib.period == pytest.approx(4 * ellipk(math.sin(0.5) ** 2), rel=1e-13)


def test_separatrix_and_equilibria_are_reported():
    body = RigidBody([1.0, 2.0, 3.0])
    h = GeneralizedSerretAndoyer(body).reduced_system(1.0)
    sep = PeriodicOrbitPropagator(h, CHART.forward(np.array([0.5, 0.0, np.sqrt(3) / 2])), L_bounds=(-1, 1))
    assert sep.kind == "separatrix" and sep.period == math.inf and len(sep.saddles) == 2
    assert sep.quadrature is not None
    with pytest.raises(SingularityError, match="separatrix"):
        sep.state(1.0)
    for m0, kind in (((0.0, 1.0, 0.0), "saddle"), ((1.0, 0.0, 0.0), "center")):
        eq = PeriodicOrbitPropagator(h, CHART.forward(np.array(m0)), L_bounds=(-1, 1))
        assert eq.kind == "equilibrium" and eq.equilibrium.kind == kind
        np.testing.assert_allclose(eq.state([0.0, 1e5]), [CHART.forward(np.array(m0))] * 2)


def test_an_orbit_that_leaves_the_domain_is_a_singularity():
    """The pendulum's libration from (1, 0) reaches |p| = 2 sin(1/2) = 0.96, outside L_bounds (-0.5, 0.5): the
    integration stops there and the quadrature propagator reports it."""
    q, p = sp.symbols("q p", real=True)
    pend = CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,))
    with pytest.raises(SingularityError, match="leaves the domain"):
        PeriodicOrbitPropagator(pend, [1.0, 0.0], L_bounds=(-0.5, 0.5))


def test_bad_input(closed_loop_reduced):
    with pytest.raises(InputError, match="one degree of freedom"):
        PeriodicOrbitPropagator(RigidBody([1, 2, 3]), [0.1, 0.2])
    with pytest.raises(InputError, match="tol"):
        PeriodicOrbitPropagator(closed_loop_reduced, [0.3, 0.2], tol=1e-3)
    with pytest.raises(InputError, match="L_bounds"):
        PeriodicOrbitPropagator(closed_loop_reduced, [0.3, 1.2], L_bounds=(-1, 1))
    with pytest.raises(InputError, match="max_steps"):
        PeriodicOrbitPropagator(closed_loop_reduced, [0.3, 0.2], max_steps=0)
    orbit = PeriodicOrbitPropagator(closed_loop_reduced, [0.3, 0.2], L_bounds=(-1, 1))
    with pytest.raises(InputError, match="period / eps"):
        orbit.state(1e20)
