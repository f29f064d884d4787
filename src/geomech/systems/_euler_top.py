"""Exact solution of the free rigid body (the Euler top) in Jacobi elliptic functions.

Euler's equations for the body angular momentum :math:`m` with principal moments
:math:`I = (I_1, I_2, I_3)` (any order) are

.. math::

    \\dot m = m \\times \\nabla H(m) = m \\times \\mathbb I^{-1} m, \\qquad
    H(m) = \\tfrac12 \\sum_i m_i^2 / I_i,

with the two invariants :math:`E = H(m)` and the Casimir :math:`|m|^2`. The solution is written in a
*working frame* ``w = R m``, ``R`` a signed permutation with :math:`\\det R = +1` (a proper rotation,
so :math:`R(a \\times b) = Ra \\times Rb` and Euler's equations keep their form with the permuted
moments :math:`J = (J_0, J_1, J_2)`). ``J_1`` is always the intermediate moment and ``J_0`` the moment
of the axis the orbit encircles; ``R`` is the plain permutation when it is cyclic and has its last row
negated when it is odd. The derivation is in the docstring of :class:`EulerTopSolution`; it follows
Landau and Lifshitz, *Mechanics*, section 37, but is written for either family and any order of
moments, so its signs are not the textbook's.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Literal

import numpy as np

from .. import _validate as V
from ..errors import InputError, NumericalError

__all__ = ["EulerTopSolution"]

Family = Literal["major", "minor", "separatrix", "steady", "axisymmetric", "spherical"]

_EPS = float(np.finfo(float).eps)

# Below this complementary parameter k'^2 the Jacobi functions come from their first-order expansion
# about k = 1 (exact in k'^2) instead of scipy.special.ellipj(u, 1 - k'^2): forming 1 - k'^2 rounds
# k'^2 by up to eps / k'^2 relatively, which costs ellipj ~1e-12 relative accuracy in cn and dn at
# k'^2 ~ 1e-9, while the expansion's O(k'^4 e^{2u}) remainder on u <= K/2 grows like k'^3; at this switch
# both are ~5e-13 relative (measured against mpmath at 40 digits).
_NEAR_SEPARATRIX = 1.5e-8


def _jacobi(u: np.ndarray, m: float, p: float, K: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Jacobi ``sn, cn, dn`` of ``u`` for parameter ``m = k^2`` with ``p = 1 - m`` given separately.

    ``u`` is reduced modulo the period ``4K`` and by the symmetries ``u -> -u``, ``u -> 2K - u`` to
    ``[0, K]``; the upper half of that quarter is mapped to ``[0, K/2]`` by the complementary
    relations ``sn(K - v) = cn v / dn v``, ``cn(K - v) = k' sn v / dn v``, ``dn(K - v) = k' / dn v``.
    That keeps the relative accuracy of ``cn`` near its zeros and of ``dn`` near its minimum ``k'``
    as ``k -> 1``, where ellipj alone (evaluated with ``m`` rounded near 1) does not.
    """
    from scipy.special import ellipj

    r = u - 4.0 * K * np.round(u / (4.0 * K))
    sign_sn = np.where(r < 0, -1.0, 1.0)
    a = np.abs(r)
    upper = a > K
    sign_cn = np.where(upper, -1.0, 1.0)
    b = np.where(upper, 2.0 * K - a, a)
    comp = b > 0.5 * K
    v = np.where(comp, K - b, b)
    if p < _NEAR_SEPARATRIX:
        # First order in k'^2 about k = 1 (A&S 16.15; cephes ellpj uses the same for m > 1 - 1e-10).
        ch, th = np.cosh(v), np.tanh(v)
        sech = 1.0 / ch
        twon = ch * np.sinh(v)
        q = 0.25 * p
        s = th + q * (twon - v) / (ch * ch)
        c = sech - q * th * sech * (twon - v)
        h = np.hypot(s, c)
        s, c = s / h, c / h
    else:
        s, c, _, _ = ellipj(v, m)
    # dn from sn, cn and the exact k'^2 (ellipj's own dn sees k'^2 through the rounded 1 - m): the
    # three then satisfy sn^2 + cn^2 = 1 and dn^2 = cn^2 + k'^2 sn^2 to round-off, so |m|^2 and E
    # are conserved to round-off whatever the error in the amplitude.
    d = np.sqrt(c * c + p * s * s)
    kp = math.sqrt(p)
    sn = np.where(comp, c / d, s)
    cn = np.where(comp, kp * s / d, c)
    dn = np.where(comp, kp / d, d)
    return sign_sn * sn, sign_cn * cn, dn


def _phase(sn0: float, cn0: float, p: float, K: float) -> float:
    """The ``u`` in ``(-2K, 2K]`` with ``sn u = sn0`` and ``cn u = cn0``, for parameter ``m = 1 - p``.

    Carlson's form :math:`F(\\varphi|m) = \\sin\\varphi\\, R_F(\\cos^2\\varphi, 1 - m \\sin^2\\varphi, 1)`
    of the incomplete integral (the integral scipy.special.ellipkinc computes) takes ``1 - m sn^2`` as
    ``cn^2 + k'^2 sn^2``, so ``k'^2`` is never rounded through ``m = 1 - k'^2`` and the phase keeps full
    relative accuracy as ``k -> 1``, including near ``K`` where ``ellipkinc(phi, m)`` does not.
    """
    from scipy.special import elliprf

    h = math.hypot(sn0, cn0)
    a, b = abs(sn0) / h, abs(cn0) / h
    u = a * float(elliprf(b * b, b * b + p * a * a, 1.0))  # in [0, K]
    if cn0 < 0:
        u = 2.0 * K - u
    return -u if sn0 < 0 else u


def _sech_tanh(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e = np.exp(-2.0 * np.abs(u))  # never overflows, unlike cosh(u) for |u| > 710
    return 2.0 * np.sqrt(e) / (1.0 + e), np.tanh(u)


def _frame(order: tuple[int, int, int]) -> np.ndarray:
    """Signed permutation ``R`` with rows ``e_order[0], e_order[1], +-e_order[2]`` and det +1."""
    R = np.eye(3)[list(order)]
    if order not in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        R[2] *= -1.0  # an odd permutation is a reflection: flip one axis to keep Euler's handedness
    R.setflags(write=False)
    return R


@dataclass(frozen=True, eq=False)
class EulerTopSolution:
    """Exact motion :math:`m(t)` of the body angular momentum of a free rigid body.

    Build it with :meth:`from_initial`; the constructor is not public API.

    Attributes
    ----------
    inertia : tuple of float
        Principal moments :math:`(I_1, I_2, I_3)`, in the order given.
    m0 : tuple of float
        Body angular momentum at ``t = 0``.
    family : str
        The kind of orbit of :math:`m` on the momentum sphere :math:`|m| = |m_0|`:

        ``"major"``
            Triaxial body, :math:`|m|^2 > 2 E I_{mid}`: low energy for the given :math:`|m|`; ``m``
            circulates round the axis of the **largest** moment (the body tumbles about the axis
            it would settle to if it dissipated energy). That component never changes sign.
        ``"minor"``
            Triaxial body, :math:`|m|^2 < 2 E I_{mid}`: ``m`` circulates round the axis of the
            **smallest** moment, whose component never changes sign.
        ``"separatrix"``
            Triaxial body, :math:`|m|^2 = 2 E I_{mid}` but ``m0`` not on the intermediate axis:
            ``m`` leaves the unstable intermediate-axis spin :math:`\\mp |m| e_{mid}` as
            :math:`t \\to -\\infty` and reaches :math:`\\pm |m| e_{mid}` as :math:`t \\to +\\infty`
            (a heteroclinic orbit; the tennis-racket flip takes infinite time). Data within the
            rounding of ``m0`` of the equality, :math:`|x - y| \\le 4 \\epsilon \\max(x, y)` with
            :math:`x = |m_{max}| \\sqrt{(I_{max} - I_{mid})/I_{max}}` and
            :math:`y = |m_{min}| \\sqrt{(I_{mid} - I_{min})/I_{min}}`, is put here.
        ``"steady"``
            ``m0`` along a principal axis (:attr:`axis`): a steady spin, ``m`` constant. It is
            Lyapunov stable (:attr:`stable`) about the largest and smallest moments and unstable about
            the intermediate one (nearby orbits are near-separatrix and flip over). For an
            axisymmetric body only the spin about the symmetry axis is called steady.
        ``"axisymmetric"``
            Two equal moments :math:`I_\\perp` and a distinct :math:`I_a` (:attr:`axis` = ``a``):
            :math:`m_a` is constant and the equatorial part of ``m`` rotates uniformly about
            :math:`e_a` at the rate :math:`\\Omega = m_a (1/I_a - 1/I_\\perp)`, the body-frame
            precession of a symmetric top. :math:`m_a = 0` gives :math:`\\Omega = 0`: every
            equatorial ``m`` is then an equilibrium.
        ``"spherical"``
            All moments equal: :math:`\\omega \\parallel m`, so ``m`` is constant.
    axis : int or None
        The spin axis of a ``"steady"`` solution and the symmetry axis of an ``"axisymmetric"`` one
        (indices into :attr:`inertia`); ``None`` otherwise.
    stable : bool or None
        For ``"steady"`` only: whether the spin is Lyapunov stable.
    energy : float
        :math:`E = \\tfrac12 \\sum_i m_i^2 / I_i`.
    casimir : float
        :math:`|m|^2`.
    k : float
        Elliptic modulus (scipy's parameter is ``k**2``). ``1`` on the separatrix and for the unstable
        steady spin, ``0`` for stable steady spins and the axisymmetric and spherical cases (the
        limits of the nearby elliptic orbits).
    rate : float
        The non-negative frequency :math:`\\lambda` multiplying ``t`` in the argument of the Jacobi
        (elliptic families) or hyperbolic (separatrix) functions, :math:`|\\Omega|` for an
        axisymmetric body, ``0`` when ``m`` is constant.
    period : float
        The least period of ``m(t)``: :math:`4K(k)/\\lambda` for ``"major"`` and ``"minor"``,
        :math:`2\\pi/|\\Omega|` for ``"axisymmetric"``. ``math.inf`` for the separatrix (``m`` never
        returns) and, by convention, ``math.inf`` also whenever ``m`` is constant (``"steady"``,
        ``"spherical"``, axisymmetric with :math:`\\Omega = 0`): there is no oscillation, so no least
        period, and ``rate`` is 0.

    Notes
    -----
    In the working frame ``w = R m`` (module docstring) with :math:`J_0` the encircled axis
    (``J_0 = I_max`` for ``"major"``, ``I_min`` for ``"minor"``) and :math:`J_1 = I_{mid}`, write
    :math:`G = |m|^2 - 2 E J_1 = \\sum_i w_i^2 (J_i - J_1)/J_i` (> 0 for major, < 0 for minor). Then

    .. math::

        w(t) = \\bigl(s_0 A\\, \\mathrm{dn}\\, u,\\; B\\, \\mathrm{sn}\\, u,\\; s_2 C\\, \\mathrm{cn}\\, u\\bigr),
        \\qquad u = \\lambda t + u_0,

    .. math::

        A^2 = w_0^2 + w_1^2 \\tfrac{J_0 (J_1 - J_2)}{J_1 (J_0 - J_2)}, \\quad
        B^2 = w_1^2 + w_2^2 \\tfrac{J_1 (J_2 - J_0)}{J_2 (J_1 - J_0)}, \\quad
        C^2 = w_2^2 + w_1^2 \\tfrac{J_2 (J_1 - J_0)}{J_1 (J_2 - J_0)},

    .. math::

        k^2 = \\frac{B^2}{A^2} \\frac{J_0 (J_1 - J_2)}{J_1 (J_0 - J_2)}, \\quad
        k'^2 = \\frac{J_0\\, G}{(J_0 - J_1) A^2}, \\quad
        \\lambda = \\frac{A}{J_0} \\sqrt{\\frac{(J_0 - J_1)(J_0 - J_2)}{J_1 J_2}},

    :math:`s_0 = \\operatorname{sign} w_0`, :math:`s_2 = s_0 \\operatorname{sign}(J_2 - J_0)` (this choice
    makes :math:`\\lambda > 0`), and :math:`u_0` the argument with
    :math:`\\mathrm{sn}\\, u_0 = w_1 / B`, :math:`\\mathrm{cn}\\, u_0 = s_2 w_2 / C` (an incomplete elliptic
    integral of the first kind, quadrant from the two signs). Every term of :math:`A^2, B^2, C^2` is
    non-negative, so they carry no cancellation near a steady spin. Substituting
    :math:`\\mathrm{sn}' = \\mathrm{cn\\,dn}`, :math:`\\mathrm{cn}' = -\\mathrm{sn\\,dn}`,
    :math:`\\mathrm{dn}' = -k^2 \\mathrm{sn\\,cn}` reduces the three equations
    :math:`\\dot w_i = w_{i+1} w_{i+2} (1/J_{i+2} - 1/J_{i+1})` to the definitions above (checked
    symbolically in the tests). For :math:`J_0 = I_3 > J_1 = I_2 > J_2 = I_1` it is Landau-Lifshitz
    eq. (37.10) up to the signs :math:`s_0, s_2`.

    On the separatrix (``R`` built with :math:`J_0 = I_{max}`), with :math:`\\mu = |m|`,

    .. math::

        w(t) = \\mu \\bigl(s_0 \\hat A\\, \\mathrm{sech}\\, u,\\; \\sigma \\tanh u,\\; s_2 \\hat C\\,
        \\mathrm{sech}\\, u\\bigr), \\quad
        \\hat A^2 = \\tfrac{J_0 (J_1 - J_2)}{J_1 (J_0 - J_2)}, \\quad
        \\hat C^2 = \\tfrac{J_2 (J_0 - J_1)}{J_1 (J_0 - J_2)}, \\quad
        \\lambda = \\frac{\\mu}{J_1} \\sqrt{\\frac{(J_0 - J_1)(J_1 - J_2)}{J_0 J_2}},

    :math:`s_0, s_2` the signs of :math:`w_0, w_2`, :math:`\\sigma = -s_0 s_2` the direction of the flip
    and :math:`\\sinh u_0 = \\sigma w_1 / \\sqrt{w_0^2 + w_2^2}`.
    """

    inertia: tuple[float, float, float]
    m0: tuple[float, float, float]
    family: Family
    energy: float
    casimir: float
    k: float
    rate: float
    period: float
    axis: int | None = None
    stable: bool | None = None
    # Working-frame data: w = R m; amplitudes of (w0, w1, w2) with their signs (for an axisymmetric body
    # _amp[0] is the signed precession rate), phase u0, quarter period K, k'^2.
    _R: np.ndarray | None = field(default=None, repr=False)
    _amp: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), repr=False)
    _u0: float = field(default=0.0, repr=False)
    _K: float = field(default=0.0, repr=False)
    _kp2: float = field(default=0.0, repr=False)

    # -- construction --------------------------------------------------------------------------
    @classmethod
    def from_initial(cls, inertia: Any, m0: Any) -> EulerTopSolution:
        """The solution with :math:`m(0) = m_0` for principal moments ``inertia`` (any order).

        Parameters
        ----------
        inertia : array_like, shape (3,)
            Positive principal moments, in any order (the triangle inequality is not needed by the
            formulas and is not checked).
        m0 : array_like, shape (3,)
            Finite, nonzero body angular momentum in the same principal frame.

        Raises
        ------
        InputError
            ``m0`` (or ``inertia``) not finite, of the wrong shape, zero, or so large that
            :math:`|m_0|^2` overflows.
        NumericalError
            ``m0`` is off the separatrix by so little (about ``1e-154 |m0|`` from the unstable spin)
            that :math:`k'^2` underflows the float64 normal range; or a derived constant came out
            non-finite (not expected for valid input).
        """
        from scipy.special import ellipk, ellipkm1

        I = V.positive(V.exact_shape(inertia, "inertia", (3,)), "inertia")
        m = V.exact_shape(m0, "m0", (3,))
        big = float(np.abs(m).max())
        if big == 0.0:
            raise InputError("Expected `m0` to be nonzero, got [0., 0., 0.]; m = 0 is the body at rest.")
        x = m / big
        mu = big * float(np.linalg.norm(x))  # |m0| without overflow or underflow in the squares
        n = m / mu
        casimir = mu * mu
        energy = 0.5 * casimir * float(np.sum(n * n / I))
        if not (math.isfinite(casimir) and math.isfinite(energy)):
            raise InputError(f"Expected `m0` small enough that |m0|^2 is finite in float64, got |m0| = {mu:g}.")
        base: dict[str, Any] = {
            "inertia": tuple(float(v) for v in I),
            "m0": tuple(float(v) for v in m),
            "energy": energy,
            "casimir": casimir,
        }
        inf = math.inf

        if I[0] == I[1] == I[2]:
            return cls(family="spherical", k=0.0, rate=0.0, period=inf, **base)

        if I[0] == I[1] or I[1] == I[2] or I[0] == I[2]:
            a = next(i for i in range(3) if I[i] != I[(i + 1) % 3] and I[i] != I[(i + 2) % 3])
            b, c = (a + 1) % 3, (a + 2) % 3
            if n[b] == 0.0 and n[c] == 0.0:
                return cls(family="steady", k=0.0, rate=0.0, period=inf, axis=a, stable=True, **base)
            # Signed precession rate (kept in _amp[0]); I_b - I_a rather than 1/I_a - 1/I_b, whose rounded
            # reciprocals would cancel for nearly equal moments.
            omega = float(m[a] * (I[b] - I[a]) / (I[a] * I[b]))
            return cls(
                family="axisymmetric", k=0.0, rate=abs(omega), period=2 * math.pi / abs(omega) if omega else inf,
                axis=a, _R=_frame((b, c, a)), _amp=(omega, 0.0, 0.0), **base,
            )  # fmt: skip

        imin, imid, imax = (int(i) for i in np.argsort(I))
        nonzero = np.flatnonzero(n)
        if nonzero.size == 1:
            ax = int(nonzero[0])
            unstable = ax == imid
            return cls(
                family="steady", k=1.0 if unstable else 0.0, rate=0.0, period=inf, axis=ax, stable=not unstable,
                **base,
            )  # fmt: skip

        # Separatrix test on square roots, x^2 - y^2 = (|m|^2 - 2 E I_mid) / |m|^2: no underflow for tiny
        # components, and a tolerance of the order of the rounding of m0.
        x = abs(n[imax]) * math.sqrt((I[imax] - I[imid]) / I[imax])
        y = abs(n[imin]) * math.sqrt((I[imid] - I[imin]) / I[imin])
        # G = x^2 - y^2 cancels near the separatrix, and k'^2 and the period inherit its relative
        # error; rational arithmetic on the float data makes it exact (and its sign exact).
        Fr = [Fraction(float(v)) for v in I]
        G_exact = sum(Fraction(float(v)) ** 2 * (Fr[i] - Fr[imid]) / Fr[i] for i, v in enumerate(m))

        if abs(x - y) <= 4.0 * _EPS * max(x, y):
            R = _frame((imax, imid, imin))
            w = R @ n
            J0, J1, J2 = I[imax], I[imid], I[imin]
            s0, s2 = math.copysign(1.0, w[0]), math.copysign(1.0, w[2])
            sigma = -s0 * s2
            A = math.sqrt(J0 * (J1 - J2) / (J1 * (J0 - J2)))
            C = math.sqrt(J2 * (J0 - J1) / (J1 * (J0 - J2)))
            lam = mu / J1 * math.sqrt((J0 - J1) * (J1 - J2) / (J0 * J2))
            h = math.hypot(w[0], w[2])
            if abs(w[1]) < 1e300 * h:
                u0 = math.asinh(sigma * w[1] / h)
            else:  # asinh(z) = sign(z) log(2 |z|) to round-off for |z| > 1e300, without overflowing z
                u0 = math.copysign(math.log(2.0) + math.log(abs(w[1])) - math.log(h), sigma * w[1])
            sol = cls(
                family="separatrix", k=1.0, rate=lam, period=inf, _R=R,
                _amp=(mu * s0 * A, mu * sigma, mu * s2 * C), _u0=u0, **base,
            )  # fmt: skip
            return sol._checked()

        major = G_exact > 0
        order = (imax, imid, imin) if major else (imin, imid, imax)
        R = _frame(order)
        w = R @ n
        J0, J1, J2 = (float(I[i]) for i in order)
        rA = J0 * (J1 - J2) / (J1 * (J0 - J2))
        rB = J1 * (J2 - J0) / (J2 * (J1 - J0))
        A = math.hypot(w[0], w[1] * math.sqrt(rA))
        B = math.hypot(w[1], w[2] * math.sqrt(rB))
        C = B / math.sqrt(rB)
        m_par = (B / A) ** 2 * rA
        # k'^2 = J0 G / ((J0 - J1) A^2), from the exact G (G itself may underflow where k'^2 does not).
        p = float(G_exact * Fraction(J0) / ((Fraction(J0) - Fraction(J1)) * Fraction(A) ** 2 * Fraction(mu) ** 2))
        if p < sys.float_info.min:
            raise NumericalError(
                f"EulerTopSolution for inertia={tuple(I.tolist())}, m0={tuple(m.tolist())}: m0 is so close to "
                f"the separatrix (or to the unstable intermediate-axis spin) that k'^2 = 1 - k^2 = {p:.3g} is "
                "below the float64 normal range, so the period and the phase cannot be computed accurately."
            )
        K = float(ellipkm1(p)) if p <= 0.5 else float(ellipk(m_par))
        lam = mu * A / J0 * math.sqrt((J0 - J1) * (J0 - J2) / (J1 * J2))
        s0 = math.copysign(1.0, w[0])
        s2 = s0 * math.copysign(1.0, J2 - J0)
        u0 = _phase(w[1] / B, s2 * w[2] / C, p, K)
        sol = cls(
            family="major" if major else "minor", k=math.sqrt(m_par), rate=lam, period=4.0 * K / lam, _R=R,
            _amp=(mu * s0 * A, mu * B, mu * s2 * C), _u0=u0, _K=K, _kp2=p, **base,
        )  # fmt: skip
        return sol._checked()

    def _checked(self) -> EulerTopSolution:
        values = (self.k, self.rate, self._u0, self._K, self._kp2, *self._amp)
        if not all(math.isfinite(v) for v in values) or self.rate <= 0:
            raise NumericalError(
                f"EulerTopSolution for inertia={self.inertia}, m0={self.m0} ({self.family}): a derived "
                f"constant is not finite or the rate is not positive (k={self.k}, rate={self.rate}, "
                f"u0={self._u0}, K={self._K}, k'^2={self._kp2}, amplitudes={self._amp})."
            )
        return self

    # -- evaluation -----------------------------------------------------------------------------
    def momentum(self, t: Any) -> np.ndarray:
        """Body angular momentum :math:`m(t)`, shape ``t.shape + (3,)``; ``t`` may be negative.

        Parameters
        ----------
        t : array_like
            Times, any shape, finite.

        Raises
        ------
        NumericalError
            If the result is not finite (it is for every finite ``t`` at which ``rate * t`` is
            representable).
        """
        t = V.finite(t, "t")
        fam = self.family
        if fam in ("spherical", "steady") or (fam == "axisymmetric" and self.rate == 0.0):
            return np.broadcast_to(np.asarray(self.m0), t.shape + (3,)).copy()
        m0 = np.asarray(self.m0)
        assert self._R is not None  # set for every family that moves
        if fam == "axisymmetric":
            w = self._R @ m0
            phase = self._amp[0] * t
            c, s = np.cos(phase), np.sin(phase)
            out = np.stack([w[0] * c + w[1] * s, w[1] * c - w[0] * s, np.full_like(t, w[2])], axis=-1)
        else:
            u = self.rate * t + self._u0
            if fam == "separatrix":
                sech, tanh = _sech_tanh(u)
                f = (sech, tanh, sech)
            else:
                sn, cn, dn = _jacobi(u, self.k**2, self._kp2, self._K)
                f = (dn, sn, cn)
            out = np.stack([a * fi for a, fi in zip(self._amp, f)], axis=-1)
        m = out @ self._R  # m = R^T w
        if not np.all(np.isfinite(m)):
            bad = np.asarray(t)[~np.all(np.isfinite(m), axis=-1)]
            raise NumericalError(
                f"EulerTopSolution.momentum: non-finite result at t = {bad.ravel()[:3].tolist()} "
                f"({self.family}, rate {self.rate:g}); rate * t is too large to evaluate."
            )
        return m
