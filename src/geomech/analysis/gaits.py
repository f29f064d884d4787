r"""Periodic gaits of nonholonomic systems with symmetry: net displacement, and what each term contributes.

For a nonholonomic system with symmetry (:class:`~geomech.systems.nonholonomic.NonholonomicSystem`) with the
shape driven along a prescribed loop :math:`r(t)` of period :math:`T`, the BKMM reduction (eqs. 1.1-1.2 of
the nonholonomic seed; Bloch, Krishnaprasad, Marsden and Murray 1996) gives

.. math::

    g^{-1}\dot g = \underbrace{-\mathcal A^{nh}(r)\,\dot r}_{\text{connection term}}
                 + \underbrace{e(r)\,\mathbb I^{-1}(r)\,p}_{\text{momentum term}}, \qquad
    \dot p = \dot r^T H(r)\,\dot r + \dot r^T K(r)\,p + p^T D(r)\,p,

with :math:`e(r)` the body-fixed basis of :math:`S_q = \mathcal D_q\cap T_q\mathrm{Orb}`. Along a prescribed
gait the momentum equation is an ODE for :math:`p` alone, driven by :math:`(r, \dot r)`; :func:`analyse_gait`
integrates it, then reconstructs :math:`g(t)` on the group with a Lie-group method
(:func:`~geomech.solve` on a :class:`~geomech.systems.GroupFlow`), and gives the net displacement
:math:`g(0)^{-1}g(T)` per period and over several periods, the change of :math:`p` over each period, and the
displacement that the connection term and the momentum term would each produce alone
(:func:`~geomech.analysis.group_paths.decompose_displacement`).

**What the split is, and is not.** The two terms are a split of the body velocity, not of the
displacement: on a non-abelian group (SE(2)) the displacement of the sum is not the composition, let
alone the sum, of the displacements of the parts, and :math:`p` is not conserved but built up along the
gait. For holonomic systems with an abelian symmetry the analogous split is the geometric plus dynamic
phase of Theorem 2.2 (eq. 2.3); for nonholonomic systems the seed (section 2) leaves the division of the
net motion into a geometric and a dynamic phase open, and this split is not offered as one. Only the
connection-alone displacement is geometric (it depends on the loop's image and orientation, not on its
timing), and the rotation it produces is exactly :math:`-\oint\mathcal A^{nh}_\theta\,dr
= -\iint B_\theta` (:func:`~geomech.analysis.phases.geometric_phase`,
:func:`~geomech.analysis.phases.curvature_integral`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import InputError, NumericalError, ShapeError
from ..integrators import Solution
from ..reduction.nonholonomic import reduced_numeric
from ..reduction.reduced_numeric import ReducedNumeric
from ..systems.gait import Gait
from .gait_model import check_regular, gait_loop
from .group_paths import decompose_displacement
from .shape_loops import bind_loop

__all__ = [
    "GaitAnalysis",
    "analyse_gait",
]

_NOTE = (
    "The connection-alone and momentum-alone displacements integrate each term of the body velocity by "
    "itself; on a non-abelian group they do not compose (nor add) to the net displacement, and their split "
    "is not a geometric/dynamic phase decomposition (open for nonholonomic systems, section 2 of the seed)."
)


# ---------------------------------------------------------------------------------------------------
# The analysis
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class GaitAnalysis(ShowsItselfAsHTML):
    """The motion of a nonholonomic system along ``periods`` periods of a gait, and its parts.

    Attributes
    ----------
    model : ReducedNumeric
    loop : Gait
    periods : int
    t : (n,) times, ``samples_per_period`` per period, the period boundaries among them.
    r, rdot : (n, sigma) shapes and shape velocities.
    p : (n, m) nonholonomic momentum (eq. 1.2 integrated along the gait).
    xi_connection, xi_momentum : (n, k) the two terms of the body velocity (eq. 1.1); ``xi`` their sum.
    path : Solution of :math:`g(t)` (eq. 1.1 integrated on the group).
    alone : ``{"connection": Solution, "momentum": Solution}``, each term integrated by itself from ``g0``.
    winding : whole turns of the loop in its angle coordinates.
    """

    model: ReducedNumeric = field(repr=False)
    loop: Gait = field(repr=False)
    periods: int
    t: np.ndarray = field(repr=False)
    r: np.ndarray = field(repr=False)
    rdot: np.ndarray = field(repr=False)
    p: np.ndarray = field(repr=False)
    xi_connection: np.ndarray = field(repr=False)
    xi_momentum: np.ndarray = field(repr=False)
    path: Solution = field(repr=False)
    alone: dict[str, Solution] = field(repr=False)
    winding: tuple[int, ...] = ()
    momentum_nfev: int = 0

    @property
    def system(self) -> Any:
        return self.model.system

    @property
    def period(self) -> float:
        return self.loop.T

    @property
    def xi(self) -> np.ndarray:
        return self.xi_connection + self.xi_momentum

    @property
    def boundary_indices(self) -> np.ndarray:
        """Indices of the times :math:`0, T, \\dots, NT` in ``t``."""
        step = (self.t.size - 1) // self.periods
        return np.arange(self.periods + 1) * step

    def _path(self, part: str) -> Solution:
        if part == "total":
            return self.path
        if part not in self.alone:
            raise InputError(f"Expected `part` to be 'total', 'connection' or 'momentum', got {part!r}.")
        return self.alone[part]

    def displacement(self, periods: int | None = None, *, part: str = "total", start: int = 0) -> np.ndarray:
        """:math:`g(t_0)^{-1}g(t_0 + nT)`, :math:`t_0` the start of period ``start``, ``n = periods`` (default
        all the rest): the net motion in the body frame at :math:`t_0`, as a group element."""
        path = self._path(part)
        idx = self.boundary_indices
        n = self.periods - start if periods is None else int(periods)
        if not (0 <= start and 0 <= n and start + n <= self.periods):
            raise InputError(
                f"Expected 0 <= start and start + periods <= {self.periods}, got start = {start}, periods = {n}."
            )
        G = self.model.group.numeric
        return G.compose(G.inverse(path.element[idx[start]]), path.element[idx[start + n]])

    def displacement_coordinates(
        self, periods: int | None = None, *, part: str = "total", start: int = 0
    ) -> np.ndarray:
        """:meth:`displacement` in the system's chart coordinates, its angles unwrapped (SE(2) ``(dx, dy,
        dtheta)`` with the turn accumulated on the universal cover, S^1 the unwrapped angle); where the chart is
        singular at the identity (3-1-3 Euler angles of SO(3)), the exponential coordinates (log, for SO(3) the
        rotation vector)."""
        chart = self.model.group
        path = self._path(part)
        idx = self.boundary_indices
        n = self.periods - start if periods is None else int(periods)
        d = self.displacement(n, part=part, start=start)
        if self.model.exponential_coordinates:
            return chart.numeric.log(d)
        q = np.array(chart.to_coordinates(d), dtype=float)
        ac = list(chart.angle_components)
        if ac:
            q[ac] = path.g[idx[start + n], ac] - path.g[idx[start], ac]
        return q

    @property
    def net_displacement(self) -> np.ndarray:
        """:meth:`displacement_coordinates` over all the periods."""
        return self.displacement_coordinates()

    def per_period(self, part: str = "total") -> np.ndarray:
        """``(periods, k)``: the displacement of each period in the body frame at its start. For a gait whose
        momentum changes from period to period these differ; they are equal when :math:`p` returns."""
        return np.array([self.displacement_coordinates(1, part=part, start=j) for j in range(self.periods)])

    @property
    def momentum_change(self) -> np.ndarray:
        """``(periods, m)``: :math:`p((j+1)T) - p(jT)` for each period."""
        return np.diff(self.p[self.boundary_indices], axis=0)

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        if self.model.exponential_coordinates:
            return tuple(f"log_{n}" for n in self.model.group.algebra_names)
        return tuple(c.name for c in self.system.group.coordinates)

    def _html_data(self) -> dict[str, Any]:
        return self.summary()

    def summary(self) -> dict[str, Any]:
        """A JSON-ready summary (numbers as floats and lists)."""
        names = self.coordinate_names

        def named(v: np.ndarray) -> dict[str, float]:
            return {n: float(x) for n, x in zip(names, v)}

        idx = self.boundary_indices
        return {
            "system": self.system.name,
            "group": self.system.group.name,
            "shape": [s.name for s in self.system.shape],
            "loop": (
                None
                if self.loop.expressions is None
                else {n: str(e) for n, e in zip([s.name for s in self.system.shape], self.loop.expressions)}
            ),
            "period": self.period,
            "periods": self.periods,
            "winding": list(self.winding),
            "p0": self.p[0].tolist(),
            "momentum_basis": self.model.reduction.normalization,
            "net_displacement": named(self.net_displacement),
            "displacement_per_period": [named(v) for v in self.per_period()],
            "connection_alone": named(self.displacement_coordinates(part="connection")),
            "momentum_alone": named(self.displacement_coordinates(part="momentum")),
            "connection_alone_per_period": [named(v) for v in self.per_period("connection")],
            "momentum_at_period_starts": self.p[idx].tolist(),
            "momentum_change_per_period": self.momentum_change.tolist(),
            "displacement_frame": "body frame at the start: g(t0)^-1 g(t0 + n T)",
            "note": _NOTE,
            "integrator": {
                "group": self.path.method.key,
                "steps": int(self.path.stats["n_internal_steps"]),
                "nfev": int(self.path.stats["n_rhs"]),
                "momentum_nfev": int(self.momentum_nfev),
            },
        }

    def to_dataset(self) -> Any:
        """The time series as an :class:`xarray.Dataset` (write it with ``.to_netcdf(path)``)."""
        import xarray as xr

        s = self.system
        alg = [f"xi{a + 1}" for a in range(self.model.k)]
        coords = {
            "t": self.t,
            "shape": [r.name for r in s.shape],
            "algebra": alg,
            "momentum": [f"p{i + 1}" for i in range(self.model.m)],
            "coordinate": list(self.coordinate_names),
        }

        def gcoords(path: Solution) -> np.ndarray:
            G = self.model.group.numeric
            if self.model.exponential_coordinates:
                return G.log(G.compose(G.inverse(path.element[0])[None], path.element))
            return path.g

        data = {
            "r": (("t", "shape"), self.r),
            "rdot": (("t", "shape"), self.rdot),
            "p": (("t", "momentum"), self.p),
            "xi": (("t", "algebra"), self.xi),
            "xi_connection": (("t", "algebra"), self.xi_connection),
            "xi_momentum": (("t", "algebra"), self.xi_momentum),
            "g": (("t", "coordinate"), gcoords(self.path)),
            "g_connection_alone": (("t", "coordinate"), gcoords(self.alone["connection"])),
            "g_momentum_alone": (("t", "coordinate"), gcoords(self.alone["momentum"])),
        }
        attrs = {
            "system": s.name,
            "group": s.group.name,
            "period": self.period,
            "periods": self.periods,
            "note": _NOTE,
            "g_convention": (
                "chart coordinates, continuous along the path, angles unwrapped "
                "(SE(2): x, y and the heading; S^1: the angle); where the chart "
                "is singular at the identity (SO(3) in 3-1-3 Euler angles): the "
                "exponential coordinates (rotation vector) of g(0)^-1 g(t)"
            ),
        }
        return xr.Dataset(data, coords=coords, attrs=attrs)


def _element0(model: ReducedNumeric, g0: Any) -> np.ndarray:
    names = [c.name for c in model.system.group.coordinates]
    if g0 is None:
        vals = np.array([float(v) for v in model.system.group.identity])
    elif isinstance(g0, Mapping):
        unknown = sorted(set(map(str, g0)) - set(names))
        if unknown:
            raise InputError(f"`g0` names {unknown}, which are not group coordinates of {model.name} ({names}).")
        vals = np.array([float(g0.get(n, v)) for n, v in zip(names, model.system.group.identity)])
    else:
        vals = V.finite(g0, "g0").reshape(-1)
        if vals.size != len(names):
            raise ShapeError(
                f"Expected `g0` with {len(names)} group coordinates ({', '.join(names)}), got {vals.size}."
            )
    return model.element(vals)


def analyse_gait(
    system: Any,
    loop: Any,
    *,
    period: float | None = None,
    periods: int = 1,
    p0: Any = None,
    g0: Any = None,
    parameters: Mapping[str, float] | None = None,
    basis: Any = None,
    samples_per_period: int = 201,
    rtol: float = 1e-12,
    atol: float = 1e-12,
) -> GaitAnalysis:
    r"""Integrate a nonholonomic system along ``periods`` periods of a prescribed gait and split its motion.

    Steps: (1) the momentum equation (1.2) along :math:`r(t)` from :math:`p(0) = p_0` (scipy's DOP853,
    dense output); (2) :math:`g^{-1}\dot g = -\mathcal A^{nh}(r)\dot r + e(r)\mathbb I^{-1}(r)p` (eq. 1.1) on
    the group by Runge-Kutta-Munthe-Kaas (:func:`~geomech.solve` on a :class:`~geomech.systems.GroupFlow`), together
    with each term alone (:func:`~geomech.analysis.group_paths.decompose_displacement`). The alone-displacements
    do not add (nor compose) to the net one on a non-abelian group, and are not a geometric/dynamic phase
    split: see the module docstring.

    Parameters
    ----------
    system : NonholonomicSystem
        Its group must be SE(2), SO(3) or S^1.
    loop : Gait or mapping
        The gait: a closed loop in shape space (angle coordinates may wind by whole turns), or formulas in
        ``t`` (and ``T``) for every shape variable, with ``period``.
    periods : int
        Number of periods to integrate.
    p0 : (m,) array, optional
        Initial nonholonomic momentum in the reduction's basis (default 0).
    g0 : mapping or (k,) array, optional
        Initial group coordinates (default the identity); the displacements do not depend on it.
    parameters : mapping, optional
        Parameter values not stored in the system.
    samples_per_period : int
        Output times per period (the integrators choose their own steps).

    Raises
    ------
    ShapeError
        The loop has the wrong dimension or wrong coordinate names, ``p0`` the wrong size.
    InputError
        The loop is not closed, or names an unknown shape variable.
    SingularityError
        The locked inertia is singular (or the connection infinite) somewhere on the loop.
    """
    from scipy.integrate import solve_ivp

    model = reduced_numeric(system, parameters, basis)
    s = model.system
    loop = gait_loop(s, loop, period, parameters=parameters)
    winding = bind_loop(model, loop)
    check_regular(model, loop)
    periods = int(periods)
    if periods < 1:
        raise InputError(f"Expected `periods` to be a positive integer, got {periods}.")
    samples = int(samples_per_period)
    if samples < 3:
        raise InputError(f"Expected `samples_per_period` >= 3, got {samples}.")
    T = loop.T
    t_eval = np.linspace(0.0, periods * T, periods * (samples - 1) + 1)
    m = model.m
    if p0 is None:
        p_init = np.zeros(m)
    else:
        p_init = V.finite(np.atleast_1d(p0), "p0").reshape(-1)
        if p_init.size != m:
            raise ShapeError(
                f"Expected `p0` with {m} component(s) (dim S_q of {s.name}, basis: "
                f"{model.reduction.normalization}), got {p_init.size}."
            )
    nfev = 0
    if m:

        def rhs(t: float, p: np.ndarray) -> np.ndarray:
            return model.pdot(loop.r(t), loop.rdot(t), p)

        sol = solve_ivp(
            rhs, (0.0, t_eval[-1]), p_init, method="DOP853", rtol=rtol, atol=atol, dense_output=True, t_eval=t_eval
        )
        if sol.status != 0 or not np.all(np.isfinite(sol.y)):
            raise NumericalError(
                f"The momentum equation (1.2) of {s.name} along the gait failed at t = {sol.t[-1]:.6g}: {sol.message}"
            )
        nfev = int(sol.nfev)
        p_of_t, P = sol.sol, sol.y.T
    else:

        def p_of_t(t: float) -> np.ndarray:
            return np.zeros(0)

        P = np.zeros((t_eval.size, 0))

    def xi_conn(t: float, g: np.ndarray) -> np.ndarray:
        return model.xi_connection(loop.r(t), loop.rdot(t))

    def xi_mom(t: float, g: np.ndarray) -> np.ndarray:
        return model.xi_momentum(loop.r(t), p_of_t(t))

    parts = decompose_displacement(
        model.group, {"connection": xi_conn, "momentum": xi_mom}, _element0(model, g0), t_eval, rtol=rtol, atol=atol
    )
    path = parts.pop("total")
    r, rd = loop.r(t_eval), loop.rdot(t_eval)
    out = GaitAnalysis(
        model,
        loop,
        periods,
        t_eval,
        r,
        rd,
        P,
        model.xi_connection(r, rd),
        model.xi_momentum(r, P),
        path,
        parts,
        tuple(int(w) for w in winding),
        nfev,
    )
    return out
