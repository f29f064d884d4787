r"""The BKMM reduction evaluated numerically: the compiled twin of
:class:`~geomech.reduction.nonholonomic.NonholonomicReduction` (``reduction.numeric(parameters)``).

Nothing here inverts or simplifies a symbolic matrix. What is compiled are the data of the system, in the shape
variables :math:`r`: the reduced mass matrix (the Hessian of :math:`l(r, \xi, \dot r)`: the full locked
inertia :math:`\mathbb I_{\mathrm{loc}}`, the coupling :math:`\Gamma`, the shape metric :math:`m_{rr}`), the
gradient of :math:`V`, the body constraints :math:`A_\xi, A_r`, the body-fixed basis :math:`e(r)` of
:math:`S_q`, and the first derivatives of each in :math:`r`. At a shape point the rest is linear algebra:

* the connection: :math:`L\mathcal A = R` with :math:`L = (A_\xi;\ e^T\mathbb I_{\mathrm{loc}})`,
  :math:`R = (A_r;\ e^T\Gamma)` (the horizontal :math:`\xi = -\mathcal A\dot r` satisfies the constraints and
  carries no momentum), and :math:`\partial_\alpha\mathcal A = L^{-1}(\partial_\alpha R - \partial_\alpha L\,
  \mathcal A)`; without constraints :math:`e = 1` and this is the mechanical connection
  :math:`\mathbb I^{-1}_{\mathrm{loc}}\,\mathbb I_{\mathrm{loc}}A_{\mathrm{loc}}` of Theorem 2.1;
* the curvature :math:`B^a_{\alpha\beta} = \partial_\alpha\mathcal A^a_\beta - \partial_\beta\mathcal A^a_\alpha
  - C^a_{bd}\mathcal A^b_\alpha\mathcal A^d_\beta`;
* the locked inertia :math:`\mathbb I = e^T\mathbb I_{\mathrm{loc}}e`, the reconstruction (1.1)
  :math:`\xi = -\mathcal A\dot r + e\,\mathbb I^{-1}p`, the momentum equation (1.2)
  :math:`\dot p_i = \langle\mu, [\xi, e_i] + \partial_\beta e_i\,\dot r^\beta\rangle` with
  :math:`\mu = \partial l/\partial\xi = \mathbb I_{\mathrm{loc}}\xi + \Gamma\dot r`;
* the shape equations (1.3) :math:`M\ddot r = \delta + \tau`, :math:`M = m_{rr} - \Gamma^T\mathcal A
  - \mathcal A^T\Gamma + \mathcal A^T\mathbb I_{\mathrm{loc}}\mathcal A` and
  :math:`\delta_\alpha = -(\partial_\beta M_{\alpha\gamma} - \tfrac12\partial_\alpha M_{\beta\gamma})\dot r^\beta
  \dot r^\gamma + \tfrac12\Omega^T\partial_\alpha\mathbb I\,\Omega + \mu_a B^a_{\alpha\beta}\dot r^\beta
  - \mu_a F^a_{j\alpha}\Omega^j - \partial_\alpha V`, :math:`\Omega = \mathbb I^{-1}p`,
  :math:`F^a_{j\alpha} = \partial_\alpha e^a_j + C^a_{bd}e^b_j\mathcal A^d_\alpha`.

The symbolic attributes of the reduction are the same formulas in closed form; the tests hold the two routes
against each other and against the full Lagrange-d'Alembert equations.
"""

from __future__ import annotations

import weakref
from collections.abc import Mapping
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, SingularityError
from ..symbolic import column

__all__ = ["ReducedNumeric", "reduction_data"]

_COND_MAX = 1e13

#: The shape of each of the system's data at one point, from (k, sigma, m, c).
_LAYOUT = {
    "M": lambda k, n, m, c: (k + n, k + n),
    "dM": lambda k, n, m, c: (n, k + n, k + n),
    "E": lambda k, n, m, c: (k, m),
    "dE": lambda k, n, m, c: (n, k, m),
    "Axi": lambda k, n, m, c: (c, k),
    "dAxi": lambda k, n, m, c: (n, c, k),
    "Ar": lambda k, n, m, c: (c, n),
    "dAr": lambda k, n, m, c: (n, c, n),
    "dV": lambda k, n, m, c: (n, 1),
}


_DATA: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def reduction_data(reduction: Any) -> dict[str, sp.Matrix]:
    """The system's data to compile, each a matrix in the shape variables (derivatives stacked by rows), in the
    order of the flat layout every numeric twin reads (:data:`_LAYOUT`; the compiled BKMM loop too). Derived
    once per system and basis."""
    known = _DATA.setdefault(reduction.system, {})
    key = sp.ImmutableMatrix(reduction.basis)
    if key not in known:
        known[key] = _derive_data(reduction)
    return known[key]


def _derive_data(reduction: Any) -> dict[str, sp.Matrix]:
    s = reduction.system
    r = list(reduction.r)
    Il, G, mrr = (sp.Matrix(x) for x in (reduction.locked_inertia_full, reduction.coupling, reduction.shape_metric))
    M = sp.Matrix.vstack(sp.Matrix.hstack(Il, G), sp.Matrix.hstack(G.T, mrr))
    Axi, Ar = (sp.Matrix(x) for x in s.body_constraints)
    E = sp.Matrix(reduction.basis)

    def d(X: sp.Matrix) -> sp.Matrix:
        return sp.Matrix.vstack(*[X.diff(x) for x in r]) if r else sp.zeros(0, X.cols)

    return {
        "M": M,
        "dM": d(M),
        "E": E,
        "dE": d(E),
        "Axi": Axi,
        "dAxi": d(Axi),
        "Ar": Ar,
        "dAr": d(Ar),
        "dV": column([reduction.potential.diff(x) for x in r]),
    }


class _Point:
    """The reduction at shape points ``r`` ``(..., sigma)``: each object computed on first use."""

    def __init__(self, owner: ReducedNumeric, r: np.ndarray):
        self.owner, self.r = owner, r
        k = owner.k
        batch = r.shape[:-1]
        with np.errstate(all="ignore"):
            vals = owner._kernel(r)[..., 0]
        if not np.isfinite(vals).all():
            bad = ~np.isfinite(vals).all(axis=-1)
            i = np.unravel_index(int(np.argmax(bad)), bad.shape)
            raise SingularityError(
                f"{owner.name}: the kinetic metric, the constraints or the potential are singular at r = "
                f"{np.round(r[i], 6).tolist()} (not finite there); the reduction is undefined at such shapes."
            )
        parts = {}
        for name, shape, start, stop in owner._layout:
            parts[name] = vals[..., start:stop].reshape(batch + shape)
        self.parts = parts
        M, dM = parts["M"], parts["dM"]
        self.Il, self.G, self.mrr = M[..., :k, :k], M[..., :k, k:], M[..., k:, k:]
        self.dIl, self.dG, self.dmrr = dM[..., :k, :k], dM[..., :k, k:], dM[..., k:, k:]
        self.E, self.dE = parts["E"], parts["dE"]

    @cached_property
    def _Linv(self) -> tuple[np.ndarray, np.ndarray]:
        o = self.owner
        Et = np.swapaxes(self.E, -1, -2)
        L = np.concatenate([self.parts["Axi"], Et @ self.Il], axis=-2)
        R = np.concatenate([self.parts["Ar"], Et @ self.G], axis=-2)
        what = "the nonholonomic connection" if o.c else "the mechanical connection"
        return o._inverse(L, self.r, what), R

    @cached_property
    def A(self) -> np.ndarray:
        Linv, R = self._Linv
        return Linv @ R

    @cached_property
    def dA(self) -> np.ndarray:
        """``dA[..., alpha, a, beta]`` = :math:`\\partial_\\alpha\\mathcal A^a_\\beta`."""
        Linv, _ = self._Linv
        Et, dEt = np.swapaxes(self.E, -1, -2)[..., None, :, :], np.swapaxes(self.dE, -1, -2)
        Il, G = self.Il[..., None, :, :], self.G[..., None, :, :]
        dL = np.concatenate([self.parts["dAxi"], dEt @ Il + Et @ self.dIl], axis=-2)
        dR = np.concatenate([self.parts["dAr"], dEt @ G + Et @ self.dG], axis=-2)
        return Linv[..., None, :, :] @ (dR - dL @ self.A[..., None, :, :])

    @cached_property
    def Im(self) -> np.ndarray:
        return np.swapaxes(self.E, -1, -2) @ self.Il @ self.E

    @cached_property
    def Iminv(self) -> np.ndarray:
        return self.owner._inverse(self.Im, self.r, "I^-1 p in the reconstruction (1.1)")

    @cached_property
    def dIm(self) -> np.ndarray:
        E, dE, Il = self.E[..., None, :, :], self.dE, self.Il[..., None, :, :]
        Et, dEt = np.swapaxes(E, -1, -2), np.swapaxes(dE, -1, -2)
        return dEt @ Il @ E + Et @ self.dIl @ E + Et @ Il @ dE

    @cached_property
    def B(self) -> np.ndarray:
        """``B[..., a, alpha, beta]``."""
        dA = np.moveaxis(self.dA, -3, -2)  # (..., a, alpha, beta) = d_alpha A^a_beta
        B = dA - np.swapaxes(dA, -1, -2)
        o = self.owner
        if not o.group.abelian:
            B = B - np.einsum("xbd,...bi,...dj->...xij", o._C, self.A, self.A)
        return B

    @cached_property
    def M(self) -> np.ndarray:
        A, G = self.A, self.G
        At, Gt = np.swapaxes(A, -1, -2), np.swapaxes(G, -1, -2)
        return self.mrr - Gt @ A - At @ G + At @ self.Il @ A

    @cached_property
    def dM(self) -> np.ndarray:
        A, dA = self.A[..., None, :, :], self.dA
        G, Il = self.G[..., None, :, :], self.Il[..., None, :, :]
        At, dAt, Gt, dGt = (np.swapaxes(x, -1, -2) for x in (A, dA, G, self.dG))
        return self.dmrr - dGt @ A - Gt @ dA - dAt @ G - At @ self.dG + dAt @ Il @ A + At @ self.dIl @ A + At @ Il @ dA


class ReducedNumeric:
    """The BKMM reduction (eqs. 1.1-1.3 of the nonholonomic seed) of a system as numeric functions, vectorised
    over leading axes: shapes ``r`` ``(..., sigma)``, shape velocities ``rdot`` ``(..., sigma)``, momenta ``p``
    ``(..., m)``. Built by :meth:`NonholonomicReduction.numeric`; the same object serves a holonomic system
    (no constraints: the mechanical connection, the body momentum) and a nonholonomic one.

    Where the connection is undefined (the locked inertia, or the constraints with it, singular) the methods
    raise :class:`~geomech.errors.SingularityError` naming the shape.
    """

    def __init__(self, reduction: Any, parameters: Mapping[str, float] | None = None):
        s = reduction.system
        self.reduction = reduction
        self.system = s
        self.parameters = dict(parameters or {})
        self.group = s.group
        self.k, self.sigma, self.m, self.c = s.k, s.sigma, reduction.m, s.c
        exprs = reduction_data(reduction)
        # one compiled function for all the data (their common subexpressions shared), split by _Point
        self._layout, start = [], 0
        for name in exprs:
            shape = _LAYOUT[name](s.k, s.sigma, reduction.m, s.c)
            self._layout.append((name, shape, start, start + int(np.prod(shape))))
            start += int(np.prod(shape))
        flat = sp.Matrix([e for X in exprs.values() for e in X])
        self._kernel = reduction._compile(parameters, {"data": flat}, list(reduction.r))["data"]
        self._lam = reduction._compile(parameters, {"Lam": s.group.body_velocity_matrix}, list(s.group.coordinates))[
            "Lam"
        ]
        C = s.group.structure_constants
        self._C = np.array([[[float(C[a][b][d]) for d in range(s.k)] for b in range(s.k)] for a in range(s.k)])
        self._last: tuple[Any, _Point] | None = None

    # -- what bind_loop and the gait analyses ask -------------------------------------------------------
    @property
    def name(self) -> str:
        return self.system.name

    @property
    def shape(self) -> tuple:
        return self.system.shape

    @property
    def shape_angles(self) -> tuple[int, ...]:
        return self.system.shape_angles

    @property
    def exponential_coordinates(self) -> bool:
        """Whether displacements are given in exponential coordinates (the log) rather than in the chart: when
        the chart is singular at the identity (3-1-3 Euler angles of SO(3)), where displacements start."""
        return not self.group.regular_at_identity

    def element(self, coordinates: Any) -> np.ndarray:
        """The group element (a matrix) at the system's group coordinates ``(..., k)``."""
        return self.group.from_coordinates(np.asarray(coordinates, dtype=float))

    def check_locked_inertia(self, r: Any) -> np.ndarray:
        """The locked inertia :math:`\\mathbb I(r)` at the points ``r`` ``(n, sigma)``, or
        :class:`SingularityError` where it is singular (the reconstruction needs :math:`\\mathbb I^{-1}`)."""
        I = self.locked_inertia(np.atleast_2d(r))
        if self.m == 0:
            return I
        V.positive_definite_along(
            I,
            r,
            f"locked inertia of {self.name}",
            "I^-1 p in the reconstruction g^-1 g' = -A r' + I^-1 p is undefined there; keep the shape away from it",
            rtol=1e-10,
            global_scale=True,
        )
        return I

    # -- evaluation -----------------------------------------------------------------------------------
    def _at(self, r: Any) -> _Point:
        r = V.trailing_shape(r, "r", (self.sigma,))
        key = (r.shape, r.tobytes())
        if self._last is None or self._last[0] != key:
            self._last = (key, _Point(self, r))
        return self._last[1]

    def _inverse(self, L: np.ndarray, r: np.ndarray, what: str) -> np.ndarray:
        """:math:`L^{-1}`, or :class:`SingularityError` naming the first shape where ``L`` is singular (its
        condition number in the 1-norm above 1e13)."""
        if L.shape[-1] == 0:
            return np.zeros(L.shape)
        with np.errstate(all="ignore"):
            try:
                Linv = np.linalg.inv(L)
                # the condition number in the 1-norm (the largest column sum), without norm()'s overhead
                cond = np.abs(L).sum(axis=-2).max(axis=-1) * np.abs(Linv).sum(axis=-2).max(axis=-1)
            except np.linalg.LinAlgError:
                Linv, cond = None, np.linalg.cond(L)
        cond = np.where(np.isfinite(cond), cond, np.inf)
        if Linv is None or np.any(cond > _COND_MAX):
            i = np.unravel_index(int(np.argmax(cond)), np.shape(cond))
            why = "the locked inertia is singular" if not self.c else "the locked inertia on S_q is singular"
            raise SingularityError(
                f"{self.name}: {what} is undefined at r = {np.round(r[i], 6).tolist()} ({why} there, condition "
                f"number {np.asarray(cond)[i]:.3g}); keep the shape away from it."
            )
        return Linv

    def _momenta(self, x: Any, n: int, name: str, shape: tuple) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if n == 0:
            return np.zeros(shape + (0,))
        return V.trailing_shape(np.atleast_1d(x), name, (n,))

    def locked_inertia_full(self, r: Any) -> np.ndarray:
        """:math:`\\mathbb I_{\\mathrm{loc}}(r) = \\partial^2 l/\\partial\\xi^2`, shape ``(..., k, k)``."""
        return self._at(r).Il

    def coupling(self, r: Any) -> np.ndarray:
        """:math:`\\Gamma(r) = \\partial^2 l/\\partial\\xi\\partial\\dot r` (:math:`\\mathbb I_{loc}A_{loc}` without
        constraints), shape ``(..., k, sigma)``."""
        return self._at(r).G

    def basis(self, r: Any) -> np.ndarray:
        """:math:`e(r)`, shape ``(..., k, m)``."""
        return self._at(r).E

    def locked_inertia(self, r: Any) -> np.ndarray:
        """:math:`\\mathbb I(r) = e^T\\mathbb I_{\\mathrm{loc}}e`, shape ``(..., m, m)``."""
        return self._at(r).Im

    def connection(self, r: Any) -> np.ndarray:
        """:math:`\\mathcal A(r)`, shape ``(..., k, sigma)``: horizontal :math:`\\xi = -\\mathcal A\\dot r`."""
        return self._at(r).A

    def connection_derivative(self, r: Any) -> np.ndarray:
        """:math:`\\partial_\\alpha\\mathcal A(r)`, shape ``(..., sigma, k, sigma)`` (index :math:`\\alpha`
        first)."""
        return self._at(r).dA

    def curvature(self, r: Any) -> np.ndarray:
        """:math:`B^a_{\\alpha\\beta}(r)`, shape ``(..., k, sigma, sigma)`` (antisymmetric in the last two)."""
        return self._at(r).B

    def curvature_2d(self, r: Any) -> np.ndarray:
        """:math:`B_{12}(r)`, shape ``(..., k)``, on a 2-D shape space."""
        if self.sigma != 2:
            raise InputError(
                f"`curvature_2d` needs a 2-D shape space, {self.name} has {self.sigma} shape coordinates; "
                "use `curvature`."
            )
        return self.curvature(r)[..., :, 0, 1]

    def shape_mass(self, r: Any) -> np.ndarray:
        """:math:`M(r)`, the kinetic metric on horizontal vectors (eq. 1.3), shape ``(..., sigma, sigma)``."""
        return self._at(r).M

    def xi_connection(self, r: Any, rdot: Any) -> np.ndarray:
        """:math:`-\\mathcal A(r)\\dot r`, shape ``(..., k)``."""
        return -np.einsum("...aj,...j->...a", self.connection(r), np.asarray(rdot, dtype=float))

    def xi_momentum(self, r: Any, p: Any) -> np.ndarray:
        """:math:`e(r)\\,\\mathbb I^{-1}(r)\\,p`, shape ``(..., k)``."""
        P = self._at(r)
        batch = P.r.shape[:-1]
        p = self._momenta(p, self.m, "p", batch)
        if self.m == 0:
            return np.zeros(np.broadcast_shapes(batch, p.shape[:-1]) + (self.k,))
        return np.einsum("...ai,...ij,...j->...a", P.E, P.Iminv, p)

    def xi(self, r: Any, rdot: Any, p: Any) -> np.ndarray:
        """The body velocity :math:`g^{-1}\\dot g = -\\mathcal A\\dot r + e\\,\\mathbb I^{-1}p` (eq. 1.1)."""
        return self.xi_connection(r, rdot) + self.xi_momentum(r, p)

    def _mu_omega(self, P: _Point, rdot: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        batch = P.r.shape[:-1]
        if self.m:
            Om = np.einsum("...ij,...j->...i", P.Iminv, p)
        else:
            Om = np.zeros(batch + (0,))
        xi = -np.einsum("...aj,...j->...a", P.A, rdot) + np.einsum("...ai,...i->...a", P.E, Om)
        mu = np.einsum("...ab,...b->...a", P.Il, xi) + np.einsum("...aj,...j->...a", P.G, rdot)
        return xi, mu, Om

    def pdot(self, r: Any, rdot: Any, p: Any) -> np.ndarray:
        """The momentum equation (1.2), shape ``(..., m)``."""
        P = self._at(r)
        batch = P.r.shape[:-1]
        if self.m == 0:
            return np.zeros(batch + (0,))
        rdot = V.trailing_shape(np.asarray(rdot, dtype=float), "rdot", (self.sigma,))
        xi, mu, _ = self._mu_omega(P, rdot, self._momenta(p, self.m, "p", batch))
        bracket = np.einsum("abd,...a,...b,...di->...i", self._C, mu, xi, P.E)
        return bracket + np.einsum("...a,...bai,...b->...i", mu, P.dE, rdot)

    def delta(self, r: Any, rdot: Any, p: Any) -> np.ndarray:
        """:math:`\\delta(r, \\dot r, p)` with :math:`M\\ddot r = \\delta + \\tau` (eq. 1.3), shape
        ``(..., sigma)``."""
        P = self._at(r)
        batch = P.r.shape[:-1]
        rd = V.trailing_shape(np.asarray(rdot, dtype=float), "rdot", (self.sigma,))
        _, mu, Om = self._mu_omega(P, rd, self._momenta(p, self.m, "p", batch))
        dM = P.dM  # (..., beta, alpha, gamma) = d_beta M_{alpha gamma}
        chris = np.einsum("...bag,...b,...g->...a", dM, rd, rd) - 0.5 * np.einsum("...abg,...b,...g->...a", dM, rd, rd)
        out = -chris - P.parts["dV"][..., 0]
        out = out + np.einsum("...a,...aij,...j->...i", mu, P.B, rd)
        if self.m:
            out = out + 0.5 * np.einsum("...i,...aij,...j->...a", Om, P.dIm, Om)
            F = np.moveaxis(P.dE, -3, -1) + np.einsum("abd,...bj,...dc->...ajc", self._C, P.E, P.A)  # (a, j, alpha)
            out = out - np.einsum("...a,...aji,...j->...i", mu, F, Om)
        return out

    def rddot(self, r: Any, rdot: Any, p: Any, tau: Any = None) -> np.ndarray:
        """The shape accelerations from eq. (1.3), :math:`\\ddot r = M^{-1}(\\delta + \\tau)`."""
        rhs = self.delta(r, rdot, p)
        if tau is not None:
            rhs = rhs + np.asarray(tau, dtype=float)
        return np.linalg.solve(self.shape_mass(r), rhs[..., None])[..., 0]

    # -- from the full state ----------------------------------------------------------------------------
    def _body(self, q: Any, qdot: Any) -> tuple[_Point, np.ndarray]:
        """The point of the shapes and :math:`\\mu = \\partial l/\\partial\\xi` at full states ``(..., n)``."""
        s = self.system
        q = V.trailing_shape(q, "q", (s.n,))
        qd = V.trailing_shape(qdot, "qdot", (s.n,))
        k = self.k
        xi = np.einsum("...ij,...j->...i", self._lam(q[..., :k]), qd[..., :k])
        P = self._at(q[..., k:])
        mu = np.einsum("...ab,...b->...a", P.Il, xi) + np.einsum("...aj,...j->...a", P.G, qd[..., k:])
        return P, mu

    def momentum(self, q: Any, qdot: Any) -> np.ndarray:
        """The nonholonomic momentum :math:`p_i = \\langle\\partial l/\\partial\\xi, e_i(r)\\rangle` at full states
        ``(..., n)``, shape ``(..., m)`` (without constraints: the body momentum)."""
        P, mu = self._body(q, qdot)
        return np.einsum("...ai,...a->...i", P.E, mu)

    def momentum_map(self, q: Any, qdot: Any) -> np.ndarray:
        """The spatial momentum :math:`J = \\mathrm{Ad}_{g^{-1}}^T\\,\\partial l/\\partial\\xi` at full states,
        shape ``(..., k)`` (conserved without constraints and forces on the group)."""
        _, mu = self._body(q, qdot)
        G = self.group
        g = G.from_coordinates(np.asarray(q, dtype=float)[..., : self.k])
        Ad_inv = G.numeric.Ad(G.numeric.inverse(g))
        return np.einsum("...ji,...j->...i", Ad_inv, mu)

    def __repr__(self) -> str:
        return f"ReducedNumeric({self.name!r}, k={self.k}, sigma={self.sigma}, m={self.m})"
