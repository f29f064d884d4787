"""Methods for left-invariant systems on T*SO(3): orders (momentum and attitude) against a direct
integration, the exact free body, Casimir and momentum map to round-off, and the Lie-group variational
integrator checked against its discrete Lagrangian built from the inverse Legendre transform."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.integrators.methods import REGISTRY, Kind
from geomech.integrators.solve import compatible_methods, solve
from geomech.lie import so3

T = 4.0
R_START = so3.exp([0.3, -0.2, 1.1])

ORDER_CASES = [
    ("closed_loop", "rk4", [10, 20, 40, 80]),
    ("closed_loop", "abm4", [80, 120, 160, 240, 320]),
    ("closed_loop", "implicit_midpoint", [20, 40, 80, 160]),
    ("closed_loop", "gauss_legendre_2", [10, 20, 40, 80]),
    ("closed_loop", "gauss_legendre_3", [5, 7, 10, 14]),
    ("closed_loop", "strang", [20, 40, 80, 160]),
    ("closed_loop", "splitting_4_yoshida", [10, 20, 40, 80]),
    ("closed_loop", "splitting_4_suzuki", [5, 10, 20, 40]),
    ("closed_loop", "lgvi", [20, 40, 80, 160]),
    ("closed_loop", "lgvi_exp", [20, 40, 80, 160]),
    ("closed_loop", "crouch_grossman", [10, 20, 40, 80]),
    ("body", "moser_veselov", [20, 40, 80, 160]),
    ("body", "lgvi", [20, 40, 80, 160]),
]


def _direct(system, m0, R0, t1):
    """A direct integration of (R, m)' = (R grad H^, m x grad H) by scipy's DOP853 at tight tolerances."""
    core = getattr(system, "system", system)

    def f(_t, z):
        dR, dm = core.vector_field(z[3:].reshape(3, 3), z[:3])
        return np.concatenate([dm, dR.ravel()])

    z = solve_ivp(f, (0, t1), np.concatenate([m0, R0.ravel()]), method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    return z[:3], z[3:].reshape(3, 3)


@pytest.fixture(scope="module")
def references(closed_loop, body, m_start):
    return {"closed_loop": _direct(closed_loop, m_start, R_START, T), "body": _direct(body, m_start, R_START, T)}


# In the fast suite: one implicit, one splitting and one group method on the closed loop, and the body's; the
# rest (their loops are the canonical methods', whose orders the fast suite checks) in the slow suite.
_FAST = {
    ("closed_loop", "implicit_midpoint"),
    ("closed_loop", "strang"),
    ("closed_loop", "lgvi"),
    ("closed_loop", "crouch_grossman"),
}
_ORDER_PARAMS = [
    pytest.param(*c, id=f"{c[0]}-{c[1]}", marks=() if c[0] == "body" or c[:2] in _FAST else pytest.mark.slow)
    for c in ORDER_CASES
]


@pytest.mark.parametrize("name, key, steps", _ORDER_PARAMS)
def test_convergence_order_of_momentum_and_attitude(name, key, steps, request, references, m_start, fitted_order):
    system = request.getfixturevalue(name)
    m_ref, R_ref = references[name]
    method = REGISTRY[key]
    err_m, err_R = [], []
    for n in steps:
        sol = solve(system, method, m0=m_start, R0=R_START, h=T / n, t_final=T, saveat=2)
        err_m.append(np.abs(sol.m[-1] - m_ref).max())
        err_R.append(np.abs(sol.R[-1] - R_ref).max())
    hs = T / np.array(steps)
    assert abs(fitted_order(hs, err_m) - method.order) < 0.2, err_m
    assert abs(fitted_order(hs, err_R) - method.order) < 0.2, err_R


@pytest.mark.slow  # long runs of every Lie-Poisson method twice
def test_momentum_alone_equals_momentum_with_attitude(closed_loop, m_start):
    for key in ("strang", "lgvi", "implicit_midpoint"):
        alone = solve(closed_loop, key, m0=m_start, h=0.05, t_final=2.5)
        both = solve(closed_loop, key, m0=m_start, R0=R_START, h=0.05, t_final=2.5)
        np.testing.assert_allclose(alone.m, both.m, rtol=0, atol=1e-15)


LP_KEYS = compatible_methods(gm.RigidBody([3.0, 2.0, 1.0]))


@pytest.mark.parametrize("key", LP_KEYS)
def test_agrees_with_the_exact_free_body(key, body):
    m0 = np.array([1.0, 0.3, 0.2])
    t1 = 3.0
    exact = body.exact_solution(m0).momentum(t1)
    method = REGISTRY[key]
    n = {2: 200, 3: 30, 4: 30, 5: 30, 6: 8, 8: 30, 10: 4, 12: 30, 15: 4}[method.order]
    errors = []
    for s in (n, 2 * n):
        # an adaptive method is told its output times (one every t1 / s), a fixed-step one its step
        times = {"saveat": s + 1} if method.kind is Kind.ADAPTIVE else {"h": t1 / s}
        errors.append(np.abs(solve(body, method, m0=m0, R0=R_START, t_final=t1, **times).m[-1] - exact).max())
    assert (
        errors[1] < {2: 1e-3, 3: 1e-5, 4: 1e-6, 5: 1e-7, 6: 1e-9, 8: 1e-8, 10: 1e-8, 12: 1e-5, 15: 1e-8}[method.order]
    )
    if method.kind is Kind.FIXED_STEP and method.order <= 6:  # an adaptive one's error is set by its tolerances
        assert errors[0] / errors[1] > 2**method.order * 0.7


# the splittings and the LGVI; Crouch-Grossman, explicit and not symplectic, by its products of rotations
CASIMIR_KEYS = ["strang", "splitting_4_yoshida", "splitting_4_suzuki", "lgvi", "lgvi_exp", "crouch_grossman"]


@pytest.mark.parametrize("key", CASIMIR_KEYS + ["moser_veselov"])
def test_casimir_and_momentum_map_kept_to_round_off(key, closed_loop, body, m_start):
    system = body if key == "moser_veselov" else closed_loop
    sol = solve(system, key, m0=m_start, R0=R_START, h=0.01, t_final=20.0)
    assert sol.casimir_error < 1e-14
    assert sol.momentum_error < 1e-14
    # the attitude stays a rotation
    R = sol.R
    assert np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max() < 1e-13
    assert REGISTRY[key].preserves_casimirs


def test_runge_kutta_does_not_keep_the_casimir(closed_loop, m_start):
    # the contrast: RK4 at the same step loses |m| and p = R m far above round-off
    sol = solve(closed_loop, "rk4", m0=m_start, R0=R_START, h=0.2, t_final=40.0)
    assert sol.casimir_error > 1e-9 and sol.momentum_error > 1e-9


def test_gauss_legendre_keeps_the_quadratic_casimir(closed_loop, m_start):
    # |m|^2 is a quadratic invariant of Euler's equations, kept by every Gauss method up to Newton's tolerance
    for key in ("implicit_midpoint", "gauss_legendre_2"):
        sol = solve(closed_loop, key, m0=m_start, R0=R_START, h=0.05, t_final=50.0)
        assert sol.casimir_error < 1e-13


@pytest.mark.parametrize("key", ["strang", "lgvi", "splitting_4_suzuki"])
def test_energy_error_bounded(key, closed_loop, m_start):
    sol = solve(closed_loop, key, m0=m_start, R0=R_START, h=0.1, t_final=2000.0, saveat=2001)
    err = np.abs(sol.energy - sol.energy[0])
    q = len(err) // 4
    assert err[-q:].max() < 1.2 * err[1:q].max() + 1e-14


# -- the Lie-group variational integrator against its discrete Lagrangian ------------------------
def _cayley_inverse(F):
    I = np.eye(3)
    return so3.vee(2 * (F - I) @ np.linalg.inv(F + I))


def _discrete_lagrangian(system, h, param):
    """L_d(R0, R1) = h l(tau^{-1}(R0^T R1)/h), l(w) = m.w - H(m) with m the inverse Legendre transform of w."""
    inverse = _cayley_inverse if param == "cayley" else so3.log

    def L_d(R0, R1):
        w = inverse(R0.T @ R1) / h
        m = system.inverse_legendre(w)
        return h * (m @ w - system.hamiltonian(m))

    return L_d


@pytest.mark.parametrize("param", ["cayley", "exp"])
def test_lgvi_solves_the_discrete_euler_lagrange_equations(param, closed_loop, m_start):
    h = 0.1
    sol = solve(
        closed_loop,
        REGISTRY["lgvi" if param == "cayley" else "lgvi_exp"],
        m0=m_start,
        R0=R_START,
        h=h,
        t_final=3 * h,
        newton_tol=1e-15,
    )
    R, m = sol.R, sol.m
    L_d = _discrete_lagrangian(closed_loop, h, param)
    eps = 1e-6
    for k in (1, 2):
        for axis in range(3):
            eta = np.zeros(3)
            eta[axis] = eps
            E_plus, E_minus = so3.exp(eta), so3.exp(-eta)
            # derivatives of L_d in its second and first slots along R exp(t eta^), by central differences
            second = (L_d(R[k - 1], R[k] @ E_plus) - L_d(R[k - 1], R[k] @ E_minus)) / (2 * eps)
            first = (L_d(R[k] @ E_plus, R[k + 1]) - L_d(R[k] @ E_minus, R[k + 1])) / (2 * eps)
            # the discrete momenta: D2 L_d(R_{k-1}, R_k) = m_k = -D1 L_d(R_k, R_{k+1}) (left-trivialised)
            assert abs(second - m[k, axis]) < 1e-8
            assert abs(first + m[k, axis]) < 1e-8
            # so the discrete Euler-Lagrange equation D2 L_d + D1 L_d = 0 holds, and not trivially
            assert abs(second + first) < 2e-8 and abs(second) > 1e-3
