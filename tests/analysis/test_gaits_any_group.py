"""Gaits of nonholonomic systems on groups without closed forms here (SE(3), products): the reconstruction
on the group (the generic matrix group) against the full constrained simulation in the chart."""

import numpy as np
import pytest
import sympy as sp

from geomech import solve
from geomech.analysis.gaits import analyse_gait
from geomech.integrators import LagrangeDAlembert
from geomech.lie import S1, SE2, SE3
from geomech.symbolic import group_chart
from geomech.systems.nonholonomic import NonholonomicSystem
from geomech.systems.nonholonomic_examples import snakeboard_bkmm


def _sleigh_with_rotor() -> NonholonomicSystem:
    """A body in space that may only move along its body x axis, carrying a rotor about its body z axis."""
    G = SE3("x", "y", "z", "a1", "a2", "a3")
    xi = group_chart(G).body_velocity_matrix * sp.Matrix(sp.symbols("x_dot y_dot z_dot a1_dot a2_dot a3_dot"))
    v, w = xi[:3, 0], xi[3:, 0]
    vc = v + w.cross(sp.Matrix([sp.Rational(2, 5), 0, sp.Rational(1, 10)]))
    psid = sp.Symbol("psi_dot")
    L = (
        vc.dot(vc)
        + (w.T * sp.diag(sp.Rational(1, 2), sp.Rational(4, 5), 1) * w)[0] / 2
        + sp.Rational(3, 10) / 2 * (psid + w[2]) ** 2
    )
    return NonholonomicSystem.from_lagrangian(L, G, ("psi",), [v[1], v[2]], name="sleigh3d_rotor")


@pytest.mark.slow
def test_gait_on_se3_matches_the_full_simulation():
    s = _sleigh_with_rotor()
    gait = {"psi": "1.5*sin(2*pi*t/T)"}
    p0 = [0.6, 0.2, -0.3, 0.1]
    a = analyse_gait(s, gait, period=1.0, periods=2, p0=p0, samples_per_period=41)
    assert a.model.group.name.startswith("SE(3)")
    tr = solve(
        s,
        LagrangeDAlembert(),
        t_final=a.t[-1],
        saveat=a.t,
        shapes={"psi": "1.5*sin(2*pi*t)"},
        p0=p0,
        rtol=1e-12,
        atol=1e-13,
    )
    np.testing.assert_allclose(a.path.g, tr.g, atol=1e-8)
    np.testing.assert_allclose(a.p, tr.p, atol=1e-8)
    # the displacement as a group element equals the chart's, and the net motion is not trivial
    G = a.model.group
    d = a.displacement()
    np.testing.assert_allclose(G.from_coordinates(a.net_displacement), d, atol=1e-10)
    assert np.abs(a.net_displacement).max() > 0.05


def test_product_group_gait_agrees_with_the_full_simulation():
    # the snakeboard with its rotor angle as a symmetry (L and the constraints do not depend on psi):
    # group SE(2) x S^1, shape phi alone; with momentum the steering loop moves it
    base = snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)
    G = SE2("x", "y", "theta") * S1("psi")
    s = NonholonomicSystem.from_lagrangian(
        base.lagrangian,
        G,
        ("phi",),
        list(base.constraint_matrix * sp.Matrix(base.qdot)),
        parameters=dict(base.parameters),
        name="snakeboard_rotor_group",
    )
    a = analyse_gait(s, {"phi": "0.5*sin(2*pi*t/T)"}, period=1.0, periods=2, p0=[0.4, 0.3], samples_per_period=41)
    assert a.model.group.name == "SE(2) x SO(2)"
    tr = solve(
        s,
        LagrangeDAlembert(),
        t_final=a.t[-1],
        saveat=a.t,
        shapes={"phi": "0.5*sin(2*pi*t)"},
        p0=[0.4, 0.3],
        rtol=1e-12,
        atol=1e-13,
    )
    np.testing.assert_allclose(a.path.g, tr.g, atol=1e-8)
    assert np.ptp(tr.q[:, 0]) > 0.05
