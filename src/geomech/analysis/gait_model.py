r"""A nonholonomic system's BKMM objects as numeric functions of the shape (:class:`GaitModel`), and gaits as
closed shape loops checked against them (:func:`gait_loop`; a locked inertia singular on the loop, even where
it only grazes the singular set, is refused before any integration).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import sympy as sp
from scipy.optimize import minimize_scalar

from .. import _validate as V
from ..errors import InputError, ShapeError, SingularityError
from ..symbolic.compile import compile_vector, stack_last
from ..systems.gait import Gait

__all__ = ["GaitModel", "gait_loop", "check_regular"]


class GaitModel:
    """The BKMM objects of a nonholonomic system as numeric functions of the shape.

    It also answers the questions :func:`~geomech.analysis.shape_loops.bind_loop` asks of a system (shape
    coordinates, which are angles, where the locked inertia is singular), so loops are checked the same
    way for holonomic and nonholonomic systems.

    Parameters
    ----------
    system : NonholonomicSystem
    parameters : mapping, optional
        Parameter values not stored in the system.
    basis : k x m matrix, optional
        The body-fixed basis of :math:`S_q` (default: the model's, else the null space); the scale of
        :math:`p` depends on it.
    """

    def __init__(self, system: Any, parameters: Mapping[str, float] | None = None, basis: Any = None):
        from ..reduction.nonholonomic import bkmm_reduction
        from ..systems.nonholonomic import NonholonomicSystem

        if not isinstance(system, NonholonomicSystem):
            raise InputError(f"Expected `system` to be a NonholonomicSystem, got {type(system).__name__}.")
        self.system = system
        self.parameters = dict(parameters or {})
        self.reduction = red = bkmm_reduction(system, basis)
        self.k, self.sigma, self.m = system.k, system.sigma, red.m
        pv = system.parameter_values(self.parameters)
        # Only eqs. (1.1)-(1.2) are needed along a prescribed gait: compiling them alone skips the derivation
        # of the shape equations (1.3), the costliest part of the reduction.
        r = list(system.shape)
        self._A = compile_vector(sp.Matrix(red.connection).subs(pv).tolist(), r)
        if self.m:
            self._E = compile_vector(sp.Matrix(red.basis).subs(pv).tolist(), r)
            self._I = compile_vector(sp.Matrix(red.locked_inertia).subs(pv).tolist(), r)
            self._pdot = compile_vector(list(sp.Matrix(red.momentum_rhs).subs(pv)), r + list(red.rdot) + list(red.p))
        # the group's twin: its chart, and (``.numeric``) the group with its closed forms where it has them
        self.group = system.group
        self._curvature: Callable[[np.ndarray], np.ndarray] | None = None

    # -- what bind_loop asks ------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.system.name

    @property
    def shape(self) -> tuple:
        return self.system.shape

    @property
    def shape_angles(self) -> tuple[int, ...]:
        return self.system.shape_angles

    def check_locked_inertia(self, r: Any) -> np.ndarray:
        """The locked inertia :math:`\\mathbb I(r)` at the points ``r`` ``(n, sigma)``, or
        :class:`SingularityError` where it is singular (the reconstruction needs :math:`\\mathbb I^{-1}`)."""
        I = self.locked_inertia(np.atleast_2d(r))
        if self.m == 0:
            return I
        V.positive_definite_along(
            I,
            r,
            f"locked inertia of {self.name}",
            "I^-1 p in the reconstruction g^-1 g' = -A r' + I^-1 p is undefined there; keep the gait away from it",
            rtol=1e-10,
            global_scale=True,
        )
        return I

    # -- numeric objects ---------------------------------------------------------------------------
    def connection(self, r: Any) -> np.ndarray:
        """:math:`\\mathcal A^{nh}(r)`, shape ``(..., k, sigma)``."""
        r = np.asarray(r, dtype=float)
        if self.sigma == 0:
            return np.zeros(r.shape[:-1] + (self.k, 0))
        return self._A(r)

    def basis(self, r: Any) -> np.ndarray:
        """:math:`e(r)`, shape ``(..., k, m)``."""
        r = np.asarray(r, dtype=float)
        return self._E(r) if self.m else np.zeros(r.shape[:-1] + (self.k, 0))

    def locked_inertia(self, r: Any) -> np.ndarray:
        """:math:`\\mathbb I(r)`, shape ``(..., m, m)``."""
        r = np.asarray(r, dtype=float)
        return self._I(r) if self.m else np.zeros(r.shape[:-1] + (0, 0))

    def curvature(self, r: Any) -> np.ndarray:
        """:math:`B^a_{\\alpha\\beta}(r)` (BKMM), shape ``(..., k, sigma, sigma)``."""
        if self._curvature is None:
            pv = self.system.parameter_values(self.parameters)
            B = [sp.Matrix(Ba).subs(pv).tolist() for Ba in self.reduction.curvature]
            self._curvature = compile_vector(B, list(self.system.shape))
        return self._curvature(np.asarray(r, dtype=float))

    def xi_connection(self, r: Any, rdot: Any) -> np.ndarray:
        """:math:`-\\mathcal A^{nh}(r)\\dot r`, shape ``(..., k)``."""
        return -np.einsum("...aj,...j->...a", self.connection(r), np.asarray(rdot, dtype=float))

    def xi_momentum(self, r: Any, p: Any) -> np.ndarray:
        """:math:`e(r)\\,\\mathbb I^{-1}(r)\\,p`, shape ``(..., k)``."""
        r = np.asarray(r, dtype=float)
        if self.m == 0:
            return np.zeros(r.shape[:-1] + (self.k,))
        Om = np.linalg.solve(self.locked_inertia(r), np.asarray(p, dtype=float)[..., None])[..., 0]
        return np.einsum("...ai,...i->...a", self.basis(r), Om)

    def pdot(self, r: Any, rdot: Any, p: Any) -> np.ndarray:
        """Right-hand side of the momentum equation (1.2)."""
        if not self.m:
            return np.zeros(np.shape(r)[:-1] + (0,))
        return self._pdot(stack_last(r, rdot, p))

    def element(self, coordinates: Any) -> np.ndarray:
        """The group element (a matrix) at the system's group coordinates ``(..., k)``."""
        return self.group.from_coordinates(np.asarray(coordinates, dtype=float))

    @property
    def exponential_coordinates(self) -> bool:
        """Whether displacements are given in exponential coordinates (the log) rather than in the chart: when
        the chart is singular at the identity (3-1-3 Euler angles of SO(3)), where displacements start."""
        return not self.group.regular_at_identity


# ---------------------------------------------------------------------------------------------------
# Loops
# ---------------------------------------------------------------------------------------------------
def gait_loop(
    system: Any, shapes: Any, period: float | None = None, *, parameters: Mapping[str, float] | None = None
) -> Gait:
    """A :class:`~geomech.systems.Gait` in the shape space of ``system``.

    ``shapes`` maps every shape variable to a formula in ``t`` (and ``T``, the period), e.g.
    ``{"psi": "sin(2*pi*t/T)", "phi": "0.4*sin(2*pi*t/T)"}``; a Gait is returned as it is (with its
    coordinate names checked when it has them). Unknown or missing shape variables raise :class:`InputError`.
    """
    names = [s.name for s in system.shape]
    if isinstance(shapes, Gait):
        _ = shapes.T  # refuses a gait without a period
        if shapes.names is not None and list(shapes.names) != names:
            raise ShapeError(
                f"Expected the shape loop's coordinates to be ({', '.join(names)}) for {system.name}, "
                f"got ({', '.join(shapes.names)})."
            )
        return shapes
    if not isinstance(shapes, Mapping):
        raise InputError(
            f"Expected `shapes` to be a mapping shape variable -> formula in t, or a Gait, got {type(shapes).__name__}."
        )
    unknown = [str(n) for n in shapes if str(n) not in names]
    if unknown:
        raise InputError(
            f"The gait names {unknown}, which are not shape variables of {system.name} "
            f"({', '.join(names) or 'no shape variables'})."
        )
    missing = [n for n in names if n not in {str(k) for k in shapes}]
    if missing:
        raise ShapeError(
            f"Expected a formula for each of the {len(names)} shape variables ({', '.join(names)}) of "
            f"{system.name}; missing {missing}: a gait prescribes the whole shape."
        )
    T = V.positive_scalar(period, "period")
    values = {"T": T, **dict(parameters or {})}
    by_name = {str(k): v for k, v in shapes.items()}
    return Gait.from_expressions({n: by_name[n] for n in names}, T, parameters=values)


def check_regular(model: GaitModel, loop: Gait, n: int = 1024) -> None:
    """Refuse a loop that passes through (or between samples touches) a singular locked inertia.

    The smallest eigenvalue is sampled densely and each local minimum refined by Brent's method: a loop
    that only grazes the singular set (the snakeboard's :math:`\\phi = \\pm\\pi/2`, where
    :math:`\\mathbb I = 4mr^2\\cos^2\\phi` touches 0 without changing sign) is caught too.
    """
    if model.m == 0:
        return
    T = loop.T

    def lam(t: Any) -> np.ndarray:
        I = model.locked_inertia(loop.r(np.atleast_1d(t)))
        return np.linalg.eigvalsh(0.5 * (I + np.swapaxes(I, -1, -2))).min(-1)

    t = np.linspace(0.0, T, n + 1)
    vals = lam(t)
    if not np.all(np.isfinite(vals)):
        i = int(np.argmax(~np.isfinite(vals)))
        raise SingularityError(
            f"The locked inertia of {model.name} is not finite at r = "
            f"{np.round(loop.r(t[i]), 6).tolist()} (t = {t[i]:.6g}) on the gait."
        )
    I_all = model.locked_inertia(loop.r(t))
    scale = max(float(np.abs(np.linalg.eigvalsh(0.5 * (I_all + np.swapaxes(I_all, -1, -2)))).max()), 1e-300)
    worst, t_worst = float(vals.min()), float(t[int(np.argmin(vals))])
    for i in range(1, n):
        # strict on one side at least: a constant stretch (a frozen shape) has nothing to refine
        if vals[i] <= min(vals[i - 1], vals[i + 1]) and vals[i] < max(vals[i - 1], vals[i + 1]):
            res = minimize_scalar(
                lambda s: float(lam(s)[0]),
                bounds=(t[i - 1], t[i + 1]),
                method="bounded",
                options={"xatol": 1e-13 * max(T, 1.0)},
            )
            if res.fun < worst:
                worst, t_worst = float(res.fun), float(res.x)
    if worst <= 1e-10 * scale:
        raise SingularityError(
            f"The locked inertia of {model.name} is singular on the gait at t = {t_worst:.6g}, r = "
            f"{np.round(loop.r(t_worst), 6).tolist()} (smallest eigenvalue {worst:.3g}, largest on the loop "
            f"{scale:.3g}): I^-1 p is undefined there; keep the gait away from it."
        )
    A = model.connection(loop.r(t))
    if not np.all(np.isfinite(A)):
        i = int(np.argmax(~np.all(np.isfinite(A), axis=(-2, -1))))
        raise SingularityError(
            f"The nonholonomic connection of {model.name} is not finite at r = "
            f"{np.round(loop.r(t[i]), 6).tolist()} on the gait."
        )
