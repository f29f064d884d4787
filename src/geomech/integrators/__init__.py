"""Simulation: ``solve(system, method, ...)``, the integrators (compiled where they are fixed-step), and
exact propagation of one-degree-of-freedom systems by quadrature."""

from ._one_dof import CriticalPoint, OrbitIntegral
from .methods import (
    REGISTRY,
    RK4,
    AdamsBashforthMoulton4,
    AdaptiveAdams,
    GaussLegendre,
    GeneratingFunction,
    ImplicitMidpoint,
    IncompatibleMethodError,
    LieGroupVariational,
    LiePoissonSplitting,
    Method,
    MoserVeselov,
    PeriodicOrbit,
    Quadrature,
    StormerVerlet,
    Structure,
    SymplecticEuler,
    get_method,
    methods_table,
)
from .nonholonomic import (
    Gait,
    NonholonomicTrajectory,
    initial_state,
    simulate_discrete,
    simulate_full,
    simulate_reduced,
)
from .periodic import PeriodicOrbitPropagator
from .quadrature import QuadraturePropagator
from .serret_andoyer_propagator import SerretAndoyerPropagator
from .solution import Failure, Solution
from .solve import compatible_methods, solve

__all__ = [
    "REGISTRY",
    "RK4",
    "AdamsBashforthMoulton4",
    "AdaptiveAdams",
    "CriticalPoint",
    "Failure",
    "Gait",
    "GaussLegendre",
    "GeneratingFunction",
    "ImplicitMidpoint",
    "IncompatibleMethodError",
    "LieGroupVariational",
    "LiePoissonSplitting",
    "Method",
    "MoserVeselov",
    "NonholonomicTrajectory",
    "OrbitIntegral",
    "PeriodicOrbit",
    "Quadrature",
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
    "simulate_discrete",
    "simulate_full",
    "simulate_reduced",
    "solve",
]
