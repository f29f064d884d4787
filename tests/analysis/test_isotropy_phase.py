"""Theorem 2.2 with a circle isotropy on SO(3) with shape variables: the phase about the spatial momentum, split as
geometric + dynamic, against the direct reconstruction on the group and, with the shapes held still, against
Montgomery's formula for the free rigid body (computed through the Serret-Andoyer variables)."""

from __future__ import annotations

import numpy as np
import pytest

from geomech.analysis import gait_loop, reconstruct, rigid_body_phase
from geomech.analysis.isotropy_phase import isotropy_phase, periodic_body_momentum
from geomech.errors import InputError
from geomech.lie import so3
from geomech.systems import RigidBody
from geomech.systems.holonomic_examples import spacecraft_with_rotors, two_pinned_bodies

LOOP = {"varphi1": "2.0*sin(2*pi*t/T)", "varphi2": "1.5*sin(2*pi*t/T + 1.1)"}


def _direct_angle(system, loop, period, Pi0):
    """The rotation R(T) R(0)^-1 about mu = Pi0 (R(0) the identity), from the reconstruction on the group (RKMK):
    its angle and how far its axis is from mu."""
    rec = reconstruct(system, gait_loop(system, loop, period), mu=Pi0)
    R = rec.path.element
    v = so3.log(R[-1] @ R[0].T)
    mu_hat = Pi0 / np.linalg.norm(Pi0)
    return float(v @ mu_hat), float(np.linalg.norm(v - (v @ mu_hat) * mu_hat))


@pytest.mark.parametrize("guess", [[1.0, 0.1, 0.05], [0.05, 0.1, -1.0]])
def test_phase_is_the_rotation_about_the_momentum_found_by_reconstruction(guess):
    s = spacecraft_with_rotors()
    Pi0 = periodic_body_momentum(s, LOOP, guess, period=2.0)
    phase = isotropy_phase(s, LOOP, Pi0, period=2.0)
    assert phase.closure < 1e-10
    assert abs(phase.geometric) > 1e-3 and abs(phase.dynamic) > 1e-2  # both parts matter, far above the tolerance
    angle, off_axis = _direct_angle(s, LOOP, 2.0, Pi0)
    assert off_axis < 1e-9  # R(T) R(0)^-1 fixes mu
    np.testing.assert_allclose(angle, phase.total_wrapped, atol=1e-9)


def test_with_the_shapes_still_it_is_montgomerys_formula_for_the_free_body():
    # rotors locked: a rigid body with the locked inertia; over one period of its motion Pi returns
    s = spacecraft_with_rotors(inertia=(3.0, 2.0, 1.0))
    m0 = np.array([0.3, 1.0, 0.2])
    montgomery = rigid_body_phase(RigidBody([3.0, 2.0, 1.0]), m0, direct=False, reconstructed=False)
    still = {"varphi1": "0", "varphi2": "0"}
    phase = isotropy_phase(s, still, m0, period=montgomery.period)
    np.testing.assert_allclose(phase.dynamic, montgomery.dynamic, rtol=1e-10)
    np.testing.assert_allclose(phase.connection_term, 0.0, atol=1e-14)
    np.testing.assert_allclose(np.exp(1j * phase.total), np.exp(1j * montgomery.total), atol=1e-9)
    np.testing.assert_allclose(
        np.exp(0.5j * phase.solid_angle), np.exp(0.5j * montgomery.solid_angle), atol=1e-9
    )  # the solid angle mod 4 pi


def test_refusals():
    s = spacecraft_with_rotors()
    with pytest.raises(InputError, match="nonzero"):
        isotropy_phase(s, LOOP, [0.0, 0.0, 0.0], period=2.0)
    with pytest.raises(InputError, match="does not return"):
        isotropy_phase(s, LOOP, [1.0, 0.1, 0.05], period=2.0)
    with pytest.raises(InputError, match="SO\\(3\\)"):
        isotropy_phase(two_pinned_bodies(), {"psi": "sin(2*pi*t/T)"}, [1.0, 0.0, 0.0], period=1.0)
