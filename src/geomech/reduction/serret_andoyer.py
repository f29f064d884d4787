"""The generalized Serret-Andoyer transformation (section 5 of the Serret-Andoyer paper).

For any left-invariant Hamiltonian :math:`H(m)` on :math:`T^*SO(3)` and conserved spatial momentum
:math:`p` with :math:`|p| = G`, the reduced phase space is the momentum sphere :math:`|m| = G`, and the
Serret-Andoyer variables :math:`(l, L)` chart it canonically (Proposition 3, eq. 20):

.. math::

    m = U_p(l, L) = \\bigl(\\sqrt{G^2 - L^2}\\sin l,\\ \\sqrt{G^2 - L^2}\\cos l,\\ L\\bigr),

with the reduced Hamiltonian :math:`h_p = H \\circ U_p` (Theorem 3, eq. 21) and canonical equations
:math:`\\dot l = \\partial h_p/\\partial L`, :math:`\\dot L = -\\partial h_p/\\partial l`.
The chart is singular at :math:`L = \\pm G` (body axis 3 along :math:`p`), and trajectories do cross it,
so geomech keeps an atlas of three such charts, one about each body axis (the body axes permuted
cyclically, which is a rotation and keeps the chart canonical), and
``geomech.solve(system, SerretAndoyerAtlas(), m0=..., R0=...)`` switches between them as it integrates.

Reconstruction (Theorem 3): relative to a spatial frame :math:`S` whose third axis is along :math:`p`,

.. math::

    R = S\\, R_z(\\varphi) R_x(\\theta) R_z(l)\\, C^T, \\qquad \\cos\\theta = L/G,\\qquad
    \\dot\\varphi = \\frac{\\partial H}{\\partial \\Phi}\\Big|_{M_p}
        = \\frac{G\\,(\\omega'_1 \\sin l + \\omega'_2 \\cos l)}{\\sqrt{G^2 - L^2}},

where :math:`C` is the chart's permutation of the body axes and :math:`\\omega' = C^T \\nabla H(m)`.
The formula for :math:`\\dot\\varphi` is the first two components of the body angular velocity of a
3-1-3 rotation (eq. 2) solved for :math:`\\dot\\varphi`; for the free body it gives the classical
:math:`\\dot\\varphi = G(\\sin^2 l/I_1 + \\cos^2 l/I_2)`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, SingularityError
from ..lie import euler as _euler
from ..lie import so3 as _so3
from ..symbolic.compile import M_SYMBOLS
from ..symbolic.simplify import simplify_expr
from ..systems.canonical import CanonicalSystem
from ..systems.left_invariant import LeftInvariantSystem, as_left_invariant

__all__ = ["SerretAndoyerChart", "GeneralizedSerretAndoyer", "reduced_formulas", "spatial_frame"]

#: The chart about body axis k uses m' = C_k^T m with C_k e3 = e_k; C_k permutes the axes cyclically
#: (a rotation), so the Lie-Poisson structure, hence canonicity of (l, L), is unchanged.
_PERMUTATIONS = {
    0: np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),  # columns e2, e3, e1
    1: np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),  # columns e3, e1, e2
    2: np.eye(3),
}

L_SYM, l_SYM = sp.symbols("L l", real=True)
G_SYM = sp.Symbol("G", positive=True)


def _axis(axis: Any) -> int:
    if axis in (0, 1, 2) and not isinstance(axis, bool):
        return int(axis)
    raise InputError(f"Expected `axis` to be a body axis index 0, 1 or 2, got {axis!r}.")


@dataclass(frozen=True)
class SerretAndoyerChart:
    """The Serret-Andoyer chart :math:`U_p` (eq. 20) about body axis ``axis`` (0-based; 2 is the paper's).

    ``forward`` maps body momenta on the sphere :math:`|m| = G` to :math:`(l, L)`, ``inverse`` maps back.
    The chart covers the sphere minus the two poles :math:`m = \\pm G e_{axis}`.
    """

    axis: int = 2

    def __post_init__(self) -> None:
        _axis(self.axis)

    @property
    def permutation(self) -> np.ndarray:
        """The rotation :math:`C` with :math:`m = C\\,U(l, L)`, :math:`C e_3 = e_{axis}`."""
        return _PERMUTATIONS[self.axis]

    def forward(self, m: Any, *, pole_tol: float = 1e-12) -> np.ndarray:
        """:math:`(l, L)` of body momenta ``m`` (shape ``(..., 3)``) -> shape ``(..., 2)``.

        Raises :class:`~geomech.errors.SingularityError` at a pole, where ``l`` is undefined.
        """
        m = V.trailing_shape(m, "m", (3,))
        mp = m @ self.permutation  # C^T m for row vectors
        s = np.hypot(mp[..., 0], mp[..., 1])
        g = np.linalg.norm(m, axis=-1)
        if np.any(g == 0):
            raise InputError("Expected `m` to be nonzero: the Serret-Andoyer chart needs G = |m| > 0.")
        bad = s <= pole_tol * g
        if np.any(bad):
            raise SingularityError(
                f"The Serret-Andoyer chart about body axis {self.axis + 1} is singular at its poles "
                f"L = +-G (m along that axis), and {int(bad.sum())} of the momenta are there; use the chart "
                "about another axis (GeneralizedSerretAndoyer picks one automatically)."
            )
        return np.stack([np.arctan2(mp[..., 0], mp[..., 1]), mp[..., 2]], -1)

    def inverse(self, lL: Any, G: Any) -> np.ndarray:
        """:math:`m = C\\,U_p(l, L)` for ``lL`` of shape ``(..., 2)`` and momentum magnitude ``G``."""
        lL = V.trailing_shape(lL, "lL", (2,))
        G = V.positive(G, "G")
        l, L = lL[..., 0], lL[..., 1]
        s = np.sqrt(np.clip(G**2 - L**2, 0.0, None))
        if np.any(np.abs(L) > G * (1 + 1e-12)):
            raise InputError(
                f"Expected |L| <= G in the Serret-Andoyer chart, got max |L|/G = {np.max(np.abs(L) / G):.6g}."
            )
        mp = np.stack(np.broadcast_arrays(s * np.sin(l), s * np.cos(l), L), -1)
        return mp @ self.permutation.T

    def tangents(self, lL: Any, G: float) -> tuple[np.ndarray, np.ndarray]:
        """:math:`\\partial m/\\partial l` and :math:`\\partial m/\\partial L`, each ``(..., 3)``."""
        lL = V.trailing_shape(lL, "lL", (2,))
        l, L = lL[..., 0], lL[..., 1]
        s = np.sqrt(G**2 - L**2)
        if np.any(s <= 0):
            raise SingularityError(f"dm/dL is unbounded at the poles L = +-G of the chart about axis {self.axis + 1}.")
        dl = np.stack([s * np.cos(l), -s * np.sin(l), np.zeros_like(l)], -1)
        dL = np.stack([-L / s * np.sin(l), -L / s * np.cos(l), np.ones_like(l)], -1)
        C = self.permutation
        return dl @ C.T, dL @ C.T

    @property
    def U_p(self) -> sp.Matrix:
        """The chart map :math:`m = C\\,U_p(l, L)` (Theorem 3) as a sympy column in the symbols ``l, L, G``;
        :meth:`inverse` evaluates it."""
        s = sp.sqrt(G_SYM**2 - L_SYM**2)
        return sp.Matrix(self.permutation.astype(int).tolist()) * sp.Matrix(
            [s * sp.sin(l_SYM), s * sp.cos(l_SYM), L_SYM]
        )


def reduced_formulas(
    hamiltonian: sp.Expr, values: Mapping[str, float] | None = None, axis: int = 2
) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """:math:`h_p = H\\circ U_p` (eq. 21) in the chart about ``axis`` and its canonical equations
    :math:`\\dot l = \\partial h_p/\\partial L`, :math:`\\dot L = -\\partial h_p/\\partial l`, as sympy expressions
    in ``l, L, G`` with ``values`` (by parameter name) substituted, the names without a value left as symbols,
    each simplified by :func:`~geomech.symbolic.simplify.simplify_expr`.
    """
    names = {s.name: s for s in hamiltonian.free_symbols}
    U = {names[m.name]: u for m, u in zip(M_SYMBOLS, SerretAndoyerChart(_axis(axis)).U_p) if m.name in names}
    subs = {names[k]: sp.Float(v) for k, v in (values or {}).items() if k in names}
    h = simplify_expr(hamiltonian.xreplace(U).xreplace(subs))
    return h, simplify_expr(sp.diff(h, L_SYM)), simplify_expr(-sp.diff(h, l_SYM))


def spatial_frame(p: Any) -> np.ndarray:
    """A rotation :math:`S` with :math:`S e_3 = p/|p|`: the smallest rotation taking :math:`e_3` to
    :math:`\\hat p` (a half turn about :math:`e_1` when :math:`\\hat p = -e_3`)."""
    p = V.exact_shape(p, "p", (3,))
    G = np.linalg.norm(p)
    if G == 0:
        raise InputError("Expected the spatial momentum `p` to be nonzero.")
    u = p / G
    axis = np.cross([0.0, 0.0, 1.0], u)
    sin_a = np.linalg.norm(axis)
    if sin_a < 1e-300:
        return np.eye(3) if u[2] > 0 else _so3.exp(np.array([np.pi, 0.0, 0.0]))
    angle = np.arctan2(sin_a, u[2])
    return _so3.exp(axis / sin_a * angle)


class GeneralizedSerretAndoyer:
    """Symplectic reduction of a left-invariant system by the generalized Serret-Andoyer variables.

    Parameters
    ----------
    system : LeftInvariantSystem (or a RigidBody, or anything :func:`as_left_invariant` accepts)
        The left-invariant Hamiltonian :math:`H(m)`. Hyperregularity is *not* needed: reduction,
        the reduced flow and the reconstruction of the attitude use only :math:`\\nabla H`.
    switch_at : float
        The chart in use is left when :math:`|L|/G` reaches this value (default 0.9); the new chart is
        the one about the body axis with the smallest :math:`|m_k|`, where :math:`|L|/G \\le 1/\\sqrt 3`.
    """

    def __init__(self, system: Any, *, switch_at: float = 0.9):
        self.system: LeftInvariantSystem = as_left_invariant(system)
        switch_at = float(switch_at)
        if not (0.6 < switch_at < 1.0):
            raise InputError(f"Expected `switch_at` in (0.6, 1), got {switch_at}; 0.9 is a good value.")
        self.switch_at = switch_at
        self.charts = tuple(SerretAndoyerChart(k) for k in range(3))

    # -- the reduced Hamiltonian --------------------------------------------------------------------
    def reduced_hamiltonian(self, lL: Any, G: Any, axis: int = 2) -> np.ndarray:
        """:math:`h_p(l, L) = H(U_p(l, L))` (eq. 21) in the chart about ``axis``."""
        return self.system.hamiltonian(self.charts[_axis(axis)].inverse(lL, G))

    def reduced_vector_field(self, lL: Any, G: float, axis: int = 2) -> np.ndarray:
        """:math:`(\\dot l, \\dot L) = (\\partial h_p/\\partial L, -\\partial h_p/\\partial l)`, exact, by the
        chain rule through :math:`\\nabla H` (so it works for callables too)."""
        chart = self.charts[_axis(axis)]
        m = chart.inverse(lL, G)
        grad = self.system.gradient(m)
        dl, dL = chart.tangents(lL, G)
        return np.stack([np.einsum("...i,...i->...", grad, dL), -np.einsum("...i,...i->...", grad, dl)], -1)

    def phi_rate(self, lL: Any, G: float, axis: int = 2) -> np.ndarray:
        """:math:`\\dot\\varphi = \\partial H/\\partial\\Phi|_{M_p}` (Theorem 3), singular at the poles."""
        chart = self.charts[_axis(axis)]
        lL = V.trailing_shape(lL, "lL", (2,))
        m = chart.inverse(lL, G)
        w = self.system.gradient(m) @ chart.permutation  # omega' = C^T omega
        l, L = lL[..., 0], lL[..., 1]
        s = np.sqrt(G**2 - L**2)
        if np.any(s <= 0):
            raise SingularityError(f"phi' is unbounded at the poles L = +-G of the chart about axis {axis + 1}.")
        return G * (w[..., 0] * np.sin(l) + w[..., 1] * np.cos(l)) / s

    def h_p(self, axis: int = 2, *, simplify: bool = True) -> sp.Expr:
        """:math:`h_p(l, L)` as a sympy expression in ``l, L, G`` (needs a formula for H).

        Simplified by :func:`reduced_formulas`; ``simplify=False`` skips the simplification (numerical use needs
        no simplified form).
        """
        if simplify:
            return reduced_formulas(self._h_p_with_parameters(axis), self.system.parameters, axis)[0]
        return self._h_p_with_parameters(axis).subs(self._parameter_subs())

    def _parameter_subs(self) -> dict[sp.Symbol, float]:
        return {sp.Symbol(k, real=True): v for k, v in self.system.parameters.items()}

    def _h_p_with_parameters(self, axis: int) -> sp.Expr:
        expr = self.system.require_expression("The symbolic reduced Hamiltonian")
        return expr.xreplace(dict(zip(M_SYMBOLS, self.charts[_axis(axis)].U_p)))

    def reduced_system(self, G: float, axis: int = 2) -> CanonicalSystem:
        """The reduced system as a 1-degree-of-freedom :class:`CanonicalSystem` ``y = (l, L)``.

        From the formula when H has one (exact derivatives), from the chain rule otherwise.
        """
        G = V.positive_scalar(G, "G")
        axis = _axis(axis)
        if self.system.expression is not None:
            return CanonicalSystem.from_expression(
                self._h_p_with_parameters(axis),
                (l_SYM,),
                (L_SYM,),
                name=f"h_p (axis {axis + 1})",
                angle_coordinates=(0,),
                substitutions={G_SYM: G, **self._parameter_subs()},
                chart=((1, -G, G),),
            )

        def ham(y: np.ndarray) -> np.ndarray:
            return self.reduced_hamiltonian(y, G, axis)

        def grad(y: np.ndarray) -> np.ndarray:
            f = self.reduced_vector_field(y, G, axis)
            return np.stack([-f[..., 1], f[..., 0]], -1)

        return CanonicalSystem(
            n=1,
            name=f"h_p (axis {axis + 1})",
            _hamiltonian=ham,
            _gradient=grad,
            angle_coordinates=(0,),
            chart=((1, -G, G),),
        )

    # -- reconstruction ------------------------------------------------------------------------------
    @staticmethod
    def attitude(S: np.ndarray, phi: Any, L: Any, l: Any, G: float, axis: Any) -> np.ndarray:
        """:math:`R = S R_z(\\varphi) R_x(\\theta) R_z(l) C^T`, :math:`\\cos\\theta = L/G`, shape ``(..., 3, 3)``."""
        phi, L, l = np.broadcast_arrays(np.asarray(phi, float), np.asarray(L, float), np.asarray(l, float))
        theta = np.arccos(np.clip(L / G, -1.0, 1.0))
        E = _euler.as_matrix(np.stack([phi, theta, l], -1), seq="ZXZ")
        C = np.stack([_PERMUTATIONS[int(a)] for a in np.ravel(np.broadcast_to(axis, phi.shape))]).reshape(
            phi.shape + (3, 3)
        )
        return S @ E @ np.swapaxes(C, -1, -2)

    def reconstruct(
        self,
        t: Any,
        lL: Any,
        G: float,
        *,
        axis: int = 2,
        R0: Any | None = None,
        p: Any | None = None,
    ) -> np.ndarray:
        """Attitudes :math:`R(t)` from a reduced solution :math:`(l(t), L(t))` in one chart (Theorem 3).

        :math:`\\theta = \\arccos(L/G)` pointwise, and :math:`\\varphi = \\int \\partial H/\\partial\\Phi|_{M_p} dt`
        by quadrature of :meth:`phi_rate` along the samples (the integral of a cubic spline through them:
        fourth order in the sampling step). Use it for reduced solutions computed elsewhere, e.g. by a
        symplectic integrator of :meth:`reduced_system`.

        Parameters
        ----------
        t : (n,) increasing sample times.
        lL : (n, 2) the reduced solution at those times, in the chart about ``axis``.
        R0 : (3, 3) the attitude at ``t[0]``; it fixes the spatial momentum ``p = R0 m(t0)`` and the initial
            angle phi. Without it, ``p`` (default ``G e3``) fixes the spatial frame and phi starts at 0.

        Returns
        -------
        (n, 3, 3) attitudes, body to space.
        """
        from scipy.interpolate import CubicSpline

        axis = _axis(axis)
        t = V.finite(t, "t")
        lL = V.trailing_shape(lL, "lL", (2,))
        if t.ndim != 1 or lL.shape != (t.size, 2) or t.size < 4 or np.any(np.diff(t) <= 0):
            raise InputError(
                f"Expected `t` strictly increasing with at least 4 samples and `lL` of shape (len(t), 2), "
                f"got {t.shape} and {lL.shape}."
            )
        G = V.positive_scalar(G, "G")
        m0 = self.charts[axis].inverse(lL[0], G)
        if R0 is not None:
            R0 = V.rotation_matrix(R0, "R0")
            S = spatial_frame(R0 @ m0)
            phi0 = self.chart_coordinates(S, R0, m0, G, axis)[2]
        else:
            S = spatial_frame(np.array([0.0, 0.0, G]) if p is None else V.exact_shape(p, "p", (3,)))
            phi0 = 0.0
        rate = self.phi_rate(lL, G, axis)
        phi = phi0 + CubicSpline(t, rate).antiderivative()(t)
        return self.attitude(S, phi, lL[:, 1], lL[:, 0], G, axis)

    def chart_coordinates(self, S: np.ndarray, R: np.ndarray, m: np.ndarray, G: float, axis: int) -> np.ndarray:
        """:math:`(l, L, \\varphi)` of the state :math:`(m, R)` in the chart about ``axis``, with the spatial frame
        ``S`` of its momentum (:func:`spatial_frame`): the inverse of :meth:`attitude` and the chart's inverse."""
        lL = self.charts[axis].forward(m)
        E = S.T @ R @ self.charts[axis].permutation
        angles = _euler.from_matrix(E, seq="ZXZ")
        return np.array([lL[0], lL[1], angles[0]])

    def first_chart(self, m0: np.ndarray, axis: int | None = None) -> int:
        """The chart to start in: ``axis`` if given and regular at ``m0``, else axis 3 (the seed's) unless
        :math:`|m_3|` is near G, else the axis with the smallest :math:`|m_k|`."""
        G = float(np.linalg.norm(m0))
        if axis is None:
            axis = 2 if abs(m0[2]) < self.switch_at * G else int(np.argmin(np.abs(m0)))
        axis = _axis(axis)
        if abs((m0 @ self.charts[axis].permutation)[2]) >= self.switch_at * G:
            axis = int(np.argmin(np.abs(m0)))
        return axis
