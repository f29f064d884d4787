"""Analysis of mechanical systems: relative equilibria and their stability (Lagrange-Dirichlet,
energy-Casimir, linearisation), stability boundaries and stability maps."""

from .equilibria import (
    Equilibrium,
    EquilibriumSet,
    chart_derivatives,
    continue_equilibria,
    find_equilibria,
    refine_equilibrium,
)
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

__all__ = [
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
]
