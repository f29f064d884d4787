"""Unit quaternions against scipy.spatial.transform.Rotation (an independent implementation)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from geomech.errors import InputError, ShapeError
from geomech.lie import quaternion as quat
from geomech.lie import so3

SETTINGS = settings(max_examples=25, deadline=None)
seeds = st.integers(0, 2**32 - 1)


def xyzw_to_wxyz(q):
    return np.roll(q, 1, axis=-1)


def same_rotation(q, r, atol=1e-12):
    """q and r are equal up to the sign of the double cover."""
    return np.allclose(np.abs(np.einsum("...i,...i->...", q, r)), 1.0, atol=atol)


@SETTINGS
@given(seed=seeds)
def test_as_matrix_matches_scipy_both_orders(seed):
    q = quat.random(seed, size=20)
    expected = Rotation.from_quat(np.roll(q, -1, axis=-1)).as_matrix()
    np.testing.assert_allclose(quat.as_matrix(q), expected, atol=1e-14)
    np.testing.assert_allclose(quat.as_matrix(np.roll(q, -1, axis=-1), scalar_first=False), expected, atol=1e-14)


@SETTINGS
@given(seed=seeds)
def test_from_matrix_matches_scipy_and_has_nonnegative_scalar(seed):
    R = so3.random(seed, size=20)
    q = quat.from_matrix(R)
    assert np.all(q[..., 0] >= 0)
    assert same_rotation(q, xyzw_to_wxyz(Rotation.from_matrix(R).as_quat()))
    np.testing.assert_allclose(quat.as_matrix(q), R, atol=1e-14)
    np.testing.assert_allclose(quat.from_matrix(R, scalar_first=False), np.roll(q, -1, axis=-1), atol=0)


@pytest.mark.parametrize(
    "v",
    [
        [0.0, 0.0, 0.0],
        [1e-12, 0.0, 0.0],
        [np.pi, 0.0, 0.0],  # each Shepperd branch: w, x, y, z largest
        [0.0, np.pi, 0.0],
        [0.0, 0.0, np.pi],
        [np.pi - 1e-9, 0.0, 0.0],
        [2.0, -2.0, 1.0],
        [-1e-8, 3e-8, 0.0],
    ],
)
def test_from_matrix_for_every_branch(v):
    R = Rotation.from_rotvec(v).as_matrix()
    q = quat.from_matrix(R)
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-15)
    assert same_rotation(q, xyzw_to_wxyz(Rotation.from_matrix(R).as_quat()), atol=1e-15)
    np.testing.assert_allclose(quat.as_matrix(q), R, atol=1e-15)
    assert q[0] >= 0


@SETTINGS
@given(seed=seeds)
def test_multiply_is_a_homomorphism_and_matches_scipy(seed):
    rng = np.random.default_rng(seed)
    q, r = quat.random(rng, size=(2, 10))
    pq = quat.multiply(q, r)
    np.testing.assert_allclose(quat.as_matrix(pq), quat.as_matrix(q) @ quat.as_matrix(r), atol=1e-14)
    ref = (Rotation.from_quat(np.roll(q, -1, -1)) * Rotation.from_quat(np.roll(r, -1, -1))).as_quat()
    assert same_rotation(pq, xyzw_to_wxyz(ref))
    np.testing.assert_allclose(
        quat.multiply(np.roll(q, -1, -1), np.roll(r, -1, -1), scalar_first=False), np.roll(pq, -1, -1), atol=1e-15
    )


def test_hamilton_convention_i_j_is_k():
    i, j, k = np.eye(4)[1], np.eye(4)[2], np.eye(4)[3]
    np.testing.assert_array_equal(quat.multiply(i, j), k)
    np.testing.assert_array_equal(quat.multiply(j, i), -k)


@SETTINGS
@given(seed=seeds)
def test_double_cover_and_inverse(seed):
    q = quat.random(seed, size=10)
    np.testing.assert_allclose(quat.as_matrix(-q), quat.as_matrix(q), atol=0)
    np.testing.assert_allclose(quat.from_matrix(quat.as_matrix(-q)), quat.from_matrix(quat.as_matrix(q)), atol=1e-15)
    np.testing.assert_allclose(quat.multiply(q, quat.inverse(q)), quat.identity(10), atol=1e-15)
    np.testing.assert_allclose(quat.as_matrix(quat.conjugate(q)), np.swapaxes(quat.as_matrix(q), -1, -2), atol=1e-15)
    p = 3.0 * q
    np.testing.assert_allclose(quat.multiply(quat.inverse(p), p), quat.identity(10), atol=1e-14)
    np.testing.assert_allclose(quat.normalize(p), q, atol=1e-15)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1.0, np.pi - 1e-6, np.pi - 1e-10])
def test_exp_log_consistent_with_so3_and_scipy(angle):
    rng = np.random.default_rng(8)
    axes = rng.normal(size=(5, 3))
    v = angle * axes / np.linalg.norm(axes, axis=-1, keepdims=True)
    q = quat.exp(v)
    np.testing.assert_allclose(quat.as_matrix(q), so3.exp(v), atol=1e-15)
    assert same_rotation(q, xyzw_to_wxyz(Rotation.from_rotvec(v).as_quat()), atol=1e-15)
    np.testing.assert_allclose(quat.log(q), v, atol=1e-12)
    np.testing.assert_allclose(quat.log(q), so3.log(so3.exp(v)), atol=1e-12)
    np.testing.assert_allclose(quat.as_rotvec(q), Rotation.from_rotvec(v).as_rotvec(), atol=1e-12)
    np.testing.assert_array_equal(quat.from_rotvec(v), q)


def test_log_chooses_the_short_way():
    v = np.array([0.0, 0.0, 1.5 * np.pi])  # the same rotation as -pi/2 about z
    np.testing.assert_allclose(quat.log(quat.exp(v)), [0.0, 0.0, -0.5 * np.pi], atol=1e-15)


def test_non_unit_quaternion_is_rejected_with_its_norm():
    with pytest.raises(InputError, match=r"unit quaternion .*got norm 1\.1\. .*normalize"):
        quat.as_matrix([1.1, 0.0, 0.0, 0.0])
    q = quat.random(0, size=(3, 4))
    q[1, 2] *= 0.5
    with pytest.raises(InputError, match=r"1 of 12 with another norm, the worst norm 0\.5 at batch index \(1, 2\)"):
        quat.as_matrix(q)
    np.testing.assert_allclose(quat.as_matrix([1.0 + 1e-10, 0, 0, 0]), np.eye(3), atol=1e-9)
    with pytest.raises(InputError, match="non-zero"):
        quat.normalize(np.zeros(4))


def test_shape_error():
    with pytest.raises(ShapeError, match=r"^Expected `q` to have shape \(\.\.\., 4\), got \(3,\)\.$"):
        quat.as_matrix([1.0, 0.0, 0.0])
