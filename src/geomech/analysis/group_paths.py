r"""Paths on a Lie group: :func:`integrate_on_group` integrates :math:`g^{-1}\dot g = \xi(t, g)` on any
group of :mod:`geomech.lie` with a Lie-group method (Runge-Kutta-Munthe-Kaas, in exponential coordinates
about a moving centre), staying on the group exactly; :class:`GroupPath` holds the result with its chart
coordinates (angles unwrapped); :func:`decompose_displacement` integrates a sum of body velocities and
each term alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from scipy.integrate import solve_ivp

from .. import _validate as V
from ..errors import InputError, NumericalError, ShapeError
from ..symbolic.charts import group_chart

__all__ = ["GroupPath", "integrate_on_group", "decompose_displacement"]


@dataclass(frozen=True, eq=False)
class GroupPath:
    """A path :math:`g(t)` in the group, from :func:`integrate_on_group`.

    Attributes
    ----------
    group : the group's symbolic twin (:class:`~geomech.symbolic.GroupChart`; ``group.numeric`` the group).
    t : (n,) times. g : (n, N, N) elements (matrices).
    angles : (n, m) the unwrapped angles of the group's ``angle_components`` (the heading of SE(2), the angle
        of S^1, on the universal cover: turns are not wrapped), None if it has none.
    coordinates : (n, k) chart coordinates, with those angles unwrapped (SO(3): 3-1-3 Euler angles, wrapped).
    method, steps, nfev : the integrator, its steps and evaluations of the velocity.
    """

    group: Any
    t: np.ndarray
    g: np.ndarray
    angles: np.ndarray | None
    coordinates: np.ndarray
    method: str
    steps: int
    nfev: int

    @property
    def angle(self) -> np.ndarray | None:
        """(n,): the unwrapped angle when the group has exactly one (S^1, SE(2)), else None."""
        return self.angles[:, 0] if self.angles is not None and self.angles.shape[1] == 1 else None

    def displacement(self) -> np.ndarray:
        """:math:`g(t_0)^{-1} g(t_{end})` (the net motion in the body frame at the start)."""
        G = self.group.numeric
        return G.compose(G.inverse(self.g[0]), self.g[-1])

    def net_motion(self) -> dict[str, float]:
        """The net motion by name: the change of each chart coordinate (angles unwrapped), or where the chart
        is singular at the identity (SO(3) in 3-1-3 Euler angles, whose differences are no motion) the
        exponential coordinates of :meth:`displacement` (``log_<algebra name>``: the rotation vector)."""
        chart = self.group
        if chart.regular_at_identity:
            names = [c.name for c in chart.coordinates]
            values = self.coordinates[-1] - self.coordinates[0]
        else:
            names = [f"log_{n}" for n in chart.algebra_names]
            values = chart.numeric.log(self.displacement())
        return {n: float(v) for n, v in zip(names, values)}


def integrate_on_group(
    group: Any,
    xi: Callable[[float, np.ndarray], np.ndarray],
    g0: Any,
    t_eval: Any,
    *,
    method: str = "rkmk-dop853",
    rtol: float = 1e-12,
    atol: float = 1e-12,
    step: float | None = None,
    chart_radius: float = 1.0,
) -> GroupPath:
    """Integrate :math:`g^{-1}\\dot g = \\xi(t, g)` on the group, staying on it exactly.

    Both methods write :math:`g = g_c\\exp(u)` about a centre :math:`g_c` and integrate
    :math:`\\dot u = \\mathrm{dexp}^{-1}_{-u}\\xi = J_r(u)^{-1}\\xi(t, g_c\\exp u)` (Munthe-Kaas 1999):

    - ``"rkmk4"``: the classical RKMK method of order 4, a new centre every step of size ``step``;
    - ``"rkmk-dop853"`` (default): scipy's adaptive DOP853 (order 8) on :math:`u`, a new centre when
      :math:`|u|` reaches ``chart_radius`` (well inside the injectivity radius of exp).

    The angles of the group's ``angle_components`` are integrated alongside, unwrapped.

    Parameters
    ----------
    group : a group of :mod:`geomech.lie`, its :class:`~geomech.symbolic.GroupChart`, or a group's name.
    xi : ``xi(t, g)`` -> ``(k,)`` body velocity.
    g0 : initial element, an ``(N, N)`` matrix.
    t_eval : increasing output times, the first being the initial time.
    """
    chart = group_chart(group)
    G = chart.numeric
    t_eval = V.finite(t_eval, "t_eval")
    if t_eval.ndim != 1 or t_eval.size < 2 or np.any(np.diff(t_eval) <= 0):
        raise InputError(f"Expected `t_eval` strictly increasing with at least 2 times, got shape {t_eval.shape}.")
    g0 = G.check(g0, "g0")
    if g0.ndim != 2:
        raise ShapeError(f"Expected one element `g0` of shape {(G.matrix_size,) * 2}, got {g0.shape}.")
    k, ac = G.dim, list(G.angle_components)
    angle0 = G.log(g0)[ac]
    out_g = np.empty((t_eval.size,) + g0.shape)
    out_a = np.empty((t_eval.size, len(ac)))
    out_g[0], out_a[0] = g0, angle0
    nfev = 0
    steps = 0

    def chart_rhs(t: float, u: np.ndarray, gc: np.ndarray) -> np.ndarray:
        nonlocal nfev
        nfev += 1
        v = np.asarray(xi(t, G.compose(gc, G.exp(u))), dtype=float).reshape(k)
        if not np.all(np.isfinite(v)):
            raise NumericalError(f"The body velocity is not finite at t = {t:.6g}: {v.tolist()}.")
        return G.right_jacobian_inverse(u) @ v

    gc, ac_angle, tc = g0.copy(), angle0.copy(), float(t_eval[0])
    # exp is a global chart of an abelian group's cover: never recentre there.
    radius = np.inf if G.abelian else float(chart_radius)
    if method == "rkmk4":
        if step is None or not (step > 0):
            raise InputError(f"Expected a positive `step` for method 'rkmk4', got {step!r}.")
        for i in range(1, t_eval.size):
            m = int(np.ceil((t_eval[i] - t_eval[i - 1]) / step - 1e-12))
            h = (t_eval[i] - t_eval[i - 1]) / m
            for j in range(m):
                t = t_eval[i - 1] + j * h
                z = np.zeros(k)
                k1 = chart_rhs(t, z, gc)
                k2 = chart_rhs(t + h / 2, h * k1 / 2, gc)
                k3 = chart_rhs(t + h / 2, h * k2 / 2, gc)
                k4 = chart_rhs(t + h, h * k3, gc)
                theta = h * (k1 + 2 * k2 + 2 * k3 + k4) / 6
                gc = G.compose(gc, G.exp(theta))
                ac_angle = ac_angle + theta[ac]
                steps += 1
            out_g[i], out_a[i] = gc, ac_angle
    elif method == "rkmk-dop853":
        i = 1
        t_end = float(t_eval[-1])
        while i < t_eval.size:

            def leave(_t, u, *_):
                return float(np.linalg.norm(u)) - radius

            cast(Any, leave).terminal = True  # event attributes read by solve_ivp
            cast(Any, leave).direction = 1
            sol = solve_ivp(
                chart_rhs,
                (tc, t_end),
                np.zeros(k),
                method="DOP853",
                rtol=rtol,
                atol=atol,
                dense_output=True,
                events=leave,
                args=(gc,),
            )
            steps += int(sol.t.size - 1)
            if sol.status < 0:
                raise NumericalError(f"Reconstruction on {G.name} failed at t = {sol.t[-1]:.6g}: {sol.message}")
            t_stop = float(sol.t[-1])
            last = sol.status == 0
            while i < t_eval.size and (t_eval[i] < t_stop or (last and t_eval[i] <= t_stop)):
                u = sol.sol(t_eval[i])
                out_g[i] = G.compose(gc, G.exp(u))
                out_a[i] = ac_angle + u[ac]
                i += 1
            u = sol.y[:, -1]
            gc = G.compose(gc, G.exp(u))
            ac_angle = ac_angle + u[ac]
            tc = t_stop
    else:
        raise InputError(f"Expected `method` to be 'rkmk-dop853' or 'rkmk4', got {method!r}.")
    coords = chart.to_coordinates(out_g)
    # the chart coordinate of an angle component's index is that angle (SO(2), SE(2), their products)
    coords[:, ac] = out_a
    return GroupPath(chart, t_eval, out_g, out_a if ac else None, coords, method, steps, nfev)


def decompose_displacement(
    group: Any, terms: Mapping[str, Callable[[float, np.ndarray], np.ndarray]], g0: Any, t_eval: Any, **options: Any
) -> dict[str, GroupPath]:
    """Integrate the sum of the body-velocity ``terms`` and each term alone, from the same ``g0``.

    Returns ``{"total": ..., name: ...}``. This is the split of a net displacement by contribution (e.g.
    the connection term :math:`-A\\dot r` and the momentum term :math:`\\mathbb I^{-1}p` of eq. 1.1 or
    2.2); on a non-abelian group, or when ``p`` depends on ``g``, the parts do not add up to the total.
    """
    names = list(terms)

    def total(t: float, g: np.ndarray) -> np.ndarray:
        return np.sum([np.asarray(terms[n](t, g), dtype=float) for n in names], axis=0)

    out = {"total": integrate_on_group(group, total, g0, t_eval, **options)}
    for n in names:
        out[n] = integrate_on_group(group, terms[n], g0, t_eval, **options)
    return out
