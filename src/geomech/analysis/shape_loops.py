r"""Closed shape loops :math:`r(t)` of period :math:`T`, the input of every phase and gait computation.

A :class:`ShapeLoop` is given by formulas in ``t`` (and ``T``), a truncated Fourier series, an ellipse, or
Python callables; :func:`bind_loop` checks it against a system's shape space (dimension, names, closed up to
whole turns of its angle coordinates, a regular locked inertia along it), and :func:`periodic_integral`
integrates a smooth periodic integrand over it to round-off (the trapezoidal rule, spectrally accurate).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import ConvergenceError, InputError, ShapeError
from ..symbolic.compile import compile_vector
from ..symbolic.formula import to_expression

__all__ = ["ShapeLoop", "bind_loop", "periodic_integral", "T_SYMBOL"]

#: The time variable of the loop formulas.
T_SYMBOL = sp.Symbol("t", real=True)


@dataclass(frozen=True, eq=False)
class ShapeLoop:
    """A closed path :math:`r(t)`, :math:`0 \\le t \\le T`, in shape space, with its first two derivatives.

    Build it with :meth:`from_expressions` (formulas in ``t``, derivatives exact), :meth:`from_fourier`
    or :meth:`ellipse`. ``r(t)``, ``rdot(t)``, ``rddot(t)`` take a scalar (returning ``(n,)``) or an
    array of times (returning ``(m, n)``). Angles may wind: ``r(T) - r(0)`` is then a multiple of
    :math:`2\\pi` in those coordinates, which :func:`bind_loop` checks against the system.
    """

    period: float
    dim: int
    _funcs: tuple[Callable, Callable, Callable] = field(repr=False)
    names: tuple[str, ...] | None = None
    expressions: tuple[sp.Expr, ...] | None = None

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

    @classmethod
    def from_expressions(
        cls,
        expressions: Any,
        period: float,
        *,
        names: Sequence[str] | None = None,
        parameters: Mapping[str, float] | None = None,
    ) -> ShapeLoop:
        """Each shape coordinate as a formula in ``t`` (strings or sympy), e.g.
        ``["0.5*sin(2*pi*t)", "0.5*cos(2*pi*t)"]`` or ``{"alpha1": "...", "alpha2": "..."}``."""
        T = V.positive_scalar(period, "period")
        if isinstance(expressions, Mapping):
            names = tuple(str(k) for k in expressions)
            expressions = list(expressions.values())
        exprs = []
        for i, e in enumerate(expressions):
            label = f"expressions[{names[i]!r}]" if names is not None and i < len(names) else f"expressions[{i}]"
            ex = to_expression(e, label, {"t": T_SYMBOL})
            sub = {s: float(parameters[s.name]) for s in ex.free_symbols if parameters and s.name in parameters}
            ex = ex.subs(sub)
            extra = sorted(str(s) for s in ex.free_symbols if s != T_SYMBOL)
            if extra:
                raise InputError(
                    f"Shape-loop expression {e!r} has symbols {extra} other than t; give their "
                    "values in `parameters` or write numbers."
                )
            exprs.append(ex)
        if not exprs:
            raise ShapeError("Expected at least one shape-loop expression.")
        derivs = [[sp.diff(ex, T_SYMBOL, k) for ex in exprs] for k in range(3)]
        funcs = (_time_function(derivs[0]), _time_function(derivs[1]), _time_function(derivs[2]))
        return cls(T, len(exprs), funcs, tuple(names) if names is not None else None, tuple(exprs))

    @classmethod
    def from_callable(
        cls,
        r: Callable,
        rdot: Callable,
        period: float,
        *,
        rddot: Callable | None = None,
        names: Sequence[str] | None = None,
    ) -> ShapeLoop:
        """A loop from functions of time (e.g. a closed form, or a periodic orbit's shape from a
        simulation). Each takes a scalar ``t`` and returns ``(n,)``; ``rddot`` is needed only to drive a
        full simulation (:meth:`HolonomicSystem.simulate`)."""
        T = V.positive_scalar(period, "period")
        n = np.atleast_1d(np.asarray(r(0.0), dtype=float)).size

        def vec(f: Callable | None, what: str) -> Callable:
            def g(t: np.ndarray) -> np.ndarray:
                if f is None:
                    raise InputError(f"This ShapeLoop was built without `{what}`; pass it to from_callable.")
                return np.stack([np.atleast_1d(np.asarray(f(float(x)), dtype=float)) for x in t]).reshape(t.size, n)

            return g

        return cls(
            T, n, (vec(r, "r"), vec(rdot, "rdot"), vec(rddot, "rddot")), tuple(names) if names is not None else None
        )

    @classmethod
    def from_fourier(
        cls, mean: Any, cos_coefficients: Any, sin_coefficients: Any, period: float, *, winding: Any = None
    ) -> ShapeLoop:
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

        return cls(T, n, (make(0), make(1), make(2)))

    @classmethod
    def ellipse(
        cls, center: Any, radii: Any, period: float, *, tilt: float = 0.0, phase: float = 0.0, clockwise: bool = False
    ) -> ShapeLoop:
        """An ellipse in a 2-D shape space, counterclockwise unless ``clockwise``."""
        c = V.exact_shape(center, "center", (2,))
        ra = V.exact_shape(radii, "radii", (2,))
        s = -1.0 if clockwise else 1.0
        R = np.array([[np.cos(tilt), -np.sin(tilt)], [np.sin(tilt), np.cos(tilt)]])
        # r = c + R (ra0 cos(wt + phase), s ra1 sin(wt + phase)), expanded in cos(wt) and sin(wt)
        a = np.array([R @ np.array([ra[0] * np.cos(phase), s * ra[1] * np.sin(phase)])])
        b = np.array([R @ np.array([-ra[0] * np.sin(phase), s * ra[1] * np.cos(phase)])])
        return cls.from_fourier(c, a, b, period)


def _time_function(exprs: list) -> Callable:
    f = compile_vector(exprs, [T_SYMBOL])

    def g(t: np.ndarray) -> np.ndarray:
        return f(np.asarray(t, dtype=float)[..., None])

    return g


def bind_loop(system: Any, loop: Any, *, atol: float = 1e-9) -> np.ndarray:
    """Check that ``loop`` lives in ``system``'s shape space and is closed; return the winding integers.

    Raises :class:`ShapeError` for a wrong dimension, :class:`InputError` for an open loop (angle
    coordinates may wind by whole turns) and :class:`SingularityError` where the locked inertia is singular.
    """
    if not isinstance(loop, ShapeLoop):
        raise InputError(f"Expected `loop` to be a ShapeLoop, got {type(loop).__name__}.")
    names = [str(s) for s in system.shape_coordinates]
    if loop.dim != system.shape_dim:
        raise ShapeError(
            f"Expected a shape loop in the {system.shape_dim}-D shape space ({', '.join(names)}) of "
            f"{system.name}, got one with {loop.dim} coordinate(s)."
        )
    if loop.names is not None and list(loop.names) != names:
        raise ShapeError(
            f"Expected the shape loop's coordinates to be ({', '.join(names)}), got ({', '.join(loop.names)})."
        )
    d = loop.r(loop.period) - loop.r(0.0)
    t_check = np.linspace(0.0, loop.period, 257)
    with np.errstate(all="ignore"):
        samples = np.asarray(loop.r(t_check), dtype=float)
        rates = np.asarray(loop.rdot(t_check), dtype=float)
    bad = ~(
        np.all(np.isfinite(samples.reshape(t_check.size, -1)), axis=1)
        & np.all(np.isfinite(rates.reshape(t_check.size, -1)), axis=1)
    )
    if np.any(bad) or not np.all(np.isfinite(d)):
        t_bad = float(t_check[np.argmax(bad)]) if np.any(bad) else loop.period
        raise InputError(
            f"Expected a shape loop with finite values and rates, got a non-finite one at t = {t_bad:.6g} "
            f"(of T = {loop.period:g}); a loop must be a smooth closed curve."
        )
    scale = max(1.0, float(np.abs(samples).max()))
    turns = np.zeros(loop.dim)
    for i in range(loop.dim):
        if i in system.angle_shapes:
            turns[i] = np.round(d[i] / (2 * np.pi))
    gap = d - 2 * np.pi * turns
    if np.any(np.abs(gap) > atol * scale):
        raise InputError(
            f"Expected a closed shape loop: r(T) - r(0) = {np.round(d, 9).tolist()} for ({', '.join(names)}) "
            f"with T = {loop.period:g}; make the loop return to its start"
            + (" (angle coordinates may wind by whole turns)." if system.angle_shapes else ".")
        )
    system.check_locked_inertia(loop.r(np.linspace(0.0, loop.period, 65)))
    return turns.astype(int)


def periodic_integral(
    f: Callable[[np.ndarray], np.ndarray],
    T: float,
    *,
    rtol: float = 1e-13,
    n0: int = 64,
    nmax: int = 2**17,
    what: str = "integral",
) -> np.ndarray:
    """:math:`\\int_0^T f`, ``f`` smooth and T-periodic, by the trapezoidal rule with doubling (spectrally
    accurate for smooth periodic integrands); falls back to adaptive Gauss-Kronrod for a kinked loop."""
    n = n0
    t = np.arange(n) * (T / n)
    prev = f(t).sum(0) * (T / n)
    while n < nmax:
        mid = (np.arange(n) + 0.5) * (T / n)
        cur = 0.5 * prev + f(mid).sum(0) * (T / (2 * n))
        n *= 2
        scale = max(np.abs(cur).max(), np.abs(f(t[:1])).max() * T, 1e-300)
        if np.abs(cur - prev).max() <= rtol * scale and n >= 2 * n0:
            return cur
        prev = cur
        t = np.arange(n) * (T / n)
        if n >= 4096:
            break
    from scipy.integrate import quad_vec

    val, err = quad_vec(lambda s: f(np.array([s]))[0], 0.0, T, epsabs=0.0, epsrel=max(rtol, 1e-13), limit=4000)
    scale = max(np.abs(val).max(), 1e-300)
    if np.max(err) > 1e-8 * scale:
        raise ConvergenceError(
            f"The quadrature of the {what} over the loop did not converge (error estimate "
            f"{np.max(err):.3g}); the loop is probably not smooth enough."
        )
    return val
