"""The stability map compiled (one numba call per block) against the map point by point in Python, and against
results known independently of both."""

import numpy as np
import pytest
import sympy as sp

from geomech import LeftInvariantSystem
from geomech.analysis import EquilibriumSet, find_equilibria, stability_map
from geomech.errors import InputError
from geomech.systems.control import StructurePreservingControl as SPC
from geomech.systems.rotors import RotorBody

CODES = ("verdict", "lagrange_dirichlet", "energy_casimir", "linearisation", "branch_jump", "complete", "status")
NUMBERS = ("m", "hessian_eigenvalues", "growth_rate", "ec_determinant")


def cubic_one_rotor():
    """phi = k v + a v^3 with p = 0.1: no closed-form boundary, folds where pairs of equilibria are born."""
    return SPC.one_rotor(
        RotorBody.one_rotor(3.0, 2.0, 1.0), "k*v + a*v**3", parameters={"k": 0.5, "a": 0.0}, p=0.1, probe_radius=1.0
    )


def assert_same_map(a, b):
    for name in CODES:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    for name in NUMBERS:
        # the same equilibria and matrices, up to the round-off of their evaluation (values of order 1)
        np.testing.assert_allclose(a[name].values, b[name].values, rtol=0, atol=1e-9, err_msg=name)


def test_compiled_map_reproduces_the_python_map_through_folds():
    family = cubic_one_rotor().family()
    x, y = ("k", np.linspace(0.05, 0.95, 9)), ("a", np.linspace(-0.9, 0.9, 8))
    compiled = stability_map(family, x, y, backend="numba")
    python = stability_map(family, x, y, backend="python")
    assert_same_map(compiled, python)
    verdicts = set(np.unique(compiled["verdict"].values))
    assert verdicts == {-1, 1}  # both sides of the boundary are in the grid
    assert compiled["complete"].values.all()


def test_compiled_map_makes_the_same_choice_among_equally_near_equilibria():
    """Where the nearest equilibria are all on the circle m2 = 0 (each at distance sqrt(2) from (0, G, 0)), the choice
    among them follows the previous point's along the row, then the larger components, in both backends."""
    family = cubic_one_rotor().family()
    x, y = ("k", np.linspace(0.05, 0.95, 20)), ("a", np.linspace(-0.9, 0.9, 20)[[8, 10]])
    compiled = stability_map(family, x, y, backend="numba")
    python = stability_map(family, x, y, backend="python")
    assert_same_map(compiled, python)
    assert (np.abs(compiled["m"].values[..., 1]) < 1e-9).sum() >= 3


def test_blocks_of_several_rows_give_the_map_of_one_row_a_block():
    """Each row starts afresh: the compiled default (blocks of many rows) is the map of one row per task."""
    family = cubic_one_rotor().family()
    x, y = ("k", np.linspace(0.05, 0.95, 7)), ("a", np.linspace(-0.9, 0.9, 5))
    assert_same_map(stability_map(family, x, y), stability_map(family, x, y, chunk=7))


def test_three_rotors_under_diagonal_cubic_controls():
    body = RotorBody.three_rotors((3.0, 2.0, 1.5), (0.2, 0.2, 0.2))
    control = SPC.diagonal(
        body,
        ["k1*v + c*v**3", "k2*v", "k3*v - c*v**3"],
        parameters={"k1": 0.2, "k2": 0.4, "k3": 0.1, "c": 0.3},
        p=(0.05, 0.0, -0.05),
        probe_radius=2.0,
    )
    x, y = ("k2", np.linspace(-0.5, 0.9, 6)), ("c", np.linspace(-0.6, 0.6, 4))
    compiled = stability_map(control.family(), x, y, G=1.3, backend="numba", fixed={"lambda3": 1.2})
    python = stability_map(control.family(), x, y, G=1.3, backend="python", fixed={"lambda3": 1.2})
    assert_same_map(compiled, python)
    np.testing.assert_allclose(np.linalg.norm(compiled["m"].values, axis=-1), 1.3, rtol=1e-12)


def test_a_users_hamiltonian_swept_through_the_intermediate_axis_theorem():
    """The free body H = sum m_i^2 / (2 I_i): the spin about axis 2 is Lyapunov stable when I2 is the largest or the
    smallest moment and unstable when it is the intermediate one, with growth rate G sqrt((1/I2 - 1/I1)(1/I3 - 1/I2))
    (Euler's equations linearised)."""
    m1, m2, m3 = sp.symbols("m1 m2 m3")
    I1, I2, I3 = sp.symbols("I1 I2 I3", positive=True)
    H = m1**2 / (2 * I1) + m2**2 / (2 * I2) + m3**2 / (2 * I3)
    system = LeftInvariantSystem.from_expression(H, {"I1": 3.0, "I2": 2.0, "I3": 1.0})
    i2s, i3s = np.array([0.5, 0.9, 1.1, 1.7, 2.6, 3.4, 4.0]), np.array([0.7, 1.3, 2.2])
    ds = stability_map(system.family(), ("I2", i2s), ("I3", i3s), G=2.0, backend="numba")
    for j, i3 in enumerate(i3s):
        for i, i2 in enumerate(i2s):
            np.testing.assert_allclose(ds["m"].values[j, i], [0.0, 2.0, 0.0], atol=1e-12)
            intermediate = min(3.0, i3) < i2 < max(3.0, i3)
            assert ds["verdict"].values[j, i] == (-1 if intermediate else 1)
            rate = 2.0 * np.sqrt(max((1 / i2 - 1 / 3.0) * (1 / i3 - 1 / i2), 0.0))
            np.testing.assert_allclose(ds["growth_rate"].values[j, i], rate, rtol=1e-10, atol=1e-14)


def test_points_without_a_closed_loop_hamiltonian_are_marked_in_both_backends():
    """phi = (a m2, b m1, 0) has a closed-loop Hamiltonian only where a / lambda1 = b / lambda2: every other point of
    the grid is refused (status 1), by the compiled map as by the family itself."""
    body = RotorBody.three_rotors((3.0, 2.0, 1.5), (0.2, 0.2, 0.2))
    control = SPC.three_rotors(body, ["a*m2", "b*m1", "0"], parameters={"a": 0.3, "b": 0.2})
    x, y = ("a", [0.3, 0.45]), ("b", [0.2, 0.3, 0.4])
    compiled = stability_map(control.family(), x, y, backend="numba")
    python = stability_map(control.family(), x, y, backend="python")
    expected = np.array([[0, 1], [1, 0], [1, 1]])  # a / 3 = b / 2 at (0.3, 0.2) and (0.45, 0.3)
    np.testing.assert_array_equal(compiled["status"].values, expected)
    assert_same_map(compiled, python)


def test_the_nearest_equilibrium_among_equally_near_ones_does_not_depend_on_their_order():
    system = cubic_one_rotor().family()(k=0.57, a=-0.14)
    eqs = find_equilibria(system, 1.0)
    near = np.array([0.0, 1.0, 0.0])
    tied = [e for e in eqs if abs(e.m[1]) < 1e-9]  # all at distance sqrt(2) from near
    assert len(tied) >= 2 and min(np.linalg.norm(e.m - near) for e in eqs) > np.sqrt(2) - 1e-9
    largest = max(tied, key=lambda e: tuple(e.m))
    backwards = EquilibriumSet(eqs.equilibria[::-1], eqs.G, eqs.index_sum, eqs.n_degenerate, eqs.complete, eqs.message)
    assert eqs.nearest(near) is largest and backwards.nearest(near) is largest
    for e in tied:
        assert eqs.nearest(near, prefer=e.m + 1e-3) is e


def test_backend_is_checked():
    family = cubic_one_rotor().family()
    with pytest.raises(InputError, match="backend"):
        stability_map(family, ("k", [0.1, 0.2]), ("a", [0.0, 0.1]), backend="fortran")
    with pytest.raises(InputError, match="no formula"):
        stability_map(lambda **v: family(**v), ("k", [0.1, 0.2]), ("a", [0.0, 0.1]), backend="numba")
    callable_system = LeftInvariantSystem.from_callable(lambda m: 0.5 * (m * m).sum(-1), lambda m: m)
    with pytest.raises(InputError, match="from_expression"):
        callable_system.family()
