"""Maps between representations: Euler-angle coordinates, Serret-Andoyer charts, reduction."""

from . import rotor_closed_forms
from .almost_poisson import AlmostPoissonStructure, PoissonReduction, almost_poisson, poisson_reduction
from .bates_sniatycki import BatesSniatycki, bates_sniatycki
from .classical import (
    ClassicalSerretAndoyer,
    LPeriod,
    andoyer_hamiltonian,
    momentum_l,
    period_of_l,
    period_of_l_from_momentum,
    reduced_hamiltonian,
    reduced_vector_field,
)
from .coadjoint import CoadjointOrbit, StationarySubgroup
from .euler_coordinates import EulerCoordinates
from .full_almost_poisson import FullAlmostPoisson, full_almost_poisson
from .lagrange_dalembert import LagrangeDAlembert, lagrange_dalembert
from .nonholonomic import NonholonomicReduction, bkmm_reduction, reduced_numeric
from .quaternion_coordinates import QuaternionCoordinates
from .reduced_numeric import ReducedNumeric
from .serret_andoyer import GeneralizedSerretAndoyer, SerretAndoyerChart, reduced_formulas, spatial_frame

__all__ = [
    "CoadjointOrbit",
    "StationarySubgroup",
    "rotor_closed_forms",
    "AlmostPoissonStructure",
    "LagrangeDAlembert",
    "NonholonomicReduction",
    "PoissonReduction",
    "ReducedNumeric",
    "almost_poisson",
    "BatesSniatycki",
    "bates_sniatycki",
    "FullAlmostPoisson",
    "full_almost_poisson",
    "bkmm_reduction",
    "lagrange_dalembert",
    "poisson_reduction",
    "reduced_numeric",
    "ClassicalSerretAndoyer",
    "EulerCoordinates",
    "QuaternionCoordinates",
    "GeneralizedSerretAndoyer",
    "LPeriod",
    "SerretAndoyerChart",
    "momentum_l",
    "period_of_l",
    "period_of_l_from_momentum",
    "reduced_hamiltonian",
    "andoyer_hamiltonian",
    "reduced_vector_field",
    "reduced_formulas",
    "spatial_frame",
]
