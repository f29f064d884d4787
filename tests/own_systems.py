"""Systems of the tests' own (not among the package's examples), shared by the tests that check a construction on
a system the package was not written around."""

from geomech.systems import NonholonomicSystem


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
