"""Simulation: ``solve(system, method, ...)``, the integrators (compiled where they are fixed-step), and
exact propagation of one-degree-of-freedom systems by quadrature."""

from ._one_dof import CriticalPoint, OrbitIntegral
from .methods import (
    BKMM,
    REGISTRY,
    RK4,
    AdamsBashforthMoulton4,
    AdaptiveAdams,
    DiscreteLagrangeDAlembert,
    GaussLegendre,
    GeneratingFunction,
    ImplicitMidpoint,
    IncompatibleMethodError,
    Kind,
    LagrangeDAlembert,
    LieGroupVariational,
    LiePoissonSplitting,
    Method,
    MoserVeselov,
    PeriodicOrbit,
    Quadrature,
    SerretAndoyerAtlas,
    SolveIVP,
    StormerVerlet,
    Structure,
    SymplecticEuler,
    get_method,
    methods_table,
)
from .nonholonomic import initial_state
from .periodic import PeriodicOrbitPropagator
from .quadrature import QuadraturePropagator
from .serret_andoyer_propagator import SerretAndoyerPropagator
from .solution import QUANTITIES, Failure, Solution, Status
from .solve import DEFAULT_SAVEAT, compatible_methods, solve

__all__ = [
    "BKMM",
    "DEFAULT_SAVEAT",
    "DiscreteLagrangeDAlembert",
    "Kind",
    "LagrangeDAlembert",
    "QUANTITIES",
    "Status",
    "REGISTRY",
    "RK4",
    "AdamsBashforthMoulton4",
    "AdaptiveAdams",
    "SolveIVP",
    "CriticalPoint",
    "Failure",
    "GaussLegendre",
    "GeneratingFunction",
    "ImplicitMidpoint",
    "IncompatibleMethodError",
    "LieGroupVariational",
    "LiePoissonSplitting",
    "Method",
    "MoserVeselov",
    "OrbitIntegral",
    "PeriodicOrbit",
    "Quadrature",
    "SerretAndoyerAtlas",
    "PeriodicOrbitPropagator",
    "QuadraturePropagator",
    "SerretAndoyerPropagator",
    "Solution",
    "StormerVerlet",
    "Structure",
    "SymplecticEuler",
    "compatible_methods",
    "get_method",
    "initial_state",
    "methods_table",
    "solve",
]
