"""Angular velocity from Euler angles and their rates, for all 24 sequences: against central differences of
the rotation matrices (w^ = R' R^T in space, R^T R' in the body), eq. (3) of the Serret-Andoyer paper with its
corrected second component, and the inverse map with its gimbal singularity."""

import numpy as np
import pytest

from geomech.errors import SingularityError
from geomech.lie import euler, so3

SEQUENCES = euler.INTRINSIC_SEQUENCES + euler.EXTRINSIC_SEQUENCES


@pytest.mark.parametrize("seq", SEQUENCES)
def test_against_central_differences_of_the_matrices(seq):
    rng = np.random.default_rng(sum(map(ord, seq)))
    angles = rng.uniform(-2.0, 2.0, (5, 3))
    angles[:, 1] = rng.uniform(0.3, 1.2, 5)  # away from either kind of gimbal singularity
    rates = rng.normal(size=(5, 3))
    eps = 1e-6
    R = euler.as_matrix(angles, seq)
    Rdot = (euler.as_matrix(angles + eps * rates, seq) - euler.as_matrix(angles - eps * rates, seq)) / (2 * eps)
    space = so3.vee(Rdot @ np.swapaxes(R, -1, -2))
    body = so3.vee(np.swapaxes(R, -1, -2) @ Rdot)
    np.testing.assert_allclose(euler.angular_velocity(angles, rates, seq), space, rtol=0, atol=1e-8)
    np.testing.assert_allclose(euler.angular_velocity(angles, rates, seq, frame="body"), body, rtol=0, atol=1e-8)
    # and back: the rates from the angular velocity
    np.testing.assert_allclose(euler.euler_rates(angles, space, seq), rates, rtol=0, atol=1e-7)


def test_eq3_of_the_seed_with_its_second_component_corrected():
    phi, theta, psi = 0.4, 0.9, -1.3
    dphi, dtheta, dpsi = 0.7, -0.2, 1.1
    w = euler.angular_velocity([phi, theta, psi], [dphi, dtheta, dpsi], "ZXZ")
    corrected = [
        dtheta * np.cos(phi) + dpsi * np.sin(phi) * np.sin(theta),
        dtheta * np.sin(phi) - dpsi * np.cos(phi) * np.sin(theta),
        dphi + dpsi * np.cos(theta),
    ]
    np.testing.assert_allclose(w, corrected, rtol=0, atol=1e-15)
    printed_second = dtheta * np.sin(phi) + dpsi * np.cos(phi) * np.sin(theta)  # the printed sign
    assert abs(w[1] - printed_second) > 0.1


@pytest.mark.parametrize("seq, middle", [("ZXZ", 0.0), ("ZXZ", np.pi), ("ZYX", np.pi / 2), ("xyz", -np.pi / 2)])
def test_the_rates_are_not_determined_at_the_gimbal_singularity(seq, middle):
    with pytest.raises(SingularityError, match="gimbal singularity"):
        euler.euler_rates([0.3, middle, -0.2], [0.1, 0.2, 0.3], seq)
