"""Exact propagation of one-degree-of-freedom Hamiltonian systems by quadrature.

A canonical system :math:`H(q, p)` with one degree of freedom is integrable by quadrature: its orbits are
the level curves :math:`H = E`, and the time of flight along a curve is

.. math::

    t = \\int \\frac{dq}{\\dot q} = \\int \\frac{dq}{\\partial H/\\partial p}
      = -\\int \\frac{dp}{\\partial H/\\partial q}.

For the reduced Serret-Andoyer system :math:`h_p(l, L)` (eq. 21 of the Serret-Andoyer paper) this is
eq. (11) there; :class:`QuadraturePropagator` does it for any :class:`~geomech.systems.CanonicalSystem`
with ``n = 1``, and :class:`~geomech.integrators.serret_andoyer_propagator.SerretAndoyerPropagator` adds the
reconstruction of the attitude (Theorem 3).

Method
------
1. The level curve through ``y0`` is traced by predictor-corrector continuation (tangent predictor, Newton
   corrector along :math:`\\nabla H`, steps limited by the turn of the tangent and the change of
   :math:`|\\nabla H|`) until it closes (a libration, or a rotation once round the angle), reaches a saddle at
   the level :math:`E` (a separatrix) or leaves the domain.
2. The curve is cut into arcs that are graphs :math:`p = P(q)` where :math:`|\\partial H/\\partial p|`
   dominates and :math:`q = Q(p)` where :math:`|\\partial H/\\partial q|` does. On each arc :math:`dt/du` is
   smooth and bounded: the turning points (:math:`\\partial H/\\partial p = 0`) lie inside arcs over ``p``
   and leave no singularity. Graph points come from Newton's method on :math:`H = E` at fixed ``u``; the
   graph and :math:`dt/du` are adaptive piecewise Chebyshev interpolants, whose antiderivative
   (Clenshaw-Curtis) gives the time of flight and the period, the last coefficients the error estimate.
3. The time of flight is inverted at Chebyshev nodes in ``t`` and the state over one period is stored as a
   piecewise Chebyshev interpolant in ``t``: :meth:`QuadraturePropagator.state` reduces ``t`` modulo the
   period and evaluates it, at a cost independent of ``t`` and with no evaluation of ``H``.
4. Any function along the orbit is integrated in time the same way (:meth:`QuadraturePropagator.integral`):
   an increment per period plus a periodic part; the reconstruction angle :math:`\\varphi` is one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.polynomial import chebyshev as _cheb

from .. import _validate as V
from ..errors import ConvergenceError, InputError, NumericalError, SingularityError, SymbolicError
from ..systems.canonical import CanonicalSystem
from ._chebyshev import _chebeval, _Piecewise
from ._one_dof import CriticalPoint, OrbitIntegral, one_dof_arguments

__all__ = ["QuadraturePropagator"]

_EPS = float(np.finfo(float).eps)
_AUTO: Any = object()
#: Predictor-corrector acceptance: the tangent may turn by at most this angle (rad) per step and
#: |grad H| may change by at most this factor; both keep the chords within a few percent of the curve.
_MAX_TURN = 0.15
_MAX_RATIO = 1.0 / 0.7
_MAX_STEPS = 20_000


def _norm(g: np.ndarray) -> np.ndarray:
    return np.hypot(g[..., 0], g[..., 1])


# -- the propagator -----------------------------------------------------------------------------------
class QuadraturePropagator:
    """Exact motion of a one-degree-of-freedom Hamiltonian system by quadrature along its level curve.

    .. math::

        T = \\oint \\frac{dq}{\\partial H/\\partial p}, \\qquad
        t(y) = \\int_{y_0}^{y} \\frac{dq}{\\partial H/\\partial p}, \\qquad y(t + T) = y(t) + (w P, 0),

    eq. (11) of the Serret-Andoyer paper for any :math:`H(q, p)`; ``w`` is the winding in the angle
    ``q`` (0 for a libration, +-1 for a rotation) and ``P`` its period.

    Parameters
    ----------
    system : CanonicalSystem with ``n = 1``, ``y = (q, p)``; e.g. the reduced Serret-Andoyer system
        ``GeneralizedSerretAndoyer(H).reduced_system(G)`` with ``(q, p) = (l, L)``.
    y0 : (2,) the initial state; its energy :math:`E = H(y_0)` fixes the orbit.
    L_bounds : (p_min, p_max), optional, the open interval of ``p`` where ``H`` is defined (``(-G, G)`` for a
        Serret-Andoyer chart). A level curve that reaches it raises :class:`SingularityError`.
    angle_period : float or None; the period of ``q``. Default ``2 pi`` if ``q`` is one of
        ``system.angle_coordinates``, else ``None`` (``q`` not periodic: no rotations).
    tol : relative accuracy of the period and of the state (default 1e-12); the Chebyshev interpolants are
        resolved to ``tol / 100`` (at least ``16 eps``) of their size.
    scale : (s_q, s_p), optional, the size of the orbit in each coordinate, used to measure distances
        and steps. Default: ``angle_period / (2 pi)`` (1 rad) and half the width of ``L_bounds``, else 1.
    energy_tol : float, optional. Two energies closer than this are equal: a saddle on the level curve
        makes it a separatrix, and ``y0`` is an equilibrium when a critical point is closer than the
        energy can resolve. Default ``16 eps`` times the energy scale (``|E|``, ``|grad H|``, ``|D^2 H|``
        at ``y0``, in the scaled coordinates).

    Attributes
    ----------
    kind : ``"libration"``, ``"rotation"``, ``"separatrix"`` or ``"equilibrium"``.
    energy, period (``inf`` for a separatrix or an equilibrium), period_error (an estimate),
    frequency (``2 pi / period``), winding, turning_points ``(k, 2)`` where ``dH/dp = 0`` (the extremes of
    ``q``) with their times turning_times in ``[0, T)``, L_range (min and max of ``p`` on the orbit),
    saddles (for a separatrix: the critical points it leaves and reaches, :class:`CriticalPoint`),
    equilibrium (for an equilibrium: the :class:`CriticalPoint`), nfev (points at which ``H`` or its
    gradient were evaluated while building; evaluation at any ``t`` adds none).

    Notes
    -----
    On a separatrix the motion takes infinite time and :meth:`state` raises
    :class:`~geomech.errors.SingularityError`; use an integrator there. H in double precision fixes the level
    curve only to about :math:`\\epsilon |E| / |\\nabla H|`, which is coarse near a centre or a saddle:
    when that limits the period to worse than ``100 tol``, a :class:`~geomech.errors.ConvergenceError` says
    how far (pass a larger ``tol`` to accept it). The state at time ``t`` inherits the period's relative
    error times ``t``: a last-bit error of ``T`` moves the state by about ``eps t |y'|``.
    """

    def __init__(
        self,
        system: CanonicalSystem,
        y0: Any,
        *,
        L_bounds: Any = None,
        angle_period: Any = _AUTO,
        tol: float = 1e-12,
        scale: Any = None,
        energy_tol: float | None = None,
    ):
        self.system, self.y0, tol = one_dof_arguments(system, y0, tol, (1e-15, 1e-3), "quadrature")
        y0 = self.y0
        self.tol = tol
        self._ctol = max(tol / 100, 16 * _EPS)
        if angle_period is _AUTO:
            angle_period = 2 * np.pi if 0 in system.angle_coordinates else None
        if angle_period is not None:
            angle_period = V.positive_scalar(angle_period, "angle_period")
        self.angle_period = angle_period
        bounds = np.array([-np.inf, np.inf]) if L_bounds is None else V.as_float_array(L_bounds, "L_bounds")
        if bounds.shape != (2,) or not bounds[0] < bounds[1]:
            raise InputError(f"Expected `L_bounds` to be an increasing pair (p_min, p_max), got {L_bounds!r}.")
        lo, hi = bounds
        if not lo < y0[1] < hi:
            raise InputError(f"Expected the initial p = y0[1] = {y0[1]:.17g} inside `L_bounds` ({lo:g}, {hi:g}).")
        if scale is None:
            scale = (angle_period / (2 * np.pi) if angle_period else 1.0, (hi - lo) / 2 if hi - lo < np.inf else 1.0)
        self._s = V.positive(scale, "scale")
        if self._s.shape != (2,):
            raise InputError(f"Expected `scale` to be a pair (s_q, s_p), got {scale!r}.")
        self._lo, self._hi = lo / self._s[1], hi / self._s[1]
        self._P: float | None = float(angle_period / self._s[0]) if angle_period else None
        self.nfev = 0
        z0 = y0 / self._s
        E = self._H(z0[None])[0]
        g0 = self._grad(z0[None])[0]
        if not (np.isfinite(E) and np.all(np.isfinite(g0))):
            raise InputError(f"Expected H and its gradient to be finite at `y0` = {y0.tolist()}, got H = {E}.")
        self.energy = E = float(E)
        hess0 = self._hess(z0)
        self._hnorm = float(np.linalg.norm(hess0, 2))
        self._escale = max(abs(E), float(np.linalg.norm(g0)), self._hnorm, 1e-300)
        self.energy_tol = 16 * _EPS * self._escale
        if energy_tol is not None:
            self.energy_tol = V.positive_scalar(energy_tol, "energy_tol")
        self._z0 = z0
        self._hmax = 0.25 * max(1.0, float(np.max(np.abs(z0))))
        self.winding = 0
        self.saddles: tuple[CriticalPoint, ...] = ()
        self.equilibrium: CriticalPoint | None = None
        self.period = self.period_error = math.inf
        self.turning_points, self.turning_times = np.empty((0, 2)), np.empty(0)
        self.L_range = (float(y0[1]), float(y0[1]))
        if self._is_equilibrium(z0, g0, hess0):
            self.kind = "equilibrium"
            return
        pts, status, info = self._trace(z0, +1)
        if status == "saddle":
            back, status_b, info_b = self._trace(z0, -1)
            self.kind, self.saddles = "separatrix", (info_b, info) if status_b == "saddle" else (info,)
            both = np.concatenate([back[::-1], pts[1:]]) * self._s
            self.L_range = (float(both[:, 1].min()), float(both[:, 1].max()))
            return
        self.winding = int(info)
        self.kind = "rotation" if self.winding else "libration"
        self._build(np.asarray(pts))

    # -- evaluation of H in scaled coordinates z = y / s -------------------------------------------------
    def _H(self, z: np.ndarray) -> np.ndarray:
        self.nfev += len(z)
        with np.errstate(all="ignore"):
            return np.asarray(self.system.hamiltonian(z * self._s), dtype=float)

    def _grad(self, z: np.ndarray) -> np.ndarray:
        self.nfev += len(z)
        with np.errstate(all="ignore"):
            return np.asarray(self.system.gradient(z * self._s), dtype=float) * self._s

    def _hess(self, z: np.ndarray) -> np.ndarray:
        try:
            with np.errstate(all="ignore"):
                return np.asarray(self.system.hessian(z * self._s), dtype=float) * np.outer(self._s, self._s)
        except SymbolicError:  # no Hessian (a callable system): central differences of the exact gradient
            h = np.cbrt(_EPS) * max(1.0, float(np.max(np.abs(z))))
            cols = [(self._grad((z + h * e)[None])[0] - self._grad((z - h * e)[None])[0]) / (2 * h) for e in np.eye(2)]
            hs = np.stack(cols, -1)
            return 0.5 * (hs + hs.T)

    def _inside(self, z: np.ndarray) -> bool:
        return bool(self._lo < z[1] < self._hi)

    # -- critical points ----------------------------------------------------------------------------------
    def _critical_point(self, z: np.ndarray) -> CriticalPoint | None:
        """Newton's method on grad H = 0 from ``z``; None when it does not converge nearby."""
        z = z.copy()
        for _ in range(40):
            hs = self._hess(z)
            try:
                dz = np.linalg.solve(hs, self._grad(z[None])[0])
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(dz)) or np.linalg.norm(dz) > 1.0:
                return None
            z -= dz
            if not self._inside(z):
                return None
            if np.linalg.norm(dz) <= 1e-14 * (1 + np.linalg.norm(z)):
                break
        else:
            return None
        hs = self._hess(z)
        det = float(np.linalg.det(hs))
        tiny = 1e-12 * float(np.linalg.norm(hs, 2)) ** 2
        kind = "saddle" if det < -tiny else "center" if det > tiny else "degenerate"
        rate = math.sqrt(abs(det)) / (self._s[0] * self._s[1])
        return CriticalPoint(z * self._s, float(self._H(z[None])[0]), kind, rate)

    def _is_equilibrium(self, z0: np.ndarray, g0: np.ndarray, hess0: np.ndarray) -> bool:
        norm_h = float(np.linalg.norm(hess0, 2))
        if np.linalg.norm(g0) > 1e-3 * norm_h and np.any(g0 != 0):
            return False
        cp = self._critical_point(z0)
        if cp is None:
            if np.any(g0 != 0):
                return False
            cp = CriticalPoint(self.y0.copy(), self.energy, "degenerate", 0.0)
        # y0 is at the critical point to working precision when no direction separates their energies
        r = np.linalg.norm(cp.y / self._s - z0)
        if np.any(g0 != 0) and 0.5 * norm_h * r**2 > self.energy_tol:
            return False
        self.equilibrium = cp
        return True

    # -- tracing the level curve ----------------------------------------------------------------------
    def _correct(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Newton's method on H = E along the gradient (the nearest point of the curve)."""
        for _ in range(16):
            if not self._inside(z):
                return None
            f = self._H(z[None])[0] - self.energy
            g = self._grad(z[None])[0]
            gg = g @ g
            if not (np.isfinite(f) and np.isfinite(gg)) or gg == 0:
                return None
            dz = f * g / gg
            z = z - dz
            if np.linalg.norm(dz) <= 1e-14 * (1 + np.linalg.norm(z)):
                break
        else:
            if np.linalg.norm(dz) > 1e-10:
                return None
        g = self._grad(z[None])[0]
        return (z, g) if self._inside(z) and np.all(np.isfinite(g)) else None

    def _trace(self, z0: np.ndarray, direction: int) -> tuple[list[np.ndarray], str, Any]:
        """Follow H = E from ``z0`` along (``+1``) or against (``-1``) the flow.

        Returns the vertices and ``("closed", winding)`` or ``("saddle", CriticalPoint)``.
        """
        z, g = z0, self._grad(z0[None])[0]
        tangent = direction * np.array([g[1], -g[0]]) / np.linalg.norm(g)
        t0 = tangent
        rho = np.linalg.norm(g) / max(np.linalg.norm(self._hess(z0), 2), 1e-300)
        h = min(self._hmax, 0.1 * rho)
        pts = [z0]
        last_try = math.inf
        shifts = [0.0] if self._P is None else [0.0, self._P, -self._P]
        out_of_domain = False
        for _ in range(_MAX_STEPS):
            pred = z + h * tangent
            res = self._correct(pred) if self._inside(pred) else None
            ok = res is not None
            if res is not None:
                zc, gc = res
                tn = direction * np.array([gc[1], -gc[0]]) / np.linalg.norm(gc)
                turn = math.acos(min(1.0, float(tangent @ tn)))
                ratio = np.linalg.norm(gc) / np.linalg.norm(g)
                disp = np.linalg.norm(zc - pred)
                ok = turn <= _MAX_TURN and 1 / _MAX_RATIO <= ratio <= _MAX_RATIO and disp <= 0.1 * h
            if not ok:
                out_of_domain = res is None
                h *= 0.5
                if h < 1e-13:
                    where = f"near y = {(z * self._s).tolist()}"
                    # a chart's pole is a boundary where H is not smooth (grad H ~ 1/sqrt(G^2 - L^2)): the
                    # steps shrink before any of them leaves the domain
                    if out_of_domain or min(z[1] - self._lo, self._hi - z[1]) < 1e-6:
                        raise SingularityError(
                            f"The level curve H = {self.energy:.17g} through y0 = {self.y0.tolist()} leaves the "
                            f"domain L_bounds {where} (for a Serret-Andoyer chart: the orbit passes through a "
                            "pole L = +-G; use the chart about another body axis)."
                        )
                    raise ConvergenceError(
                        f"The level curve H = {self.energy:.17g} could not be followed {where}: a degenerate "
                        "critical point of H?"
                    )
                continue
            chord = zc - z
            for w in shifts:
                if w == 0.0 and len(pts) < 2:
                    continue
                target = z0 + np.array([w, 0.0])
                d = target - z
                s = float(d @ chord) / float(chord @ chord)
                if -1e-12 <= s <= 1 + 1e-12 and np.linalg.norm(d - s * chord) <= 0.1 * h and tangent @ t0 > 0.5:
                    pts.append(target)
                    return pts, "closed", round(w / self._P) if w and self._P else 0
            pts.append(zc)
            z, g, tangent = zc, gc, tn
            rho = np.linalg.norm(g) / max(np.linalg.norm(self._hess(z), 2), 1e-300)
            if rho < 1e-2 and rho < 0.3 * last_try:
                last_try = rho
                cp = self._critical_point(z)
                if cp is not None and cp.kind == "saddle" and abs(cp.energy - self.energy) <= self.energy_tol:
                    pts.append(cp.y / self._s)
                    return pts, "saddle", cp
            elif rho > 0.05:
                last_try = math.inf
            if turn < _MAX_TURN / 3 and 0.85 < ratio < 1 / 0.85 and disp < 0.02 * h:
                h = min(self._hmax, 1.5 * h)
        raise ConvergenceError(
            f"The level curve H = {self.energy:.17g} through y0 = {self.y0.tolist()} did not close after "
            f"{_MAX_STEPS} steps: is the orbit unbounded (pass `angle_period` if q is an angle)?"
        )

    # -- arcs, time of flight, state table ------------------------------------------------------------
    def _solve_graph(self, kind: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Solve H = E for the coordinate ``v`` at fixed ``u`` (``kind`` 0: u = q; 1: u = p) by Newton."""
        other = 1 - kind
        rows = np.arange(u.size)
        for it in range(50):
            z = np.empty((u.size, 2))
            z[rows, kind], z[rows, other] = u, v
            f = self._H(z) - self.energy
            g = self._grad(z)
            dv = f / g[rows, other]
            if not np.all(np.isfinite(dv)):
                bad = int(np.argmax(~np.isfinite(dv)))
                raise NumericalError(f"H or its gradient is not finite near y = {(z[bad] * self._s).tolist()}.")
            v = v - dv
            # converged to round-off, or (after a few steps) to the rounding noise of H over |grad H|
            slack = 8 * _EPS * (1 + np.abs(v)) + (it > 5) * 2 * self._position_noise(g)
            if np.all(np.abs(dv) <= slack):
                break
        else:
            bad = int(np.argmax(np.abs(dv)))
            raise ConvergenceError(f"Newton's method on H = E did not converge near y = {(z[bad] * self._s).tolist()}.")
        z = np.empty((u.size, 2))
        z[rows, kind], z[rows, other] = u, v
        return z, self._grad(z)

    def _build(self, pts: np.ndarray) -> None:
        s01 = self._s[0] * self._s[1]
        gv = self._grad(pts)
        dominant = (np.abs(gv[:, 0]) > np.abs(gv[:, 1])).astype(int)  # 0: graph over q, 1: graph over p
        chords = np.diff(pts, axis=0)
        keep = np.any(chords != 0, axis=1)
        steeper = (np.abs(chords[:, 1]) > np.abs(chords[:, 0])).astype(int)
        kinds = np.where(dominant[:-1] == dominant[1:], dominant[:-1], steeper)
        runs: list[list[int]] = []  # [kind, first vertex, last vertex]
        for i in np.flatnonzero(keep):
            k = int(kinds[i])
            sign = np.sign(chords[i, k])
            if runs and runs[-1][0] == k and runs[-1][2] == i and np.sign(pts[i, k] - pts[runs[-1][1], k]) == sign:
                runs[-1][2] = i + 1
            else:
                runs.append([k, int(i), int(i + 1)])
        self._run_kind = np.array([r[0] for r in runs])
        self._run_u = np.array([[pts[r[1], r[0]], pts[r[2], r[0]]] for r in runs])
        guides = [(pts[r[1] : r[2] + 1, r[0]], pts[r[1] : r[2] + 1, 1 - r[0]]) for r in runs]

        def arcs(sig: np.ndarray, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            kind = self._run_kind[root]
            u0, u1 = self._run_u[root, 0], self._run_u[root, 1]
            u = u0 + (sig - root) * (u1 - u0)
            v = np.empty_like(u)
            for j in np.unique(root):
                U, W = guides[j]
                sel = root == j
                order = np.argsort(U)
                v[sel] = np.interp(u[sel], U[order], W[order])
            z, g = self._solve_graph(kind, u, v)
            rows = np.arange(u.size)
            zdot = np.stack([g[:, 1], -g[:, 0]], -1) / s01
            dtds = (u1 - u0) / zdot[rows, kind]
            if np.any(dtds <= 0):
                raise ConvergenceError("Internal error: an arc of the level curve is not a graph over its parameter.")
            dz = self._position_noise(g)
            return np.stack([z[rows, 1 - kind], dtds], -1), np.stack([dz, dtds * self._hnorm * dz / _norm(g)], -1)

        floor = np.array([1.0, 0.0])
        self._arcs = _Piecewise.fit(arcs, np.arange(len(runs) + 1.0), floor, self._ctol, "time of flight")
        self._tau, self._tau_edges = self._arcs.antiderivative()
        self._tau.coeffs, self._tau_edges = self._tau.coeffs[:, :, 1:], self._tau_edges[:, 1]
        T = float(self._tau_edges[-1])
        tails = np.abs(self._arcs.coeffs[:, -3:, 1]).max(axis=1) * np.diff(self._arcs.edges)
        self.period, self.period_error = T, float(np.sum(tails))
        if self.period_error > 100 * self.tol * T:
            g = _norm(self._grad(pts)).min()
            raise ConvergenceError(
                f"The period of the orbit through y0 = {self.y0.tolist()} is resolved only to a relative "
                f"{self.period_error / T:.1e} (asked: tol = {self.tol:g}): the level curve comes within "
                f"|grad H| = {g:.2e} of a critical point, where H in double precision fixes it only to about "
                f"{4 * _EPS * self._escale / g:.1e} (scaled). Pass a larger `tol` to accept that accuracy, or a "
                "larger `energy_tol` to treat the orbit as the nearby separatrix or equilibrium."
            )
        run_edges = self._tau_edges[np.searchsorted(self._arcs.edges, np.arange(len(runs) + 1.0))]

        def states(t: np.ndarray, _root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            z, g = self._invert(t)
            return z, self._position_noise(g)[:, None]

        self._table = _Piecewise.fit(states, run_edges, np.ones(2), self._ctol, "state", ladder=(17, 33))
        self._turning_and_range()

    def _position_noise(self, g: np.ndarray) -> np.ndarray:
        """How far a computed point of the level curve may be from it: the rounding of H over |grad H|."""
        return 4 * _EPS * self._escale / _norm(g)

    def _invert(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The scaled state at times ``r`` in [0, T] (and grad H there) by inverting the time of flight."""
        idx = np.clip(np.searchsorted(self._tau_edges, r, side="right") - 1, 0, len(self._tau_edges) - 2)
        t_a, t_b = self._tau_edges[idx], self._tau_edges[idx + 1]
        half = np.diff(self._arcs.edges)[idx] / 2
        x = np.clip(-1 + 2 * (r - t_a) / (t_b - t_a), -1.0, 1.0)
        lo, hi = -np.ones_like(x), np.ones_like(x)
        for it in range(100):
            F = _chebeval(self._tau.coeffs, idx, x)[:, 0] - r
            dF = _chebeval(self._arcs.coeffs[:, :, 1:], idx, x)[:, 0] * half
            lo, hi = np.where(F < 0, x, lo), np.where(F > 0, x, hi)
            xn = x - F / dF
            xn = np.where((xn <= lo) | (xn >= hi) | (it > 30), 0.5 * (lo + hi), xn)  # Newton, else bisection
            # the time of flight is known to a few ulps of t: x is resolved when F is at that level
            done = (np.abs(xn - x) <= 4 * _EPS) | (np.abs(F) <= 4 * _EPS * t_b) | (hi - lo <= 8 * _EPS)
            x = xn
            if np.all(done):
                break
        else:
            raise ConvergenceError("Inverting the time of flight did not converge (internal error).")
        root = self._arcs.root[idx]
        sig = self._arcs.edges[idx] + (x + 1) * half
        kind = self._run_kind[root]
        u = self._run_u[root, 0] + (sig - root) * (self._run_u[root, 1] - self._run_u[root, 0])
        v = _chebeval(self._arcs.coeffs[:, :, :1], idx, x)[:, 0]
        return self._solve_graph(kind, u, v)

    def _extremes(self, kind: int) -> np.ndarray:
        """Parameters ``sigma`` on arcs of ``kind`` where the graph ``v`` has a stationary point."""
        found = []
        for j in np.flatnonzero(self._run_kind[self._arcs.root] == kind):
            c = np.trim_zeros(self._arcs.coeffs[j, :, 0], "b")
            if c.size < 3:
                continue
            dc = _cheb.chebder(c)
            for root in _cheb.chebroots(dc):
                if abs(root.imag) < 1e-8 and -1 - 1e-9 <= root.real <= 1 + 1e-9:
                    x = float(np.clip(root.real, -1, 1))
                    for _ in range(5):  # roots of the companion matrix, refined by Newton on v'
                        d2 = _cheb.chebval(x, _cheb.chebder(dc))
                        if d2 == 0:
                            break
                        x = float(np.clip(x - _cheb.chebval(x, dc) / d2, -1, 1))
                    a, b = self._arcs.edges[j], self._arcs.edges[j + 1]
                    found.append(a + (x + 1) * (b - a) / 2)
        return np.array(found)

    def _turning_and_range(self) -> None:
        T = self.period
        sig = self._extremes(1)
        if sig.size:
            z = np.array([self._polish_turning(zi) for zi in self._invert(self._tau(sig)[:, 0].clip(0, T))[0]])
            # the time from the polished p on its arc (a graph over p): exact where the derivative root is not
            idx, _ = self._arcs.locate(sig)
            root = self._arcs.root[idx]
            u0, u1 = self._run_u[root, 0], self._run_u[root, 1]
            times = np.mod(self._tau(root + (z[:, 1] - u0) / (u1 - u0))[:, 0], T)
            order = np.argsort(times)
            z, times = z[order], times[order]
            # one turning point may be found on two neighbouring arcs (at both ends of [0, T] too)
            keep = [i for i in range(len(z)) if not any(np.linalg.norm(z[i] - z[k]) < 1e-8 for k in range(i))]
            self.turning_times, self.turning_points = times[keep], z[keep] * self._s
        sig = np.concatenate([self._extremes(0), self._arcs.edges])
        p = self._invert(self._tau(sig)[:, 0].clip(0, T))[0][:, 1] * self._s[1]
        self.L_range = (float(p.min()), float(p.max()))

    def _polish_turning(self, z: np.ndarray) -> np.ndarray:
        """Newton's method on (H - E, dH/dp) = 0; the Jacobian is regular where d^2H/dp^2 != 0."""
        for _ in range(4):
            g = self._grad(z[None])[0]
            F = np.array([self._H(z[None])[0] - self.energy, g[1]])
            with np.errstate(all="ignore"):
                dz = np.linalg.lstsq(np.array([g, self._hess(z)[1]]), F, rcond=None)[0]
            if not np.all(np.isfinite(dz)) or np.linalg.norm(dz) > 1e-6:
                break
            z = z - dz
        return z

    # -- public ---------------------------------------------------------------------------------------
    @property
    def frequency(self) -> float:
        """:math:`2\\pi / T` (0 for an infinite period)."""
        return 2 * np.pi / self.period

    def _require_periodic(self, what: str) -> None:
        if self.kind == "separatrix":
            at = ", ".join(str(np.round(s.y, 12).tolist()) for s in self.saddles)
            raise SingularityError(
                f"{what}: the orbit through y0 = {self.y0.tolist()} is a separatrix (it reaches the saddle(s) "
                f"{at} in infinite time); quadrature gives no periodic motion there, use an integrator."
            )

    def state(self, t: Any) -> np.ndarray:
        """The state :math:`y(t) = (q, p)` with :math:`y(0) = y_0`, shape ``t.shape + (2,)``.

        ``q`` is the continuous lift (a rotation advances it by ``winding * angle_period`` per period);
        reduce it modulo the angle period if needed. ``t`` may be negative.
        """
        self._require_periodic("state")
        t = V.finite(t, "t")
        if self.kind == "equilibrium":
            return np.broadcast_to(self.y0, t.shape + (2,)).copy()
        if np.any(np.abs(t) > self.period / _EPS):
            raise InputError(
                f"Expected |t| below period / eps = {self.period / _EPS:.3g}, got {np.max(np.abs(t)):.3g}: beyond "
                "it not one digit of the phase t mod T is known in double precision."
            )
        n = np.floor(t / self.period)
        z = self._table(t - n * self.period)
        if self.winding:
            assert self._P is not None  # a rotation winds only where q is an angle
            z[..., 0] += n * (self.winding * self._P)
        return z * self._s

    def integral(self, f: Callable[[np.ndarray], Any]) -> OrbitIntegral:
        """:math:`\\int_0^t f(y(s))\\,ds` along the orbit, for ``f`` mapping states ``(N, 2)`` to ``(N,)`` or
        ``(N, k)``: its increment per period and its periodic part, each by adaptive Chebyshev quadrature."""
        self._require_periodic("integral")
        if not callable(f):
            raise InputError(f"Expected `f` to be callable on states of shape (N, 2), got {type(f).__name__}.")

        def values(t: np.ndarray) -> np.ndarray:
            y = self.state(t)
            with np.errstate(all="ignore"):
                out = np.asarray(f(y), dtype=float).reshape(t.size, -1)
            if not np.all(np.isfinite(out)):
                bad = int(np.argmax(~np.all(np.isfinite(out), axis=1)))
                raise NumericalError(f"`f` is not finite on the orbit at y = {y[bad].tolist()} (t = {t[bad]:.6g}).")
            return out

        if self.kind == "equilibrium":
            rate = values(np.zeros(1))[0]
            return OrbitIntegral(math.inf, rate * 0, None, rate)
        m = values(np.zeros(1)).shape[1]

        def sampled(t: np.ndarray, _root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            out = values(t)
            # f inherits the rounding noise of the states it is evaluated at
            return out, 10 * self._table.noise * np.abs(out).max(axis=0)

        table, at_edges = _Piecewise.fit(
            sampled, self._table.edges, np.zeros(m), self._ctol, "integral"
        ).antiderivative()
        return OrbitIntegral(self.period, at_edges[-1], table, at_edges[-1] / self.period)

    def __repr__(self) -> str:
        return (
            f"QuadraturePropagator(kind={self.kind!r}, energy={self.energy:.17g}, period={self.period:.17g}, "
            f"winding={self.winding})"
        )
