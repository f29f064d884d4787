"""Quaternion canonical coordinates of :math:`T^*SO(3)` for any left-invariant Hamiltonian: a global chart
without the gimbal lock of Euler angles, in which the symmetry acts linearly.

The attitude is the unit quaternion :math:`q = (w, v)` of :math:`R` (:mod:`geomech.lie.quaternion`: Hamilton
product, ``x = R X``), lifted to :math:`\\mathbb R^4` with its conjugate momentum :math:`\\pi \\in \\mathbb R^4`.
Every formula here was derived with sympy (and is re-derived in ``tests/reduction``):

- body angular velocity, from :math:`R^T\\dot R = \\hat\\omega`: :math:`\\dot q = \\tfrac12\\, q\\,(0, \\omega)`,
  :math:`\\omega = 2\\operatorname{Im}(\\bar q\\,\\dot q)`;
- conjugate momentum of :math:`L(q, \\dot q) = \\ell(2\\operatorname{Im}(\\bar q\\dot q))`:
  :math:`\\pi = 2\\, q\\,(0, m)`, so :math:`m = \\tfrac12\\operatorname{Im}(\\bar q\\,\\pi)` where :math:`|q| = 1`;
- the Hamiltonian on :math:`T^*\\mathbb R^4`, :math:`\\tilde H(q, \\pi) = H(\\tilde m)` with
  :math:`\\tilde m = \\tfrac12\\operatorname{Im}(\\bar q\\pi) = \\tfrac12(w\\pi_v - \\pi_w v - v\\times\\pi_v)`,
  bilinear; its canonical equations give :math:`\\dot q = \\tfrac12 q(0, \\nabla H)` and Euler's equation for
  :math:`\\tilde m`;
- the left action :math:`q \\mapsto a q`, :math:`\\pi \\mapsto a\\pi` (:math:`|a| = 1`, the cotangent lift of a
  linear orthogonal map) leaves :math:`\\tilde m` and so :math:`\\tilde H` invariant; its momentum map is the
  spatial momentum :math:`p = \\tfrac12\\operatorname{Im}(\\pi\\bar q) = \\tfrac12(w\\pi_v - \\pi_w v + v\\times\\pi_v)`
  (:math:`= R m` on the physical set);
- :math:`|q|^2` and :math:`q\\cdot\\pi` are first integrals of :math:`\\tilde H` (:math:`\\tilde m` does not
  change under :math:`(q, \\pi) \\mapsto (sq, \\pi/s)`, nor along :math:`\\pi \\mapsto \\pi + tq`); their level
  set :math:`|q| = 1`, :math:`q\\cdot\\pi = 0` is :math:`T^*S^3`, the double cover of :math:`T^*SO(3)`.

Every invariant above is quadratic in :math:`(q, \\pi)`, so the implicit midpoint rule (and every Gauss-Legendre
method) conserves all of them to round-off: the spatial momentum exactly, as Remark 10 of the Serret-Andoyer
paper anticipates for the quaternionic setting, where in Euler angles only :math:`\\Phi = p_3` is (the rule there
is not equivariant under the rotations of the other two axes).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError
from ..lie import quaternion as quat
from ._cotangent_chart import CotangentChart

__all__ = ["QuaternionCoordinates"]

QUATERNION_SYMBOLS: tuple[sp.Symbol, ...] = sp.symbols("q_w q_x q_y q_z p_w p_x p_y p_z", real=True)


def _split(y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return y[..., 0], y[..., 1:4], y[..., 4], y[..., 5:8]


def _body_momentum(y: np.ndarray) -> np.ndarray:
    """:math:`\\tilde m = \\tfrac12\\operatorname{Im}(\\bar q\\pi)`."""
    w, v, pw, pv = _split(y)
    return 0.5 * (w[..., None] * pv - pw[..., None] * v - np.cross(v, pv))


def _spatial_momentum(y: np.ndarray) -> np.ndarray:
    """:math:`p = \\tfrac12\\operatorname{Im}(\\pi\\bar q)`."""
    w, v, pw, pv = _split(y)
    return 0.5 * (w[..., None] * pv - pw[..., None] * v + np.cross(v, pv))


def _momentum_jacobian(y: np.ndarray) -> np.ndarray:
    """Exact :math:`\\partial\\tilde m_i/\\partial y_j`, shape (..., 3, 8): :math:`\\tilde m` is bilinear."""
    w, v, pw, pv = _split(y)
    eye = np.broadcast_to(np.eye(3), w.shape + (3, 3))

    def cross_matrix(a: np.ndarray) -> np.ndarray:
        z = np.zeros_like(a[..., 0])
        return np.stack(
            [
                np.stack([z, -a[..., 2], a[..., 1]], -1),
                np.stack([a[..., 2], z, -a[..., 0]], -1),
                np.stack([-a[..., 1], a[..., 0], z], -1),
            ],
            -2,
        )

    d_w = 0.5 * pv[..., :, None]
    d_v = 0.5 * (-pw[..., None, None] * eye + cross_matrix(pv))  # d(-v x pv)/dv = [pv]x
    d_pw = -0.5 * v[..., :, None]
    d_pv = 0.5 * (w[..., None, None] * eye - cross_matrix(v))
    return np.concatenate([d_w, d_v, d_pw, d_pv], -1)


def _body_momentum_expressions() -> list[sp.Expr]:
    w, x, y, z, pw, px, py, pz = QUATERNION_SYMBOLS
    v, pv = sp.Matrix([x, y, z]), sp.Matrix([px, py, pz])
    m = (w * pv - pw * v - v.cross(pv)) / 2
    return [sp.expand(e) for e in m]


class QuaternionCoordinates(CotangentChart):
    """Quaternion canonical coordinates :math:`y = (q, \\pi) \\in T^*\\mathbb R^4` of :math:`T^*SO(3)` for a
    left-invariant Hamiltonian :math:`H(m)`: global (no gimbal lock), the symmetry acting linearly.

    Parameters
    ----------
    system : LeftInvariantSystem or an object wrapping one (``RigidBody``)
        The Hamiltonian. The numeric maps work for a system built from a callable; :meth:`canonical_system` with
        exact derivatives, :meth:`canonical_hamiltonian` and :meth:`hamilton_equations` need a formula.

    Notes
    -----
    With :math:`q = (w, v)`, :math:`\\pi = (\\pi_w, \\pi_v)`:

    .. math::

        \\pi &= 2\\,q\\,(0, m) = 2(-v\\cdot m,\\; w m + v\\times m) &\\text{(forward)}\\\\
        \\tilde m &= \\tfrac12(w\\pi_v - \\pi_w v - v\\times\\pi_v),\\qquad
        p = \\tfrac12(w\\pi_v - \\pi_w v + v\\times\\pi_v) &\\text{(body and spatial momentum)}\\\\
        \\tilde H(q, \\pi) &= H(\\tilde m),\\qquad \\dot q = \\partial\\tilde H/\\partial\\pi
        = \\tfrac12\\, q\\,(0, \\nabla H(\\tilde m)),\\quad \\dot\\pi = -\\partial\\tilde H/\\partial q.

    :math:`|q|^2`, :math:`q\\cdot\\pi` and :math:`p` are quadratic first integrals (:meth:`invariants`). The
    physical set is :math:`|q| = 1`, :math:`q\\cdot\\pi = 0`; :meth:`forward` lands on it and :meth:`inverse`
    reads :math:`R` from :math:`q/|q|`. :math:`(q, \\pi)` and :math:`(-q, -\\pi)` are the same state.
    """

    __slots__ = ()

    #: :math:`(q_w, q_x, q_y, q_z, p_w, p_x, p_y, p_z)`: the quaternion and its conjugate momentum (sympy, real).
    symbols = QUATERNION_SYMBOLS
    chart_name = "in quaternion coordinates"
    _m = staticmethod(_body_momentum)
    _dm = staticmethod(_momentum_jacobian)
    _m_expressions = staticmethod(_body_momentum_expressions)

    @staticmethod
    def _y(y: Any) -> np.ndarray:
        return V.trailing_shape(y, "y", (8,))

    # -- the chart ---------------------------------------------------------------------------------
    def forward(self, R: Any, m: Any) -> np.ndarray:
        """:math:`y = (q, \\pi)` of :math:`(R, m)`: ``q`` the unit quaternion of ``R`` with :math:`w \\ge 0`,
        :math:`\\pi = 2q(0, m)`; shape ``(..., 8)``. Defined everywhere (no gimbal lock)."""
        R = V.rotation_matrix(R, "R")
        m = V.trailing_shape(m, "m", (3,))
        batch = np.broadcast_shapes(R.shape[:-2], m.shape[:-1])
        q = quat.from_matrix(np.broadcast_to(R, batch + (3, 3)))
        return self.from_quaternion(q, np.broadcast_to(m, batch + (3,)))

    def from_quaternion(self, q: Any, m: Any) -> np.ndarray:
        """:math:`y = (q, 2q(0, m))` from a unit quaternion ``(..., 4)`` (scalar first) and the body momentum."""
        q = V.trailing_shape(q, "q", (4,))
        m = V.trailing_shape(m, "m", (3,))
        quat.as_matrix(q)  # checks |q| = 1
        batch = np.broadcast_shapes(q.shape[:-1], m.shape[:-1])
        q, m = np.broadcast_to(q, batch + (4,)), np.broadcast_to(m, batch + (3,))
        w, v = q[..., 0], q[..., 1:]
        pi = 2.0 * np.concatenate([-np.sum(v * m, -1)[..., None], w[..., None] * m + np.cross(v, m)], -1)
        return np.concatenate([q, pi], -1)

    def inverse(self, y: Any) -> tuple[np.ndarray, np.ndarray]:
        """:math:`(R, m)`: ``R`` of :math:`q/|q|`, :math:`m = \\tilde m(y)`."""
        y = V.trailing_shape(y, "y", (8,))
        n = np.linalg.norm(y[..., :4], axis=-1, keepdims=True)
        if np.any(n == 0):
            raise InputError("Expected `y` to have a nonzero quaternion part q (its first four components).")
        return quat.as_matrix(y[..., :4] / n), _body_momentum(y)

    def body_momentum(self, y: Any) -> np.ndarray:
        """:math:`\\tilde m = \\tfrac12\\operatorname{Im}(\\bar q\\pi)`, shape ``(..., 3)``."""
        return _body_momentum(V.trailing_shape(y, "y", (8,)))

    def spatial_momentum(self, y: Any) -> np.ndarray:
        """The momentum map of the left action, :math:`p = \\tfrac12\\operatorname{Im}(\\pi\\bar q)` (:math:`= Rm`
        on the physical set), shape ``(..., 3)``."""
        return _spatial_momentum(V.trailing_shape(y, "y", (8,)))

    def invariants(self, y: Any) -> np.ndarray:
        """The quadratic first integrals that define the physical set, :math:`(|q|^2 - 1,\\ q\\cdot\\pi)`, shape
        ``(..., 2)``: zero there, conserved by the flow and by the implicit midpoint rule."""
        y = V.trailing_shape(y, "y", (8,))
        return np.stack([np.sum(y[..., :4] ** 2, -1) - 1.0, np.sum(y[..., :4] * y[..., 4:], -1)], -1)

    def momentum_jacobian(self, y: Any) -> np.ndarray:
        """Exact Jacobian :math:`\\partial\\tilde m_i/\\partial y_j`, shape ``(..., 3, 8)``."""
        return _momentum_jacobian(V.trailing_shape(y, "y", (8,)))

    # -- the Hamiltonian side: hamiltonian, gradient, vector_field, canonical_system (through which solve with
    # ImplicitMidpoint keeps the spatial momentum, |q| and q . pi to round-off, at every attitude),
    # canonical_hamiltonian and hamilton_equations are CotangentChart's, with K = H(m~(q, pi))
