r"""Van der Schaft and Maschke's tensor before its truncation (section 1.2 of the nonholonomic seed): the canonical
Poisson tensor of :math:`T^*Q` in the coordinates :math:`(q, \tilde p_\alpha, \tilde p_a)` of a basis of the
constraint distribution and a complement, its Hamiltonian, the constraint :math:`\partial\tilde H/\partial\tilde
p_a` and the multiplier term that keeps the motion on :math:`\mathcal M = \mathbb FL(\mathcal D)`. The truncated
tensor :math:`J_{\mathcal M}` is :class:`~geomech.reduction.AlmostPoissonStructure`; on :math:`\mathcal M` the two
give the same motion (:class:`FullAlmostPoisson`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from ..symbolic import NumericCache, inverse, shared_property, simplify_expr, simplify_matrix
from ..symbolic.formula import to_expression
from ..systems.nonholonomic import NonholonomicSystem
from ._derived import Derived
from .almost_poisson import AlmostPoissonStructure, _lie_bracket, almost_poisson
from .lagrange_dalembert import lagrange_dalembert

__all__ = ["FullAlmostPoisson", "full_almost_poisson"]


@dataclass(frozen=True, eq=False)
class FullAlmostPoisson(Derived, NumericCache):
    r"""The canonical Poisson tensor of :math:`T^*Q` in VM's coordinates :math:`(q, \tilde p_\alpha, \tilde p_a)`, and
    the constrained equations with their multiplier term (section 1.2 of the nonholonomic seed, before truncation).

    With :math:`W = [X\,|\,\Omega]` (the basis :math:`X_\alpha` of :math:`\mathcal D`, then a complement
    :math:`\omega_a` with :math:`\langle\omega^b, \omega_a\rangle = (A\Omega)^b_a` invertible), the momenta are
    :math:`\tilde p = W^T p`, so :math:`p = W^{-T}\tilde p` and

    .. math::

        \{q^i, q^j\} = 0, \qquad \{q^i, \tilde p_J\} = W^i_J, \qquad
        \{\tilde p_J, \tilde p_K\} = -\langle p, [W_J, W_K]\rangle, \qquad
        \tilde H = \tfrac12\tilde p^T(W^T\mathbb M W)^{-1}\tilde p + V(q).

    This is a Poisson tensor (the canonical one in other coordinates: it satisfies the Jacobi identity). The
    constrained equations are :math:`\dot z = \tilde J\nabla\tilde H + (0, 0, K\lambda)`, :math:`K = (A\Omega)^T`,
    on :math:`\mathcal M = \{\partial\tilde H/\partial\tilde p_a = 0\}`, where :math:`\partial\tilde H/\partial
    \tilde p_a = (A\Omega)^{-1}A\dot q` is the constraint's value. The multiplier :math:`\lambda` is the one that keeps
    the motion on :math:`\mathcal M` (the Lagrange-d'Alembert multiplier). On :math:`\mathcal M` the
    :math:`(q, \tilde p_\alpha)` components equal the truncated :math:`J_{\mathcal M}\nabla H_{\mathcal M}` for any
    complement; off it the velocity :math:`\dot q = W\,\partial\tilde H/\partial\tilde p` has the extra part
    :math:`\Omega\,\partial\tilde H/\partial\tilde p_a` across :math:`\mathcal D`, which the truncated tensor drops.

    Attributes
    ----------
    structure : AlmostPoissonStructure
        The truncated structure whose basis :math:`X` is used.
    complement : Matrix (n, c)
        :math:`\Omega`; default the kinetic-orthogonal complement :math:`Z` (:math:`AZ = I`, :math:`X^T\mathbb MZ = 0`),
        for which :math:`\mathcal M = \{\tilde p_a = 0\}` and :math:`K = I`.
    pc : tuple of Symbol
        The complement momenta :math:`\tilde p_a`.
    """

    structure: AlmostPoissonStructure
    complement: sp.ImmutableMatrix
    pc: tuple[sp.Symbol, ...]
    orthogonal: bool
    title: str = "full almost-Poisson structure of VM on T*Q (before truncation)"

    @property
    def system(self) -> NonholonomicSystem:
        return self.structure.system

    @property
    def _cache_key(self) -> tuple:
        return (self.structure._cache_key, self.complement)

    @property
    def z(self) -> list[sp.Symbol]:
        r"""Coordinates :math:`(q, \tilde p_\alpha, \tilde p_a)` of :math:`T^*Q`."""
        return self.structure.z + list(self.pc)

    @property
    def W(self) -> sp.Matrix:
        return sp.Matrix.hstack(sp.Matrix(self.structure.X), sp.Matrix(self.complement))

    @shared_property
    def coupling(self) -> sp.ImmutableMatrix:
        r""":math:`K = (A\Omega)^T`, the matrix of the multiplier term."""
        return simplify_matrix((sp.Matrix(self.system.constraint_matrix) * sp.Matrix(self.complement)).T)

    @shared_property
    def W_inverse(self) -> sp.ImmutableMatrix:
        r""":math:`W^{-1}`: rows :math:`G^{-1}X^T\mathbb M(I - \Omega(A\Omega)^{-1}A)` and :math:`(A\Omega)^{-1}A`
        (no n x n inversion: :math:`AX = 0`)."""
        s = self.system
        X, Om, A = sp.Matrix(self.structure.X), sp.Matrix(self.complement), sp.Matrix(s.constraint_matrix)
        AOm_inv = sp.eye(s.c) if self.orthogonal else inverse(sp.Matrix(self.coupling).T)
        top = sp.Matrix(self.structure.metric_inverse) * X.T * sp.Matrix(s.mass_matrix)
        if not self.orthogonal:
            top = top * (sp.eye(s.n) - Om * AOm_inv * A)
        return simplify_matrix(sp.Matrix.vstack(top, AOm_inv * A))

    @shared_property
    def momentum(self) -> sp.ImmutableMatrix:
        r"""The canonical momentum :math:`p = W^{-T}\tilde p` at :math:`(q, \tilde p)`."""
        return sp.ImmutableMatrix(sp.Matrix(self.W_inverse).T * sp.Matrix(list(self.structure.pt) + list(self.pc)))

    @shared_property
    def hamiltonian(self) -> sp.Expr:
        r""":math:`\tilde H = \tfrac12\tilde p^T(W^T\mathbb MW)^{-1}\tilde p + V`; block diagonal,
        :math:`\mathrm{diag}(G^{-1}, (Z^T\mathbb MZ)^{-1})`, for the kinetic-orthogonal complement."""
        s = self.system
        Om = sp.Matrix(self.complement)
        if self.orthogonal:
            inv = sp.diag(
                sp.Matrix(self.structure.metric_inverse),
                inverse(simplify_matrix(Om.T * sp.Matrix(s.mass_matrix) * Om)),
            )
        else:
            inv = inverse(simplify_matrix(self.W.T * sp.Matrix(s.mass_matrix) * self.W))
        pt = sp.Matrix(list(self.structure.pt) + list(self.pc))
        return (pt.T * inv * pt)[0, 0] / 2 + s.potential

    @shared_property
    def tensor(self) -> sp.ImmutableMatrix:
        r""":math:`\tilde J(q, \tilde p)`, 2n x 2n, ordered :math:`(q, \tilde p_\alpha, \tilde p_a)`."""
        s, W = self.system, self.W
        n, q = s.n, list(s.q)
        J = sp.zeros(2 * n, 2 * n)
        J[:n, n:] = W
        J[n:, :n] = -W.T
        p = sp.Matrix(self.momentum)
        for a in range(n):
            for b in range(a + 1, n):
                e = -(p.T * _lie_bracket(W[:, a], W[:, b], q))[0, 0]
                J[n + a, n + b], J[n + b, n + a] = e, -e
        return sp.ImmutableMatrix(J)

    @shared_property
    def constraint(self) -> sp.ImmutableMatrix:
        r""":math:`\partial\tilde H/\partial\tilde p_a`, zero exactly on :math:`\mathcal M` (it is
        :math:`(A\Omega)^{-1}A\dot q`).r"""
        return sp.ImmutableMatrix([sp.diff(self.hamiltonian, v) for v in self.pc])

    def _latex_names(self) -> dict:
        names = self.structure._latex_names()
        d = len(self.structure.pt)
        for a, p in enumerate(self.pc):
            names[p] = rf"\tilde p_{{{d + a + 1}}}"
        return names

    def items(self):
        return [
            ("complement of D (columns)", r"\Omega(q)", self.complement),
            ("coordinates z", "z", self.z),
            ("H~", r"\tilde H", self.hamiltonian),
            ("J~", r"\tilde J", self.tensor),
            ("multiplier coupling K = (A Omega)^T", "K", self.coupling),
            ("constraint dH~/dp~_a", r"\partial\tilde H/\partial\tilde p_a", self.constraint),
        ]

    def numeric(self, parameters: dict | None = None) -> dict:
        """Compiled ``J(z)``, ``gradH(z)``, ``C(z)`` (the constraint), ``gradC(z)`` (its Jacobian), ``K(z)``,
        ``p(z)`` (the canonical momentum), ``W(z)`` and ``pt(q, qdot) = W^T M qdot``, and ``field(z, force=None)``:
        the constrained vector field with its multiplier, and ``multiplier(z, force=None)``, both from the compiled
        pieces. A generalised force :math:`F(q)` (shape ``(..., n)``) adds :math:`W^TF` to the momenta's rates
        (:math:`\\dot p = -\\partial H/\\partial q + F + A^T\\lambda` in canonical coordinates) and enters the
        multiplier; ``response(z)`` gives the free field and ``R`` with ``field(z, F) = free + R F``."""
        z = self.z
        H = self.hamiltonian
        C = sp.Matrix(self.constraint)
        out = dict(
            self._compile(
                parameters,
                {
                    "J": self.tensor,
                    "gradH": sp.Matrix([sp.diff(H, v) for v in z]),
                    "C": C,
                    "gradC": C.jacobian(z),
                    "K": self.coupling,
                    "p": self.momentum,
                    "W": self.W,
                },
                z,
            )
        )
        s = self.system
        pt = self.W.T * sp.Matrix(s.mass_matrix) * sp.Matrix(s.qdot)
        out.update(self._compile(parameters, {"pt": pt}, list(s.q) + list(s.qdot)))
        n, c = s.n, s.c

        def unconstrained(y: Any, force: Any = None) -> np.ndarray:
            y = np.asarray(y, dtype=float)
            f = np.einsum("...ij,...j->...i", out["J"](y), out["gradH"](y)[..., 0])
            if force is not None:
                f[..., n:] += np.einsum("...ia,...i->...a", out["W"](y), np.asarray(force, dtype=float))
            return f

        def solved(y: np.ndarray, free: np.ndarray) -> np.ndarray:
            # d/dt C = gradC . (free + (0, 0, K lam)) = 0, free = J gradH + (0, W^T F)
            gC = out["gradC"](y)
            rhs = np.einsum("...ij,...j->...i", gC, free)
            lhs = gC[..., :, 2 * n - c :] @ out["K"](y)
            return -np.linalg.solve(lhs, rhs[..., None])[..., 0]

        def multiplier(y: Any, force: Any = None) -> np.ndarray:
            y = np.asarray(y, dtype=float)
            return solved(y, unconstrained(y, force))

        def field(y: Any, force: Any = None) -> np.ndarray:
            y = np.asarray(y, dtype=float)
            f = unconstrained(y, force)
            f[..., 2 * n - c :] += np.einsum("...ij,...j->...i", out["K"](y), solved(y, f))
            return f

        def response(y: Any) -> tuple[np.ndarray, np.ndarray]:
            # the constrained field is linear in the unconstrained one, u -> u + (0, K lam(u)): applied to the free
            # field and to the columns (0, W^T e_i) of the force's
            y = np.asarray(y, dtype=float)
            free = unconstrained(y)
            U = np.zeros(free.shape + (n,))
            U[..., n:, :] = np.swapaxes(out["W"](y), -1, -2)
            both = np.concatenate([free[..., None], U], axis=-1)
            gC, K = out["gradC"](y), out["K"](y)
            lam = -np.linalg.solve(gC[..., :, 2 * n - c :] @ K, gC @ both)
            both[..., 2 * n - c :, :] += K @ lam
            return both[..., 0], both[..., 1:]

        out.update(unconstrained=unconstrained, multiplier=multiplier, field=field, response=response)
        return out


def full_almost_poisson(system: NonholonomicSystem, basis: str = "bkmm", complement: Any = None) -> FullAlmostPoisson:
    r"""VM's full tensor on :math:`T^*Q` for ``system`` (:class:`FullAlmostPoisson`), with the basis of
    :math:`\mathcal D` of :func:`almost_poisson` and ``complement`` (n x c, its columns spanning a complement of
    :math:`\mathcal D`; formulas in the coordinates as strings are parsed) or, by default, the kinetic-orthogonal one.
    """
    structure = almost_poisson(system, basis)
    if system.c == 0:
        raise InputError(f"{system.name} has no constraints: its full and truncated tensors are the canonical one.")
    if complement is None:
        Om = sp.Matrix(lagrange_dalembert(system).constraint_complement)
        orthogonal = True
    else:
        names = {v.name: v for v in system.q}
        names.update({p.name: p for p in system.parameter_symbols})
        rows = complement.tolist() if isinstance(complement, (sp.MatrixBase, np.ndarray)) else list(complement)
        try:
            Om = sp.Matrix(
                [
                    [to_expression(e, f"complement[{i}][{j}]", names) for j, e in enumerate(r)]
                    for i, r in enumerate(rows)
                ]
            )
        except TypeError as exc:
            raise InputError(
                f"Expected `complement` to be an n x c matrix (rows of formulas), got {complement!r}."
            ) from exc
        if Om.shape == (system.c, system.n):
            Om = Om.T
        if Om.shape != (system.n, system.c):
            raise InputError(
                f"Expected `complement` to be {system.n} x {system.c} (one column per constraint), got {Om.shape}."
            )
        AOm = simplify_matrix(sp.Matrix(system.constraint_matrix) * Om)
        if simplify_expr(AOm.det()) == 0:
            raise InputError("`complement` does not complement D: A(q) Omega(q) is singular.")
        orthogonal = False
    pc = tuple(sp.Symbol(f"pt{len(structure.pt) + a + 1}", real=True) for a in range(system.c))
    return FullAlmostPoisson(structure, sp.ImmutableMatrix(Om), pc, orthogonal)
