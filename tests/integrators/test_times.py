"""The output times of a run."""

import numpy as np

from geomech.integrators._times import evenly_spaced


def test_evenly_spaced_times_are_numpy_linspace_to_the_bit(rng):
    cases = [
        (0.0, 100.0, 2),
        (0.0, 5.0, 201),
        (-3.0, 3.0, 2),
        (1e5, -2.5, 77),
        (0.1, 0.1 + 1e-12, 5),
        (2.0, 2.0, 3),
        (1.0, 4.0, 1),
    ]
    for _ in range(300):
        a, b = rng.normal(size=2) * 10 ** rng.uniform(-3, 6, size=2)
        cases.append((float(a), float(b), int(rng.integers(1, 3000))))
    for a, b, n in cases:
        np.testing.assert_array_equal(evenly_spaced(a, b, n), np.linspace(a, b, n))
        assert n == 1 or evenly_spaced(a, b, n)[-1] == b
