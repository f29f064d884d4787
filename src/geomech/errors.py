"""Exception hierarchy of geomech.

Every error geomech raises on purpose derives from :class:`GeomechError`, so a caller (and the command
line, which turns these into one line on stderr and exit status 2) can catch them all at once. The
specific classes also derive from the matching built-in, so ``except ValueError`` keeps working.
"""

from __future__ import annotations

__all__ = [
    "GeomechError",
    "InputError",
    "ShapeError",
    "SymbolicError",
    "NumericalError",
    "SingularityError",
    "ConvergenceError",
]


class GeomechError(Exception):
    """Base class of every error raised on purpose by geomech."""


class InputError(GeomechError, ValueError):
    """An argument has the wrong value: not finite, not positive, outside a domain, inconsistent."""


class ShapeError(InputError):
    """An array argument has the wrong shape."""


class SymbolicError(InputError):
    """A symbolic construction was asked of something that has no formula, or of a bad formula."""


class NumericalError(GeomechError, RuntimeError):
    """A numerical procedure failed; the message says where (time, step, state) and why."""


class SingularityError(NumericalError):
    """A chart or a formula was evaluated at (or too near) one of its singular points.

    Raised, for instance, for Euler angles at gimbal lock when the caller asked to be told, or for a
    Serret-Andoyer chart evaluated at its poles ``L = +-G``.
    """


class ConvergenceError(NumericalError):
    """An iteration (Newton, a root bracket, an adaptive quadrature) did not converge."""
