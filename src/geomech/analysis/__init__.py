"""Analysis of mechanical systems: relative equilibria and their stability (Lagrange-Dirichlet,
energy-Casimir, linearisation), stability boundaries and maps; geometric and dynamic phases; nonholonomic gaits;
studies over many parameter values on dask (sweeps and Monte Carlo, resumable)."""

from ..systems.gait import Gait
from .equilibria import (
    Equilibrium,
    EquilibriumSet,
    chart_derivatives,
    continue_equilibria,
    find_equilibria,
    refine_equilibrium,
)
from .gait_model import gait_loop
from .gait_sweep import GaitSweep
from .gaits import GaitAnalysis, analyse_gait
from .group_paths import decompose_displacement, integrate_path
from .isotropy_phase import IsotropyPhase, isotropy_phase, periodic_body_momentum
from .momentum_transport import MomentumTransport, momentum_connection, momentum_curvature, momentum_transport
from .phases import (
    PhaseSplit,
    Reconstruction,
    curvature_integral,
    geometric_phase,
    phase_history,
    phases,
    reconstruct,
)
from .rigid_body_phase import RigidBodyPhase, rigid_body_phase, spherical_polygon_area
from .shape_loops import bind_loop
from .stability import (
    VERDICT_CODES,
    PerturbationGrowth,
    StabilityAnalysis,
    StabilityBoundary,
    StabilityReport,
    Verdict,
    analyse_stability,
    assess,
    energy_casimir,
    lagrange_dirichlet,
    linearisation,
    perturbation_growth,
    stability_boundary,
)
from .stability_map import stability_map, theorem5_margin
from .sweep import monte_carlo, sweep

__all__ = [
    "IsotropyPhase",
    "isotropy_phase",
    "periodic_body_momentum",
    "MomentumTransport",
    "momentum_connection",
    "momentum_curvature",
    "momentum_transport",
    "GaitAnalysis",
    "GaitSweep",
    "analyse_gait",
    "gait_loop",
    "PhaseSplit",
    "Reconstruction",
    "RigidBodyPhase",
    "Gait",
    "bind_loop",
    "curvature_integral",
    "decompose_displacement",
    "geometric_phase",
    "phase_history",
    "integrate_path",
    "phases",
    "reconstruct",
    "rigid_body_phase",
    "spherical_polygon_area",
    "VERDICT_CODES",
    "Equilibrium",
    "EquilibriumSet",
    "PerturbationGrowth",
    "StabilityAnalysis",
    "StabilityBoundary",
    "StabilityReport",
    "Verdict",
    "analyse_stability",
    "assess",
    "chart_derivatives",
    "continue_equilibria",
    "energy_casimir",
    "find_equilibria",
    "lagrange_dirichlet",
    "linearisation",
    "perturbation_growth",
    "refine_equilibrium",
    "stability_boundary",
    "stability_map",
    "theorem5_margin",
    "monte_carlo",
    "sweep",
]
