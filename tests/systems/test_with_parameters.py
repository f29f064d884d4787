"""Parameters one way: every system has ``parameters`` (values by name) and ``with_parameters(**values)``, which
gives the same system as building it afresh with those values."""

import numpy as np
import pytest

from geomech import LeftInvariantSystem, RigidBody
from geomech.errors import InputError
from geomech.systems import RotorBody, StructurePreservingControl, two_pinned_bodies
from geomech.systems.nonholonomic_examples import chaplygin_sleigh


def test_rigid_body_with_other_moments_is_the_body_built_with_them(rng):
    body = RigidBody([3.0, 2.0, 1.5])
    assert body.parameters == {"I1": 3.0, "I2": 2.0, "I3": 1.5}
    other = body.with_parameters(I2=2.5)
    fresh = RigidBody([3.0, 2.5, 1.5])
    m = rng.normal(size=(5, 3))
    np.testing.assert_allclose(other.system.hamiltonian(m), fresh.system.hamiltonian(m), rtol=1e-14)
    assert not np.allclose(other.system.hamiltonian(m), body.system.hamiltonian(m))
    with pytest.raises(InputError, match=r"Unknown parameter\(s\) \['I4'\]"):
        body.with_parameters(I4=1.0)
    with pytest.raises(InputError, match="positive"):
        body.with_parameters(I1=-1.0)
    with pytest.raises(InputError, match="triangle"):
        body.with_parameters(I1=10.0)
    with pytest.raises(InputError, match="full inertia tensor"):
        RigidBody(np.array([[2.0, 0.1, 0.0], [0.1, 1.5, 0.0], [0.0, 0.0, 1.0]])).with_parameters(I1=2.0)


def test_rotor_body_with_other_inertias():
    body = RotorBody.one_rotor(3.0, 2.0, 1.0, 0.4)
    assert body.parameters == {"lambda1": 3.0, "lambda2": 2.0, "I3": 1.0, "J3": 0.4}
    other = body.with_parameters(lambda2=2.2, J3=0.5)
    fresh = RotorBody.one_rotor(3.0, 2.2, 1.0, 0.5)
    np.testing.assert_array_equal(other.locked_inertia, fresh.locked_inertia)
    assert not np.array_equal(other.locked_inertia, body.locked_inertia)
    # unspecified rotor inertias can be given, all at once
    bare = RotorBody.three_rotors([3.0, 2.0, 1.2])
    with pytest.raises(InputError, match="unspecified"):
        bare.with_parameters(J1=0.1)
    full = bare.with_parameters(J1=0.1, J2=0.15, J3=0.2)
    np.testing.assert_array_equal(full.rotor_inertia, [0.1, 0.15, 0.2])
    with pytest.raises(InputError, match="positive"):
        body.with_parameters(J3=0.0)


def test_control_with_other_values_is_the_control_built_with_them(rng):
    body = RotorBody.one_rotor(3.0, 2.0, 1.0, 0.4)
    control = StructurePreservingControl.one_rotor(body, "k*v + a*v**3", parameters={"k": 0.6, "a": 0.3}, p=0.05)
    assert control.parameters == {"lambda1": 3.0, "lambda2": 2.0, "I3": 1.0, "p": 0.05, "k": 0.6, "a": 0.3}
    other = control.with_parameters(k=0.8, p=0.1, lambda2=2.4)
    fresh = StructurePreservingControl.one_rotor(
        RotorBody.one_rotor(3.0, 2.4, 1.0, 0.4), "k*v + a*v**3", parameters={"k": 0.8, "a": 0.3}, p=0.1
    )
    m = rng.normal(size=(6, 3))
    np.testing.assert_allclose(other.closed_loop_hamiltonian(m), fresh.closed_loop_hamiltonian(m), rtol=1e-13)
    np.testing.assert_allclose(other.closed_loop_gradient(m), fresh.closed_loop_gradient(m), rtol=1e-13)
    assert not np.allclose(other.closed_loop_hamiltonian(m), control.closed_loop_hamiltonian(m))
    assert control.parameters["k"] == 0.6  # the original is unchanged
    with pytest.raises(InputError, match=r"Unknown parameter\(s\) \['b'\]"):
        control.with_parameters(b=1.0)
    with pytest.raises(InputError, match="positive"):
        control.with_parameters(lambda1=-3.0)


def test_three_rotor_control_with_parameters_keeps_its_existence_check():
    body = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.15, 0.2])
    control = StructurePreservingControl.three_rotors(
        body, ["3*c*m2", "2*c*m1", "k*m3"], parameters={"c": 0.2, "k": 0.4}
    )
    assert control.with_parameters(c=0.3).condition.holds
    # Lambda^-1 A Dphi stays symmetric only while lambda1 : lambda2 = 3 : 2; other values lose the closed loop
    with pytest.raises(InputError, match="no closed-loop Hamiltonian"):
        control.with_parameters(lambda1=2.5)


def test_every_kind_of_system_takes_with_parameters():
    # the same two calls on each kind: a reading of parameters, a new system with one of them changed
    systems = [
        LeftInvariantSystem.from_expression("m1**2/(2*a) + m2**2/4 + m3**2/2", {"a": 3.0}),
        two_pinned_bodies(1.0, 3.0),
        chaplygin_sleigh(m=1.0, I_c=0.2, a=0.3),
        RigidBody([3.0, 2.0, 1.5]),
        RotorBody.one_rotor(3.0, 2.0, 1.0, 0.4),
    ]
    for s in systems:
        name, value = next(iter(sorted(s.parameters.items())))
        other = s.with_parameters(**{name: value * 1.1})
        assert other.parameters[name] == pytest.approx(value * 1.1)
        assert s.parameters[name] == value


def test_a_canonical_system_takes_its_coordinates_by_name():
    import sympy as sp

    from geomech import CanonicalSystem
    from geomech.errors import InputError

    q, p = sp.symbols("q p", real=True)
    by_name = CanonicalSystem.from_expression("p**2/2 + q**4/4", ["q"], ["p"])
    by_symbol = CanonicalSystem.from_expression(p**2 / 2 + q**4 / 4, [q], [p])
    assert by_name.expression == by_symbol.expression
    with pytest.raises(InputError, match="q_symbols"):
        CanonicalSystem.from_expression("p**2/2", ["q x"], ["p"])
