"""Immutable descriptions of mechanical systems."""

from . import rotor_closed_forms
from ._euler_top import EulerTopSolution
from .canonical import CanonicalSystem
from .control import ClosedLoopFamily, HyperregularityReport, StructurePreservingControl
from .left_invariant import LeftInvariantSystem, as_left_invariant
from .rigid_body import RigidBody
from .rotors import RotorBody, RotorTrajectory

__all__ = [
    "CanonicalSystem",
    "ClosedLoopFamily",
    "EulerTopSolution",
    "HyperregularityReport",
    "LeftInvariantSystem",
    "RigidBody",
    "RotorBody",
    "RotorTrajectory",
    "StructurePreservingControl",
    "as_left_invariant",
    "rotor_closed_forms",
]
