r"""Paths on a Lie group for the analyses: the reconstruction :math:`g^{-1}\dot g = \xi(t, g)` integrated by
:func:`~geomech.solve` on a :class:`~geomech.systems.GroupFlow` with a Runge-Kutta-Munthe-Kaas method
(staying on the group exactly, angles unwrapped), and :func:`decompose_displacement`, which integrates a sum of
body velocities and each term alone. Each path is a :class:`~geomech.Solution` of layout ``"group"``: ``g``
(the chart coordinates), ``element`` (the matrices), ``displacement()``, ``net_motion()``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError
from ..integrators import Kind, Solution, get_method, solve
from ..systems.group_flow import GroupFlow

__all__ = ["integrate_path", "decompose_displacement"]


def integrate_path(
    group: Any,
    xi: Callable[[float, np.ndarray], Any] | Sequence[Any],
    g0: Any,
    t_eval: Any,
    *,
    method: Any = "rkmk",
    rtol: float = 1e-12,
    atol: float = 1e-12,
    h: float | None = None,
    name: str = "reconstruction",
) -> Solution:
    """:math:`g^{-1}\\dot g = \\xi(t, g)` (``xi`` a callable or formulas, as :class:`~geomech.systems.GroupFlow`
    takes them: formulas run compiled) from ``g0`` (an element or its coordinates) at the times ``t_eval``
    (the first is the start), by ``method`` (``"rkmk"``: adaptive, with ``rtol``/``atol``; ``"rkmk4"``: the
    fixed step ``h``, the times on its grid): :func:`~geomech.solve` on a :class:`~geomech.systems.GroupFlow`."""
    t = V.finite(t_eval, "t_eval").ravel()
    if t.size < 2 or np.any(np.diff(t) == 0) or not (np.all(np.diff(t) > 0) or np.all(np.diff(t) < 0)):
        raise InputError(f"Expected `t_eval` strictly monotone with at least 2 times, got {t.size} time(s).")
    m = get_method(method)
    times: dict[str, Any] = {"h": h} if m.kind is Kind.FIXED_STEP else {"rtol": rtol, "atol": atol}
    return solve(GroupFlow(group, xi, name), m, t0=float(t[0]), t_final=float(t[-1]), saveat=t, g0=g0, **times)


def decompose_displacement(
    group: Any, terms: Mapping[str, Callable[[float, np.ndarray], Any]], g0: Any, t_eval: Any, **options: Any
) -> dict[str, Solution]:
    """Integrate the sum of the body-velocity ``terms`` and each term alone, from the same ``g0``.

    Returns ``{"total": ..., name: ...}``, each a :class:`~geomech.Solution` (``options`` as in
    :func:`integrate_path`). This is the split of a net displacement by contribution (e.g. the connection term
    :math:`-A\\dot r` and the momentum term :math:`\\mathbb I^{-1}p` of eq. 1.1 or 2.2); on a non-abelian group,
    or when ``p`` depends on ``g``, the parts do not add up to the total.
    """
    names = list(terms)

    def total(t: float, g: np.ndarray) -> np.ndarray:
        return np.sum([np.asarray(terms[n](t, g), dtype=float) for n in names], axis=0)

    out = {"total": integrate_path(group, total, g0, t_eval, name="total", **options)}
    for n in names:
        out[n] = integrate_path(group, terms[n], g0, t_eval, name=n, **options)
    return out
