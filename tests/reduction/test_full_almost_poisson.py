"""VM's full tensor on T*Q with the multiplier term (section 1.2 of the nonholonomic seed, before truncation):
checked against the canonical tensor transformed by hand, the Lagrange-d'Alembert flow, and the truncated bracket
on and off the constraint submanifold."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from own_systems import knife_edge_with_rotor

from geomech.errors import InputError
from geomech.reduction import lagrange_dalembert
from geomech.reduction.almost_poisson import almost_poisson, jacobiator
from geomech.reduction.full_almost_poisson import full_almost_poisson
from geomech.systems import NonholonomicSystem
from geomech.systems.nonholonomic_examples import EXAMPLES

SYSTEMS = {
    "chaplygin_sleigh": lambda: EXAMPLES["chaplygin_sleigh"](),
    "rolling_disk": lambda: EXAMPLES["rolling_disk"](),
    "own": knife_edge_with_rotor,
}


def _with_values(s: NonholonomicSystem, rng) -> NonholonomicSystem:
    missing = [p.name for p in s.parameter_symbols if p.name not in s.parameters]
    return s.with_parameters(**{n: float(rng.uniform(0.5, 1.5)) for n in missing})


def _state_on_D(s, num, rng):
    q = rng.uniform(-1, 1, s.n)
    A = num.constraint_matrix(q).reshape(s.c, s.n)
    qd = np.linalg.svd(A)[2][s.c :].T @ rng.uniform(-1, 1, s.n - s.c)
    return q, qd


def _W_T_p(full):
    """p~ = W^T p as a function of (q, p), with its Jacobian: the coordinate change written out here."""
    s = full.system
    p = sp.Matrix(sp.symbols(f"P0:{s.n}", real=True))
    pt = full.W.T * p
    args = list(s.q) + list(p)
    subs = s.parameter_values()
    return sp.lambdify(args, pt.subs(subs)), sp.lambdify(args, pt.jacobian(args).subs(subs))


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_full_tensor_is_the_canonical_tensor_in_vm_coordinates(name, rng):
    s = _with_values(SYSTEMS[name](), rng)
    full = full_almost_poisson(s)
    f = full.numeric()
    new, jac = _W_T_p(full)
    n = s.n
    canonical = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    for _ in range(3):
        q, p = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        T = np.vstack([np.eye(n, 2 * n), np.asarray(jac(*q, *p), dtype=float)])
        z = np.r_[q, np.asarray(new(*q, *p), dtype=float).ravel()]
        np.testing.assert_allclose(f["J"](z), T @ canonical @ T.T, atol=1e-11)
        np.testing.assert_allclose(f["p"](z)[:, 0], p, atol=1e-12)


def test_full_tensor_satisfies_jacobi_where_the_truncated_one_does_not(rng):
    s = EXAMPLES["chaplygin_sleigh"]()
    full = full_almost_poisson(s)
    J, z = full.tensor, full.z
    keys = [(i, j, k) for i in range(len(z)) for j in range(i + 1, len(z)) for k in range(j + 1, len(z))]
    syms = z + list(s.parameter_symbols)
    f = sp.lambdify(syms, [jacobiator(J, z, *key) for key in keys])
    values = np.array([f(*rng.uniform(0.5, 1.5, len(syms))) for _ in range(3)], dtype=float)
    scale = np.abs(np.asarray(sp.lambdify(syms, J)(*rng.uniform(0.5, 1.5, len(syms))), dtype=float)).max()
    assert np.abs(values).max() < 1e-12 * scale**2
    assert not almost_poisson(s).satisfies_jacobi


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_full_field_with_its_multiplier_is_the_lagrange_dalembert_flow_and_truncates_to_J_M(name, rng):
    s = _with_values(SYSTEMS[name](), rng)
    full, trunc = full_almost_poisson(s), almost_poisson(s)
    f, ft = full.numeric(), trunc.numeric()
    num = lagrange_dalembert(s).numeric()
    new, jac = _W_T_p(full)
    n, c = s.n, s.c
    for _ in range(3):
        q, qd = _state_on_D(s, num, rng)
        qdd, lam = num.solve(q, qd)
        p = num.mass_matrix(q).reshape(n, n) @ qd
        z = np.r_[q, np.asarray(new(*q, *p), dtype=float).ravel()]
        np.testing.assert_allclose(z[2 * n - c :], 0.0, atol=1e-12)  # on M: p~_a = 0 (kinetic-orthogonal complement)
        np.testing.assert_allclose(f["C"](z)[:, 0], 0.0, atol=1e-12)
        # the multiplier is Lagrange-d'Alembert's
        np.testing.assert_allclose(f["multiplier"](z), np.ravel(lam), atol=1e-10 * (1 + np.abs(lam).max()))
        # z' along the Lagrange-d'Alembert flow: (q', d/dt W^T M q')
        Mq = lambda qq, vv: num.mass_matrix(qq).reshape(n, n) @ vv  # noqa: E731
        eps = 1e-6
        dp = (Mq(q + eps * qd, qd + eps * qdd) - Mq(q - eps * qd, qd - eps * qdd)) / (2 * eps)
        Tq = np.asarray(jac(*q, *p), dtype=float)
        expected = np.r_[qd, Tq @ np.r_[qd, dp]]
        field = f["field"](z)
        np.testing.assert_allclose(field, expected, atol=1e-7 * (1 + np.abs(expected).max()))
        # truncated: the (q, p~_alpha) components
        zt = z[: 2 * n - c]
        np.testing.assert_allclose(field[: 2 * n - c], ft["J"](zt) @ ft["gradH"](zt)[:, 0], atol=1e-11)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_off_M_the_full_bracket_moves_across_D_by_the_constraint_value(name, rng):
    s = _with_values(SYSTEMS[name](), rng)
    full, trunc = full_almost_poisson(s), almost_poisson(s)
    f, ft = full.numeric(), trunc.numeric()
    num = lagrange_dalembert(s).numeric()
    new, _ = _W_T_p(full)
    n, c = s.n, s.c
    Om = sp.lambdify(list(s.q), sp.Matrix(full.complement).subs(s.parameter_values()))
    for _ in range(3):
        q, p = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        M = num.mass_matrix(q).reshape(n, n)
        A = num.constraint_matrix(q).reshape(c, n)
        qd = np.linalg.solve(M, p)
        z = np.r_[q, np.asarray(new(*q, *p), dtype=float).ravel()]
        C = f["C"](z)[:, 0]
        np.testing.assert_allclose(C, A @ qd, atol=1e-12)  # K = I: the constraint's value
        assert np.abs(C).max() > 1e-3  # off M
        full_qd = f["unconstrained"](z)[:n]
        np.testing.assert_allclose(full_qd, qd, atol=1e-11)  # canonical: q' = M^-1 p
        zt = z[: 2 * n - c]
        trunc_qd = (ft["J"](zt) @ ft["gradH"](zt)[:, 0])[:n]
        np.testing.assert_allclose(A @ trunc_qd, 0.0, atol=1e-12)  # the truncated tensor keeps q' in D
        np.testing.assert_allclose(full_qd - trunc_qd, np.asarray(Om(*q), dtype=float) @ C, atol=1e-11)


def test_another_complement_gives_the_same_motion_on_M(rng):
    s = _with_values(knife_edge_with_rotor(), rng)
    default = full_almost_poisson(s)
    # a complement that is not kinetic-orthogonal: the coordinate direction y (A Omega = cos(theta))
    other = full_almost_poisson(s, complement=[["0"], ["1"], ["0"], ["0"]])
    assert not other.orthogonal
    f0, f1 = default.numeric(), other.numeric()
    num = lagrange_dalembert(s).numeric()
    for W_full, f in ((default, f0), (other, f1)):
        new, _ = _W_T_p(W_full)
        q, qd = _state_on_D(s, num, np.random.default_rng(3))
        p = num.mass_matrix(q).reshape(s.n, s.n) @ qd
        z = np.r_[q, np.asarray(new(*q, *p), dtype=float).ravel()]
        np.testing.assert_allclose(f["C"](z)[:, 0], 0.0, atol=1e-12)
        _, lam = num.solve(q, qd)
        K = f["K"](z)
        np.testing.assert_allclose(K @ f["multiplier"](z), K @ np.ravel(lam), atol=1e-10)
        np.testing.assert_allclose(f["field"](z)[: s.n], qd, atol=1e-11)
    assert abs(np.asarray(new(*q, *p), dtype=float).ravel()[-1]) > 1e-3  # p~_a is not zero on M for this one


def test_bad_complements_and_unconstrained_systems_are_refused():
    s = knife_edge_with_rotor()
    with pytest.raises(InputError, match="complement"):
        full_almost_poisson(s, complement=[["1"], ["0"], ["0"], ["0"], ["0"]])
    with pytest.raises(InputError, match="singular"):
        full_almost_poisson(s, complement=[["cos(theta)"], ["sin(theta)"], ["0"], ["0"]])  # along D
    with pytest.raises(InputError, match="no constraints"):
        full_almost_poisson(
            NonholonomicSystem.from_lagrangian("m*(x_dot**2 + y_dot**2)/2 + J*theta_dot**2/2", "SE2", name="free")
        )


def test_full_structure_prints_as_text_latex_and_json():
    import json

    full = full_almost_poisson(EXAMPLES["chaplygin_sleigh"]())
    assert "J~" in full.to_text() and r"\tilde J" in full.to_latex()
    data = json.loads(json.dumps(full.to_json()))
    assert data
