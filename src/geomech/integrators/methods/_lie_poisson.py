"""Methods for left-invariant systems on :math:`T^*SO(3)`: Lie-Poisson splitting ([HLW], [Y]), Moser-Veselov
([MV]), Lie-group variational integrators ([LLM]); and the exact propagators of the reduced flow: the
periodic orbit and the quadrature of the Serret-Andoyer paper ([SA])."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ...errors import InputError
from ._base import Kind, Method, Structure
from ._composition import check_composition, composition_weights


@dataclass(frozen=True)
class LiePoissonSplitting(Method):
    """Splitting for Lie-Poisson systems on so(3)* whose Hamiltonian is a sum
    :math:`H = f_1(m_1) + f_2(m_2) + f_3(m_3)` (the free rigid body, the seed's closed loop).

    The flow of :math:`f_i(m_i)` keeps :math:`m_i`, hence :math:`\\omega_i = f_i'(m_i)`, constant: it is the
    exact rotation :math:`m(t) = \\exp(-t\\omega_i \\hat e_i)\\, m`, :math:`R(t) = R \\exp(t\\omega_i \\hat e_i)`.
    ``order=2`` is Strang's symmetric composition
    :math:`\\varphi^{a}_{h/2}\\varphi^{b}_{h/2}\\varphi^{c}_{h}\\varphi^{b}_{h/2}\\varphi^{a}_{h/2}` (the costliest
    part c in the middle, the last sub-flow merged with the next step's first); higher orders compose it
    (``composition``): Yoshida's triple jump or Suzuki's five-fold fractal, recursively (any even order), or
    the optimised compositions ``"s7"``, ``"s9"`` (order 6), ``"s15"``, ``"s17"`` (order 8), ``"s35"`` (order 10)
    of [HLW] V.3.2 (:func:`~geomech.integrators.methods.composition_weights`).

    Order 2, 4, 6, 8 or 10; explicit; Poisson (each sub-flow is a Hamiltonian flow), symmetric; keeps the Casimir
    :math:`|m|` and, with the attitude, the spatial momentum :math:`p = R m` to round-off. Structure:
    Lie-Poisson on so(3)* with a split Hamiltonian (checked symbolically: the mixed second derivatives
    vanish). Cost per step: 4 derivative evaluations and rotations for each Strang step (1 at order 2, 3 or 5
    for the order-4 compositions, J for a table of J steps).
    Reference: [HLW] VII.5.4 (the free rigid body), II.4 and V.3 (compositions); [Y].
    """

    order: int = 2
    composition: str = "yoshida"
    axis_order: tuple[int, int, int] | None = None
    structure: ClassVar[Structure] = Structure.LIE_POISSON_SPLIT
    explicit: ClassVar[bool] = True
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "split_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "split"})

    def __post_init__(self) -> None:
        if self.order != 2:
            check_composition(self.order, self.composition, (2, 4, 6, 8, 10))
        if self.axis_order is not None and sorted(self.axis_order) != [0, 1, 2]:
            raise InputError(f"Expected `axis_order` to be a permutation of (0, 1, 2), got {self.axis_order!r}.")

    @property
    def key(self) -> str:
        return "strang" if self.order == 2 else f"splitting_{self.order}_{self.composition}"

    def sequence(self, axis_order: tuple[int, int, int]) -> list[tuple[int, float]]:
        """One step as (axis, fraction of h) sub-flows, adjacent flows about one axis merged."""
        a, b, c = self.axis_order or axis_order
        strang = [(a, 0.5), (b, 0.5), (c, 1.0), (b, 0.5), (a, 0.5)]
        seq: list[tuple[int, float]] = []
        for g in composition_weights(self.order, self.composition):
            for axis, frac in strang:
                if seq and seq[-1][0] == axis:
                    seq[-1] = (axis, seq[-1][1] + g * frac)
                else:
                    seq.append((axis, g * frac))
        return seq

    def constants(self, problem: Any) -> np.ndarray:
        seq = self.sequence(problem.split_axis_order)
        return np.array([len(seq)] + [a for a, _ in seq] + [f for _, f in seq], dtype=float)


@dataclass(frozen=True)
class MoserVeselov(Method):
    """The discrete Moser-Veselov rigid body, for the free body :math:`H = \\tfrac12 m\\cdot\\mathbb I^{-1}m`.

    Discrete Lagrangian :math:`L_d(R_k, R_{k+1}) = \\operatorname{tr}\\bigl((I - F_k) J_d\\bigr)/h` with
    :math:`F_k = R_k^T R_{k+1}` and :math:`J_d = \\tfrac12\\operatorname{tr}(\\mathbb I) I - \\mathbb I`; its
    discrete Euler-Lagrange equations :math:`h\\hat m_k = F_k J_d - J_d F_k^T`, :math:`m_{k+1} = F_k^T m_k`,
    :math:`R_{k+1} = R_k F_k` are solved for the Cayley vector of :math:`F_k` by Newton.

    Order 2; a symplectic (variational) map on T*SO(3), a Poisson map on so(3)*; keeps :math:`|m|` and
    :math:`p = R m` to round-off. Structure: Lie-Poisson on so(3)* with a quadratic Hamiltonian (any
    positive definite inertia tensor, principal axes or not). Cost per step: Newton on 3 unknowns
    (polynomial equations, no derivative evaluations). Reference: [MV]; [LLM] (the Cayley form).
    """

    structure: ClassVar[Structure] = Structure.LIE_POISSON_QUADRATIC
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "mv_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs"})

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return "moser_veselov"

    def constants(self, problem: Any) -> np.ndarray:
        return np.asarray(problem.inertia_tensor, dtype=float).ravel()


@dataclass(frozen=True)
class LieGroupVariational(Method):
    """Lie-group variational integrator on SO(3) for any hyperregular left-invariant system
    (the discrete Euler-Lagrange equations of Remark 10 of [SA]).

    With :math:`\\ell(\\omega) = m\\cdot\\omega - H(m)`, :math:`m = (\\nabla H)^{-1}(\\omega)` (the Legendre
    transform of H, which needs H hyperregular), and a local diffeomorphism :math:`\\tau` of so(3) onto
    SO(3) with :math:`\\tau(-X) = \\tau(X)^{-1}` (``parametrization="cayley"`` or ``"exp"``), the discrete
    Lagrangian is :math:`L_d(R_k, R_{k+1}) = h\\,\\ell\\bigl(\\tau^{-1}(R_k^T R_{k+1})/h\\bigr)`. Its discrete
    Euler-Lagrange equations, with :math:`F^{-1}\\delta F = J_\\tau(X)\\,\\delta X` the right-trivialised
    tangent of :math:`\\tau`, read in momentum form

    .. math::

        X_k = h\\,\\nabla H\\bigl(J_\\tau(X_k)\\, m_k\\bigr), \\quad F_k = \\tau(X_k), \\quad
        R_{k+1} = R_k F_k, \\quad m_{k+1} = F_k^T m_k,

    (:math:`J_\\tau(X) m_k = \\nabla\\ell(X_k/h)` is the momentum of the step), solved by Newton on so(3)
    with the exact Hessian of H, so no inner inverse Legendre transform is needed. The discrete momentum
    map :math:`p_k = R_k m_k` is conserved exactly (discrete Noether theorem, [MW] 1.3.3) and :math:`|m|`
    too. For Cayley, :math:`J_\\tau(X) = (I - \\hat X/2)/(1 + |X|^2/4)`; for exp it is the right
    Jacobian of SO(3).

    Order 2; symplectic (variational), symmetric. Structure: Lie group SO(3) with a hyperregular
    Lagrangian. Cost per step: Newton on 3 unknowns, each one gradient and Hessian of H.
    Reference: [MW]; [LLM]; Bou-Rabee & Marsden, Found. Comput. Math. 9 (2009).
    """

    parametrization: str = "cayley"
    structure: ClassVar[Structure] = Structure.LIE_GROUP
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "lgvi_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "ghess3"})

    def __post_init__(self) -> None:
        if self.parametrization not in ("cayley", "exp"):
            raise InputError(f"Expected `parametrization` to be 'cayley' or 'exp', got {self.parametrization!r}.")

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return "lgvi" if self.parametrization == "cayley" else "lgvi_exp"

    def constants(self, problem: Any) -> np.ndarray:
        return np.array([0.0 if self.parametrization == "cayley" else 1.0])


@dataclass(frozen=True)
class CrouchGrossman(Method):
    r"""Crouch-Grossman method of order 3 on the coadjoint orbit and SO(3): explicit, in products of rotations.

    The Lie-Poisson equations read :math:`\dot m = -\hat w\, m`, :math:`\dot R = R\,\hat w` with
    :math:`w = \nabla H(m)`: the group SO(3) acts on the sphere :math:`|m| = \text{const}` (the coadjoint orbit)
    and on the attitude. A Crouch-Grossman method ([CG]; [OM]) replaces the sums of a Runge-Kutta method by
    products of exponentials of the frozen velocities: the stages
    :math:`Y_i = \exp(h a_{i,i-1}\hat w_{i-1})^T\cdots\exp(h a_{i1}\hat w_1)^T m_n`, :math:`w_i =
    \nabla H(Y_i)`, and the step :math:`F = \exp(h b_1 \hat w_1)\cdots\exp(h b_s\hat w_s)`,
    :math:`m_{n+1} = F^T m_n`, :math:`R_{n+1} = R_n F`. It stays on the level set of the Casimir :math:`|m|` and
    in SO(3) to round-off, and keeps the spatial momentum :math:`R m` (each factor does), where a Runge-Kutta method
    drifts off them: the embedding of the momentum's level set that section 8 of [SA] names as an alternative.
    The coefficients are Crouch and Grossman's three-stage method (c = (0, 3/4, 17/24), b = (13/51, -2/3,
    24/17)), which meets the four classical conditions of order 3 and the one more that non-commuting
    exponentials impose (:math:`\sum_i b_i^2 c_i + 2\sum_{i<j} b_i c_i b_j = 1/3`).

    Order 3; explicit; neither symplectic nor symmetric (the energy drifts). Structure: Lie-Poisson on so(3)*,
    any H. Cost per step: 3 gradients of H and 6 rotations. Reference: [CG] Crouch & Grossman, Numerical
    integration of ordinary differential equations on manifolds, J. Nonlinear Sci. 3 (1993); [OM] Owren &
    Marthinsen, Runge-Kutta methods adapted to manifolds and based on rigid frames, BIT 39 (1999).
    """

    structure: ClassVar[Structure] = Structure.LIE_POISSON
    explicit: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "cg_run"
    features: ClassVar[frozenset[str]] = frozenset({"ghess3"})

    @property
    def order(self) -> int:
        return 3

    @property
    def key(self) -> str:
        return "crouch_grossman"

    def constants(self, problem: Any) -> np.ndarray:
        A = np.zeros((3, 3))
        A[1, 0] = 3.0 / 4.0
        A[2, 0], A[2, 1] = 119.0 / 216.0, 17.0 / 108.0
        b = np.array([13.0 / 51.0, -2.0 / 3.0, 24.0 / 17.0])
        return np.concatenate([[3.0], A.ravel(), b])


@dataclass(frozen=True)
class SerretAndoyerAtlas(Method):
    r"""The reduced Serret-Andoyer flow on an atlas of three charts, with the reconstruction of the attitude.

    In the chart about a body axis the state is the canonical pair :math:`(l, L)` of eq. (20) with the
    reconstruction angle :math:`\varphi` of Theorem 3, integrated by Dormand-Prince 8(5,3) with error
    control; where :math:`|L|/G` reaches ``switch_at`` (the chart's pole is :math:`|L| = G`) the run
    switches, at the event, to the chart about the body axis with the smallest :math:`|m_k|`. The momentum
    stays on its sphere :math:`|m| = G` exactly (the Casimir is kept to round-off) and :math:`p = R m` to
    the tolerance. Kind: adaptive (``rtol``, ``atol``; default 1e-12, 1e-12, ``atol`` relative to G).
    Order 8. Structure: Lie-Poisson on so(3)* with any left-invariant Hamiltonian (given by a formula or a
    callable: only its gradient is used). Cost: as many evaluations as the tolerances require, each one
    gradient of H (Python, not compiled). Reference: [SA] sections 5 and 8 (eqs. 20, 21, Theorem 3).

    Parameters
    ----------
    switch_at : float
        The value of :math:`|L|/G` in (0.6, 1) where a chart is left (default 0.9).
    axis : {1, 2, 3} or None
        The first chart's body axis (1-based); default axis 3 (the seed's) unless :math:`|m_3|` is near G.
    """

    switch_at: float = 0.9
    axis: int | None = None
    structure: ClassVar[Structure] = Structure.LIE_POISSON
    kind: ClassVar[Kind] = Kind.ADAPTIVE
    default_tolerances: ClassVar[tuple[float, float]] = (1e-12, 1e-12)
    explicit: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if isinstance(self.switch_at, bool) or not isinstance(self.switch_at, (int, float)):
            raise InputError(f"Expected `switch_at` to be a number in (0.6, 1), got {self.switch_at!r}.")
        if not 0.6 < self.switch_at < 1.0:
            raise InputError(f"Expected `switch_at` in (0.6, 1), got {self.switch_at}; 0.9 is a good value.")
        if self.axis is not None and self.axis not in (1, 2, 3):
            raise InputError(f"Expected `axis` to be 1, 2 or 3 (a body axis) or None, got {self.axis!r}.")

    @property
    def order(self) -> int:
        return 8

    @property
    def key(self) -> str:
        return "serret_andoyer_atlas"


@dataclass(frozen=True)
class PeriodicOrbit(Method):
    """Exact propagation of a one-degree-of-freedom orbit by its period: the state at any time from one period.

    Every bounded orbit of a 1-dof Hamiltonian that is not an equilibrium or a separatrix is periodic, so
    the state at t is the state at t mod T: one period is integrated (Dormand-Prince 8(5,3) with error
    control, compiled), its end located on the section through y0 by Newton, and each output is one
    Runge-Kutta step from the stored mesh point before it (:class:`~geomech.integrators.PeriodicOrbitPropagator`).
    Kind: exact propagator (no steps in t; the states are given at ``saveat``); the period is integrated to
    order 8 with error control, and the error does not grow with t beyond ``t * period_error / T``. Not
    symplectic, but the energy error is that of one period, bounded for all t. Structure: canonical with
    n = 1. Cost per trajectory: about (0.1 ms + compile once) for the period,
    then one step per output, independent of t. A separatrix, an equilibrium that the period cannot resolve
    or an orbit that leaves ``L_bounds`` is a failure (``not_periodic``) with the reason in the message.
    Reference: [HNW] II.10 (DOP853); eq. (11) of the Serret-Andoyer paper (periodicity).

    Parameters
    ----------
    tol : float
        Local error tolerance of the period's integration (in [1e-15, 1e-6]).
    L_bounds : (p_min, p_max), optional
        The open interval of ``p`` where ``H`` is defined (``(-G, G)`` for a Serret-Andoyer chart).
    """

    tol: float = 1e-14
    L_bounds: tuple[float, float] | None = None
    structure: ClassVar[Structure] = Structure.ONE_DOF
    kind: ClassVar[Kind] = Kind.EXACT
    explicit: ClassVar[bool | None] = None

    def __post_init__(self) -> None:
        if not (isinstance(self.tol, (int, float)) and 1e-15 <= self.tol <= 1e-6):
            raise InputError(f"Expected `tol` in [1e-15, 1e-6], got {self.tol!r}.")
        object.__setattr__(self, "L_bounds", _bounds(self.L_bounds))

    @property
    def order(self) -> None:
        return None

    @property
    def key(self) -> str:
        return "periodic_orbit"


@dataclass(frozen=True)
class Quadrature(Method):
    """Exact propagation of a one-degree-of-freedom orbit by quadrature (equation (11) of [SA], for any H).

    The period is the integral :math:`T = \\oint dq / (\\partial H/\\partial p)` along the level curve of
    :math:`H(y_0)`, the state at t is found from the time-of-flight integral at ``t mod T`` and periodicity
    (:class:`~geomech.integrators.QuadraturePropagator`): no time stepping, so the cost does not grow with
    t and the energy error is that of the level curve, bounded for all t. Kind: exact propagator (the states
    are given at ``saveat``); no order (exact up to ``tol``; ``order`` is None). Structure: canonical with n = 1.
    Cost per trajectory: tracing the level curve and building Chebyshev tables (tens of ms), then a table
    look-up per output. A separatrix, an equilibrium or a level curve that leaves ``L_bounds`` is a failure
    (``not_periodic``) with the reason in the message. Reference: eq. (11) of the Serret-Andoyer paper.

    Parameters
    ----------
    tol : float
        Relative accuracy of the period and the state (in [1e-15, 1e-3]).
    L_bounds : (p_min, p_max), optional
        The open interval of ``p`` where ``H`` is defined (``(-G, G)`` for a Serret-Andoyer chart).
    """

    tol: float = 1e-12
    L_bounds: tuple[float, float] | None = None
    structure: ClassVar[Structure] = Structure.ONE_DOF
    kind: ClassVar[Kind] = Kind.EXACT
    explicit: ClassVar[bool | None] = None

    def __post_init__(self) -> None:
        if not (isinstance(self.tol, (int, float)) and 1e-15 <= self.tol <= 1e-3):
            raise InputError(f"Expected `tol` in [1e-15, 1e-3], got {self.tol!r}.")
        object.__setattr__(self, "L_bounds", _bounds(self.L_bounds))

    @property
    def order(self) -> None:
        return None

    @property
    def key(self) -> str:
        return "quadrature"


def _bounds(L_bounds: Any) -> tuple[float, float] | None:
    if L_bounds is None:
        return None
    try:
        lo, hi = (float(v) for v in L_bounds)
    except (TypeError, ValueError):
        raise InputError(f"Expected `L_bounds` to be a pair (p_min, p_max), got {L_bounds!r}.") from None
    if not lo < hi:
        raise InputError(f"Expected `L_bounds` to be increasing, got {L_bounds!r}.")
    return lo, hi
