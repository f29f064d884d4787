"""Helpers for the closed-loop constructions: time-limited sympy calls, definite integrals from 0 with a
numeric check, and vectorised Gauss-Legendre quadrature from 0 for when sympy finds no antiderivative."""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ConvergenceError, NumericalError

__all__ = ["time_limit", "SympyTimeout", "integral_from_zero", "quadrature_from_zero", "ray_quadrature"]

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(16)


class SympyTimeout(Exception):
    """A sympy call took longer than its budget."""


@contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`SympyTimeout` in the block after ``seconds`` (main thread on POSIX, with no other
    real-time timer running; elsewhere the block runs unbounded, since a thread cannot be interrupted safely)."""
    # Only where nobody else uses the real-time timer: a caller's own alarm is never overridden.
    usable = (
        seconds is not None
        and hasattr(signal, "setitimer")
        and threading.current_thread() is threading.main_thread()
        and signal.getitimer(signal.ITIMER_REAL)[0] == 0.0
    )
    if not usable:
        yield
        return

    def _raise(signum: int, frame: Any) -> None:
        raise SympyTimeout()

    previous = signal.signal(signal.SIGALRM, _raise)
    signal.setitimer(signal.ITIMER_REAL, float(seconds))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def integral_from_zero(integrand: sp.Expr, var: sp.Symbol, upper: sp.Expr, timeout: float | None) -> sp.Expr | None:
    """:math:`\\int_0^{upper} f(s)\\,ds` with ``f = integrand(var -> s)``, or None when sympy returns an
    unevaluated integral, an infinite value, or runs out of time."""
    s = sp.Dummy("s", real=True)
    f = integrand.xreplace({var: s})
    if not f.has(s):
        return sp.expand(f * upper)
    try:
        with time_limit(timeout):
            res = sp.integrate(f, (s, 0, upper))
    except SympyTimeout:
        return None
    except (NotImplementedError, ValueError, TypeError, AttributeError, RecursionError):
        return None
    if res.has(sp.Integral) or res.has(sp.oo, -sp.oo, sp.zoo, sp.nan) or res.has(sp.exp_polar):
        return None
    return res


def _panels(n_panels: int) -> tuple[np.ndarray, np.ndarray]:
    edges = np.linspace(0.0, 1.0, n_panels + 1)
    h = np.diff(edges)
    t = (edges[:-1, None] + h[:, None] * (_NODES + 1.0) / 2.0).ravel()
    w = (h[:, None] * _WEIGHTS / 2.0).ravel()
    return t, w


def _adaptive(values_at: Callable[[np.ndarray], np.ndarray], what: str, tol: float, max_panels: int) -> np.ndarray:
    """Composite 16-point Gauss-Legendre on [0, 1] in the path parameter, panels doubled until two
    successive estimates agree to ``tol`` (relative, with an absolute floor of ``tol``)."""
    prev = None
    n = 1
    while n <= max_panels:
        t, w = _panels(n)
        with np.errstate(all="ignore"):
            vals = values_at(t)
        if not np.all(np.isfinite(vals)):
            raise NumericalError(
                f"{what}: the integrand is not finite on the path from 0 (is phi defined on the whole segment "
                "from 0 to this momentum?)."
            )
        est = vals @ w
        if prev is not None and np.all(np.abs(est - prev) <= tol * np.maximum(1.0, np.abs(est))):
            return est
        prev = est
        n *= 2
    raise ConvergenceError(
        f"{what}: Gauss-Legendre quadrature did not converge with {max_panels} panels (relative change "
        f"{np.max(np.abs(est - prev) / np.maximum(1.0, np.abs(est))):.3g}); the integrand may be singular there."
    )


def quadrature_from_zero(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, *, what: str = "quadrature",
                         tol: float = 1e-14, max_panels: int = 256) -> np.ndarray:
    """:math:`\\int_0^x f(s)\\,ds` for an array ``x`` (vectorised ``f``), error about ``tol`` relative."""
    x = np.asarray(x, dtype=float)
    return _adaptive(lambda t: x[..., None] * f(x[..., None] * t), what, tol, max_panels)


def ray_quadrature(g: Callable[[np.ndarray], np.ndarray], m: np.ndarray, *, what: str = "quadrature",
                   tol: float = 1e-14, max_panels: int = 256) -> np.ndarray:
    """The potential :math:`\\psi(m) = \\int_0^1 g(t m)\\cdot m\\, dt` of a curl-free field ``g`` with
    :math:`\\psi(0) = 0` (``m`` of shape ``(..., 3)``)."""
    m = np.asarray(m, dtype=float)

    def values(t: np.ndarray) -> np.ndarray:
        pts = m[..., None, :] * t[:, None]
        return np.einsum("...ki,...i->...k", g(pts), m)

    return _adaptive(values, what, tol, max_panels)
