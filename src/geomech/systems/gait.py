r"""Prescribed shape motions :math:`r(t)`, with their first two derivatives: the one type for a gait.

A :class:`Gait` drives the shapes of a system on Q = G x S in a simulation
(``geomech.solve(system, method, shapes=gait)``) and, when it has a period and closes, is the loop of every
phase and gait computation (:mod:`geomech.analysis`). It is given by formulas in ``t`` (derivatives exact; a
period ``T`` may appear in them), a truncated Fourier series, an ellipse, or Python callables.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from .._storage import remember
from ..errors import InputError, ShapeError
from ..symbolic.compile import compile_vector
from ..symbolic.formula import to_expression

__all__ = ["Gait", "T_SYMBOL"]

#: The time variable of the gait formulas.
T_SYMBOL = sp.Symbol("t", real=True)


@dataclass(frozen=True, eq=False)
class Gait:
    """Prescribed shapes :math:`r(t)` with :math:`\\dot r(t)` and :math:`\\ddot r(t)`, and a period where it has one.

    Build it with :meth:`from_expressions` (formulas in ``t``, derivatives exact), :meth:`from_callable`,
    :meth:`from_fourier` or :meth:`ellipse`. ``r(t)``, ``rdot(t)``, ``rddot(t)`` take a scalar (returning
    ``(n,)``) or an array of times (returning ``(m, n)``); ``gait(t)`` returns the three at one time.
    ``names`` are the shape variables it prescribes (None: all of a system's shapes, in order). A periodic
    gait (``period`` given) may wind: ``r(T) - r(0)`` is then a multiple of :math:`2\\pi` in its angle
    coordinates, which :func:`geomech.analysis.bind_loop` checks against the system.
    """

    period: float | None
    dim: int
    _funcs: tuple[Callable, Callable, Callable] = field(repr=False)
    names: tuple[str, ...] | None = None
    expressions: tuple[sp.Expr, ...] | None = None
    _all: Callable | None = field(default=None, repr=False)
    #: a gait of formulas at the last few times asked (every run from t0 asks for its start)
    _memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def _eval(self, i: int, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = self._funcs[i](np.atleast_1d(t))
        return out[0] if t.ndim == 0 else out

    def r(self, t: Any) -> np.ndarray:
        return self._eval(0, t)

    def rdot(self, t: Any) -> np.ndarray:
        return self._eval(1, t)

    def rddot(self, t: Any) -> np.ndarray:
        return self._eval(2, t)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(r, rdot, rddot)`` at the time ``t`` (for a gait of formulas, read-only arrays)."""
        t = float(t)
        if self._all is None:
            return self.r(t), self.rdot(t), self.rddot(t)
        known = self._memo.get(t)
        if known is None:
            v = self._all(t)
            v.setflags(write=False)
            known = (v[0], v[1], v[2])
            remember(self._memo, t, known, 16)
        return known

    @property
    def periodic(self) -> bool:
        return self.period is not None

    @property
    def T(self) -> float:
        """The period, for a gait used as a closed loop; an :class:`InputError` when it has none."""
        if self.period is None:
            raise InputError(f"Expected a closed loop: {self!r} has no period; build it with `period=`.")
        return self.period

    def __repr__(self) -> str:
        what = ", ".join(self.names) if self.names else f"{self.dim} shape(s)"
        period = f", period {self.period:g}" if self.period is not None else ""
        return f"Gait({what}{period})"

    # -- constructors -------------------------------------------------------------------------------
    @classmethod
    def from_expressions(
        cls,
        expressions: Any,
        period: float | None = None,
        *,
        names: Sequence[str] | None = None,
        parameters: Mapping[str, float] | None = None,
    ) -> Gait:
        """Each prescribed shape as a formula in ``t`` (text or sympy), e.g. ``{"psi": "sin(2*pi*t)"}`` or
        ``["0.5*sin(2*pi*t/T)", "0.5*cos(2*pi*t/T)"]``; ``T`` stands for ``period`` when one is given, and
        ``parameters`` give the values of other symbols. An empty mapping (or None) prescribes nothing. The same
        formulas (text or sympy) give the same Gait, parsed and compiled once."""
        key = _formulas_key(expressions, period, names, parameters)
        if key is None:  # something unhashable (a list of parameters, say): parsed each time
            return cls._parse(expressions, period, names, parameters)
        gait = _GAITS.get((cls, key))
        if gait is None:
            gait = remember(_GAITS, (cls, key), cls._parse(expressions, period, names, parameters), 256)
        return gait

    @classmethod
    def _parse(cls, expressions: Any, period: Any, names: Any, parameters: Any) -> Gait:
        T = None if period is None else V.positive_scalar(period, "period")
        if expressions is None:
            expressions = {}
        if isinstance(expressions, Mapping):
            names = tuple(str(k) for k in expressions)
            expressions = list(expressions.values())
        elif isinstance(expressions, (str, sp.Expr)):
            raise InputError(
                "Expected the gait as a mapping {shape name: formula in t} or a sequence of formulas, "
                f"got the single formula {expressions!r}."
            )
        values = dict(parameters or {})
        if T is not None:
            values.setdefault("T", T)
        exprs = []
        for i, e in enumerate(expressions):
            label = f"shapes[{names[i]!r}]" if names is not None and i < len(names) else f"shapes[{i}]"
            ex = to_expression(e, label, {"t": T_SYMBOL})
            ex = ex.subs({s: float(values[s.name]) for s in ex.free_symbols if s.name in values})
            extra = sorted(str(s) for s in ex.free_symbols if s != T_SYMBOL)
            if extra:
                hint = "; `T` is the period: give `period`" if "T" in extra and T is None else ""
                raise InputError(
                    f"Expected the gait of {label} to be a formula in t only, got symbols {extra} in {ex}{hint}; "
                    "give their values in `parameters` or write numbers."
                )
            exprs.append(ex)
        if names is not None and len(names) != len(exprs):
            raise ShapeError(f"Expected {len(exprs)} names for the {len(exprs)} formulas, got {list(names)}.")
        derivs = [[sp.diff(ex, T_SYMBOL, k) for ex in exprs] for k in range(3)]
        for i, ex in enumerate(derivs[2]):
            if ex.has(sp.DiracDelta, sp.Derivative):
                label = f"shapes[{names[i]!r}]" if names is not None and i < len(names) else f"shapes[{i}]"
                raise InputError(
                    f"The gait of {label}, {exprs[i]}, has no second derivative in t where it has a corner (abs, "
                    "sign, min, max): the equations of motion read the shapes' accelerations; write a smooth formula."
                )
        funcs = (_time_function(derivs[0]), _time_function(derivs[1]), _time_function(derivs[2]))
        together = _time_function(derivs[0] + derivs[1] + derivs[2]) if exprs else None
        n = len(exprs)

        def at(t: float) -> np.ndarray:
            if together is None:
                return np.zeros((3, 0))
            return together(np.array([t]))[0].reshape(3, n)

        return cls(T, n, funcs, tuple(names) if names is not None else None, tuple(exprs), at)

    @classmethod
    def from_callable(
        cls,
        r: Callable,
        rdot: Callable,
        period: float | None = None,
        *,
        rddot: Callable | None = None,
        names: Sequence[str] | None = None,
    ) -> Gait:
        """A gait from functions of time (a closed form, or a periodic orbit's shape from a simulation). Each
        takes a scalar ``t`` and returns ``(n,)``; ``rddot`` is needed only to drive a simulation."""
        T = None if period is None else V.positive_scalar(period, "period")
        n = np.atleast_1d(np.asarray(r(0.0), dtype=float)).size

        def vec(f: Callable | None, what: str) -> Callable:
            def g(t: np.ndarray) -> np.ndarray:
                if f is None:
                    raise InputError(
                        f"This gait was built without `{what}`, which driving a simulation needs; pass it to "
                        "Gait.from_callable."
                    )
                return np.stack([np.atleast_1d(np.asarray(f(float(x)), dtype=float)) for x in t]).reshape(t.size, n)

            return g

        if names is not None and len(names) != n:
            raise ShapeError(f"Expected {n} names for a gait of {n} shape(s), got {list(names)}.")
        return cls(T, n, (vec(r, "r"), vec(rdot, "rdot"), vec(rddot, "rddot")), tuple(names) if names else None)

    @classmethod
    def from_fourier(
        cls,
        mean: Any,
        cos_coefficients: Any,
        sin_coefficients: Any,
        period: float,
        *,
        winding: Any = None,
        names: Sequence[str] | None = None,
    ) -> Gait:
        """:math:`r(t) = \\bar r + 2\\pi w t/T + \\sum_{j\\ge1} a_j\\cos(2\\pi jt/T) + b_j\\sin(2\\pi jt/T)`,
        coefficients of shape ``(harmonics, n)``, ``winding`` the integers :math:`w` (angles only)."""
        T = V.positive_scalar(period, "period")
        mean = V.finite(mean, "mean").reshape(-1)
        a = np.atleast_2d(V.finite(cos_coefficients, "cos_coefficients"))
        b = np.atleast_2d(V.finite(sin_coefficients, "sin_coefficients"))
        n = mean.size
        if a.shape != b.shape or a.shape[1] != n:
            raise ShapeError(f"Expected cos and sin coefficients of shape (harmonics, {n}), got {a.shape}, {b.shape}.")
        w = np.zeros(n) if winding is None else np.asarray(winding, dtype=float).reshape(n)
        omega = 2 * np.pi / T * np.arange(1, a.shape[0] + 1)

        def make(order: int) -> Callable:
            def f(t: np.ndarray) -> np.ndarray:
                ph = np.outer(t, omega)
                c, s = np.cos(ph), np.sin(ph)
                # d^k/dt^k of cos and sin cycle through (c, -s, -c, s) and (s, c, -s, -c) times omega^k
                cc, ss = [(c, s), (-s, c), (-c, -s)][order]
                out = (cc * omega**order) @ a + (ss * omega**order) @ b
                if order == 0:
                    out = out + mean + np.outer(t, 2 * np.pi * w / T)
                elif order == 1:
                    out = out + 2 * np.pi * w / T
                return out

            return f

        if names is not None and len(names) != n:
            raise ShapeError(f"Expected {n} names for a gait of {n} shape(s), got {list(names)}.")
        return cls(T, n, (make(0), make(1), make(2)), tuple(names) if names else None)

    @classmethod
    def ellipse(
        cls,
        center: Any,
        radii: Any,
        period: float,
        *,
        tilt: float = 0.0,
        phase: float = 0.0,
        clockwise: bool = False,
        names: Sequence[str] | None = None,
    ) -> Gait:
        """An ellipse in a 2-D shape space, counterclockwise unless ``clockwise``."""
        c = V.exact_shape(center, "center", (2,))
        ra = V.exact_shape(radii, "radii", (2,))
        s = -1.0 if clockwise else 1.0
        R = np.array([[np.cos(tilt), -np.sin(tilt)], [np.sin(tilt), np.cos(tilt)]])
        # r = c + R (ra0 cos(wt + phase), s ra1 sin(wt + phase)), expanded in cos(wt) and sin(wt)
        a = np.array([R @ np.array([ra[0] * np.cos(phase), s * ra[1] * np.sin(phase)])])
        b = np.array([R @ np.array([-ra[0] * np.sin(phase), s * ra[1] * np.cos(phase)])])
        return cls.from_fourier(c, a, b, period, names=names)


def _time_function(exprs: list) -> Callable:
    if not exprs:
        return lambda t: np.zeros((np.size(t), 0))
    f = compile_vector(exprs, [T_SYMBOL])

    def g(t: np.ndarray) -> np.ndarray:
        return f(np.asarray(t, dtype=float)[..., None])

    return g


_GAITS: dict[Any, Gait] = {}


def _formulas_key(expressions: Any, period: Any, names: Any, parameters: Any) -> tuple | None:
    """What :meth:`Gait.from_expressions` is given, as a key of its cache (None where it is not hashable)."""
    if isinstance(expressions, Mapping):
        expressions = tuple(expressions.items())
    elif isinstance(expressions, list):
        expressions = tuple(expressions)
    try:
        key = (
            expressions,
            period,
            None if names is None else tuple(names),
            None if parameters is None else tuple(sorted(parameters.items())),
        )
        hash(key)
    except (TypeError, AttributeError):
        return None
    return key
