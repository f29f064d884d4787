"""Maps between representations: Euler-angle coordinates, Serret-Andoyer charts, reduction."""

from .almost_poisson import AlmostPoissonStructure, PoissonReduction, almost_poisson, poisson_reduction
from .classical import (
    ClassicalSerretAndoyer,
    LPeriod,
    momentum_l,
    period_of_l,
    period_of_l_from_momentum,
    reduced_hamiltonian,
    reduced_hamiltonian_expression,
    reduced_vector_field,
)
from .connections import MechanicalConnection
from .euler_coordinates import EulerCoordinates, body_angular_velocity
from .nonholonomic import LagrangeDAlembert, NonholonomicReduction, bkmm_reduction, lagrange_dalembert
from .serret_andoyer import GeneralizedSerretAndoyer, ReducedTrajectory, SerretAndoyerChart, spatial_frame

__all__ = [
    "AlmostPoissonStructure",
    "LagrangeDAlembert",
    "NonholonomicReduction",
    "PoissonReduction",
    "almost_poisson",
    "bkmm_reduction",
    "lagrange_dalembert",
    "poisson_reduction",
    "ClassicalSerretAndoyer",
    "EulerCoordinates",
    "GeneralizedSerretAndoyer",
    "LPeriod",
    "MechanicalConnection",
    "ReducedTrajectory",
    "SerretAndoyerChart",
    "body_angular_velocity",
    "momentum_l",
    "period_of_l",
    "period_of_l_from_momentum",
    "reduced_hamiltonian",
    "reduced_hamiltonian_expression",
    "reduced_vector_field",
    "spatial_frame",
]
