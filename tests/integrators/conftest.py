"""Models shared by the integrator tests (built once per session: numba compiles each loop once per
model, and caches it on disk across sessions)."""

import numpy as np
import pytest
import sympy as sp

import geomech as gm

LAM1, LAM2, I3, G = 3.0, 2.0, 1.0, 1.0


@pytest.fixture(scope="session")
def pendulum():
    """The pendulum H = p^2/2 - cos q: nonlinear and separable."""
    q, p = sp.symbols("q p", real=True)
    return gm.CanonicalSystem.from_expression(p**2 / 2 - sp.cos(q), (q,), (p,), name="pendulum")


@pytest.fixture(scope="session")
def closed_loop_reduced():
    """The reduced closed loop of section 8 of the Serret-Andoyer paper (eq. 32 with phi(v) = 2 tan(v/G),
    p = 0, the integral of phi taken from 0), lambda1 = 3, lambda2 = 2, I3 = 1, G = 1, built from the
    formula: h_p = (G^2 - L^2)(sin^2 l/lambda1 + cos^2 l/lambda2)/2 + L^2/(2 I3) + (2G/I3) log cos(L/G)."""
    l, L = sp.symbols("l L", real=True)
    hp = (
        sp.Rational(1, 2) * (G**2 - L**2) * (sp.sin(l) ** 2 / LAM1 + sp.cos(l) ** 2 / LAM2)
        + L**2 / (2 * I3)
        + 2 * G * sp.log(sp.cos(L / G)) / I3
    )
    return gm.CanonicalSystem.from_expression(hp, (l,), (L,), name="closed-loop h_p", angle_coordinates=(0,))


@pytest.fixture(scope="session")
def closed_loop_family():
    """``build(G, k)``: the reduced closed loop with the gain of its log term, k (2G/I3 above), and G as named
    parameters (substituted numbers, which the compiled model reads at run time)."""
    l, L, G_, k_ = sp.symbols("l L G k", real=True)
    hp = (
        sp.Rational(1, 2) * (G_**2 - L**2) * (sp.sin(l) ** 2 / LAM1 + sp.cos(l) ** 2 / LAM2)
        + L**2 / (2 * I3)
        + k_ * sp.log(sp.cos(L / G_))
    )

    def build(G: float = 1.0, k: float = 2.0):
        return gm.CanonicalSystem.from_expression(hp, (l,), (L,), substitutions={G_: G, k_: k})

    return build


@pytest.fixture(scope="session")
def closed_loop():
    """The closed loop H_c(m) on so(3)* whose reduction is ``closed_loop_reduced``."""
    m1, m2, m3 = gm.M_SYMBOLS
    return gm.LeftInvariantSystem.from_expression(
        m1**2 / (2 * LAM1) + m2**2 / (2 * LAM2) + m3**2 / (2 * I3) + 2 * G * sp.log(sp.cos(m3 / G)) / I3,
        name="closed loop H_c",
    )


@pytest.fixture(scope="session")
def body():
    return gm.RigidBody([3.0, 2.0, 1.0])


@pytest.fixture(scope="session")
def m_start():
    """m = U(l, L) at (l, L) = (0.3, 0.2), G = 1 (eq. 20)."""
    s = np.sqrt(1 - 0.2**2)
    return np.array([s * np.sin(0.3), s * np.cos(0.3), 0.2])


def _fitted_order(hs, errors, floor=1e-11):
    hs, errors = np.asarray(hs), np.asarray(errors)
    keep = errors > floor
    assert keep.sum() >= 3, f"too few points above the round-off floor: {errors}"
    return np.polyfit(np.log(hs[keep]), np.log(errors[keep]), 1)[0]


@pytest.fixture(scope="session")
def fitted_order():
    """Slope of log(error) against log(h), the points at the round-off floor dropped."""
    return _fitted_order
