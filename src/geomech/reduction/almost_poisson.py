r"""The Hamiltonian side of nonholonomic mechanics: the almost-Poisson bracket on the constraint submanifold, its
Jacobiator through the curvature of the constraint distribution, and its Poisson reduction.

Section 1.2 of the nonholonomic seed (after van der Schaft and Maschke, Rep. Math. Phys. 34 (1994) 225, "VM"):
the constraint submanifold is :math:`\mathcal M = \mathbb FL(\mathcal D) \subset T^*Q`; with a basis
:math:`X_\alpha(q)` of :math:`\mathcal D` the induced coordinates are :math:`(q^i, \tilde p_\alpha)`,
:math:`\tilde p_\alpha = X_\alpha^i p_i`. On :math:`\mathcal M`, :math:`p = \mathbb M X G^{-1}\tilde p` with
:math:`G = X^T\mathbb M X`, so the constrained Hamiltonian is
:math:`H_{\mathcal M}(q, \tilde p) = \tfrac12\tilde p^T G^{-1}\tilde p + V(q)` and the truncated tensor
:math:`J_{\mathcal M}` has the entries of the canonical brackets restricted to :math:`\mathcal M`:

.. math::

    \{q^i, q^j\} = 0, \qquad \{q^i, \tilde p_\beta\} = X^i_\beta, \qquad
    \{\tilde p_\alpha, \tilde p_\beta\} = -\langle p, [X_\alpha, X_\beta]\rangle .

(These do not depend on the complement :math:`\{\omega_a\}` chosen in the seed: only values on
:math:`\mathcal M` enter.) The dynamics is :math:`\dot z = J_{\mathcal M}\nabla H_{\mathcal M}`. Its Jacobiator,
derived here, is expressed through the curvature of :math:`\mathcal D`,
:math:`K_{\alpha\beta} = A\,[X_\alpha, X_\beta]` (the constraint one-forms on the brackets):

.. math::

    \mathrm{Jac}(q^i, \tilde p_\alpha, \tilde p_\beta) = \big(Z K_{\alpha\beta}\big)^i, \qquad
    \mathrm{Jac}(\tilde p_\alpha, \tilde p_\beta, \tilde p_\gamma)
        = -\Big\langle p, \textstyle\sum_{\rm cyc}\,[X_\alpha, Z K_{\beta\gamma}]\Big\rangle,

with :math:`Z = (I - \Pi)Y`, :math:`\Pi = XG^{-1}X^T\mathbb M` the kinetic-metric projector onto
:math:`\mathcal D` and :math:`Y` any right inverse of :math:`A`; all other Jacobiators of coordinate functions
vanish. So the bracket satisfies the Jacobi identity exactly when :math:`\mathcal D` is integrable.

Section 1.3 and Theorems 1.1-1.2 (Poisson reduction, after BKMM): with the BKMM-adapted basis
:math:`X_i = (e_i)_Q`, :math:`X_\alpha = -(\mathcal A^{nh}_\alpha)_Q + \partial_{r^\alpha}` the induced momenta are the
nonholonomic momentum :math:`p_i` and :math:`\tilde p_\alpha = p_\alpha - \mu_b\mathcal A^b_\alpha`; the reduced
Hamiltonian is :math:`h = \tfrac12\tilde p_r^T M^{-1}\tilde p_r + \tfrac12 p^T\mathbb I^{-1}p + V(r)` and

.. math::

    \dot p_i &= -\mu_a C^a_{bd}e^b_i e^d_j\frac{\partial h}{\partial p_j}
        + \mu_a F^a_{i\beta}\frac{\partial h}{\partial\tilde p_\beta},
    \qquad \dot r^\alpha = \frac{\partial h}{\partial\tilde p_\alpha}, \\
    \dot{\tilde p}_\alpha &= -\frac{\partial h}{\partial r^\alpha} - \mu_a F^a_{j\alpha}\frac{\partial h}{\partial p_j}
        + \mu_a B^a_{\alpha\beta}\frac{\partial h}{\partial\tilde p_\beta} + \tau_\alpha, \qquad
    \xi^b = -\mathcal A^b_\beta\frac{\partial h}{\partial\tilde p_\beta} + e^b_i\frac{\partial h}{\partial p_i},

with :math:`B` the curvature of the nonholonomic connection (BKMM),
:math:`B^a_{\alpha\beta} = \partial_\alpha\mathcal A^a_\beta - \partial_\beta\mathcal A^a_\alpha
- C^a_{bd}\mathcal A^b_\alpha\mathcal A^d_\beta`.
Corrections to the printed Theorem 1.1: the reconstruction equation gives :math:`\xi`, not :math:`\dot\xi`; with
BKMM's sign of the curvature the :math:`B`-term enters :math:`\dot{\tilde p}_\alpha` with a plus sign (the printed
minus corresponds to the opposite orientation of :math:`B`); both are checked against the Lagrangian reduction.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from itertools import combinations
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from ..symbolic import (
    NumericCache,
    clear_denominators,
    derivative,
    half_quadratic,
    jacobian,
    shared_property,
    simplified_inverse,
    simplify_expr,
    simplify_matrix,
)
from ..symbolic.compile import evaluate
from ..symbolic.formula import to_expression
from ..systems.nonholonomic import NonholonomicSystem
from ._derived import Derived, Labelled
from .lagrange_dalembert import lagrange_dalembert
from .nonholonomic import NonholonomicReduction, bkmm_reduction

__all__ = [
    "AlmostPoissonStructure",
    "PoissonReduction",
    "almost_poisson",
    "poisson_reduction",
    "jacobiator",
]


def _lie_bracket(X: sp.Matrix, Y: sp.Matrix, q: list) -> sp.Matrix:
    """:math:`[X, Y]^i = X^j\\partial_j Y^i - Y^j\\partial_j X^i`."""
    return jacobian(Y, q) * X - jacobian(X, q) * Y


def jacobiator(J: sp.MatrixBase, z: list, i: int, j: int, k: int) -> sp.Expr:
    r""":math:`\{z^i, \{z^j, z^k\}\} + \text{cyclic}
    = \sum_l J^{il}\partial_l J^{jk} + J^{jl}\partial_l J^{ki} + J^{kl}\partial_l J^{ij}`."""
    return sum(
        J[i, l] * derivative(J[j, k], z[l]) + J[j, l] * derivative(J[k, i], z[l]) + J[k, l] * derivative(J[i, j], z[l])
        for l in range(len(z))
    )


def _D_basis(system: NonholonomicSystem, basis: str) -> tuple[sp.Matrix, str]:
    s = system
    if basis == "bkmm":
        red = bkmm_reduction(s)
        Li = sp.Matrix(s.group.body_velocity_inverse)
        E, A = sp.Matrix(red.basis), sp.Matrix(red.connection)
        cols = [sp.Matrix.vstack(Li * E[:, i], sp.zeros(s.sigma, 1)) for i in range(red.m)]
        for al in range(s.sigma):
            e = sp.zeros(s.sigma, 1)
            e[al] = 1
            cols.append(sp.Matrix.vstack(-Li * A[:, al], e))
        X = sp.Matrix.hstack(*cols).applyfunc(simplify_expr)
        return X, (
            "BKMM-adapted: X_i = (e_i(r))_Q spanning S_q, then the horizontal lifts X_alpha = "
            "-(A_alpha)_Q + d/dr^alpha; the induced momenta are (p_i, p~_alpha)"
        )
    if basis == "nullspace":
        A = sp.Matrix(s.constraint_matrix)
        vecs = A.nullspace(simplify=True) if s.c else [sp.eye(s.n)[:, i] for i in range(s.n)]
        return sp.Matrix.hstack(*[clear_denominators(v) for v in vecs]), "null space of A(q), denominators cleared"
    raise InputError(f"Expected `basis` to be 'bkmm' or 'nullspace', got {basis!r}.")


# --------------------------------------------------------------------------------------------------
# The almost-Poisson bracket on M = FL(D)
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class AlmostPoissonStructure(Derived, NumericCache):
    r"""The truncated almost-Poisson tensor :math:`J_{\mathcal M}` of VM in induced coordinates :math:`(q, \tilde p)`.

    Attributes
    ----------
    system : NonholonomicSystem
    X : Matrix (n, n - c)
        The basis of :math:`\mathcal D` (columns); ``basis_note`` says which.
    pt : tuple of Symbol
        The induced momenta :math:`\tilde p_\alpha`.
    """

    system: NonholonomicSystem
    X: sp.ImmutableMatrix
    basis_note: str
    pt: tuple[sp.Symbol, ...]
    blocks: tuple[sp.ImmutableMatrix, ...] | None = None
    title: str = "almost-Poisson bracket on M = FL(D)"

    @property
    def _cache_key(self) -> tuple:
        return (self.system.key, self.X)

    @property
    def z(self) -> list[sp.Symbol]:
        """Coordinates :math:`(q, \\tilde p)` of :math:`\\mathcal M`."""
        return list(self.system.q) + list(self.pt)

    @shared_property
    def metric(self) -> sp.ImmutableMatrix:
        """:math:`G = X^T\\mathbb M X`, the kinetic metric on :math:`\\mathcal D` in the basis. For the BKMM-adapted
        basis it is :math:`\\mathrm{diag}(\\mathbb I(r), M(r))`: :math:`S_q` and the horizontal space are orthogonal."""
        if self.blocks is not None:
            return sp.ImmutableMatrix(sp.diag(*[sp.Matrix(b) for b in self.blocks if b.rows]))
        X = sp.Matrix(self.X)
        return simplify_matrix(X.T * sp.Matrix(self.system.mass_matrix) * X)

    @shared_property
    def metric_inverse(self) -> sp.ImmutableMatrix:
        if self.blocks is not None:
            # diag(I(r), M(r)) of the BKMM reduction, whose inverses it has already
            red = bkmm_reduction(self.system)
            return sp.ImmutableMatrix(
                sp.diag(*[sp.Matrix(b) for b in (red.locked_inertia_inverse, red.shape_mass_inverse) if b.rows])
            )
        return simplified_inverse(self.metric)

    @shared_property
    def momentum(self) -> sp.ImmutableMatrix:
        r"""The point :math:`p(q, \tilde p) = \mathbb M X G^{-1}\tilde p` of
        :math:`\mathcal M = \mathbb FL(\mathcal D)`."""
        X = sp.Matrix(self.X)
        MX = simplify_matrix(sp.Matrix(self.system.mass_matrix) * X)
        return sp.ImmutableMatrix(MX * sp.Matrix(self.metric_inverse) * sp.Matrix(self.pt))

    @shared_property
    def hamiltonian(self) -> sp.Expr:
        r""":math:`H_{\mathcal M}(q, \tilde p) = \tfrac12\tilde p^T G^{-1}\tilde p + V(q)`, with the simplified
        entries of :math:`G^{-1}` (as the reduced Hamiltonian of :class:`PoissonReduction`; one fraction over their
        common denominator was 35 % of the three-link chain's printed derivation)."""
        return half_quadratic(self.metric_inverse, self.pt) + self.system.potential

    @shared_property
    def brackets(self) -> tuple[tuple[sp.Expr, ...], ...]:
        r""":math:`[X_\alpha, X_\beta]` for :math:`\alpha < \beta` (as n-vectors), row-major over the pairs."""
        X, q = sp.Matrix(self.X), list(self.system.q)
        d = X.cols
        return tuple(
            tuple(_lie_bracket(X[:, a], X[:, b], q).applyfunc(simplify_expr)) for a in range(d) for b in range(a + 1, d)
        )

    def _pair(self, a: int, b: int) -> sp.Matrix:
        d = self.X.cols
        if a == b:
            return sp.zeros(self.system.n, 1)
        lo, hi = min(a, b), max(a, b)
        idx = lo * d - lo * (lo + 1) // 2 + (hi - lo - 1)
        v = sp.Matrix(self.brackets[idx])
        return v if a < b else -v

    @shared_property
    def tensor(self) -> sp.ImmutableMatrix:
        r""":math:`J_{\mathcal M}(q, \tilde p)`, of size (2n - c) x (2n - c), ordered :math:`(q, \tilde p)`."""
        s, X = self.system, sp.Matrix(self.X)
        n, d = s.n, X.cols
        J = sp.zeros(n + d, n + d)
        J[:n, n:] = X
        J[n:, :n] = -X.T
        p = sp.Matrix(self.momentum)
        for a in range(d):
            for b in range(a + 1, d):
                e = simplify_expr(-(p.T * self._pair(a, b))[0, 0])
                J[n + a, n + b], J[n + b, n + a] = e, -e
        return sp.ImmutableMatrix(J)

    def bracket(self, F: Any, G: Any) -> sp.Expr:
        r""":math:`\{F, G\}_{\mathcal M} = \nabla F^T J_{\mathcal M}\nabla G` of two functions of
        :math:`(q, \tilde p)`."""
        z = self.z
        names = {v.name: v for v in z}
        F, G = to_expression(F, "F", names), to_expression(G, "G", names)
        gF = sp.Matrix([derivative(F, v) for v in z])
        gG = sp.Matrix([derivative(G, v) for v in z])
        return simplify_expr((gF.T * sp.Matrix(self.tensor) * gG)[0, 0])

    @shared_property
    def vector_field(self) -> sp.ImmutableMatrix:
        r""":math:`\dot z = J_{\mathcal M}\nabla H_{\mathcal M}` (no shape forces)."""
        gH = sp.Matrix([derivative(self.hamiltonian, v) for v in self.z])
        return sp.ImmutableMatrix(sp.Matrix(self.tensor) * gH)

    # ---------------- Jacobiator ----------------
    @shared_property
    def curvature(self) -> tuple[sp.ImmutableMatrix, ...]:
        r"""The curvature of :math:`\mathcal D` in the basis: :math:`K_{\alpha\beta} = A\,[X_\alpha, X_\beta]`
        (c-vectors, one per pair :math:`\alpha < \beta`); all zero iff :math:`\mathcal D` is integrable."""
        A = sp.Matrix(self.system.constraint_matrix)
        return tuple(simplify_matrix(A * sp.Matrix(v)) for v in self.brackets)

    @property
    def _Z(self) -> sp.Matrix:
        # (I - Pi) Y depends on neither the basis X of D nor the right inverse Y: it is the kinetic-orthogonal
        # right inverse of A, derived (simplified) once for the system
        return sp.Matrix(lagrange_dalembert(self.system).constraint_complement)

    def _keys(self) -> list[tuple[int, int, int]]:
        n, d = self.system.n, self.X.cols
        keys = [(i, n + a, n + b) for a, b in combinations(range(d), 2) for i in range(n)]
        return keys + [(n + a, n + b, n + c) for a, b, c in combinations(range(d), 3)]

    @shared_property
    def jacobiator_direct(self) -> dict:
        r"""Jacobiators of coordinate functions computed directly from :math:`J_{\mathcal M}` (not simplified), keyed
        by the index triple of ``z = (q, pt)``: ``(i, n+a, n+b)`` and ``(n+a, n+b, n+c)``; the others vanish
        identically (:math:`\{q^i, q^j\} = 0` and :math:`\{q^i, \tilde p_\alpha\}` does not depend on
        :math:`\tilde p`)."""
        J, z = self.tensor, self.z
        return {key: jacobiator(J, z, *key) for key in self._keys()}

    @shared_property
    def jacobiator_curvature(self) -> dict:
        r"""The same Jacobiators from the curvature formula of the module docstring (same keys, not simplified)."""
        n, d, q = self.system.n, self.X.cols, list(self.system.q)
        X, Z, p = sp.Matrix(self.X), self._Z, sp.Matrix(self.momentum)
        ZK = {}
        for idx, (a, b) in enumerate(combinations(range(d), 2)):
            ZK[(a, b)] = Z * sp.Matrix(self.curvature[idx])
            ZK[(b, a)] = -ZK[(a, b)]
        out = {}
        for a, b in combinations(range(d), 2):
            for i in range(n):
                out[(i, n + a, n + b)] = ZK[(a, b)][i]
        for a, b, c in combinations(range(d), 3):
            cyc = (
                _lie_bracket(X[:, a], ZK[(b, c)], q)
                + _lie_bracket(X[:, b], ZK[(c, a)], q)
                + _lie_bracket(X[:, c], ZK[(a, b)], q)
            )
            out[(n + a, n + b, n + c)] = -(p.T * cyc)[0, 0]
        return out

    @property
    def jacobiator_labels(self) -> tuple[str, ...]:
        """What each column of :meth:`jacobiator_values` and :meth:`jacobiator_numeric` is, in their order:
        ``"Jac(x, pt1, pt2)"`` with the names of the coordinates ``z = (q, pt)`` (the keys of
        :attr:`jacobiator_direct`, by name)."""
        names = [v.name for v in self.z]
        return tuple(f"Jac({names[i]}, {names[j]}, {names[k]})" for i, j, k in self._keys())

    def jacobiator_values(self, points: int = 3, seed: int = 0, parameters: dict | None = None) -> np.ndarray:
        """Both Jacobiator forms at random points ``z`` (parameters random in [0.6, 1.7] unless given): an array
        ``(points, 2, number of keys)``, ``[:, 0]`` direct and ``[:, 1]`` from the curvature; the last axis in the
        order of :attr:`jacobiator_labels`."""
        s, keys = self.system, self._keys()
        rng = np.random.default_rng(seed)
        syms = self.z + list(s.parameter_symbols)
        both = [[self.jacobiator_direct[k] for k in keys], [self.jacobiator_curvature[k] for k in keys]]
        args = []
        for _ in range(points):
            pv = s._random_point(rng, self.z)
            if parameters:
                pv.update({p: float(parameters[p.name]) for p in s.parameter_symbols if p.name in parameters})
            args.append([pv[v] for v in syms])
        return evaluate(both, syms, np.array(args, dtype=float).reshape(points, len(syms)))

    @shared_property
    def jacobiators(self) -> dict:
        r"""The Jacobiators of coordinate functions by the curvature formula, simplified (keys as in
        :attr:`jacobiator_curvature`): :math:`\mathrm{Jac}(q^i, \tilde p_\alpha, \tilde p_\beta) = (ZK_{\alpha\beta})^i`
        is a function of :math:`q`; :math:`\mathrm{Jac}(\tilde p_\alpha, \tilde p_\beta, \tilde p_\gamma)` is linear in
        :math:`\tilde p`, each coefficient simplified. Built from simplified pieces (:math:`ZK_{\alpha\beta}`, the
        brackets, :math:`\mathbb M X G^{-1}`), so that no large expression is differentiated or simplified."""
        s = self.system
        n, d, q = s.n, self.X.cols, list(s.q)
        X, Z = sp.Matrix(self.X), self._Z
        out, ZK = {}, {}
        for idx, (a, b) in enumerate(combinations(range(d), 2)):
            ZK[(a, b)] = simplify_matrix(Z * sp.Matrix(self.curvature[idx]))
            ZK[(b, a)] = -ZK[(a, b)]
            for i in range(n):
                out[(i, n + a, n + b)] = ZK[(a, b)][i]
        if d >= 3 and all(entry == 0 for v in ZK.values() for entry in v):
            # D integrable (or no constraints): every ZK vanishes, and with it the cyclic sums
            out.update({(n + a, n + b, n + c): sp.Integer(0) for a, b, c in combinations(range(d), 3)})
        elif d >= 3:
            # p = M X G^{-1} pt: the coefficient of pt_e in -<p, cyc> is -(M X G^{-1})[:, e] . cyc, simplified once
            # from the cyclic sum as it comes (simplifying its entries first made them larger: 55k characters each
            # for the tilted sleigh, converted back to expressions and read again)
            P = simplify_matrix(simplify_matrix(sp.Matrix(s.mass_matrix) * X) * sp.Matrix(self.metric_inverse))
            for a, b, c in combinations(range(d), 3):
                cyc = (
                    _lie_bracket(X[:, a], ZK[(b, c)], q)
                    + _lie_bracket(X[:, b], ZK[(c, a)], q)
                    + _lie_bracket(X[:, c], ZK[(a, b)], q)
                )
                out[(n + a, n + b, n + c)] = sp.Add(
                    *[simplify_expr(-(P[:, e].T * cyc)[0, 0]) * pt for e, pt in enumerate(self.pt)]
                )
        return out

    def jacobiator_numeric(self, points: int = 3, seed: int = 0, parameters: dict | None = None) -> np.ndarray:
        r"""The Jacobiators of coordinate functions (keys of :attr:`jacobiator_direct`) at random points, computed
        from :math:`J_{\mathcal M}` alone: :math:`\sum_l J^{il}\partial_l J^{jk} + \text{cyclic}` with the
        derivatives of the compiled tensor by complex step (exact to round-off). Shape ``(points, number of keys)``,
        the columns in the order of :attr:`jacobiator_labels`.
        """
        s, keys, z = self.system, self._keys(), self.z
        rng = np.random.default_rng(seed)
        syms = z + list(s.parameter_symbols)
        tensor = sp.Matrix(self.tensor)
        N, h = len(z), 1e-30
        out = np.empty((points, len(keys)))
        for j in range(points):
            pv = s._random_point(rng, z)
            if parameters:
                pv.update({p: float(parameters[p.name]) for p in s.parameter_symbols if p.name in parameters})
            args = np.array([pv[v] for v in syms], dtype=complex)
            # the point, and the point stepped by i h along each coordinate: one vectorised evaluation
            stepped = np.tile(args, (N + 1, 1))
            stepped[1 + np.arange(N), np.arange(N)] += 1j * h
            values = evaluate(tensor, syms, stepped, dtype=complex)
            J, dJ = values[0].real, values[1:].imag / h
            out[j] = [J[a, :] @ dJ[:, b, c] + J[b, :] @ dJ[:, c, a] + J[c, :] @ dJ[:, a, b] for a, b, c in keys]
        return out

    @shared_property
    def satisfies_jacobi(self) -> bool:
        """Whether every Jacobiator of coordinate functions vanishes, decided at random points from the tensor
        itself (:meth:`jacobiator_numeric`; the formulas are exact, so a value beyond round-off is decisive)."""
        vals = self.jacobiator_numeric()
        scale = max(1.0, float(np.abs(vals).max(initial=0.0)))
        return bool(np.abs(vals).max(initial=0.0) < 1e-9 * scale) if vals.size else True

    def _latex_names(self) -> dict:
        names = dict(self.system.latex_names)
        for a, p in enumerate(self.pt):
            names[p] = rf"\tilde p_{{{a + 1}}}"
        return names

    def items(self):
        z, names = self.z, self._latex_names()
        tex = [names.get(v, sp.latex(v)) for v in z]
        jac = Labelled(
            (f"Jac({z[i]}, {z[j]}, {z[k]})", rf"\mathrm{{Jac}}({tex[i]}, {tex[j]}, {tex[k]})", v)
            for (i, j, k), v in self.jacobiators.items()
        )
        d = self.X.cols
        pairs = [(a, b) for a in range(d) for b in range(a + 1, d)]
        curv = Labelled((f"K_{a + 1}{b + 1}", rf"K_{{{a + 1}{b + 1}}}", K) for (a, b), K in zip(pairs, self.curvature))
        return [
            ("basis of D (columns)", r"X(q)", self.X),
            ("basis note", r"\mathrm{basis}", self.basis_note),
            ("coordinates z", "z", self.z),
            ("momentum on M", r"p(q, \tilde p)", self.momentum),
            ("H_M", r"H_{\mathcal M}", self.hamiltonian),
            ("J_M", r"J_{\mathcal M}", self.tensor),
            ("curvature of D", r"K_{\alpha\beta} = A[X_\alpha, X_\beta]", curv),
            ("Jacobi identity holds", r"\mathrm{Jacobi}", str(self.satisfies_jacobi)),
            (
                "Jacobiators Jac(q^i, pt_a, pt_b) = (Z K_ab)^i and Jac(pt_a, pt_b, pt_c)",
                r"\mathrm{Jac}",
                jac if jac else "none (dim D < 2)",
            ),
        ]

    def numeric(self, parameters: dict | None = None) -> dict:
        r"""Compiled ``J(z)``, ``gradH(z)``, ``p(z)`` (the point of M), ``X(z)``, ``pt(q, qdot) = X^T M qdot``, and
        ``field(z, force=None)``: :math:`\dot z = J_{\mathcal M}\nabla H_{\mathcal M} + (0, X^TF)`, the
        constrained motion under a generalised force :math:`F(q)` (shape ``(..., n)``; none: the free motion);
        ``response(z)``: the free field and the matrix ``R`` (shape ``(..., dim z, n)``) with ``field(z, F) = free +
        R F``, for a force that depends on the velocity (the field's q rows, which ``R`` leaves alone).
        Vectorised over leading axes."""
        s = self.system
        gH = sp.Matrix([derivative(self.hamiltonian, v) for v in self.z])
        out = dict(self._compile(parameters, {"J": self.tensor, "gradH": gH, "p": self.momentum, "X": self.X}, self.z))
        pt = sp.Matrix(self.X).T * sp.Matrix(s.mass_matrix) * sp.Matrix(s.qdot)
        out.update(self._compile(parameters, {"pt": pt}, list(s.q) + list(s.qdot)))
        n = s.n

        def field(z: Any, force: Any = None) -> np.ndarray:
            z = np.asarray(z, dtype=float)
            f = np.einsum("...ij,...j->...i", out["J"](z), out["gradH"](z)[..., 0])
            if force is not None:
                f[..., n:] += np.einsum("...ia,...i->...a", out["X"](z), np.asarray(force, dtype=float))
            return f

        def response(z: Any) -> tuple[np.ndarray, np.ndarray]:
            z = np.asarray(z, dtype=float)
            free = field(z)
            R = np.zeros(free.shape + (n,))
            R[..., n:, :] = np.swapaxes(out["X"](z), -1, -2)
            return free, R

        out.update(field=field, response=response)
        return out


@lru_cache(maxsize=64)
def _almost_poisson_fields(system: NonholonomicSystem, basis: str) -> tuple:
    X, note = _D_basis(system, basis)
    pt = tuple(sp.Symbol(f"pt{a + 1}", real=True) for a in range(X.cols))
    blocks = None
    if basis == "bkmm":
        red = bkmm_reduction(system)
        blocks = (red.locked_inertia, red.shape_mass)
    return sp.ImmutableMatrix(X), note, pt, blocks


def almost_poisson(system: NonholonomicSystem, basis: str = "bkmm") -> AlmostPoissonStructure:
    """The almost-Poisson structure of ``system`` on :math:`\\mathcal M = \\mathbb FL(\\mathcal D)` (cached).

    ``basis``: ``"bkmm"`` (default; needs the BKMM reduction, the momenta are then :math:`(p_i, \\tilde p_\\alpha)`)
    or ``"nullspace"`` (the null space of :math:`A(q)`).
    """
    if not isinstance(system, NonholonomicSystem):
        raise InputError(f"Expected `system` to be a NonholonomicSystem, got {type(system).__name__}.")
    return AlmostPoissonStructure(system, *_almost_poisson_fields(system, basis))


# --------------------------------------------------------------------------------------------------
# Poisson reduction (Theorems 1.1 and 1.2)
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PoissonReduction(Derived, NumericCache):
    r"""Theorems 1.1 and 1.2 of the nonholonomic seed: reduced Hamilton equations on :math:`\bar{\mathcal M}` with
    coordinates :math:`(r, \tilde p_r, p)`, and the reduced Legendre transform to :math:`(r, \dot r, \Omega)`."""

    reduction: NonholonomicReduction
    ptr: tuple[sp.Symbol, ...]
    omega: tuple[sp.Symbol, ...]
    title: str = "Poisson reduction (Theorems 1.1, 1.2)"

    @property
    def _cache_key(self) -> tuple:
        return self.reduction._cache_key

    @property
    def system(self) -> NonholonomicSystem:
        return self.reduction.system

    @property
    def z(self) -> list[sp.Symbol]:
        """Coordinates :math:`(r, \\tilde p_r, p)` of :math:`\\bar{\\mathcal M}`."""
        red = self.reduction
        return list(red.r) + list(self.ptr) + list(red.p)

    @shared_property
    def hamiltonian(self) -> sp.Expr:
        r""":math:`h = \tfrac12\tilde p_r^T M^{-1}\tilde p_r + \tfrac12 p^T\mathbb I^{-1}p + V(r)`."""
        red = self.reduction
        Minv = sp.Matrix(red.shape_mass_inverse) if red.r else sp.zeros(0, 0)
        a, p = sp.Matrix(self.ptr), sp.Matrix(len(red.p), 1, list(red.p))
        h = red.potential
        if red.r:
            h += (a.T * Minv * a)[0, 0] / 2
        if red.m:
            h += (p.T * sp.Matrix(red.locked_inertia_inverse) * p)[0, 0] / 2
        return h

    @shared_property
    def _mu(self) -> sp.Matrix:
        """:math:`\\mu` in ``(r, ptr, p)``: :math:`\\mu_r M^{-1}\\tilde p_r + \\mu_p p`."""
        red = self.reduction
        rd = sp.Matrix([derivative(self.hamiltonian, a) for a in self.ptr])
        return red.mu.xreplace(dict(zip(red.rdot, rd)))

    @shared_property
    def tensor(self) -> sp.ImmutableMatrix:
        r"""The reduced almost-Poisson tensor on :math:`(r, \tilde p_r, p)`: :math:`\{r^\alpha, \tilde p_\beta\} =
        \delta`, :math:`\{\tilde p_\alpha, \tilde p_\beta\} = \mu_a B^a_{\alpha\beta}`,
        :math:`\{p_i, \tilde p_\beta\} = \mu_a F^a_{i\beta}`, :math:`\{p_i, p_j\} = -\mu_a C^a_{bd}e^b_ie^d_j`."""
        red, s = self.reduction, self.reduction.system
        sig, m, k = s.sigma, red.m, s.k
        C, E, mu = s.group.structure_constants, sp.Matrix(red.basis), self._mu
        J = sp.zeros(2 * sig + m, 2 * sig + m)
        for al in range(sig):
            J[al, sig + al], J[sig + al, al] = 1, -1
            for be in range(sig):
                J[sig + al, sig + be] = sum(mu[a] * red.curvature[a][al, be] for a in range(k))
        for i in range(m):
            for be in range(sig):
                e = sum(mu[a] * red.F[a][i, be] for a in range(k))
                J[2 * sig + i, sig + be], J[sig + be, 2 * sig + i] = e, -e
            for j in range(m):
                J[2 * sig + i, 2 * sig + j] = -sum(
                    mu[a] * C[a][b][d] * E[b, i] * E[d, j] for a in range(k) for b in range(k) for d in range(k)
                )
        return sp.ImmutableMatrix(J)

    @shared_property
    def equations(self) -> sp.ImmutableMatrix:
        r"""Theorem 1.1: :math:`(\dot r, \dot{\tilde p}_r, \dot p) = J_{\bar{\mathcal M}}\nabla h` (add :math:`\tau` to
        :math:`\dot{\tilde p}_r` for shape forces)."""
        gh = sp.Matrix([derivative(self.hamiltonian, v) for v in self.z])
        return sp.ImmutableMatrix(sp.Matrix(self.tensor) * gh)

    @shared_property
    def reconstruction(self) -> sp.ImmutableMatrix:
        r""":math:`\xi = -\mathcal A\,\partial h/\partial\tilde p_r + e\,\partial h/\partial p` (the seed prints
        :math:`\dot\xi`)."""
        red = self.reduction
        gr = sp.Matrix(len(self.ptr), 1, [derivative(self.hamiltonian, a) for a in self.ptr])
        gp = sp.Matrix(red.m, 1, [derivative(self.hamiltonian, p) for p in red.p])
        return sp.ImmutableMatrix(-sp.Matrix(red.connection) * gr + sp.Matrix(red.basis) * gp)

    # ---------------- Theorem 1.2 ----------------
    @shared_property
    def constrained_lagrangian(self) -> sp.Expr:
        r""":math:`l_c(r, \dot r, \Omega) = l(r, \dot r, -\mathcal A\dot r + \Omega^i e_i)`."""
        # l = xi^T I_loc xi / 2 + xi^T Gamma rdot + rdot^T m_rr rdot / 2 - V with xi = -A rdot + e Omega: the blocks
        # are the shape mass M, the locked inertia e^T I_loc e and the cross block e^T (Gamma - I_loc A), which the
        # nonholonomic connection makes zero (horizontal is kinetic-orthogonal to S), formed and simplified here
        red = self.reduction
        cross = simplify_matrix(sp.Matrix(red.basis).T * sp.Matrix(red._mu_parts[0]))  # (m, sigma)
        M, I = sp.Matrix(red.shape_mass), sp.Matrix(red.locked_inertia)
        Q = sp.Matrix.vstack(sp.Matrix.hstack(M, cross.T), sp.Matrix.hstack(cross, I))
        return half_quadratic(Q, list(red.rdot) + list(self.omega)) - red.potential

    def legendre(self) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
        r"""The reduced Legendre transform :math:`\tilde p_r = \partial l_c/\partial\dot r`,
        :math:`p = \partial l_c/\partial\Omega` (in ``(r, rdot, Omega)``)."""
        lc, red = self.constrained_lagrangian, self.reduction
        return (
            simplify_matrix(sp.Matrix(len(red.rdot), 1, [derivative(lc, v) for v in red.rdot])),
            simplify_matrix(sp.Matrix(len(self.omega), 1, [derivative(lc, w) for w in self.omega])),
        )

    def lagrangian_form(self) -> sp.Matrix:
        r"""Theorem 1.1 carried to :math:`(r, \dot r, p)` by the Legendre transform :math:`\tilde p_r = M\dot r`, minus
        the Lagrangian reduced equations: :math:`\dot p_i^{(1.1)} - \dot p_i^{(1.2)}` and
        :math:`\dot M\dot r + \delta - \dot{\tilde p}_r^{(1.1)}` (i.e. :math:`d(M\dot r)/dt` with
        :math:`M\ddot r = \delta`, eq. 1.3). Identically zero when the two reductions agree (Theorem 1.2)."""
        red = self.reduction
        sig = len(red.r)
        rd = sp.Matrix(sig, 1, list(red.rdot))
        M = sp.Matrix(red.shape_mass)
        eq = sp.Matrix(self.equations).xreplace(dict(zip(self.ptr, M * rd)))
        Mdot = sum((derivative(M, r) * v for r, v in zip(red.r, red.rdot)), sp.zeros(sig, sig))
        out = [eq[2 * sig + i] - red.momentum_rhs[i] for i in range(red.m)]
        out += [(Mdot * rd)[al] + red.shape_forces[al] - eq[sig + al] for al in range(sig)]
        return sp.Matrix(len(out), 1, out)

    def _latex_names(self) -> dict:
        names = dict(self.system.latex_names)
        for r, a in zip(self.reduction.r, self.ptr):
            names[a] = rf"\tilde p_{{{sp.latex(r)}}}"
        for i, w in enumerate(self.omega):
            names[w] = rf"\Omega^{{{i + 1}}}"
        return names

    def items(self):
        red = self.reduction
        return [
            ("coordinates", "z", self.z),
            ("reduced Hamiltonian h", "h", self.hamiltonian),
            ("C (structure constants)", "C^a_{bd}", [sp.Matrix(c) for c in self.system.group.structure_constants]),
            ("F", "F^a_{i\\beta}", list(red.F)),
            ("B (curvature of A_nh)", "B^a_{\\alpha\\beta}", list(red.curvature)),
            ("reduced tensor", r"J_{\bar{\mathcal M}}", self.tensor),
            ("Hamilton equations (Thm 1.1)", r"\dot z", self.equations),
            ("reconstruction", r"\xi", self.reconstruction),
            ("constrained Lagrangian l_c (Thm 1.2)", "l_c", self.constrained_lagrangian),
            ("Legendre transform", r"(\tilde p_r, p)", list(self.legendre())),
        ]

    def numeric(self, parameters: dict | None = None) -> dict:
        gh = sp.Matrix([derivative(self.hamiltonian, v) for v in self.z])
        return self._compile(parameters, {"J": self.tensor, "gradh": gh, "zdot": self.equations}, self.z)


def poisson_reduction(system: NonholonomicSystem, basis: Any = None) -> PoissonReduction:
    """Theorems 1.1-1.2 for ``system`` (with the body-fixed basis of :func:`bkmm_reduction`), cached."""
    reduction = bkmm_reduction(system, basis)
    ptr = tuple(sp.Symbol(f"pt_{r.name}", real=True) for r in reduction.r)
    omega = tuple(sp.Symbol(f"Omega{i + 1}", real=True) for i in range(reduction.m))
    return PoissonReduction(reduction, ptr, omega)
