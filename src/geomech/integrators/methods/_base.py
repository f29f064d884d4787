"""The method type: :class:`Method` (order, traits, the structure it needs), :class:`Structure`, and the error
raised when a method does not fit a system."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ...errors import InputError


class Structure(str, enum.Enum):
    """The structure of system a method needs."""

    ODE = "any ODE"
    CANONICAL = "canonical"
    SEPARABLE_CANONICAL = "separable canonical"
    LIE_POISSON_SPLIT = "Lie-Poisson so(3)* with split Hamiltonian"
    LIE_POISSON_QUADRATIC = "Lie-Poisson so(3)* with quadratic Hamiltonian (free rigid body)"
    LIE_GROUP = "Lie group SO(3) hyperregular Lagrangian"
    ONE_DOF = "canonical with one degree of freedom"


class IncompatibleMethodError(InputError):
    """A method was asked to integrate a system that lacks the structure it needs."""


@dataclass(frozen=True)
class Method:
    """Base of every method (abstract). Subclasses set the class-level traits and ``kernel``."""

    structure: ClassVar[Structure]
    explicit: ClassVar[bool] = False
    symplectic: ClassVar[bool] = False
    symmetric: ClassVar[bool] = False
    preserves_casimirs: ClassVar[bool] = False
    needs_expression: ClassVar[bool] = False
    variable_order: ClassVar[bool] = False
    """True when the method changes its order as it goes; ``order`` is then the largest."""
    kernel: ClassVar[str | None] = None
    features: ClassVar[frozenset[str]] = frozenset({"rhs"})
    """Model functions the compiled loop calls."""

    @property
    def order(self) -> int:  # pragma: no cover - every concrete method overrides
        raise NotImplementedError

    @property
    def key(self) -> str:
        """The method's name in :data:`REGISTRY`."""
        return type(self).__name__

    @property
    def implicit(self) -> bool:
        return not self.explicit

    def constants(self, problem: Any) -> np.ndarray:
        """Constants passed to the compiled loop (the ``P`` argument)."""
        return np.zeros(1)

    def describe(self) -> dict[str, Any]:
        """Traits as a JSON-ready dict (one row of :func:`methods_table`)."""
        return {
            "key": self.key,
            "method": repr(self),
            "order": self.order,
            "variable_order": self.variable_order,
            "structure": self.structure.value,
            "explicit": self.explicit,
            "symplectic": self.symplectic,
            "symmetric": self.symmetric,
            "preserves_casimirs": self.preserves_casimirs,
            "summary": (type(self).__doc__ or "").strip().splitlines()[0],
        }
