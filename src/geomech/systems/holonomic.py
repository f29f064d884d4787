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

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, ShapeError, SymbolicError
from ..lie.groups import named_group
from ..symbolic.charts import GroupChart
from ..symbolic.compile import bind_expression, compile_vector
from ..symbolic.simplify import tidy_trig

__all__ = ["HolonomicSystem"]


# ---------------------------------------------------------------------------------------------------
# The system
# ---------------------------------------------------------------------------------------------------
def _chart(group: Any, coordinates: Sequence[Any] | None) -> GroupChart:
    """The twin of ``group`` (a Lie group, a chart or a name) in ``coordinates`` (default: the group's names)."""
    G = group.numeric if isinstance(group, GroupChart) else named_group(group)
    if coordinates is None:
        return group if isinstance(group, GroupChart) else GroupChart(G)
    alpha = _symbols(coordinates, "group_coordinates")
    if len(alpha) != G.dim:
        raise ShapeError(
            f"Expected {G.dim} `group_coordinates` for {G.name} ({', '.join(G.coordinate_names)}), "
            f"got {len(alpha)}: {[str(a) for a in alpha]}."
        )
    return GroupChart(G, alpha)


def _symbols(names: Sequence[Any], argname: str) -> tuple[sp.Symbol, ...]:
    out = []
    for n in names:
        if isinstance(n, sp.Symbol):
            out.append(sp.Symbol(n.name, real=True))
        elif isinstance(n, str) and n.isidentifier():
            out.append(sp.Symbol(n, real=True))
        else:
            raise SymbolicError(f"Expected `{argname}` to hold symbols or identifier strings, got {n!r}.")
    return tuple(out)


@dataclass(frozen=True, eq=False)
class HolonomicSystem:
    """A simple mechanical system with a free left symmetry on :math:`Q = G \\times S`.

    Build it with :meth:`from_lagrangian` (a Lagrangian in group and shape coordinates and their
    velocities) or :meth:`from_reduced` (the reduced Lagrangian in body velocities). Every expression
    keeps its parameters as symbols; :attr:`parameters` holds their values, substituted on compilation.

    Attributes
    ----------
    group : GroupChart
        The symmetry group's symbolic twin in the group coordinates (its ``numeric`` attribute is the group).
    group_coordinates, shape_coordinates : the coordinate symbols :math:`\\alpha` and :math:`r`.
    group_velocities, shape_velocities : their velocity symbols.
    lagrangian : :math:`L(\\alpha, r, \\dot\\alpha, \\dot r)`.
    mass_matrix : :math:`M(\\alpha, r)`, the Hessian of :math:`L` in the velocities, order
        :math:`(\\alpha, r)`.
    potential : :math:`V(r)`.
    reduced_mass_matrix : the matrix of Theorem 2.1, order :math:`(\\xi, \\dot r)`, a function of
        :math:`r` alone.
    angle_shapes : indices of the shape coordinates that are angles (a loop may wind in them).
    """

    group: GroupChart
    group_coordinates: tuple[sp.Symbol, ...]
    shape_coordinates: tuple[sp.Symbol, ...]
    group_velocities: tuple[sp.Symbol, ...]
    shape_velocities: tuple[sp.Symbol, ...]
    lagrangian: sp.Expr
    mass_matrix: sp.Matrix
    potential: sp.Expr
    reduced_mass_matrix: sp.Matrix
    parameters: dict[str, float]
    angle_shapes: tuple[int, ...] = ()
    name: str = "holonomic system"

    # -- construction ------------------------------------------------------------------------------
    @classmethod
    def from_lagrangian(
        cls,
        lagrangian: Any,
        group: Any,
        shape_coordinates: Sequence[Any],
        *,
        group_coordinates: Sequence[Any] | None = None,
        velocities: Mapping[Any, Any] | None = None,
        parameters: Mapping[str, float] | None = None,
        angle_shapes: Sequence[int] = (),
        name: str = "holonomic system",
        check_invariance: bool = True,
    ) -> HolonomicSystem:
        """A system from :math:`L(q, \\dot q)` in group and shape coordinates (nonholonomic paper, sec. 2.1).

        Parameters
        ----------
        lagrangian : sympy expression or string, :math:`\\tfrac12\\dot q^T M(q)\\dot q - V(q)`.
        group : a group of :mod:`geomech.lie` (``SO2()``, ``SE2()``, ``SO3()``, ...) or its name ``"S1"``/``"SO2"``,
            ``"SE2"``, ``"SO3"``.
        shape_coordinates : names or symbols of :math:`r` (at least one).
        group_coordinates : names or symbols of :math:`\\alpha`, in the group's order; default the
            group's names (``theta``; ``x, y, theta``; ``phi, theta, psi``).
        velocities : optional map coordinate -> velocity symbol; default ``<name>_dot``.
        parameters : values of every other symbol.
        angle_shapes : indices of the shape coordinates that are angles.
        check_invariance : verify at random configurations that :math:`L` is left-invariant.

        Raises
        ------
        SymbolicError
            When :math:`L` is not quadratic in the velocities with no linear term, when :math:`V`
            depends on the group coordinates, or when the kinetic energy is not left-invariant.
        """
        G = _chart(group, group_coordinates)
        alpha = G.coordinates
        r = _symbols(shape_coordinates, "shape_coordinates")
        if len(r) == 0:
            raise ShapeError(
                "Expected at least one shape coordinate; a system without shape is a rigid "
                "body (use geomech.RigidBody and geomech.analysis.rigid_body_phase)."
            )
        q = alpha + r
        vel_map = {str(k): str(v) for k, v in (velocities or {}).items()}
        qd = tuple(sp.Symbol(vel_map.get(str(s), f"{s}_dot"), real=True) for s in q)
        if len({str(s) for s in q + qd}) != 2 * len(q):
            raise SymbolicError(f"Coordinate and velocity names must be distinct, got {[str(s) for s in q + qd]}.")
        expr, values = bind_expression(lagrangian, parameters, q + qd, "lagrangian")
        M, linear, Vr = _quadratic_split(expr, qd)
        linear = [t if t == 0 else sp.simplify(t) for t in linear]
        if any(t != 0 for t in linear):
            bad = [str(v) for v, t in zip(qd, linear) if t != 0]
            raise SymbolicError(
                f"`lagrangian` has terms linear in the velocities {bad} (gyroscopic or magnetic terms); "
                "Theorem 2.1 needs a simple mechanical Lagrangian 1/2 qdot^T M(q) qdot - V(q)."
            )
        if any(Vr.has(a) for a in alpha):
            Vr = sp.simplify(Vr)
        if any(Vr.has(a) for a in alpha):
            raise SymbolicError(
                f"The potential V = {Vr} depends on the group coordinates {[str(a) for a in alpha if Vr.has(a)]}:"
                f" it is not invariant under {G.name}."
            )
        Mred = _reduced_mass_matrix(G, alpha, M)
        system = cls(
            G,
            alpha,
            r,
            qd[: G.dim],
            qd[G.dim :],
            expr,
            sp.Matrix(M),
            Vr,
            Mred,
            values,
            tuple(int(i) for i in angle_shapes),
            name,
        )
        if any(i < 0 or i >= len(r) for i in system.angle_shapes):
            raise InputError(f"Expected `angle_shapes` to index the {len(r)} shape coordinates, got {angle_shapes}.")
        if check_invariance:
            system._check_invariance()
        return system

    @classmethod
    def from_reduced(
        cls,
        reduced_lagrangian: Any,
        group: Any,
        body_velocities: Sequence[Any],
        shape_coordinates: Sequence[Any],
        *,
        group_coordinates: Sequence[Any] | None = None,
        velocities: Mapping[Any, Any] | None = None,
        parameters: Mapping[str, float] | None = None,
        angle_shapes: Sequence[int] = (),
        name: str = "holonomic system",
    ) -> HolonomicSystem:
        """A system from its reduced Lagrangian :math:`l(r, \\xi, \\dot r)` (Theorem 2.1), the body
        velocity :math:`\\xi` named by ``body_velocities`` in the group's algebra order; the Lagrangian on
        :math:`TQ` is :math:`l` with :math:`\\xi = B(\\alpha)\\dot\\alpha`."""
        G = _chart(group, group_coordinates)
        xi = _symbols(body_velocities, "body_velocities")
        if len(xi) != G.dim:
            raise ShapeError(f"Expected {G.dim} `body_velocities` ({', '.join(G.algebra_names)}), got {len(xi)}.")
        alpha = G.coordinates
        vel_map = {str(k): str(v) for k, v in (velocities or {}).items()}
        ad = [sp.Symbol(vel_map.get(str(a), f"{a}_dot"), real=True) for a in alpha]
        r = _symbols(shape_coordinates, "shape_coordinates")
        rd = [sp.Symbol(vel_map.get(str(s), f"{s}_dot"), real=True) for s in r]
        expr, values = bind_expression(reduced_lagrangian, parameters, xi + r + tuple(rd), "reduced_lagrangian")
        body = G.body_velocity_matrix * sp.Matrix(ad)
        full = expr.xreplace(dict(zip(xi, body)))
        names = {str(a): str(v) for a, v in zip(alpha + r, ad + rd)}
        return cls.from_lagrangian(
            full,
            G,
            r,
            group_coordinates=alpha,
            velocities=names,
            parameters=values,
            angle_shapes=angle_shapes,
            name=name,
            check_invariance=False,
        )

    def with_parameters(self, **values: float) -> HolonomicSystem:
        """The same system with other parameter values (every parameter already has one)."""
        unknown = sorted(set(values) - set(self.parameters))
        if unknown:
            raise InputError(
                f"Unknown parameter(s) {unknown}; the parameters of {self.name} are "
                f"{sorted(self.parameters) or 'none'}."
            )
        bad = {k: v for k, v in values.items() if not np.isfinite(float(v))}
        if bad:
            raise InputError(f"Expected finite parameter values, got {bad}.")
        merged = {**self.parameters, **{k: float(v) for k, v in values.items()}}
        return dataclasses.replace(self, parameters=merged)

    def _check_invariance(self, samples: int = 4, rtol: float = 1e-9) -> None:
        """Compare the reduced mass matrix at random group coordinates with the one at the reference."""
        G, alpha, r = self.group, self.group_coordinates, self.shape_coordinates
        sub = self._substitutions
        # M_red(alpha, r) = T^T M T, T = diag(B^{-1}, 1): invariance <=> independent of alpha.
        Bfun = compile_vector(G.body_velocity_matrix.tolist(), alpha)
        Mfun = compile_vector(self.mass_matrix.subs(sub).tolist(), alpha + r)
        red = self.reduced_mass_function
        rng = np.random.default_rng(7)
        k = G.dim
        # about the chart's regular reference point (away from the gimbal lock of Euler angles)
        ref = np.array([float(v) for v in G.reference])
        for _ in range(samples):
            a = ref + rng.uniform(-1.2, 1.2, k)
            x = rng.uniform(0.5, 1.3, len(r))  # positive: some shapes are lengths
            T = np.eye(k + len(r))
            T[:k, :k] = np.linalg.inv(Bfun(a))
            got = T.T @ Mfun(np.concatenate([a, x])) @ T
            want = red(x)
            scale = max(1.0, np.abs(want).max())
            if np.abs(got - want).max() > rtol * scale:
                raise SymbolicError(
                    f"The kinetic energy of `lagrangian` is not invariant under the left action of {G.name}: "
                    f"its reduced mass matrix changes with the group coordinates {[str(s) for s in alpha]} "
                    f"(by {np.abs(got - want).max():.3g} at alpha = {np.round(a, 3).tolist()}); check that "
                    "positions are written as g applied to body-frame positions."
                )

    # -- symbolic objects ---------------------------------------------------------------------------
    @property
    def shape_dim(self) -> int:
        return len(self.shape_coordinates)

    @property
    def coordinates(self) -> tuple[sp.Symbol, ...]:
        return self.group_coordinates + self.shape_coordinates

    @property
    def velocities(self) -> tuple[sp.Symbol, ...]:
        return self.group_velocities + self.shape_velocities

    @cached_property
    def _substitutions(self) -> dict[sp.Symbol, float]:
        return {sp.Symbol(k, real=True): v for k, v in self.parameters.items()}

    @cached_property
    def body_velocity_symbols(self) -> tuple[sp.Symbol, ...]:
        """Symbols of :math:`\\xi` used in :meth:`reduced_lagrangian`."""
        return _symbols(self.group.algebra_names, "xi")

    def reduced_lagrangian(self) -> sp.Expr:
        """:math:`l(r, \\xi, \\dot r) = \\tfrac12 (\\xi, \\dot r)^T M_{red}(r) (\\xi, \\dot r) - V(r)`."""
        v = sp.Matrix(self.body_velocity_symbols + self.shape_velocities)
        return sp.expand((v.T * self.reduced_mass_matrix * v)[0, 0] / 2) - self.potential

    # -- numeric kernels ---------------------------------------------------------------------------
    def compile(self, exprs: Any, variables: Sequence[sp.Symbol]) -> Callable[[np.ndarray], np.ndarray]:
        """Compile expressions (parameters substituted) to a function of ``(..., len(variables))``."""
        sub = self._substitutions
        if isinstance(exprs, sp.MatrixBase):
            return compile_vector(exprs.subs(sub).tolist(), variables)
        if isinstance(exprs, sp.Expr):
            return compile_vector([exprs.subs(sub)], variables)
        return compile_vector([sp.sympify(e).subs(sub) for e in exprs], variables)

    @cached_property
    def reduced_mass_function(self) -> Callable[[np.ndarray], np.ndarray]:
        """``r -> M_red(r)``, shape ``(..., k + n, k + n)``."""
        return self.compile(self.reduced_mass_matrix, self.shape_coordinates)

    @cached_property
    def _euler_lagrange(self) -> tuple[Callable, Callable]:
        """``M(q)`` and ``f(q, qdot)`` with ``M qddot = f`` the Euler-Lagrange equations (no forcing)."""
        q, qd = self.coordinates, self.velocities
        L = self.lagrangian
        # d/dt dL/dqdot_i = M qddot + sum_j d^2L/(dqdot_i dq_j) qdot_j; f collects the rest.
        f = [sp.diff(L, q[i]) - sum(sp.diff(L, qd[i], q[j]) * qd[j] for j in range(len(q))) for i in range(len(q))]
        return self.compile(self.mass_matrix, q), self.compile(f, q + qd)

    def shape_matrix(self, r: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Blocks of :math:`M_{red}(r)`: the locked inertia :math:`\\mathbb I_{loc}`, the product
        :math:`\\mathbb I_{loc} A_{loc}` and the shape block :math:`m(r)`."""
        r = V.trailing_shape(r, "r", (self.shape_dim,))
        M = self.reduced_mass_function(r)
        k = self.group.dim
        return M[..., :k, :k], M[..., :k, k:], M[..., k:, k:]

    def body_velocity_matrix_function(self) -> Callable[[np.ndarray], np.ndarray]:
        """``alpha -> B(alpha)``, ``xi = B(alpha) alpha_dot``."""
        return self.compile(self.group.body_velocity_matrix, self.group_coordinates)

    def group_velocity(self, alpha: Any, r: Any, rdot: Any, mu: Any) -> np.ndarray:
        """:math:`\\dot\\alpha` with spatial momentum :math:`\\mu` at :math:`(\\alpha, r, \\dot r)`:
        :math:`\\dot\\alpha = B^{-1}(-A_{loc}\\dot r + \\mathbb I_{loc}^{-1}\\mathrm{Ad}_g^*\\mu)` (eq. 2.2)."""
        k = self.group.dim
        alpha = V.exact_shape(alpha, "alpha", (k,))
        r = V.exact_shape(r, "r", (self.shape_dim,))
        rdot = V.exact_shape(rdot, "rdot", (self.shape_dim,))
        mu = V.exact_shape(np.atleast_1d(mu), "mu", (k,))
        I, IA, _ = self.shape_matrix(r)
        g = self.group.from_coordinates(alpha)
        p = self.group.numeric.Ad(g).T @ mu
        xi = np.linalg.solve(I, p - IA @ rdot)
        B = np.asarray(self.body_velocity_matrix_function()(alpha), dtype=float)
        return np.linalg.solve(B, xi)

    def simulate(
        self, q0: Any, qdot0: Any, t_eval: Any, *, shape: Any = None, rtol: float = 1e-12, atol: float = 1e-12
    ) -> Any:
        """Integrate the Euler-Lagrange equations of :math:`L` in the coordinates :math:`(\\alpha, r)`.

        With ``shape=None`` the whole system moves freely; with a shape path (an object with ``r(t)``,
        ``rdot(t)``, ``rddot(t)``, e.g. a :class:`~geomech.systems.Gait`) the shape is
        prescribed (driven by shape forces only) and the group coordinates obey
        :math:`M_{\\alpha\\alpha}\\ddot\\alpha = f_\\alpha - M_{\\alpha r}\\ddot r`. This is the direct
        route, independent of the connection; in Euler-angle coordinates it fails near gimbal lock.

        Returns the ``scipy`` solution with ``q = y[:, :N]``, ``qdot = y[:, N:]`` at ``t_eval``.
        """
        from scipy.integrate import solve_ivp

        from ..errors import NumericalError

        N, k = len(self.coordinates), self.group.dim
        t_eval = V.finite(t_eval, "t_eval")
        q0 = V.exact_shape(q0, "q0", (N,))
        qdot0 = V.exact_shape(qdot0, "qdot0", (N,))
        Mf, ff = self._euler_lagrange
        if shape is None:

            def rhs(_t, y):
                acc = np.linalg.solve(Mf(y[:N]), ff(y))
                return np.concatenate([y[N:], acc])

            y0 = np.concatenate([q0, qdot0])
        else:

            def rhs(t, y):
                r, rd, rdd = shape.r(t), shape.rdot(t), shape.rddot(t)
                q = np.concatenate([y[:k], r])
                Mq = Mf(q)
                f = ff(np.concatenate([q, y[k:], rd]))
                acc = np.linalg.solve(Mq[:k, :k], f[:k] - Mq[:k, k:] @ rdd)
                return np.concatenate([y[k:], acc])

            y0 = np.concatenate([q0[:k], qdot0[:k]])
        sol = solve_ivp(rhs, (t_eval[0], t_eval[-1]), y0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
        if sol.status != 0:
            raise NumericalError(
                f"Euler-Lagrange integration of {self.name} failed at t = {sol.t[-1]:.6g}: {sol.message}"
            )
        if shape is not None:
            rs = np.stack([shape.r(t) for t in sol.t])
            rds = np.stack([shape.rdot(t) for t in sol.t])
            y = np.concatenate([sol.y[:k].T, rs, sol.y[k:].T, rds], 1)
        else:
            y = sol.y.T
        sol.q, sol.qdot = y[:, :N], y[:, N:]
        return sol

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
        return (
            f"HolonomicSystem({self.name!r}, group={self.group.name}, shape={[str(s) for s in self.shape_coordinates]})"
        )


def _quadratic_split(expr: sp.Expr, qd: Sequence[sp.Symbol]) -> tuple[sp.Matrix, list, sp.Expr]:
    """``expr = 1/2 qd^T M qd + b . qd - V``: return ``(M, b, V)``, term by term (much faster than a
    Hessian of a long expanded sum), or :class:`SymbolicError` if ``expr`` is not quadratic in ``qd``."""
    n = len(qd)
    index = {v: i for i, v in enumerate(qd)}
    M = [[sp.Integer(0)] * n for _ in range(n)]
    b = [sp.Integer(0)] * n
    V0 = sp.Integer(0)
    for term in sp.Add.make_args(sp.expand(expr)):
        c, mon = term.as_independent(*qd, as_Add=False)
        powers = mon.as_powers_dict() if mon != 1 else {}
        if any(v not in index or not (e.is_Integer and e > 0) for v, e in powers.items()):
            raise SymbolicError(f"Expected `lagrangian` to be a polynomial in the velocities, got the term {term}.")
        deg = sum(int(e) for e in powers.values())
        if deg > 2:
            raise SymbolicError(f"Expected `lagrangian` to be quadratic in the velocities, got the term {term}.")
        idx = [index[v] for v, e in powers.items() for _ in range(int(e))]
        if deg == 0:
            V0 -= c
        elif deg == 1:
            b[idx[0]] += c
        elif idx[0] == idx[1]:
            M[idx[0]][idx[0]] += 2 * c
        else:
            M[idx[0]][idx[1]] += c
            M[idx[1]][idx[0]] += c
    return sp.Matrix(M), b, V0


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
