"""The BKMM reduction against the full Lagrange-d'Alembert equations, and against published equations."""

import importlib
import json
import time

import numpy as np
import pytest
import sympy as sp

from geomech.errors import InputError, SymbolicError
from geomech.reduction import bkmm_reduction, lagrange_dalembert
from geomech.symbolic import simplify_expr
from geomech.systems.nonholonomic_examples import (
    EXAMPLES,
    chaplygin_sleigh,
    rolling_disk,
    snakeboard,
    snakeboard_bkmm,
)

ALL = [(name, {}) for name in EXAMPLES] + [("geared_body", {"scaled": True})]
IDS = [n + ("_scaled" if kw else "") for n, kw in ALL]


def _sym(system, name):
    return next(p for p in system.parameter_symbols if p.name == name)


def _reduced_state(s, red, rn, rng):
    """A random full state (q, qdot) in D built from random (g, r, rdot, p) through eq. (1.1)."""
    r, rd, p = rng.uniform(-1, 1, s.sigma), rng.uniform(-1, 1, s.sigma), rng.uniform(-1, 1, red.m)
    g = rng.uniform(-1, 1, s.k)
    xi = rn.xi(r, rd, p)
    lam_inv = sp.lambdify(s.group.coordinates, s.group.body_velocity_inverse)
    gd = np.asarray(lam_inv(*g), dtype=float) @ xi
    return np.r_[g, r], np.r_[gd, rd], r, rd, p


@pytest.mark.parametrize("name, kw", ALL, ids=IDS)
def test_reduced_equations_agree_with_the_full_equations(name, kw, rng):
    """Eqs. (1.1)-(1.3) at random states: p(q, qdot) returns p, d/dt p along the full solution is eq. (1.2), the
    shape accelerations of the full equations solve eq. (1.3), and the state satisfies the constraints."""
    s = EXAMPLES[name](**kw)
    s = s.with_parameters(**{p.name: float(rng.uniform(0.5, 1.5)) for p in s.parameter_symbols})
    red, lda = bkmm_reduction(s), lagrange_dalembert(s)
    rn, num = red.numeric(), lda.numeric()
    P = red.momentum.subs(s.parameter_values())
    grad = sp.lambdify([s.q, s.qdot], [P.jacobian(s.q), P.jacobian(s.qdot)])
    for _ in range(3):
        q, qd, r, rd, p = _reduced_state(s, red, rn, rng)
        tau = rng.uniform(-1, 1, s.sigma)
        qdd, _ = num.solve(q, qd, tau)
        Jq, Jv = (np.asarray(a, dtype=float).reshape(red.m, s.n) for a in grad(q, qd))
        assert np.abs(num.constraint_residual(q, qd)).max(initial=0) < 1e-12
        np.testing.assert_allclose(rn.momentum(q, qd), p, atol=1e-12)
        np.testing.assert_allclose(Jq @ qd + Jv @ qdd, rn.pdot(r, rd, p), atol=1e-11)
        np.testing.assert_allclose(qdd[s.k :], rn.rddot(r, rd, p, tau), atol=1e-10)


@pytest.mark.parametrize("name", ["snakeboard_bkmm", "rolling_disk", "geared_body"])
def test_shape_equation_two_derivations_agree_symbolically(name):
    red = bkmm_reduction(EXAMPLES[name]())
    lhs = red.shape_equation_projection()
    M, delta = sp.Matrix(red.shape_mass), sp.Matrix(red.shape_forces)
    diff = lhs - (M * sp.Matrix(red.rddot) - delta)
    assert all(simplify_expr(e) == 0 for e in diff)


@pytest.mark.parametrize("name", ["snakeboard", "roller_racer", "simplified_bicycle"])
def test_shape_equation_two_derivations_agree_numerically(name, rng):
    red = bkmm_reduction(EXAMPLES[name]())
    lhs = red.shape_equation_projection()
    diff = lhs - (sp.Matrix(red.shape_mass) * sp.Matrix(red.rddot) - sp.Matrix(red.shape_forces))
    syms = sorted(diff.free_symbols, key=lambda s: s.name)
    f = sp.lambdify(syms, diff)
    for _ in range(3):
        vals = rng.uniform(0.5, 1.5, len(syms))
        assert np.abs(np.asarray(f(*vals), dtype=float)).max() < 1e-10


@pytest.mark.parametrize("name", [n for n in EXAMPLES])
def test_momentum_coefficients_reproduce_the_momentum_equation(name):
    red = bkmm_reduction(EXAMPLES[name]())
    H, K, D = red.momentum_coefficients
    rd = sp.Matrix(red.rdot)
    for i in range(red.m):
        assert H[i] == H[i].T and D[i] == D[i].T
        assert H[i].shape == (len(rd), len(rd)) and K[i].shape == (len(rd), red.m) and D[i].shape == (red.m, red.m)
    # direct BKMM form <mu, [xi, e_i] + de_i/dt>, independent of the coefficient extraction
    s = red.system
    xi, mu, E = sp.Matrix(red.reconstruction), red.mu, sp.Matrix(red.basis)
    for i in range(red.m):
        direct = (
            mu.T
            * (
                s.group.bracket(list(xi), list(E[:, i]))
                + sum((sp.diff(E[:, i], r) * v for r, v in zip(red.r, red.rdot)), sp.zeros(s.k, 1))
            )
        )[0, 0]
        assert simplify_expr(direct - red.momentum_rhs[i]) == 0


def test_snakeboard_matches_bkmm_published_equations():
    """BKMM (1996), the snakeboard (also Koon and Marsden, Rep. Math. Phys. 40 (1997) 21-62): with their basis
    e = (-2 r cos^2 phi, 0, sin 2 phi) and J + J0 + 2 J1 = m r^2,

        I = 4 m r^2 cos^2 phi,  p' = 2 J0 cos^2(phi) phi' psi' - tan(phi) p phi',
        theta' = -(J0 / (m r^2)) sin^2(phi) psi' + tan(phi) p / (2 m r^2),  2 J1 phi'' = tau_phi.
    """
    s = snakeboard_bkmm()
    red = bkmm_reduction(s)
    m, r, J0, J1 = (_sym(s, n) for n in ("m", "r", "J0", "J1"))
    psi, phi = s.shape
    psid, phid = s.shape_dot
    (p,) = red.p
    assert simplify_expr(red.locked_inertia[0, 0] - 4 * m * r**2 * sp.cos(phi) ** 2) == 0
    published = 2 * J0 * sp.cos(phi) ** 2 * phid * psid - sp.tan(phi) * p * phid
    assert simplify_expr(red.momentum_rhs[0] - published) == 0
    theta_dot = -J0 / (m * r**2) * sp.sin(phi) ** 2 * psid + sp.tan(phi) * p / (2 * m * r**2)
    assert simplify_expr(red.reconstruction[2] - theta_dot) == 0
    # body forward velocity (x' cos theta + y' sin theta) along e: -(p - J0 sin 2phi psi') / (2 m r); no side slip
    assert simplify_expr(red.reconstruction[0] + (p - J0 * sp.sin(2 * phi) * psid) / (2 * m * r)) == 0
    assert red.reconstruction[1] == 0
    # the connection: only the rotor drives the group directly
    A = red.connection
    assert A[:, 1] == sp.zeros(3, 1)
    assert simplify_expr(A[2, 0] - J0 * sp.sin(phi) ** 2 / (m * r**2)) == 0
    # shape equations: 2 J1 phi'' = tau_phi and J0 (1 - J0 sin^2 phi / (m r^2)) psi'' = delta_psi + tau_psi
    assert red.shape_mass[1, 1] == 2 * J1 and red.shape_mass[0, 1] == 0 and red.shape_forces[1] == 0
    assert simplify_expr(red.shape_mass[0, 0] - J0 * (1 - J0 * sp.sin(phi) ** 2 / (m * r**2))) == 0
    delta_psi = J0**2 * sp.sin(2 * phi) * phid * psid / (2 * m * r**2) - J0 * p * phid / (2 * m * r**2)
    assert simplify_expr(red.shape_forces[0] - delta_psi) == 0
    H, K, D = red.momentum_coefficients
    assert simplify_expr(H[0][0, 1] - J0 * sp.cos(phi) ** 2) == 0 and H[0][0, 0] == 0 and H[0][1, 1] == 0
    assert simplify_expr(K[0][1, 0] + sp.tan(phi)) == 0 and K[0][0, 0] == 0 and D[0][0, 0] == 0


def test_general_snakeboard_reduces_to_bkmm_with_normalised_inertia():
    g, b = bkmm_reduction(snakeboard()), bkmm_reduction(snakeboard_bkmm())
    s = g.system
    m, r, J, J0, J1 = (_sym(s, n) for n in ("m", "r", "J", "J0", "J1"))
    sub = {J: m * r**2 - J0 - 2 * J1}
    assert simplify_expr(g.momentum_rhs[0].subs(sub) - b.momentum_rhs[0]) == 0
    assert all(simplify_expr(e) == 0 for e in (g.reconstruction.subs(sub) - b.reconstruction))
    assert all(simplify_expr(e) == 0 for e in (g.shape_forces.subs(sub) - b.shape_forces))


def test_chaplygin_sleigh_matches_the_classical_equations():
    """v' = a w^2, w' = -m a v w / (I_c + m a^2) with p1 = m v, p2 = (I_c + m a^2) w."""
    s = chaplygin_sleigh()
    red = bkmm_reduction(s)
    m, I_c, a = (_sym(s, n) for n in ("m", "I_c", "a"))
    assert red.basis == sp.Matrix([[1, 0], [0, 0], [0, 1]])
    p1, p2 = red.p
    v, w = p1 / m, p2 / (I_c + m * a**2)
    assert simplify_expr(red.momentum_rhs[0] - m * a * w**2) == 0
    assert simplify_expr(red.momentum_rhs[1] + (I_c + m * a**2) * m * a * v * w / (I_c + m * a**2)) == 0
    assert red.connection.shape == (3, 0) and red.shape_mass.shape == (0, 0)


def test_rolling_disk_spin_is_conserved_and_rolling_is_horizontal():
    s = rolling_disk()
    red = bkmm_reduction(s)
    R, I = _sym(s, "R"), _sym(s, "I")
    (phid,) = red.rdot
    (p,) = red.p
    assert red.basis == sp.Matrix([0, 0, 1]) and red.momentum_rhs[0] == 0
    assert red.reconstruction == sp.Matrix([R * phid, 0, p / I]) and red.shape_forces[0] == 0


def test_curvature_is_antisymmetric():
    red = bkmm_reduction(EXAMPLES["roller_racer"]())
    for B in red.curvature:
        assert sp.simplify(B + B.T) == sp.zeros(*B.shape)


def test_user_basis_is_validated_and_scales_the_momentum():
    s = snakeboard_bkmm()
    phi = s.shape[1]
    r = _sym(s, "r")
    with pytest.raises(SymbolicError, match="does not lie in S_q"):
        bkmm_reduction(s, basis=[1, 0, 0])
    with pytest.raises(InputError, match="3 rows"):
        bkmm_reduction(s, basis=[[1, 0], [0, 1]])
    with pytest.raises(InputError, match="k x m matrix"):
        bkmm_reduction(s, basis="hello")
    red1 = bkmm_reduction(s, basis=[-r * sp.cos(phi), 0, sp.sin(phi)])
    assert red1.normalization == "given by the caller"
    red2 = bkmm_reduction(s)
    assert "BKMM" in red2.normalization
    # p_BKMM = 2 cos(phi) p_1 for e_BKMM = 2 cos(phi) e_1
    assert simplify_expr(red2.momentum[0] - 2 * sp.cos(phi) * red1.momentum[0]) == 0


def test_default_basis_is_the_cleared_null_space():
    from geomech.lie import SE2
    from geomech.systems.nonholonomic import NonholonomicSystem

    s = snakeboard()
    plain = NonholonomicSystem.from_lagrangian(
        s.lagrangian, SE2(*s.group.coordinates), s.shape, [list(row) for row in s.constraint_matrix.tolist()]
    )
    red = bkmm_reduction(plain)
    phi, r = plain.shape[1], _sym(s, "r")
    assert red.basis == sp.Matrix([-r * sp.cos(phi), 0, sp.sin(phi)])
    assert "null space" in red.normalization


def test_derived_objects_print_as_text_latex_and_json():
    red = bkmm_reduction(snakeboard_bkmm())
    text, tex = red.to_text(), red.to_latex()
    assert "momentum equation" in text and "phi_dot" in text
    assert r"\dot{\phi}" in tex and r"\mathcal A^{nh}(r)" in tex
    data = json.loads(red.to_json())
    assert set(data) == {"title", "text", "latex"} and "H(r)" in data["text"]
    lda = lagrange_dalembert(snakeboard_bkmm())
    assert r"\lambda_{1}" in lda.to_latex() and json.loads(lda.to_json())["title"].startswith("Lagrange")


def test_derivations_are_cached_and_fast():
    t0 = time.perf_counter()
    for name in ("snakeboard_bkmm", "chaplygin_sleigh", "rolling_disk"):
        red = bkmm_reduction(EXAMPLES[name]())
        assert red.momentum_coefficients and red.shape_forces is not None
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    a, b = bkmm_reduction(snakeboard_bkmm()), bkmm_reduction(snakeboard_bkmm(m=2.0))
    # systems differing only in parameter values share the symbolic work but keep their own values
    assert a.momentum_coefficients is b.momentum_coefficients and b.system.parameters == {"m": 2.0}
    assert time.perf_counter() - t0 < 0.05
    assert first < 30.0


def test_multipliers_on_the_distribution():
    # Chaplygin sleigh: the knife edge's lateral force is m (v omega + a omega') = m v omega I_c/(I_c + m a^2),
    # with p1 = m v, p2 = (I_c + m a^2) omega (Newton's law for the centre of mass, not the reduction).
    s = chaplygin_sleigh()
    lam = lagrange_dalembert(s).multipliers_on_distribution()
    m, a, Ic = (_sym(s, n) for n in ("m", "a", "I_c"))
    v, w = sp.symbols("v omega")
    p1, p2 = bkmm_reduction(s).p
    expected = m * v * w * Ic / (Ic + m * a**2)
    assert sp.simplify(lam[0].subs({p1: m * v, p2: (Ic + m * a**2) * w}) - expected) == 0
    # Snakeboard (BKMM's): the short form equals the general multipliers at random states in D
    s, rng = snakeboard_bkmm(), np.random.default_rng(3)
    lda, red = lagrange_dalembert(s), bkmm_reduction(s)
    short = lda.multipliers_on_distribution()
    assert sum(sp.count_ops(e) for e in short) < sum(sp.count_ops(e) for e in lda.multipliers) / 10
    values = {sym: float(rng.uniform(0.2, 1.0)) for sym in s.parameter_symbols}
    rn = red.numeric({k.name: v for k, v in values.items()})
    for _ in range(3):
        q, qd, r, rd, p = _reduced_state(s, red, rn, rng)
        tau = rng.uniform(-1, 1, s.sigma)
        sub = {**values, **dict(zip(s.q, q)), **dict(zip(s.qdot, qd)), **dict(zip(red.p, p)), **dict(zip(lda.tau, tau))}
        full = np.array([float(e.subs(sub)) for e in lda.multipliers])
        np.testing.assert_allclose([float(e.subs(sub)) for e in short], full, rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------------------------------
# The kinetic-orthogonal right inverse Z, the on-disk cache, and the whole derivation of the heavy examples
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(EXAMPLES))  # every nonholonomic example has constraints (checked below)
def test_constraint_complement_is_the_kinetic_orthogonal_right_inverse(name, rng):
    """A Z = I and X^T M Z = 0 (X the null-space basis of A), at random points; no group coordinate in a
    denominator (the route through body velocities avoids the right inverse's sin(theta + phi) and the like)."""
    s = EXAMPLES[name]()
    assert s.c > 0
    lda = lagrange_dalembert(s)
    Z, X = sp.Matrix(lda.constraint_complement), sp.Matrix(lda.projected_equations[1])
    f = sp.lambdify(
        list(s.q) + list(s.parameter_symbols), [sp.Matrix(s.constraint_matrix) * Z, X.T * sp.Matrix(s.mass_matrix) * Z]
    )
    for _ in range(3):
        AZ, XMZ = (np.asarray(v, dtype=float) for v in f(*rng.uniform(0.3, 1.3, s.n + len(s.parameter_symbols))))
        np.testing.assert_allclose(AZ, np.eye(s.c), atol=1e-12)
        assert np.abs(XMZ).max() < 1e-12
    dens = set().union(*[sp.fraction(sp.together(e))[1].free_symbols for e in Z])
    assert not dens & set(s.group.coordinates)


def _fresh_memory(monkeypatch, tmp_path):
    """A new process as far as the caches go: empty in-memory store, disk cache in tmp_path."""
    from geomech.symbolic import cache as ns

    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(ns, "_SHARED", {})
    return ns


def test_a_second_derivation_loads_from_the_disk_cache(monkeypatch, tmp_path):
    ns = _fresh_memory(monkeypatch, tmp_path)
    s = rolling_disk()
    first = bkmm_reduction(s).to_dict()
    files = sorted(tmp_path.rglob("*.pkl"))
    assert files and ns.DISK_CACHE.misses > 0
    monkeypatch.setattr(ns, "_SHARED", {})
    hits, misses = ns.DISK_CACHE.hits, ns.DISK_CACHE.misses
    again = bkmm_reduction(s)
    assert again.to_dict() == first
    assert again.momentum_rhs == sp.Matrix([0]) and again.shape_mass[0, 0] == bkmm_reduction(s).shape_mass[0, 0]
    assert ns.DISK_CACHE.hits > hits and ns.DISK_CACHE.misses == misses
    # the key holds the symbolic content: other parameter values share the files, another system does not
    monkeypatch.setattr(ns, "_SHARED", {})
    hits = ns.DISK_CACHE.hits
    assert bkmm_reduction(rolling_disk(m=2.0)).to_dict() == first
    assert ns.DISK_CACHE.misses == misses and ns.DISK_CACHE.hits > hits
    monkeypatch.setattr(ns, "_SHARED", {})
    bkmm_reduction(chaplygin_sleigh()).to_dict()
    assert ns.DISK_CACHE.misses > misses


def test_each_printed_form_is_made_alone_and_agrees_with_both(monkeypatch, tmp_path):
    _fresh_memory(monkeypatch, tmp_path)
    from geomech.reduction._derived import Derived

    red = bkmm_reduction(chaplygin_sleigh())
    with monkeypatch.context() as m:
        m.setattr(Derived, "_latex", lambda self, v: pytest.fail("LaTeX printed for a text-only caller"))
        text = red.to_dict(("text",))
    assert set(text) == {"title", "text"}
    both = red.to_dict()
    assert both["text"] == text["text"] and both["latex"] == red.to_dict(("latex",))["latex"]
    assert "\\" in json.dumps(both["latex"]) and both["latex"] != both["text"]
    with pytest.raises(InputError, match="`forms` takes 'text' and 'latex'"):
        red.to_dict(("html",))


def test_a_new_process_reads_the_disk_cache(tmp_path):
    """Two fresh processes (this one's in-memory state, whatever earlier tests left, plays no part): the first
    derives and writes, the second reads everything back and derives nothing."""
    import os
    import subprocess
    import sys

    code = (
        "import json; from geomech.reduction.nonholonomic import bkmm_reduction; "
        "from geomech.symbolic import cache as ns; "
        "from geomech.systems.nonholonomic_examples import chaplygin_sleigh; "
        "d = bkmm_reduction(chaplygin_sleigh()).to_dict(); "
        "print(json.dumps([d, ns.DISK_CACHE.hits, ns.DISK_CACHE.misses]))"
    )

    def run():
        out = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            check=True,
            env={**os.environ, "GEOMECH_CACHE_DIR": str(tmp_path)},
        )
        return json.loads(out.stdout)

    first, hits1, misses1 = run()
    assert misses1 > 0 and hits1 == 0 and sorted(tmp_path.rglob("*.pkl"))
    data, hits, misses = run()
    assert data == first and hits > 0 and misses == 0


def test_a_corrupted_cache_file_is_ignored_and_rewritten(monkeypatch, tmp_path):
    ns = _fresh_memory(monkeypatch, tmp_path)
    s = snakeboard_bkmm()
    expected = bkmm_reduction(s).momentum_rhs
    files = sorted(tmp_path.rglob("*.pkl"))
    for i, f in enumerate(files):  # garbage, truncated pickles, empty files
        data = f.read_bytes()
        f.write_bytes([b"not a pickle", data[: len(data) // 2], b""][i % 3])
    monkeypatch.setattr(ns, "_SHARED", {})
    hits = ns.DISK_CACHE.hits
    assert simplify_expr(bkmm_reduction(s).momentum_rhs[0] - expected[0]) == 0
    assert ns.DISK_CACHE.hits == hits  # nothing was read from the damaged files
    monkeypatch.setattr(ns, "_SHARED", {})
    assert bkmm_reduction(s).momentum_rhs == expected and ns.DISK_CACHE.hits > hits  # rewritten, readable


def test_disk_cache_can_be_switched_off(monkeypatch, tmp_path):
    ns = _fresh_memory(monkeypatch, tmp_path)
    monkeypatch.setenv("GEOMECH_CACHE_DIR", "off")
    assert ns.cache_dir() is None
    assert bkmm_reduction(rolling_disk()).momentum_rhs == sp.Matrix([0])
    assert not list(tmp_path.rglob("*.pkl"))


@pytest.mark.slow  # the whole cold derivation of two heavy examples
@pytest.mark.parametrize("name", ["roller_racer", "simplified_bicycle"])
def test_the_whole_derivation_of_the_heavy_examples_is_produced(name, monkeypatch, tmp_path):
    """Every section of `geomech derive`, derived from scratch (empty caches): the objects exist, have their
    shapes, and the printed forms are short (the expanded multipliers used to take megabytes)."""
    from geomech.cli.nonholonomic import derivation

    _fresh_memory(monkeypatch, tmp_path)
    s = EXAMPLES[name]()
    data = derivation(s)
    assert set(data) == {"system", "lagrange_dalembert", "bkmm", "almost_poisson", "poisson_reduction"}
    lda, red = lagrange_dalembert(s), bkmm_reduction(s)
    lam = lda.multipliers_on_distribution()
    assert lam.shape == (s.c, 1) and not lam.free_symbols & set(s.qdot[: s.k])
    assert lda.projected_equations[0].shape == (s.n - s.c, 1)
    text = data["lagrange_dalembert"]["text"]
    assert set(text["multipliers lambda on D"]) == {f"lambda{a + 1}(q, rdot, p, tau)" for a in range(s.c)}
    assert len(text["projected equations X^T(M qddot - f - B tau) (= 0)"]) == s.n - s.c
    assert len(red.momentum_rhs) == red.m and red.shape_forces.shape == (s.sigma, 1)
    jac = data["almost_poisson"]["text"]["Jacobiators Jac(q^i, pt_a, pt_b) = (Z K_ab)^i and Jac(pt_a, pt_b, pt_c)"]
    d = s.n - s.c
    assert len(jac) == s.n * d * (d - 1) // 2 + d * (d - 1) * (d - 2) // 6
    assert data["almost_poisson"]["text"]["Jacobi identity holds"] == "False"
    assert len(json.dumps(data)) < 500_000


@pytest.mark.parametrize("name", ["chaplygin_sleigh", "rolling_disk", "snakeboard_bkmm"])
def test_the_coordinate_route_agrees_with_the_body_velocity_route(name, monkeypatch, tmp_path):
    """Z and the multipliers on D without the body-velocity route (the fallback for systems where it fails)."""
    nh = importlib.import_module("geomech.reduction.lagrange_dalembert")  # the module, not the function

    ns = _fresh_memory(monkeypatch, tmp_path)
    monkeypatch.setenv("GEOMECH_CACHE_DIR", "off")
    s = EXAMPLES[name]()
    lda = lagrange_dalembert(s)
    Z, lam = lda.constraint_complement, lda.multipliers_on_distribution()
    monkeypatch.setattr(ns, "_SHARED", {})
    monkeypatch.setattr(nh, "_complement_in_body_frame", lambda system: None)
    lda = lagrange_dalembert(s)
    assert lda._body_complement is None
    assert all(simplify_expr(e) == 0 for e in lda.constraint_complement - Z)
    assert all(simplify_expr(e) == 0 for e in lda.multipliers_on_distribution() - lam)


def test_the_default_reduction_is_one_object_per_system_with_that_systems_values():
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    heavy = s.with_parameters(m=3.0)
    red = bkmm_reduction(s)
    assert bkmm_reduction(s) is red and red.system is s
    other = bkmm_reduction(heavy)
    assert other is not red and other.system is heavy and bkmm_reduction(heavy) is other
    # the numeric twins follow each system's own values and the values asked for, remembered or not
    r, rd, p = np.array([0.3, 0.2]), np.array([0.5, -0.4]), np.full(red.m, 0.7)
    light_xi = red.numeric().xi(r, rd, p)
    heavy_xi = other.numeric().xi(r, rd, p)
    assert np.abs(light_xi - heavy_xi).max() > 1e-2 * np.abs(light_xi).max()
    np.testing.assert_allclose(red.numeric({"m": 3.0}).xi(r, rd, p), heavy_xi, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(red.numeric().xi(r, rd, p), light_xi)
    # a basis given is its own reduction (a sympy matrix, mutable or not, is one)
    for basis in (red.basis, sp.Matrix(red.basis)):
        given = bkmm_reduction(s, basis)
        assert given is not red and given.basis == red.basis
