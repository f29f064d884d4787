"""3-1-3 Euler-angle canonical coordinates of :math:`T^*SO(3)` for any left-invariant Hamiltonian.

The attitude is :math:`R = R_z(\\phi) R_x(\\theta) R_z(\\psi)` (eq. 1 of the Serret-Andoyer paper; ``R``
maps body to space) and :math:`(\\Phi, \\Theta, \\Psi)` are the momenta conjugate to
:math:`(\\phi, \\theta, \\psi)`. The chart covers :math:`0 < \\theta < \\pi`; at :math:`\\theta = 0, \\pi`
(gimbal lock) :math:`\\phi` and :math:`\\psi` are not separately defined and the momenta of eq. (6)
divide by :math:`\\sin\\theta`.

Every formula here was derived with sympy (and is re-derived in ``tests/reduction``):

- body angular velocity, from :math:`R^T \\dot R = \\hat\\omega` (eq. 2, as printed):
  :math:`\\omega = (\\dot\\theta\\cos\\psi + \\dot\\phi\\sin\\psi\\sin\\theta,\\;
  -\\dot\\theta\\sin\\psi + \\dot\\phi\\cos\\psi\\sin\\theta,\\; \\dot\\phi\\cos\\theta + \\dot\\psi)`;
- momenta, :math:`\\Phi = m\\cdot\\partial\\omega/\\partial\\dot\\phi` etc. (eq. 15, Lemma 2, as printed);
- body momentum, the inverse of eq. 15 (eq. 6, as printed), with
  :math:`X = (\\Phi - \\Psi\\cos\\theta)/\\sin\\theta`:
  :math:`m = (X\\sin\\psi + \\Theta\\cos\\psi,\\; X\\cos\\psi - \\Theta\\sin\\psi,\\; \\Psi)`;
- spatial momentum :math:`p = R m` (eq. 16 with the sign of eq. 16b corrected, as in eq. 7b);
- for the free rigid body, eq. (4c) as printed has :math:`\\cos\\phi` where :math:`\\cos\\psi` belongs.
"""

from __future__ import annotations

from typing import Any, final

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import SingularityError
from ..lie import euler
from ..symbolic.compile import compile_vector
from ._cotangent_chart import CotangentChart

__all__ = ["EulerCoordinates"]

#: :math:`|\sin\theta|` at or below which the momenta of eq. (6) are not defined. ``sin(np.pi)`` is
#: about 1.2e-16, so this catches theta = pi given in floating point, and nothing representable and
#: mathematically regular is refused.
_SIN_THETA_MIN = 8 * np.finfo(float).eps

EULER_SYMBOLS: tuple[sp.Symbol, ...] = sp.symbols("phi theta psi Phi Theta Psi", real=True)


# -- numeric chart formulas (independent of H) -------------------------------------------------------
def _coordinates(q: Any, name: str = "q") -> np.ndarray:
    return V.trailing_shape(q, name, (6,))


def _sin_theta(theta: np.ndarray, name: str = "q") -> np.ndarray:
    s = np.sin(theta)
    bad = np.abs(s) <= _SIN_THETA_MIN
    if np.any(bad):
        raise SingularityError(
            f"3-1-3 Euler-angle coordinates are singular at theta = 0 or pi (gimbal lock: the body axis b3 "
            f"is along +-s3, phi and psi are not separately defined and the momenta of eq. (6) divide by "
            f"sin(theta)); `{name}` has theta = {float(np.asarray(theta)[bad].ravel()[0])!r}. Use another "
            "spatial frame, or a chart without this singularity (quaternions, R itself)."
        )
    return s


def _body_momentum(q: np.ndarray) -> np.ndarray:
    """Eq. (6): m from (theta, psi, Phi, Theta, Psi); q already validated."""
    theta, psi, Phi, Theta, Psi = (q[..., k] for k in range(1, 6))
    st = _sin_theta(theta)
    x = (Phi - Psi * np.cos(theta)) / st
    sp_, cp = np.sin(psi), np.cos(psi)
    return np.stack([x * sp_ + Theta * cp, x * cp - Theta * sp_, Psi], -1)


def _momenta(angles: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Eq. (15): (Phi, Theta, Psi) from the angles and the body momentum."""
    theta, psi = angles[..., 1], angles[..., 2]
    sp_, cp = np.sin(psi), np.cos(psi)
    Phi = (m[..., 0] * sp_ + m[..., 1] * cp) * np.sin(theta) + m[..., 2] * np.cos(theta)
    Theta = m[..., 0] * cp - m[..., 1] * sp_
    return np.stack([Phi, Theta, m[..., 2]], -1)


def _angles_from_matrix(R: np.ndarray, name: str = "R") -> np.ndarray:
    try:
        return np.asarray(euler.from_matrix(R, seq="ZXZ", on_singular="raise"), dtype=float)
    except SingularityError as exc:
        margin = float(np.min(euler.gimbal_margin(R, seq="ZXZ")))
        raise SingularityError(
            f"3-1-3 Euler-angle coordinates are singular at theta = 0 or pi (gimbal lock: the body axis b3 "
            f"is along +-s3, phi and psi are not separately defined and the momenta of eq. (6) divide by "
            f"sin(theta)); `{name}` has theta within {margin:.3g} rad of 0 or pi, inside the singular band "
            "of geomech.lie.euler.from_matrix. Use another spatial frame, or a chart without this "
            "singularity (quaternions, R itself)."
        ) from exc


def _matrix_from_angles(angles: np.ndarray) -> np.ndarray:
    return np.asarray(euler.as_matrix(angles, seq="ZXZ"), dtype=float)


def _momentum_jacobian(q: np.ndarray) -> np.ndarray:
    """Exact partial derivatives of eq. (6), dm_i/dq_j, shape (..., 3, 6)."""
    theta, psi, Phi, Theta, Psi = (q[..., k] for k in range(1, 6))
    st = _sin_theta(theta)
    ct = np.cos(theta)
    sp_, cp = np.sin(psi), np.cos(psi)
    x = (Phi - Psi * ct) / st
    dx_dtheta = (Psi - Phi * ct) / st**2
    z = np.zeros_like(theta)
    one = np.ones_like(theta)
    cot = ct / st
    cols = [
        np.stack([z, z, z], -1),  # phi is cyclic (Remark 3)
        np.stack([dx_dtheta * sp_, dx_dtheta * cp, z], -1),
        np.stack([x * cp - Theta * sp_, -x * sp_ - Theta * cp, z], -1),
        np.stack([sp_ / st, cp / st, z], -1),
        np.stack([cp, -sp_, z], -1),
        np.stack([-cot * sp_, -cot * cp, one], -1),
    ]
    return np.stack(cols, -1)


def _rates_from_omega(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Eq. (2) inverted: (phi', theta', psi') from the body angular velocity."""
    theta, psi = q[..., 1], q[..., 2]
    st = _sin_theta(theta)
    sp_, cp = np.sin(psi), np.cos(psi)
    u = omega[..., 0] * sp_ + omega[..., 1] * cp
    phidot = u / st
    thetadot = omega[..., 0] * cp - omega[..., 1] * sp_
    psidot = omega[..., 2] - phidot * np.cos(theta)
    return np.stack([phidot, thetadot, psidot], -1)


def _body_momentum_expressions() -> list[sp.Expr]:
    _, theta, psi, Phi, Theta, Psi = EULER_SYMBOLS
    x = (Phi - Psi * sp.cos(theta)) / sp.sin(theta)
    return [x * sp.sin(psi) + Theta * sp.cos(psi), x * sp.cos(psi) - Theta * sp.sin(psi), Psi]


@final
class EulerCoordinates(CotangentChart):
    """3-1-3 Euler-angle canonical coordinates :math:`q = (\\phi, \\theta, \\psi, \\Phi, \\Theta, \\Psi)`
    of :math:`T^*SO(3)` for a left-invariant Hamiltonian :math:`H(m)` (Lemma 2 of the Serret-Andoyer
    paper).

    Parameters
    ----------
    system : LeftInvariantSystem or an object wrapping one (``RigidBody``)
        The Hamiltonian. Everything numeric works for a system built from a callable; the symbolic
        methods (:meth:`canonical_hamiltonian`, :meth:`hamilton_equations`) need a formula.

    Notes
    -----
    The chart maps (:meth:`forward`, :meth:`inverse`, :meth:`body_momentum`, :meth:`spatial_momentum`)
    do not depend on H. With :math:`X = (\\Phi - \\Psi\\cos\\theta)/\\sin\\theta`:

    .. math::

        \\Phi &= (m_1\\sin\\psi + m_2\\cos\\psi)\\sin\\theta + m_3\\cos\\theta, \\quad
        \\Theta = m_1\\cos\\psi - m_2\\sin\\psi, \\quad \\Psi = m_3 \\qquad &\\text{(eq. 15)} \\\\
        m &= (X\\sin\\psi + \\Theta\\cos\\psi,\\; X\\cos\\psi - \\Theta\\sin\\psi,\\; \\Psi)
        &\\text{(eq. 6)} \\\\
        p = R m &= (\\Theta\\cos\\phi + Y\\sin\\phi,\\; \\Theta\\sin\\phi - Y\\cos\\phi,\\; \\Phi),
        \\quad Y = (\\Psi - \\Phi\\cos\\theta)/\\sin\\theta &\\text{(eq. 16, corrected)}

    Eq. (16b) of the paper is printed with :math:`-\\Theta\\sin\\phi`; the sign is ``+`` (eq. 7b has
    it right). The Hamiltonian in these coordinates is :math:`K(q) = H(m(q))`; :math:`\\phi` is cyclic
    (Remark 3), so :math:`\\Phi = p_3` is conserved.

    The chart covers :math:`0 < \\theta < \\pi`, :math:`\\phi, \\psi \\in (-\\pi, \\pi]`.
    :class:`~geomech.errors.SingularityError` is raised at :math:`\\theta = 0, \\pi`.
    """

    __slots__ = ()

    #: The coordinate symbols :math:`(\phi, \theta, \psi, \Phi, \Theta, \Psi)` (sympy, real).
    symbols = EULER_SYMBOLS
    chart_name = "in 3-1-3 Euler coordinates"
    angle_coordinates = (0, 1, 2)
    _y = staticmethod(_coordinates)
    _m = staticmethod(_body_momentum)
    _dm = staticmethod(_momentum_jacobian)
    _m_expressions = staticmethod(_body_momentum_expressions)

    @property
    def angle_symbols(self) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
        """:math:`(\\phi, \\theta, \\psi)`."""
        return self.symbols[:3]

    @property
    def momentum_symbols(self) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
        """:math:`(\\Phi, \\Theta, \\Psi)`."""
        return self.symbols[3:]

    # -- the chart ---------------------------------------------------------------------------------
    def forward(self, R: Any, m: Any) -> np.ndarray:
        """Euler-angle coordinates of :math:`(R, m)`: angles of ``R`` (ZXZ, eq. 1), momenta by eq. (15).

        Parameters
        ----------
        R : array_like, shape (..., 3, 3)
            Attitude (body to space), a rotation matrix.
        m : array_like, shape (..., 3)
            Body angular momentum.

        Returns
        -------
        q : ndarray, shape (..., 6)
            :math:`(\\phi, \\theta, \\psi, \\Phi, \\Theta, \\Psi)`, with :math:`0 < \\theta < \\pi`.

        Raises
        ------
        SingularityError
            At (or too near, as judged by :func:`geomech.lie.euler.from_matrix`) :math:`\\theta = 0, \\pi`.
        """
        R = V.rotation_matrix(R, "R")
        m = V.trailing_shape(m, "m", (3,))
        batch = np.broadcast_shapes(R.shape[:-2], m.shape[:-1])
        R = np.broadcast_to(R, batch + (3, 3))
        m = np.broadcast_to(m, batch + (3,))
        angles = _angles_from_matrix(R)
        return np.concatenate([angles, _momenta(angles, m)], -1)

    def inverse(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """:math:`(R, m)` from Euler-angle coordinates: ``R`` by eq. (1), ``m`` by eq. (6).

        Returns
        -------
        R : ndarray, shape (..., 3, 3)
        m : ndarray, shape (..., 3)

        Raises
        ------
        SingularityError
            Where :math:`|\\sin\\theta| \\le 8\\epsilon` (eq. 6 divides by it). Any other theta is
            accepted, also outside :math:`(0, \\pi)`; :meth:`forward` returns the representative with
            :math:`0 < \\theta < \\pi` and refuses :math:`R` within ``sqrt(eps)`` rad of gimbal lock, where
            :func:`geomech.lie.euler.from_matrix` cannot separate phi and psi.
        """
        q = _coordinates(q)
        m = _body_momentum(q)
        return _matrix_from_angles(q[..., :3]), m

    def body_momentum(self, q: Any) -> np.ndarray:
        """Body angular momentum :math:`m(\\theta, \\psi, \\Phi, \\Theta, \\Psi)` (eq. 6), shape ``(..., 3)``."""
        return _body_momentum(_coordinates(q))

    def spatial_momentum(self, q: Any) -> np.ndarray:
        """Spatial angular momentum :math:`p = R m` (eq. 16, sign of eq. 16b corrected), shape ``(..., 3)``.

        .. math::

            p_1 = \\Theta\\cos\\phi + Y\\sin\\phi, \\quad p_2 = \\Theta\\sin\\phi - Y\\cos\\phi, \\quad
            p_3 = \\Phi, \\qquad Y = \\frac{\\Psi - \\Phi\\cos\\theta}{\\sin\\theta}.

        The paper prints :math:`p_2 = -\\Theta\\sin\\phi - Y\\cos\\phi` (eq. 16b); that is not
        :math:`(R m)_2`. Eq. (7b), the same quantity for the free rigid body, is printed correctly.
        """
        q = _coordinates(q)
        phi, theta, _, Phi, Theta, Psi = (q[..., k] for k in range(6))
        y = (Psi - Phi * np.cos(theta)) / _sin_theta(theta)
        sf, cf = np.sin(phi), np.cos(phi)
        return np.stack([Theta * cf + y * sf, Theta * sf - y * cf, Phi], -1)

    def momentum_jacobian(self, q: Any) -> np.ndarray:
        """Exact Jacobian :math:`\\partial m_i/\\partial q_j` of eq. (6), shape ``(..., 3, 6)``.

        Its nonzero columns, with :math:`X` as in eq. (6):
        :math:`\\partial_\\theta m = \\frac{\\Psi - \\Phi\\cos\\theta}{\\sin^2\\theta}(\\sin\\psi, \\cos\\psi, 0)`,
        :math:`\\partial_\\psi m = (m_2, -m_1, 0)`,
        :math:`\\partial_\\Phi m = (\\sin\\psi, \\cos\\psi, 0)/\\sin\\theta`,
        :math:`\\partial_\\Theta m = (\\cos\\psi, -\\sin\\psi, 0)`,
        :math:`\\partial_\\Psi m = (-\\cot\\theta\\sin\\psi, -\\cot\\theta\\cos\\psi, 1)`.
        """
        return _momentum_jacobian(_coordinates(q))

    # -- the Hamiltonian side: hamiltonian, gradient, vector_field, canonical_system, canonical_hamiltonian and
    # hamilton_equations are CotangentChart's (K = H(m(q)) through eq. 6; phi is cyclic, so Phi' = 0)
    def compiled_vector_field(self):
        """:meth:`hamilton_equations` compiled to ``f(q)`` with ``q`` of shape ``(..., 6)`` (parameters
        substituted); equal to :meth:`vector_field` up to round-off, and like it raises
        :class:`~geomech.errors.SingularityError` at the chart's gimbal lock instead of returning inf or NaN."""
        key = "compiled"
        if key not in self._cache:
            f = compile_vector(list(self.hamilton_equations(substitute_parameters=True)), self.symbols)

            def field(q: Any) -> np.ndarray:
                q = _coordinates(q)
                _sin_theta(q[..., 1])
                return f(q)

            self._cache[key] = field
        return self._cache[key]

    # -- the Lagrangian side (H hyperregular) --------------------------------------------------------
    def euler_angle_rates(self, q: Any) -> np.ndarray:
        """:math:`(\\dot\\phi, \\dot\\theta, \\dot\\psi)` from :math:`\\omega = \\nabla H(m(q))` by
        inverting eq. (2), shape ``(..., 3)``:

        .. math::

            \\dot\\phi = \\frac{\\omega_1\\sin\\psi + \\omega_2\\cos\\psi}{\\sin\\theta}, \\quad
            \\dot\\theta = \\omega_1\\cos\\psi - \\omega_2\\sin\\psi, \\quad
            \\dot\\psi = \\omega_3 - \\dot\\phi\\cos\\theta.
        """
        q = _coordinates(q)
        omega = self.system.gradient(_body_momentum(q))
        return _rates_from_omega(q, omega)

    def momenta_from_rates(self, angles: Any, rates: Any, *, m_guess: Any | None = None) -> np.ndarray:
        """The conjugate momenta :math:`(\\Phi, \\Theta, \\Psi)` of given Euler angles and rates,
        shape ``(..., 3)``: :math:`\\omega` by eq. (2), :math:`m = (\\nabla H)^{-1}(\\omega)` (the
        Legendre transform :math:`FL` of Lemma 1, needs H hyperregular), then eq. (15).

        Raises
        ------
        SingularityError, ConvergenceError
            From :meth:`LeftInvariantSystem.inverse_legendre` where :math:`\\nabla H` is not invertible.
        """
        a = V.trailing_shape(angles, "angles", (3,))
        omega = euler.angular_velocity(a, rates, "ZXZ", frame="body")
        a = np.broadcast_to(a, omega.shape)
        m = self.system.inverse_legendre(omega, m_guess)
        return _momenta(a, m)
