r"""The symplectic side of nonholonomic mechanics (Bates and Sniatycki, Rep. Math. Phys. 32 (1993); section 1.1 of
the nonholonomic seed): the dynamics on the constraint momentum submanifold from the restriction of the canonical
symplectic form to the constraint distribution.

On :math:`\mathcal M = \mathbb FL(\mathcal D) \subset T^*Q`, in the induced coordinates :math:`z = (q, \tilde p)`
(:math:`\tilde p_\alpha = X_\alpha\cdot p`, :math:`p = P(q, \tilde p) = \mathbb M X G^{-1}\tilde p` of
:class:`~geomech.reduction.AlmostPoissonStructure`), the pull-back of :math:`\omega = dq^i\wedge dp_i` is

.. math::

    \omega_{\mathcal M} = dq^i\wedge dP_i(q, \tilde p), \qquad
    \Omega_{\mathcal M} = \begin{pmatrix} P_q - P_q^T & P_{\tilde p} \\ -P_{\tilde p}^T & 0\end{pmatrix},

which is presymplectic on :math:`\mathcal M`. The distribution :math:`\mathcal H = \{v \in T\mathcal M : T\tau(v)
\in \mathcal D\}`, spanned by the columns of :math:`B = \mathrm{diag}(X, I)`, carries the restriction
:math:`\omega_{\mathcal H} = B^T\Omega_{\mathcal M}B`, nondegenerate (Bates and Sniatycki: the constrained system is
"almost symplectic" on :math:`\mathcal H`), and the dynamics is the section :math:`Z = Bw` of :math:`\mathcal H`
with :math:`\omega_{\mathcal M}(Z, Y) = dH_{\mathcal M}(Y)` for every :math:`Y \in \mathcal H`:

.. math::

    w = -(B^T\Omega_{\mathcal M}B)^{-1}B^T\nabla H_{\mathcal M}.

No Lie bracket of the basis enters (where the almost-Poisson tensor :math:`J_{\mathcal M}` has
:math:`-\langle p, [X_\alpha, X_\beta]\rangle`), yet the two vector fields are the same, and both are the
Lagrange-d'Alembert flow: the tests hold the three against one another. With the BKMM-adapted basis the field is
:math:`G`-invariant, and its components along :math:`(r, p_i, \tilde p_\alpha)` at any group element are the
reduced equations of Theorem 1.1 (:func:`~geomech.reduction.poisson_reduction`): the reduction of this
almost-symplectic system by the symmetry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from ..symbolic import NumericCache, shared_property
from ..systems.nonholonomic import NonholonomicSystem
from ._derived import Derived
from .almost_poisson import AlmostPoissonStructure, almost_poisson

__all__ = ["BatesSniatycki", "bates_sniatycki"]


@dataclass(frozen=True, eq=False)
class BatesSniatycki(Derived, NumericCache):
    r"""The presymplectic form on :math:`\mathcal M = \mathbb FL(\mathcal D)`, its restriction to the constraint
    distribution :math:`\mathcal H`, and the dynamics it defines (see the module docstring).

    Attributes
    ----------
    structure : AlmostPoissonStructure
        Whose basis :math:`X` of :math:`\mathcal D`, coordinates :math:`(q, \tilde p)`, point :math:`P(q, \tilde p)`
        of :math:`\mathcal M` and Hamiltonian :math:`H_{\mathcal M}` are used.
    """

    structure: AlmostPoissonStructure
    title: str = "Bates-Sniatycki: the constrained dynamics from the symplectic form restricted to H"

    @property
    def system(self) -> NonholonomicSystem:
        return self.structure.system

    @property
    def _cache_key(self) -> tuple:
        return ("bates_sniatycki", self.structure._cache_key)

    @property
    def z(self) -> list[sp.Symbol]:
        return self.structure.z

    @shared_property
    def form(self) -> sp.ImmutableMatrix:
        r""":math:`\Omega_{\mathcal M}`, the matrix of :math:`\omega_{\mathcal M} = dq^i\wedge dP_i` in :math:`(q,
        \tilde p)`: :math:`\omega_{\mathcal M}(u, v) = u^T\Omega_{\mathcal M}v`."""
        s = self.system
        P = sp.Matrix(self.structure.momentum)
        Pq = P.jacobian(list(s.q))
        Pp = P.jacobian(list(self.structure.pt))
        d = len(self.structure.pt)
        return sp.ImmutableMatrix(sp.Matrix(sp.BlockMatrix([[Pq - Pq.T, Pp], [-Pp.T, sp.zeros(d, d)]])))

    @shared_property
    def distribution(self) -> sp.ImmutableMatrix:
        r""":math:`B = \mathrm{diag}(X, I)`, whose columns span :math:`\mathcal H = \{v : T\tau(v) \in \mathcal D\}`."""
        X = sp.Matrix(self.structure.X)
        return sp.ImmutableMatrix(sp.diag(X, sp.eye(X.cols)))

    @shared_property
    def restricted_form(self) -> sp.ImmutableMatrix:
        r""":math:`\omega_{\mathcal H} = B^T\Omega_{\mathcal M}B`, skew and nondegenerate: the almost-symplectic
        structure of the constrained system."""
        B = sp.Matrix(self.distribution)
        return sp.ImmutableMatrix(B.T * sp.Matrix(self.form) * B)

    def _latex_names(self) -> dict:
        return self.structure._latex_names()

    def items(self):
        return [
            ("coordinates z", "z", self.z),
            ("point of M", r"P(q, \tilde p)", self.structure.momentum),
            ("H_M", r"H_{\mathcal M}", self.structure.hamiltonian),
            ("omega_M", r"\Omega_{\mathcal M}", self.form),
            ("basis of H (columns)", "B", self.distribution),
        ]

    def numeric(self, parameters: dict | None = None) -> dict:
        """Compiled ``form(z)``, ``B(z)``, ``gradH(z)``, and ``field(z, force=None)``: the dynamics
        :math:`Z = -B(B^T\\Omega B)^{-1}B^T(\\nabla H_{\\mathcal M} - (F, 0))`, from
        :math:`\\omega_{\\mathcal M}(Z, Y) = dH_{\\mathcal M}(Y) - \\langle F, T\\tau(Y)\\rangle` for every
        :math:`Y \\in \\mathcal H` under a generalised force :math:`F(q)` (shape ``(..., n)``; none: the free
        motion), and ``response(z)``: the free field and ``R`` with ``field(z, F) = free + R F``; vectorised over
        leading axes."""
        H = self.structure.hamiltonian
        out = dict(
            self._compile(
                parameters,
                {
                    "form": self.form,
                    "B": self.distribution,
                    "gradH": sp.Matrix([sp.diff(H, v) for v in self.z]),
                },
                self.z,
            )
        )

        n = self.system.n

        def solved(z: np.ndarray, dH: np.ndarray, response: bool) -> np.ndarray:
            # B (B^T W B)^-1 B^T applied to dH (the field is minus it) and, with `response`, to [I_n; 0] (the force's
            # response) in the same solve
            B, W = out["B"](z), out["form"](z)
            BT = np.swapaxes(B, -1, -2)
            rhs = np.concatenate([BT @ dH, BT[..., :, :n]], axis=-1) if response else BT @ dH
            return B @ np.linalg.solve(BT @ W @ B, rhs)

        def field(z: Any, force: Any = None) -> np.ndarray:
            z = np.asarray(z, dtype=float)
            dH = out["gradH"](z)
            if force is not None:
                dH = dH.copy()
                dH[..., :n, 0] -= np.asarray(force, dtype=float)
            return -solved(z, dH, False)[..., 0]

        def response(z: Any) -> tuple[np.ndarray, np.ndarray]:
            z = np.asarray(z, dtype=float)
            x = solved(z, out["gradH"](z), True)
            return -x[..., 0], x[..., 1:]

        out.update(field=field, response=response)
        return out


def bates_sniatycki(system: NonholonomicSystem, basis: str = "bkmm") -> BatesSniatycki:
    """The Bates-Sniatycki description of ``system`` (:class:`BatesSniatycki`), in the basis of :math:`\\mathcal D`
    of :func:`~geomech.reduction.almost_poisson` (``"bkmm"``: the BKMM-adapted one, or ``"nullspace"``)."""
    if not isinstance(system, NonholonomicSystem):
        raise InputError(f"Expected `system` to be a NonholonomicSystem, got {type(system).__name__}.")
    return BatesSniatycki(almost_poisson(system, basis))
