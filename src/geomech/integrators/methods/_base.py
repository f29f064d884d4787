"""The method type: :class:`Method` (order, traits, the structure it needs), :class:`Structure`, and the error
raised when a method does not fit a system."""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ...errors import InputError


class Structure(str, enum.Enum):
    """The structure of system a method needs."""

    ODE = "any ODE"
    CANONICAL = "canonical"
    SEPARABLE_CANONICAL = "separable canonical"
    LIE_POISSON = "Lie-Poisson so(3)* (any left-invariant Hamiltonian)"
    LIE_POISSON_SPLIT = "Lie-Poisson so(3)* with split Hamiltonian"
    LIE_POISSON_QUADRATIC = "Lie-Poisson so(3)* with quadratic Hamiltonian (free rigid body)"
    LIE_GROUP = "Lie group SO(3) hyperregular Lagrangian"
    ONE_DOF = "canonical with one degree of freedom"
    LAGRANGIAN = "Lagrangian on G x S with velocity constraints (none: holonomic)"
    GROUP_FLOW = "a body velocity on a Lie group (the reconstruction equation g^-1 g' = xi(t, g))"


class Kind(str, enum.Enum):
    """How a method advances in time, which decides how :func:`~geomech.solve` is told the times.

    ``FIXED_STEP`` methods take a step ``h``; ``ADAPTIVE`` ones choose their steps to meet ``rtol`` and
    ``atol``; ``EXACT`` propagators do not step in time at all (the state at any time from a closed form or
    one period), so their cost does not grow with t. All three save the state at ``saveat``.
    """

    FIXED_STEP = "fixed step"
    ADAPTIVE = "adaptive"
    EXACT = "exact propagator"


class IncompatibleMethodError(InputError):
    """A method was asked to integrate a system that lacks the structure it needs."""


@dataclass(frozen=True)
class Method:
    """Base of every method (abstract). Subclasses set the class-level traits and ``kernel``."""

    structure: ClassVar[Structure]
    kind: ClassVar[Kind] = Kind.FIXED_STEP
    default_tolerances: ClassVar[tuple[float, float]] = (1e-6, 1e-8)
    """``(rtol, atol)`` of an adaptive method when :func:`~geomech.solve` is not given them."""
    explicit: ClassVar[bool | None] = False
    """Whether a step needs no solve; None for exact propagators, which take no steps."""
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
    def order(self) -> int | None:  # pragma: no cover - every concrete method overrides
        """The convergence order; None for an exact propagator (its accuracy is its ``tol``)."""
        raise NotImplementedError

    @property
    def key(self) -> str:
        """The method's name in :data:`REGISTRY`."""
        return type(self).__name__

    @property
    def summary(self) -> str:
        """What the method is, in one sentence: its docstring's first, joined and with the markup made plain
        (a method with several variants words each)."""
        doc = (type(self).__doc__ or "").strip().split("\n\n")[0]
        text = " ".join(line.strip() for line in doc.splitlines())
        text = re.sub(r":math:`([^`]*)`", r"`\1`", text).replace("``", "`")
        m = re.match(r"(.+?\.)(\s|$)", text)
        return (m.group(1) if m else text).rstrip(".")

    @property
    def implicit(self) -> bool | None:
        return None if self.explicit is None else not self.explicit

    def constants(self, problem: Any) -> np.ndarray:
        """Constants passed to the compiled loop (the ``P`` argument)."""
        return np.zeros(1)

    def describe(self) -> dict[str, Any]:
        """Traits as a JSON-ready dict (one row of :func:`methods_table`)."""
        return {
            "key": self.key,
            "method": repr(self),
            "kind": self.kind.value,
            "order": self.order,
            "variable_order": self.variable_order,
            "structure": self.structure.value,
            "explicit": self.explicit,
            "symplectic": self.symplectic,
            "symmetric": self.symmetric,
            "preserves_casimirs": self.preserves_casimirs,
            "summary": self.summary,
        }
