"""The mechanical connection (the reduction of a system without constraints): Theorem 2.1 read off vs the
direct construction on TQ, the symbolic attributes vs the numeric twin, curvature, holonomy."""

import numpy as np
import pytest
import sympy as sp

from geomech.analysis import Gait, reconstruct
from geomech.errors import InputError, SingularityError
from geomech.lie import SO3
from geomech.reduction import bkmm_reduction
from geomech.systems import (
    planar_point_masses,
    spacecraft_with_rotors,
    three_link_chain,
    two_pinned_bodies,
)


@pytest.fixture(scope="module")
def systems():
    return {
        "pinned": two_pinned_bodies(1.0, 3.0),
        "chain": three_link_chain(origin="middle"),
        "spacecraft": spacecraft_with_rotors(),
        "bodies": planar_point_masses([1.0, 2.0, 1.5]),
    }


def _direct_local_forms(red):
    """(I_loc, I_loc A_loc) by the direct route, at the chart's reference point g0: I_loc = Ad_g0^T I(g0, r) Ad_g0
    and I_loc A_loc rdot = Ad_g0^T J(g0, r; 0, rdot) (from J(g, r; g', r') = Ad_{g^-1}^T I_loc (g^-1 g' + A r'))."""
    s, G = red.system, red.system.group
    sub = dict(zip(G.coordinates, G.reference))
    Ad0 = G.Ad_matrix(G.matrix.subs(sub))
    I_sp = sp.Matrix(red.spatial_locked_inertia).subs(sub)
    J = sp.Matrix(red.momentum_map).subs(sub).subs({v: 0 for v in s.qdot[: s.k]})
    IA = sp.Matrix(s.k, s.sigma, lambda a, j: sp.diff(J[a], s.shape_dot[j]))
    return Ad0.T * I_sp * Ad0, Ad0.T * IA


@pytest.mark.parametrize("name", ["pinned", "chain", "spacecraft", "bodies"])
def test_theorem_2_1_read_off_equals_direct_construction(systems, name):
    # Locked inertia and I A from the momentum map and the infinitesimal generators (section 2.1)
    # must be the blocks of the reduced mass matrix (Theorem 2.1): the Hessian of l(r, xi, rdot).
    red = bkmm_reduction(systems[name])
    I, IA = _direct_local_forms(red)
    assert (I - red.locked_inertia_full).applyfunc(sp.simplify) == sp.zeros(*I.shape)
    assert (IA - red.coupling).applyfunc(sp.simplify) == sp.zeros(*IA.shape)


@pytest.mark.parametrize("name", ["pinned", "chain", "spacecraft", "bodies"])
def test_momentum_map_at_random_group_elements_is_carried_by_the_local_forms(systems, name, rng):
    # Away from the chart's reference point: the spatial momentum J = zeta_Q^T M qdot, from the full mass
    # matrix and the infinitesimal generators at g, must equal Ad_{g^-1}^T I_loc(r) (g^-1 g' + A_loc(r) r')
    # with I_loc, A_loc the numeric blocks of the reduced mass matrix (Theorem 2.1).
    s = systems[name]
    red = bkmm_reduction(s)
    c = red.numeric()
    G = s.group
    J = sp.lambdify(s.q + s.qdot, sp.Matrix(red.momentum_map).subs(s.parameter_values()))
    Ad_of = lambda *alpha: G.numeric.Ad(G.from_coordinates(alpha))  # noqa: E731  the numeric group, not the chart
    B = s.body_velocity_matrix_function
    for _ in range(4):
        alpha = rng.uniform(-1.2, 1.2, G.dim) + (np.array([0.0, 0.7, 0.0]) if isinstance(G.numeric, SO3) else 0.0)
        r = rng.uniform(-0.6, 0.6, s.sigma) + (0.8 if name == "bodies" else 0.0)
        ad, rd = rng.normal(size=G.dim), rng.normal(size=s.sigma)
        xi = B(alpha) @ ad
        body = c.locked_inertia(r) @ (xi + c.connection(r) @ rd)
        Ad_inv = np.linalg.inv(np.atleast_2d(np.array(Ad_of(*alpha), dtype=float)))
        want = Ad_inv.T @ body
        got = np.array(J(*alpha, *r, *ad, *rd), dtype=float).ravel()
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)
        # the numeric twin's spatial momentum from the full state
        q, qd = np.r_[alpha, r], np.r_[ad, rd]
        np.testing.assert_allclose(c.momentum_map(q, qd), want, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name", ["pinned", "bodies", "spacecraft"])
def test_murray_splitting_equals_reduced_lagrangian_symbolically(systems, name):
    s = systems[name]
    assert sp.simplify(bkmm_reduction(s).murray_lagrangian() - s.body_lagrangian) == 0


def test_murray_splitting_equals_full_lagrangian_numerically(systems, rng):
    # Murray's form with the numeric twin's I_loc, A and M(r) = m - A^T I A, in xi = B(alpha) alpha_dot, must equal
    # L(q, qdot) itself at random states (the chain: its symbolic connection takes minutes to simplify).
    s = systems["chain"]
    c = bkmm_reduction(s).numeric()
    full = sp.lambdify(s.q + s.qdot, s.lagrangian.subs(s.parameter_values()))
    B = s.body_velocity_matrix_function
    for _ in range(5):
        q, qd = rng.uniform(-1, 1, 5), rng.normal(size=5)
        xi, r, rd = B(q[:3]) @ qd[:3], q[3:], qd[3:]
        u = xi + c.connection(r) @ rd
        murray = u @ c.locked_inertia_full(r) @ u / 2 + rd @ c.shape_mass(r) @ rd / 2
        np.testing.assert_allclose(murray, full(*q, *qd), rtol=1e-12)


def test_murray_splitting_needs_no_constraints():
    from geomech.systems.nonholonomic_examples import chaplygin_sleigh

    with pytest.raises(InputError, match="Murray"):
        bkmm_reduction(chaplygin_sleigh()).murray_lagrangian()


def test_pinned_bodies_connection_is_the_seeds():
    red = bkmm_reduction(two_pinned_bodies(1.0, 3.0))
    c = red.numeric()
    I1, I2 = sp.symbols("I1 I2", real=True)
    assert sp.simplify(red.connection[0, 0] - I2 / (I1 + I2)) == 0
    np.testing.assert_allclose(c.connection(np.array([[0.1], [2.0]])), np.full((2, 1, 1), 0.75))
    np.testing.assert_allclose(c.curvature(np.array([0.3])), 0.0)


def test_horizontal_space_is_metric_orthogonal_to_the_orbits(systems, rng):
    # xi = -A rdot is horizontal: zero momentum, and (B^-1 xi, rdot) is M-orthogonal to every generator.
    for name in ("chain", "bodies", "spacecraft"):
        s = systems[name]
        red = bkmm_reduction(s)
        c = red.numeric()
        Xi = s.compile(sp.Matrix(red.generators), s.q)
        Mq = s.compile(s.mass_matrix, s.q)
        B = s.body_velocity_matrix_function
        for _ in range(3):
            alpha = rng.uniform(-1, 1, 3)
            alpha[1] = abs(alpha[1]) + 0.3 if isinstance(s.group.numeric, SO3) else alpha[1]
            r = rng.uniform(0.5, 1.2, s.sigma)
            rd = rng.normal(size=s.sigma)
            ad = np.linalg.solve(B(alpha), -c.connection(r) @ rd)
            q = np.concatenate([alpha, r])
            v = np.concatenate([ad, rd])
            np.testing.assert_allclose(Xi(q).T @ Mq(q) @ v, 0.0, atol=1e-11)
            np.testing.assert_allclose(c.momentum_map(q, v), 0.0, atol=1e-11)


@pytest.mark.parametrize("name", ["pinned", "spacecraft", "bodies"])
def test_symbolic_attributes_match_the_numeric_twin(systems, name, rng):
    # Two routes: the closed forms of the reduction (connection, curvature, shape metric, eqs. 1.1-1.3) and the
    # numeric twin, which solves the linear systems at each point from the Lagrangian's Hessian alone.
    s = systems[name]
    red = bkmm_reduction(s)
    c = red.numeric()
    pv = s.parameter_values()
    x = list(red.r) + list(red.rdot) + list(red.p)
    f = {
        n: sp.lambdify(x, sp.Matrix(e).subs(pv))
        for n, e in [
            ("A", red.connection),
            ("M", red.shape_mass),
            ("xi", red.reconstruction),
            ("pdot", red.momentum_rhs),
            ("delta", red.shape_forces),
        ]
    }
    for _ in range(3):
        r = rng.uniform(0.3, 1.2, s.sigma)
        rd, p = rng.normal(size=s.sigma), rng.normal(size=red.m)
        args = (*r, *rd, *p)
        scale = 1.0 + np.abs(c.delta(r, rd, p)).max()
        np.testing.assert_allclose(np.asarray(f["A"](*args), float), c.connection(r), atol=1e-12)
        np.testing.assert_allclose(np.asarray(f["M"](*args), float), c.shape_mass(r), atol=1e-12)
        np.testing.assert_allclose(np.asarray(f["xi"](*args), float).ravel(), c.xi(r, rd, p), atol=1e-12)
        np.testing.assert_allclose(np.asarray(f["pdot"](*args), float).ravel(), c.pdot(r, rd, p), atol=1e-12 * scale)
        np.testing.assert_allclose(np.asarray(f["delta"](*args), float).ravel(), c.delta(r, rd, p), atol=1e-12 * scale)
        B = np.stack([np.asarray(sp.lambdify(red.r, sp.Matrix(Ba).subs(pv))(*r), float) for Ba in red.curvature])
        np.testing.assert_allclose(B, c.curvature(r), atol=1e-12)


def test_curvature_of_a_constant_connection_is_the_bracket_term(systems, rng):
    s = systems["spacecraft"]
    red = bkmm_reduction(s)
    c = red.numeric()
    B = np.array([[float(sp.Matrix(Ba).subs(s.parameter_values())[0, 1])] for Ba in red.curvature]).ravel()
    A = c.connection(np.zeros(2))
    # A is constant: dA = 0 and the curvature is the bracket term alone, -A_1 x A_2 for so(3)
    np.testing.assert_allclose(B, -np.cross(A[:, 0], A[:, 1]), atol=1e-15)
    np.testing.assert_allclose(c.curvature_2d(rng.normal(size=(3, 2))), np.tile(B, (3, 1)), atol=1e-15)
    assert np.linalg.norm(B) > 1e-3


def _holonomy_about(system, r0, eps):
    """Holonomy of a circle of radius eps about r0, moved back to r0 along the radius (gauge covariant)."""
    G = system.group.numeric
    loop = Gait.ellipse(r0, [eps, eps], 1.0)

    class Segment:
        def r(self, t):
            return r0 + t * np.array([eps, 0.0])

        def rdot(self, t):
            return np.array([eps, 0.0])

    seg = reconstruct(system, Segment(), 0.0, t_eval=np.array([0.0, 1.0])).path.displacement()
    h = reconstruct(system, loop, 0.0, t_eval=np.array([0.0, 1.0])).path.displacement()
    h0 = G.compose(G.compose(seg, h), G.inverse(seg))
    return G.log(h0) / (np.pi * eps**2)


@pytest.mark.parametrize("name", ["chain", "spacecraft"])
def test_small_loop_holonomy_is_minus_the_curvature(systems, name):
    # The sign convention and the bracket term: hol = exp(-area B12) + O(eps^3) for a non-abelian G.
    s = systems[name]
    r0 = np.array([0.3, -0.4])
    B = bkmm_reduction(s).numeric().curvature_2d(r0)
    errs = []
    for eps in (4e-2, 2e-2):
        errs.append(np.abs(_holonomy_about(s, r0, eps) + B).max())
    assert errs[1] < 0.3 * errs[0] + 1e-9  # second order in eps
    assert errs[1] < 1e-3 * np.abs(B).max() + 1e-9


def test_curvature_rejects_non_2d_and_singular(systems):
    c = bkmm_reduction(systems["bodies"]).numeric()
    with pytest.raises(InputError, match="2-D"):
        c.curvature_2d(np.ones(3))
    with pytest.raises(SingularityError, match="singular"):
        c.connection(np.zeros(3))
    with pytest.raises(InputError, match="NonholonomicSystem"):
        bkmm_reduction("not a system")
