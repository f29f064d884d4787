r"""The mechanical connection of a holonomic system with symmetry (section 2.1 of the nonholonomic paper).

For a simple mechanical system on :math:`Q = G\times S` with a free left action
(:class:`~geomech.systems.holonomic.HolonomicSystem`) the mechanical connection is the "angular velocity
of the locked system" (eq. 2.1)

.. math::

    \mathcal A(q, v) = \mathbb I(q)^{-1} J(q, v), \qquad
    \langle J(q, v), \zeta\rangle = \langle\!\langle v, \zeta_Q(q)\rangle\!\rangle, \qquad
    \langle \mathbb I(q)\zeta, \eta\rangle = \langle\!\langle \zeta_Q(q), \eta_Q(q)\rangle\!\rangle,

with :math:`\zeta_Q` the infinitesimal generators and :math:`\langle\!\langle\,,\rangle\!\rangle` the
kinetic-energy metric. In the trivialisation :math:`q = (g, r)` it has the local form
:math:`\mathcal A(g, r)(\dot g, \dot r) = \mathrm{Ad}_g(g^{-1}\dot g + A_{loc}(r)\dot r)` and
:math:`\mathbb I(g, r) = \mathrm{Ad}_{g^{-1}}^*\,\mathbb I_{loc}(r)\,\mathrm{Ad}_{g^{-1}}`.

Murray's splitting (Theorem 2.1): the reduced Lagrangian is

.. math::

    l(r, \dot r, \xi) = \tfrac12 (\xi^T, \dot r^T)
        \begin{pmatrix} \mathbb I & \mathbb I A \\ A^T\mathbb I & m(r)\end{pmatrix}
        \begin{pmatrix}\xi\\ \dot r\end{pmatrix} - V(r)
      = \tfrac12 (\xi + A\dot r)^T\mathbb I(\xi + A\dot r) + \tfrac12\dot r^T(m - A^T\mathbb I A)\dot r - V,

so :math:`\mathbb I_{loc}` and :math:`A_{loc}` can be read off the reduced mass matrix;
:class:`MechanicalConnection` does both that and the direct construction from :math:`J` and
:math:`\mathbb I`, and they agree (tested).

Curvature of the local form (the sign fixed by the reconstruction :math:`g^{-1}\dot g = -A\dot r` at
zero momentum, so that a small loop of area :math:`\varepsilon^2` in the :math:`(r_i, r_j)` plane gives
the holonomy :math:`\exp(-\varepsilon^2 B_{ij})`):

.. math::

    B_{ij}(r) = \partial_i A_j - \partial_j A_i - [A_i, A_j],

with :math:`A_i` the :math:`i`-th column of :math:`A_{loc}` and :math:`[\,,]` the Lie bracket; the bracket
term vanishes for abelian :math:`G` (then :math:`B = dA`).
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, SingularityError
from ..symbolic.simplify import simplify_expr, tidy_trig

__all__ = ["MechanicalConnection"]


class MechanicalConnection:
    """Momentum map, locked inertia, mechanical connection and its curvature of a holonomic system.

    Parameters
    ----------
    system : HolonomicSystem

    Notes
    -----
    Numeric methods take shapes ``r`` of shape ``(..., n)`` and are vectorised. Momenta are in the
    dual of the algebra with the Euclidean pairing; a spatial momentum :math:`\\mu` and the body momentum
    :math:`p = \\mathrm{Ad}_g^*\\mu = \\mathrm{Ad}_g^T\\mu` (eq. 2.2).
    """

    def __init__(self, system: Any):
        from ..systems.holonomic import HolonomicSystem

        if not isinstance(system, HolonomicSystem):
            raise InputError(f"Expected `system` to be a HolonomicSystem, got {type(system).__name__}.")
        self.system = system
        self.group = system.group
        self.k = system.group.dim
        self.n = system.sigma

    # -- Theorem 2.1: read off the reduced mass matrix ---------------------------------------------
    @property
    def locked_inertia_expression(self) -> sp.Matrix:
        """:math:`\\mathbb I_{loc}(r)`, the upper-left block of the reduced mass matrix."""
        return self.system.reduced_mass_matrix[: self.k, : self.k]

    @property
    def momentum_coupling_expression(self) -> sp.Matrix:
        """:math:`\\mathbb I_{loc} A_{loc}(r)`, the upper-right block of the reduced mass matrix."""
        return self.system.reduced_mass_matrix[: self.k, self.k :]

    @property
    def shape_metric_expression(self) -> sp.Matrix:
        """:math:`m(r)`, the lower-right block (the full shape metric, not the reduced one)."""
        return self.system.reduced_mass_matrix[self.k :, self.k :]

    def connection_expression(self, *, numeric: bool = False) -> sp.Matrix:
        """:math:`A_{loc}(r) = \\mathbb I_{loc}^{-1}(\\mathbb I_{loc}A_{loc})`, shape ``(k, n)``.

        With symbolic parameters the entries are only brought over a common denominator (simplifying
        them is slow for chains of bodies); ``numeric=True`` substitutes the parameter values first and
        simplifies fully.
        """
        I, C = self.locked_inertia_expression, self.momentum_coupling_expression
        if numeric:
            sub = self.system.parameter_values()
            A = I.subs(sub).LUsolve(C.subs(sub))
            return A.applyfunc(lambda e: sp.trigsimp(sp.cancel(e)) if e.has(sp.sin, sp.cos) else sp.cancel(e))
        return I.LUsolve(C).applyfunc(lambda e: sp.factor_terms(sp.together(e)))

    def reduced_shape_metric_expression(self) -> sp.Matrix:
        """:math:`m - A^T\\mathbb I A` (the kinetic metric of the shape at zero momentum)."""
        A = self.connection_expression()
        return (self.shape_metric_expression - A.T * self.locked_inertia_expression * A).applyfunc(sp.together)

    def murray_lagrangian(self) -> sp.Expr:
        """:math:`\\tfrac12(\\xi + A\\dot r)^T\\mathbb I(\\xi + A\\dot r) + \\tfrac12\\dot r^T(m - A^T\\mathbb IA)
        \\dot r - V(r)`, in :attr:`HolonomicSystem.xi` and the shape velocities."""
        s = self.system
        xi = sp.Matrix(s.xi)
        rd = sp.Matrix(s.shape_dot)
        A = self.connection_expression()
        u = xi + A * rd
        return (
            (u.T * self.locked_inertia_expression * u)[0, 0] / 2
            + (rd.T * self.reduced_shape_metric_expression() * rd)[0, 0] / 2
            - s.potential
        )

    # -- section 2.1: the direct construction on TQ -------------------------------------------------
    @cached_property
    def generators_expression(self) -> sp.Matrix:
        """Infinitesimal generators :math:`\\zeta_Q` of the basis of the algebra, as the columns of an
        ``(N, k)`` matrix in the coordinates :math:`(\\alpha, r)`: :math:`\\dot g = \\hat\\zeta g`, i.e.
        :math:`\\dot\\alpha = B(\\alpha)^{-1}\\mathrm{Ad}_{g^{-1}}\\zeta` and :math:`\\dot r = 0`."""
        G = self.group
        top = G.body_velocity_inverse * G.Ad_matrix(inverse=True)
        return sp.Matrix.vstack(top.applyfunc(simplify_expr), sp.zeros(self.n, self.k))

    @cached_property
    def _direct_blocks(self) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
        s = self.system
        Xi = self.generators_expression
        M = s.mass_matrix
        return Xi, (Xi.T * M * Xi), M

    def locked_inertia_spatial_expression(self) -> sp.Matrix:
        """:math:`\\mathbb I(q)` with :math:`\\langle\\mathbb I\\zeta, \\eta\\rangle = \\zeta_Q^T M \\eta_Q`."""
        return self._direct_blocks[1]

    def momentum_map_expression(self) -> sp.Matrix:
        """:math:`J(q, \\dot q) = \\zeta_Q^T M(q)\\dot q`, the spatial momentum, shape ``(k, 1)``."""
        Xi, _, M = self._direct_blocks
        return Xi.T * M * sp.Matrix(self.system.qdot)

    def local_forms_direct(self) -> tuple[sp.Matrix, sp.Matrix]:
        """:math:`(\\mathbb I_{loc}, \\mathbb I_{loc}A_{loc})` by the direct route, at the group's reference
        point :math:`g_0` of the chart: :math:`\\mathbb I_{loc} = \\mathrm{Ad}_{g_0}^T\\mathbb I(g_0, r)
        \\mathrm{Ad}_{g_0}` and :math:`\\mathbb I_{loc}A_{loc}\\dot r = \\mathrm{Ad}_{g_0}^T J(g_0, r; 0, \\dot r)`
        (from :math:`J(g, r; \\dot g, \\dot r) = \\mathrm{Ad}_{g^{-1}}^T\\mathbb I_{loc}(g^{-1}\\dot g +
        A_{loc}\\dot r)`)."""
        s, G = self.system, self.group
        sub = dict(zip(s.group.coordinates, G.reference))
        Ad0 = G.Ad_matrix(G.matrix.subs(sub))
        I_sp = self.locked_inertia_spatial_expression().subs(sub)
        J = self.momentum_map_expression().subs(sub).subs({v: 0 for v in s.qdot[: s.k]})
        IA = sp.Matrix(self.k, self.n, lambda a, j: sp.diff(J[a], s.shape_dot[j]))
        return (Ad0.T * I_sp * Ad0).applyfunc(tidy_trig), (Ad0.T * IA).applyfunc(tidy_trig)

    # -- numeric ---------------------------------------------------------------------------------
    @cached_property
    def _kernels(self):
        s = self.system
        r = s.shape
        Mred = s.reduced_mass_matrix
        dM = [Mred.diff(ri) for ri in r]
        return s.reduced_mass_function, s.compile(sp.Matrix.vstack(*dM), r)

    def _blocks(self, r: Any, derivative: bool = False):
        r = V.trailing_shape(r, "r", (self.n,))
        Mf, dMf = self._kernels
        M = Mf(r)
        k = self.k
        I, C = M[..., :k, :k], M[..., :k, k:]
        if not derivative:
            return r, I, C, None, None
        dM = dMf(r).reshape(r.shape[:-1] + (self.n, k + self.n, k + self.n))
        return r, I, C, dM[..., :k, :k], dM[..., :k, k:]

    @staticmethod
    def _solve(I: np.ndarray, C: np.ndarray, r: np.ndarray) -> np.ndarray:
        try:
            cond = np.linalg.cond(I)
        except np.linalg.LinAlgError:
            cond = np.inf
        if np.any(~np.isfinite(cond)) or np.any(cond > 1e13):
            i = np.unravel_index(int(np.argmax(np.where(np.isfinite(cond), cond, np.inf))), np.shape(cond))
            raise SingularityError(
                f"The locked inertia is singular at r = {np.round(r[i], 6).tolist()} (condition number "
                f"{np.asarray(cond)[i]:.3g}): the mechanical connection I^-1 J is undefined there."
            )
        return np.linalg.solve(I, C)

    def locked_inertia(self, r: Any) -> np.ndarray:
        """:math:`\\mathbb I_{loc}(r)`, shape ``(..., k, k)``."""
        return self._blocks(r)[1]

    def connection(self, r: Any) -> np.ndarray:
        """:math:`A_{loc}(r)`, shape ``(..., k, n)``; :class:`SingularityError` where :math:`\\mathbb I` is
        singular."""
        r, I, C, _, _ = self._blocks(r)
        return self._solve(I, C, r)

    def connection_derivative(self, r: Any) -> np.ndarray:
        """:math:`\\partial_i A_{loc}(r)`, shape ``(..., n, k, n)`` (index ``i`` first):
        :math:`\\partial_i A = \\mathbb I^{-1}(\\partial_i(\\mathbb IA) - \\partial_i\\mathbb I\\, A)`."""
        r, I, C, dI, dC = self._blocks(r, derivative=True)
        A = self._solve(I, C, r)
        rhs = dC - dI @ A[..., None, :, :]
        return np.linalg.solve(I[..., None, :, :], rhs)

    def curvature(self, r: Any) -> np.ndarray:
        """:math:`B_{ij}(r) = \\partial_iA_j - \\partial_jA_i - [A_i, A_j]`, shape ``(..., k, n, n)``
        (antisymmetric in the last two indices)."""
        r = V.trailing_shape(r, "r", (self.n,))
        A = self.connection(r)
        dA = self.connection_derivative(r)  # (..., i, a, j) = d_i A^a_j
        dA = np.moveaxis(dA, -3, -2)  # (..., a, i, j)
        B = dA - np.swapaxes(dA, -1, -2)  # d_i A_j - d_j A_i at [a, i, j]
        if not self.group.abelian:
            Ai = np.swapaxes(A, -1, -2)  # (..., n, k): A_i
            ad = self.group.numeric.ad(Ai)  # (..., n, k, k)
            br = np.einsum("...iab,...jb->...aij", ad, Ai)
            B = B - br
        return B

    def curvature_2d(self, r: Any) -> np.ndarray:
        """:math:`B_{12}(r)`, shape ``(..., k)``, on a 2-D shape space."""
        if self.n != 2:
            raise InputError(
                f"`curvature_2d` needs a 2-D shape space, {self.system.name} has {self.n} shape "
                "coordinates; use `curvature`."
            )
        return self.curvature(r)[..., :, 0, 1]

    def curvature_expression(self, *, numeric: bool = False) -> sp.Matrix:
        """:math:`B_{12}` symbolically on a 2-D shape space (``(k, 1)``), or all :math:`B_{ij}` as a
        ``(k, n*n)`` matrix (``[a, i*n + j]``) otherwise; ``numeric`` as in :meth:`connection_expression`."""
        A, r = self.connection_expression(numeric=numeric), self.system.shape
        n = self.n
        # trigsimp of derivatives of A is slow for chains of bodies: bring over a common denominator only.
        tidy = sp.cancel if numeric else (lambda e: sp.factor_terms(sp.together(e)))
        cols = []
        for i in range(n):
            for j in range(n):
                b = A[:, j].diff(r[i]) - A[:, i].diff(r[j])
                if not self.group.abelian:
                    b = b - self.group.bracket(list(A[:, i]), list(A[:, j]))
                cols.append(b.applyfunc(tidy))
        if n == 2:
            return cols[1]
        return sp.Matrix.hstack(*cols)

    def body_velocity(self, r: Any, rdot: Any, p: Any) -> np.ndarray:
        """:math:`\\xi = -A_{loc}(r)\\dot r + \\mathbb I_{loc}^{-1}(r)p` (eq. 2.2), shape ``(..., k)``."""
        r, I, C, _, _ = self._blocks(r)
        rdot = V.trailing_shape(rdot, "rdot", (self.n,))
        p = V.trailing_shape(np.atleast_1d(p), "p", (self.k,))
        rhs = np.broadcast_to(p, np.broadcast_shapes(p.shape, I.shape[:-1]))[..., None] - C @ rdot[..., None]
        return self._solve(I, rhs, r)[..., 0]

    def momentum_map(self, alpha: Any, r: Any, alpha_dot: Any, rdot: Any) -> np.ndarray:
        """Spatial momentum :math:`J = \\mathrm{Ad}_{g^{-1}}^T\\mathbb I_{loc}(g^{-1}\\dot g + A_{loc}\\dot r)`."""
        G = self.group
        alpha = V.trailing_shape(alpha, "alpha", (self.k,))
        alpha_dot = V.trailing_shape(alpha_dot, "alpha_dot", (self.k,))
        r, I, C, _, _ = self._blocks(r)
        rdot = V.trailing_shape(rdot, "rdot", (self.n,))
        B = np.asarray(self.system.body_velocity_matrix_function(alpha))
        xi = np.einsum("...ij,...j->...i", B, alpha_dot)
        p = np.einsum("...ij,...j->...i", I, xi) + np.einsum("...ij,...j->...i", C, rdot)
        Ad_inv = G.numeric.Ad(G.numeric.inverse(G.from_coordinates(alpha)))
        return np.einsum("...ji,...j->...i", Ad_inv, p)

    def __repr__(self) -> str:
        return f"MechanicalConnection({self.system!r})"
