"""The discrete Lagrange-d'Alembert map with the group's discrete Lagrangian, compiled: the groups' kernels
(``_k_groups.py``: logarithms and inverse Jacobians of SO(2), R^n, SE(2), SO(3), SE(3)) against :mod:`geomech.lie`,
and whole runs against the Python engine on every kind of group and product, with and without constraints and
gaits; and against what does not depend on either engine: the rolling disk's closed-form motion (order 2) and the
conserved spatial momentum of the free body in space (discrete Noether)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from own_systems import (
    free_body_in_euler_angles,
    planar_body_with_arm,
    rolling_disk,
    skate_in_space,
    suslov_with_rotor,
)

from geomech import solve
from geomech.integrators import DiscreteLagrangeDAlembert
from geomech.integrators import _k_groups as K
from geomech.integrators._group_code import group_kernels
from geomech.lie import SE2, SE3, SO2, SO3, MatrixGroup, Rn
from geomech.lie import _common as series
from geomech.systems.nonholonomic_examples import roller_racer, snakeboard_bkmm

GROUP = DiscreteLagrangeDAlembert("group")


@pytest.mark.parametrize(
    "name", ["HALF_COT_HALF", "JINV_D", "T_OVER_SIN", "ONE_MINUS_COS_T2", "T_MINUS_SIN_T3", "SE3_C2", "SE3_C3"]
)
def test_the_kernels_series_are_lies(name):
    """The templates carry the series' coefficients and switch points as text: they are lie._common's, and the
    kernels' functions agree with its EvenSeries across the switch point (where the two branches meet)."""
    ours, theirs = getattr(K, f"GK_{name}"), getattr(series, name)
    assert ours == tuple(theirs.coeffs) and getattr(K, f"GK_{name}_TOL") == theirs._tol64
    f = getattr(K, f"gk_{name.lower()}")
    for t in np.r_[np.linspace(0.0, 3.0, 61), theirs._tol64 * np.array([0.999, 1.0, 1.001])]:
        if t == 0.0 and name not in ("HALF_COT_HALF", "JINV_D", "T_OVER_SIN"):
            continue
        assert abs(f(t) - float(theirs(np.float64(t)))) <= 4e-16 * abs(float(theirs(np.float64(t)))) + 1e-300


def _block(g, o=1):
    """An element as the block of a larger matrix at row and column o (as a product's factor)."""
    n = g.shape[0]
    P = np.full((n + 2 * o, n + 2 * o), np.nan)
    P[o : o + n, o : o + n] = g
    return P


@pytest.mark.parametrize(
    "group, log, jlinv, angles",
    [
        (SE2(), K.log_se2, K.jlinv_se2, [1e-9, 1e-3, 0.29, 0.3, 1.0, 3.0]),
        (SO3(), K.log_so3, K.jlinv_so3, [1e-9, 1e-3, 0.006, 0.3, 1.42, 1.6, 3.0, np.pi - 1e-7]),
        (SE3(), K.log_se3, K.jlinv_se3, [1e-9, 1e-3, 0.3, 1.42, 1.6, 3.0]),
    ],
    ids=["SE2", "SO3", "SE3"],
)
def test_the_kernels_logarithms_and_jacobians_are_lies(group, log, jlinv, angles):
    """At rotation angles from 1e-9 to near pi (each series' switch point among them), in a block at an offset: the
    logarithm and J_l^-1(u), J_r^-1(u) = J_l^-1(-u) to a few units of round-off of lie's."""
    rng = np.random.default_rng(7)
    k = group.dim
    rot = slice(2, 3) if k == 3 and isinstance(group, SE2) else (slice(0, 3) if k == 3 else slice(3, 6))
    for angle in angles:
        for _ in range(5):
            u = rng.standard_normal(k)
            u[rot] *= angle / np.linalg.norm(u[rot])
            g = group.exp(u)
            out = np.full(k + 2, np.nan)
            log(_block(g), 1, out, 1)
            ref = group.log(g)
            np.testing.assert_allclose(out[1:-1], ref, rtol=0, atol=2e-15 * max(1.0, np.abs(ref).max()))
            for sign, jac in ((1.0, group.left_jacobian_inverse), (-1.0, group.right_jacobian_inverse)):
                J = np.full((k + 2, k + 2), np.nan)
                jlinv(out, 1, sign, J, 1)
                expected = jac(ref)
                np.testing.assert_allclose(J[1:-1, 1:-1], expected, rtol=0, atol=4e-15 * np.abs(expected).max())


def test_the_abelian_kernels():
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = rng.uniform(-np.pi, np.pi)
        out = np.zeros(2)
        K.log_so2(_block(SO2().exp([a])), 1, out, 1)
        assert abs(out[1] - SO2().log(SO2().exp([a]))[0]) <= 1e-15
        t = rng.standard_normal(3)
        out = np.zeros(4)
        K.log_rn(_block(Rn(3).exp(t)), 1, 3, out, 1)
        assert np.array_equal(out[1:], t)


def test_which_groups_have_kernels():
    """Each factor of a product at its block and algebra index; a general matrix group has none (logm)."""
    assert group_kernels(SE2()) == [("se2", 0, 0, 3)]
    assert group_kernels(SE2("x", "y", "p") * SO2("t") * Rn("u", "v")) == [
        ("se2", 0, 0, 3),
        ("so2", 3, 3, 1),
        ("rn", 5, 4, 2),
    ]
    assert group_kernels(SO3() * SE3("x", "y", "z", "a", "b", "c")) == [("so3", 0, 0, 3), ("se3", 3, 3, 6)]
    E = lambda i, j: sp.Matrix(3, 3, lambda a, b: int((a, b) == (i, j)))  # noqa: E731
    heisenberg = MatrixGroup("Heisenberg", [E(0, 1), E(1, 2), E(0, 2)])
    assert group_kernels(heisenberg) is None and group_kernels(SE2() * heisenberg) is None


def _skate_start(system):
    """A start of the body in space with body velocity (1, 0, 0.5, 0.4, -0.7, 0.9): along the blade."""
    Lam_inv = sp.lambdify(system.group.coordinates, system.group.body_velocity_inverse)
    q0 = np.array([0.1, -0.2, 0.3, 0.2, -0.3, 0.4])
    return dict(q0=q0, qdot0=np.asarray(Lam_inv(*q0), dtype=float) @ np.array([1.0, 0.0, 0.5, 0.4, -0.7, 0.9]))


CASES = {
    "SO3": (free_body_in_euler_angles, lambda s: dict(q0=[0.3, 1.1, -0.5], qdot0=[0.4, -0.7, 0.9])),
    "SO3_constraint_gait": (
        suslov_with_rotor,
        lambda s: dict(shapes={"psi": "0.8*sin(2*pi*t)"}, q0={"a": 0.2, "b": 1.0, "c": -0.4}, p0=[0.4, -0.3]),
    ),
    "SE2_gait": (
        lambda: snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1),
        lambda s: dict(shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, q0={"theta": 0.3}, qdot0="rest"),
    ),
    "SE2_torque": (
        lambda: roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6),
        lambda s: dict(tau={"phi": "0.3*sin(3*t) - 0.05*phi_dot + 0.1*x"}, q0={"phi": 0.2}),
    ),
    "SE3_constraint": (skate_in_space, _skate_start),
    "SE2xSO2_constraints": (
        rolling_disk,
        lambda s: dict(q0=[0.0, 0.0, 0.2, 0.1], qdot0=[np.cos(0.2), np.sin(0.2), 1.3, 2.0]),
    ),
    "R2xSO2_shape_gait": (
        planar_body_with_arm,
        lambda s: dict(shapes={"r": "0.5*sin(2*pi*t)"}, q0={"th": 0.3}, p0=[0.2, 0.3]),
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_compiled_group_map_is_the_python_engines(case):
    make, start = CASES[case]
    s = make()
    kw = dict(t_final=1.0, h=0.02, saveat=6, **start(s))
    a, b = (solve(s, GROUP, backend=k, **kw) for k in ("python", "numba"))
    assert b.stats["backend"] == "numba" and a.stats["backend"] == "python"
    # the same steps to Newton's tolerance (1e-14 relative), over 50 steps
    scale = 1.0 + np.abs(a.q).max()
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(b.qdot, a.qdot, rtol=0, atol=1e-10 * (1.0 + np.abs(a.qdot).max()))
    for key in ("energy", "work", "tau", "constraint_residual"):
        x, y = np.asarray(a.quantities[key]), np.asarray(b.quantities[key])
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-9 * (1.0 + np.abs(x).max(initial=0.0)), err_msg=key)


def test_the_compiled_rolling_disk_converges_at_order_2_to_its_closed_form():
    """Heading and rolling rates constant, the contact point on a circle of radius R thetadot / phidot."""
    s = rolling_disk(R=0.5)
    phi0, th0, w, W = 0.2, 0.1, 1.3, 2.0
    start = dict(q0=[0.0, 0.0, phi0, th0], qdot0=[0.5 * W * np.cos(phi0), 0.5 * W * np.sin(phi0), w, W])
    T = 2.0
    phi = phi0 + w * T
    exact = np.array(
        [0.5 * W / w * (np.sin(phi) - np.sin(phi0)), -0.5 * W / w * (np.cos(phi) - np.cos(phi0)), phi, th0 + W * T]
    )
    errors = []
    for h in (0.04, 0.02):
        sol = solve(s, GROUP, t_final=T, h=h, saveat=2, backend="numba", **start)
        errors.append(np.abs(sol.q[-1] - exact).max())
    assert abs(np.log2(errors[0] / errors[1]) - 2) < 0.2, errors
    assert errors[1] < 1e-3


def test_the_compiled_free_body_in_space_keeps_its_spatial_momentum():
    """Without constraints the group's discrete Lagrangian is invariant under SE(3): its discrete momentum map is
    conserved to Newton's tolerance, where the midpoint discrete Lagrangian in the Z-Y-X angles lets it drift."""
    s = skate_in_space(blade=False)
    kw = dict(t_final=4.0, h=0.05, saveat=11, **_skate_start(s))
    group = solve(s, GROUP, backend="numba", **kw)
    midpoint = solve(s, DiscreteLagrangeDAlembert("midpoint"), backend="numba", **kw)
    J, Jm = group.quantities["spatial_momentum"], midpoint.quantities["spatial_momentum"]
    scale = np.abs(J[0]).max()
    assert np.abs(J - J[0]).max() < 1e-12 * scale * 4.0 / 0.05
    assert np.abs(Jm - Jm[0]).max() > 1e-6 * scale
