"""Systems of the tests' own (not among the package's examples), shared by the tests that check a construction on
a system the package was not written around."""

import numpy as np
import sympy as sp

from geomech.lie import SO3
from geomech.symbolic import group_chart
from geomech.systems import NonholonomicSystem

#: The inertia of :func:`suslov_with_rotor`'s body, not aligned with its constraint.
SUSLOV_INERTIA = np.array([[2.0, 0.0, 0.4], [0.0, 1.5, 0.0], [0.4, 0.0, 1.0]])
#: The inertia of its rotor, spinning about the body axis 1.
SUSLOV_ROTOR = 0.3


def knife_edge_with_rotor() -> NonholonomicSystem:
    """A knife edge on SE(2) carrying a rotor (shape phi) coupled to the heading, in a potential."""
    return NonholonomicSystem.from_lagrangian(
        "m*(x_dot**2 + y_dot**2)/2 + J*theta_dot**2/2 + k*phi_dot**2/2 + c*theta_dot*phi_dot - e*cos(phi)",
        "SE2",
        ["phi"],
        ["-sin(theta)*x_dot + cos(theta)*y_dot"],
        parameters={"m": 1.3, "J": 0.7, "k": 0.4, "c": 0.1, "e": 0.3},
        name="knife edge with rotor",
    )


def suslov_with_rotor() -> NonholonomicSystem:
    """Suslov's body on SO(3) in the 3-1-3 Euler-angle chart (angular velocity about the body axis 3 forbidden)
    carrying a rotor (shape psi) about the body axis 1."""
    G = group_chart(SO3("a", "b", "c"))
    qdot = sp.Matrix(sp.symbols("a_dot b_dot c_dot"))
    omega = G.body_velocity_matrix * qdot
    psid = sp.Symbol("psi_dot")
    L = (omega.T * sp.Matrix(SUSLOV_INERTIA) * omega)[0] / 2 + sp.Rational(3, 10) / 2 * (psid + omega[0]) ** 2
    return NonholonomicSystem.from_lagrangian(sp.nsimplify(L), G, ("psi",), [omega[2]], name="suslov_rotor")


def free_body_in_euler_angles(inertia=(3, 2, 1)) -> NonholonomicSystem:
    """The free rigid body as a Lagrangian system on SO(3) in the 3-1-3 Euler angles: no shape, no constraint."""
    G = group_chart(SO3("a", "b", "c"))
    omega = G.body_velocity_matrix * sp.Matrix(sp.symbols("a_dot b_dot c_dot"))
    L = (omega.T * sp.diag(*[sp.nsimplify(float(i)) for i in inertia]) * omega)[0] / 2
    return NonholonomicSystem.from_lagrangian(L, G, (), [], name="free body (Euler angles)")


def skate_in_space(mass=1.5, inertia=(0.4, 0.7, 0.9), blade=True) -> NonholonomicSystem:
    """A rigid body in space on SE(3) (position and Z-Y-X angles) that cannot slide along its body axis 2 (without
    ``blade``: the free body): the constraint is on the body velocity, hence invariant under the group, as is the
    kinetic energy."""
    from geomech.lie import SE3

    G = group_chart(SE3("x", "y", "z", "yaw", "pitch", "roll"))
    qdot = sp.Matrix(sp.symbols("x_dot y_dot z_dot yaw_dot pitch_dot roll_dot"))
    xi = G.body_velocity_matrix * qdot  # (v, omega) in the body frame
    v, omega = xi[:3, :], xi[3:, :]
    m = sp.nsimplify(mass)
    L = m / 2 * (v.T * v)[0] + (omega.T * sp.diag(*[sp.nsimplify(i) for i in inertia]) * omega)[0] / 2
    name = "skate in space" if blade else "free body in space"
    return NonholonomicSystem.from_lagrangian(L, G, (), [xi[1]] if blade else [], name=name)


def rolling_disk(R=0.5, m=2.0, J=0.3, I=0.25) -> NonholonomicSystem:
    """The vertical disk rolling without slipping on SE(2) x S^1: position and heading (x, y, phi), the rolling
    angle theta; no shape. The heading and rolling rates are constant and the contact point moves on a circle."""
    from geomech.lie import SE2, SO2

    G = group_chart(SE2("x", "y", "phi") * SO2("theta"))
    xd, yd, phid, thd = sp.symbols("x_dot y_dot phi_dot theta_dot")
    phi = sp.Symbol("phi")
    r, mm, JJ, II = (sp.nsimplify(a) for a in (R, m, J, I))
    L = mm / 2 * (xd**2 + yd**2) + JJ / 2 * phid**2 + II / 2 * thd**2
    constraints = [xd - r * sp.cos(phi) * thd, yd - r * sp.sin(phi) * thd]
    return NonholonomicSystem.from_lagrangian(L, G, (), constraints, name="rolling disk")


def planar_body_with_arm() -> NonholonomicSystem:
    """A body translating in the plane and turning freely on R^2 x S^1, carrying an arm (shape r) whose motion
    drives the translation x by the constraint x' = cos(r) r' and is coupled to the turning by the inertia."""
    from geomech.lie import SO2, Rn

    G = group_chart(Rn("x", "y") * SO2("th"))
    xd, yd, thd, rd = sp.symbols("x_dot y_dot th_dot r_dot")
    r = sp.Symbol("r")
    L = (xd**2 + yd**2) + sp.Rational(3, 5) / 2 * thd**2 + rd**2 / 2 + sp.Rational(1, 5) * sp.cos(r) * thd * rd
    return NonholonomicSystem.from_lagrangian(L, G, ("r",), [xd - sp.cos(r) * rd], name="planar body with arm")
