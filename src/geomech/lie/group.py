r"""The abstract matrix Lie group: one API for every group in geomech, vectorised over leading batch axes.

A group is an immutable value. Elements are ``(..., n, n)`` matrices (``n`` = :attr:`LieGroup.matrix_size`),
algebra elements ``(..., k)`` coordinate vectors in a fixed basis :math:`b_1, \dots, b_k`
(:math:`\hat u = \sum_a u_a b_a`, ``k`` = :attr:`LieGroup.dim`). Every operation takes any leading batch
axes and broadcasts them where it takes two arguments, as jaxlie and manif do:

=========================  =================================================================================
``exp(u)``, ``log(g)``     the exponential map and its principal inverse
``compose(g, h)``          :math:`g h`; ``inverse(g)``: :math:`g^{-1}`; ``identity(batch_shape)``
``act(g, x)``              the action on points (rotations on vectors, rigid motions on points)
``Ad(g)``, ``ad(u)``       matrices of :math:`\mathrm{Ad}_g` and :math:`\mathrm{ad}_u v = [u, v]`
``coad(g, mu)``            :math:`\mathrm{Ad}^*_{g^{-1}}\mu = \mathrm{Ad}_{g^{-1}}^T\mu`
``right_jacobian(u)``      :math:`\exp(u + \delta) = \exp(u)\exp(J_r(u)\delta) + O(\delta^2)`; also
                           ``left_jacobian`` (:math:`\exp(J_l(u)\delta)\exp(u)`) and both inverses
``rplus(g, u)``            :math:`g\exp(u)`; ``rminus(g, h)``: :math:`\log(h^{-1}g)`, so
                           ``rplus(h, rminus(g, h)) == g``
``interpolate(g, h, s)``   :math:`g\exp(s\log(g^{-1}h))`, the geodesic of the left-invariant structure
``random(rng, size)``      random elements (Haar on compact groups)
=========================  =================================================================================

The base class computes everything from the basis by matrix functions (``expm``, ``logm`` and Van Loan's
block exponential for the Jacobians, :math:`J_r(u) = \int_0^1 e^{-s\,\mathrm{ad}_u}ds`); the concrete groups
(:mod:`geomech.lie.groups`) override them with closed forms. The same group carries its chart for the
mechanics (coordinate names, the element as a sympy matrix of the coordinates, which coordinates are
angles): :class:`geomech.symbolic.GroupChart` is its symbolic twin.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from . import _common as c

__all__ = ["LieGroup", "Product"]


class LieGroup:
    """A matrix Lie group with a basis of its algebra and a coordinate chart (abstract: see the subclasses).

    Attributes
    ----------
    name : str
    dim : int
        Dimension :math:`k` of the algebra.
    matrix_size : int
        Size :math:`n` of the matrices representing elements.
    point_dim : int
        Dimension of the points :meth:`act` acts on.
    abelian : bool
    coordinate_names : tuple of str
        Names of the chart coordinates (``dim`` of them).
    algebra_names : tuple of str
        Names of the body-velocity components.
    chart_angles : tuple of int
        Indices of the chart coordinates that are angles.
    angle_components : tuple of int
        Algebra components whose time integral is an unwrapped rotation angle on the universal cover (the
        homomorphisms SO(2) -> R and SE(2) -> SO(2) -> R): tracked by reconstructions so that a heading that
        turns many times is not wrapped.
    """

    name: str = "G"
    dim: int
    matrix_size: int
    point_dim: int
    abelian: bool = False
    coordinate_names: tuple[str, ...] = ()
    algebra_names: tuple[str, ...] = ()
    chart_angles: tuple[int, ...] = ()
    angle_components: tuple[int, ...] = ()

    # -- the basis and the algebra ------------------------------------------------------------------
    @property
    def basis(self) -> np.ndarray:
        """``(k, n, n)``: the matrices :math:`b_a` (the hat map of the unit vectors)."""
        return self.hat(np.eye(self.dim))

    def hat(self, u: Any) -> np.ndarray:
        """:math:`\\hat u = \\sum_a u_a b_a`, shape ``(..., n, n)``."""
        return np.tensordot(c.vector(u, "u", self.dim), self._basis_array, axes=([-1], [0]))

    def vee(self, X: Any) -> np.ndarray:
        """The inverse of :meth:`hat` (components of the projection of ``X`` on the algebra)."""
        X = c.matrix(X, "X", self.matrix_size)
        return X.reshape(X.shape[:-2] + (-1,)) @ self._vee_array.T

    @property
    def _basis_array(self) -> np.ndarray:
        cached = self.__dict__.get("_basis_cache")
        if cached is None:
            cached = np.asarray(self.basis, dtype=float)
            self.__dict__["_basis_cache"] = cached
        return cached

    @property
    def _vee_array(self) -> np.ndarray:
        cached = self.__dict__.get("_vee_cache")
        if cached is None:
            cached = np.linalg.pinv(self._basis_array.reshape(self.dim, -1).T)
            self.__dict__["_vee_cache"] = cached
        return cached

    @property
    def structure_constants(self) -> np.ndarray:
        """``C[a, b, d]`` with :math:`[b_b, b_d] = C^a_{bd} b_a`."""
        cached = self.__dict__.get("_structure_cache")
        if cached is None:
            B = self._basis_array
            comm = np.einsum("bij,djk->bdik", B, B) - np.einsum("dij,bjk->bdik", B, B)
            cached = np.einsum("ap,bdp->abd", self._vee_array, comm.reshape(self.dim, self.dim, -1))
            self.__dict__["_structure_cache"] = cached
        return cached

    def bracket(self, u: Any, v: Any) -> np.ndarray:
        """:math:`[u, v]`, batch axes broadcast."""
        return np.einsum("...ab,...b->...a", self.ad(u), c.vector(v, "v", self.dim))

    def ad(self, u: Any) -> np.ndarray:
        """Matrix of :math:`\\mathrm{ad}_u v = [u, v]`: ``ad(u)[a, d] = C[a, b, d] u_b``."""
        return np.einsum("abd,...b->...ad", self.structure_constants, c.vector(u, "u", self.dim))

    # -- the group ----------------------------------------------------------------------------------
    def check(self, g: Any, name: str = "g") -> np.ndarray:
        """``g`` as a float array of elements, or :class:`~geomech.errors.InputError` naming ``name``."""
        return c.matrix(g, name, self.matrix_size)

    def identity(self, batch_shape: Any = ()) -> np.ndarray:
        """Identity elements, shape ``(*batch_shape, n, n)``."""
        return c.eye(self.matrix_size, batch_shape)

    def exp(self, u: Any) -> np.ndarray:
        from scipy.linalg import expm

        return expm(self.hat(u))

    def log(self, g: Any) -> np.ndarray:
        """The principal logarithm (real part of ``scipy.linalg.logm``, element by element)."""
        from scipy.linalg import logm

        g = self.check(g)
        flat = g.reshape((-1,) + g.shape[-2:])
        out = np.array([np.real(logm(x)) for x in flat]).reshape(g.shape)
        return self.vee(out)

    def compose(self, g: Any, h: Any) -> np.ndarray:
        return self.check(g, "g") @ self.check(h, "h")

    def inverse(self, g: Any) -> np.ndarray:
        return np.linalg.inv(self.check(g))

    def act(self, g: Any, x: Any) -> np.ndarray:
        """The linear action :math:`g x` on ``(..., n)`` vectors."""
        return np.einsum("...ij,...j->...i", self.check(g), c.vector(x, "x", self.point_dim))

    def Ad(self, g: Any) -> np.ndarray:
        """Matrix of :math:`\\mathrm{Ad}_g`, :math:`(\\mathrm{Ad}_g u)^\\wedge = g\\hat u g^{-1}`."""
        g = self.check(g)
        conj = g[..., None, :, :] @ self._basis_array @ np.linalg.inv(g)[..., None, :, :]
        return np.swapaxes(self.vee(conj), -1, -2)

    def coad(self, g: Any, mu: Any) -> np.ndarray:
        """:math:`\\mathrm{Ad}^*_{g^{-1}}\\mu = \\mathrm{Ad}_{g^{-1}}^T\\mu` (body momentum to spatial)."""
        return np.einsum("...ji,...j->...i", self.Ad(self.inverse(g)), c.vector(mu, "mu", self.dim))

    def random(self, rng: Any = None, size: Any = ()) -> np.ndarray:
        """``exp`` of standard normal algebra vectors (the concrete groups draw Haar-uniform rotations)."""
        shape = c.batch_shape_of(size)
        return self.exp(c.generator(rng).standard_normal(shape + (self.dim,)))

    # -- Jacobians of exp ---------------------------------------------------------------------------
    def right_jacobian(self, u: Any) -> np.ndarray:
        """:math:`J_r(u) = \\int_0^1 e^{-s\\,\\mathrm{ad}_u}ds`, by the exponential of a block matrix."""
        from scipy.linalg import expm

        adu = self.ad(u)
        k = self.dim
        M = np.zeros(adu.shape[:-2] + (2 * k, 2 * k))
        M[..., :k, :k] = -adu
        M[..., :k, k:] = np.eye(k)
        return expm(M)[..., :k, k:]

    def left_jacobian(self, u: Any) -> np.ndarray:
        """:math:`J_l(u) = J_r(-u)`."""
        return self.right_jacobian(-c.vector(u, "u", self.dim))

    def right_jacobian_inverse(self, u: Any) -> np.ndarray:
        """:math:`J_r(u)^{-1}`: :math:`g = g_0\\exp(u)` has :math:`g^{-1}\\dot g = \\xi` iff
        :math:`\\dot u = J_r(u)^{-1}\\xi`."""
        return np.linalg.inv(self.right_jacobian(u))

    def left_jacobian_inverse(self, u: Any) -> np.ndarray:
        return np.linalg.inv(self.left_jacobian(u))

    # -- on-manifold calculus (manif's plus and minus) ------------------------------------------------
    def rplus(self, g: Any, u: Any) -> np.ndarray:
        """:math:`g\\exp(u)`."""
        return self.compose(g, self.exp(u))

    def rminus(self, g: Any, h: Any) -> np.ndarray:
        """:math:`\\log(h^{-1}g)`, the body-frame difference: ``rplus(h, rminus(g, h)) == g``."""
        return self.log(self.compose(self.inverse(h), g))

    def interpolate(self, g: Any, h: Any, s: Any) -> np.ndarray:
        """:math:`g\\exp(s\\log(g^{-1}h))`: ``g`` at ``s = 0``, ``h`` at ``s = 1`` (``s`` broadcasts)."""
        u = self.rminus(h, g)
        s = np.asarray(s, dtype=float)
        return self.rplus(g, s[..., None] * u)

    # -- the chart (for the mechanics and its symbolic twin) -------------------------------------------
    def sympy_basis(self) -> tuple[sp.ImmutableMatrix, ...]:
        """The basis as exact sympy matrices."""
        return tuple(sp.ImmutableMatrix(sp.nsimplify(sp.Matrix(b), rational=True)) for b in self._basis_array)

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        """``(g(q), g(q)^{-1})`` as exact sympy matrices of the chart coordinates ``q``."""
        raise InputError(f"{self.name} has no coordinate chart: build it with one (see geomech.lie.MatrixGroup).")

    @property
    def chart_reference(self) -> tuple[sp.Expr, ...]:
        """A regular point of the chart (exact values): the identity unless the chart is singular there."""
        return (sp.Integer(0),) * self.dim

    @property
    def chart_identity(self) -> tuple[sp.Expr, ...]:
        """Coordinates of the identity."""
        return (sp.Integer(0),) * self.dim

    def from_coordinates(self, q: Any) -> np.ndarray:
        """The elements at chart coordinates ``q`` ``(..., k)`` in closed form (a generic group reads its
        chart through its symbolic twin, :meth:`geomech.symbolic.GroupChart.from_coordinates`)."""
        raise NotImplementedError

    def to_coordinates(self, g: Any) -> np.ndarray:
        """Chart coordinates of ``g`` in closed form (angles wrapped to (-pi, pi])."""
        raise NotImplementedError

    @property
    def closed_chart(self) -> bool:
        """Whether :meth:`from_coordinates` and :meth:`to_coordinates` have closed forms."""
        return False

    # -- products, equality ---------------------------------------------------------------------------
    def __mul__(self, other: Any) -> LieGroup:
        if not isinstance(other, LieGroup):
            return NotImplemented
        return Product(self, other)

    def _key(self) -> tuple:
        return (id(self),)

    def __eq__(self, other: Any) -> bool:
        return type(self) is type(other) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash((type(self).__name__,) + self._key())

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(map(repr, self.coordinate_names))})"


class Product(LieGroup):
    """The direct product :math:`G_1\\times\\dots\\times G_m`: block-diagonal matrices, algebra vectors and
    coordinates concatenated, every operation factor by factor (``G1 * G2`` builds one)."""

    def __init__(self, *factors: LieGroup):
        flat: list[LieGroup] = []
        for f in factors:
            if not isinstance(f, LieGroup):
                raise InputError(f"Expected the factors of a product to be Lie groups, got {f!r}.")
            flat.extend(f.factors if isinstance(f, Product) else [f])
        if len(flat) < 2:
            raise InputError("Expected at least two factors for a product group.")
        self.factors: tuple[LieGroup, ...] = tuple(flat)
        self.name = " x ".join(f.name for f in flat)
        self.dim = sum(f.dim for f in flat)
        self.matrix_size = sum(f.matrix_size for f in flat)
        self.point_dim = sum(f.point_dim for f in flat)
        self.abelian = all(f.abelian for f in flat)
        self.coordinate_names = sum((f.coordinate_names for f in flat), ())
        if len(set(self.coordinate_names)) != len(self.coordinate_names):
            raise InputError(
                f"Expected distinct coordinate names in the product {self.name}, got "
                f"{list(self.coordinate_names)}: name the factors' coordinates apart."
            )
        self.algebra_names = sum((f.algebra_names for f in flat), ())
        self._k = np.cumsum([0] + [f.dim for f in flat])
        self._n = np.cumsum([0] + [f.matrix_size for f in flat])
        self._p = np.cumsum([0] + [f.point_dim for f in flat])
        self.chart_angles = sum((tuple(int(o) + i for i in f.chart_angles) for f, o in zip(flat, self._k)), ())
        self.angle_components = sum((tuple(int(o) + i for i in f.angle_components) for f, o in zip(flat, self._k)), ())

    # -- splitting and assembling ----------------------------------------------------------------------
    def _split_u(self, u: Any, name: str = "u") -> list[np.ndarray]:
        u = c.vector(u, name, self.dim)
        return [u[..., a:b] for a, b in zip(self._k[:-1], self._k[1:])]

    def _split_g(self, g: Any, name: str = "g") -> list[np.ndarray]:
        g = c.matrix(g, name, self.matrix_size)
        return [g[..., a:b, a:b] for a, b in zip(self._n[:-1], self._n[1:])]

    def _blocks(self, parts: Sequence[np.ndarray], offsets: np.ndarray) -> np.ndarray:
        shape = np.broadcast_shapes(*[p.shape[:-2] for p in parts])
        out = np.zeros(shape + (int(offsets[-1]), int(offsets[-1])))
        for p, a, b in zip(parts, offsets[:-1], offsets[1:]):
            out[..., a:b, a:b] = p
        return out

    def _on_g(self, method: str, g: Any, offsets: np.ndarray) -> np.ndarray:
        return self._blocks([getattr(f, method)(x) for f, x in zip(self.factors, self._split_g(g))], offsets)

    def _on_u(self, method: str, u: Any, offsets: np.ndarray) -> np.ndarray:
        return self._blocks([getattr(f, method)(x) for f, x in zip(self.factors, self._split_u(u))], offsets)

    # -- the API ------------------------------------------------------------------------------------------
    @property
    def basis(self) -> np.ndarray:
        B = np.zeros((self.dim, self.matrix_size, self.matrix_size))
        for f, a, b, n0, n1 in zip(self.factors, self._k[:-1], self._k[1:], self._n[:-1], self._n[1:]):
            B[a:b, n0:n1, n0:n1] = f.basis
        return B

    def check(self, g: Any, name: str = "g") -> np.ndarray:
        g = c.matrix(g, name, self.matrix_size)
        for f, a, b in zip(self.factors, self._n[:-1], self._n[1:]):
            f.check(g[..., a:b, a:b], name)
            off = g[..., a:b, :].copy()
            off[..., :, a:b] = 0.0
            c.refuse_non_elements(np.abs(off).max(axis=(-2, -1)), name, f"{self.name} (block diagonal)")
        return g

    def exp(self, u: Any) -> np.ndarray:
        return self._on_u("exp", u, self._n)

    def log(self, g: Any) -> np.ndarray:
        return np.concatenate([f.log(x) for f, x in zip(self.factors, self._split_g(g))], -1)

    def compose(self, g: Any, h: Any) -> np.ndarray:
        return self._blocks(
            [f.compose(x, y) for f, x, y in zip(self.factors, self._split_g(g, "g"), self._split_g(h, "h"))], self._n
        )

    def inverse(self, g: Any) -> np.ndarray:
        return self._on_g("inverse", g, self._n)

    def identity(self, batch_shape: Any = ()) -> np.ndarray:
        return c.eye(self.matrix_size, batch_shape)

    def act(self, g: Any, x: Any) -> np.ndarray:
        x = c.vector(x, "x", self.point_dim)
        parts = [
            f.act(gi, x[..., a:b]) for f, gi, a, b in zip(self.factors, self._split_g(g), self._p[:-1], self._p[1:])
        ]
        shape = np.broadcast_shapes(*[p.shape[:-1] for p in parts])
        return np.concatenate([np.broadcast_to(p, shape + p.shape[-1:]) for p in parts], -1)

    def Ad(self, g: Any) -> np.ndarray:
        return self._on_g("Ad", g, self._k)

    def ad(self, u: Any) -> np.ndarray:
        return self._on_u("ad", u, self._k)

    def right_jacobian(self, u: Any) -> np.ndarray:
        return self._on_u("right_jacobian", u, self._k)

    def left_jacobian(self, u: Any) -> np.ndarray:
        return self._on_u("left_jacobian", u, self._k)

    def right_jacobian_inverse(self, u: Any) -> np.ndarray:
        return self._on_u("right_jacobian_inverse", u, self._k)

    def left_jacobian_inverse(self, u: Any) -> np.ndarray:
        return self._on_u("left_jacobian_inverse", u, self._k)

    def random(self, rng: Any = None, size: Any = ()) -> np.ndarray:
        rng = c.generator(rng)
        return self._blocks([f.random(rng, size) for f in self.factors], self._n)

    # -- the chart ------------------------------------------------------------------------------------------
    def sympy_basis(self) -> tuple[sp.ImmutableMatrix, ...]:
        out = []
        for f, n0 in zip(self.factors, self._n[:-1]):
            for b in f.sympy_basis():
                m = sp.zeros(self.matrix_size)
                m[int(n0) : int(n0) + f.matrix_size, int(n0) : int(n0) + f.matrix_size] = b
                out.append(sp.ImmutableMatrix(m))
        return tuple(out)

    def sympy_element(self, q: Sequence[sp.Expr]) -> tuple[sp.Matrix, sp.Matrix]:
        parts = [f.sympy_element(list(q[a:b])) for f, a, b in zip(self.factors, self._k[:-1], self._k[1:])]
        return sp.diag(*[p[0] for p in parts]), sp.diag(*[p[1] for p in parts])

    @property
    def chart_reference(self) -> tuple[sp.Expr, ...]:
        return sum((f.chart_reference for f in self.factors), ())

    @property
    def chart_identity(self) -> tuple[sp.Expr, ...]:
        return sum((f.chart_identity for f in self.factors), ())

    @property
    def closed_chart(self) -> bool:
        return all(f.closed_chart for f in self.factors)

    def from_coordinates(self, q: Any) -> np.ndarray:
        return self._blocks([f.from_coordinates(x) for f, x in zip(self.factors, self._split_u(q, "q"))], self._n)

    def to_coordinates(self, g: Any) -> np.ndarray:
        return np.concatenate([f.to_coordinates(x) for f, x in zip(self.factors, self._split_g(g))], -1)

    def _key(self) -> tuple:
        return self.factors

    def __repr__(self) -> str:
        return " * ".join(map(repr, self.factors))
