r"""The reduced phase space of a left-invariant system on T*SO(3) as objects (sections 5.1-5.2 of the
Serret-Andoyer paper): the stationary subgroup of the momentum, the momentum sphere (the coadjoint orbit) with
its Kostant-Kirillov symplectic forms, and the pull-back of a form by a chart, which decides whether the chart's
coordinates are canonical.

- Proposition 1: the stationary subgroup :math:`G_p = \{R : \mathrm{Ad}^*_{R^{-1}} p = p\}` of a spatial
  momentum :math:`p \ne 0` is the one-parameter group of rotations about :math:`p` (:class:`StationarySubgroup`;
  on so(3)* ≅ R^3, :math:`\mathrm{Ad}^*_{R^{-1}} p = R p`).
- The reduced space :math:`M_p/G_p` is the coadjoint orbit :math:`O_p = \{m : |m| = |p|\}`, reached by the
  projection :math:`\pi_p(R, m) = \mathrm{Ad}^*_R J(R, m) = m` (:meth:`CoadjointOrbit.project`).
- Eq. (19): :math:`\omega^\pm_m(v\times m, w\times m) = \pm\, m\cdot(v\times w)`. For tangent vectors
  :math:`a = v\times m`, :math:`b = w\times m` this is :math:`\pm (a\times b)\cdot m / |m|^2` (as
  :math:`a\times b = (m\cdot(v\times w))\, m`), which :meth:`CoadjointOrbit.kostant_kirillov` evaluates.
- Proposition 3: the Serret-Andoyer chart :math:`U_p` pulls :math:`\omega^-` back to :math:`dl\wedge dL`
  (:meth:`CoadjointOrbit.pullback` gives the coefficient for any chart, symbolically).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError
from ..lie import so3
from ..symbolic.simplify import simplify_expr

__all__ = ["CoadjointOrbit", "StationarySubgroup"]


def _sign(sign: str) -> float:
    if sign not in ("-", "+"):
        raise InputError(f"Expected `sign` to be '-' (the left form, the seed's) or '+', got {sign!r}.")
    return -1.0 if sign == "-" else 1.0


@dataclass(frozen=True)
class StationarySubgroup:
    """The stationary subgroup :math:`G_p` of a nonzero spatial momentum ``p`` (Proposition 1): the rotations
    about ``p``."""

    p: np.ndarray

    def __post_init__(self) -> None:
        p = V.exact_shape(self.p, "p", (3,))
        if not np.linalg.norm(p) > 0:
            raise InputError("Expected a nonzero momentum `p`: every rotation fixes p = 0 (G_p is all of SO(3)).")
        object.__setattr__(self, "p", p)

    @property
    def axis(self) -> np.ndarray:
        """The unit vector along ``p``, the generator of :math:`G_p`."""
        return self.p / np.linalg.norm(self.p)

    def element(self, angle: Any) -> np.ndarray:
        """The rotation by ``angle`` (radians, any shape) about ``p``, shape ``(..., 3, 3)``."""
        angle = np.asarray(V.finite(angle, "angle"), dtype=float)
        return so3.exp(angle[..., None] * self.axis)

    def contains(self, R: Any, tol: float = 1e-12) -> np.ndarray:
        """Whether each rotation ``R`` (``(..., 3, 3)``) keeps ``p``: :math:`|\\mathrm{Ad}^*_{R^{-1}} p - p| \\le`
        ``tol`` :math:`|p|`."""
        R = V.rotation_matrix(R, "R")
        moved = np.einsum("...ij,j->...i", R, self.p)
        return np.linalg.norm(moved - self.p, axis=-1) <= tol * np.linalg.norm(self.p)


@dataclass(frozen=True)
class CoadjointOrbit:
    """The momentum sphere :math:`O_p = \\{m : |m| = G\\}`, the coadjoint orbit of so(3)* through a momentum of
    magnitude ``G`` and the reduced phase space of Theorem 3, with its Kostant-Kirillov forms (eq. 19)."""

    G: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "G", V.positive_scalar(self.G, "G"))

    def contains(self, m: Any, tol: float = 1e-12) -> np.ndarray:
        """Whether each ``m`` (``(..., 3)``) lies on the sphere, to ``tol`` relative to ``G``."""
        m = V.trailing_shape(m, "m", (3,))
        return np.abs(np.linalg.norm(m, axis=-1) - self.G) <= tol * self.G

    @staticmethod
    def tangent(m: Any, v: Any) -> np.ndarray:
        """The tangent vector :math:`\\hat v_{so(3)^*}(m) = v\\times m` of the infinitesimal coadjoint action."""
        return np.cross(V.trailing_shape(v, "v", (3,)), V.trailing_shape(m, "m", (3,)))

    def project(self, R: Any, m: Any) -> np.ndarray:
        """:math:`\\pi_p(R, m) = \\mathrm{Ad}^*_R J(R, m) = m`: the point of the orbit of a state ``(R, m)`` of the
        level set :math:`M_p` (checked: ``|R m|`` must be ``G``)."""
        R = V.rotation_matrix(R, "R")
        m = V.trailing_shape(m, "m", (3,))
        p = np.einsum("...ij,...j->...i", R, m)
        if not np.all(np.abs(np.linalg.norm(p, axis=-1) - self.G) <= 1e-10 * self.G):
            raise InputError(f"Expected states on the momentum level set |R m| = G = {self.G:g}.")
        return np.asarray(m, dtype=float).copy()

    def kostant_kirillov(self, m: Any, a: Any, b: Any, sign: str = "-", tol: float = 1e-9) -> np.ndarray:
        """:math:`\\omega^\\pm_m(a, b) = \\pm (a\\times b)\\cdot m / |m|^2` for tangent vectors ``a``, ``b`` at
        ``m`` (arrays ``(..., 3)``, broadcast); eq. (19) with :math:`a = v\\times m`, :math:`b = w\\times m`.

        Raises
        ------
        InputError
            A point off the sphere, or a vector not tangent to it (``|a . m| > tol |a| |m|``).
        """
        s = _sign(sign)
        m = V.trailing_shape(m, "m", (3,))
        a = V.trailing_shape(a, "a", (3,))
        b = V.trailing_shape(b, "b", (3,))
        if not np.all(self.contains(m, 1e-9)):
            raise InputError(f"Expected points of the momentum sphere |m| = G = {self.G:g}.")
        norm_m = np.linalg.norm(m, axis=-1)
        for name, x in (("a", a), ("b", b)):
            if np.any(np.abs(np.einsum("...i,...i->...", x, m)) > tol * np.linalg.norm(x, axis=-1) * norm_m):
                raise InputError(f"Expected `{name}` tangent to the sphere at m (orthogonal to m).")
        return s * np.einsum("...i,...i->...", np.cross(a, b), m) / norm_m**2

    @staticmethod
    def pullback(chart: Any, coordinates: Sequence[sp.Symbol], sign: str = "-") -> sp.Expr:
        """The coefficient f of the pull-back :math:`U^*\\omega^\\pm = f\\, dx\\wedge dy` by a chart
        :math:`m = U(x, y)` (a sympy 3-vector in the two ``coordinates``), simplified: the chart's coordinates are
        canonical for the form exactly when f = 1 (Proposition 3: the Serret-Andoyer chart and the left form)."""
        U = sp.Matrix(chart)
        if U.shape != (3, 1) or len(coordinates) != 2:
            raise InputError("Expected a chart m = U(x, y): a sympy 3-vector in two coordinates.")
        x, y = coordinates
        a, b = U.diff(x), U.diff(y)
        value = sp.Integer(int(_sign(sign))) * (a.cross(b)).dot(U) / U.dot(U)
        return simplify_expr(value)
