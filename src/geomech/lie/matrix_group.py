"""Any matrix Lie group, numerically: from a basis of its algebra (and, optionally, a coordinate chart).

The closed-form modules (:mod:`~geomech.lie.so3`, :mod:`~geomech.lie.se2`, :mod:`~geomech.lie.se3`) are
faster; this one serves the groups they do not cover (SE(3) in a user's chart, R^n, products such as
SE(2) x S^1) with the same operations that Lie-group integrators need: ``exp``, ``compose``, ``inverse``,
``ad`` and the inverse of the right Jacobian of ``exp``, computed exactly by matrix exponentials:

.. math::

    J_r(u) = \\int_0^1 e^{-s\\,\\mathrm{ad}_u}\\,ds
           = \\Big[\\exp\\begin{pmatrix}-\\mathrm{ad}_u & I\\\\ 0 & 0\\end{pmatrix}\\Big]_{12},
    \\qquad \\frac{d}{dt}\\exp(u) = \\exp(u)\\,\\widehat{J_r(u)\\dot u}

(Van Loan 1978 for the block exponential; Iserles, Munthe-Kaas, Norsett, Zanna 2000 for :math:`J_r`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.linalg import expm

from ..errors import ConvergenceError, InputError

__all__ = ["MatrixLieGroup"]


class MatrixLieGroup:
    """A matrix Lie group given by a basis :math:`b_1, \\dots, b_k` of its algebra (``(k, n, n)``).

    Parameters
    ----------
    name : str
    basis : array_like, shape (k, n, n)
        Linearly independent matrices, closed under the commutator (checked).
    chart : callable, optional
        ``chart(q) -> (n, n)``: the element at coordinates ``q`` (``(k,)``), for :meth:`to_coordinates`.
    chart_jacobian : callable, optional
        ``chart_jacobian(q) -> (n, n, k)``: its derivatives (Gauss-Newton in :meth:`to_coordinates`).
    reference : array_like, optional
        Coordinates of a regular point of the chart (default zeros), where the search for coordinates starts.
    coordinate_names : sequence of str, optional
        Names of the chart coordinates (for labels).

    Notes
    -----
    Elements are ``(n, n)`` matrices; algebra elements are coordinate vectors ``u`` with
    :math:`\\hat u = \\sum_a u_a b_a`. ``angle_component`` is None: the unwrapped angles of SE(2) and S^1
    are the closed-form groups' business; coordinates read off a path by :meth:`to_coordinates` are
    continuous along it (angles not wrapped).
    """

    angle_component = None

    def __init__(self, name: str, basis: Any, *, chart: Callable[[np.ndarray], np.ndarray] | None = None,
                 chart_jacobian: Callable[[np.ndarray], np.ndarray] | None = None, reference: Any = None,
                 coordinate_names: Any = None):
        B = np.asarray(basis, dtype=float)
        if B.ndim != 3 or B.shape[1] != B.shape[2] or B.shape[0] < 1:
            raise InputError(f"Expected `basis` of shape (k, n, n), got {B.shape}.")
        self.name, self.dim, self.size = str(name), B.shape[0], B.shape[1]
        self._B = B
        flat = B.reshape(self.dim, -1).T  # (n*n, k)
        if np.linalg.matrix_rank(flat) < self.dim:
            raise InputError(f"The basis of {name} is linearly dependent.")
        self._vee = np.linalg.pinv(flat)
        # structure constants [b_b, b_d] = C[a, b, d] b_a; a basis not closed under brackets is no algebra
        comm = np.einsum("bij,djk->bdik", B, B) - np.einsum("dij,bjk->bdik", B, B)
        C = np.einsum("ap,bdp->abd", self._vee, comm.reshape(self.dim, self.dim, -1))
        resid = np.abs(np.einsum("abd,aij->bdij", C, B) - comm).max()
        if resid > 1e-10 * max(1.0, np.abs(B).max() ** 2):
            raise InputError(f"The basis of {name} is not closed under the commutator (residual {resid:.3g}): "
                             "it does not span a Lie algebra.")
        self._C = C
        self.abelian = bool(np.abs(C).max() < 1e-14)
        self._chart, self._chart_jacobian = chart, chart_jacobian
        self.reference = np.zeros(self.dim) if reference is None else np.asarray(reference, dtype=float)
        self.coordinate_names = None if coordinate_names is None else tuple(map(str, coordinate_names))

    # -- algebra ------------------------------------------------------------------------------------
    def hat(self, u: Any) -> np.ndarray:
        return np.tensordot(np.asarray(u, dtype=float), self._B, axes=([-1], [0]))

    def vee(self, X: Any) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        return X.reshape(X.shape[:-2] + (-1,)) @ self._vee.T

    def ad(self, u: Any) -> np.ndarray:
        """Matrix of :math:`\\mathrm{ad}_u v = [u, v]`: ``ad(u)[a, d] = C[a, b, d] u_b``."""
        return np.einsum("abd,...b->...ad", self._C, np.asarray(u, dtype=float))

    # -- group --------------------------------------------------------------------------------------
    def identity(self) -> np.ndarray:
        return np.eye(self.size)

    def exp(self, u: Any) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            return expm(self.hat(u))
        return np.array([expm(X) for X in self.hat(u).reshape((-1, self.size, self.size))]).reshape(
            u.shape[:-1] + (self.size, self.size))

    def compose(self, g: Any, h: Any) -> np.ndarray:
        return np.asarray(g, dtype=float) @ np.asarray(h, dtype=float)

    def inverse(self, g: Any) -> np.ndarray:
        return np.linalg.inv(np.asarray(g, dtype=float))

    def Ad(self, g: Any) -> np.ndarray:
        """Matrix of :math:`\\mathrm{Ad}_g`, :math:`(\\mathrm{Ad}_g u)^\\wedge = g\\hat u g^{-1}`."""
        g = np.asarray(g, dtype=float)
        conj = g[..., None, :, :] @ self._B @ np.linalg.inv(g)[..., None, :, :]  # (..., k, n, n)
        return np.swapaxes(self.vee(conj), -1, -2)

    def right_jacobian(self, u: Any) -> np.ndarray:
        """:math:`J_r(u) = \\int_0^1 e^{-s\\,\\mathrm{ad}_u} ds`, by the exponential of a block matrix."""
        u = np.asarray(u, dtype=float)
        k = self.dim
        out = np.empty(u.shape[:-1] + (k, k))
        for idx in np.ndindex(u.shape[:-1]):
            M = np.zeros((2 * k, 2 * k))
            M[:k, :k] = -self.ad(u[idx])
            M[:k, k:] = np.eye(k)
            out[idx] = expm(M)[:k, k:]
        return out

    def dexpinv(self, u: Any) -> np.ndarray:
        """:math:`J_r(u)^{-1}`: :math:`g = g_0\\exp(u)` has :math:`g^{-1}\\dot g = \\xi` iff
        :math:`\\dot u = J_r(u)^{-1}\\xi` (singular where ``ad_u`` has an eigenvalue :math:`2\\pi i m`, ``m != 0``)."""
        return np.linalg.inv(self.right_jacobian(u))

    # -- coordinates --------------------------------------------------------------------------------
    def from_coordinates(self, q: Any) -> np.ndarray:
        """The element at chart coordinates ``q`` (``(..., k)``)."""
        if self._chart is None:
            raise InputError(f"{self.name} was built without a chart: give `chart`.")
        return np.asarray(self._chart(np.asarray(q, dtype=float)), dtype=float)

    def to_coordinates(self, g: Any, *, start: Any = None, tol: float = 1e-12, maxiter: int = 50) -> np.ndarray:
        """Chart coordinates of the elements ``g`` (``(..., n, n)``), continuous along the leading axis.

        Gauss-Newton on :math:`\\|chart(q) - g\\|_F`, each element started from the previous one's
        coordinates (the first from ``start``, else the best of the reference and a few spread points), so
        that angles along a path are not wrapped. Raises :class:`~geomech.errors.ConvergenceError` where the
        chart does not reach an element (a singular point of the chart).
        """
        if self._chart is None or self._chart_jacobian is None:
            raise InputError(f"{self.name} was built without a chart: give `chart` and `chart_jacobian`.")
        g = np.asarray(g, dtype=float)
        flat = g.reshape((-1, self.size, self.size))
        out = np.empty((flat.shape[0], self.dim))
        q = None if start is None else np.asarray(start, dtype=float)
        for i, gi in enumerate(flat):
            if q is None:
                rng = np.random.default_rng(0)
                starts = [self.reference] + [self.reference + rng.uniform(-np.pi, np.pi, self.dim) for _ in range(8)]
                tries = [self._newton(gi, s, tol, maxiter) for s in starts]
                q, res = min(tries, key=lambda pair: pair[1])
            else:
                q, res = self._newton(gi, q, tol, maxiter)
            if res > 1e3 * tol * max(1.0, np.abs(gi).max()):
                raise ConvergenceError(f"The chart of {self.name} does not reach element {i} of the path (residual "
                                       f"{res:.3g} at coordinates {np.round(q, 6).tolist()}): a singular point of "
                                       "the chart, such as gimbal lock of Euler angles.")
            out[i] = q
        return out.reshape(g.shape[:-2] + (self.dim,))

    def _newton(self, g: np.ndarray, q0: np.ndarray, tol: float, maxiter: int) -> tuple[np.ndarray, float]:
        q = np.array(q0, dtype=float)
        for _ in range(maxiter):
            r = (np.asarray(self._chart(q), dtype=float) - g).ravel()
            J = np.asarray(self._chart_jacobian(q), dtype=float).reshape(-1, self.dim)
            dq = np.linalg.lstsq(J, -r, rcond=None)[0]
            q = q + dq
            if np.abs(dq).max() <= tol * max(1.0, np.abs(q).max()):
                break
        return q, float(np.abs(np.asarray(self._chart(q), dtype=float) - g).max())

    def __repr__(self) -> str:
        return f"MatrixLieGroup({self.name!r}, dim={self.dim}, n={self.size})"

