"""Integration methods: small immutable values with an order, traits, and the structure they need.

Each method names the structure of system it needs (:class:`Structure`); :func:`~geomech.integrators.solve`
checks it against the system before any work and raises :class:`IncompatibleMethodError`, naming both
and the methods that would work, when they do not fit. :data:`REGISTRY` lists one instance of each
method, for documentation tables and test parametrisation (as GeometricIntegrators.jl does).

References (short keys as in the docstrings):

- [HLW] Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., Springer 2006.
- [HNW] Hairer, Norsett & Wanner, *Solving ODEs I*, 2nd ed., Springer 1993.
- [MV] Moser & Veselov, Discrete versions of some classical integrable systems and factorization of
  matrix polynomials, Comm. Math. Phys. 139 (1991).
- [LLM] Lee, Leok & McClamroch, Lie group variational integrators for the full body problem, Comput.
  Methods Appl. Mech. Engrg. 196 (2007).
- [MW] Marsden & West, Discrete mechanics and variational integrators, Acta Numerica (2001).
- [Y] Yoshida, Construction of higher order symplectic integrators, Phys. Lett. A 150 (1990).
- [SA] the Serret-Andoyer paper (seeds/000), section 8.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import InputError

__all__ = [
    "Structure",
    "IncompatibleMethodError",
    "Method",
    "RK4",
    "AdamsBashforthMoulton4",
    "AdaptiveAdams",
    "SymplecticEuler",
    "StormerVerlet",
    "ImplicitMidpoint",
    "GeneratingFunction",
    "GaussLegendre",
    "LiePoissonSplitting",
    "MoserVeselov",
    "LieGroupVariational",
    "REGISTRY",
    "get_method",
    "methods_table",
]


class Structure(str, enum.Enum):
    """The structure of system a method needs."""

    ODE = "any ODE"
    CANONICAL = "canonical"
    SEPARABLE_CANONICAL = "separable canonical"
    LIE_POISSON_SPLIT = "Lie-Poisson so(3)* with split Hamiltonian"
    LIE_POISSON_QUADRATIC = "Lie-Poisson so(3)* with quadratic Hamiltonian (free rigid body)"
    LIE_GROUP = "Lie group SO(3) hyperregular Lagrangian"
    ONE_DOF = "canonical with one degree of freedom"


class IncompatibleMethodError(InputError):
    """A method was asked to integrate a system that lacks the structure it needs."""


@dataclass(frozen=True)
class Method:
    """Base of every method (abstract). Subclasses set the class-level traits and ``kernel``."""

    structure: ClassVar[Structure]
    explicit: ClassVar[bool] = False
    symplectic: ClassVar[bool] = False
    symmetric: ClassVar[bool] = False
    preserves_casimirs: ClassVar[bool] = False
    needs_expression: ClassVar[bool] = False
    variable_order: ClassVar[bool] = False
    """True when the method changes its order as it goes; ``order`` is then the largest."""
    kernel: ClassVar[str | None] = None
    features: ClassVar[frozenset[str]] = frozenset({"rhs"})
    """Model functions the compiled loop calls."""

    @property
    def order(self) -> int:  # pragma: no cover - every concrete method overrides
        raise NotImplementedError

    @property
    def key(self) -> str:
        """The method's name in :data:`REGISTRY`."""
        return type(self).__name__

    @property
    def implicit(self) -> bool:
        return not self.explicit

    def constants(self, problem: Any) -> np.ndarray:
        """Constants passed to the compiled loop (the ``P`` argument)."""
        return np.zeros(1)

    def describe(self) -> dict[str, Any]:
        """Traits as a JSON-ready dict (one row of :func:`methods_table`)."""
        return {
            "key": self.key,
            "method": repr(self),
            "order": self.order,
            "variable_order": self.variable_order,
            "structure": self.structure.value,
            "explicit": self.explicit,
            "symplectic": self.symplectic,
            "symmetric": self.symmetric,
            "preserves_casimirs": self.preserves_casimirs,
            "summary": (type(self).__doc__ or "").strip().splitlines()[0],
        }


@dataclass(frozen=True)
class RK4(Method):
    """The classical fourth-order Runge-Kutta method.

    Order 4; explicit; not symplectic nor symmetric. Structure: any ODE. Cost per step: 4 evaluations of
    the right-hand side. Reference: [HNW] II.1.
    """

    structure: ClassVar[Structure] = Structure.ODE
    explicit: ClassVar[bool] = True
    kernel: ClassVar[str] = "rk4_run"

    @property
    def order(self) -> int:
        return 4

    @property
    def key(self) -> str:
        return "rk4"


@dataclass(frozen=True)
class AdamsBashforthMoulton4(Method):
    """Fixed-step Adams-Bashforth-Moulton predictor-corrector of order 4 in PECE mode, started by RK4.

    Order 4; explicit (a linear multistep method, so not symplectic). Structure: any ODE. Cost per step:
    2 evaluations of the right-hand side (4 for each of the three starting RK4 steps).
    Reference: [HNW] III.1.
    """

    structure: ClassVar[Structure] = Structure.ODE
    explicit: ClassVar[bool] = True
    kernel: ClassVar[str] = "abm4_run"

    @property
    def order(self) -> int:
        return 4

    @property
    def key(self) -> str:
        return "abm4"


@dataclass(frozen=True)
class AdaptiveAdams(Method):
    """Variable-order, variable-step Adams method with error control, output every ``h``.

    Wraps the well-kept Fortran solvers of scipy: ``solver="vode"`` (VODE in its non-stiff Adams mode,
    orders 1-12; the closest to MATLAB's ``ode113`` that the Serret-Andoyer paper used) or
    ``solver="lsoda"`` (Adams switching to BDF where the problem is stiff). Order: variable, 1 to 12
    (``order`` is the largest); implicit (Adams-Moulton correctors solved by fixed-point iteration, so no
    Jacobian is needed); not structure-preserving. Structure: any ODE. Cost: as
    many evaluations as the tolerances require; runs through Python (not compiled).
    Reference: [HNW] III.7; Brown, Byrne & Hindmarsh, VODE, SIAM J. Sci. Stat. Comput. 10 (1989).

    Parameters
    ----------
    rtol, atol : float
        Relative and absolute tolerances of the local error estimate.
    solver : {"vode", "lsoda"}
    max_steps : int
        Internal steps allowed between two outputs.
    """

    rtol: float = 1e-6
    atol: float = 1e-8
    solver: str = "vode"
    max_steps: int = 100_000
    structure: ClassVar[Structure] = Structure.ODE
    explicit: ClassVar[bool] = False
    variable_order: ClassVar[bool] = True

    def __post_init__(self) -> None:
        for name in ("rtol", "atol"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 < value < 1):
                raise InputError(f"Expected `{name}` in (0, 1), got {value!r}.")
        if self.solver not in ("vode", "lsoda"):
            raise InputError(f"Expected `solver` to be 'vode' or 'lsoda', got {self.solver!r}.")
        if not (isinstance(self.max_steps, int) and self.max_steps > 0):
            raise InputError(f"Expected `max_steps` to be a positive integer, got {self.max_steps!r}.")

    @property
    def order(self) -> int:
        return 12

    @property
    def key(self) -> str:
        return "adams"


@dataclass(frozen=True)
class SymplecticEuler(Method):
    """Symplectic Euler for canonical systems.

    ``variant="A"``: :math:`p_{n+1} = p_n - h H_q(q_n, p_{n+1})`, :math:`q_{n+1} = q_n + h H_p(q_n, p_{n+1})`;
    ``variant="B"`` (its adjoint): :math:`q_{n+1} = q_n + h H_p(q_{n+1}, p_n)`,
    :math:`p_{n+1} = p_n - h H_q(q_{n+1}, p_n)`, generated by :math:`S = q_{n+1} p_n - h H(q_{n+1}, p_n)`.

    Order 1; symplectic; implicit in one half of the variables (explicit when H is separable: Newton then
    stops after one iteration). Structure: canonical. Cost per step: Newton iterations on n unknowns, each
    one gradient and Hessian, plus one gradient. Reference: [HLW] VI.3.
    """

    variant: str = "A"
    structure: ClassVar[Structure] = Structure.CANONICAL
    symplectic: ClassVar[bool] = True
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "grad", "ghess"})

    def __post_init__(self) -> None:
        if self.variant not in ("A", "B"):
            raise InputError(f"Expected `variant` to be 'A' or 'B', got {self.variant!r}.")

    kernel: ClassVar[str] = "symplectic_run"

    def constants(self, problem: Any) -> np.ndarray:
        return np.array([0.0 if self.variant == "A" else 1.0])

    @property
    def order(self) -> int:
        return 1

    @property
    def key(self) -> str:
        return "symplectic_euler" if self.variant == "A" else "symplectic_euler_b"


@dataclass(frozen=True)
class StormerVerlet(Method):
    """Stormer-Verlet (leapfrog) for separable Hamiltonians :math:`H = T(p) + V(q)`.

    :math:`p_{n+1/2} = p_n - \\tfrac h2 V'(q_n)`, :math:`q_{n+1} = q_n + h T'(p_{n+1/2})`,
    :math:`p_{n+1} = p_{n+1/2} - \\tfrac h2 V'(q_{n+1})`.

    Order 2; explicit, symplectic, symmetric. Structure: separable canonical (checked symbolically:
    every :math:`\\partial^2 H/\\partial q_i \\partial p_j` must vanish). Cost per step: 2 gradients.
    Reference: [HLW] I.3, VI.3.
    """

    structure: ClassVar[Structure] = Structure.SEPARABLE_CANONICAL
    explicit: ClassVar[bool] = True
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    kernel: ClassVar[str] = "verlet_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "grad"})

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return "stormer_verlet"


@dataclass(frozen=True)
class ImplicitMidpoint(Method):
    """The implicit midpoint rule :math:`y_{n+1} = y_n + h f\\bigl((y_n + y_{n+1})/2\\bigr)` (method 5 of
    section 8.1 of [SA]).

    Order 2; symplectic (for canonical systems), symmetric, and it preserves every quadratic invariant
    (so the Casimir :math:`|m|^2` of Euler's equations). Structure: any ODE with a Jacobian. Cost per step:
    Newton iterations (usually 2 at small h) on d unknowns, each one evaluation of f and of its exact
    Jacobian and one d x d solve. Reference: [HLW] VI.3, IV.2.
    """

    structure: ClassVar[Structure] = Structure.ODE
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "midpoint_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "fjac"})

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return "implicit_midpoint"


@dataclass(frozen=True)
class GeneratingFunction(Method):
    """The second-order generating-function method of section 8.1 of [SA] (its method 4).

    The step :math:`(q_n, p_n) \\mapsto (q_{n+1}, p_{n+1})` is :math:`q_n = \\partial S/\\partial p_n`,
    :math:`p_{n+1} = \\partial S/\\partial q_{n+1}` with

    .. math::

        S(p_n, q_{n+1}) = q_{n+1} p_n - h H(q_{n+1}, p_n)
            + \\frac{h^2}{2}\\, H_q(q_{n+1}, p_n) \\cdot H_p(q_{n+1}, p_n),

    (for the reduced system q = l, p = L). The :math:`h^2` term is the second coefficient of the
    solution of the Hamilton-Jacobi equation for generating functions of this type (the flow for time
    :math:`-h` has :math:`S^1 = -hH + \\tfrac{h^2}{2} H_p H_q + O(h^3)`, [HLW] VI.5.4); without it the
    method is symplectic Euler B, of order 1. It is not the midpoint rule: it is not symmetric, and it
    differs from it at order :math:`h^3` per step.

    Order 2; symplectic; implicit in :math:`q_{n+1}`. Structure: canonical, with a formula (the Newton
    Jacobian uses third derivatives of H, taken symbolically). Cost per step: Newton iterations on n
    unknowns, each gradient and Hessian of H and of :math:`W = H_q \\cdot H_p`. Reference: [SA] section 8.1
    (which cites Channell & Scovel for it); [HLW] VI.5.4 for the Hamilton-Jacobi construction.
    """

    structure: ClassVar[Structure] = Structure.CANONICAL
    symplectic: ClassVar[bool] = True
    needs_expression: ClassVar[bool] = True
    kernel: ClassVar[str] = "symplectic_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "grad", "gf"})

    def constants(self, problem: Any) -> np.ndarray:
        return np.array([2.0])

    @property
    def order(self) -> int:
        return 2

    @property
    def key(self) -> str:
        return "generating_function"


def _gauss_tableau(s: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r3, r15 = np.sqrt(3.0), np.sqrt(15.0)
    if s == 1:
        return np.array([[0.5]]), np.array([1.0]), np.array([0.5])
    if s == 2:
        A = np.array([[0.25, 0.25 - r3 / 6], [0.25 + r3 / 6, 0.25]])
        return A, np.array([0.5, 0.5]), np.array([0.5 - r3 / 6, 0.5 + r3 / 6])
    A = np.array(
        [
            [5 / 36, 2 / 9 - r15 / 15, 5 / 36 - r15 / 30],
            [5 / 36 + r15 / 24, 2 / 9, 5 / 36 - r15 / 24],
            [5 / 36 + r15 / 30, 2 / 9 + r15 / 15, 5 / 36],
        ]
    )
    return A, np.array([5 / 18, 4 / 9, 5 / 18]), np.array([0.5 - r15 / 10, 0.5, 0.5 + r15 / 10])


@dataclass(frozen=True)
class GaussLegendre(Method):
    """Gauss-Legendre collocation with ``stages`` = s = 1, 2, 3 stages (s = 1 is the midpoint rule).

    Order 2s; symplectic (canonical systems), symmetric, preserves quadratic invariants (so
    :math:`|m|^2`). Structure: any ODE with a Jacobian. Cost per step: Newton iterations on s d unknowns,
    each s evaluations of f and of its exact Jacobian and one (s d) x (s d) solve.
    Reference: [HLW] II.1.3, VI.4; [HNW] II.7.
    """

    stages: int = 2
    structure: ClassVar[Structure] = Structure.ODE
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "gauss_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "fjac"})

    def __post_init__(self) -> None:
        if self.stages not in (1, 2, 3) or isinstance(self.stages, bool):
            raise InputError(f"Expected `stages` to be 1, 2 or 3, got {self.stages!r}.")

    @property
    def order(self) -> int:
        return 2 * self.stages

    @property
    def key(self) -> str:
        return f"gauss_legendre_{self.stages}"

    def tableau(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The Butcher tableau ``(A, b, c)``."""
        return _gauss_tableau(self.stages)

    def constants(self, problem: Any) -> np.ndarray:
        A, b, c = self.tableau()
        d = np.linalg.solve(A.T, b)  # d^T = b^T A^{-1}
        return np.concatenate([[self.stages], A.ravel(), d, c])


def _composition_weights(order: int, composition: str) -> tuple[float, ...]:
    if order == 2:
        return (1.0,)
    if composition == "yoshida":
        g1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
        return (g1, 1.0 - 2.0 * g1, g1)
    g1 = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))  # Suzuki's fractal of five Strang steps
    return (g1, g1, 1.0 - 4.0 * g1, g1, g1)


@dataclass(frozen=True)
class LiePoissonSplitting(Method):
    """Splitting for Lie-Poisson systems on so(3)* whose Hamiltonian is a sum
    :math:`H = f_1(m_1) + f_2(m_2) + f_3(m_3)` (the free rigid body, the seed's closed loop).

    The flow of :math:`f_i(m_i)` keeps :math:`m_i`, hence :math:`\\omega_i = f_i'(m_i)`, constant: it is the
    exact rotation :math:`m(t) = \\exp(-t\\omega_i \\hat e_i)\\, m`, :math:`R(t) = R \\exp(t\\omega_i \\hat e_i)`.
    ``order=2`` is Strang's symmetric composition
    :math:`\\varphi^{a}_{h/2}\\varphi^{b}_{h/2}\\varphi^{c}_{h}\\varphi^{b}_{h/2}\\varphi^{a}_{h/2}` (the costliest
    part c in the middle, the last sub-flow merged with the next step's first); ``order=4`` composes it
    as Yoshida's triple jump or Suzuki's five-fold fractal.

    Order 2 or 4; explicit; Poisson (each sub-flow is a Hamiltonian flow), symmetric; keeps the Casimir
    :math:`|m|` and, with the attitude, the spatial momentum :math:`p = R m` to round-off. Structure:
    Lie-Poisson on so(3)* with a split Hamiltonian (checked symbolically: the mixed second derivatives
    vanish). Cost per step: 4 (order 2) or 12 / 16 (order 4) derivative evaluations and rotations.
    Reference: [HLW] VII.5.4 (the free rigid body), II.4 and V.3 (compositions); [Y].
    """

    order: int = 2  # type: ignore[assignment]
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
        if self.order not in (2, 4) or isinstance(self.order, bool):
            raise InputError(f"Expected `order` to be 2 or 4, got {self.order!r}.")
        if self.composition not in ("yoshida", "suzuki"):
            raise InputError(f"Expected `composition` to be 'yoshida' or 'suzuki', got {self.composition!r}.")
        if self.axis_order is not None and sorted(self.axis_order) != [0, 1, 2]:
            raise InputError(f"Expected `axis_order` to be a permutation of (0, 1, 2), got {self.axis_order!r}.")

    @property
    def key(self) -> str:
        return "strang" if self.order == 2 else f"splitting_4_{self.composition}"

    def sequence(self, axis_order: tuple[int, int, int]) -> list[tuple[int, float]]:
        """One step as (axis, fraction of h) sub-flows, adjacent flows about one axis merged."""
        a, b, c = self.axis_order or axis_order
        strang = [(a, 0.5), (b, 0.5), (c, 1.0), (b, 0.5), (a, 0.5)]
        seq: list[tuple[int, float]] = []
        for g in _composition_weights(self.order, self.composition):
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


#: One instance of every method, by key.
@dataclass(frozen=True)
class PeriodicOrbit(Method):
    """Exact propagation of a one-degree-of-freedom orbit by its period: the state at any time from one period.

    Every bounded orbit of a 1-dof Hamiltonian that is not an equilibrium or a separatrix is periodic, so
    the state at t is the state at t mod T: one period is integrated (Dormand-Prince 8(5,3) with error
    control, compiled), its end located on the section through y0 by Newton, and each output is one
    Runge-Kutta step from the stored mesh point before it (:class:`~geomech.integrators.PeriodicOrbitPropagator`).
    Order: 8 within the period; the error does not grow with t beyond ``t * period_error / T``. ``h`` is only
    the output interval. Explicit; not symplectic, but the energy error is that of one period, bounded for all
    t. Structure: canonical with n = 1. Cost per trajectory: about (0.1 ms + compile once) for the period,
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
    explicit: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not (isinstance(self.tol, (int, float)) and 1e-15 <= self.tol <= 1e-6):
            raise InputError(f"Expected `tol` in [1e-15, 1e-6], got {self.tol!r}.")
        object.__setattr__(self, "L_bounds", _bounds(self.L_bounds))

    @property
    def order(self) -> int:
        return 8

    @property
    def key(self) -> str:
        return "periodic_orbit"


@dataclass(frozen=True)
class Quadrature(Method):
    """Exact propagation of a one-degree-of-freedom orbit by quadrature (eq. (11) of [SA] for any H).

    The period is the integral :math:`T = \\oint dq / (\\partial H/\\partial p)` along the level curve of
    :math:`H(y_0)`, the state at t is found from the time-of-flight integral at ``t mod T`` and periodicity
    (:class:`~geomech.integrators.QuadraturePropagator`): no time stepping, so the cost does not grow with
    t and the energy error is that of the level curve, bounded for all t. ``h`` is only the output
    interval. Order: none (exact up to ``tol``; ``order`` reports 0). Structure: canonical with n = 1.
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
    explicit: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not (isinstance(self.tol, (int, float)) and 1e-15 <= self.tol <= 1e-3):
            raise InputError(f"Expected `tol` in [1e-15, 1e-3], got {self.tol!r}.")
        object.__setattr__(self, "L_bounds", _bounds(self.L_bounds))

    @property
    def order(self) -> int:
        return 0

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


REGISTRY: dict[str, Method] = {
    m.key: m
    for m in (
        RK4(),
        AdamsBashforthMoulton4(),
        AdaptiveAdams(),
        SymplecticEuler("A"),
        SymplecticEuler("B"),
        StormerVerlet(),
        ImplicitMidpoint(),
        GeneratingFunction(),
        GaussLegendre(1),
        GaussLegendre(2),
        GaussLegendre(3),
        LiePoissonSplitting(2),
        LiePoissonSplitting(4, "yoshida"),
        LiePoissonSplitting(4, "suzuki"),
        MoserVeselov(),
        LieGroupVariational("cayley"),
        LieGroupVariational("exp"),
        PeriodicOrbit(),
        Quadrature(),
    )
}


def get_method(method: Any) -> Method:
    """A :class:`Method` from an instance or a registry key (``"rk4"``, ``"implicit_midpoint"``, ...)."""
    if isinstance(method, Method):
        return method
    if isinstance(method, str) and method in REGISTRY:
        return REGISTRY[method]
    raise InputError(
        f"Expected `method` to be a geomech.integrators method or one of {sorted(REGISTRY)}, got {method!r}."
    )


def methods_table() -> list[dict[str, Any]]:
    """Every registered method's traits (for documentation tables)."""
    return [m.describe() for m in REGISTRY.values()]
