"""The symbolic twin of a group checks what it is given: an algebra element is one exactly (trigonometric
identities included), and a chart that leaves the group is refused, not silently projected."""

import pytest
import sympy as sp

from geomech.errors import SymbolicError
from geomech.lie import SO2, SO3, MatrixGroup
from geomech.symbolic import group_chart

a = sp.Symbol("a", real=True)


def test_vee_accepts_algebra_elements_up_to_identities_and_refuses_the_rest():
    C = group_chart(SO3())
    X = C.hat([1, 2, 3]) + (sp.sin(a) ** 2 + sp.cos(a) ** 2 - 1) * sp.eye(3)  # zero symmetric part, exactly
    assert list(C.vee(X)) == [1, 2, 3]
    with pytest.raises(SymbolicError, match="not in the Lie algebra"):
        C.vee(C.hat([1, 2, 3]) + sp.sin(a) * sp.eye(3))
    with pytest.raises(SymbolicError, match="not in the Lie algebra"):
        C.vee(C.hat([1, 2, 3]) + sp.Rational(1, 10**12) * sp.eye(3))  # small is not zero


def test_a_chart_outside_the_group_is_refused():
    basis = SO2().sympy_basis()
    good = MatrixGroup(
        "rotations", basis, coordinates=[a], matrix=sp.Matrix([[sp.cos(a), -sp.sin(a)], [sp.sin(a), sp.cos(a)]])
    )
    assert group_chart(good).body_velocity_matrix == sp.Matrix([[1]])
    bad = MatrixGroup(
        "not rotations", basis, coordinates=[a], matrix=sp.Matrix([[sp.cos(a), -sp.sin(a)], [sp.sin(a), 2 * sp.cos(a)]])
    )
    with pytest.raises(SymbolicError, match="not in the Lie algebra"):
        _ = group_chart(bad).body_velocity_matrix


def test_a_charts_body_velocity_matrices_are_read_back_from_disk(monkeypatch, tmp_path):
    """Lambda(q) and its inverse are derived once for a chart's content and kept on disk: a new chart of the same
    group in the same coordinates (another process) reads them; other coordinates derive their own. Lambda^{-1}
    Lambda = I exactly."""
    from geomech.lie import SE2

    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(tmp_path))
    first = group_chart(SE2("x", "y", "theta"))
    L, Li = first.body_velocity_matrix, first.body_velocity_inverse
    assert sp.simplify(Li * L - sp.eye(3)) == sp.zeros(3, 3)

    def derived_again(*args, **kwargs):
        raise RuntimeError("derived again")

    monkeypatch.setattr(sp.MatrixBase, "inv", derived_again)
    again = group_chart(SE2("x", "y", "theta"))
    assert again is not first and again.body_velocity_inverse == Li and again.body_velocity_matrix == L
    with pytest.raises(RuntimeError, match="derived again"):
        _ = group_chart(SE2("u", "v", "phi")).body_velocity_inverse
