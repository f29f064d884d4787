"""Bates-Sniatycki: the constrained dynamics from the canonical symplectic form restricted to the constraint
distribution, held against the almost-Poisson bracket at random states and against the BKMM and
Lagrange-d'Alembert simulators along flows (the snakeboard, the roller racer and a system of the test's own)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from own_systems import knife_edge_with_rotor
from scipy.integrate import solve_ivp

from geomech import solve
from geomech.integrators import BKMM
from geomech.reduction import lagrange_dalembert
from geomech.reduction.almost_poisson import almost_poisson
from geomech.reduction.bates_sniatycki import bates_sniatycki
from geomech.systems.nonholonomic_examples import EXAMPLES, roller_racer, snakeboard_bkmm

FLOWS = {
    "snakeboard": (
        lambda: snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1),
        dict(q0={"phi": 0.2}, rdot0={"psi": 1.0, "phi": 0.3}, p0=[0.3]),
    ),
    "roller_racer": (
        lambda: roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6),
        dict(q0={"phi": 0.3}, rdot0={"phi": 0.5}, p0=[0.4]),
    ),
    "own": (knife_edge_with_rotor, dict(q0={"phi": 0.4}, rdot0={"phi": -0.6}, p0=[0.5, -0.2])),
}


@pytest.mark.parametrize("name", ["snakeboard_bkmm", "chaplygin_sleigh", "rolling_disk", "geared_body"])
def test_the_symplectic_route_is_the_almost_poisson_field(name, rng):
    s = EXAMPLES[name]()
    s = s.with_parameters(
        **{p.name: float(rng.uniform(0.5, 1.5)) for p in s.parameter_symbols if p.name not in s.parameters}
    )
    bs = bates_sniatycki(s)
    f, ap = bs.numeric(), almost_poisson(s).numeric()
    num = lagrange_dalembert(s).numeric()
    for _ in range(3):
        q = rng.uniform(-1, 1, s.n)
        A = num.constraint_matrix(q).reshape(s.c, s.n)
        qd = np.linalg.svd(A)[2][s.c :].T @ rng.uniform(-1, 1, s.n - s.c)
        z = np.r_[q, ap["pt"](np.r_[q, qd])[:, 0]]
        Z = f["field"](z)
        np.testing.assert_allclose(Z, ap["J"](z) @ ap["gradH"](z)[:, 0], atol=1e-11)
        np.testing.assert_allclose(Z[: s.n], qd, atol=1e-12)
        # omega_H is skew and nondegenerate; omega_M itself is degenerate only along directions off H
        W = f["B"](z).T @ f["form"](z) @ f["B"](z)
        np.testing.assert_allclose(W, -W.T, atol=1e-12)
        assert abs(np.linalg.det(W)) > 1e-8


def test_the_form_is_the_pullback_of_dq_wedge_dp(rng):
    # omega_M(u, v) = dq(u) . dP(v) - dq(v) . dP(u), with dP the derivative of the point of M: here by
    # differences of P(q, pt), independent of the matrix the module assembles
    s = knife_edge_with_rotor()
    bs = bates_sniatycki(s)
    f = bs.numeric()
    P = sp.lambdify(bs.z, sp.Matrix(bs.structure.momentum).subs(s.parameter_values()))
    z = rng.uniform(-1, 1, len(bs.z))
    u, v = rng.normal(size=z.size), rng.normal(size=z.size)
    eps = 1e-6

    def dP(w):
        return (np.asarray(P(*(z + eps * w)), dtype=float) - np.asarray(P(*(z - eps * w)), dtype=float)).ravel() / (
            2 * eps
        )

    n = s.n
    expected = u[:n] @ dP(v) - v[:n] @ dP(u)
    np.testing.assert_allclose(u @ f["form"](z) @ v, expected, rtol=1e-8)


@pytest.mark.parametrize("name", [n if n != "roller_racer" else pytest.param(n, marks=pytest.mark.slow) for n in FLOWS])
def test_bates_sniatycki_flow_is_the_bkmm_flow(name):
    build, start = FLOWS[name]
    s = build()
    reduced = solve(s, BKMM(), t_final=2.0, saveat=[0.0, 2.0], rtol=1e-12, atol=1e-12, backend="python", **start)
    q0, qd0 = reduced.q[0], reduced.qdot[0]
    f = bates_sniatycki(s).numeric()
    ap = almost_poisson(s).numeric()
    z0 = np.r_[q0, ap["pt"](np.r_[q0, qd0])[:, 0]]
    flow = solve_ivp(lambda t, z: f["field"](z), (0.0, 2.0), z0, method="DOP853", rtol=1e-12, atol=1e-12)
    assert flow.success
    zT = flow.y[:, -1]
    assert np.abs(zT[: s.n] - q0).max() > 0.05  # it moves
    np.testing.assert_allclose(zT[: s.n], reduced.q[-1], atol=1e-8)
    np.testing.assert_allclose(zT[s.n :], ap["pt"](np.r_[reduced.q[-1], reduced.qdot[-1]])[:, 0], atol=1e-8)


@pytest.mark.parametrize("name", ["snakeboard_bkmm", "rolling_disk"])
def test_the_field_reduces_to_theorem_1_1(name, rng):
    # with the BKMM-adapted basis the coordinates of M are (g, r, p_i, pt_alpha); the field's components along
    # (r, pt_alpha, p_i) at any g are the reduced equations of the Poisson reduction
    from geomech.reduction import poisson_reduction

    s = EXAMPLES[name]()
    s = s.with_parameters(
        **{p.name: float(rng.uniform(0.5, 1.5)) for p in s.parameter_symbols if p.name not in s.parameters}
    )
    f = bates_sniatycki(s).numeric()
    pr = poisson_reduction(s)
    reduced = pr.numeric()
    k, n, m = s.k, s.n, pr.reduction.m
    for _ in range(3):
        z = rng.uniform(-1, 1, n + n - s.c)
        Z = f["field"](z)
        r, p, ptr = z[k:n], z[n : n + m], z[n + m :]
        zbar = np.r_[r, ptr, p]
        expected = reduced["zdot"](zbar)[:, 0]
        np.testing.assert_allclose(np.r_[Z[k:n], Z[n + m :], Z[n : n + m]], expected, atol=1e-10)
        # and the same at another group element: the field is G-invariant
        moved = z.copy()
        moved[:k] = rng.uniform(-1, 1, k)
        Zm = f["field"](moved)
        np.testing.assert_allclose(Zm[k:], Z[k:], atol=1e-10)
