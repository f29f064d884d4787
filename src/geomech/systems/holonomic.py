r"""Holonomic mechanical systems with symmetry on a trivial principal bundle :math:`Q = G \times S`.

A configuration is :math:`q = (g, r)`: a group element :math:`g` (position and orientation, written in
group coordinates :math:`\alpha`) and a shape :math:`r` (joint angles, distances). The group acts on the
left, :math:`h \cdot (g, r) = (hg, r)`, and the Lagrangian is simple and left-invariant,

.. math::

    L(q, \dot q) = \tfrac12\, \dot q^T M(q)\, \dot q - V(r),

so that in the body velocity :math:`\xi = g^{-1}\dot g = B(\alpha)\dot\alpha` it depends on the shape
only: the reduced Lagrangian :math:`l(r, \xi, \dot r)` of Theorem 2.1 of the nonholonomic paper, whose
mass matrix :attr:`HolonomicSystem.reduced_mass_matrix` carries the locked inertia and the mechanical
connection (see :mod:`geomech.reduction.connections`).

Groups: any group of :mod:`geomech.lie` (``SO2``/``S1``: one angle; ``SE2``: ``(x, y, theta)``, body
velocity ``(v_x, v_y, omega)``; ``SO3``: 3-1-3 Euler angles ``(phi, theta, psi)``, ``R = Rz(phi) Rx(theta)
Rz(psi)``, body angular velocity; ``SE3``, ``Rn``, products), or one of the names ``"S1"``, ``"SE2"``,
``"SO3"``; the system holds the group's symbolic twin (:class:`~geomech.symbolic.GroupChart`).

Examples, built with the public constructors: :func:`two_pinned_bodies` (section 2.2 of the
nonholonomic paper), :func:`planar_point_masses` (the planar N-body), :func:`three_link_chain` (a free
planar chain, the falling-cat mechanism in the plane), :func:`spacecraft_with_rotors` (SO(3)).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import ShapeError, SymbolicError
from ..symbolic.charts import GroupChart, group_chart
from ..symbolic.compile import compile_vector
from ..symbolic.formula import parse_formula
from ..symbolic.simplify import tidy_trig
from .nonholonomic import NonholonomicSystem, _symbols

__all__ = ["HolonomicSystem"]


@dataclass(frozen=True, eq=False)
class HolonomicSystem(NonholonomicSystem):
    """A simple mechanical system with a free left symmetry on :math:`Q = G \\times S` and no constraints.

    It is a :class:`~geomech.systems.NonholonomicSystem` with no constraint one-forms (the one description of a
    Lagrangian system on :math:`G \\times S`: the same coordinates ``q``, velocities ``qdot``, ``shape``,
    ``shape_angles``, parameters, and every method of :func:`~geomech.solve` for it), with what the mechanical
    connection needs on top: Theorem 2.1's reduced mass matrix and its blocks. Build it with
    :meth:`from_lagrangian` (a Lagrangian in group and shape coordinates and their velocities) or
    :meth:`from_reduced` (the reduced Lagrangian in body velocities). Every expression keeps its parameters
    as symbols; :attr:`parameters` holds their values, substituted on compilation.

    It has the attributes of :class:`~geomech.systems.NonholonomicSystem`, and one more.

    Attributes
    ----------
    reduced_mass_matrix : sympy.Matrix
        The matrix of Theorem 2.1, order :math:`(\\xi, \\dot r)`, a function of :math:`r` alone.
    """

    # -- construction ------------------------------------------------------------------------------
    @classmethod
    def from_lagrangian(  # type: ignore[override]
        cls,
        lagrangian: Any,
        group: Any,
        shape: Sequence[Any],
        constraints: Sequence[Any] = (),
        *,
        parameters: Mapping[str, float] | None = None,
        velocities: Sequence[Any] | Mapping[Any, Any] | None = None,
        shape_angles: Sequence[int] | None = None,
        name: str = "holonomic system",
        description: str = "",
        check: bool = True,
    ) -> HolonomicSystem:
        """A system from :math:`L(q, \\dot q)` in group and shape coordinates (nonholonomic paper, sec. 2.1).

        The arguments are those of :meth:`geomech.systems.NonholonomicSystem.from_lagrangian`
        with no constraints: ``group`` a group of :mod:`geomech.lie` with its coordinate names
        (``SE2("x", "y", "theta")``) or a group's name (``"S1"``, ``"SE2"``, ``"SO3"``: the group's own
        coordinate names), ``shape`` the shape coordinates (at least one), ``velocities`` their velocity
        names (a sequence, or a mapping for those not named ``<name>_dot``), ``shape_angles`` the indices of
        the shapes that are angles (default: those with Greek names), ``check`` the check that :math:`L` is
        kinetic minus potential energy and invariant under the group.

        Raises
        ------
        SymbolicError
            When :math:`L` is not quadratic in the velocities with no linear term, when :math:`V`
            depends on the group coordinates, or when the kinetic energy is not left-invariant.
        """
        if len(constraints):
            raise ShapeError(
                "A HolonomicSystem has no constraints; describe a system with constraint one-forms as a "
                "NonholonomicSystem.from_lagrangian(lagrangian, group, shape, constraints)."
            )
        if len(shape) == 0:
            raise ShapeError(
                "Expected at least one shape coordinate; a system without shape is a rigid "
                "body (use geomech.RigidBody and geomech.analysis.rigid_body_phase)."
            )
        system = super().from_lagrangian(
            lagrangian,
            group,
            shape,
            (),
            parameters=parameters,
            velocities=velocities,
            shape_angles=shape_angles,
            name=name,
            description=description,
            check=check,
        )
        assert isinstance(system, HolonomicSystem)
        return system

    @classmethod
    def from_reduced(
        cls,
        reduced_lagrangian: Any,
        group: Any,
        body_velocities: Sequence[Any],
        shape: Sequence[Any],
        *,
        parameters: Mapping[str, float] | None = None,
        velocities: Mapping[Any, Any] | None = None,
        shape_angles: Sequence[int] | None = None,
        name: str = "holonomic system",
        description: str = "",
    ) -> HolonomicSystem:
        """A system from its reduced Lagrangian :math:`l(r, \\xi, \\dot r)` (Theorem 2.1), the body
        velocity :math:`\\xi` named by ``body_velocities`` in the group's algebra order; the Lagrangian on
        :math:`TQ` is :math:`l` with :math:`\\xi = B(\\alpha)\\dot\\alpha`. The other arguments are those
        of :meth:`from_lagrangian`."""
        G = group_chart(group)
        xi = _symbols(body_velocities, "body_velocities")
        if len(xi) != G.dim:
            raise ShapeError(f"Expected {G.dim} `body_velocities` ({', '.join(G.algebra_names)}), got {len(xi)}.")
        alpha = G.coordinates
        vel_map = {str(k): str(v) for k, v in (velocities or {}).items()}
        ad = [sp.Symbol(vel_map.get(str(a), f"{a}_dot"), real=True) for a in alpha]
        expr = (
            parse_formula(reduced_lagrangian, "reduced_lagrangian")
            if isinstance(reduced_lagrangian, str)
            else reduced_lagrangian
        )
        if not isinstance(expr, sp.Basic):
            raise SymbolicError(
                f"Expected `reduced_lagrangian` to be a sympy expression or a string, got {type(expr).__name__}."
            )
        by_name = {x.name: x for x in xi}
        expr = expr.xreplace({s: by_name[s.name] for s in expr.free_symbols if getattr(s, "name", None) in by_name})
        body = G.body_velocity_matrix * sp.Matrix(ad)
        full = expr.xreplace(dict(zip(xi, body)))
        return cls.from_lagrangian(
            full,
            G,
            shape,
            parameters=parameters,
            velocities={**vel_map, **{str(a): str(v) for a, v in zip(alpha, ad)}},
            shape_angles=shape_angles,
            name=name,
            description=description,
        )

    # -- Theorem 2.1 --------------------------------------------------------------------------------
    @cached_property
    def reduced_mass_matrix(self) -> sp.Matrix:
        """Theorem 2.1's matrix: the Hessian of the reduced Lagrangian :math:`l(r, \\xi, \\dot r)` in
        :math:`(\\xi, \\dot r)`, a function of :math:`r` alone (parameters as symbols)."""
        return _reduced_mass_matrix(self.group, self.group.coordinates, sp.Matrix(self.mass_matrix))

    # -- numeric kernels ---------------------------------------------------------------------------
    def compile(self, exprs: Any, variables: Sequence[sp.Symbol]) -> Callable[[np.ndarray], np.ndarray]:
        """Compile expressions (parameter values substituted) to a function of ``(..., len(variables))``."""
        sub = self.parameter_values()
        if isinstance(exprs, sp.MatrixBase):
            return compile_vector(exprs.subs(sub).tolist(), variables)
        if isinstance(exprs, sp.Expr):
            return compile_vector([exprs.subs(sub)], variables)
        return compile_vector([sp.sympify(e).subs(sub) for e in exprs], variables)

    @cached_property
    def reduced_mass_function(self) -> Callable[[np.ndarray], np.ndarray]:
        """``r -> M_red(r)``, shape ``(..., k + n, k + n)``."""
        return self.compile(self.reduced_mass_matrix, self.shape)

    def shape_matrix(self, r: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Blocks of :math:`M_{red}(r)`: the locked inertia :math:`\\mathbb I_{loc}`, the product
        :math:`\\mathbb I_{loc} A_{loc}` and the shape block :math:`m(r)`."""
        r = V.trailing_shape(r, "r", (self.sigma,))
        M = self.reduced_mass_function(r)
        k = self.k
        return M[..., :k, :k], M[..., :k, k:], M[..., k:, k:]

    @cached_property
    def body_velocity_matrix_function(self) -> Callable[[np.ndarray], np.ndarray]:
        """``alpha -> B(alpha)``, ``xi = B(alpha) alpha_dot``."""
        return compile_vector(self.group.body_velocity_matrix.tolist(), self.group.coordinates)

    def group_velocity(self, alpha: Any, r: Any, rdot: Any, mu: Any) -> np.ndarray:
        """:math:`\\dot\\alpha` with spatial momentum :math:`\\mu` at :math:`(\\alpha, r, \\dot r)`:
        :math:`\\dot\\alpha = B^{-1}(-A_{loc}\\dot r + \\mathbb I_{loc}^{-1}\\mathrm{Ad}_g^*\\mu)` (eq. 2.2)."""
        k = self.k
        alpha = V.exact_shape(alpha, "alpha", (k,))
        r = V.exact_shape(r, "r", (self.sigma,))
        rdot = V.exact_shape(rdot, "rdot", (self.sigma,))
        mu = V.exact_shape(np.atleast_1d(mu), "mu", (k,))
        I, IA, _ = self.shape_matrix(r)
        g = self.group.from_coordinates(alpha)
        p = self.group.numeric.Ad(g).T @ mu
        xi = np.linalg.solve(I, p - IA @ rdot)
        B = np.asarray(self.body_velocity_matrix_function(alpha), dtype=float)
        return np.linalg.solve(B, xi)

    def check_locked_inertia(self, r: Any) -> np.ndarray:
        """The locked inertia at ``r`` (shape ``(n_r, k, k)``), or :class:`SingularityError` where it is
        singular (the connection :math:`A = \\mathbb I^{-1}J` is undefined there)."""
        I, _, _ = self.shape_matrix(np.atleast_2d(r))
        V.positive_definite_along(
            I,
            r,
            f"locked inertia of {self.name}",
            "the mechanical connection I^{-1} J is undefined there; keep the shape away from it",
            rtol=1e-12,
        )
        return I

    def __repr__(self) -> str:
        return f"HolonomicSystem({self.name!r}, group={self.group.name}, shape={[s.name for s in self.shape]})"


def _reduced_mass_matrix(G: GroupChart, alpha: tuple, M: sp.Matrix) -> sp.Matrix:
    """Theorem 2.1's matrix: :math:`T^T M T` at the reference point, :math:`T = \\mathrm{diag}(B^{-1}, 1)`."""
    sub = dict(zip(alpha, G.reference))
    B0 = G.body_velocity_matrix.subs(sub)
    k, N = G.dim, M.shape[0]
    T = sp.eye(N)
    T[:k, :k] = B0.inv()
    out = T.T * M.subs(sub) * T
    for i in range(N):
        for j in range(i, N):
            out[i, j] = out[j, i] = tidy_trig(out[i, j])
    return out
