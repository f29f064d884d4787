"""Lie groups, numerically, vectorised over leading batch axes: one hierarchy.

:class:`~geomech.lie.group.LieGroup` is the abstract group (``exp, log, compose, inverse, act, Ad, ad, coad``,
left and right Jacobians and their inverses, ``identity(batch_shape), random, rplus, rminus, interpolate``,
a basis, structure constants and a coordinate chart). The concrete groups (:mod:`~geomech.lie.groups`):
:class:`SO3` (with quaternion and Euler-angle constructors), :class:`SE2`, :class:`SE3`, :class:`SO2`
(alias :data:`S1`), :class:`Rn`, direct products (``G1 * G2``, :class:`~geomech.lie.group.Product`) and any matrix
group from a basis of its algebra (:class:`~geomech.lie.matrix_group.MatrixGroup`). Their symbolic twins are
:class:`geomech.symbolic.GroupChart`.

The closed forms are vectorised kernels in :mod:`~geomech.lie.so3`, :mod:`~geomech.lie.se2` and
:mod:`~geomech.lie.se3` (free functions on arrays); rotation parametrisations in
:mod:`~geomech.lie.quaternion` (unit quaternions) and :mod:`~geomech.lie.euler` (all 12 Euler-angle
sequences, intrinsic and extrinsic, with gimbal lock detected).
"""

from __future__ import annotations

from . import euler, quaternion, se2, se3, so3
from .group import LieGroup, Product
from .groups import S1, SE2, SE3, SO2, SO3, Rn, named_group
from .matrix_group import MatrixGroup

__all__ = [
    "LieGroup",
    "MatrixGroup",
    "Product",
    "Rn",
    "S1",
    "SE2",
    "SE3",
    "SO2",
    "SO3",
    "euler",
    "named_group",
    "quaternion",
    "se2",
    "se3",
    "so3",
]
