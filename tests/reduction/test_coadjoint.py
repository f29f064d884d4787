"""The reduced phase space as objects (sections 5.1-5.2 of the Serret-Andoyer paper): the stationary subgroup of
the momentum (Proposition 1, against the coadjoint action of the group hierarchy), the Kostant-Kirillov forms
(eq. 19, against its v, w form), and the pull-back that makes the Serret-Andoyer variables canonical
(Proposition 3) where spherical coordinates are not."""

import numpy as np
import pytest
import sympy as sp

from geomech.errors import InputError
from geomech.lie import SO3, so3
from geomech.reduction import CoadjointOrbit, SerretAndoyerChart, StationarySubgroup
from geomech.reduction.serret_andoyer import G_SYM, L_SYM, l_SYM

RNG = np.random.default_rng(11)


def coadjoint(R, p):
    """Ad*_{R^-1} p = (Ad_{R^-1})^T p, from the group's adjoint representation."""
    return SO3().Ad(np.swapaxes(R, -1, -2)).swapaxes(-1, -2) @ p


def test_the_stationary_subgroup_is_the_rotations_about_p():
    p = np.array([0.3, -1.1, 0.7])
    group = StationarySubgroup(p)
    angles = RNG.uniform(-np.pi, np.pi, 7)
    R = group.element(angles)
    np.testing.assert_allclose(coadjoint(R, p), np.broadcast_to(p, (7, 3)), rtol=0, atol=1e-14)
    assert group.contains(R).all()
    # a rotation with a component about any other axis moves p
    other = so3.exp(np.cross(p, [1.0, 0.0, 0.0]) * 0.05) @ R
    assert not group.contains(other).any()
    assert np.abs(coadjoint(other, p) - p).max() > 1e-3
    # and a rotation that keeps p is one of the group: its axis is p's
    axes = so3.log(R)
    np.testing.assert_allclose(np.cross(axes, group.axis), 0.0, atol=1e-13)
    with pytest.raises(InputError, match="nonzero"):
        StationarySubgroup([0.0, 0.0, 0.0])


def test_the_kostant_kirillov_forms_are_eq_19():
    G = 1.7
    orbit = CoadjointOrbit(G)
    m = RNG.normal(size=(6, 3))
    m *= G / np.linalg.norm(m, axis=-1, keepdims=True)
    v, w = RNG.normal(size=(6, 3)), RNG.normal(size=(6, 3))
    a, b = orbit.tangent(m, v), orbit.tangent(m, w)
    left = orbit.kostant_kirillov(m, a, b)
    np.testing.assert_allclose(left, -np.einsum("ni,ni->n", m, np.cross(v, w)), rtol=1e-12, atol=0)
    np.testing.assert_allclose(orbit.kostant_kirillov(m, a, b, "+"), -left, rtol=0, atol=0)
    np.testing.assert_allclose(orbit.kostant_kirillov(m, b, a), -left, rtol=0, atol=1e-15)  # antisymmetric
    assert np.abs(left).min() > 1e-6  # nondegenerate on independent tangents
    with pytest.raises(InputError, match="tangent"):
        orbit.kostant_kirillov(m[0], m[0], b[0])
    with pytest.raises(InputError, match="sphere"):
        orbit.kostant_kirillov(2 * m[0], a[0], b[0])


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_the_serret_andoyer_charts_are_canonical_for_the_left_form(axis):
    chart = SerretAndoyerChart(axis)
    assert CoadjointOrbit.pullback(chart.U_p, (l_SYM, L_SYM)) == 1
    assert CoadjointOrbit.pullback(chart.U_p, (l_SYM, L_SYM), "+") == -1
    # the same numerically, from the chart's own tangent vectors
    G = 1.3
    lL = np.stack([RNG.uniform(-3, 3, 20), RNG.uniform(-1.2, 1.2, 20)], -1)
    dl, dL = chart.tangents(lL, G)
    np.testing.assert_allclose(CoadjointOrbit(G).kostant_kirillov(chart.inverse(lL, G), dl, dL), 1.0, atol=1e-12)


def test_spherical_coordinates_are_not_canonical_and_archimedes_are():
    theta, phi, z = sp.symbols("theta phi z", real=True)
    G = G_SYM
    spherical = G * sp.Matrix([sp.sin(theta) * sp.cos(phi), sp.sin(theta) * sp.sin(phi), sp.cos(theta)])
    area = CoadjointOrbit.pullback(spherical, (theta, phi))
    assert sp.simplify(area + G * sp.sin(theta)) == 0  # the area element, not 1
    s = sp.sqrt(G**2 - z**2)
    cylinder = sp.Matrix([s * sp.cos(phi), s * sp.sin(phi), z])
    assert CoadjointOrbit.pullback(cylinder, (z, phi)) == 1  # height and longitude: canonical


def test_the_projection_of_the_level_set_is_the_body_momentum():
    orbit = CoadjointOrbit(2.0)
    R = so3.exp(RNG.normal(size=(4, 3)))
    p = np.array([0.0, 0.0, 2.0])
    m = np.einsum("nji,j->ni", R, p)  # m = R^T p: on the level set J(R, m) = R m = p
    np.testing.assert_allclose(orbit.project(R, m), m)
    assert orbit.contains(m).all()
    with pytest.raises(InputError, match="level set"):
        orbit.project(R, 1.1 * m)
