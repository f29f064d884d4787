r"""The concrete groups with closed forms: SO3, SO2 (S1), SE2, SE3, Rn; and the one lookup of a group by name.

Each is an immutable value of the one API of :class:`~geomech.lie.group.LieGroup`, with closed forms where
they exist (:mod:`~geomech.lie.so3`, :mod:`~geomech.lie.se2`, :mod:`~geomech.lie.se3` hold them as
vectorised kernels) and a coordinate chart for the mechanics, whose names are the constructor's
arguments::

    >>> from geomech.lie import SE2, SO2
    >>> G = SE2("x", "y", "theta") * SO2("psi")    # a product: block-diagonal matrices
    >>> G.dim, G.matrix_size, G.coordinate_names
    (4, 5, ('x', 'y', 'theta', 'psi'))

Algebra orderings: SO(3) :math:`\omega`; SE(2) :math:`(v_x, v_y, \omega)`; SE(3) :math:`(v, \omega)`;
R^n the translation; a product the concatenation of its factors'.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from . import _common as c
from . import euler as _euler
from . import quaternion as _quat
from . import se2 as _se2
from . import se3 as _se3
from . import so3 as _so3
from .group import LieGroup

__all__ = ["SO3", "SO2", "S1", "SE2", "SE3", "Rn", "named_group"]


def _rot2_sym(a: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[sp.cos(a), -sp.sin(a)], [sp.sin(a), sp.cos(a)]])


def _rot3_sym(axis: int, a: sp.Expr) -> sp.Matrix:
    co, si = sp.cos(a), sp.sin(a)
    if axis == 0:
        return sp.Matrix([[1, 0, 0], [0, co, -si], [0, si, co]])
    if axis == 1:
        return sp.Matrix([[co, 0, si], [0, 1, 0], [-si, 0, co]])
    return sp.Matrix([[co, -si, 0], [si, co, 0], [0, 0, 1]])


def _euler_sym(q: Sequence[sp.Expr], seq: str) -> sp.Matrix:
    (i, j, k), intrinsic = _euler._parse(seq)
    Ra, Rb, Rc = _rot3_sym(i, q[0]), _rot3_sym(j, q[1]), _rot3_sym(k, q[2])
    return Ra * Rb * Rc if intrinsic else Rc * Rb * Ra


def _rigid_sym(R: sp.Matrix, t: sp.Matrix) -> tuple[sp.Matrix, sp.Matrix]:
    n = R.rows
    g = sp.Matrix.vstack(sp.Matrix.hstack(R, t), sp.Matrix([[0] * n + [1]]))
    gi = sp.Matrix.vstack(sp.Matrix.hstack(R.T, -R.T * t), sp.Matrix([[0] * n + [1]]))
    return g, gi.applyfunc(sp.trigsimp)


def _euler_reference(seq: str) -> tuple[sp.Expr, ...]:
    # A proper Euler sequence ('ZXZ') is singular at the identity (middle angle 0); a Tait-Bryan one is not.
    return (sp.Integer(0), sp.pi / 2, sp.Integer(0)) if _euler.is_proper(seq) else (sp.Integer(0),) * 3


class _Closed(LieGroup):
    """A group whose operations come from one of the closed-form kernel modules."""

    _kernel: Any

    def check(self, g: Any, name: str = "g") -> np.ndarray:
        return self._kernel._element(g, name) if hasattr(self._kernel, "_element") else c.rotation(g, name)

    def hat(self, u: Any) -> np.ndarray:
        return self._kernel.hat(u)

    def vee(self, X: Any) -> np.ndarray:
        return self._kernel.vee(X)

    def ad(self, u: Any) -> np.ndarray:
        return self._kernel.ad(u)

    def identity(self, batch_shape: Any = ()) -> np.ndarray:
        return self._kernel.identity(batch_shape)

    def exp(self, u: Any) -> np.ndarray:
        return self._kernel.exp(u)

    def log(self, g: Any) -> np.ndarray:
        return self._kernel.log(g)

    def compose(self, g: Any, h: Any) -> np.ndarray:
        return self._kernel.compose(g, h)

    def inverse(self, g: Any) -> np.ndarray:
        return self._kernel.inverse(g)

    def act(self, g: Any, x: Any) -> np.ndarray:
        return self._kernel.act(g, x)

    def Ad(self, g: Any) -> np.ndarray:
        return self._kernel.Ad(g)

    def coad(self, g: Any, mu: Any) -> np.ndarray:
        return self._kernel.coad(g, mu)

    def random(self, rng: Any = None, size: Any = ()) -> np.ndarray:
        return self._kernel.random(rng, size)

    def left_jacobian(self, u: Any) -> np.ndarray:
        return self._kernel.left_jacobian(u)

    def right_jacobian(self, u: Any) -> np.ndarray:
        return self._kernel.right_jacobian(u)

    def left_jacobian_inverse(self, u: Any) -> np.ndarray:
        return self._kernel.left_jacobian_inverse(u)

    def right_jacobian_inverse(self, u: Any) -> np.ndarray:
        return self._kernel.right_jacobian_inverse(u)

    @property
    def closed_chart(self) -> bool:
        return True

    def _key(self) -> tuple:
        return self.coordinate_names


class SO3(_Closed):
    """The rotations of space, charted by the Euler angles of ``seq`` (default 3-1-3,
    :math:`R = R_z(\\phi) R_x(\\theta) R_z(\\psi)`, eq. (1) of the Serret-Andoyer paper).

    Elements are rotation matrices mapping body to space coordinates; the algebra is :math:`\\omega` with
    :math:`\\hat\\omega w = \\omega\\times w`. Constructors from and to unit quaternions and Euler angles of
    any sequence: :meth:`from_quaternion`, :meth:`as_quaternion`, :meth:`from_euler`, :meth:`as_euler`.
    """

    _kernel = _so3
    dim = matrix_size = point_dim = 3
    algebra_names = ("omega_1", "omega_2", "omega_3")
    chart_angles = (0, 1, 2)

    def __init__(self, *names: Any, seq: str = "ZXZ"):
        _euler._parse(seq)
        self.seq = seq
        self.coordinate_names = c.coordinate_names(names, ("phi", "theta", "psi"), "SO(3)", "three Euler angles")
        self.name = "SO(3)" if seq == "ZXZ" else f"SO(3)[{seq}]"

    def check(self, g: Any, name: str = "g") -> np.ndarray:
        return c.rotation(g, name)

    def from_quaternion(self, q: Any, *, scalar_first: bool = True) -> np.ndarray:
        """Rotation matrices of unit quaternions ``(..., 4)``."""
        return _quat.as_matrix(q, scalar_first=scalar_first)

    def as_quaternion(self, R: Any, *, scalar_first: bool = True) -> np.ndarray:
        """Unit quaternions (scalar part >= 0) of rotations ``(..., 3, 3)``."""
        return _quat.from_matrix(R, scalar_first=scalar_first)

    def from_euler(self, angles: Any, seq: str | None = None) -> np.ndarray:
        """Rotations of Euler angles ``(..., 3)`` of ``seq`` (default: the chart's sequence)."""
        return _euler.as_matrix(angles, seq or self.seq)

    def as_euler(self, R: Any, seq: str | None = None, *, on_singular: str = "raise") -> np.ndarray:
        """Euler angles of ``seq`` (default: the chart's); gimbal lock raises unless ``on_singular="resolve"``."""
        return _euler.from_matrix(R, seq or self.seq, on_singular=on_singular)

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        R = _euler_sym(q, self.seq)
        return R, R.T

    @property
    def chart_reference(self) -> tuple[sp.Expr, ...]:
        return _euler_reference(self.seq)

    def from_coordinates(self, q: Any) -> np.ndarray:
        return _euler.as_matrix(q, self.seq)

    def to_coordinates(self, g: Any) -> np.ndarray:
        return _euler.from_matrix(g, self.seq, on_singular="resolve")

    def _key(self) -> tuple:
        return self.coordinate_names + (self.seq,)


class SE2(_Closed):
    """The planar rigid motions :math:`g = [[R(\\theta), (x, y)], [0, 1]]`, coordinates :math:`(x, y, \\theta)`;
    body velocity :math:`(v_x, v_y, \\omega)`, :math:`v_x = \\cos\\theta\\,\\dot x + \\sin\\theta\\,\\dot y`."""

    _kernel = _se2
    dim = matrix_size = 3
    point_dim = 2
    algebra_names = ("v_x", "v_y", "omega")
    chart_angles = (2,)
    angle_components = (2,)
    name = "SE(2)"

    def __init__(self, *names: Any):
        self.coordinate_names = c.coordinate_names(names, ("x", "y", "theta"), "SE(2)", "x, y, theta")

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        return _rigid_sym(_rot2_sym(q[2]), sp.Matrix([q[0], q[1]]))

    def from_coordinates(self, q: Any) -> np.ndarray:
        a = c.vector(q, "q", 3)
        co, si = np.cos(a[..., 2]), np.sin(a[..., 2])
        g = np.zeros(a.shape[:-1] + (3, 3))
        g[..., 0, 0], g[..., 0, 1], g[..., 1, 0], g[..., 1, 1] = co, -si, si, co
        g[..., 0, 2], g[..., 1, 2], g[..., 2, 2] = a[..., 0], a[..., 1], 1.0
        return g

    def to_coordinates(self, g: Any) -> np.ndarray:
        g = self.check(g)
        return np.stack([g[..., 0, 2], g[..., 1, 2], np.arctan2(g[..., 1, 0], g[..., 0, 0])], -1)


class SE3(_Closed):
    """The rigid motions of space, position :math:`(x, y, z)` and the Euler angles of ``seq`` (default
    'ZYX'); body velocity :math:`(v, \\omega)`, :math:`v = R^T\\dot t`, :math:`\\hat\\omega = R^T\\dot R`."""

    _kernel = _se3
    dim = 6
    matrix_size = 4
    point_dim = 3
    algebra_names = ("v_1", "v_2", "v_3", "omega_1", "omega_2", "omega_3")
    chart_angles = (3, 4, 5)

    def __init__(self, *names: Any, seq: str = "ZYX"):
        _euler._parse(seq)
        self.seq = seq
        self.coordinate_names = c.coordinate_names(
            names, ("x", "y", "z", "phi", "theta", "psi"), "SE(3)", "x, y, z and three Euler angles"
        )
        self.name = f"SE(3)[{seq}]"

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        return _rigid_sym(_euler_sym(q[3:], self.seq), sp.Matrix(q[:3]))

    @property
    def chart_reference(self) -> tuple[sp.Expr, ...]:
        return (sp.Integer(0),) * 3 + _euler_reference(self.seq)

    def from_coordinates(self, q: Any) -> np.ndarray:
        a = c.vector(q, "q", 6)
        g = np.zeros(a.shape[:-1] + (4, 4))
        g[..., :3, :3] = _euler.as_matrix(a[..., 3:], self.seq)
        g[..., :3, 3] = a[..., :3]
        g[..., 3, 3] = 1.0
        return g

    def to_coordinates(self, g: Any) -> np.ndarray:
        g = self.check(g)
        return np.concatenate([g[..., :3, 3], _euler.from_matrix(g[..., :3, :3], self.seq, on_singular="resolve")], -1)

    def _key(self) -> tuple:
        return self.coordinate_names + (self.seq,)


class SO2(LieGroup):
    """The circle as the rotations of the plane, one angle; ``(..., 2, 2)`` matrices, algebra the rate.

    The angle's integral is tracked on the universal cover by reconstructions (:attr:`angle_components`).
    """

    dim = 1
    matrix_size = point_dim = 2
    abelian = True
    algebra_names = ("omega",)
    chart_angles = (0,)
    angle_components = (0,)
    name = "SO(2)"

    def __init__(self, *names: Any):
        self.coordinate_names = c.coordinate_names(names, ("theta",), "SO(2)", "one angle")

    @property
    def basis(self) -> np.ndarray:
        return np.array([[[0.0, -1.0], [1.0, 0.0]]])

    def check(self, g: Any, name: str = "g") -> np.ndarray:
        g = c.matrix(g, name, 2)
        err = np.maximum(np.abs(g[..., 0, 0] - g[..., 1, 1]), np.abs(g[..., 0, 1] + g[..., 1, 0]))
        err = np.maximum(err, np.abs(g[..., 0, 0] ** 2 + g[..., 1, 0] ** 2 - 1.0))
        c.refuse_non_elements(err, name, "SO(2), a rotation [[cos, -sin], [sin, cos]]")
        return g

    def _rot(self, a: np.ndarray) -> np.ndarray:
        co, si = np.cos(a), np.sin(a)
        return np.stack([np.stack([co, -si], -1), np.stack([si, co], -1)], -2)

    def exp(self, u: Any) -> np.ndarray:
        return self._rot(c.angles(c.vector(u, "u", 1), "u")[..., 0])

    def log(self, g: Any) -> np.ndarray:
        g = self.check(g)
        return np.arctan2(g[..., 1, 0], g[..., 0, 0])[..., None]

    def compose(self, g: Any, h: Any) -> np.ndarray:
        return self.check(g, "g") @ self.check(h, "h")

    def inverse(self, g: Any) -> np.ndarray:
        return np.swapaxes(self.check(g), -1, -2).copy()

    def Ad(self, g: Any) -> np.ndarray:
        return np.ones(self.check(g).shape[:-2] + (1, 1))

    def ad(self, u: Any) -> np.ndarray:
        return np.zeros(c.vector(u, "u", 1).shape[:-1] + (1, 1))

    def right_jacobian(self, u: Any) -> np.ndarray:
        return np.ones(c.vector(u, "u", 1).shape[:-1] + (1, 1))

    left_jacobian = right_jacobian_inverse = left_jacobian_inverse = right_jacobian

    def random(self, rng: Any = None, size: Any = ()) -> np.ndarray:
        """Haar-uniform rotations (angle uniform on [-pi, pi))."""
        return self._rot(c.generator(rng).uniform(-np.pi, np.pi, c.batch_shape_of(size)))

    def sympy_basis(self) -> tuple[sp.ImmutableMatrix, ...]:
        return (sp.ImmutableMatrix([[0, -1], [1, 0]]),)

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        R = _rot2_sym(q[0])
        return R, R.T

    def from_coordinates(self, q: Any) -> np.ndarray:
        return self._rot(c.vector(q, "q", 1)[..., 0])

    def to_coordinates(self, g: Any) -> np.ndarray:
        return self.log(g)

    @property
    def closed_chart(self) -> bool:
        return True

    def _key(self) -> tuple:
        return self.coordinate_names


S1 = SO2


class Rn(LieGroup):
    """The translations of :math:`\\mathbb R^n`, as homogeneous ``(n+1, n+1)`` matrices :math:`[[I, t], [0, 1]]`;
    body velocity = the coordinate rates. ``Rn("u", "v")`` names the coordinates, ``Rn(3)`` gives ``q1..q3``."""

    abelian = True

    def __init__(self, *names: Any):
        if len(names) == 1 and isinstance(names[0], (int, np.integer)) and not isinstance(names[0], bool):
            n = int(names[0])
            if n < 1:
                raise InputError(f"Expected a dimension n >= 1 for Rn, got {n}.")
            names = tuple(f"q{i + 1}" for i in range(n))
        if not names:
            raise InputError("Expected at least one coordinate name (or the dimension) for Rn, got none.")
        self.coordinate_names = c.coordinate_names(names, [""] * len(names), "R^n", "one name a coordinate")
        self.dim = self.point_dim = len(self.coordinate_names)
        self.matrix_size = self.dim + 1
        self.name = f"R^{self.dim}"
        self.algebra_names = tuple(f"{n}_dot" for n in self.coordinate_names)

    @property
    def basis(self) -> np.ndarray:
        n = self.dim
        B = np.zeros((n, n + 1, n + 1))
        B[np.arange(n), np.arange(n), n] = 1.0
        return B

    def check(self, g: Any, name: str = "g") -> np.ndarray:
        g = c.matrix(g, name, self.matrix_size)
        target = self.identity()
        mask = np.ones((self.matrix_size, self.matrix_size), dtype=bool)
        mask[: self.dim, self.dim] = False
        err = np.abs(np.where(mask, g - target, 0.0)).max(axis=(-2, -1))
        c.refuse_non_elements(err, name, f"{self.name}, a homogeneous translation [[I, t], [0, 1]]")
        return g

    def _assemble(self, t: np.ndarray) -> np.ndarray:
        g = self.identity(t.shape[:-1])
        g[..., : self.dim, self.dim] = t
        return g

    def exp(self, u: Any) -> np.ndarray:
        return self._assemble(c.vector(u, "u", self.dim))

    def log(self, g: Any) -> np.ndarray:
        return self.check(g)[..., : self.dim, self.dim].copy()

    def compose(self, g: Any, h: Any) -> np.ndarray:
        return self._assemble(self.log(g) + self.log(h))

    def inverse(self, g: Any) -> np.ndarray:
        return self._assemble(-self.log(g))

    def act(self, g: Any, x: Any) -> np.ndarray:
        return c.vector(x, "x", self.dim) + self.log(g)

    def Ad(self, g: Any) -> np.ndarray:
        return c.eye(self.dim, self.check(g).shape[:-2])

    def ad(self, u: Any) -> np.ndarray:
        return np.zeros(c.vector(u, "u", self.dim).shape[:-1] + (self.dim, self.dim))

    def right_jacobian(self, u: Any) -> np.ndarray:
        return c.eye(self.dim, c.vector(u, "u", self.dim).shape[:-1])

    left_jacobian = right_jacobian_inverse = left_jacobian_inverse = right_jacobian

    def random(self, rng: Any = None, size: Any = ()) -> np.ndarray:
        """Standard normal translations (R^n has no invariant probability measure: the law is a choice)."""
        return self.exp(c.generator(rng).standard_normal(c.batch_shape_of(size) + (self.dim,)))

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        return _rigid_sym(sp.eye(self.dim), sp.Matrix(q))

    def from_coordinates(self, q: Any) -> np.ndarray:
        return self.exp(q)

    def to_coordinates(self, g: Any) -> np.ndarray:
        return self.log(g)

    @property
    def closed_chart(self) -> bool:
        return True

    def _key(self) -> tuple:
        return self.coordinate_names


_NAMED = {
    "S1": SO2,
    "SO2": SO2,
    "SO(2)": SO2,
    "S^1": SO2,
    "SE2": SE2,
    "SE(2)": SE2,
    "SO3": SO3,
    "SO(3)": SO3,
    "SE3": SE3,
    "SE(3)": SE3,
}


def named_group(name: Any, *names: Any) -> LieGroup:
    """A group given by name (``"SO3"``, ``"SE2"``, ``"SE3"``, ``"S1"``/``"SO2"``, case-insensitive), or a
    :class:`LieGroup` returned as it is: the one place where a user's text names a group."""
    if isinstance(name, LieGroup):
        return name
    key = str(name).upper().replace(" ", "")
    if key not in _NAMED:
        raise InputError(
            f"Expected `group` to be a Lie group (geomech.lie.SE2(...), ...) or one of 'S1' (or "
            f"'SO2'), 'SE2', 'SO3', 'SE3', got {name!r}."
        )
    return _NAMED[key](*names)
