r"""Lagrange-d'Alembert equations and the BKMM reduction of a nonholonomic system with symmetry.

Two derivations, both automatic from a :class:`~geomech.systems.nonholonomic.NonholonomicSystem`:

* :func:`lagrange_dalembert`: the equations with multipliers in coordinates,

  .. math::

      \mathbb M(q)\,\ddot q - f(q, \dot q) = A(q)^T\lambda + B\tau, \qquad A(q)\,\dot q = 0,

  with :math:`f = \partial L/\partial q - (\partial^2 L/\partial\dot q\,\partial q)\,\dot q`, the constraint
  forces :math:`A^T\lambda` (the multipliers solved from the differentiated constraints) and the
  accelerations with the multipliers eliminated; :math:`B\tau` are the shape forces.

* :func:`bkmm_reduction`: the reduction of Bloch, Krishnaprasad, Marsden and Murray, "Nonholonomic
  mechanical systems with symmetry", Arch. Rational Mech. Anal. 136 (1996) 21-99 (BKMM), in the form of
  eqs. (1.1)-(1.3) of the nonholonomic seed,

  .. math::

      g^{-1}\dot g = -\mathcal A^{nh}(r)\,\dot r + \mathbb I^{-1}(r)\,p, \qquad
      \dot p = \dot r^T H(r)\,\dot r + \dot r^T K(r)\,p + p^T D(r)\,p, \qquad
      M(r)\,\ddot r = \delta(r, \dot r, p) + \tau.

Conventions (body form, left action): :math:`\xi = g^{-1}\dot g`; :math:`S_q = \mathcal D_q\cap T_q\mathrm{Orb}`
is :math:`\{\xi : A_\xi(r)\xi = 0\}`; the body-fixed basis :math:`e_i(r)` (columns of ``basis``) spans it;
the nonholonomic momentum is :math:`p_i = \langle \partial l/\partial\xi, e_i(r)\rangle`; the locked inertia
is :math:`\mathbb I_{ij} = \langle e_i, \mathbb I_{\mathrm{loc}}\, e_j\rangle` with
:math:`\mathbb I_{\mathrm{loc}} = \partial^2 l/\partial\xi^2`; the nonholonomic connection
:math:`\mathcal A^{nh}(r)` (k x sigma) is defined by the horizontal space: :math:`(\xi, \dot r) =
(-\mathcal A^{nh}\dot r, \dot r)` satisfies the constraints and is orthogonal, in the kinetic metric, to
every :math:`(e_i, 0)`. Then :math:`\xi = -\mathcal A^{nh}\dot r + e_i\,(\mathbb I^{-1})^{ij} p_j` (eq. 1.1)
and the momentum equation is (BKMM; Theorem 1.2 of the seed)

.. math::

    \dot p_i = \Big\langle \frac{\partial l}{\partial \xi},\; [\xi, e_i] + \frac{\partial e_i}{\partial r^\beta}
    \dot r^\beta \Big\rangle, \qquad [\xi, \eta]^a = C^a_{bd}\,\xi^b\eta^d .

The shape equations are the Lagrange-d'Alembert equations along the horizontal lifts
:math:`(-\mathcal A^{nh}\delta r, \delta r)`; :math:`M(r) = m_{rr} - \Gamma^T\mathcal A - \mathcal A^T\Gamma +
\mathcal A^T\mathbb I_{\mathrm{loc}}\mathcal A` is the kinetic metric on horizontal vectors
(:math:`\Gamma = \partial^2 l/\partial\xi\,\partial\dot r`, :math:`m_{rr} = \partial^2 l/\partial\dot r^2`).
"""

from __future__ import annotations

import weakref
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError, SymbolicError
from ..symbolic import (
    DISK_CACHE,
    NumericCache,
    clear_denominators,
    column,
    derivative,
    quadratic_blocks,
    shared_property,
    simplified_inverse,
    simplify_expr,
    simplify_matrix,
    suffixed_symbols,
    time_derivative,
    to_expression,
)
from ..symbolic.cache import MISSING
from ..systems.nonholonomic import NonholonomicSystem
from ._derived import Derived
from .reduced_numeric import ReducedNumeric

__all__ = [
    "NonholonomicReduction",
    "ReducedNumeric",
    "bkmm_reduction",
    "reduced_numeric",
]

_simp_matrix = simplify_matrix
_dt = time_derivative
_clear_denominators = clear_denominators
_NumericMixin = NumericCache


@dataclass(frozen=True, eq=False)
class NonholonomicReduction(Derived, _NumericMixin):
    r"""The BKMM reduction of a nonholonomic system with symmetry (eqs. 1.1-1.3 of the nonholonomic seed).

    Attributes
    ----------
    system : NonholonomicSystem
    basis : Matrix (k, m)
        The body-fixed basis :math:`e_1(r), \dots, e_m(r)` of :math:`S = \{\xi : A_\xi(r)\xi = 0\}` as columns.
    normalization : str
        How the basis was chosen (the momentum's scale depends on it).
    p, rddot, tau : tuple of Symbol
        Nonholonomic momentum, shape accelerations, shape forces.
    locked_inertia_full, coupling, shape_metric : Matrix
        :math:`\mathbb I_{\mathrm{loc}} = \partial^2 l/\partial\xi^2` (k x k),
        :math:`\Gamma = \partial^2 l/\partial\xi\partial\dot r` (k x sigma),
        :math:`m_{rr} = \partial^2 l/\partial\dot r^2` (sigma x sigma).
    potential : Expr
        :math:`V(r)`.
    """

    system: NonholonomicSystem
    basis: sp.ImmutableMatrix
    normalization: str
    p: tuple[sp.Symbol, ...]
    rddot: tuple[sp.Symbol, ...]
    tau: tuple[sp.Symbol, ...]
    locked_inertia_full: sp.ImmutableMatrix = field(repr=False)
    coupling: sp.ImmutableMatrix = field(repr=False)
    shape_metric: sp.ImmutableMatrix = field(repr=False)
    potential: sp.Expr = field(repr=False)
    title: str = "BKMM reduction"

    @property
    def _cache_key(self) -> tuple:
        return (self.system.key, self.basis)

    @property
    def m(self) -> int:
        """Dimension of :math:`S_q` (number of nonholonomic momenta)."""
        return self.basis.cols

    @property
    def r(self) -> tuple[sp.Symbol, ...]:
        return self.system.shape

    @property
    def rdot(self) -> tuple[sp.Symbol, ...]:
        return self.system.shape_dot

    # ---------------- connection and inertia ----------------
    @shared_property
    def locked_inertia(self) -> sp.ImmutableMatrix:
        r""":math:`\mathbb I_{ij}(r) = e_i^T\,\mathbb I_{\mathrm{loc}}\,e_j` (m x m)."""
        E = sp.Matrix(self.basis)
        return _simp_matrix(E.T * self.locked_inertia_full * E)

    @shared_property
    def locked_inertia_inverse(self) -> sp.ImmutableMatrix:
        return simplified_inverse(self.locked_inertia) if self.m else sp.ImmutableMatrix(0, 0, [])

    @shared_property
    def connection(self) -> sp.ImmutableMatrix:
        r"""The nonholonomic connection :math:`\mathcal A^{nh}(r)` (k x sigma), horizontal
        :math:`\xi = -\mathcal A^{nh}\dot r`.

        Solves :math:`A_\xi\,\xi_h = -A_r\dot r` and :math:`e_i^T(\mathbb I_{\mathrm{loc}}\xi_h + \Gamma\dot r) = 0`.
        """
        s = self.system
        if s.sigma == 0:
            return sp.ImmutableMatrix(sp.zeros(s.k, 0))
        Axi, Ar = (sp.Matrix(a) for a in s.body_constraints)
        E = sp.Matrix(self.basis)
        lhs = sp.Matrix.vstack(Axi, E.T * self.locked_inertia_full)
        rhs = sp.Matrix.vstack(Ar, E.T * self.coupling)
        return _simp_matrix(lhs.LUsolve(rhs))

    @shared_property
    def reconstruction(self) -> sp.ImmutableMatrix:
        r""":math:`\xi = g^{-1}\dot g = -\mathcal A^{nh}(r)\dot r + e(r)\,\mathbb I^{-1}(r)\,p` (seed eq. 1.1)."""
        E = sp.Matrix(self.basis)
        rd, p = column(self.rdot), column(self.p)
        xi = -sp.Matrix(self.connection) * rd
        if self.m:
            xi += E * sp.Matrix(self.locked_inertia_inverse) * p
        return _simp_matrix(xi)

    @shared_property
    def momentum(self) -> sp.ImmutableMatrix:
        r""":math:`p_i(q, \dot q) = \langle\partial l/\partial\xi, e_i(r)\rangle`, :math:`\xi = \Lambda(g)\dot g`,
        in coordinates."""
        s = self.system
        xi = s.group.body_velocity_matrix * column(s.qdot[: s.k])
        mu = sp.Matrix([derivative(s.body_lagrangian, x) for x in s.xi]).xreplace(dict(zip(s.xi, xi)))
        return _simp_matrix(sp.Matrix(self.basis).T * mu)

    @shared_property
    def _mu_parts(self) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix, sp.ImmutableMatrix]:
        r""":math:`\mu = \partial l/\partial\xi = \mu_r\dot r + \mu_p p` and :math:`\Omega = \mathbb I^{-1}p`, with
        :math:`\mu_r = \Gamma - \mathbb I_{\mathrm{loc}}\mathcal A` (k x sigma), :math:`\mu_p = \mathbb I_{\mathrm{loc}}
        e\,\mathbb I^{-1}` (k x m); returns ``(mu_r, mu_p, e I^{-1})``."""
        Il, E = sp.Matrix(self.locked_inertia_full), sp.Matrix(self.basis)
        EIinv = _simp_matrix(E * sp.Matrix(self.locked_inertia_inverse)) if self.m else sp.zeros(self.system.k, 0)
        mu_r = _simp_matrix(sp.Matrix(self.coupling) - Il * sp.Matrix(self.connection))
        mu_p = _simp_matrix(Il * EIinv) if self.m else sp.ImmutableMatrix(sp.zeros(self.system.k, 0))
        return mu_r, mu_p, sp.ImmutableMatrix(EIinv)

    @property
    def mu(self) -> sp.Matrix:
        r""":math:`\mu = \partial l/\partial\xi` (the body momentum, k components) in terms of ``(r, rdot, p)``."""
        mu_r, mu_p, _ = self._mu_parts
        return sp.Matrix(mu_r) * column(self.rdot) + sp.Matrix(mu_p) * column(self.p)

    # ---------------- the momentum map on TQ (section 2.1) ----------------
    @shared_property
    def generators(self) -> sp.ImmutableMatrix:
        r"""The infinitesimal generators :math:`\zeta_Q` of the algebra's basis as the columns of an ``(n, k)``
        matrix in the coordinates :math:`(\alpha, r)`: :math:`\dot g = \hat\zeta g`, i.e.
        :math:`\dot\alpha = \Lambda(\alpha)^{-1}\mathrm{Ad}_{g^{-1}}\zeta`, :math:`\dot r = 0`."""
        G, s = self.system.group, self.system
        top = G.body_velocity_inverse * G.Ad_matrix(inverse=True)
        return sp.ImmutableMatrix(sp.Matrix.vstack(top.applyfunc(simplify_expr), sp.zeros(s.sigma, s.k)))

    @shared_property
    def spatial_locked_inertia(self) -> sp.ImmutableMatrix:
        r""":math:`\mathbb I(q)` with :math:`\langle\mathbb I\zeta, \eta\rangle = \langle\!\langle\zeta_Q,
        \eta_Q\rangle\!\rangle` (the kinetic metric on the orbit; :math:`\mathrm{Ad}`-conjugate to
        :attr:`locked_inertia_full`), ``(k, k)`` in the coordinates :math:`q`."""
        X = sp.Matrix(self.generators)
        return sp.ImmutableMatrix(X.T * sp.Matrix(self.system.mass_matrix) * X)

    @shared_property
    def momentum_map(self) -> sp.ImmutableMatrix:
        r"""The spatial momentum map :math:`\langle J(q, \dot q), \zeta\rangle = \langle\!\langle\dot q,
        \zeta_Q(q)\rangle\!\rangle`, ``(k, 1)`` in :math:`(q, \dot q)`; conserved without constraints."""
        X = sp.Matrix(self.generators)
        return sp.ImmutableMatrix(X.T * sp.Matrix(self.system.mass_matrix) * column(self.system.qdot))

    def murray_lagrangian(self) -> sp.Expr:
        r"""Murray's splitting (Theorem 2.1 of the seed) of a system without constraints:
        :math:`l = \tfrac12(\xi + \mathcal A\dot r)^T\mathbb I(\xi + \mathcal A\dot r) + \tfrac12\dot r^T
        M(r)\dot r - V(r)`, in the body velocities :attr:`NonholonomicSystem.xi` and the shape velocities."""
        s = self.system
        if s.c:
            raise InputError(
                f"Murray's splitting holds for the mechanical connection of a system without constraints; "
                f"{s.name} has {s.c}: its reduced Lagrangian keeps the cross term through the constraints."
            )
        u = column(s.xi) + sp.Matrix(self.connection) * column(self.rdot)
        rd = column(self.rdot)
        return (
            (u.T * sp.Matrix(self.locked_inertia_full) * u)[0, 0] / 2
            + (rd.T * sp.Matrix(self.shape_mass) * rd)[0, 0] / 2
            - self.potential
        )

    @property
    def omega(self) -> sp.Matrix:
        r""":math:`\Omega = \mathbb I^{-1}(r)\,p`, the velocity along :math:`S_q` in the basis :math:`e_i`."""
        return sp.Matrix(self.locked_inertia_inverse) * column(self.p)

    @shared_property
    def curvature(self) -> tuple[sp.ImmutableMatrix, ...]:
        r"""Curvature of the nonholonomic connection (BKMM), one sigma x sigma matrix per algebra index a:

        .. math::

            B^a_{\alpha\beta} = \frac{\partial\mathcal A^a_\beta}{\partial r^\alpha}
            - \frac{\partial\mathcal A^a_\alpha}{\partial r^\beta} - C^a_{bd}\,\mathcal A^b_\alpha\mathcal A^d_\beta,

        the local form of :math:`B = d\mathcal A - [\mathcal A, \mathcal A]`."""
        s, A = self.system, sp.Matrix(self.connection)
        C, k, r = s.group.structure_constants, s.k, self.r
        out = []
        for a in range(k):
            out.append(
                _simp_matrix(
                    sp.Matrix(
                        s.sigma,
                        s.sigma,
                        lambda al, be, a=a: (
                            derivative(A[a, be], r[al])
                            - derivative(A[a, al], r[be])
                            - sum(C[a][b][d] * A[b, al] * A[d, be] for b in range(k) for d in range(k))
                        ),
                    )
                )
            )
        return tuple(out)

    @shared_property
    def F(self) -> tuple[sp.ImmutableMatrix, ...]:
        r"""The seed's :math:`F^a_{i\beta} = \partial e^a_i/\partial r^\beta + C^a_{bd}\,e^b_i\mathcal A^d_\beta`
        (Theorem 1.1), one m x sigma matrix per algebra index a."""
        s, A, E = self.system, sp.Matrix(self.connection), sp.Matrix(self.basis)
        C, k, r = s.group.structure_constants, s.k, self.r
        return tuple(
            _simp_matrix(
                sp.Matrix(
                    self.m,
                    s.sigma,
                    lambda i, be, a=a: (
                        derivative(E[a, i], r[be])
                        + sum(C[a][b][d] * E[b, i] * A[d, be] for b in range(k) for d in range(k))
                    ),
                )
            )
            for a in range(k)
        )

    # ---------------- momentum equation ----------------
    @shared_property
    def momentum_coefficients(self) -> tuple[tuple[sp.ImmutableMatrix, ...], ...]:
        r"""``(H, K, D)``, each a tuple over :math:`i` of matrices, with
        :math:`\dot p_i = \dot r^T H_i\dot r + \dot r^T K_i p + p^T D_i p` (seed eq. 1.2; :math:`H_i, D_i` symmetric).

        From :math:`\dot p_i = -\mu_a C^a_{bd}e^b_i e^d_j\Omega^j + \mu_a F^a_{i\beta}\dot r^\beta` (BKMM's
        :math:`\dot p_i = \langle\mu, [\xi, e_i] + \partial_\beta e_i\dot r^\beta\rangle` with eq. 1.1 inserted)."""
        s = self.system
        mu_r, mu_p, EIinv = (sp.Matrix(x) for x in self._mu_parts)
        C, k, E = s.group.structure_constants, s.k, sp.Matrix(self.basis)
        rd, p = column(self.rdot), column(self.p)
        mu = mu_r * rd + mu_p * p
        W = EIinv * p
        Hs, Ks, Ds = [], [], []
        for i in range(self.m):
            adj = sum(mu[a] * C[a][b][d] * E[b, i] * W[d] for a in range(k) for b in range(k) for d in range(k))
            e = -adj + sum(mu[a] * (sp.Matrix(self.F[a])[i, :] * rd)[0, 0] for a in range(k))
            H, K, D = quadratic_blocks(e, list(rd), list(p))
            Hs.append(_simp_matrix(H) if s.sigma else sp.ImmutableMatrix(sp.zeros(0, 0)))
            Ks.append(_simp_matrix(K))
            Ds.append(_simp_matrix(D))
        return tuple(Hs), tuple(Ks), tuple(Ds)

    @shared_property
    def momentum_rhs(self) -> sp.ImmutableMatrix:
        r"""Right-hand side of the momentum equation (1.2) in ``(r, rdot, p)``."""
        H, K, D = self.momentum_coefficients
        rd, p = column(self.rdot), column(self.p)
        return sp.ImmutableMatrix([(rd.T * H[i] * rd + rd.T * K[i] * p + p.T * D[i] * p)[0, 0] for i in range(self.m)])

    # ---------------- shape equations ----------------
    @shared_property
    def shape_mass(self) -> sp.ImmutableMatrix:
        r""":math:`M(r)`, the kinetic metric on horizontal vectors (seed eq. 1.3)."""
        A = sp.Matrix(self.connection)
        G, Il, mrr = sp.Matrix(self.coupling), sp.Matrix(self.locked_inertia_full), sp.Matrix(self.shape_metric)
        return _simp_matrix(mrr - G.T * A - A.T * G + A.T * Il * A)

    @shared_property
    def shape_mass_inverse(self) -> sp.ImmutableMatrix:
        r""":math:`M(r)^{-1}` (simplified)."""
        return simplified_inverse(self.shape_mass) if self.system.sigma else sp.ImmutableMatrix(0, 0, [])

    @shared_property
    def shape_coefficients(self) -> tuple[tuple[sp.ImmutableMatrix, ...], ...]:
        r"""``(Q, R, S)``, each a tuple over :math:`\alpha`, with
        :math:`\delta_\alpha = \dot r^T Q_\alpha\dot r + \dot r^T R_\alpha p + p^T S_\alpha p
        - \partial V/\partial r^\alpha`.

        They come from the constrained reduced Lagrangian :math:`l_c = \tfrac12\dot r^T M\dot r + \tfrac12\Omega^T
        \mathbb I\,\Omega - V` (no cross term: the connection makes horizontal and vertical orthogonal) and

        .. math::

            \frac{d}{dt}\frac{\partial l_c}{\partial\dot r^\alpha} - \frac{\partial l_c}{\partial r^\alpha}
            = \mu_a B^a_{\alpha\beta}\dot r^\beta - \mu_a F^a_{j\alpha}\Omega^j + \tau_\alpha,

        derived here from the Lagrange-d'Alembert principle along horizontal variations. Theorem 1.2 of the seed
        prints :math:`-\mu_a B^a_{\alpha\beta}\dot r^\beta`: with BKMM's curvature
        (:attr:`curvature`) the sign is +, as the tests confirm against the full equations.
        """
        s = self.system
        r, rd, p = list(self.r), column(self.rdot), column(self.p)
        M, Iinv = sp.Matrix(self.shape_mass), sp.Matrix(self.locked_inertia_inverse)
        mu = self.mu
        Om = Iinv * p
        Qs, Rs, Ss = [], [], []
        for al in range(s.sigma):
            chris = sum(
                (derivative(M[al, g], r[b]) - derivative(M[b, g], r[al]) / 2) * rd[b] * rd[g]
                for b in range(s.sigma)
                for g in range(s.sigma)
            )
            vert = -(p.T * derivative(Iinv, r[al]) * p)[0, 0] / 2 if self.m else sp.Integer(0)
            curv = sum(mu[a] * (sp.Matrix(self.curvature[a])[al, :] * rd)[0, 0] for a in range(s.k))
            fterm = (
                sum(mu[a] * (sp.Matrix(self.F[a])[:, al].T * Om)[0, 0] for a in range(s.k)) if self.m else sp.Integer(0)
            )
            # Each mechanism simplified on its own and the results added: one common denominator over all of
            # them costs minutes (multivariate gcds) for general parameters and reads no better.
            Q = R = S = None
            for e in (-chris, vert, curv, -fterm):
                q_, r_, s_ = (_simp_matrix(b) for b in quadratic_blocks(e, list(rd), list(p)))
                Q, R, S = (q_, r_, s_) if Q is None else (Q + q_, R + r_, S + s_)
            Qs.append(sp.ImmutableMatrix(Q))
            Rs.append(sp.ImmutableMatrix(R))
            Ss.append(sp.ImmutableMatrix(S))
        return tuple(Qs), tuple(Rs), tuple(Ss)

    @shared_property
    def shape_forces(self) -> sp.ImmutableMatrix:
        r""":math:`\delta(r, \dot r, p)` with :math:`M(r)\ddot r = \delta + \tau` (seed eq. 1.3)."""
        Q, R, S = self.shape_coefficients
        rd, p = column(self.rdot), column(self.p)
        out = []
        for al, r in enumerate(self.r):
            e = (rd.T * Q[al] * rd + rd.T * R[al] * p)[0, 0] - simplify_expr(derivative(self.potential, r))
            if self.m:
                e += (p.T * S[al] * p)[0, 0]
            out.append(e)
        return sp.ImmutableMatrix(sp.Matrix(len(out), 1, out))

    def shape_equation_projection(self) -> sp.Matrix:
        r"""Second derivation of eq. (1.3), unsimplified: :math:`-\mathcal A^T(\dot\mu - \mathrm{ad}^*_\xi\mu)
        + \frac{d}{dt}\frac{\partial l}{\partial\dot r} - \frac{\partial l}{\partial r}` with eqs. (1.1)-(1.2)
        inserted, in ``(r, rdot, rddot, p)``; it equals :math:`M\ddot r - \delta` (= :math:`\tau`)."""
        s = self.system
        r, rd, rdd, p = list(self.r), list(self.rdot), list(self.rddot), list(self.p)
        xi = sp.Matrix(self.reconstruction)
        pdot = list(self.momentum_rhs)

        def ddt(expr):
            out = _dt(expr, r, rd) + _dt(expr, rd, rdd)
            return out + _dt(expr, p, pdot) if p else out

        mu = self.mu
        C, k = s.group.structure_constants, s.k
        ad_star = sp.Matrix([sum(mu[a] * C[a][b][d] * xi[b] for a in range(k) for b in range(k)) for d in range(k)])
        l = s.body_lagrangian
        sub = dict(zip(s.xi, xi))
        pi_r = sp.Matrix([derivative(l, v) for v in rd]).xreplace(sub)
        dl_dr = sp.Matrix([derivative(l, v) for v in r]).xreplace(sub)
        return -sp.Matrix(self.connection).T * (ddt(mu) - ad_star) + ddt(pi_r) - dl_dr

    def _latex_names(self) -> dict:
        names = dict(self.system.latex_names)
        for r, a, t in zip(self.r, self.rddot, self.tau):
            names[a] = rf"\ddot{{{sp.latex(r)}}}"
            names[t] = rf"\tau_{{{sp.latex(r)}}}"
        return names

    def items(self):
        H, K, D = self.momentum_coefficients
        return [
            ("basis e_i(r) (columns)", r"e(r)", self.basis),
            ("normalization", r"\mathrm{normalization}", self.normalization),
            ("momentum p(q, qdot)", r"p", self.momentum),
            ("locked inertia I(r)", r"\mathbb I(r)", self.locked_inertia),
            ("connection A_nh(r)", r"\mathcal A^{nh}(r)", self.connection),
            ("reconstruction g^-1 g' (eq. 1.1)", r"g^{-1}\dot g", self.reconstruction),
            ("momentum equation p' (eq. 1.2)", r"\dot p", self.momentum_rhs),
            ("H(r)", r"H(r)", list(H)),
            ("K(r)", r"K(r)", list(K)),
            ("D(r)", r"D(r)", list(D)),
            ("shape mass M(r) (eq. 1.3)", r"M(r)", self.shape_mass),
            ("delta(r, rdot, p) (eq. 1.3)", r"\delta(r, \dot r, p)", self.shape_forces),
        ]

    # ---------------- numeric ----------------
    def _check_basis_at(self, parameters: Mapping[str, float] | None) -> None:
        """The body-fixed basis, derived for generic parameter values, must still span S_q at these values (a
        blade tilted by beta = 0 can make two of its vectors parallel while S_q keeps its dimension)."""
        s = self.system
        if not self.m:
            return
        pv = s.parameter_values(parameters)
        E = sp.Matrix(self.basis).subs(pv)
        A = sp.Matrix(s.body_constraints[0]).subs(pv)
        rng = np.random.default_rng(0)
        for _ in range(3):  # generic shape points: one that happens to be special is not held against the basis
            pt = {r: float(rng.uniform(0.3, 1.2)) for r in s.shape}
            rank_E, rank_A = _numeric_rank(E.subs(pt)), _numeric_rank(A.subs(pt))
            if rank_E == self.m or rank_A is None or s.k - rank_A != self.m:
                return
        shown = ", ".join(f"{k.name} = {v:g}" for k, v in pv.items())
        raise InputError(
            f"{s.name}: the body-fixed basis of S_q = D n T(orbit) derived for generic parameter values "
            f"(the null space of A_xi with denominators cleared) degenerates at {shown} (rank "
            f"{rank_E if rank_E is not None else 'undefined'} < {self.m}) though S_q keeps dimension "
            f"{self.m} there; give a basis valid at these values (`basis=` of "
            "NonholonomicSystem.from_lagrangian, or bkmm_reduction(system, basis))."
        )

    def numeric(self, parameters: Mapping[str, float] | None = None) -> ReducedNumeric:
        """The compiled twin: connection, curvature, locked inertia and eqs. (1.1)-(1.3) as numeric functions of
        the shape (:class:`~geomech.reduction.reduced_numeric.ReducedNumeric`), from the system's data alone: no
        symbolic attribute above is derived for it. Built once per system, basis and parameter values."""
        given = tuple(sorted({**self.system.parameters, **(parameters or {})}.items()))
        try:
            return self._numerics[given]  # this reduction's (a prepared problem's runs ask at each call)
        except KeyError:
            pass
        except TypeError:  # values that are not plain numbers: built each time (and checked there)
            self._check_basis_at(parameters)
            return ReducedNumeric(self, parameters)
        key = (sp.ImmutableMatrix(self.basis), given)
        known = _NUMERIC.setdefault(self.system, {})
        if key not in known:
            self._check_basis_at(parameters)
            known[key] = ReducedNumeric(self, parameters)
        self._numerics[given] = known[key]
        return known[key]

    @cached_property
    def _numerics(self) -> dict:
        return {}


#: the numeric twins built so far, by system (weakly), basis and parameter values
_NUMERIC: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _numeric_rank(M: sp.MatrixBase) -> int | None:
    try:
        arr = np.array(M.evalf(), dtype=float)
    except (TypeError, ValueError):  # zoo or nan: a division by zero at these values
        return None
    if not np.all(np.isfinite(arr)):
        return None
    return int(np.linalg.matrix_rank(arr, tol=1e-9 * max(1.0, float(np.abs(arr).max(initial=0.0)))))


def _basis(system: NonholonomicSystem, basis: Any) -> tuple[sp.ImmutableMatrix, str]:
    s = system
    Axi = sp.Matrix(s.body_constraints[0])
    if basis is None:
        if s.c == 0:
            return sp.ImmutableMatrix(sp.eye(s.k)), "standard basis of the Lie algebra (no constraint on the group)"
        vecs = Axi.nullspace(simplify=True)
        E = sp.Matrix.hstack(*[_clear_denominators(v) for v in vecs]) if vecs else sp.zeros(s.k, 0)
        return sp.ImmutableMatrix(E), (
            "null space of the body constraint matrix A_xi(r) by row reduction (one free "
            "component set to 1), each vector then multiplied by the common denominator of "
            "its entries"
        )
    names = {x.name: x for x in s.shape}
    try:
        E = sp.Matrix(basis)
    except (TypeError, ValueError, sp.SympifyError) as exc:
        raise InputError(
            f"Expected `basis` to be a k x m matrix (k = {s.k}) of expressions in the shape variables, got {basis!r}."
        ) from exc
    E = E.applyfunc(lambda e: sp.sympify(e).xreplace({x: names.get(x.name, x) for x in sp.sympify(e).free_symbols}))
    if E.rows != s.k and E.cols == s.k:
        E = E.T
    if E.rows != s.k:
        raise InputError(f"Expected `basis` to have {s.k} rows (dim of {s.group.name}), got shape {E.shape}.")
    bad = set().union(*[e.free_symbols for e in E]) & (set(s.group.coordinates) | set(s.qdot))
    if bad:
        raise InputError(
            f"Expected `basis` to depend on the shape variables only (it is body-fixed), got {sorted(map(str, bad))}."
        )
    res = (Axi * E).applyfunc(simplify_expr)
    if any(e != 0 for e in res):
        raise SymbolicError(f"`basis` does not lie in S_q = D_q cap T_q(Orb): A_xi(r) e(r) = {res.tolist()} != 0.")
    expected = s.k - Axi.rank(simplify=True)
    if E.cols != expected or E.rank(simplify=True) != expected:
        raise InputError(
            f"Expected `basis` to hold {expected} independent vectors (dim S_q), got {E.cols} of rank "
            f"{E.rank(simplify=True)}."
        )
    return sp.ImmutableMatrix(E), "given by the caller"


@lru_cache(maxsize=64)
def _bkmm_fields(system: NonholonomicSystem, basis_key: Any) -> tuple:
    """The basis, its note and the blocks of the body Lagrangian of the reduction: from the disk cache where an
    earlier process derived them (the basis's checks take symbolic ranks), else derived."""
    stored = ("bkmm fields", basis_key)
    fields = DISK_CACHE.load(system.key, stored)
    if fields is MISSING:
        fields = _derive_bkmm_fields(system, basis_key)
        DISK_CACHE.save(system.key, stored, fields)
    if basis_key is not None and basis_key[0] == "model":
        fields = (fields[0], system.basis_note or "given by the model", *fields[2:])
    return fields


def _derive_bkmm_fields(system: NonholonomicSystem, basis_key: Any) -> tuple:
    s = system
    E, normalization = _basis(s, None if basis_key is None else sp.Matrix(basis_key[1]))
    l = s.body_lagrangian
    xi, rd = list(s.xi), list(s.shape_dot)
    half_Il, Gam, half_mrr = quadratic_blocks(l, xi, rd)
    Il, mrr = 2 * half_Il, 2 * half_mrr
    V = -l.xreplace({v: sp.Integer(0) for v in xi + rd})
    if any(e.free_symbols & set(s.group.coordinates) for e in list(Il) + list(Gam) + list(mrr)):
        raise SymbolicError(f"{s.name}: the body Lagrangian still depends on the group variables; check G-invariance.")
    p = tuple(sp.Symbol(f"p{i + 1}", real=True) for i in range(E.cols))
    rdd = suffixed_symbols("ddot", [r.name for r in s.shape])
    tau = suffixed_symbols("", [f"tau_{r.name}" for r in s.shape])
    return (
        E,
        normalization,
        p,
        rdd,
        tau,
        sp.ImmutableMatrix(Il),
        sp.ImmutableMatrix(Gam),
        sp.ImmutableMatrix(mrr),
        V,  # as the Lagrangian gives it: sympy.simplify of a sum of pair potentials takes half a minute
    )


def _basis_matrix(system: NonholonomicSystem, basis: Any) -> sp.ImmutableMatrix:
    """A caller's basis as a sympy matrix, text entries parsed one by one by the whitelist (``sp.Matrix`` of
    strings would sympify them)."""
    if isinstance(basis, sp.MatrixBase):  # (an immutable matrix has no __iter__)
        rows = basis.tolist()
    elif isinstance(basis, (str, bytes)) or not hasattr(basis, "__iter__"):
        raise TypeError("not a matrix")
    else:
        rows = [list(row) if isinstance(row, (list, tuple, np.ndarray)) else [row] for row in basis]
    names = {s.name: s for s in (*system.q, *system.parameter_symbols)}
    return sp.ImmutableMatrix(
        [[to_expression(e, f"basis[{i}][{j}]", names) for j, e in enumerate(row)] for i, row in enumerate(rows)]
    )


def bkmm_reduction(system: NonholonomicSystem, basis: Any = None) -> NonholonomicReduction:
    r"""The BKMM reduction of ``system``.

    Parameters
    ----------
    system : NonholonomicSystem
    basis : k x m matrix, optional
        The body-fixed basis :math:`e_i(r)` of :math:`S_q = \mathcal D_q\cap T_q\mathrm{Orb}` as columns, in
        the shape variables. Default: the null space of :math:`A_\xi(r)` with denominators cleared (see
        ``normalization`` of the result). The nonholonomic momentum scales with this choice.

    Returns
    -------
    NonholonomicReduction
        Cached on the system's symbolic content and the basis (systems that differ only in parameter values share
        it; each result keeps its own system's values); every part is derived on first access.
    """
    if not isinstance(system, NonholonomicSystem):
        raise InputError(f"Expected `system` to be a NonholonomicSystem, got {type(system).__name__}.")
    if basis is None:  # the default basis: one reduction per system object (every run asks for it)
        known = system.derived_cache.get("bkmm")
        if known is None:
            known = system.derived_cache["bkmm"] = _bkmm_reduction(system, None)
        return known
    return _bkmm_reduction(system, basis)


def _bkmm_reduction(system: NonholonomicSystem, basis: Any) -> NonholonomicReduction:
    key: tuple[str, Any] | None
    if basis is None and system.body_basis is not None:
        key = ("model", system.body_basis)
    else:
        try:
            key = None if basis is None else ("caller", _basis_matrix(system, basis))
        except (TypeError, ValueError, sp.SympifyError) as exc:
            raise InputError(
                f"Expected `basis` to be a k x m matrix (k = {system.k}) of expressions in the shape "
                f"variables, got {basis!r}."
            ) from exc
    return NonholonomicReduction(system, *_bkmm_fields(system, key))


def reduced_numeric(system: Any, parameters: Mapping[str, float] | None = None, basis: Any = None) -> ReducedNumeric:
    """``bkmm_reduction(system, basis).numeric(parameters)``, or ``system`` itself when it is already a
    :class:`ReducedNumeric` (the analyses and pictures take either)."""
    if isinstance(system, ReducedNumeric):
        return system
    return bkmm_reduction(system, basis).numeric(parameters)
