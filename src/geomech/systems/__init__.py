"""Immutable descriptions of mechanical systems."""

from . import nonholonomic_examples
from ._euler_top import EulerTopSolution
from .canonical import CanonicalSystem
from .control import ClosedLoopFamily, HyperregularityReport, StructurePreservingControl
from .gait import Gait
from .group_flow import GroupFlow
from .holonomic import HolonomicSystem
from .holonomic_examples import (
    planar_point_masses,
    planar_point_positions,
    spacecraft_with_rotors,
    three_link_chain,
    three_link_positions,
    two_pinned_bodies,
)
from .left_invariant import LeftInvariantSystem, as_left_invariant
from .nonholonomic import InvarianceReport, NonholonomicSystem
from .rigid_body import RigidBody
from .rotors import RotorBody

__all__ = [
    "Gait",
    "GroupFlow",
    "InvarianceReport",
    "NonholonomicSystem",
    "nonholonomic_examples",
    "CanonicalSystem",
    "ClosedLoopFamily",
    "EulerTopSolution",
    "HolonomicSystem",
    "HyperregularityReport",
    "LeftInvariantSystem",
    "RigidBody",
    "RotorBody",
    "StructurePreservingControl",
    "as_left_invariant",
    "planar_point_masses",
    "planar_point_positions",
    "spacecraft_with_rotors",
    "three_link_chain",
    "three_link_positions",
    "two_pinned_bodies",
]
