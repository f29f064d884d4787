"""Numeric Lie-group primitives, vectorised over leading batch axes.

One module per group with the same small API (``hat, vee, exp, log, inverse, compose, act, Ad, ad, coad,
identity, random, left_jacobian, right_jacobian`` and their inverses, ``DIM, MATRIX_SIZE``):
:mod:`~geomech.lie.so3`, :mod:`~geomech.lie.se2`, :mod:`~geomech.lie.se3`. Rotation parametrisations:
:mod:`~geomech.lie.quaternion` (unit quaternions) and :mod:`~geomech.lie.euler` (all 12 Euler-angle
sequences, intrinsic and extrinsic, with gimbal lock detected). Any other matrix group, from a basis of its
algebra: :class:`~geomech.lie.matrix_group.MatrixLieGroup`.
"""

from __future__ import annotations

from . import euler, quaternion, se2, se3, so3
from .matrix_group import MatrixLieGroup

__all__ = ["MatrixLieGroup", "euler", "quaternion", "se2", "se3", "so3"]
