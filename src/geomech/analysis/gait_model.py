r"""Gaits as closed shape loops of a system (:func:`gait_loop`), checked against its reduction's numeric twin
(:class:`~geomech.reduction.ReducedNumeric`, :func:`check_regular`: a locked inertia singular on the loop, even
where it only grazes the singular set, is refused before any integration).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError, ShapeError, SingularityError
from ..reduction.reduced_numeric import ReducedNumeric
from ..systems.gait import Gait

__all__ = ["gait_loop", "check_regular"]


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


def check_regular(model: ReducedNumeric, loop: Gait, n: int = 1024) -> None:
    """Refuse a loop that passes through (or between samples touches) a singular locked inertia.

    The smallest eigenvalue is sampled densely and each local minimum refined by Brent's method: a loop
    that only grazes the singular set (the snakeboard's :math:`\\phi = \\pm\\pi/2`, where
    :math:`\\mathbb I = 4mr^2\\cos^2\\phi` touches 0 without changing sign) is caught too.
    """
    from scipy.optimize import minimize_scalar

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
