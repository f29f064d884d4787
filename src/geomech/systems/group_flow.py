r"""A motion on a Lie group given by its body velocity: the reconstruction equation

.. math::

    g^{-1}\dot g = \xi(t, g),

eq. (1.1) of the nonholonomic seed and eq. (2.2) of its section 2 once the shape path and the momentum are
known. :class:`GroupFlow` is the system :func:`~geomech.solve` integrates on the group with the
Runge-Kutta-Munthe-Kaas methods (``"rkmk"``, ``"rkmk4"``), staying on the group exactly, for any group of
:mod:`geomech.lie`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError, NumericalError
from ..symbolic.charts import GroupChart, group_chart

__all__ = ["GroupFlow"]


@dataclass(frozen=True, eq=False)
class GroupFlow:
    """The body velocity :math:`\\xi(t, g)` of a path on a Lie group.

    Parameters
    ----------
    group : a group of :mod:`geomech.lie` (with its coordinate names), its
        :class:`~geomech.symbolic.GroupChart`, or a group's name (``"SE2"``, ``"SO3"``, ``"S1"``, ...).
    xi : callable ``xi(t, g) -> (k,)``, the body velocity at time ``t`` and element ``g`` (an ``(N, N)``
        matrix), in the basis of the group's algebra (``group.algebra_names``).
    name : str
    """

    group: Any
    xi: Callable[[float, np.ndarray], Any]
    name: str = "group flow"

    def __post_init__(self) -> None:
        object.__setattr__(self, "group", group_chart(self.group))
        if not callable(self.xi):
            raise InputError(f"Expected `xi` to be a callable xi(t, g) -> body velocity, got {type(self.xi).__name__}.")

    @property
    def chart(self) -> GroupChart:
        return self.group

    @property
    def k(self) -> int:
        """Dimension of the group."""
        return int(self.group.dim)

    def velocity(self, t: float, g: np.ndarray) -> np.ndarray:
        """:math:`\\xi(t, g)` as a float array of shape ``(k,)``; :class:`NumericalError` where it is not finite."""
        v = np.asarray(self.xi(t, g), dtype=float)
        if v.size != self.k:
            raise InputError(
                f"Expected the body velocity of {self.name} to have {self.k} components "
                f"({', '.join(self.group.algebra_names)}), got shape {v.shape}."
            )
        v = v.reshape(self.k)
        if not np.all(np.isfinite(v)):
            raise NumericalError(f"the body velocity is not finite at t = {t:.6g}: {v.tolist()}")
        return v

    def __repr__(self) -> str:
        return f"GroupFlow({self.name!r}, group={self.group.name})"
