r"""The symbolic twin of a Lie group: its chart in sympy, as the mechanics uses it.

A :class:`GroupChart` holds, for a group of :mod:`geomech.lie` and coordinate symbols :math:`q`, the element
:math:`g(q)` and its inverse as exact matrices, the basis :math:`b_a` of the algebra, the body-velocity matrix
:math:`\Lambda(q)` with :math:`\xi = (g^{-1}\dot g)^\vee = \Lambda(q)\dot q`, the structure constants
:math:`[b_b, b_d] = C^a_{bd}b_a` and :math:`\mathrm{Ad}_g` as a matrix of :math:`q`. Numerically it reads
coordinates off elements: in closed form where the group has one, else by Gauss-Newton on the compiled chart,
continuous along a path. Its ``numeric`` attribute is the group itself, whose operations it shares.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ConvergenceError, InputError, SymbolicError
from ..lie.group import LieGroup
from ..lie.groups import named_group
from .cache import DISK_CACHE, MISSING
from .compile import compile_vector
from .polys import expand_terms
from .simplify import simplify_expr, vanishes

__all__ = ["GroupChart", "group_chart"]


def _symbol(s: Any) -> sp.Symbol:
    if isinstance(s, sp.Symbol):
        return s if s.is_real else sp.Symbol(s.name, real=True)
    return sp.Symbol(str(s), real=True)


class GroupChart:
    """The symbolic twin of ``group`` in the coordinates ``coordinates`` (default: the group's names).

    Attributes
    ----------
    numeric : LieGroup
        The group (numerical operations: ``exp``, ``compose``, ``Ad``, Jacobians, ...).
    name, dim, abelian, algebra_names, angle_components : as the group's.
    coordinates : tuple of Symbol
    matrix, inverse : ImmutableMatrix
        :math:`g(q)` and :math:`g(q)^{-1}`.
    basis : tuple of ImmutableMatrix
    identity, reference : tuple
        Coordinates of the identity, and of a regular point of the chart where body-frame objects are read off.
    angles : tuple of int
        Indices of the coordinates that are angles.
    """

    def __init__(self, group: LieGroup, coordinates: Sequence[Any] | None = None):
        if not isinstance(group, LieGroup):
            raise InputError(f"Expected a Lie group of geomech.lie, got {group!r}.")
        self.numeric = group
        names = group.coordinate_names if coordinates is None else tuple(coordinates)
        if len(names) != group.dim:
            raise InputError(f"Expected {group.dim} coordinates for {group.name}, got {len(names)}: {list(names)}.")
        self.coordinates = tuple(_symbol(s) for s in names)
        g, gi = group.sympy_element(self.coordinates)
        self.matrix = sp.ImmutableMatrix(g)
        self.inverse = sp.ImmutableMatrix(gi)
        self.basis = group.sympy_basis()
        self.identity = tuple(group.chart_identity)
        self.reference = tuple(group.chart_reference)
        self.angles = tuple(group.chart_angles)

    # -- what the group says ---------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.numeric.name

    @property
    def dim(self) -> int:
        return self.numeric.dim

    @property
    def abelian(self) -> bool:
        return self.numeric.abelian

    @property
    def algebra_names(self) -> tuple[str, ...]:
        return self.numeric.algebra_names

    @property
    def angle_components(self) -> tuple[int, ...]:
        return self.numeric.angle_components

    @property
    def regular_at_identity(self) -> bool:
        """Whether the chart is regular at the identity (3-1-3 Euler angles of SO(3) are not: there a motion
        from the identity is given in exponential coordinates, the log, instead)."""
        return tuple(self.reference) == tuple(self.identity)

    # -- the algebra, exactly ---------------------------------------------------------------------------
    @cached_property
    def _vee_matrix(self) -> sp.Matrix:
        return sp.Matrix.hstack(*[sp.Matrix(b).reshape(len(b), 1) for b in self.basis])

    def hat(self, xi: Sequence[sp.Expr]) -> sp.Matrix:
        """:math:`\\hat\\xi = \\sum_a \\xi^a b_a`."""
        out = sp.zeros(*self.basis[0].shape)
        for x, b in zip(xi, self.basis):
            out += x * sp.Matrix(b)
        return out

    def vee(self, X: sp.MatrixBase, *, check: bool = True) -> sp.Matrix:
        """Components of an algebra element ``X`` in the basis (exact).

        With ``check``, ``X`` must lie in the span of the basis: the residual is evaluated at random points
        of its free symbols first (cheap), and simplified exactly only where that is not clearly zero, so
        that a long trigonometric expression that is zero costs no ``simplify``. Raises
        :class:`~geomech.errors.SymbolicError` if it is not in the span.
        """
        B = self._vee_matrix
        x = sp.Matrix(X).reshape(B.rows, 1)
        pivots = [next(i for i in range(B.rows) if B[i, a] != 0) for a in range(B.cols)]
        comps = sp.Matrix([x[p] / B[p, a] for a, p in enumerate(pivots)])
        if check and not vanishes(B * comps - x):
            raise SymbolicError(f"{X} is not in the Lie algebra of {self.name}.")
        return comps

    @cached_property
    def structure_constants(self) -> tuple[tuple[tuple[sp.Expr, ...], ...], ...]:
        """``C[a][b][d]`` with :math:`[b_b, b_d] = C^a_{bd} b_a` (exact)."""
        k = self.dim
        C = [[[sp.Integer(0)] * k for _ in range(k)] for _ in range(k)]
        for b in range(k):
            for d in range(k):
                comps = self.vee(self.basis[b] * self.basis[d] - self.basis[d] * self.basis[b])
                for a in range(k):
                    C[a][b][d] = comps[a]
        return tuple(tuple(tuple(row) for row in Ca) for Ca in C)

    def bracket(self, xi: Sequence[sp.Expr], eta: Sequence[sp.Expr]) -> sp.Matrix:
        """:math:`[\\xi, \\eta]^a = C^a_{bd}\\,\\xi^b \\eta^d`."""
        C, k = self.structure_constants, self.dim
        return sp.Matrix(
            [expand_terms(sum(C[a][b][d] * xi[b] * eta[d] for b in range(k) for d in range(k))) for a in range(k)]
        )

    # -- the chart --------------------------------------------------------------------------------------
    @cached_property
    def body_velocity_matrix(self) -> sp.ImmutableMatrix:
        """:math:`\\Lambda(q)` with :math:`\\xi = \\Lambda(q)\\,\\dot q`, column :math:`j` being
        :math:`(g^{-1}\\partial g/\\partial q_j)^\\vee`."""

        def derive() -> sp.ImmutableMatrix:
            cols = [self.vee((self.inverse * self.matrix.diff(q)).applyfunc(simplify_expr)) for q in self.coordinates]
            return sp.ImmutableMatrix(sp.Matrix.hstack(*cols).applyfunc(simplify_expr))

        return self._kept("body_velocity_matrix", derive)

    @cached_property
    def body_velocity_inverse(self) -> sp.ImmutableMatrix:
        """:math:`\\Lambda(q)^{-1}`: coordinate rates from the body velocity."""

        def derive() -> sp.ImmutableMatrix:
            inv = sp.Matrix(self.body_velocity_matrix).inv(method="LU")
            return sp.ImmutableMatrix(inv.applyfunc(simplify_expr))

        return self._kept("body_velocity_inverse", derive)

    def _kept(self, name: str, derive: Any) -> Any:
        """``derive()``, kept in the derivation cache on disk under the chart's exact content (the group's matrix,
        its inverse and basis in these coordinates): every process that builds a system on this chart reads it."""
        key = ("group chart", self.name, self.coordinates, self.matrix, self.inverse, self.basis)
        value = DISK_CACHE.load(key, name)
        if value is MISSING:
            value = derive()
            DISK_CACHE.save(key, name, value)
        return value

    def Ad_matrix(self, g: sp.MatrixBase | None = None, *, inverse: bool = False) -> sp.Matrix:
        """:math:`\\mathrm{Ad}_g` as a ``dim x dim`` matrix (default :math:`g = g(q)`),
        :math:`(\\mathrm{Ad}_g\\xi)^\\wedge = g\\hat\\xi g^{-1}`; with ``inverse``,
        :math:`\\mathrm{Ad}_{g^{-1}}` (from the chart's exact inverse when ``g`` is not given)."""
        if g is None:
            g, ginv = self.matrix, self.inverse
        else:
            g = sp.Matrix(g)
            ginv = g.inv(method="LU")
        if inverse:
            g, ginv = ginv, g
        # g b g^-1 is in the algebra for every element of the group: no membership check is needed
        cols = [self.vee(sp.Matrix(g) * sp.Matrix(b) * sp.Matrix(ginv), check=False) for b in self.basis]
        return sp.Matrix.hstack(*cols).applyfunc(simplify_expr)

    # -- coordinates, numerically ---------------------------------------------------------------------------
    @cached_property
    def _compiled(self) -> tuple[Any, Any]:
        q = list(self.coordinates)
        chart = compile_vector(sp.Matrix(self.matrix).tolist(), q)
        jac = [
            [[sp.diff(self.matrix[i, j], c) for c in q] for j in range(self.matrix.cols)]
            for i in range(self.matrix.rows)
        ]
        return chart, compile_vector(jac, q)

    def from_coordinates(self, q: Any) -> np.ndarray:
        """The elements at coordinates ``q`` ``(..., k)``."""
        q = np.asarray(q, dtype=float)
        if self.numeric.closed_chart:
            return self.numeric.from_coordinates(q)
        return np.asarray(self._compiled[0](q), dtype=float)

    def to_coordinates(self, g: Any, *, start: Any = None, tol: float = 1e-12, maxiter: int = 50) -> np.ndarray:
        """Coordinates of the elements ``g`` (``(..., n, n)``).

        In closed form where the group has one (angles wrapped to (-pi, pi]); otherwise Gauss-Newton on
        :math:`\\|g(q) - g\\|_F`, each element started from the previous one's coordinates (the first from
        ``start``, else the best of the reference and a few spread points), so that coordinates along a path are
        continuous. Raises :class:`~geomech.errors.ConvergenceError` where the chart does not reach an element.
        """
        if self.numeric.closed_chart and start is None:
            return self.numeric.to_coordinates(g)
        g = np.asarray(g, dtype=float)
        n = self.numeric.matrix_size
        flat = g.reshape((-1, n, n))
        out = np.empty((flat.shape[0], self.dim))
        ref = np.array([float(v) for v in self.reference])
        q = None if start is None else np.asarray(start, dtype=float)
        for i, gi in enumerate(flat):
            if q is None:
                rng = np.random.default_rng(0)
                starts = [ref] + [ref + rng.uniform(-np.pi, np.pi, self.dim) for _ in range(8)]
                q, res = min((self._newton(gi, s, tol, maxiter) for s in starts), key=lambda pair: pair[1])
            else:
                q, res = self._newton(gi, q, tol, maxiter)
            if res > 1e3 * tol * max(1.0, np.abs(gi).max()):
                raise ConvergenceError(
                    f"The chart of {self.name} does not reach element {i} of the path (residual "
                    f"{res:.3g} at coordinates {np.round(q, 6).tolist()}): a singular point of "
                    "the chart, such as gimbal lock of Euler angles."
                )
            out[i] = q
        return out.reshape(g.shape[:-2] + (self.dim,))

    def _newton(self, g: np.ndarray, q0: np.ndarray, tol: float, maxiter: int) -> tuple[np.ndarray, float]:
        chart, jacobian = self._compiled
        q = np.array(q0, dtype=float)
        for _ in range(maxiter):
            r = (np.asarray(chart(q), dtype=float) - g).ravel()
            J = np.asarray(jacobian(q), dtype=float).reshape(-1, self.dim)
            dq = np.linalg.lstsq(J, -r, rcond=None)[0]
            q = q + dq
            if np.abs(dq).max() <= tol * max(1.0, np.abs(q).max()):
                break
        return q, float(np.abs(np.asarray(chart(q), dtype=float) - g).max())

    def __mul__(self, other: Any) -> GroupChart:
        if not isinstance(other, GroupChart):
            return NotImplemented
        return GroupChart(self.numeric * other.numeric, self.coordinates + other.coordinates)

    def __repr__(self) -> str:
        return f"{self.name}({', '.join(map(str, self.coordinates))})"


def group_chart(group: Any, coordinates: Sequence[Any] | None = None) -> GroupChart:
    """The symbolic twin of ``group``: a :class:`GroupChart` as it is, a Lie group, or a group's name
    (``"SE2"``, ``"SO3"``, ``"S1"``, ...) in ``coordinates`` (default: the group's names)."""
    if isinstance(group, GroupChart) and coordinates is None:
        return group
    if isinstance(group, GroupChart):
        group = group.numeric
    return GroupChart(named_group(group), coordinates)
