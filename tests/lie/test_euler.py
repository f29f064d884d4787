"""Euler angles: all 24 sequences against scipy, the seed's eq. (1), and gimbal lock detection."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from geomech.errors import InputError, ShapeError, SingularityError
from geomech.lie import euler, so3

ALL = euler.INTRINSIC_SEQUENCES + euler.EXTRINSIC_SEQUENCES


def test_the_twelve_and_twelve():
    assert len(set(euler.INTRINSIC_SEQUENCES)) == 12 and len(set(euler.EXTRINSIC_SEQUENCES)) == 12
    proper = [s for s in euler.INTRINSIC_SEQUENCES if euler.is_proper(s)]
    assert sorted(proper) == ["XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ"]


def regular_angles(seq: str, n: int, rng: np.random.Generator, margin: float = 0.05) -> np.ndarray:
    """Angles in the canonical ranges, at least ``margin`` from the gimbal singularity."""
    a = rng.uniform(-np.pi, np.pi, size=(n, 3))
    if euler.is_proper(seq):
        a[:, 1] = rng.uniform(margin, np.pi - margin, size=n)
    else:
        a[:, 1] = rng.uniform(-np.pi / 2 + margin, np.pi / 2 - margin, size=n)
    return a


@pytest.mark.parametrize("seq", ALL)
def test_as_matrix_matches_scipy(seq):
    rng = np.random.default_rng(0)
    angles = rng.uniform(-7, 7, size=(30, 3))
    np.testing.assert_allclose(euler.as_matrix(angles, seq), Rotation.from_euler(seq, angles).as_matrix(), atol=1e-14)


@pytest.mark.parametrize("seq", ALL)
def test_from_matrix_round_trip_and_scipy_agree_away_from_singularity(seq):
    rng = np.random.default_rng(1)
    angles = regular_angles(seq, 50, rng)
    R = euler.as_matrix(angles, seq)
    back = euler.from_matrix(R, seq)
    np.testing.assert_allclose(back, angles, atol=1e-12)
    np.testing.assert_allclose(back, Rotation.from_matrix(R).as_euler(seq), atol=1e-10)


@pytest.mark.parametrize("seq", ALL)
def test_ranges_for_arbitrary_rotations(seq):
    angles = euler.from_matrix(so3.random(2, size=300), seq)
    assert np.all(angles[:, [0, 2]] > -np.pi) and np.all(angles[:, [0, 2]] <= np.pi)
    lo, hi = (0.0, np.pi) if euler.is_proper(seq) else (-np.pi / 2, np.pi / 2)
    assert np.all(angles[:, 1] >= lo) and np.all(angles[:, 1] <= hi)


def seed_eq_1(phi, theta, psi):
    """Eq. (1) of the Serret-Andoyer paper, written out entry by entry."""
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    return np.array(
        [
            [cp * cf - ct * sf * sp, -sp * cf - ct * sf * cp, st * sf],
            [cp * sf + ct * cf * sp, -sp * sf + ct * cf * cp, -st * cf],
            [st * sp, st * cp, ct],
        ]
    )


def test_zxz_is_the_seed_eq_1_and_maps_body_to_space():
    rng = np.random.default_rng(3)
    for phi, theta, psi in rng.uniform(-3, 3, size=(20, 3)):
        R = euler.as_matrix([phi, theta, psi], "ZXZ")
        np.testing.assert_allclose(R, seed_eq_1(phi, theta, psi), atol=1e-15)
        np.testing.assert_allclose(R, so3.rot_z(phi) @ so3.rot_x(theta) @ so3.rot_z(psi), atol=1e-15)
    # the body axis b3 = R e3 is at polar angle theta from s3, with azimuth phi - pi/2 (line of nodes at phi)
    phi, theta, psi = 0.4, 0.9, -1.2
    b3 = euler.as_matrix([phi, theta, psi]) @ [0, 0, 1.0]
    expected = [np.sin(theta) * np.sin(phi), -np.sin(theta) * np.cos(phi), np.cos(theta)]
    np.testing.assert_allclose(b3, expected, atol=1e-15)


def test_intrinsic_is_extrinsic_reversed():
    a = np.array([0.3, -1.1, 2.0])
    np.testing.assert_allclose(euler.as_matrix(a, "ZYX"), euler.as_matrix(a[::-1], "xyz"), atol=1e-15)


# -- gimbal lock -----------------------------------------------------------------------------------------

ZXZ_CASES = [0.0, 1e-8, np.pi - 1e-6, np.pi]


@pytest.mark.parametrize("theta", ZXZ_CASES)
def test_zxz_at_and_near_the_singularity(theta):
    phi, psi = 0.7, -2.1
    R = seed_eq_1(phi, theta, psi)
    margin = min(theta, np.pi - theta)
    assert euler.gimbal_margin(R, "ZXZ") == pytest.approx(margin, rel=1e-6, abs=1e-15)
    if margin <= np.sqrt(np.finfo(float).eps):
        with pytest.raises(SingularityError, match="on_singular='resolve'"):
            euler.from_matrix(R, "ZXZ")
        got = euler.from_matrix(R, "ZXZ", on_singular="resolve")
        assert got[2] == 0.0
        # exact at the singularity, within the band width (~1e-8) just inside it
        np.testing.assert_allclose(euler.as_matrix(got, "ZXZ"), R, atol=1e-14 if margin == 0 else 5e-8)
        expected_first = phi + psi if theta < 1 else phi - psi
        assert np.isclose(np.cos(got[0] - expected_first), 1.0, atol=1e-14)
    else:
        got = euler.from_matrix(R, "ZXZ")
        # a and c individually are conditioned like 1/margin; the matrix is reproduced to round-off
        np.testing.assert_allclose(got, [phi, theta, psi], atol=1e-9)
        np.testing.assert_allclose(euler.as_matrix(got, "ZXZ"), R, atol=1e-15)
    assert np.all(np.isfinite(euler.from_matrix(R, "ZXZ", on_singular="resolve")))


@pytest.mark.parametrize("margin", [1e-12, 1e-9, 1e-6])
@pytest.mark.parametrize("seq", ["ZXZ", "zyz", "ZYX", "xzy"])
def test_accurate_near_the_singularity_with_tol_zero(seq, margin):
    rng = np.random.default_rng(4)
    angles = regular_angles(seq, 20, rng)
    ends = (margin, np.pi - margin) if euler.is_proper(seq) else (-np.pi / 2 + margin, np.pi / 2 - margin)
    for b in ends:
        angles[:, 1] = b
        R = euler.as_matrix(angles, seq)
        got = euler.from_matrix(R, seq, tol=0.0)
        np.testing.assert_allclose(euler.as_matrix(got, seq), R, atol=2e-15)
        np.testing.assert_allclose(got[:, 1], b, atol=1e-15)
        np.testing.assert_allclose(euler.gimbal_margin(R, seq), margin, rtol=1e-3)


@pytest.mark.parametrize("seq", ALL)
def test_resolve_at_exact_singularity_for_every_sequence(seq):
    rng = np.random.default_rng(5)
    angles = regular_angles(seq, 10, rng)
    ends = (0.0, np.pi) if euler.is_proper(seq) else (-np.pi / 2, np.pi / 2)
    for b in ends:
        angles[:, 1] = b
        R = euler.as_matrix(angles, seq)
        with pytest.raises(SingularityError):
            euler.from_matrix(R, seq)
        got = euler.from_matrix(R, seq, on_singular="resolve")
        np.testing.assert_array_equal(got[:, 2], 0.0)
        np.testing.assert_allclose(euler.as_matrix(got, seq), R, atol=2e-15)
        np.testing.assert_allclose(euler.gimbal_margin(R, seq), 0.0, atol=1e-15)
        # scipy warns at gimbal lock and also sets the third angle to zero; the matrices must agree
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            ref = Rotation.from_matrix(R).as_euler(seq)
        np.testing.assert_allclose(euler.as_matrix(ref, seq), R, atol=1e-12)


def test_singularity_error_names_the_entries_and_the_fix():
    angles = np.array([[0.1, 0.5, 0.2], [0.3, 0.0, -0.4], [1.0, 2.0, 3.0], [0.2, np.pi, 0.1], [0.0, 1.0, 0.0]])
    R = euler.as_matrix(angles)
    with pytest.raises(SingularityError) as info:
        euler.from_matrix(R, "ZXZ")
    msg = str(info.value)
    assert "2 of 5" in msg
    assert "(1,)" in msg and "(3,)" in msg
    assert "middle angle" in msg and "0 or pi" in msg
    assert "on_singular='resolve'" in msg and "quaternion" in msg
    good = euler.from_matrix(R, "ZXZ", on_singular="resolve")
    np.testing.assert_allclose(good[[0, 2, 4]], angles[[0, 2, 4]], atol=1e-14)


def test_tait_bryan_message_names_pi_over_2():
    with pytest.raises(SingularityError, match=re.escape("+-pi/2")):
        euler.from_matrix(euler.as_matrix([0.3, np.pi / 2, 0.1], "ZYX"), "ZYX")


def test_gimbal_margin_from_angles_and_from_matrix_agree():
    rng = np.random.default_rng(6)
    for seq in ("ZXZ", "ZYX", "yxy", "xyz"):
        angles = rng.uniform(-4, 4, size=(40, 3))
        from_angles = euler.gimbal_margin_angles(angles, seq)
        np.testing.assert_allclose(euler.gimbal_margin(euler.as_matrix(angles, seq), seq), from_angles, atol=1e-12)
    assert euler.gimbal_margin_angles([0.0, 0.25, 0.0], "ZYX") == pytest.approx(np.pi / 2 - 0.25)
    assert euler.gimbal_margin_angles([0.0, -3.0, 0.0], "ZXZ") == pytest.approx(np.pi - 3.0)


# -- validation ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", ["zxx", "ZxZ", "ABC", "ZZX", "ZXZX", "", 313, None])
def test_bad_sequences_list_the_valid_forms(bad):
    with pytest.raises(InputError) as info:
        euler.as_matrix([0.0, 0.0, 0.0], bad)
    msg = str(info.value)
    assert all(s in msg for s in ALL)
    assert repr(bad) in msg


def test_bad_arguments():
    with pytest.raises(ShapeError, match=r"^Expected `angles` to have shape \(\.\.\., 3\), got \(2,\)\.$"):
        euler.as_matrix([0.0, 1.0])
    with pytest.raises(InputError, match="on_singular"):
        euler.from_matrix(np.eye(3), on_singular="nan")
    for tol in (-1.0, np.nan, "big"):
        with pytest.raises(InputError, match="tol"):
            euler.from_matrix(np.eye(3), tol=tol)
    with pytest.raises(InputError, match="rotation matrix"):
        euler.from_matrix(np.diag([1.0, 1.0, -1.0]))


def test_batch_shape():
    angles = regular_angles("ZYX", 6, np.random.default_rng(7)).reshape(2, 3, 3)
    R = euler.as_matrix(angles, "ZYX")
    assert R.shape == (2, 3, 3, 3)
    np.testing.assert_allclose(euler.from_matrix(R, "ZYX"), angles, atol=1e-12)
    assert euler.gimbal_margin(R, "ZYX").shape == (2, 3)
