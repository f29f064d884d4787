"""Exact motion of a left-invariant system on :math:`T^*SO(3)`: the reduced flow :math:`(l, L)(t)` by the
quadrature of :mod:`geomech.integrators.quadrature` and the attitude by the reconstruction of Theorem 3 of the
Serret-Andoyer paper."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError, SingularityError
from ._one_dof import OrbitIntegral
from .quadrature import QuadraturePropagator

__all__ = ["SerretAndoyerPropagator"]


class SerretAndoyerPropagator:
    """Exact motion of a left-invariant system :math:`H(m)` on :math:`T^*SO(3)`: :math:`(l, L)(t)` by
    quadrature (eq. 11) and the attitude by the reconstruction of Theorem 3,

    .. math::

        R = S\\,R_z(\\varphi)R_x(\\theta)R_z(l)\\,C^T,\\quad \\cos\\theta = L/G,\\quad
        \\varphi(t) = \\varphi_0 + \\int_0^t \\dot\\varphi\\,ds,

    :math:`\\dot\\varphi` (:meth:`GeneralizedSerretAndoyer.phi_rate`) integrated by the same quadrature: a
    fixed advance per period of :math:`(l, L)` plus a periodic part.

    Parameters
    ----------
    reduction : GeneralizedSerretAndoyer, or a system it accepts (LeftInvariantSystem, RigidBody).
    m0 : (3,) the initial body momentum, ``G = |m0|``. R0 : (3, 3) the initial attitude (default I).
    axis : the chart's body axis (0-based; 2 is the paper's). Default: axis 3 if the orbit keeps
        ``|L|/G <= reduction.switch_at`` there, else the chart where it stays farthest from the poles.
    tol : as in :class:`QuadraturePropagator`.

    Attributes
    ----------
    orbit (the :class:`QuadraturePropagator` of :math:`h_p`), kind, energy, period, G, axis, p (spatial
    momentum), S (spatial frame, ``S e3 = p/G``), phi0, pole_ratio (max ``|L|/G`` on the orbit: near 1 the
    chart and :math:`\\dot\\varphi` are near their singularity).
    """

    def __init__(self, reduction: Any, m0: Any, *, R0: Any = None, axis: int | None = None, tol: float = 1e-12):
        from ..lie import euler
        from ..reduction.serret_andoyer import GeneralizedSerretAndoyer, spatial_frame

        sa = reduction if isinstance(reduction, GeneralizedSerretAndoyer) else GeneralizedSerretAndoyer(reduction)
        self.reduction, self.m0 = sa, V.exact_shape(m0, "m0", (3,))
        self.G = G = float(np.linalg.norm(self.m0))
        if G == 0:
            raise InputError("Expected `m0` to be nonzero: the momentum sphere |m| = G needs G > 0.")
        R0 = np.eye(3) if R0 is None else V.rotation_matrix(R0, "R0")
        if axis is not None and (isinstance(axis, bool) or axis not in (0, 1, 2)):
            raise InputError(f"Expected `axis` to be a body axis index 0, 1 or 2 or None, got {axis!r}.")
        best, failures = None, []
        for k in [axis] if axis is not None else [2, 0, 1]:
            try:
                y0 = sa.charts[k].forward(self.m0)
                orbit = QuadraturePropagator(sa.reduced_system(G, k), y0, L_bounds=(-G, G), tol=tol)
            except SingularityError as exc:
                if axis is not None:
                    raise
                failures.append(f"axis {k + 1}: {exc}")
                continue
            ratio = max(abs(orbit.L_range[0]), abs(orbit.L_range[1])) / G
            if best is None or ratio < best[1]:
                best = (k, ratio, orbit)
            if ratio <= sa.switch_at:
                break
        if best is None:
            raise SingularityError("No Serret-Andoyer chart covers the orbit: " + " | ".join(failures))
        self.axis, self.pole_ratio, self.orbit = best
        self.p = R0 @ self.m0
        self.S = spatial_frame(self.p)
        self.phi0 = float(euler.from_matrix(self.S.T @ R0 @ sa.charts[self.axis].permutation, seq="ZXZ")[0])
        self._phi: OrbitIntegral | None = None
        if self.orbit.kind != "separatrix":
            self._phi = self.orbit.integral(lambda y: sa.phi_rate(y, G, self.axis))

    @classmethod
    def from_reduced(cls, reduction: Any, lL0: Any, G: float, *, axis: int = 2, tol: float = 1e-12):
        """Start from ``(l0, L0)`` in the chart about ``axis``, with ``phi0 = 0`` and ``p = G e3`` (``S = I``)."""
        from ..reduction.serret_andoyer import GeneralizedSerretAndoyer, SerretAndoyerChart

        lL0, G = V.exact_shape(lL0, "lL0", (2,)), V.positive_scalar(G, "G")
        R0 = GeneralizedSerretAndoyer.attitude(np.eye(3), 0.0, lL0[1], lL0[0], G, axis)
        return cls(reduction, SerretAndoyerChart(axis).inverse(lL0, G), R0=R0, axis=axis, tol=tol)

    kind = property(lambda self: self.orbit.kind)
    energy = property(lambda self: self.orbit.energy)
    period = property(lambda self: self.orbit.period)

    def state(self, t: Any) -> np.ndarray:
        """:math:`(l, L)(t)` in the chart about :attr:`axis` (``l`` lifted), shape ``t.shape + (2,)``."""
        return self.orbit.state(t)

    def phi(self, t: Any) -> np.ndarray:
        """The reconstruction angle :math:`\\varphi(t)` (continuous, not reduced modulo 2 pi)."""
        self.orbit._require_periodic("phi")
        assert self._phi is not None  # every periodic orbit has it
        return self.phi0 + self._phi(t)

    @property
    def phi_per_period(self) -> float:
        """The advance of :math:`\\varphi` over one period of :math:`(l, L)`: R(t + T) = exp(that * p/G) R(t)."""
        self.orbit._require_periodic("phi_per_period")
        assert self._phi is not None  # every periodic orbit has it
        return float(self._phi.per_period)

    def momentum(self, t: Any) -> np.ndarray:
        """Body momentum :math:`m(t)`, shape ``t.shape + (3,)``."""
        return self.reduction.charts[self.axis].inverse(self.state(t), self.G)

    def attitude(self, t: Any) -> np.ndarray:
        """Attitude :math:`R(t)` (body to space), shape ``t.shape + (3, 3)``."""
        y, phi = self.state(t), self.phi(t)
        return self.reduction.attitude(self.S, phi, y[..., 1], y[..., 0], self.G, self.axis)

    def __repr__(self) -> str:
        return f"SerretAndoyerPropagator(axis={self.axis + 1}, G={self.G:.17g}, {self.orbit!r})"
