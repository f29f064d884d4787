"""Methods for a Lagrangian system on Q = G x S with linear velocity constraints (a
:class:`~geomech.systems.NonholonomicSystem`; no constraints: holonomic): the Lagrange-d'Alembert equations
with multipliers, the reduced BKMM equations, and the discrete Lagrange-d'Alembert integrator.

References: [KM] Koon & Marsden, The geometric structure of nonholonomic mechanics (the second seed), eqs.
(1.1)-(1.3); [BKMM] Bloch, Krishnaprasad, Marsden & Murray, ARMA 136 (1996); [CM] Cortes & Martinez,
Nonlinearity 14 (2001) (discrete Lagrange-d'Alembert); [HNW] II.5 (DOP853).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from ...errors import InputError
from ._base import Method, Structure
from ._general import ScipyStepped


@dataclass(frozen=True)
class LagrangeDAlembert(ScipyStepped):
    """The Lagrange-d'Alembert equations with multipliers in coordinates, solved by an adaptive scipy solver.

    The index-reduced DAE :math:`M\\ddot q - A^T\\lambda = f`, :math:`A\\ddot q + \\dot A\\dot q = 0`, solved
    at each evaluation for the accelerations of the free coordinates, the multipliers and the forces that
    realise prescribed shapes; optionally stabilised, :math:`A\\ddot q + \\dot A\\dot q + 2\\alpha A\\dot q = 0`.
    Kind: adaptive (``rtol``, ``atol``; default 1e-10, 1e-12). Order: that of ``solver`` (DOP853: 8).
    Not structure-preserving: the constraint residual and the energy drift at the tolerance. Structure: a
    Lagrangian system on G x S with constraints. Cost per evaluation: one dense solve of size
    (free coordinates + constraints + prescribed shapes) with the mass matrix, the constraint matrix and its
    derivative evaluated; as many evaluations as the tolerances require (Python, not compiled).
    Reference: [KM] section 1; [HNW] II.5.

    Parameters
    ----------
    solver : {"DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA"}
    baumgarte : float
        :math:`\\alpha \\ge 0` of the stabilised constraint.
    """

    baumgarte: float = 0.0
    structure: ClassVar[Structure] = Structure.LAGRANGIAN

    def __post_init__(self) -> None:
        super().__post_init__()
        b = self.baumgarte
        if isinstance(b, bool) or not isinstance(b, (int, float)) or not 0 <= b < float("inf"):
            raise InputError(f"Expected `baumgarte` to be a finite number >= 0, got {b!r}.")

    @property
    def key(self) -> str:
        return "lagrange_dalembert"


@dataclass(frozen=True)
class BKMM(ScipyStepped):
    """The reduced equations of Bloch, Krishnaprasad, Marsden and Murray, solved by an embedded Runge-Kutta pair.

    The momentum equation (1.2) for the nonholonomic momentum p, the shape equations (1.3) and the
    reconstruction (1.1) :math:`g^{-1}\\dot g = -A(r)\\dot r + \\Omega(r) p` (in coordinates
    :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi`): the state is (g, free shapes and their rates, p). Kind:
    adaptive (``rtol``, ``atol``; default 1e-10, 1e-12). Order: that of ``solver`` (DOP853: 8). The
    constraints hold by construction. Structure: a Lagrangian system on G x S with constraints. Cost per
    evaluation: the reduced formulas (connection, momentum equation, shape mass matrix) and one solve of the
    size of the shape space; as many evaluations as the tolerances require. With ``solver`` "DOP853" or "RK45"
    and the gait and torques given as formulas the equations are compiled (straight-line code for the system's
    sizes, its parameters read at run time) and stepped by the compiled Dormand-Prince pairs of the same error
    control; otherwise, or with ``backend="python"``, they are evaluated in Python and stepped by scipy.
    Reference: [KM] eqs. (1.1)-(1.3); [BKMM].

    Parameters
    ----------
    solver : {"DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA"}
    """

    structure: ClassVar[Structure] = Structure.LAGRANGIAN

    @property
    def key(self) -> str:
        return "bkmm"


@dataclass(frozen=True)
class DiscreteLagrangeDAlembert(Method):
    """The discrete Lagrange-d'Alembert integrator with the midpoint discrete Lagrangian.

    :math:`L_d(q_k, q_{k+1}) = h L\\bigl(\\tfrac{q_k + q_{k+1}}2, \\tfrac{q_{k+1} - q_k}h\\bigr)`, the discrete
    equations :math:`D_2L_d(q_{k-1}, q_k) + D_1L_d(q_k, q_{k+1}) = A^T(q_k)\\lambda_k` with the constraint
    imposed at the midpoints, solved by Newton (``newton_tol``, ``max_newton``). The velocity reported at
    a node is the discrete Legendre transform projected on the constraint distribution. Kind: fixed step.
    Order 2; implicit; symmetric; not symplectic (a nonholonomic flow is not). Structure: a Lagrangian
    system on G x S with constraints. Cost per step: Newton on (free coordinates + constraints) unknowns,
    each iteration the first and second derivatives of L and the constraint matrix (Python, not compiled).
    Reference: [CM].
    """

    structure: ClassVar[Structure] = Structure.LAGRANGIAN
    symmetric: ClassVar[bool] = True

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return "discrete_lagrange_dalembert"
