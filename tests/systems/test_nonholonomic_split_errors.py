"""A shape/group split that does not match the Lagrangian is named as such, not as a symptom."""

import pytest

from geomech.errors import InputError, SymbolicError
from geomech.lie import S1, SE2
from geomech.systems.nonholonomic import NonholonomicSystem

L = "m/2*(x_dot**2 + y_dot**2) + I/2*theta_dot**2"
BLADE = "-sin(theta)*x_dot + cos(theta)*y_dot"


def test_an_undeclared_velocity_in_a_constraint_is_a_split_error():
    # psi is neither a group coordinate nor a shape variable: its velocity would otherwise read as a
    # parameter and the constraint as "not homogeneous"
    with pytest.raises(InputError, match=r"\['psi_dot'\].*shape/group split"):
        NonholonomicSystem.from_lagrangian(
            L, SE2("x", "y", "theta"), (), [BLADE + " + a*psi_dot"], parameters={"m": 1, "I": 1, "a": 1}
        )


def test_a_group_factor_the_lagrangian_ignores_is_named():
    with pytest.raises(SymbolicError, match=r"\['alpha'\] appear nowhere in the Lagrangian"):
        NonholonomicSystem.from_lagrangian(
            L, SE2("x", "y", "theta") * S1("alpha"), (), [BLADE], parameters={"m": 1, "I": 1}
        )


def test_a_genuinely_nonhomogeneous_constraint_is_still_called_so():
    with pytest.raises(InputError, match="velocity-free term"):
        NonholonomicSystem.from_lagrangian(
            L, SE2("x", "y", "theta"), (), [BLADE + " + c"], parameters={"m": 1, "I": 1, "c": 1}
        )
