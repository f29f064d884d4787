"""The momentum equation (1.2) as transport plus forcing along a shape path: the holonomy against Stokes (the
curvature integrated over the enclosed region), the momentum gained against the gait analysis's own integration,
the geometric part's independence of the timing and the forcing part's scaling with it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import dblquad

from geomech.analysis import analyse_gait
from geomech.analysis.momentum_transport import momentum_connection, momentum_curvature, momentum_transport
from geomech.errors import InputError
from geomech.lie.groups import Rn
from geomech.systems import NonholonomicSystem
from geomech.systems.nonholonomic_examples import EXAMPLES, snakeboard


def own_system() -> NonholonomicSystem:
    """A point on the plane with a shape-dependent mass along x, rolling along the direction r1, and a coupling
    of x with the shape r2: a momentum connection that is not flat, and a forcing."""
    return NonholonomicSystem.from_lagrangian(
        "(1 + k*r2**2)*x_dot**2/2 + y_dot**2/2 + (r1_dot**2 + r2_dot**2)/2 + c*x_dot*r2_dot",
        Rn("x", "y"),
        ["r1", "r2"],
        ["-sin(r1)*x_dot + cos(r1)*y_dot"],
        parameters={"k": 0.8, "c": 0.3},
        name="point with a shape-dependent mass",
    )


CENTRE, AXES = (0.3, 0.2), (0.5, 0.4)


def ellipse(T: str = "T", warp: float = 0.0) -> dict[str, str]:
    """The ellipse about CENTRE, counterclockwise, its phase s = t/T + warp sin(2 pi t/T) (same image)."""
    s = f"(2*pi*t/{T} + {warp}*sin(2*pi*t/{T}))"
    return {"r1": f"{CENTRE[0]} + {AXES[0]}*cos{s}", "r2": f"{CENTRE[1]} + {AXES[1]}*sin{s}"}


def stokes(system) -> float:
    """exp of the curvature integrated over the ellipse (polar coordinates scaled to it)."""
    a, b = AXES

    def F(theta: float, rho: float) -> float:
        r = np.array([CENTRE[0] + a * rho * np.cos(theta), CENTRE[1] + b * rho * np.sin(theta)])
        return momentum_curvature(system, r)[0, 1] * a * b * rho

    value, _ = dblquad(F, 0.0, 1.0, 0.0, 2 * np.pi, epsabs=1e-13, epsrel=1e-12)
    return float(np.exp(value))


def test_holonomy_is_the_exponential_of_the_enclosed_curvature():
    s = own_system()
    mt = momentum_transport(s, ellipse(), period=2.0)
    assert abs(mt.holonomy[0, 0] - 1.0) > 1e-2  # not flat
    np.testing.assert_allclose(mt.holonomy[0, 0], stokes(s), rtol=1e-10)
    # the curvature is the exterior derivative of the connection (finite differences of K, a second route)
    r, h = np.array([0.4, 0.3]), 1e-5
    K = lambda x: momentum_connection(s, x)[..., 0, 0]  # noqa: E731  (sigma,) components of K
    dK = np.array([(K(r + h * e) - K(r - h * e)) / (2 * h) for e in np.eye(2)])  # dK[a, b] = d_a K_b
    np.testing.assert_allclose(momentum_curvature(s, r), dK - dK.T, atol=1e-8)


@pytest.mark.parametrize("p0", [0.0, 0.7, -1.3])
def test_momentum_gained_is_the_gait_analysis_integration_of_eq_1_2(p0):
    s = own_system()
    mt = momentum_transport(s, ellipse(), period=2.0)
    direct = analyse_gait(s, ellipse(), period=2.0, p0=[p0]).momentum_change
    np.testing.assert_allclose(mt.gained([p0]), np.ravel(direct), atol=1e-10)
    # along the path too: p(t) = Phi(t) p0 + b(t)
    ga = analyse_gait(s, ellipse(), period=2.0, p0=[p0], samples_per_period=mt.t.size)
    np.testing.assert_allclose(mt.momentum([p0]), ga.p, atol=1e-10)


def test_transport_is_geometric_and_the_forcing_scales_with_the_timing():
    s = own_system()
    base = momentum_transport(s, ellipse(), period=2.0)
    warped = momentum_transport(s, ellipse(warp=0.15), period=2.0)
    slower = momentum_transport(s, ellipse(), period=6.0)
    # the same loop traversed with another timing: the same holonomy
    np.testing.assert_allclose(warped.holonomy, base.holonomy, rtol=1e-10)
    np.testing.assert_allclose(slower.holonomy, base.holonomy, rtol=1e-10)
    # the forcing is quadratic in the shape velocity, integrated in time: three times slower, a third of it
    assert abs(base.offset[0]) > 1e-4
    np.testing.assert_allclose(3.0 * slower.offset, base.offset, rtol=1e-8)
    assert abs(warped.offset[0] - base.offset[0]) > 1e-6 * abs(base.offset[0])


def test_the_snakeboard_momentum_connection_is_flat():
    # K = kappa(phi) dphi: exact, so every loop has holonomy 1; the momentum gained is the forcing alone
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    gait = {"psi": "0.8*sin(2*pi*t/T)", "phi": "0.5*sin(2*pi*t/T + 1.1)"}
    mt = momentum_transport(s, gait, period=1.0)
    np.testing.assert_allclose(mt.holonomy, [[1.0]], atol=1e-12)
    rng = np.random.default_rng(0)
    r = np.c_[rng.uniform(-3, 3, 5), rng.uniform(-1.2, 1.2, 5)]
    assert np.abs(momentum_curvature(s, r)).max() == 0.0
    for p0 in (0.0, 0.4):
        direct = analyse_gait(s, gait, period=1.0, p0=[p0]).momentum_change
        np.testing.assert_allclose(mt.gained([p0]), np.ravel(direct), atol=1e-10)


def _valued(name: str) -> NonholonomicSystem:
    s = EXAMPLES[name]()
    return s.with_parameters(**{p.name: 1.0 for p in s.parameter_symbols if p.name not in s.parameters})


def test_systems_without_a_transport_are_refused():
    with pytest.raises(InputError, match="no shape variables"):
        momentum_transport(_valued("chaplygin_sleigh"), {}, period=1.0)
    car = _valued("kinematic_car")
    gait = {str(r): "sin(2*pi*t/T)" for r in car.shape}
    with pytest.raises(InputError, match="no nonholonomic momentum"):
        momentum_transport(car, gait, period=1.0)
