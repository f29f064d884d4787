"""The classical Serret-Andoyer transformation (section 3 of the Serret-Andoyer paper).

Geometry (Fig. 2 of the paper): with the spatial momentum :math:`p = R m`, :math:`G = |m| = |p|`,

- :math:`i = R_z(h)\\,s_1` is the node of the invariable plane, :math:`k = p/G = R_z(h) R_x(\\sigma)\\,s_3`,
  :math:`\\cos\\sigma = H/G`;
- the body frame is reached from the frame :math:`(i, \\cdot, k)` by the 3-1-3 angles
  :math:`(g, \\beta, l)`: :math:`R = R_z(h) R_x(\\sigma) R_z(g) R_x(\\beta) R_z(l)`,
  :math:`\\cos\\beta = L/G`;
- :math:`m = R^T p = (\\sqrt{G^2 - L^2}\\sin l,\\; \\sqrt{G^2 - L^2}\\cos l,\\; L)` (eq. 20),
  :math:`H = p_3 = \\Phi`, :math:`L = m_3 = \\Psi`.

Canonicity (eq. 9): the body angular velocity of that product satisfies
:math:`m\\cdot\\omega\\,dt = H\\,dh + G\\,dg + L\\,dl` because :math:`p \\perp i` and :math:`p \\perp j`
(:math:`j` the node of the body plane), so the Liouville forms of :math:`(l, g, h; L, G, H)` and of
:math:`(\\phi, \\theta, \\psi; \\Phi, \\Theta, \\Psi)` agree and the map is symplectic.

The chart is singular where :math:`\\sigma` is 0 or :math:`\\pi` (``p`` along :math:`\\pm s_3`: ``h`` and
``g`` are not separately defined), where :math:`\\beta` is 0 or :math:`\\pi` (``m`` along
:math:`\\pm b_3`, :math:`L = \\pm G`: ``g`` and ``l`` are not separately defined) and at ``m = 0``.

For the free rigid body the reduced Hamiltonian is eq. (10), and the motion of ``l`` is a quadrature
(eq. 11); :func:`period_of_l` computes its period. Eq. (11b) as printed takes the positive root:
``L`` has the sign of its initial value (it changes sign only at the turning points of a libration).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, final

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import ConvergenceError, InputError, SingularityError
from ..lie import quaternion as _quat
from ..lie import so3
from .euler_coordinates import _angles_from_matrix, _body_momentum, _coordinates, _matrix_from_angles, _momenta

__all__ = [
    "ClassicalSerretAndoyer",
    "LPeriod",
    "momentum_l",
    "period_of_l",
    "period_of_l_from_momentum",
    "reduced_hamiltonian",
    "andoyer_hamiltonian",
    "reduced_vector_field",
]

#: Relative size (of G) of the component of ``p`` across ``s3``, or of ``m`` across ``b3``, at or below
#: which sigma or beta is taken as 0 or pi: there the angles h, g, l lose all their digits.
_POLE_RTOL = 64 * np.finfo(float).eps

SA_SYMBOLS: tuple[sp.Symbol, ...] = sp.symbols("l g h L G H", real=True)


def _rz(a: np.ndarray) -> np.ndarray:
    return np.asarray(so3.rot_z(a), dtype=float)


def _rx(a: np.ndarray) -> np.ndarray:
    return np.asarray(so3.rot_x(a), dtype=float)


def _T(A: np.ndarray) -> np.ndarray:
    return np.swapaxes(A, -1, -2)


def _first(mask: np.ndarray, *arrays: np.ndarray) -> list[float]:
    idx = np.argwhere(np.atleast_1d(mask))[0]
    return [float(np.atleast_1d(a)[tuple(idx)]) if np.ndim(a) else float(a) for a in arrays]


@final
class ClassicalSerretAndoyer:
    """The classical Serret-Andoyer canonical transformation
    :math:`(\\phi, \\theta, \\psi, \\Phi, \\Theta, \\Psi) \\mapsto (l, g, h, L, G, H)` (section 3).

    It is purely geometric (independent of the Hamiltonian): :math:`G = |m|`, :math:`H = p_3`,
    :math:`L = m_3`, :math:`l = \\operatorname{atan2}(m_1, m_2)`, :math:`h = \\operatorname{atan2}(p_1,
    -p_2)`, and ``g`` from :math:`R_z(g) = R_x(\\sigma)^T R_z(h)^T R\\, R_z(l)^T R_x(\\beta)^T`; see the
    module docstring. Angles are returned in :math:`(-\\pi, \\pi]`, with :math:`G > 0`,
    :math:`|L| < G`, :math:`|H| < G`.

    Raises :class:`~geomech.errors.SingularityError` naming the angle where :math:`\\sigma` or
    :math:`\\beta` is 0 or :math:`\\pi`, and at ``m = 0``.
    """

    __slots__ = ()

    #: The coordinate symbols :math:`(l, g, h, L, G, H)` (sympy, real).
    symbols: tuple[sp.Symbol, ...] = SA_SYMBOLS

    def __repr__(self) -> str:
        return "ClassicalSerretAndoyer()"

    # -- body representation <-> Serret-Andoyer ---------------------------------------------------
    def from_body(self, R: Any, m: Any) -> np.ndarray:
        """Serret-Andoyer variables :math:`(l, g, h, L, G, H)` of :math:`(R, m)`, shape ``(..., 6)``.

        Parameters
        ----------
        R : array_like, shape (..., 3, 3)
            Attitude (body to space).
        m : array_like, shape (..., 3)
            Body angular momentum.
        """
        R = V.rotation_matrix(R, "R")
        m = V.trailing_shape(m, "m", (3,))
        batch = np.broadcast_shapes(R.shape[:-2], m.shape[:-1])
        R = np.broadcast_to(R, batch + (3, 3))
        m = np.broadcast_to(m, batch + (3,))
        p = np.einsum("...ij,...j->...i", R, m)
        G = np.linalg.norm(m, axis=-1)
        zero = G <= np.finfo(float).tiny
        if np.any(zero):
            raise SingularityError(
                "The Serret-Andoyer chart is undefined at m = 0 (no invariable plane: k = p/|p| is undefined)."
            )
        p_perp = np.hypot(p[..., 0], p[..., 1])
        m_perp = np.hypot(m[..., 0], m[..., 1])
        bad = p_perp <= _POLE_RTOL * G
        if np.any(bad):
            p3, g_ = _first(bad, p[..., 2], G)
            raise SingularityError(
                "The Serret-Andoyer chart is singular at sigma = 0 or pi: the spatial momentum p is along "
                f"+-s3 (H = p3 = {p3:.17g}, G = {g_:.17g}), so the node angle h and g are not separately "
                "defined. Choose a spatial frame whose s3 is not along p (e.g. tilt it)."
            )
        bad = m_perp <= _POLE_RTOL * G
        if np.any(bad):
            l3, g_ = _first(bad, m[..., 2], G)
            raise SingularityError(
                "The Serret-Andoyer chart is singular at beta = 0 or pi: the body momentum m is along "
                f"+-b3 (L = m3 = {l3:.17g} = +-G, G = {g_:.17g}), so l and g are not separately defined."
            )
        sigma = np.arctan2(p_perp, p[..., 2])
        beta = np.arctan2(m_perp, m[..., 2])
        h = np.arctan2(p[..., 0], -p[..., 1])
        l_ = np.arctan2(m[..., 0], m[..., 1])
        Mg = _T(_rx(sigma)) @ _T(_rz(h)) @ R @ _T(_rz(l_)) @ _T(_rx(beta))
        g = np.arctan2(Mg[..., 1, 0], Mg[..., 0, 0])
        return np.stack([l_, g, h, m[..., 2], G, p[..., 2]], -1)

    def to_body(self, sa: Any) -> tuple[np.ndarray, np.ndarray]:
        """:math:`(R, m)` from Serret-Andoyer variables:
        :math:`R = R_z(h)R_x(\\sigma)R_z(g)R_x(\\beta)R_z(l)` and ``m`` by eq. (20).

        Parameters
        ----------
        sa : array_like, shape (..., 6)
            :math:`(l, g, h, L, G, H)` with :math:`G > 0`, :math:`|L| < G`, :math:`|H| < G`.

        Returns
        -------
        R : ndarray, shape (..., 3, 3)
        m : ndarray, shape (..., 3)
        """
        sa = V.trailing_shape(sa, "sa", (6,))
        l_, g, h, L, G, H = (sa[..., k] for k in range(6))
        if np.any(G <= 0):
            raise InputError(f"Expected G = |m| > 0 in `sa`, got G = {_first(G <= 0, G)[0]!r}.")
        for name, x, what in (("L", L, "beta"), ("H", H, "sigma")):
            out = np.abs(x) > G
            if np.any(out):
                xv, gv = _first(out, x, G)
                raise InputError(f"Expected |{name}| <= G in `sa`, got {name} = {xv!r}, G = {gv!r}.")
            perp = np.sqrt(np.maximum((G - x) * (G + x), 0.0))
            pole = perp <= _POLE_RTOL * G
            if np.any(pole):
                xv, gv = _first(pole, x, G)
                raise SingularityError(
                    f"The Serret-Andoyer chart is singular at {what} = 0 or pi ({name} = {xv!r} = +-G, G = {gv!r})."
                )
        sin_beta = np.sqrt((G - L) * (G + L))
        beta = np.arctan2(sin_beta, L)
        sigma = np.arctan2(np.sqrt((G - H) * (G + H)), H)
        R = _rz(h) @ _rx(sigma) @ _rz(g) @ _rx(beta) @ _rz(l_)
        m = np.stack([sin_beta * np.sin(l_), sin_beta * np.cos(l_), L], -1)
        return R, m

    # -- quaternion coordinates <-> Serret-Andoyer --------------------------------------------------
    def to_quaternion(self, sa: Any) -> np.ndarray:
        """The point :math:`(q, \\pi)` of the quaternion coordinates
        (:class:`~geomech.reduction.QuaternionCoordinates`) of :math:`(l, g, h, L, G, H)`, shape ``(..., 8)``.

        :math:`q = q_z(h)\\,q_x(\\sigma)\\,q_z(g)\\,q_x(\\beta)\\,q_z(l)` with :math:`q_z(a) = (\\cos\\frac a2, 0, 0,
        \\sin\\frac a2)`, :math:`q_x(a) = (\\cos\\frac a2, \\sin\\frac a2, 0, 0)` (the quaternion of the product of
        rotations of :meth:`to_body`, on the double cover: a turn of an angle changes the sign of ``(q, pi)``,
        the same state), and :math:`\\pi = 2q(0, m)`. The map is canonical: the Liouville form
        :math:`\\pi\\cdot dq` pulls back to :math:`L\\,dl + G\\,dg + H\\,dh` (Deprit and Elipe's quaternion form of
        the transformation); it is defined wherever the Serret-Andoyer chart is, whatever the Euler angles of
        the attitude (at their gimbal lock too).
        """
        sa = V.trailing_shape(sa, "sa", (6,))
        R, m = self.to_body(sa)  # checks the chart's ranges
        l_, g, h, L, G, H = (sa[..., k] for k in range(6))
        beta = np.arctan2(np.sqrt((G - L) * (G + L)), L)
        sigma = np.arctan2(np.sqrt((G - H) * (G + H)), H)
        zero = np.zeros_like(l_)

        def qz(a: np.ndarray) -> np.ndarray:
            return np.stack([np.cos(a / 2), zero, zero, np.sin(a / 2)], -1)

        def qx(a: np.ndarray) -> np.ndarray:
            return np.stack([np.cos(a / 2), np.sin(a / 2), zero, zero], -1)

        q = qz(h)
        for factor in (qx(sigma), qz(g), qx(beta), qz(l_)):
            q = _quat.multiply(q, factor)
        w, v = q[..., 0], q[..., 1:]
        pi = 2.0 * np.concatenate([-np.sum(v * m, -1)[..., None], w[..., None] * m + np.cross(v, m)], -1)
        return np.concatenate([q, pi], -1)

    def from_quaternion(self, y: Any) -> np.ndarray:
        """:math:`(l, g, h, L, G, H)` of a point :math:`(q, \\pi)` of the quaternion coordinates, shape ``(..., 6)``:
        :meth:`from_body` of its attitude and body momentum, with no Euler angle on the way (so along a motion
        through the Euler angles' gimbal lock as well)."""
        from .quaternion_coordinates import _body_momentum as _quaternion_momentum

        y = V.trailing_shape(y, "y", (8,))
        norm = np.linalg.norm(y[..., :4], axis=-1, keepdims=True)
        if np.any(norm == 0):
            raise InputError("Expected `y` to have a nonzero quaternion part q (its first four components).")
        return self.from_body(_quat.as_matrix(y[..., :4] / norm), _quaternion_momentum(y))

    # -- Euler coordinates <-> Serret-Andoyer -------------------------------------------------------
    def forward(self, q_euler: Any) -> np.ndarray:
        """:math:`(\\phi, \\theta, \\psi, \\Phi, \\Theta, \\Psi) \\mapsto (l, g, h, L, G, H)`, shape ``(..., 6)``.

        ``R`` by eq. (1) and ``m`` by eq. (6), then :meth:`from_body`.
        """
        q = _coordinates(q_euler, "q_euler")
        m = _body_momentum(q)
        return self.from_body(_matrix_from_angles(q[..., :3]), m)

    def inverse(self, sa: Any) -> np.ndarray:
        """:math:`(l, g, h, L, G, H) \\mapsto (\\phi, \\theta, \\psi, \\Phi, \\Theta, \\Psi)`, shape ``(..., 6)``.

        Raises :class:`~geomech.errors.SingularityError` also where the Euler chart is singular
        (:math:`\\theta = 0, \\pi`, i.e. :math:`b_3 = \\pm s_3`).
        """
        R, m = self.to_body(sa)
        angles = _angles_from_matrix(R, "the attitude of `sa`")
        return np.concatenate([angles, _momenta(angles, m)], -1)


# -- the free rigid body in Serret-Andoyer variables ---------------------------------------------------
def _inertia(inertia: Any) -> np.ndarray:
    arr = V.finite(inertia, "inertia")
    if arr.shape != (3,):
        raise InputError(f"Expected `inertia` to have shape (3,) (principal moments), got {arr.shape}.")
    return V.positive(arr, "inertia")


def reduced_hamiltonian(l: Any, L: Any, G: Any, inertia: Any) -> np.ndarray:
    """The free-rigid-body Hamiltonian in Serret-Andoyer variables (eq. 10), broadcast over the arguments.

    .. math::

        h(l, L; G) = \\tfrac12\\Big(\\frac{\\sin^2 l}{I_1} + \\frac{\\cos^2 l}{I_2}\\Big)(G^2 - L^2)
        + \\frac{L^2}{2 I_3},

    :math:`H = \\sum m_i^2/(2 I_i)` with ``m`` from eq. (20). Printed correctly in the paper.
    """
    I1, I2, I3 = _inertia(inertia)
    l = V.finite(l, "l")
    L = V.finite(L, "L")
    G = V.finite(G, "G")
    a = np.sin(l) ** 2 / I1 + np.cos(l) ** 2 / I2
    return 0.5 * a * (G - L) * (G + L) + L**2 / (2 * I3)


def reduced_vector_field(l: Any, L: Any, G: Any, inertia: Any) -> np.ndarray:
    """Hamilton's equations of eq. (10): :math:`(\\dot l, \\dot L)`, shape ``(..., 2)``.

    .. math::

        \\dot l = \\frac{\\partial h}{\\partial L} = L\\Big(\\frac1{I_3} - a(l)\\Big), \\qquad
        \\dot L = -\\frac{\\partial h}{\\partial l} = -\\tfrac12 (G^2 - L^2)\\sin 2l
        \\Big(\\frac1{I_1} - \\frac1{I_2}\\Big),

    :math:`a(l) = \\sin^2 l/I_1 + \\cos^2 l/I_2`. (:math:`\\dot L = \\dot m_3 = m_1 m_2 (1/I_2 - 1/I_1)`.)
    """
    I1, I2, I3 = _inertia(inertia)
    l = V.finite(l, "l")
    L = V.finite(L, "L")
    G = V.finite(G, "G")
    a = np.sin(l) ** 2 / I1 + np.cos(l) ** 2 / I2
    ldot = L * (1 / I3 - a)
    Ldot = -0.5 * (G - L) * (G + L) * np.sin(2 * l) * (1 / I1 - 1 / I2)
    ldot, Ldot = np.broadcast_arrays(ldot, Ldot)
    return np.stack([ldot, Ldot], -1)


def andoyer_hamiltonian(inertia: Any = None) -> sp.Expr:
    """Eq. (10) as a sympy expression in ``l, L, G`` (:attr:`ClassicalSerretAndoyer.symbols`) and
    ``I1, I2, I3`` (positive symbols) or, with ``inertia``, those values (as exact rationals of the floats).
    """
    l, _, _, L, G, _ = SA_SYMBOLS
    if inertia is None:
        I1, I2, I3 = sp.symbols("I1 I2 I3", positive=True)
    else:
        I1, I2, I3 = (sp.nsimplify(float(x), rational=True) for x in _inertia(inertia))
    return sp.Rational(1, 2) * (sp.sin(l) ** 2 / I1 + sp.cos(l) ** 2 / I2) * (G**2 - L**2) + L**2 / (2 * I3)


def momentum_l(l: Any, G: Any, energy: Any, inertia: Any, sign: Any) -> np.ndarray:
    """``L`` on the level set :math:`h(l, L; G) = E` (eq. 11b, with its sign restored).

    .. math::

        L = \\operatorname{sign}(L_0)\\, G \\sqrt{\\frac{A - a(l)}{1/I_3 - a(l)}}, \\qquad
        A = \\frac{2E}{G^2}, \\quad a(l) = \\frac{\\sin^2 l}{I_1} + \\frac{\\cos^2 l}{I_2}.

    The printed eq. (11b) takes the positive root only; ``L`` keeps the sign ``sign`` (that of its
    initial value) until a turning point of a libration. Raises :class:`InputError` where ``l`` is not
    reachable on this level (the radicand is negative or the denominator vanishes).
    """
    I1, I2, I3 = _inertia(inertia)
    l = V.finite(l, "l")
    G = V.finite(G, "G")
    A = 2 * V.finite(energy, "energy") / G**2
    s = np.sign(V.finite(sign, "sign"))
    # A - a and b - a as sums of cos^2 and sin^2 terms: no cancellation where both coefficients agree.
    c2, s2 = np.cos(l) ** 2, np.sin(l) ** 2
    num = (A - 1 / I2) * c2 + (A - 1 / I1) * s2
    den = (1 / I3 - 1 / I2) * c2 + (1 / I3 - 1 / I1) * s2
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = num / den
    bad = ~np.isfinite(ratio) | (ratio < 0) | (ratio > 1 + 1e-12)
    if np.any(bad):
        raise InputError(
            f"l = {_first(bad, l)[0]!r} is not reached on the level h = {energy} with G = {G}: "
            "(A - a(l)) / (1/I3 - a(l)) must lie in [0, 1]."
        )
    return s * G * np.sqrt(np.minimum(ratio, 1.0))


@dataclass(frozen=True)
class LPeriod:
    """The period of ``l`` on a level set of eq. (10), from the quadrature eq. (11).

    Attributes
    ----------
    period : float
        The period of :math:`l(t)`, which is also the least period of :math:`m(t)`.
    kind : {"circulating", "librating"}
        ``l`` runs round the circle (``m`` circles body axis 3, ``L`` keeps its sign) or oscillates
        between two turning points (``m`` circles body axis 1 or 2; ``L`` changes sign there).
    turning_points : tuple of float or None
        :math:`(l_-, l_+)`, the ends of the libration (where ``L = 0``); None for circulation. The
        interval is :math:`(c - w, c + w)` with centre ``c`` a multiple of pi/2: the copy that contains
        ``l0`` as given (not reduced modulo 2 pi) when ``l0`` is given, else ``c = 0`` or ``pi/2``.
    A : float
        :math:`2E/G^2`.
    error : float
        The quadrature's estimate of the absolute error of ``period``.
    """

    period: float
    kind: str
    turning_points: tuple[float, float] | None
    A: float
    error: float


def _quad(f, a: float, b: float, what: str) -> tuple[float, float]:
    from scipy.integrate import quad

    val, err = quad(f, a, b, epsabs=0.0, epsrel=1e-13, limit=400)
    if not np.isfinite(val) or err > 1e-9 * abs(val):
        raise ConvergenceError(
            f"The quadrature of eq. (11) for the period of l ({what}) did not converge: value {val!r}, "
            f"error estimate {err!r}. The level is probably too close to the separatrix."
        )
    return float(val), float(err)


def period_of_l(inertia: Any, G: Any, energy: Any, l0: Any = None) -> LPeriod:
    """The period of the Serret-Andoyer angle ``l`` of a free rigid body, by the quadrature eq. (11).

    With :math:`a(l) = \\sin^2 l/I_1 + \\cos^2 l/I_2`, :math:`b = 1/I_3`, :math:`A = 2E/G^2`,
    Hamilton's equation for eq. (10) and the energy level give

    .. math::

        \\dot l = \\frac{\\partial h}{\\partial L} = L\\,(b - a(l)), \\qquad
        L^2 = G^2 \\frac{A - a(l)}{b - a(l)}, \\qquad
        |\\dot l| = G\\sqrt{(A - a(l))(b - a(l))}\\quad\\text{(eq. 11a)}.

    - circulating (:math:`A` and :math:`b` on the same side of the range of :math:`a`):
      :math:`T = \\int_0^{2\\pi} dl/|\\dot l|`, with :math:`A - a(l) = (A - 1/I_2)\\cos^2 l +
      (A - 1/I_1)\\sin^2 l` (both terms of one sign, so free of cancellation);
    - librating (:math:`A` strictly inside the range of :math:`a`): ``l`` oscillates in
      :math:`|l - c| < w` about a centre :math:`c \\in \\{0, \\pi\\}` or :math:`\\{\\pm\\pi/2\\}`, where
      :math:`A - a(l) = \\kappa(\\sin^2 w - \\sin^2(l - c)) = \\kappa\\sin(w - x)\\sin(w + x)`,
      :math:`x = l - c`, :math:`T = 2\\int_{-w}^{w} dx/|\\dot l|`. The substitution
      :math:`x = w\\sin u` removes both inverse-square-root end singularities exactly:

      .. math::

          T = 2\\int_{-\\pi/2}^{\\pi/2}
          \\frac{du}{G\\sqrt{|\\kappa|\\,\\mathrm{sinc}(w(1 - \\sin u))\\,\\mathrm{sinc}(w(1 + \\sin u))\\,
          |b - a(c + w\\sin u)|}},

      a smooth integrand (``sinc x = sin x / x``) for adaptive Gauss-Kronrod (QUADPACK).

    Parameters
    ----------
    inertia : array_like, shape (3,)
        Principal moments :math:`(I_1, I_2, I_3)`, in any order.
    G : float
        :math:`|m| > 0`.
    energy : float
        The value of eq. (10).
    l0 : float, optional
        The initial ``l``; selects which of the two librating intervals (about ``c`` or ``c + pi``) is
        reported in ``turning_points`` (the period is the same). It must be reachable on the level.

    Returns
    -------
    LPeriod

    Notes
    -----
    Near the separatrix the period grows like :math:`-\\log|A - 1/I_{mid}|`, and :math:`A = 2E/G^2`
    formed from a rounded energy carries that difference with an absolute error of a few ulps; from
    initial data, :func:`period_of_l_from_momentum` forms it without cancellation.

    Raises
    ------
    InputError
        If no motion with this ``G`` has this energy, for a steady spin (``A`` at an extreme of
        :math:`\\{1/I_k\\}`: ``l`` does not move, or ``L = +-G``) and for ``l0`` off the level set.
    SingularityError
        On the separatrix (``A`` equal to the intermediate :math:`1/I_k`): infinite period.
    ConvergenceError
        If the quadrature fails to reach its tolerance (only extremely near the separatrix).
    """
    I = _inertia(inertia)
    G = V.positive_scalar(G, "G")
    E = V.finite(energy, "energy")
    if E.ndim != 0:
        raise InputError(f"Expected `energy` to be a scalar, got shape {E.shape}.")
    A = 2.0 * float(E) / G**2
    d = A - 1 / I
    tol = np.full(3, 64 * np.finfo(float).eps * float(np.max(1 / I)))
    l0v = None if l0 is None else float(V.finite(l0, "l0"))
    return _period(I, G, A, d, tol, l0v)


def period_of_l_from_momentum(inertia: Any, m0: Any) -> LPeriod:
    """:func:`period_of_l` for the motion through the body momentum ``m0`` (shape ``(3,)``).

    :math:`G = |m_0|`, :math:`l_0 = \\operatorname{atan2}(m_{0,1}, m_{0,2})` (eq. 20), and the level
    differences :math:`A - 1/I_k = \\sum_i (m_{0,i}/G)^2 (1/I_i - 1/I_k)` are formed without the
    cancellation of :math:`2E/G^2 - 1/I_k`, which matters near the separatrix (where the period depends
    on the logarithm of that difference) and near steady spins.
    """
    I = _inertia(inertia)
    m0 = V.exact_shape(m0, "m0", (3,))
    G = float(np.linalg.norm(m0))
    if G <= 0:
        raise InputError("Expected `m0` to be nonzero: at m = 0 nothing moves.")
    a = 1 / I
    w = (m0 / G) ** 2
    terms = w[:, None] * (a[:, None] - a[None, :])  # terms[i, k] = w_i (a_i - a_k)
    d = terms.sum(axis=0)
    tol = 8 * np.finfo(float).eps * np.abs(terms).sum(axis=0) + np.finfo(float).tiny
    A = float(np.dot(w, a))
    return _period(I, G, A, d, tol, math.atan2(m0[0], m0[1]))


def _period(I: np.ndarray, G: float, A: float, d: np.ndarray, tol: np.ndarray, l0: float | None) -> LPeriod:
    """The quadrature of eq. (11) given d_k = A - 1/I_k (k = 1, 2, 3), each accurate to tol_k."""
    a1, a2, b = 1 / I
    vals = np.array([a1, a2, b])
    d1, d2, d3 = d
    order = np.argsort(vals, kind="stable")
    kmin, kmid, kmax = (int(k) for k in order)
    if d[kmax] > tol[kmax] or d[kmin] < -tol[kmin]:
        raise InputError(
            f"No motion with G = {G!r} has this energy: 2E/G^2 = {A!r} must lie in [min 1/I_k, max 1/I_k] = "
            f"[{vals[kmin]!r}, {vals[kmax]!r}] for inertia {I.tolist()}."
        )
    steady = [k + 1 for k in range(3) if abs(d[k]) <= tol[k] and vals[k] in (vals[kmin], vals[kmax])]
    if steady:
        raise InputError(
            f"The level 2E/G^2 = {A!r} = 1/I_k (k = {steady}) is a steady spin about a principal axis of "
            f"extreme inertia: l is constant{' and L = +-G (the chart pole)' if 3 in steady else ''}, so it "
            "has no period."
        )
    if abs(d[kmid]) <= tol[kmid]:
        raise SingularityError(
            f"The level 2E/G^2 = {A!r} = 1/I_{kmid + 1} (the intermediate moment) is the separatrix of the "
            f"free rigid body with inertia {I.tolist()}: the motion is asymptotic to the unstable steady "
            "spin and the period of l is infinite."
        )
    b_a1, b_a2 = b - a1, b - a2

    def b_minus_a(l: float) -> float:
        return b_a2 * math.cos(l) ** 2 + b_a1 * math.sin(l) ** 2

    if d1 * d2 < 0:
        # A strictly between 1/I1 and 1/I2: L vanishes where sin^2 l = (A - a2)/(a1 - a2) = sin^2 alpha.
        # Centre 0: |l| < alpha, kappa = a1 - a2; centre pi/2: |l - pi/2| < pi/2 - alpha, kappa = a2 - a1.
        # The one on the level has sign(b - A) = sign(kappa).
        alpha = math.atan2(math.sqrt(abs(d2)), math.sqrt(abs(d1)))
        if -d3 * (a1 - a2) > 0:
            centre, w, kappa = 0.0, alpha, a1 - a2
        else:
            centre, w, kappa = 0.5 * math.pi, 0.5 * math.pi - alpha, a2 - a1
        if l0 is not None:
            for c in (centre, centre - math.pi):
                x = math.remainder(l0 - c, 2 * math.pi)
                if abs(x) <= w * (1 + 1e-9) + 1e-12:
                    # the copy of the interval that contains l0 as given (not reduced mod 2 pi)
                    centre = l0 - x
                    break
            else:
                raise InputError(
                    f"l0 = {l0!r} is not on the level 2E/G^2 = {A!r}: l librates in |l - c| <= {w!r} about "
                    f"c = {centre!r} or c + pi."
                )
        k = math.sqrt(abs(kappa))

        def f(u: float) -> float:
            su = math.sin(u)
            sinc_m = np.sinc(w * (1 - su) / math.pi)
            sinc_p = np.sinc(w * (1 + su) / math.pi)
            return 1.0 / (G * k * math.sqrt(sinc_m * sinc_p * abs(b_minus_a(centre + w * su))))

        val, err = _quad(f, -0.5 * math.pi, 0.5 * math.pi, "libration")
        return LPeriod(2 * val, "librating", (centre - w, centre + w), A, 2 * err)

    def g(l: float) -> float:
        # A - a(l) = (A - a2) cos^2 l + (A - a1) sin^2 l: both terms of one sign here.
        c2, s2 = math.cos(l) ** 2, math.sin(l) ** 2
        return 1.0 / (G * math.sqrt(abs((d2 * c2 + d1 * s2) * b_minus_a(l))))

    # a(l) is even and pi-periodic and symmetric about pi/2: a quarter of the circle suffices.
    val, err = _quad(g, 0.0, 0.5 * math.pi, "circulation")
    return LPeriod(4 * val, "circulating", None, A, 4 * err)
