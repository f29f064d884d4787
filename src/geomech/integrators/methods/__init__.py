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
- [KM] Koon & Marsden, The geometric structure of nonholonomic mechanics (seeds/004).
- [CM] Cortes & Martinez, Non-holonomic integrators, Nonlinearity 14 (2001).
- [VM] van der Schaft & Maschke, On the Hamiltonian formulation of nonholonomic mechanical systems, Rep. Math.
  Phys. 34 (1994); [BS] Bates & Sniatycki, Nonholonomic reduction, Rep. Math. Phys. 32 (1993).
- [BRM] Bou-Rabee & Marsden, Hamilton-Pontryagin integrators on Lie groups, Found. Comput. Math. 9 (2009).
- [DP] Dormand & Prince, A family of embedded Runge-Kutta formulae, J. Comput. Appl. Math. 6 (1980).
- [MK] Munthe-Kaas, High order Runge-Kutta methods on manifolds, Appl. Numer. Math. 29 (1999).
- [CG] Crouch & Grossman, Numerical integration of ordinary differential equations on manifolds, J. Nonlinear
  Sci. 3 (1993); [OM] Owren & Marthinsen, Runge-Kutta methods adapted to manifolds and based on rigid frames,
  BIT 39 (1999).
"""

from __future__ import annotations

from typing import Any

from ...errors import InputError
from ._base import IncompatibleMethodError, Kind, Method, Structure
from ._canonical import GaussLegendre, GeneratingFunction, ImplicitMidpoint, StormerVerlet, SymplecticEuler
from ._composition import COMPOSITION_TABLES, Composition, composition_weights
from ._embedded import DormandPrince, EmbeddedPair, Taylor, embedded_pair, taylor_order
from ._general import RK4, AdamsBashforthMoulton4, AdaptiveAdams, SolveIVP
from ._group import RKMK, RKMK4
from ._lagrangian import BKMM, TAYLOR, DiscreteLagrangeDAlembert, LagrangeDAlembert, NonholonomicHamilton
from ._lie_poisson import (
    CrouchGrossman,
    LieGroupVariational,
    LiePoissonSplitting,
    MoserVeselov,
    PeriodicOrbit,
    Quadrature,
    SerretAndoyerAtlas,
)

__all__ = [
    "Structure",
    "Kind",
    "IncompatibleMethodError",
    "Method",
    "RK4",
    "AdamsBashforthMoulton4",
    "AdaptiveAdams",
    "SolveIVP",
    "DormandPrince",
    "Composition",
    "COMPOSITION_TABLES",
    "composition_weights",
    "EmbeddedPair",
    "embedded_pair",
    "SymplecticEuler",
    "StormerVerlet",
    "ImplicitMidpoint",
    "GeneratingFunction",
    "GaussLegendre",
    "LiePoissonSplitting",
    "MoserVeselov",
    "LieGroupVariational",
    "CrouchGrossman",
    "PeriodicOrbit",
    "Quadrature",
    "SerretAndoyerAtlas",
    "LagrangeDAlembert",
    "BKMM",
    "Taylor",
    "taylor_order",
    "TAYLOR",
    "DiscreteLagrangeDAlembert",
    "NonholonomicHamilton",
    "RKMK",
    "RKMK4",
    "REGISTRY",
    "get_method",
    "methods_table",
]


REGISTRY: dict[str, Method] = {
    m.key: m
    for m in (
        RK4(),
        AdamsBashforthMoulton4(),
        AdaptiveAdams(),
        SolveIVP(),
        DormandPrince("DOP853"),
        DormandPrince("DOPRI5"),
        Taylor(),
        SymplecticEuler("A"),
        SymplecticEuler("B"),
        StormerVerlet(),
        ImplicitMidpoint(),
        GeneratingFunction(),
        GaussLegendre(1),
        GaussLegendre(2),
        GaussLegendre(3),
        GaussLegendre(4),
        GaussLegendre(5),
        GaussLegendre(6),
        Composition(6),
        Composition(8),
        Composition(10),
        LiePoissonSplitting(2),
        LiePoissonSplitting(4, "yoshida"),
        LiePoissonSplitting(4, "suzuki"),
        LiePoissonSplitting(6, "s9"),
        LiePoissonSplitting(8, "s17"),
        MoserVeselov(),
        LieGroupVariational("cayley"),
        LieGroupVariational("exp"),
        CrouchGrossman(),
        SerretAndoyerAtlas(),
        PeriodicOrbit(),
        Quadrature(),
        LagrangeDAlembert(),
        BKMM(),
        NonholonomicHamilton(form="almost_poisson"),
        NonholonomicHamilton(form="bates_sniatycki"),
        NonholonomicHamilton(form="full"),
        DiscreteLagrangeDAlembert(),
        DiscreteLagrangeDAlembert("group"),
        RKMK(),
        RKMK4(),
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
