"""Relative equilibria of a left-invariant system: critical points of the reduced Hamiltonian on the sphere.

For a left-invariant :math:`H(m)` and :math:`|p| = G`, the relative equilibria are the momenta
:math:`m_e` on the sphere :math:`|m| = G` where :math:`m\\times\\nabla H(m) = 0` (Euler's equation at
rest), i.e. the critical points of the reduced Hamiltonian :math:`h_p = H\\circ U_p` (Theorem 3) in any
Serret-Andoyer chart. They are located here by Newton's method on :math:`\\nabla h_p = 0` in an atlas of
the three charts (one about each body axis), so the poles of the seed's chart, :math:`m = \\pm G e_3`, are
found like any other point; starting points are the local minima of :math:`|m\\times\\nabla H|` on a
quasi-uniform point set of the sphere. Completeness is checked with the Poincare-Hopf theorem: for
isolated nondegenerate critical points the indices :math:`\\operatorname{sign}\\det\\delta^2 h_p` add up
to :math:`\\chi(S^2) = 2`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import ConvergenceError, InputError, NumericalError
from ..reduction import SerretAndoyerChart
from ..systems import as_left_invariant

__all__ = [
    "Equilibrium",
    "EquilibriumSet",
    "chart_derivatives",
    "continue_equilibria",
    "find_equilibria",
    "refine_equilibrium",
    "fibonacci_sphere",
]

_CHARTS = tuple(SerretAndoyerChart(k) for k in range(3))


def fibonacci_sphere(n: int, G: float = 1.0) -> np.ndarray:
    """``n`` quasi-uniform points on the sphere of radius ``G`` (the golden-angle spiral), shape (n, 3)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - z**2)
    a = np.pi * (3.0 - np.sqrt(5.0)) * k
    return G * np.stack([r * np.cos(a), r * np.sin(a), z], -1)


def chart_derivatives(system: Any, m: Any, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:math:`(l, L)`, :math:`\\nabla h_p` and the Hessian :math:`\\delta^2 h_p` at ``m`` in the chart
    about ``axis`` (0-based), by the chain rule through :math:`\\nabla H` and :math:`D^2 H`:

    .. math::

        \\partial_{ab} h_p = U_a\\cdot D^2H\\, U_b + \\nabla H\\cdot U_{ab},
        \\qquad U(l, L) = C(s\\sin l, s\\cos l, L),\\ s = \\sqrt{G^2 - L^2}.
    """
    system = as_left_invariant(system)
    m = V.exact_shape(m, "m", (3,))
    if not 0 <= int(axis) <= 2:
        raise InputError(f"Expected `axis` to be 0, 1 or 2, got {axis!r}.")
    lL, grad, hess, _, _ = _derivatives(system, m, int(axis))
    return lL, grad, hess


def _derivatives(system: Any, m: np.ndarray, axis: int) -> tuple[np.ndarray, ...]:
    # Called in the inner loop of Newton: no argument checks (the callers have made them).
    G = float(np.sqrt(m @ m))
    C = _CHARTS[axis].permutation
    mp = m @ C
    s = float(np.hypot(mp[0], mp[1]))
    if s <= 1e-9 * G:
        raise InputError(f"m = {m.tolist()} is at a pole of the chart about axis {axis + 1}; use another chart.")
    l, L = float(np.arctan2(mp[0], mp[1])), float(mp[2])
    sL, sLL = -L / s, -(G**2) / s**3
    sn, cs = mp[0] / s, mp[1] / s
    U1 = C @ np.array([[s * cs, sL * sn], [-s * sn, sL * cs], [0.0, 1.0]])
    Ull = C @ np.array([-s * sn, -s * cs, 0.0])
    UlL = C @ np.array([sL * cs, -sL * sn, 0.0])
    ULL = C @ np.array([sLL * sn, sLL * cs, 0.0])
    g = np.asarray(system._gradient(m), dtype=float)
    H = np.asarray(system._hessian(m), dtype=float)
    hess = U1.T @ H @ U1 + np.array([[g @ Ull, g @ UlL], [g @ UlL, g @ ULL]])
    return np.array([l, L]), g @ U1, 0.5 * (hess + hess.T), g, H


def _best_axis(m: np.ndarray) -> int:
    return int(np.argmin(np.abs(m)))


@dataclass(frozen=True)
class Equilibrium(ShowsItselfAsHTML):
    """A relative equilibrium: a critical point of :math:`h_p` on :math:`|m| = G`.

    Attributes
    ----------
    m : (3,) body momentum; G : :math:`|m|`.
    axis : the chart (0-based body axis) in which it is described: the one it is farthest from the poles of.
    lL : (2,) its Serret-Andoyer coordinates in that chart.
    hessian : (2, 2) :math:`\\delta^2 h_p` there; its sign pattern does not depend on the chart.
    energy : :math:`H(m)`; residual : :math:`|\\nabla h_p|` reached by Newton.
    """

    m: np.ndarray
    G: float
    axis: int
    lL: np.ndarray
    hessian: np.ndarray
    energy: float
    residual: float

    @property
    def index(self) -> int:
        """Poincare-Hopf index: +1 at an extremum of :math:`h_p`, -1 at a saddle, 0 if degenerate."""
        if not np.all(np.isfinite(self.hessian)):
            raise NumericalError(
                f"The Hessian of h_p at the equilibrium m = {np.round(self.m, 6).tolist()} is not "
                "finite (an overflow: parameter values too large for double precision?)."
            )
        ev = np.linalg.eigvalsh(self.hessian)
        scale = max(np.abs(ev).max(), 1e-300)
        if np.abs(ev).min() <= 1e-9 * scale:
            return 0
        return int(np.sign(ev[0] * ev[1]))

    def coordinates(self, axis: int = 2) -> np.ndarray | None:
        """:math:`(l, L)` in the chart about ``axis``, or None at its poles."""
        mp = self.m @ _CHARTS[axis].permutation
        if np.hypot(mp[0], mp[1]) <= 1e-9 * self.G:
            return None
        return _CHARTS[axis].forward(self.m)

    def to_json(self) -> dict[str, Any]:
        seed = self.coordinates(2)
        return {
            "m": (self.m + 0.0).tolist(),
            "G": self.G,
            "chart_axis": self.axis + 1,
            "l": float(self.lL[0]),
            "L": float(self.lL[1]),
            "seed_chart_lL": None if seed is None else seed.tolist(),
            "energy": self.energy,
            "hessian": self.hessian.tolist(),
            "hessian_eigenvalues": np.linalg.eigvalsh(self.hessian).tolist(),
            "index": self.index,
            "residual": self.residual,
        }


def refine_equilibrium(
    system: Any, m_guess: Any, G: float | None = None, *, tol: float = 1e-12, max_iter: int = 80
) -> Equilibrium:
    """Solve :math:`\\nabla h_p = 0` from ``m_guess`` (projected to :math:`|m| = G`) in the chart farthest
    from its poles, switching chart when an iterate nears a pole.

    Levenberg-Marquardt on the residual :math:`r = \\nabla h_p` in the scaled coordinates :math:`(l, L/G)`:
    Newton's step where it reduces :math:`|r|` (quadratic convergence to a critical point of any type,
    minimum, maximum or saddle), a damped step towards steepest descent of :math:`|r|^2` where it does not.
    Raises :class:`~geomech.errors.ConvergenceError` when no critical point is reached, e.g. when the guess
    is near a local minimum of :math:`|\\nabla h_p|` that is not a zero (an equilibrium that has vanished
    in a fold).
    """
    system = as_left_invariant(system)
    m = V.exact_shape(m_guess, "m_guess", (3,))
    nm = np.linalg.norm(m)
    if nm == 0:
        raise InputError("Expected `m_guess` to be nonzero.")
    G = cast(float, nm) if G is None else V.positive_scalar(G, "G")  # the norm is a np.float64, a float
    m = G * m / nm
    S = np.diag([1.0, G])

    def state(m: np.ndarray, axis: int):
        lL, grad, hess, g, H = _derivatives(system, m, axis)
        return lL, S @ grad, S @ hess @ S, G * max(np.linalg.norm(g), G * np.abs(H).max(), 1e-300)

    axis = _best_axis(m)
    lL, r, J, scale = state(m, axis)
    mu = 1e-6 * max(np.abs(J).max() ** 2, 1e-300)
    res = float(np.linalg.norm(r))
    for _ in range(max_iter):
        if res <= tol * scale:
            # Report in the seed's chart (about axis 3) unless the point is near its poles.
            if axis != 2 and abs(m[2]) <= 0.9 * G:
                axis = 2
            lL, _, hess, _, _ = _derivatives(system, m, axis)
            return Equilibrium(m, G, axis, lL, hess, float(system.hamiltonian(m)), res)
        accepted = False
        for _ in range(30):
            step = np.linalg.solve(J.T @ J + mu * np.eye(2), J.T @ r)
            # Steps longer than a fraction of the sphere leave any local model's validity: shorten them.
            size = np.abs(step).max()
            if size > 0.5:
                step *= 0.5 / size
            new = lL - step * np.array([1.0, G])
            new[1] = np.clip(new[1], -0.95 * G, 0.95 * G)
            m_new = _CHARTS[axis].inverse(new, G)
            ax_new = _best_axis(m_new) if abs(new[1]) > 0.8 * G else axis
            lL_new, r_new, J_new, scale_new = state(m_new, ax_new)
            if np.linalg.norm(r_new) < res:
                m, axis, lL, r, J, scale = m_new, ax_new, lL_new, r_new, J_new, scale_new
                res = float(np.linalg.norm(r))
                mu = max(mu / 5.0, 1e-14 * max(np.abs(J).max() ** 2, 1e-300))
                accepted = True
                break
            mu *= 6.0
        if not accepted:
            break
    raise ConvergenceError(
        f"No relative equilibrium reached from m = {np.asarray(m_guess).tolist()}: |grad h_p| stalled at {res:.3g} "
        f"at m = {np.round(m, 9).tolist()} (a local minimum of |grad h_p| that is not a zero, or a degenerate "
        "critical point); none is near this guess."
    )


@dataclass(frozen=True)
class EquilibriumSet:
    """All relative equilibria found on :math:`|m| = G`, sorted by energy.

    ``index_sum`` is the sum of the Poincare-Hopf indices; ``complete`` is True when every equilibrium is
    nondegenerate and the sum is :math:`\\chi(S^2) = 2`, the evidence that none was missed.
    """

    equilibria: tuple[Equilibrium, ...]
    G: float
    index_sum: int
    n_degenerate: int
    complete: bool
    message: str

    def __iter__(self):
        return iter(self.equilibria)

    def __len__(self) -> int:
        return len(self.equilibria)

    def __getitem__(self, k: int) -> Equilibrium:
        return self.equilibria[k]

    def nearest(self, m: Any, prefer: Any = None) -> Equilibrium:
        """The equilibrium closest to ``m``. Several as close (to 1e-9 G: mirror images under a symmetry of H) are
        told apart by their distance to ``prefer`` (e.g. the previous choice along a parameter), then by their
        components, largest first: the choice does not depend on the order in which they were found."""
        m = V.exact_shape(m, "m", (3,))
        ms = np.array([e.m for e in self.equilibria])
        return self.equilibria[nearest_index(ms, m, self.G, None if prefer is None else np.asarray(prefer, float))]


def nearest_index(ms: np.ndarray, m: np.ndarray, G: float, prefer: np.ndarray | None = None) -> int:
    """The index of the row of ``ms`` closest to ``m``, ties (to 1e-9 G) broken as :meth:`EquilibriumSet.nearest`."""
    d = np.linalg.norm(ms - m, axis=-1)
    tied = np.nonzero(d <= d.min() + 1e-9 * G)[0]
    if tied.size == 1:
        return int(tied[0])
    keys = [
        (0.0 if prefer is None else float(np.linalg.norm(ms[j] - prefer)), -ms[j, 0], -ms[j, 1], -ms[j, 2], j)
        for j in tied
    ]
    return int(min(keys)[-1])


def find_equilibria(system: Any, G: float = 1.0, *, n_points: int = 1500, tol: float = 1e-12) -> EquilibriumSet:
    """Locate every relative equilibrium of ``system`` on the sphere :math:`|m| = G`.

    Starting points are the local minima of :math:`|m\\times\\nabla H(m)|` over ``n_points``
    quasi-uniform points (compared with their 8 nearest neighbours) and the six points
    :math:`\\pm G e_k`; each is refined by :func:`refine_equilibrium`, and duplicates are merged. When the
    result is not consistent with the Poincare-Hopf theorem, a second pass uses six times as many points.
    ``complete`` says whether the final set is consistent (nondegenerate, index sum 2).
    """
    from scipy.spatial import cKDTree

    system = as_left_invariant(system)
    G = V.positive_scalar(G, "G")
    n_points = int(n_points)
    if n_points < 50:
        raise InputError(f"Expected `n_points` >= 50, got {n_points}.")
    found: list[Equilibrium] = []
    tried = 0
    # A second, denser pass when the first is not consistent with Poincare-Hopf: close pairs of equilibria
    # (near a bifurcation) can share one starting point.
    for n in (n_points, 6 * n_points):
        pts = fibonacci_sphere(n, G)
        with np.errstate(all="ignore"):
            r = np.linalg.norm(np.cross(pts, system.gradient(pts)), axis=-1)
        r = np.where(np.isfinite(r), r, np.inf)
        _, nbr = cKDTree(pts).query(pts, k=9)
        minima = np.nonzero(r <= r[nbr[:, 1:]].min(axis=1))[0]
        if len(minima) > max(200, n // 20):
            # a smooth H has a few equilibria; this many local minima of |m x grad H| is round-off noise
            raise NumericalError(
                f"|m x grad H| has {len(minima)} local minima over {n} points of the sphere "
                f"|m| = {G:g}: H is not resolved in double precision there (parameters spanning "
                "too many orders of magnitude?)."
            )
        seeds = ([G * e for e in np.vstack([np.eye(3), -np.eye(3)])] if not tried else []) + [pts[i] for i in minima]
        tried += 1
        for s in seeds:
            if any(np.linalg.norm(s - f.m) < 1e-9 * G for f in found):
                continue
            try:
                eq = refine_equilibrium(system, s, G, tol=tol)
            except (ConvergenceError, InputError, FloatingPointError):
                continue
            if all(np.linalg.norm(eq.m - f.m) > 1e-7 * G for f in found):
                found.append(eq)
        idx = [e.index for e in found]
        if all(i != 0 for i in idx) and sum(idx) == 2:
            break
    return _as_set(found, G)


def _as_set(found: list[Equilibrium], G: float) -> EquilibriumSet:
    found = sorted(found, key=lambda e: e.energy)
    idx = [e.index for e in found]
    n_deg = sum(1 for i in idx if i == 0)
    total = int(sum(idx))
    complete = n_deg == 0 and total == 2
    if complete:
        msg = f"{len(found)} nondegenerate equilibria; Poincare-Hopf index sum 2 = chi(S^2): none missed."
    elif n_deg:
        msg = (
            f"{n_deg} of {len(found)} equilibria are degenerate (singular Hessian of h_p): they may be "
            "non-isolated (a continuum) or bifurcating; the list may be incomplete."
        )
    else:
        msg = f"Poincare-Hopf index sum is {total}, not 2: some equilibria were missed; retry with more `n_points`."
    return EquilibriumSet(tuple(found), G, total, n_deg, complete, msg)


def continue_equilibria(
    system: Any, previous: EquilibriumSet, *, n_points: int = 600, tol: float = 1e-12, seeds: Any = None
) -> EquilibriumSet:
    """The equilibria of ``system`` continued from those of a nearby system (``previous``, same G).

    Each previous equilibrium is refined for the new system, and so is each point of ``seeds`` (``(k, 3)``
    momenta, scaled to the sphere: Newton from there may find an equilibrium the previous set did not have). When
    the result is not complete (Poincare-Hopf), e.g. after a fold, a pitchfork or a merger, or when it has more
    equilibria than ``previous`` (a seed found a pair born in a fold, which Poincare-Hopf cannot see: its two
    indices cancel), the full search :func:`find_equilibria` is run instead.
    """
    system = as_left_invariant(system)
    G = previous.G
    starts = [e.m for e in previous]
    if seeds is not None:
        extra = np.asarray(seeds, dtype=float).reshape(-1, 3)
        starts += [G * s / np.linalg.norm(s) for s in extra if np.linalg.norm(s) > 0]
    found: list[Equilibrium] = []
    for m in starts:
        try:
            eq = refine_equilibrium(system, m, G, tol=tol, max_iter=12)
        except (ConvergenceError, InputError, FloatingPointError):
            continue
        if all(np.linalg.norm(eq.m - f.m) > 1e-7 * G for f in found):
            found.append(eq)
    out = _as_set(found, G)
    if out.complete and len(out) == len(previous):
        return out
    return find_equilibria(system, G, n_points=n_points, tol=tol)
