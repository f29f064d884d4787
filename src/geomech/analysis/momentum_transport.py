r"""The momentum equation as transport along the shape path (BKMM; eq. 1.2 of the nonholonomic seed).

Along a prescribed shape path :math:`r(t)` the momentum equation is an ODE for the nonholonomic momentum alone,

.. math::

    \dot p = \dot r^T H(r)\,\dot r + \dot r^T K(r)\,p + p^T D(r)\,p .

Where :math:`D = 0` (the snakeboard, the roller racer, the rolling disk, the Chaplygin ball: every example with a
shape space) it is affine in :math:`p`: :math:`\dot p = \mathcal K(r)(\dot r)\,p + h(r, \dot r)`, with
:math:`\mathcal K = K_\alpha(r)\,dr^\alpha` (:math:`(K_\alpha)_{ij} = (K_i)_{\alpha j}`) a connection on the
bundle of momenta :math:`S\times\mathbb R^m` and :math:`h = \dot r^T H\dot r` a forcing quadratic in the shape
velocity. Its solution over a path is the affine map

.. math::

    p(t) = \Phi(t)\,p(0) + b(t), \qquad \dot\Phi = \mathcal K(\dot r)\,\Phi,\ \Phi(0) = I, \qquad
    \dot b = \mathcal K(\dot r)\,b + h, \ b(0) = 0,

where :math:`\Phi` is the parallel transport of :math:`\mathcal K`: geometric (it depends on the path's image
and orientation, not on its timing), and over a closed loop its holonomy. With one momentum (:math:`m = 1`) it
is :math:`\Phi = \exp\oint K_\alpha\,dr^\alpha = \exp\iint F` by Stokes, with the curvature
:math:`F_{\alpha\beta} = \partial_\alpha K_\beta - \partial_\beta K_\alpha`. The forcing part :math:`b` is not
geometric: it is quadratic in :math:`\dot r` and integrated in time, so traversing the same loop :math:`\lambda`
times slower divides it by :math:`\lambda`. The momentum gained by a gait from :math:`p_0` is
:math:`\Phi p_0 + b - p_0`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import InputError, NumericalError, ShapeError
from ..reduction.nonholonomic import reduced_numeric
from ..reduction.reduced_numeric import ReducedNumeric
from ..systems.gait import Gait
from .gait_model import check_regular, gait_loop
from .shape_loops import bind_loop

__all__ = ["MomentumTransport", "momentum_connection", "momentum_curvature", "momentum_transport"]


def _affine_model(system: Any, parameters: Mapping[str, float] | None, basis: Any) -> ReducedNumeric:
    model = system if isinstance(system, ReducedNumeric) else reduced_numeric(system, parameters, basis)
    s = model.system
    if model.m == 0:
        raise InputError(f"{s.name} has no nonholonomic momentum (dim S_q = 0): there is nothing to transport.")
    if model.sigma == 0:
        raise InputError(f"{s.name} has no shape variables: the momentum is not transported along a shape path.")
    _, _, D = model.reduction.momentum_coefficients
    if any(any(e != 0 for e in d) for d in D):
        raise InputError(
            f"The momentum equation of {s.name} is quadratic in p (p^T D(r) p is not zero): it is not a transport "
            "by a connection; integrate it along the gait with geomech.analysis.analyse_gait instead."
        )
    return model


def momentum_connection(
    system: Any, r: Any, *, parameters: Mapping[str, float] | None = None, basis: Any = None
) -> np.ndarray:
    """:math:`K_\\alpha(r)`, the connection of the momentum equation at shapes ``r`` ``(..., sigma)``: shape
    ``(..., sigma, m, m)``, with :math:`\\dot p = \\dot r^\\alpha K_\\alpha(r)\\,p + \\dot r^T H\\dot r`."""
    model = _affine_model(system, parameters, basis)
    r = V.trailing_shape(np.asarray(r, dtype=float), "r", (model.sigma,))
    return _connection(model, r)


def _connection(model: ReducedNumeric, r: np.ndarray) -> np.ndarray:
    sigma, m = model.sigma, model.m
    batch = r.shape[:-1]
    out = np.empty(batch + (sigma, m, m))
    zero = np.zeros(batch + (m,))
    for a in range(sigma):
        e = np.zeros(batch + (sigma,))
        e[..., a] = 1.0
        base = model.pdot(r, e, zero)
        for j in range(m):
            p = zero.copy()
            p[..., j] = 1.0
            out[..., a, :, j] = model.pdot(r, e, p) - base
    return out


def momentum_curvature(
    system: Any, r: Any, *, parameters: Mapping[str, float] | None = None, basis: Any = None
) -> np.ndarray:
    """The curvature :math:`F_{\\alpha\\beta} = \\partial_\\alpha K_\\beta - \\partial_\\beta K_\\alpha` of the momentum
    equation's connection at shapes ``r`` ``(..., sigma)``, shape ``(..., sigma, sigma)``, for one momentum
    (:math:`m = 1`, where the holonomy of a loop bounding a surface :math:`\\Sigma` is :math:`\\exp\\iint_\\Sigma F`).
    Exact: differentiated symbolically from the reduction's :math:`K`."""
    model = _affine_model(system, parameters, basis)
    if model.m != 1:
        raise InputError(
            f"momentum_curvature is the abelian curvature of one momentum; {model.system.name} has m = {model.m} "
            "(use the holonomy of momentum_transport)."
        )
    red = model.reduction
    _, K, _ = red.momentum_coefficients
    shapes = list(red.r)
    kappa = [sp.Matrix(K[0])[a, 0] for a in range(model.sigma)]
    F = sp.Matrix(model.sigma, model.sigma, lambda a, b: sp.diff(kappa[b], shapes[a]) - sp.diff(kappa[a], shapes[b]))
    f = red._compile(model.parameters, {"F": F}, shapes)["F"]
    r = V.trailing_shape(np.asarray(r, dtype=float), "r", (model.sigma,))
    return np.asarray(f(r), dtype=float)


@dataclass(frozen=True)
class MomentumTransport(ShowsItselfAsHTML):
    """The momentum equation integrated along a shape path as the affine map :math:`p(t) = \\Phi(t)p_0 + b(t)`.

    Attributes
    ----------
    model : ReducedNumeric
    loop : Gait
    t : (n,) times; r : (n, sigma) the shapes there.
    transport : (n, m, m)
        :math:`\\Phi(t)`, the parallel transport of the connection :math:`K_\\alpha dr^\\alpha` (geometric).
    forcing : (n, m)
        :math:`b(t)`, the momentum built from rest by the forcing :math:`\\dot r^T H\\dot r` (depends on the timing).
    nfev : evaluations of the momentum equation.
    """

    model: ReducedNumeric
    loop: Gait
    t: np.ndarray
    r: np.ndarray
    transport: np.ndarray
    forcing: np.ndarray
    nfev: int

    def _html_data(self) -> dict[str, Any]:
        return {
            "system": self.model.system.name,
            "period": float(self.loop.T),
            "holonomy Phi(T)": self.holonomy.tolist(),
            "forcing b(T)": self.offset.tolist(),
            "momentum gained from 0": self.gained().tolist(),
            "evaluations": self.nfev,
        }

    @property
    def holonomy(self) -> np.ndarray:
        """:math:`\\Phi(T)`, ``(m, m)``: the holonomy of the connection around the loop."""
        return self.transport[-1]

    @property
    def offset(self) -> np.ndarray:
        """:math:`b(T)`, ``(m,)``."""
        return self.forcing[-1]

    def momentum(self, p0: Any = None) -> np.ndarray:
        """:math:`p(t) = \\Phi(t)p_0 + b(t)` at :attr:`t`, ``(n, m)`` (``p0`` default 0)."""
        p0 = self._p0(p0)
        return np.einsum("nij,j->ni", self.transport, p0) + self.forcing

    def gained(self, p0: Any = None) -> np.ndarray:
        """The momentum gained over the path, :math:`\\Phi(T)p_0 + b(T) - p_0`, ``(m,)``."""
        p0 = self._p0(p0)
        return self.holonomy @ p0 + self.offset - p0

    def _p0(self, p0: Any) -> np.ndarray:
        m = self.model.m
        if p0 is None:
            return np.zeros(m)
        p0 = V.finite(np.atleast_1d(p0), "p0").reshape(-1)
        if p0.size != m:
            raise ShapeError(f"Expected `p0` with {m} component(s), got {p0.size}.")
        return p0


def momentum_transport(
    system: Any,
    loop: Any,
    *,
    period: float | None = None,
    parameters: Mapping[str, float] | None = None,
    basis: Any = None,
    samples: int = 201,
    rtol: float = 1e-12,
    atol: float = 1e-12,
) -> MomentumTransport:
    """The momentum equation (1.2) of ``system`` along the shape path ``loop`` as transport plus forcing.

    Parameters
    ----------
    system : NonholonomicSystem
        Its momentum equation must be affine in :math:`p` (:math:`D = 0`); :class:`~geomech.errors.InputError`
        otherwise, naming the alternative.
    loop : Gait or mapping
        The shape path over one period, as for :func:`~geomech.analysis.analyse_gait` (a closed loop, or formulas in
        ``t`` for every shape variable with ``period``).
    samples : int
        Output times over the period.

    Returns
    -------
    MomentumTransport
        :math:`\\Phi(t)` and :math:`b(t)` (DOP853 on the :math:`m^2 + m` linear equations, tolerances ``rtol``,
        ``atol``).
    """
    from scipy.integrate import solve_ivp

    model = _affine_model(system, parameters, basis)
    s = model.system
    loop = gait_loop(s, loop, period, parameters=parameters)
    bind_loop(model, loop)
    check_regular(model, loop)
    samples = int(samples)
    if samples < 2:
        raise InputError(f"Expected `samples` >= 2, got {samples}.")
    m = model.m
    t_eval = np.linspace(0.0, loop.T, samples)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        r, rd = loop.r(t), loop.rdot(t)
        L = np.einsum("a,aij->ij", rd, _connection(model, r))
        h = model.pdot(r, rd, np.zeros(m))
        Phi, b = y[: m * m].reshape(m, m), y[m * m :]
        return np.concatenate([(L @ Phi).ravel(), L @ b + h])

    y0 = np.concatenate([np.eye(m).ravel(), np.zeros(m)])
    sol = solve_ivp(rhs, (0.0, loop.T), y0, method="DOP853", rtol=rtol, atol=atol, t_eval=t_eval)
    if sol.status != 0 or not np.all(np.isfinite(sol.y)):
        raise NumericalError(
            f"The momentum transport of {s.name} along the shape path failed at t = {sol.t[-1]:.6g}: {sol.message}"
        )
    Y = sol.y.T
    return MomentumTransport(
        model, loop, t_eval, loop.r(t_eval), Y[:, : m * m].reshape(-1, m, m), Y[:, m * m :], int(sol.nfev)
    )
