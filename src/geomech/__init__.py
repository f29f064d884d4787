"""geomech: computational geometric mechanics.

Describe a system once (:mod:`geomech.systems`), move it between representations
(:mod:`geomech.reduction`, :mod:`geomech.lie`), simulate it, and analyse and show the result.
"""

from . import analysis, errors, integrators, lie
from ._version import __version__
from .analysis import monte_carlo, sweep
from .errors import GeomechError
from .integrators import Solution, prepare, solve
from .reduction import GeneralizedSerretAndoyer, SerretAndoyerChart
from .symbolic.compile import M_SYMBOLS
from .systems import (
    CanonicalSystem,
    Gait,
    GroupFlow,
    HolonomicSystem,
    LeftInvariantSystem,
    NonholonomicSystem,
    RigidBody,
    RotorBody,
    StructurePreservingControl,
    as_left_invariant,
)

__all__ = [
    "CanonicalSystem",
    "Gait",
    "GroupFlow",
    "HolonomicSystem",
    "NonholonomicSystem",
    "GeneralizedSerretAndoyer",
    "GeomechError",
    "LeftInvariantSystem",
    "M_SYMBOLS",
    "RigidBody",
    "RotorBody",
    "StructurePreservingControl",
    "SerretAndoyerChart",
    "Solution",
    "as_left_invariant",
    "analysis",
    "errors",
    "integrators",
    "lie",
    "monte_carlo",
    "prepare",
    "solve",
    "sweep",
    "__version__",
]
