"""General-purpose methods, for any system: RK4, Adams-Bashforth-Moulton 4, adaptive Adams ([HNW])."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from ...errors import InputError
from ._base import Kind, Method, Structure


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
    """Variable-order, variable-step Adams method with error control (the ``rtol`` and ``atol`` given to solve).

    Wraps the well-kept Fortran solvers of scipy: ``solver="vode"`` (VODE in its non-stiff Adams mode,
    orders 1-12; the closest to MATLAB's ``ode113`` that the Serret-Andoyer paper used) or
    ``solver="lsoda"`` (Adams switching to BDF where the problem is stiff). Order: variable, 1 to 12
    (``order`` is the largest); implicit (Adams-Moulton correctors solved by fixed-point iteration, so no
    Jacobian is needed); not structure-preserving. Structure: any ODE. Cost: as
    many evaluations as the tolerances require; runs through Python (not compiled).
    Reference: [HNW] III.7; Brown, Byrne & Hindmarsh, VODE, SIAM J. Sci. Stat. Comput. 10 (1989).

    Parameters
    ----------
    solver : {"vode", "lsoda"}
    max_steps : int
        Internal steps allowed between two outputs.
    """

    solver: str = "vode"
    max_steps: int = 100_000
    structure: ClassVar[Structure] = Structure.ODE
    kind: ClassVar[Kind] = Kind.ADAPTIVE
    explicit: ClassVar[bool] = False
    variable_order: ClassVar[bool] = True

    def __post_init__(self) -> None:
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


#: scipy.integrate.solve_ivp's explicit and implicit solvers, with their orders (largest for variable order).
SCIPY_SOLVERS = {"DOP853": 8, "RK45": 5, "RK23": 3, "Radau": 5, "BDF": 5, "LSODA": 12}


def check_solver(solver: str) -> None:
    if solver not in SCIPY_SOLVERS:
        raise InputError(f"Expected `solver` to be one of {sorted(SCIPY_SOLVERS)} (scipy's solve_ivp), got {solver!r}.")


@dataclass(frozen=True)
class ScipyStepped(Method):
    """Base of the methods stepped by a solver of scipy's ``solve_ivp`` family (abstract): the ``solver``
    field, the adaptive kind and tolerances, and the traits (order, explicitness) that follow from the solver."""

    solver: str = "DOP853"
    kind: ClassVar[Kind] = Kind.ADAPTIVE
    default_tolerances: ClassVar[tuple[float, float]] = (1e-10, 1e-12)

    def __post_init__(self) -> None:
        check_solver(self.solver)

    @property
    def explicit(self) -> bool:  # type: ignore[override]
        return self.solver in ("DOP853", "RK45", "RK23")

    @property
    def order(self) -> int:
        return SCIPY_SOLVERS[self.solver]

    @property
    def variable_order(self) -> bool:  # type: ignore[override]
        return self.solver in ("BDF", "LSODA")


@dataclass(frozen=True)
class SolveIVP(ScipyStepped):
    """An adaptive solver of scipy's ``solve_ivp`` family on the system's equations, with error control.

    ``solver="DOP853"`` (Dormand-Prince 8(5,3), the default), ``"RK45"``, ``"RK23"`` (explicit Runge-Kutta
    pairs), ``"Radau"``, ``"BDF"`` (implicit, for stiff problems) or ``"LSODA"`` (Adams/BDF switching), stepped
    one step at a time with dense output at ``saveat``; the number of evaluations is bounded by
    ``max_evaluations``, and a failure is data with the states reached. Kind: adaptive (``rtol``, ``atol``;
    default 1e-10, 1e-12). Order: that of the solver. Not structure-preserving. Structure: any ODE.
    Cost: as many evaluations as the tolerances require; the stepping runs in Python (the right-hand side is
    compiled where the system is a formula).
    Reference: [HNW] II.4-II.5 (DOP853); Hairer & Wanner, Solving ODEs II, IV.8 (Radau).

    Parameters
    ----------
    solver : {"DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA"}
    """

    structure: ClassVar[Structure] = Structure.ODE

    @property
    def key(self) -> str:
        return "solve_ivp"
