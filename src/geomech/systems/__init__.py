"""Immutable descriptions of mechanical systems."""

from ._euler_top import EulerTopSolution
from .canonical import CanonicalSystem
from .left_invariant import LeftInvariantSystem, as_left_invariant
from .rigid_body import RigidBody

__all__ = ["CanonicalSystem", "EulerTopSolution", "LeftInvariantSystem", "RigidBody", "as_left_invariant"]
