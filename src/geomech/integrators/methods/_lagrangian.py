"""Methods for a Lagrangian system on Q = G x S with linear velocity constraints (a
:class:`~geomech.systems.NonholonomicSystem`; no constraints: holonomic): the Lagrange-d'Alembert equations
with multipliers, the reduced BKMM equations, Hamilton's equations on the constraint momentum submanifold in
three forms, and the discrete Lagrange-d'Alembert integrator with two discrete Lagrangians.

References: [KM] Koon & Marsden, The geometric structure of nonholonomic mechanics (the second seed), eqs.
(1.1)-(1.3) and section 1; [BKMM] Bloch, Krishnaprasad, Marsden & Murray, ARMA 136 (1996); [VM] van der Schaft &
Maschke, Rep. Math. Phys. 34 (1994); [BS] Bates & Sniatycki, Rep. Math. Phys. 32 (1993); [CM] Cortes & Martinez,
Nonlinearity 14 (2001) (discrete Lagrange-d'Alembert); [BRM] Bou-Rabee & Marsden, Found. Comput. Math. 9 (2009)
(the discrete Lagrangian on a Lie group through the exponential); [HNW] II.5 (DOP853).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from ...errors import InputError
from ._base import Method, Structure
from ._embedded import taylor_order
from ._general import ScipyStepped


@dataclass(frozen=True)
class LagrangeDAlembert(ScipyStepped):
    """The Lagrange-d'Alembert equations with multipliers in coordinates, solved by an embedded Runge-Kutta pair.

    The index-reduced DAE :math:`M\\ddot q - A^T\\lambda = f`, :math:`A\\ddot q + \\dot A\\dot q = 0`, solved
    at each evaluation for the accelerations of the free coordinates, the multipliers and the forces that
    realise prescribed shapes; optionally stabilised, :math:`A\\ddot q + \\dot A\\dot q + 2\\alpha A\\dot q = 0`.
    Kind: adaptive (``rtol``, ``atol``; default 1e-10, 1e-12). Order: that of ``solver`` (DOP853: 8).
    Not structure-preserving: the constraint residual and the energy drift at the tolerance. Structure: a
    Lagrangian system on G x S with constraints. Cost per evaluation: one dense solve of size
    (free coordinates + constraints) with the mass matrix, the constraint matrix and its derivative evaluated; as
    many evaluations as the tolerances require. With ``solver`` "DOP853" or "RK45" and the gait and torques given
    as formulas the equations are compiled (straight-line code for the system's sizes, the solve an elimination
    with partial pivoting in the same function, the parameters and ``baumgarte`` read at run time) and stepped by
    the compiled Dormand-Prince pairs of the same error control; otherwise, or with ``backend="python"``, they are
    evaluated in Python and stepped by scipy. Reference: [KM] section 1; [HNW] II.5.

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


#: The ``solver`` of :class:`BKMM` that is Taylor's method (compiled only).
TAYLOR = "taylor"


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
    With ``solver="taylor"`` (compiled only) they are stepped by Taylor's method: the Taylor coefficients of the
    solution generated from the reduction's closed forms (reconstruction, momentum equation, shape mass and forces)
    by the recurrences of their elementary operations, the order ``ceil(-ln(eps) / 2) + 1`` (4 to 40) from the
    smaller tolerance eps (15 at 1e-12), the step from the last two coefficients (Jorba & Zou), the saved states
    and the events by the step's polynomial: a few dozen steps where DOP853 takes hundreds, for smooth motions at
    tight tolerances; its coefficients' code unrolled for the order as :class:`~geomech.integrators.Taylor`'s.
    Reference: [KM] eqs. (1.1)-(1.3); [BKMM]; [JZ] Jorba & Zou, Experiment. Math. 14 (2005).

    Parameters
    ----------
    solver : {"DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA", "taylor"}
    work : bool
        Integrate the work of the shape forces with the state (default): the quantity ``work``, which checks the
        energy balance :math:`E(t) - E(t_0) = W(t)` of ideal constraints. False leaves it out (its derivative is
        zero, and the Solution has no ``work``; the shape forces ``tau`` are still observed at the saved times):
        the equations then need the shape forces only to move free shapes, so a system whose shapes are all
        prescribed integrates its group motion and momentum alone, as a peer solver given those equations
        would (the snakeboard's Taylor pass: 26 products, quotients and functions instead of 34).
    """

    work: bool = True
    structure: ClassVar[Structure] = Structure.LAGRANGIAN

    def __post_init__(self) -> None:
        if not isinstance(self.work, bool):
            raise InputError(f"Expected BKMM's `work` to be True or False, got {self.work!r}.")
        if self.solver != TAYLOR:
            super().__post_init__()

    @property
    def explicit(self) -> bool:  # type: ignore[override]
        return self.solver == TAYLOR or super().explicit

    @property
    def order(self) -> int:
        # Taylor's: that of the tolerances, fixed along a run (at the defaults here)
        return taylor_order(self.default_tolerances) if self.solver == TAYLOR else super().order

    @property
    def key(self) -> str:
        return "bkmm"


#: The forms of :class:`NonholonomicHamilton`, with their keys in the registry.
HAMILTON_FORMS = {
    "almost_poisson": "almost_poisson",
    "bates_sniatycki": "bates_sniatycki",
    "full": "full_almost_poisson",
}

#: The discrete Lagrangians of :class:`DiscreteLagrangeDAlembert`, with their keys in the registry.
DISCRETIZATIONS = {"midpoint": "discrete_lagrange_dalembert", "group": "discrete_lagrange_dalembert_group"}


@dataclass(frozen=True)
class NonholonomicHamilton(ScipyStepped):
    """Hamilton's equations on the constraint momentum submanifold, in one of three forms, solved by scipy.

    The state is :math:`z = (q, \\tilde p)`, :math:`\\tilde p_\\alpha = \\langle p, X_\\alpha\\rangle` the momenta along
    a basis :math:`X` of the constraint distribution :math:`\\mathcal D` (``basis``: "bkmm", the BKMM-adapted one,
    or "nullspace"), and :math:`H_{\\mathcal M}` the Hamiltonian on :math:`\\mathcal M = \\mathbb FL(\\mathcal D)`.
    ``form`` says which vector field is integrated ([KM] section 1):

    * "almost_poisson": :math:`\\dot z = J_{\\mathcal M}\\nabla H_{\\mathcal M}`, van der Schaft and Maschke's truncated
      bracket (:func:`~geomech.reduction.almost_poisson`);
    * "bates_sniatycki": the section of :math:`\\mathcal H` with :math:`\\omega_{\\mathcal M}(Z, \\cdot) =
      dH_{\\mathcal M}` on :math:`\\mathcal H`, the canonical form restricted to the constraint distribution
      (:func:`~geomech.reduction.bates_sniatycki`); no Lie bracket of the basis enters;
    * "full": the full tensor on :math:`T^*Q` in coordinates :math:`(q, \\tilde p_\\alpha, \\tilde p_a)` with a
      kinetic-orthogonal complement, the multiplier solved at each evaluation so that
      :math:`\\partial\\tilde H/\\partial\\tilde p_a` stays zero (:func:`~geomech.reduction.full_almost_poisson`);
      the state leaves :math:`\\mathcal M` only by the solver's error, which the constraint residual shows.

    The three are the Lagrange-d'Alembert flow; torques on the free shapes act as the force :math:`(0, \\tau)`.
    Prescribed shapes (a gait) are a time-dependent constraint outside these forms: use :class:`BKMM` or
    :class:`LagrangeDAlembert`. Kind: adaptive (``rtol``, ``atol``; default 1e-10, 1e-12). Order: that of
    ``solver``. Not structure-preserving. Structure: a Lagrangian system on G x S with constraints. Cost per
    evaluation: the compiled tensor (or forms) and one small dense solve; as many evaluations as the tolerances
    require (Python, not compiled). Reference: [KM] section 1; [VM]; [BS].

    Parameters
    ----------
    solver : {"DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA"}
    form : {"almost_poisson", "bates_sniatycki", "full"}
    basis : {"bkmm", "nullspace"}
    """

    form: str = "almost_poisson"
    basis: str = "bkmm"
    structure: ClassVar[Structure] = Structure.LAGRANGIAN

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.form not in HAMILTON_FORMS:
            raise InputError(f"Expected `form` to be one of {sorted(HAMILTON_FORMS)}, got {self.form!r}.")
        if self.basis not in ("bkmm", "nullspace"):
            raise InputError(f"Expected `basis` to be 'bkmm' or 'nullspace', got {self.basis!r}.")

    @property
    def key(self) -> str:
        return HAMILTON_FORMS[self.form]

    @property
    def summary(self) -> str:
        return {
            "almost_poisson": "Hamilton's equations on FL(D) by van der Schaft and Maschke's almost-Poisson tensor",
            "bates_sniatycki": "Hamilton's equations on FL(D) by the symplectic form restricted to H (Bates-Sniatycki)",
            "full": "Hamilton's equations on T*Q by the full tensor with its multiplier, which keeps them on FL(D)",
        }[self.form] + ", solved by scipy"


@dataclass(frozen=True)
class DiscreteLagrangeDAlembert(Method):
    """The discrete Lagrange-d'Alembert integrator, with the midpoint or the group discrete Lagrangian.

    The discrete equations :math:`D_2L_d(q_{k-1}, q_k) + D_1L_d(q_k, q_{k+1}) = A^T(q_k)\\lambda_k` with a discrete
    constraint, solved by Newton (``newton_tol``, ``max_newton``), for one of two discrete Lagrangians
    (``discretization``):

    * "midpoint": :math:`L_d(q_k, q_{k+1}) = h L\\bigl(\\tfrac{q_k + q_{k+1}}2, \\tfrac{q_{k+1} - q_k}h\\bigr)` in
      the coordinates, the constraint :math:`A(\\bar q)(q_{k+1} - q_k) = 0` at the midpoint [CM]. Not invariant
      under the group where the chart is not (Euler angles on SO(3)): the discrete momentum map drifts at
      :math:`O(h^2)` (Remark 10 of the Serret-Andoyer seed);
    * "group": :math:`L_d = h\\,\\ell\\bigl(\\bar r, \\tfrac1h\\log(g_k^{-1}g_{k+1}),
      \\tfrac{r_{k+1} - r_k}h\\bigr)` with :math:`\\ell` the reduced Lagrangian and the group's exponential [BRM],
      the constraint in the body frame,
      :math:`A_{\\rm body}(\\bar r)(\\log(g_k^{-1}g_{k+1}), r_{k+1} - r_k) = 0`. Invariant under the group in any
      chart (Euler angles included): without constraints the discrete momentum map
      :math:`\\mathrm{Ad}^*_{g_k^{-1}}\\,dexp^{-T}\\ell_\\xi` is conserved to the Newton tolerance (discrete Noether).

    The velocity reported at a node is the discrete Legendre transform projected on the constraint distribution.
    Kind: fixed step. Order 2; implicit; symmetric; not symplectic (a nonholonomic flow is not; without
    constraints both are variational, hence symplectic). Structure: a Lagrangian system on G x S with
    constraints. Cost per step: Newton on (free coordinates + constraints) unknowns, each iteration the first and
    second derivatives of L and the constraint matrix (midpoint), or the reduced Lagrangian's first derivatives and
    the group's log and Jacobians with a difference Jacobian (group). Both maps run compiled where the gait and
    torques are formulas (the whole run, Newton included, in one numba call: the Python engine's steps, hundreds of
    times faster), the group's on SO(2), R^n, SE(2), SO(3), SE(3) and their products (a general
    :class:`~geomech.lie.MatrixGroup`, whose logarithm is ``logm``, and ``backend="python"`` run in Python).
    Reference: [CM]; [MW]; [BRM].

    Parameters
    ----------
    discretization : {"midpoint", "group"}
    """

    discretization: str = "midpoint"
    structure: ClassVar[Structure] = Structure.LAGRANGIAN
    symmetric: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if self.discretization not in DISCRETIZATIONS:
            raise InputError(
                f"Expected `discretization` to be one of {sorted(DISCRETIZATIONS)}, got {self.discretization!r}."
            )

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return DISCRETIZATIONS[self.discretization]

    @property
    def summary(self) -> str:
        return {
            "midpoint": "The discrete Lagrange-d'Alembert integrator with the midpoint discrete Lagrangian",
            "group": "The discrete Lagrange-d'Alembert integrator with the group's discrete Lagrangian, invariant in "
            "any chart",
        }[self.discretization]
