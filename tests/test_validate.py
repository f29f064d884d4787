"""The checks at the public boundary: the quick paths for a few numbers agree with numpy's on every input."""

import numpy as np
import pytest

from geomech import _validate as V
from geomech.errors import InputError
from geomech.integrators._runners import failed_rows
from geomech.lie import so3


def numpy_orthogonality_error(R: np.ndarray) -> float:
    return float(np.abs(R.T @ R - np.eye(3)).max())


def test_one_rotation_matrix_is_checked_as_numpy_would(rng):
    for _ in range(200):
        R = so3.exp(rng.normal(size=3) * 3)
        assert V.rotation_matrix(R, "R0") is not None  # accepted: orthogonal to round-off
        # off by more than the tolerance in one entry: rejected, with numpy's measure of the error in the message
        bad = R.copy()
        i, j = rng.integers(0, 3, size=2)
        bad[i, j] += rng.choice([-1, 1]) * 10 ** rng.uniform(-8, -2)
        with pytest.raises(InputError, match="rotation matrix") as err:
            V.rotation_matrix(bad, "R0")
        shown = float(str(err.value).split("off by ")[1].split(";")[0])
        assert shown == pytest.approx(numpy_orthogonality_error(bad), rel=1e-2)
        # a reflection is orthogonal with det -1
        with pytest.raises(InputError, match="det R = \\+1"):
            V.rotation_matrix(-R, "R0")
        # within the tolerance: accepted, as numpy's measure says
        near = R.copy()
        near[i, j] += 1e-11
        assert numpy_orthogonality_error(near) < 1e-9
        V.rotation_matrix(near, "R0")


def test_a_batch_of_rotation_matrices_and_one_agree(rng):
    Rs = np.stack([so3.exp(rng.normal(size=3)) for _ in range(5)])
    np.testing.assert_array_equal(V.rotation_matrix(Rs, "R0"), Rs)
    Rs[3] = -Rs[3]
    with pytest.raises(InputError, match="rotation matrix"):
        V.rotation_matrix(Rs, "R0")
    with pytest.raises(InputError, match="rotation matrix"):
        V.rotation_matrix(Rs[3], "R0")


@pytest.mark.parametrize("size", [1, 3, 9, 32, 33, 1000])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_finite_rejects_a_non_finite_entry_anywhere_at_every_size(size, bad, rng):
    x = rng.normal(size=size)
    np.testing.assert_array_equal(V.finite(x, "x"), x)
    for where in {0, size // 2, size - 1}:
        y = x.copy()
        y[where] = bad
        with pytest.raises(InputError, match="`x` to be finite"):
            V.finite(y, "x")
        with pytest.raises(InputError, match="`x` to be finite"):
            V.finite(y.reshape(1, -1), "x")


def test_finite_accepts_the_largest_numbers_whose_sum_overflows():
    x = np.full(4, 1.7e308)
    np.testing.assert_array_equal(V.finite(x, "x"), x)
    assert V.finite(5.0, "x").shape == ()


def test_failed_rows_are_the_members_with_a_status():
    info = np.zeros((1, 8))
    assert failed_rows(info) == []
    info[0, 0] = 2
    assert failed_rows(info) == [0]
    info = np.zeros((5, 8))
    assert failed_rows(info) == []
    info[[1, 4], 0] = [8, 6]
    assert failed_rows(info) == [1, 4]
