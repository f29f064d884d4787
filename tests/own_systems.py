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
