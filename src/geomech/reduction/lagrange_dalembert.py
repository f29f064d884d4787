r"""The Lagrange-d'Alembert equations of a nonholonomic system, with and without multipliers.

:math:`M(q)\ddot q = f(q, \dot q) + A(q)^T\lambda + B\tau`, :math:`A(q)\dot q = 0`: the multipliers (constraint
forces) as expressions, on and off the distribution :math:`\mathcal D`, the accelerations, and the projected
equations :math:`X^T(M\ddot q - f - B\tau) = 0` with :math:`X` a basis of :math:`\mathcal D`. The multipliers on
:math:`\mathcal D` use a kinetic-orthogonal complement :math:`Z` of the constraints (:math:`AZ = I`,
:math:`X^T M Z = 0`). BKMM's reduction of these equations is :mod:`geomech.reduction.nonholonomic`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

from ..errors import InputError, SymbolicError
from ..symbolic import (
    NumericCache,
    clear_denominators,
    column,
    compile_matrix,
    derivative,
    expand_terms,
    inverse,
    jacobian,
    quadratic_form,
    shared_property,
    shared_value,
    simplified_inverse,
    simplify_expr,
    simplify_matrix,
    stack_last,
    suffixed_symbols,
    time_derivative,
)
from ..systems.nonholonomic import NonholonomicSystem
from ._derived import Derived, Labelled

if TYPE_CHECKING:
    from .nonholonomic import NonholonomicReduction

__all__ = ["LagrangeDAlembert", "LagrangeDAlembertNumeric", "lagrange_dalembert"]

_simp_matrix = simplify_matrix
_dt = time_derivative
_clear_denominators = clear_denominators
_NumericMixin = NumericCache


# --------------------------------------------------------------------------------------------------
# Lagrange-d'Alembert equations
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LagrangeDAlembert(Derived, _NumericMixin):
    r"""The Lagrange-d'Alembert equations of a nonholonomic system, with and without multipliers.

    Attributes
    ----------
    system : NonholonomicSystem
    qddot, lam, tau : tuple of Symbol
        Accelerations, multipliers :math:`\lambda_a` (one per constraint), shape forces :math:`\tau_\alpha`.
    mass_matrix : Matrix (n, n)
        :math:`\mathbb M(q)`.
    forces : Matrix (n, 1)
        :math:`f(q, \dot q) = \partial L/\partial q - (\partial^2 L/\partial\dot q\,\partial q)\dot q`.
    constraint_matrix : Matrix (c, n)
        :math:`A(q)`.
    constraint_drift : Matrix (c, 1)
        :math:`\dot A\,\dot q`, so that the differentiated constraints read :math:`A\ddot q + \dot A\dot q = 0`.
    """

    system: NonholonomicSystem
    qddot: tuple[sp.Symbol, ...]
    lam: tuple[sp.Symbol, ...]
    tau: tuple[sp.Symbol, ...]
    mass_matrix: sp.ImmutableMatrix = field(repr=False)
    forces: sp.ImmutableMatrix = field(repr=False)
    constraint_matrix: sp.ImmutableMatrix = field(repr=False)
    constraint_drift: sp.ImmutableMatrix = field(repr=False)
    title: str = "Lagrange-d'Alembert equations"

    @property
    def _cache_key(self) -> tuple:
        return (self.system.key,)

    @property
    def input_matrix(self) -> sp.Matrix:
        r""":math:`B = (0, I_\\sigma)^T`: the shape forces act on the shape coordinates only."""
        s = self.system
        return sp.Matrix.vstack(sp.zeros(s.k, s.sigma), sp.eye(s.sigma))

    @shared_property
    def equations(self) -> sp.ImmutableMatrix:
        r"""Left-hand sides (= 0) of :math:`\mathbb M\ddot q - f - A^T\lambda - B\tau = 0`."""
        M, A = sp.Matrix(self.mass_matrix), sp.Matrix(self.constraint_matrix)
        lhs = M * column(self.qddot) - self.forces - A.T * column(self.lam) - self.input_matrix * column(self.tau)
        return sp.ImmutableMatrix(expand_terms(lhs))

    @shared_property
    def _solved(self) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
        # With X a basis of D (A X = 0) and Y a right inverse of A (A Y = I): qddot = X a + Y b, b = -Adot qdot from
        # the differentiated constraints, a = (X^T M X)^{-1} X^T (F - M Y b) from the projected equations, and
        # lambda = Y^T (M qddot - F). Only (X^T M X)^{-1} is inverted: it exists whenever M is positive definite on
        # D (M itself may be singular, as for the point-mass bicycle), and it is smaller than M.
        s = self.system
        M = sp.Matrix(self.mass_matrix)
        F = sp.Matrix(self.forces) + self.input_matrix * column(self.tau)
        X = sp.Matrix(self.projected_equations[1])
        G = _simp_matrix(X.T * M * X)
        Ginv = simplified_inverse(G)
        if s.c == 0:
            qdd = expand_terms(X * Ginv * X.T * F)
            return sp.ImmutableMatrix(sp.zeros(0, 1)), sp.ImmutableMatrix(qdd)
        Y = self._right_inverse()
        b = -sp.Matrix(self.constraint_drift)
        MY = _simp_matrix(M * Y)
        a = Ginv * (X.T * F - (X.T * MY) * b)
        qdd = X * a + Y * b
        lam = (Y.T * M * X) * a + (Y.T * MY) * b - Y.T * F
        return sp.ImmutableMatrix(expand_terms(lam)), sp.ImmutableMatrix(expand_terms(qdd))

    def _right_inverse(self) -> sp.Matrix:
        """A right inverse :math:`Y` of :math:`A` (:math:`AY = I`) supported on c coordinates: the columns of A with
        the best-conditioned (and shortest) c x c block, inverted symbolically."""
        return sp.Matrix(self._right_inverse_matrix)

    @shared_property
    def _right_inverse_matrix(self) -> sp.ImmutableMatrix:
        s = self.system
        return sp.ImmutableMatrix(_block_right_inverse(sp.Matrix(self.constraint_matrix), s, s.q))

    @shared_property
    def constraint_complement(self) -> sp.ImmutableMatrix:
        r""":math:`Z(q)` (n x c), the right inverse of :math:`A` whose columns are kinetic-orthogonal to
        :math:`\mathcal D`: :math:`AZ = I`, :math:`X^T\mathbb M Z = 0` for a basis :math:`X` of :math:`\mathcal D`
        (simplified).

        :math:`Z = (I - \Pi)Y` for any right inverse :math:`Y` of :math:`A`, with :math:`\Pi = XG^{-1}X^T\mathbb M`
        the kinetic projector onto :math:`\mathcal D` (:math:`G = X^T\mathbb M X`); it does not depend on the
        choice of :math:`Y` or :math:`X`. It carries the constraint forces, :math:`\lambda = Z^T(\mathbb M\ddot q - f
        - B\tau)`, and the Jacobiator of the almost-Poisson bracket (:mod:`geomech.reduction.almost_poisson`).

        Computed in body velocities, where :math:`\mathbb M`, the constraints and the BKMM-adapted basis of
        :math:`\mathcal D` depend on the shape only (:math:`G = \mathrm{diag}(\mathbb I, M)` is block diagonal),
        then carried to coordinates: with :math:`T(g) = \mathrm{diag}(\Lambda(g)^{-1}, I)` and
        :math:`A T = R(g, r)\,(A_\xi, A_r)` (G-invariance of :math:`\mathcal D`), :math:`Z = T Z_{body} R^{-1}`. That
        avoids the spurious denominators of a right inverse in coordinates (e.g. :math:`\sin(\theta + \phi)`). A
        system for which that route fails a numeric check is done in coordinates.
        """
        s = self.system
        if s.c == 0:
            return sp.ImmutableMatrix(sp.zeros(s.n, 0))
        Z = None
        if self._body_complement is not None:
            Zb, R = (sp.Matrix(x) for x in self._body_complement)
            T = sp.diag(sp.Matrix(s.group.body_velocity_inverse), sp.eye(s.sigma))
            Z = _simp_matrix(T * Zb * (sp.eye(s.c) if R == sp.eye(s.c) else _simp_matrix(inverse(R))))
        if Z is None or not _is_complement(s, Z, sp.Matrix(self.projected_equations[1])):
            X = sp.Matrix(self.projected_equations[1])
            M, Y = sp.Matrix(s.mass_matrix), self._right_inverse()
            V = _simp_matrix(inverse(_simp_matrix(X.T * M * X)) * _simp_matrix(X.T * M * Y))
            Z = _simp_matrix(Y - X * V)
        return sp.ImmutableMatrix(Z)

    @shared_property
    def _body_complement(self) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix] | None:
        r"""``(Z_body(r), R(g, r))`` with :math:`Z = T Z_{body} R^{-1}` (:attr:`constraint_complement`), or ``None``
        when the route through body velocities does not apply."""
        try:
            return _complement_in_body_frame(self.system)
        except (ValueError, ZeroDivisionError, SymbolicError):  # e.g. a singular block: coordinates instead
            return None

    @property
    def multipliers(self) -> sp.ImmutableMatrix:
        r""":math:`\lambda(q, \dot q, \tau) = Y^T(\mathbb M\ddot q - f - B\tau)`, the constraint forces being
        :math:`A^T\lambda`; :math:`Y` is a right inverse of :math:`A` (:math:`AY = I`) and :math:`\ddot q` as in
        :attr:`accelerations`
        (expanded, not simplified)."""
        return self._solved[0]

    def multipliers_on_distribution(self, basis: Any = None) -> sp.ImmutableMatrix:
        r""":math:`\lambda` along motions that satisfy the constraints, in the reduced variables
        :math:`(q, \dot r, p, \tau)` (:func:`bkmm_reduction` with ``basis`` for :math:`p`), simplified.
        :attr:`multipliers` is defined off :math:`\mathcal D` too and is much longer; the two agree on
        :math:`\mathcal D`.

        .. math::

            \lambda = Z^T(\mathbb M\ddot q - f - B\tau) = -N\,\dot A\dot q - Z^T(f + B\tau), \qquad
            N = Z^T\mathbb M Z,

        with :math:`Z` the :attr:`constraint_complement` (:math:`Z^T\mathbb M` annihilates :math:`\mathcal D`, so
        only the constraint part :math:`-Z\dot A\dot q` of :math:`\ddot q` enters), evaluated at
        :math:`\dot q = T_w(q)\,w` on :math:`\mathcal D`, :math:`w = (\dot r, p)` (eq. 1.1): a quadratic form in
        :math:`w`, plus terms in :math:`\tau` and the potential, each coefficient a simplified function of
        :math:`q`.
        """
        from .nonholonomic import bkmm_reduction  # BKMM's reduction builds on these equations: imported late

        red = bkmm_reduction(self.system, basis)
        return shared_value(
            self, "multipliers_on_distribution", lambda: self._multipliers_on_d(red), extra=red._cache_key
        )

    def _multipliers_on_d(self, red: NonholonomicReduction) -> sp.ImmutableMatrix:
        # In body velocities v = (xi, rdot), where everything depends on the shape only: the Lagrange-d'Alembert
        # equations read EP = M_b vdot + h(r, v) = A_b^T lambda_b + B tau (Euler-Poincare form; T^T A^T = A_b^T R^T,
        # so lambda = R^{-T} lambda_b), and lambda_b = Z_b^T (EP - B tau) = -N_b Adot_b v + Z_b^T h - Z_b^T B tau
        # with N_b = Z_b^T M_b Z_b, because Z_b^T M_b kills the component of vdot in D and A_b vdot = -Adot_b v.
        s = self.system
        if s.c == 0:
            return sp.ImmutableMatrix(sp.zeros(0, 1))
        if self._body_complement is None:
            return self._multipliers_on_d_coordinates(red)
        Zb, R = (sp.Matrix(x) for x in self._body_complement)
        k, sig, m = s.k, s.sigma, red.m
        l, xi, r, rd = s.body_lagrangian, list(s.xi), list(s.shape), list(s.shape_dot)
        v = xi + rd
        Mb = sp.hessian(l, v)
        Nb = _simp_matrix(Zb.T * Mb * Zb)
        mu = sp.Matrix([derivative(l, x) for x in xi])
        pr = sp.Matrix(sig, 1, [derivative(l, x) for x in rd])
        C = s.group.structure_constants
        ad_star = sp.Matrix(
            k, 1, [sum(mu[a] * C[a][b][d] * xi[b] for a in range(k) for b in range(k)) for d in range(k)]
        )
        dl_dr = sp.Matrix(sig, 1, [derivative(l, x) for x in r])
        h = sp.Matrix.vstack(_dt(mu, r, rd) - ad_star, _dt(pr, r, rd) - dl_dr)
        Ab = sp.Matrix.hstack(*(sp.Matrix(a) for a in s.body_constraints))
        e = -Nb * (_dt(Ab, r, rd) * column(v)) + Zb.T * h
        Tb = sp.Matrix.vstack(
            sp.Matrix.hstack(-sp.Matrix(red.connection), sp.Matrix(red._mu_parts[2])),
            sp.Matrix.hstack(sp.eye(sig), sp.zeros(sig, m)),
        )
        ftau = -Zb[k:, :].T * column(self.tau)
        if R != sp.eye(s.c):
            Rinv_T = simplified_inverse(R).T
            e, ftau = Rinv_T * e, Rinv_T * ftau
        w = list(red.rdot) + list(red.p)
        zero_v = {x: 0 for x in v}
        out = []
        for a in range(s.c):
            # a quadratic form in v, then in w = (rdot, p); every coefficient depends on q only
            S = _simp_matrix(quadratic_form(e[a], v))
            Cw = Tb.T * S * Tb
            terms = [simplify_expr(e[a].xreplace(zero_v))]
            for i in range(len(w)):
                for j in range(i, len(w)):
                    terms.append(simplify_expr(Cw[i, j] + Cw[j, i] if i != j else Cw[i, i]) * w[i] * w[j])
            terms += [simplify_expr(derivative(ftau[a], t)) * t for t in self.tau]
            out.append(sp.Add(*terms))
        return sp.ImmutableMatrix(sp.Matrix(len(out), 1, out))

    def _multipliers_on_d_coordinates(self, red: NonholonomicReduction) -> sp.ImmutableMatrix:
        # the general multipliers with the group velocities of eq. (1.1) inserted (slow: a large simplification)
        s = self.system
        qd_group = sp.Matrix(s.group.body_velocity_inverse) * sp.Matrix(red.reconstruction)
        return _simp_matrix(sp.Matrix(self.multipliers).subs(dict(zip(s.qdot[: s.k], qd_group))))

    @property
    def accelerations(self) -> sp.ImmutableMatrix:
        r""":math:`\ddot q(q, \dot q, \tau) = X a - Y\dot A\dot q`, :math:`a = (X^T\mathbb M X)^{-1}X^T(f + B\tau +
        \mathbb M Y\dot A\dot q)`: the accelerations with the multipliers eliminated (valid on :math:`\mathcal D`;
        expanded, not simplified: :attr:`projected_equations` reads better)."""
        return self._solved[1]

    @shared_property
    def projected_equations(self) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
        r"""The equations without multipliers, :math:`X^T(\mathbb M\ddot q - f - B\tau) = 0`, with :math:`X(q)`
        (n x (n - c), returned second) a basis of :math:`\mathcal D = \ker A`."""
        A = sp.Matrix(self.constraint_matrix)
        s = self.system
        if s.c == 0:
            X = sp.eye(s.n)
        else:
            # the pivots tested for zero by the exact simplifier (sympy's `simplify` there is most of the time)
            vecs = A.nullspace(simplify=simplify_expr, iszerofunc=lambda e: simplify_expr(e) == 0)
            X = sp.Matrix.hstack(*[_clear_denominators(v) for v in vecs])
        lhs = X.T * (
            sp.Matrix(self.mass_matrix) * column(self.qddot) - self.forces - self.input_matrix * column(self.tau)
        )
        return _simp_matrix(lhs), sp.ImmutableMatrix(X)

    def _latex_names(self) -> dict:
        names = dict(self.system.latex_names)
        for q, a in zip(self.system.q, self.qddot):
            names[a] = rf"\ddot{{{sp.latex(q)}}}"
        for i, lam in enumerate(self.lam):
            names[lam] = rf"\lambda_{{{i + 1}}}"
        for r, t in zip(self.system.shape, self.tau):
            names[t] = rf"\tau_{{{sp.latex(r)}}}"
        return names

    def items(self):
        # The multipliers and accelerations valid off D (attributes `multipliers`, `accelerations`) are long
        # expanded forms (megabytes for the roller racer): printed are their forms on D, which read.
        s = self.system
        lhs, X = self.projected_equations
        lam = self.multipliers_on_distribution()
        return [
            ("equations (= 0)", r"\mathbb M\ddot q - f - A^T\lambda - B\tau", self.equations),
            ("constraints (= 0)", r"A(q)\dot q", sp.Matrix(self.constraint_matrix) * column(s.qdot)),
            ("basis of D X(q) (columns)", r"X(q)", X),
            ("projected equations X^T(M qddot - f - B tau) (= 0)", r"X^T(\mathbb M\ddot q - f - B\tau)", lhs),
            (
                "multipliers lambda on D",
                r"\lambda|_{\mathcal D}",
                Labelled((f"lambda{a + 1}(q, rdot, p, tau)", rf"\lambda_{{{a + 1}}}", lam[a]) for a in range(s.c)),
            ),
        ]

    # ---------------- numeric ----------------
    def numeric(self, parameters: Mapping[str, float] | None = None) -> LagrangeDAlembertNumeric:
        """Compiled numeric functions (vectorised over leading axes) with the given parameter values."""
        s = self.system
        x = list(s.q) + list(s.qdot)
        funcs = self._compile(
            parameters,
            {
                "M": self.mass_matrix,
                "f": self.forces,
                "A": self.constraint_matrix,
                "Adq": self.constraint_drift,
                "E": s.energy,
            },
            x,
        )
        return LagrangeDAlembertNumeric(s, funcs)


@dataclass(frozen=True)
class LagrangeDAlembertNumeric:
    """Numeric Lagrange-d'Alembert equations: the multipliers and accelerations by a linear solve.

    Every function takes ``q`` and ``qd`` of shape ``(..., n)`` and ``tau`` of shape ``(..., sigma)``.
    """

    system: NonholonomicSystem
    funcs: dict = field(repr=False)

    def _x(self, q: Any, qd: Any) -> np.ndarray:
        return stack_last(q, qd)

    def mass_matrix(self, q: Any) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        return self.funcs["M"](self._x(q, np.zeros_like(q)))

    def constraint_matrix(self, q: Any) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        return self.funcs["A"](self._x(q, np.zeros_like(q)))

    def energy(self, q: Any, qd: Any) -> np.ndarray:
        return self.funcs["E"](self._x(q, qd))[..., 0, 0]

    def constraint_residual(self, q: Any, qd: Any) -> np.ndarray:
        r""":math:`A(q)\\dot q`, shape (..., c)."""
        A = self.constraint_matrix(q)
        return np.einsum("...ij,...j->...i", A, np.asarray(qd, dtype=float))

    def solve(self, q: Any, qd: Any, tau: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations and multipliers ``(qddot, lam)`` from the index-reduced equations."""
        s = self.system
        x = self._x(q, qd)
        M, f, A, Adq = self.funcs["M"](x), self.funcs["f"](x)[..., 0], self.funcs["A"](x), self.funcs["Adq"](x)[..., 0]
        if tau is not None and s.sigma:
            f = f.copy()
            f[..., s.k :] += np.asarray(tau, dtype=float)
        c = s.c
        K = np.zeros(x.shape[:-1] + (s.n + c, s.n + c))
        K[..., : s.n, : s.n] = M
        K[..., : s.n, s.n :] = -np.swapaxes(A, -1, -2)
        K[..., s.n :, : s.n] = A
        rhs = np.concatenate([f, -Adq], axis=-1)
        sol = np.linalg.solve(K, rhs[..., None])[..., 0]
        return sol[..., : s.n], sol[..., s.n :]

    def multipliers(self, q: Any, qd: Any, tau: Any = None) -> np.ndarray:
        return self.solve(q, qd, tau)[1]

    def accelerations(self, q: Any, qd: Any, tau: Any = None) -> np.ndarray:
        return self.solve(q, qd, tau)[0]


def lagrange_dalembert(system: NonholonomicSystem) -> LagrangeDAlembert:
    """Derive the Lagrange-d'Alembert equations of ``system`` (cached on the system's symbolic content: systems
    that differ only in parameter values share the derivation; each result keeps its own system's values)."""
    if not isinstance(system, NonholonomicSystem):
        raise InputError(f"Expected `system` to be a NonholonomicSystem, got {type(system).__name__}.")
    return LagrangeDAlembert(system, *_lda_fields(system))


@lru_cache(maxsize=64)
def _lda_fields(system: NonholonomicSystem) -> tuple:
    s = system
    names = [q.name for q in s.q]
    qdd = suffixed_symbols("ddot", names)
    lam = tuple(sp.Symbol(f"lambda{i + 1}", real=True) for i in range(s.c))
    tau = suffixed_symbols("", [f"tau_{r.name}" for r in s.shape])
    L = s.lagrangian
    M = sp.Matrix(s.mass_matrix)
    p = sp.Matrix([derivative(L, v) for v in s.qdot])
    f = sp.Matrix([derivative(L, q) for q in s.q]) - jacobian(p, s.q) * column(s.qdot)
    A = sp.Matrix(s.constraint_matrix)
    Adq = _dt(A, s.q, s.qdot) * column(s.qdot)
    return (
        qdd,
        lam,
        tau,
        sp.ImmutableMatrix(M),
        sp.ImmutableMatrix(f.applyfunc(_expand_small)),
        sp.ImmutableMatrix(A),
        sp.ImmutableMatrix(Adq.applyfunc(_expand_small)),
    )


#: Entries with more operations than this are kept as derived: expanding a force of a system with a
#: long potential (the planar N-body's 1/d of Jacobi coordinates) multiplies its size by a thousand.
_EXPAND_LIMIT = 400


def _expand_small(e: sp.Expr) -> sp.Expr:
    """``e`` expanded (a sum of terms, as printed in the equations) where it is small, else as it is."""
    return expand_terms(e) if sp.count_ops(e) <= _EXPAND_LIMIT else e


# --------------------------------------------------------------------------------------------------
# BKMM reduction
# --------------------------------------------------------------------------------------------------


def _block_right_inverse(A: sp.Matrix, system: NonholonomicSystem, variables: Sequence[sp.Symbol]) -> sp.Matrix:
    """A right inverse of ``A`` (c x n) supported on c of its columns: the best-conditioned (and shortest)
    c x c block at a random point, inverted symbolically and simplified."""
    from itertools import combinations

    c, n = A.shape
    pt = system._random_point(np.random.default_rng(3), variables)
    An = np.array(A.subs(pt).evalf(), dtype=float).reshape(c, n)
    best = None
    for cols in combinations(range(n), c):
        cond = np.linalg.cond(An[:, cols])
        if cond > 1e8:
            continue
        cost = (sum(sp.count_ops(A[i, j]) for i in range(c) for j in cols), cond)
        if best is None or cost < best[0]:
            best = (cost, cols)
    if best is None:
        raise SymbolicError(f"{system.name}: no invertible {c} x {c} block of the constraint matrix at a random point.")
    cols = best[1]
    block_inv = simplified_inverse(A[:, list(cols)])
    Y = sp.zeros(n, c)
    for a, j in enumerate(cols):
        Y[j, :] = block_inv[a, :]
    return Y


def _complement_in_body_frame(s: NonholonomicSystem) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix] | None:
    r"""``(Z_body, R)``: :math:`Z = T(g) Z_{body}(r) R^{-1}` (see :attr:`LagrangeDAlembert.constraint_complement`).

    :math:`Z_{body} = (I - X_b G^{-1}X_b^T\mathbb M_b)Y_b` in body velocities, with the BKMM-adapted basis
    :math:`X_b = \begin{pmatrix} e & -\mathcal A^{nh}\\ 0 & I\end{pmatrix}` (so :math:`G = \mathrm{diag}(\mathbb I,
    M)`) and :math:`Y_b` a right inverse of :math:`A_\xi` (rank c); :math:`R = A\,T\,Y_b`."""
    from .nonholonomic import bkmm_reduction

    red = bkmm_reduction(s)
    sig, m = s.sigma, red.m
    Axi = sp.Matrix(s.body_constraints[0])
    Mb = sp.Matrix.vstack(
        sp.Matrix.hstack(red.locked_inertia_full, red.coupling),
        sp.Matrix.hstack(sp.Matrix(red.coupling).T, red.shape_metric),
    )
    Xb = sp.Matrix.vstack(
        sp.Matrix.hstack(red.basis, -sp.Matrix(red.connection)), sp.Matrix.hstack(sp.zeros(sig, m), sp.eye(sig))
    )
    Ginv = sp.diag(*[sp.Matrix(b) for b in (red.locked_inertia_inverse, red.shape_mass_inverse) if b.rows])
    # A_xi has rank c (checked when the system is built): a right inverse on the group columns
    Yb = sp.Matrix.vstack(_block_right_inverse(Axi, s, s.shape), sp.zeros(sig, s.c))
    V = _simp_matrix(Ginv * _simp_matrix(Xb.T * Mb * Yb))
    Zb = _simp_matrix(Yb - Xb * V)
    T = sp.diag(sp.Matrix(s.group.body_velocity_inverse), sp.eye(sig))
    R = _simp_matrix(sp.Matrix(s.constraint_matrix) * T * Yb)
    if any(e.free_symbols & set(s.qdot) for e in R):
        return None
    return sp.ImmutableMatrix(Zb), sp.ImmutableMatrix(R)


def _is_complement(s: NonholonomicSystem, Z: sp.Matrix, X: sp.Matrix) -> bool:
    """``A Z = I`` and ``X^T M Z = 0`` at two random points (parameters random too)."""
    rng = np.random.default_rng(5)
    variables = list(s.q) + list(s.parameter_symbols)
    parts = [sp.Matrix(s.constraint_matrix) * Z, X.T * sp.Matrix(s.mass_matrix) * Z, Z]
    fs = [compile_matrix(m, variables) for m in parts]
    for _ in range(2):
        pt = s._random_point(rng, s.q)
        x = np.array([pt[v] for v in variables], dtype=float)
        AZ, XMZ, Zn = (f(x) for f in fs)
        scale = max(1.0, float(np.abs(Zn).max(initial=0.0)))
        if not (np.allclose(AZ, np.eye(s.c), atol=1e-9 * scale) and np.abs(XMZ).max(initial=0.0) < 1e-9 * scale):
            return False
    return True
