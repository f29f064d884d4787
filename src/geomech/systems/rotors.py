"""Rigid bodies carrying symmetric rotors (momentum wheels): sections 6 and 7 of the Serret-Andoyer paper.

A main body carries :math:`N` symmetric rotors; rotor :math:`i` spins about the body-fixed unit axis
:math:`a_i` with axial moment of inertia :math:`J_i` and angle :math:`\\gamma_i` relative to the body.
With :math:`\\Lambda` the inertia tensor of body and rotors *with each rotor's own axial moment left
out* (the seed's :math:`\\operatorname{diag}(\\lambda_1, \\lambda_2, I_3)` of section 6 and
:math:`\\Lambda = \\operatorname{diag}(\\lambda_i)` of section 7) and :math:`A = [a_1 \\cdots a_N]`, the
Lagrangian (eq. 22, eq. 35 with its rotor term squared) is

.. math::

    L_f(\\omega, \\dot\\gamma) = \\tfrac12\\, \\omega\\cdot\\Lambda\\,\\omega
        + \\sum_i \\tfrac{J_i}{2} (a_i\\cdot\\omega + \\dot\\gamma_i)^2 .

Its Legendre transform (eqs. 23, 36) gives the total body angular momentum and the rotors' axial momenta

.. math::

    m = \\Lambda\\omega + A\\Gamma, \\qquad \\Gamma_i = J_i (a_i\\cdot\\omega + \\dot\\gamma_i),

and the free Hamiltonian (eqs. 24, 37), left-invariant on :math:`T^*(SO(3)\\times T^N)`:

.. math::

    H_f(m, \\Gamma) = \\tfrac12 (m - A\\Gamma)\\cdot\\Lambda^{-1}(m - A\\Gamma)
        + \\sum_i \\frac{\\Gamma_i^2}{2 J_i}.

With a torque :math:`u_i` applied to rotor :math:`i` by a motor on the body, the open-loop controlled
equations (eqs. 26, 38) are

.. math::

    \\dot R = R\\,\\widehat{D_1 H_f}, \\quad \\dot m = m\\times D_1 H_f, \\quad
    \\dot\\gamma = D_2 H_f, \\quad \\dot\\Gamma = u,

with :math:`D_1 H_f = \\omega = \\Lambda^{-1}(m - A\\Gamma)` and
:math:`D_2 H_f = \\dot\\gamma = \\Gamma/J - A^T\\omega`. Internal torques leave the total spatial
angular momentum :math:`\\pi = R m` constant; the energy changes at the rate
:math:`\\dot H_f = u\\cdot\\dot\\gamma` (the motors' power), so it is conserved when :math:`u = 0`.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError
from ..lie.so3 import hat
from ..symbolic.compile import M_SYMBOLS

__all__ = ["RotorBody", "torque_function"]

#: Elevation of the wheel axes above the base plane that makes the four-wheel pyramid isotropic,
#: A A^T = (4/3) I: 2 cos^2(beta) = 4 sin^2(beta), i.e. tan(beta) = 1/sqrt(2) (35.26 degrees).
ISOTROPIC_PYRAMID_ELEVATION = float(np.arctan(1.0 / np.sqrt(2.0)))


@functools.cache
def _positive_symbols(names: str) -> tuple[sp.Symbol, ...]:
    """``sp.symbols(names, positive=True)`` as a tuple, made once (a run reads them several times)."""
    return tuple(sp.symbols(names, positive=True, seq=True))


@dataclass(frozen=True, eq=False)
class RotorBody:
    """A rigid body with :math:`N` symmetric rotors on body-fixed unit axes.

    Parameters
    ----------
    inertia : (3, 3) or (3,)
        :math:`\\Lambda`, the inertia of body and rotors in the body frame with each rotor's axial moment
        left out (symmetric positive definite; three numbers mean a diagonal tensor).
    axes : (N, 3)
        The rotor axes :math:`a_i` in the body frame (normalised here; each must be nonzero).
    rotor_inertia : (N,) or None
        The rotors' axial moments :math:`J_i > 0`. ``None`` leaves them unspecified: the closed-loop
        analysis of a structure-preserving control does not depend on them (the closed-loop Hamiltonian
        involves :math:`\\Lambda` only), while the free Hamiltonian, the rotor rates and open-loop
        simulation need them and say so.
    name : str
        A label.

    Use :meth:`one_rotor` (section 6), :meth:`three_rotors` (section 7) or :meth:`pyramid` (the usual
    four-wheel spacecraft layout) for the common layouts. The locked inertia (rotors not spinning
    relative to the body) is :attr:`locked_inertia` :math:`= \\Lambda + \\sum_i J_i a_i a_i^T`.
    """

    inertia: np.ndarray
    axes: np.ndarray
    rotor_inertia: np.ndarray | None = None
    name: str = "rigid body with rotors"

    def __post_init__(self) -> None:
        lam = V.finite(self.inertia, "inertia")
        if lam.shape == (3,):
            lam = np.diag(V.positive(lam, "inertia"))
        elif lam.shape != (3, 3):
            raise InputError(f"Expected `inertia` to have shape (3,) or (3, 3), got {lam.shape}.")
        if not np.allclose(lam, lam.T, rtol=1e-12, atol=1e-14 * np.abs(lam).max()):
            raise InputError(
                f"Expected `inertia` to be symmetric, got max |Lambda - Lambda^T| = {np.abs(lam - lam.T).max():.3g}."
            )
        lam = 0.5 * (lam + lam.T)
        eig = np.linalg.eigvalsh(lam)
        if eig[0] <= 0:
            raise InputError(f"Expected `inertia` to be positive definite, got eigenvalues {eig.tolist()}.")
        axes = V.finite(self.axes, "axes")
        if axes.ndim == 1:
            axes = axes[None, :]
        if axes.ndim != 2 or axes.shape[1] != 3 or axes.shape[0] == 0:
            raise InputError(f"Expected `axes` to have shape (N, 3) with N >= 1, got {np.shape(self.axes)}.")
        norms = np.linalg.norm(axes, axis=1)
        if np.any(norms < 1e-12):
            raise InputError(f"Expected every rotor axis to be nonzero, got norms {norms.tolist()}.")
        axes = axes / norms[:, None]
        J = None
        if self.rotor_inertia is not None:
            J = np.atleast_1d(V.positive(self.rotor_inertia, "rotor_inertia")).astype(float)
            if J.shape != (axes.shape[0],):
                raise InputError(
                    f"Expected `rotor_inertia` to have one entry per rotor ({axes.shape[0]}), got shape {J.shape}."
                )
            J.setflags(write=False)
        for arr in (lam, axes):
            arr.setflags(write=False)
        object.__setattr__(self, "inertia", lam)
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "rotor_inertia", J)

    # -- the seed's layouts ------------------------------------------------------------------------
    @classmethod
    def one_rotor(cls, lambda1: float, lambda2: float, I3: float, J3: float | None = None) -> RotorBody:
        """One symmetric rotor on principal axis 3 (section 6, Figure 4).

        ``lambda1``, ``lambda2`` are :math:`\\lambda_i = I_i + J_i` (body plus rotor transverse moments),
        ``I3`` the body's own moment about axis 3 and ``J3`` the rotor's axial moment; the locked
        inertia is :math:`(\\lambda_1, \\lambda_2, I_3 + J_3)`.
        """
        lam = V.positive(np.array([lambda1, lambda2, I3], dtype=float), "(lambda1, lambda2, I3)")
        J = None if J3 is None else np.array([V.positive_scalar(J3, "J3")])
        return cls(np.diag(lam), np.array([[0.0, 0.0, 1.0]]), J, name="rigid body with one rotor on axis 3")

    @classmethod
    def three_rotors(cls, lambdas: Any, J: Any = None) -> RotorBody:
        """Three symmetric rotors on the principal axes (section 7): :math:`\\Lambda = \\operatorname{diag}
        (\\lambda_i)` without the rotors' axial moments :math:`J_i`; the locked inertia is
        :math:`\\Lambda + \\operatorname{diag}(J)`."""
        lam = V.positive(lambdas, "lambdas")
        if lam.shape != (3,):
            raise InputError(f"Expected `lambdas` to have shape (3,), got {lam.shape}.")
        return cls(np.diag(lam), np.eye(3), J, name="rigid body with three rotors on the principal axes")

    @classmethod
    def pyramid(
        cls, inertia: Any, J: Any, *, elevation: float = ISOTROPIC_PYRAMID_ELEVATION, azimuth: float = 0.0
    ) -> RotorBody:
        """Four wheels in a pyramid: :math:`a_k = (\\cos\\beta\\cos\\alpha_k, \\cos\\beta\\sin\\alpha_k,
        \\sin\\beta)`, :math:`\\alpha_k = \\alpha_0 + k\\pi/2`.

        ``elevation`` :math:`\\beta` defaults to :math:`\\arctan(1/\\sqrt 2)`, for which
        :math:`A A^T = \\tfrac43 I` (equal momentum capacity about every body axis); any three of the
        four axes are linearly independent for :math:`0 < \\beta < \\pi/2`, so one wheel can fail.
        ``J`` is one axial moment for all wheels or four.
        """
        beta = float(V.finite(elevation, "elevation"))
        if not (0.0 < beta < np.pi / 2):
            raise InputError(f"Expected `elevation` in (0, pi/2) radians, got {beta}.")
        alpha = float(V.finite(azimuth, "azimuth")) + np.arange(4) * np.pi / 2
        axes = np.stack([np.cos(beta) * np.cos(alpha), np.cos(beta) * np.sin(alpha), np.full(4, np.sin(beta))], 1)
        J = np.broadcast_to(V.positive(J, "J"), (4,)).copy()
        return cls(inertia, axes, J, name="rigid body with a four-wheel pyramid")

    # -- structure -------------------------------------------------------------------------------
    @property
    def n_rotors(self) -> int:
        return int(self.axes.shape[0])

    @property
    def A(self) -> np.ndarray:
        """The (3, N) matrix whose columns are the rotor axes."""
        return self.axes.T

    @functools.cached_property
    def is_principal(self) -> bool:
        """Whether :math:`\\Lambda` is diagonal and every rotor axis is a body axis (the seed's layouts)."""
        lam = self.inertia
        diag = np.all(lam == np.diag(np.diag(lam)))
        return bool(diag and np.all(np.isclose(np.abs(self.axes).max(axis=1), 1.0, rtol=0, atol=1e-15)))

    def require_rotor_inertia(self, feature: str) -> np.ndarray:
        """The rotors' axial moments, or an :class:`InputError` saying ``feature`` needs them."""
        if self.rotor_inertia is None:
            raise InputError(
                f"{feature} needs the rotors' axial moments of inertia; build the body with "
                "`rotor_inertia` (J3=... for RotorBody.one_rotor)."
            )
        return self.rotor_inertia

    @property
    def locked_inertia(self) -> np.ndarray:
        """:math:`\\Lambda + \\sum_i J_i a_i a_i^T`, the inertia with every rotor locked to the body."""
        J = self.require_rotor_inertia("The locked inertia")
        return self.inertia + (self.A * J) @ self.A.T

    # -- Legendre transform and Hamiltonian (eqs. 23-24, 36-37) ------------------------------------
    def _mg(self, m: Any, Gamma: Any) -> tuple[np.ndarray, np.ndarray]:
        m = V.trailing_shape(m, "m", (3,))
        Gamma = V.finite(Gamma, "Gamma")
        Gamma = V.trailing_shape(Gamma[None] if Gamma.ndim == 0 else Gamma, "Gamma", (self.n_rotors,))
        return m, Gamma

    def angular_velocity(self, m: Any, Gamma: Any) -> np.ndarray:
        """:math:`\\omega = D_1 H_f(m, \\Gamma) = \\Lambda^{-1}(m - A\\Gamma)`, shape ``(..., 3)``."""
        m, Gamma = self._mg(m, Gamma)
        return np.linalg.solve(self.inertia, (m - Gamma @ self.axes)[..., None])[..., 0]

    def rotor_rates(self, m: Any, Gamma: Any) -> np.ndarray:
        """:math:`\\dot\\gamma = D_2 H_f(m, \\Gamma) = \\Gamma/J - A^T\\omega`, shape ``(..., N)``."""
        J = self.require_rotor_inertia("The rotor rates")
        m, Gamma = self._mg(m, Gamma)
        return Gamma / J - self.angular_velocity(m, Gamma) @ self.A

    def hamiltonian(self, m: Any, Gamma: Any) -> np.ndarray:
        """The free Hamiltonian :math:`H_f(m, \\Gamma)` (eq. 24 for one rotor, eq. 37 for three)."""
        J = self.require_rotor_inertia("The free Hamiltonian")
        m, Gamma = self._mg(m, Gamma)
        w = self.angular_velocity(m, Gamma)
        return 0.5 * np.einsum("...i,...i->...", m - Gamma @ self.axes, w) + 0.5 * np.sum(Gamma**2 / J, -1)

    def legendre(self, omega: Any, gamma_dot: Any) -> tuple[np.ndarray, np.ndarray]:
        """:math:`(\\omega, \\dot\\gamma) \\mapsto (m, \\Gamma)` (eqs. 23, 36)."""
        J = self.require_rotor_inertia("The Legendre transform")
        omega = V.trailing_shape(omega, "omega", (3,))
        gamma_dot = V.trailing_shape(gamma_dot, "gamma_dot", (self.n_rotors,))
        Gamma = J * (omega @ self.A + gamma_dot)
        return omega @ self.inertia.T + Gamma @ self.axes, Gamma

    def lagrangian(self, omega: Any, gamma_dot: Any) -> np.ndarray:
        """:math:`L_f(\\omega, \\dot\\gamma)` (eq. 22; eq. 35 with the rotor term squared)."""
        J = self.require_rotor_inertia("The Lagrangian")
        omega = V.trailing_shape(omega, "omega", (3,))
        gamma_dot = V.trailing_shape(gamma_dot, "gamma_dot", (self.n_rotors,))
        rel = omega @ self.A + gamma_dot
        return 0.5 * np.einsum("...i,ij,...j->...", omega, self.inertia, omega) + 0.5 * np.sum(J * rel**2, -1)

    def wheel_momentum(self, Gamma: Any) -> np.ndarray:
        """The rotors' share of the body momentum, :math:`A\\Gamma` (body frame); :math:`m - A\\Gamma =
        \\Lambda\\omega` is the rest. Wheel saturation is a bound on the :math:`\\Gamma_i`."""
        Gamma = V.trailing_shape(Gamma, "Gamma", (self.n_rotors,))
        return Gamma @ self.axes

    @property
    def Gamma_symbols(self) -> tuple[sp.Symbol, ...]:
        """The rotor momenta ``Gamma1 .. GammaN`` of :attr:`H_f` (real symbols)."""
        return tuple(sp.symbols(f"Gamma1:{self.n_rotors + 1}", real=True))

    @property
    def H_f(self) -> sp.Expr:
        """The free Hamiltonian :math:`H_f` (eqs. 24, 37) as sympy, in ``m1, m2, m3`` and
        :attr:`Gamma_symbols`; :meth:`hamiltonian` evaluates it.

        For the seed's layouts the inertias are the symbols ``lambda1, lambda2, I3, J3`` (one rotor) or
        ``lambda1..3, J1..3`` (three rotors); otherwise numbers.
        """
        J = self.require_rotor_inertia("The free Hamiltonian")
        Gam = self.Gamma_symbols
        lam_syms, J_syms = self.symbols()
        Js: Sequence[Any]
        m = sp.Matrix(M_SYMBOLS)
        A = sp.Matrix(self.A.tolist()) if not self.is_principal else sp.Matrix(np.rint(self.A).astype(int).tolist())
        if lam_syms is not None:
            lam_inv = sp.diag(*[1 / s for s in lam_syms])
            Js = J_syms
        else:
            lam_inv = sp.Matrix(np.linalg.inv(self.inertia).tolist())
            Js = [sp.Float(x) for x in J]
        rel = m - A * sp.Matrix(Gam)
        expr = (rel.T * lam_inv * rel)[0, 0] / 2 + sum(g**2 / (2 * j) for g, j in zip(Gam, Js))
        return sp.expand(expr)

    def symbols(self) -> tuple[tuple[sp.Symbol, ...] | None, tuple[sp.Symbol, ...]]:
        """The inertia symbols of the seed's layouts: ``(lambda1, lambda2, I3)`` and ``(J3,)`` for one
        rotor on axis 3, ``(lambda1, lambda2, lambda3)`` and ``(J1, J2, J3)`` for three on the principal
        axes; ``(None, ...)`` for other layouts (numbers are used)."""
        if self.is_principal and self.n_rotors == 1 and abs(self.axes[0, 2]) == 1.0:
            return _positive_symbols("lambda1 lambda2 I3"), _positive_symbols("J3")
        if self.is_principal and self.n_rotors == 3 and np.array_equal(np.abs(self.axes), np.eye(3)):
            return _positive_symbols("lambda1:4"), _positive_symbols("J1:4")
        return None, _positive_symbols(f"J1:{self.n_rotors + 1}")

    @property
    def parameters(self) -> dict[str, float]:
        """The named inertias of the seed's layouts (:meth:`symbols`) and their values, as every system's
        ``parameters``; empty for other layouts, which are given by numbers."""
        return self.parameter_values()

    def with_parameters(self, **values: float) -> RotorBody:
        """The same layout with other named inertias (``lambda1, lambda2, I3, J3`` for one rotor on axis 3,
        ``lambda1..3, J1..3`` for three on the principal axes)."""
        lam_syms, J_syms = self.symbols()
        known = set(self.parameters) | ({str(s) for s in J_syms} if lam_syms is not None else set())
        new = V.parameter_update(values, known, self.name, known)
        lam = np.array(self.inertia, dtype=float)
        for i, s in enumerate(lam_syms or ()):
            lam[i, i] = new.get(str(s), lam[i, i])
        J = self.rotor_inertia
        if any(str(s) in new for s in J_syms):
            if J is None and not all(str(s) in new for s in J_syms):
                raise InputError(
                    f"The rotor inertias of {self.name} are unspecified: give all of {[str(s) for s in J_syms]}."
                )
            J = np.array([new.get(str(s), J[i] if J is not None else 0.0) for i, s in enumerate(J_syms)])
        return dataclasses.replace(self, inertia=lam, rotor_inertia=J)

    def lagrangian_system(self) -> Any:
        """This body as a Lagrangian system on :math:`SO(3)\\times T^N`, in the one description of every
        mechanical system (:class:`~geomech.systems.HolonomicSystem`): the Lagrangian :math:`L_f` above in the body
        angular velocity and the rotor rates, shape the rotor angles :math:`\\gamma_i`, with this body's named
        parameters (:meth:`symbols`) or its numbers. Its body momentum :math:`\\partial l/\\partial\\omega` is
        :math:`m` and :math:`\\partial l/\\partial\\dot\\gamma_i = \\Gamma_i`; its reduction is the mechanical
        connection of the rotors and its Euler-Lagrange equations are eqs. (26, 38) with :math:`u` as shape
        forces (tested against them)."""
        from .holonomic import HolonomicSystem

        J = self.require_rotor_inertia("The Lagrangian system")
        lam_syms, J_syms = self.symbols()
        n = self.n_rotors
        w = sp.Matrix(sp.symbols("omega_1 omega_2 omega_3", real=True))
        gammas = sp.symbols(f"gamma1:{n + 1}", real=True)
        Lam = sp.diag(*lam_syms) if lam_syms is not None else sp.Matrix(self.inertia.tolist())
        Js = list(J_syms) if lam_syms is not None else [sp.Float(v) for v in J]
        axes = np.rint(self.axes).astype(int) if self.is_principal else self.axes
        lagrangian = (w.T * Lam * w)[0, 0] / 2
        for k in range(n):
            rate = sp.Symbol(f"{gammas[k]}_dot", real=True)
            lagrangian += Js[k] * (sum(sp.sympify(a) * x for a, x in zip(axes[k].tolist(), w)) + rate) ** 2 / 2
        return HolonomicSystem.from_reduced(
            lagrangian,
            "SO3",
            list(w),
            gammas,
            parameters=self.parameters if lam_syms is not None else None,
            shape_angles=tuple(range(n)),
            name=self.name,
        )

    def parameter_values(self) -> dict[str, float]:
        """Values of the symbols of :meth:`symbols` by name (the rotors' only when they are known)."""
        return dict(self._parameter_values)

    @functools.cached_property
    def _parameter_values(self) -> dict[str, float]:
        # made once (the body is immutable, its arrays read-only): every run's Solution carries them
        lam_syms, J_syms = self.symbols()
        out: dict[str, float] = {}
        if lam_syms is not None:
            out.update({s.name: float(v) for s, v in zip(lam_syms, np.diag(self.inertia))})
        if self.rotor_inertia is not None:
            out.update({s.name: float(v) for s, v in zip(J_syms, self.rotor_inertia)})
        return out

    # -- open-loop equations (eqs. 26, 38) -----------------------------------------------------------
    def vector_field(
        self, R: np.ndarray, m: np.ndarray, Gamma: np.ndarray, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:math:`(\\dot R, \\dot m, \\dot\\gamma, \\dot\\Gamma)` of eqs. (26), (38) for one state and torque ``u``."""
        w = self.angular_velocity(m, Gamma)
        return R @ hat(w, check=False), np.cross(m, w), self.rotor_rates(m, Gamma), np.asarray(u, dtype=float)

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": "RotorBody",
            "name": self.name,
            "inertia_without_rotor_axial_moments": self.inertia.tolist(),
            "axes": self.axes.tolist(),
            "rotor_inertia": None if self.rotor_inertia is None else self.rotor_inertia.tolist(),
        }

    def __repr__(self) -> str:
        J = None if self.rotor_inertia is None else self.rotor_inertia.tolist()
        return f"RotorBody(inertia={self.inertia.tolist()}, axes={self.axes.tolist()}, rotor_inertia={J})"


def torque_function(torque: Any, n: int) -> Callable[..., np.ndarray]:
    """The rotor torques ``u(t, R, m, gamma, Gamma)`` from ``tau``: None (a free body), open-loop torques in time
    (a :class:`~geomech.systems.Gait` with one component per rotor: its values are the torques), a callable of
    those arguments, or a feedback law with ``feedback(m, Gamma)`` (a :class:`StructurePreservingControl`)."""
    from .gait import Gait

    if torque is None:
        zero = np.zeros(n)
        return lambda t, R, m, gam, Gam: zero
    if isinstance(torque, Gait):
        if torque.dim != n:
            raise InputError(
                f"Expected the torque gait `tau` to have {n} component(s), one per rotor, got {torque.dim}."
            )
        return lambda t, R, m, gam, Gam: np.asarray(torque.r(t), dtype=float).reshape(n)
    if hasattr(torque, "feedback"):
        return lambda t, R, m, gam, Gam: np.asarray(torque.feedback(m, Gam), dtype=float).reshape(n)
    if callable(torque):

        def u(t, R, m, gam, Gam):
            val = np.asarray(torque(t, R, m, gam, Gam), dtype=float)
            if val.size != n:
                raise InputError(f"Expected `tau` to return {n} torque(s), one per rotor, got shape {val.shape}.")
            return val.reshape(n)

        return u
    raise InputError(
        "Expected `tau`, the rotor torques, to be None, a Gait in t, a callable u(t, R, m, gamma, Gamma) or a "
        f"feedback law with .feedback(m, Gamma), got {type(torque).__name__}."
    )
