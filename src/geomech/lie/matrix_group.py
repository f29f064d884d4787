r"""Any matrix Lie group from a basis of its algebra: the fallback of the hierarchy.

Operations are matrix functions (``expm``, ``logm``, the block exponential for the Jacobians) inherited from
:class:`~geomech.lie.group.LieGroup`; a chart, if given, is a sympy matrix of coordinate symbols, read back
numerically by the group's symbolic twin (:class:`geomech.symbolic.GroupChart`)::

    >>> import sympy as sp
    >>> from geomech.lie import MatrixGroup
    >>> E = lambda i, j: sp.Matrix(3, 3, lambda a, b: int((a, b) == (i, j)))
    >>> H = MatrixGroup("Heisenberg", [E(0, 1), E(1, 2), E(0, 2)])
    >>> H.dim, H.abelian
    (3, False)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from . import _common as c
from .group import LieGroup

__all__ = ["MatrixGroup"]


class MatrixGroup(LieGroup):
    """Any matrix Lie group, from a basis :math:`b_1, \\dots, b_k` of its algebra (``(k, n, n)``, checked to
    be closed under the commutator), with an optional chart given as a sympy matrix of coordinate symbols.

    Parameters
    ----------
    name : str
    basis : array_like or sequence of sympy matrices, shape (k, n, n)
    coordinates : sequence of str or Symbol, optional
        The chart's coordinates (``k`` of them).
    matrix, inverse : sympy Matrix, optional
        :math:`g(q)` in those coordinates and its inverse (computed if not given).
    identity, reference : sequence, optional
        Coordinates of the identity, and of a regular point of the chart (default: the identity).
    angles : sequence of int, optional
        Indices of the coordinates that are angles.

    The numerical operations use matrix functions (``expm``, ``logm``, the block exponential for the
    Jacobians); its chart is read numerically by its symbolic twin (:class:`geomech.symbolic.GroupChart`).
    """

    def __init__(
        self,
        name: str,
        basis: Any,
        *,
        coordinates: Sequence[Any] | None = None,
        matrix: Any = None,
        inverse: Any = None,
        identity: Sequence[Any] | None = None,
        reference: Sequence[Any] | None = None,
        angles: Sequence[int] = (),
        algebra_names: Sequence[str] | None = None,
    ):
        self.name = str(name)
        try:
            exact = tuple(sp.ImmutableMatrix(b) for b in basis)
            B = np.array([np.asarray(b, dtype=float) for b in exact])
        except (TypeError, ValueError, sp.SympifyError) as exc:
            raise InputError(f"Expected the basis of {name} to be numbers of shape (k, n, n): {exc}") from exc
        if B.ndim != 3 or B.shape[1] != B.shape[2] or B.shape[0] < 1:
            raise InputError(f"Expected the basis of {name} of shape (k, n, n), got {B.shape}.")
        if not np.all(np.isfinite(B)):
            raise InputError(f"Expected the basis of {name} to be finite numbers.")
        self.dim, self.matrix_size = B.shape[0], B.shape[1]
        self.point_dim = self.matrix_size
        flat = B.reshape(self.dim, -1).T
        if np.linalg.matrix_rank(flat) < self.dim:
            raise InputError(f"The basis of {name} is linearly dependent.")
        self._B, self._exact = B, exact
        comm = np.einsum("bij,djk->bdik", B, B) - np.einsum("dij,bjk->bdik", B, B)
        C = self.structure_constants
        resid = np.abs(np.einsum("abd,aij->bdij", C, B) - comm).max()
        if resid > 1e-10 * max(1.0, np.abs(B).max() ** 2):
            raise InputError(
                f"The basis of {name} is not closed under the commutator (residual {resid:.3g}): "
                "it does not span a Lie algebra."
            )
        self.abelian = bool(np.abs(C).max() < 1e-14)
        self._symbols: tuple[sp.Symbol, ...] = ()
        if coordinates is not None:
            self.coordinate_names = c.coordinate_names(
                tuple(coordinates), [""] * self.dim, name, "one name a dimension"
            )
            self._symbols = tuple(s if isinstance(s, sp.Symbol) else sp.Symbol(str(s), real=True) for s in coordinates)
        else:
            self.coordinate_names = tuple(f"q{i + 1}" for i in range(self.dim))
        self._matrix = None if matrix is None else sp.Matrix(matrix)
        if self._matrix is not None and self._matrix.shape != (self.matrix_size, self.matrix_size):
            raise InputError(
                f"Expected the chart `matrix` of {name} to be {self.matrix_size} x {self.matrix_size}, "
                f"got {self._matrix.shape}."
            )
        if self._matrix is not None and not self._symbols:
            raise InputError(f"Expected `coordinates` with the chart `matrix` of {name}.")
        self._inverse = None if inverse is None else sp.Matrix(inverse)
        self._identity = tuple(sp.sympify(v) for v in (identity if identity is not None else (0,) * self.dim))
        self._reference = tuple(sp.sympify(v) for v in reference) if reference else self._identity
        self.chart_angles = tuple(int(i) for i in angles)
        self.algebra_names = (
            tuple(algebra_names) if algebra_names is not None else tuple(f"xi_{a + 1}" for a in range(self.dim))
        )

    @property
    def basis(self) -> np.ndarray:
        return self._B

    def sympy_basis(self) -> tuple[sp.ImmutableMatrix, ...]:
        return self._exact

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        if self._matrix is None:
            return super().sympy_element(q)
        sub = dict(zip(self._symbols, q))
        g = self._matrix.xreplace(sub)
        gi = self._inverse.xreplace(sub) if self._inverse is not None else g.inv(method="LU").applyfunc(sp.simplify)
        return g, gi

    @property
    def chart_identity(self) -> tuple[sp.Expr, ...]:
        return self._identity

    @property
    def chart_reference(self) -> tuple[sp.Expr, ...]:
        return self._reference

    def __repr__(self) -> str:
        return f"MatrixGroup({self.name!r}, dim={self.dim}, n={self.matrix_size})"
