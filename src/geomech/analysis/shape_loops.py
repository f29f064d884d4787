r"""Closed shape loops: a periodic :class:`~geomech.systems.Gait` of period :math:`T` is the input of every
phase and gait computation.

:func:`bind_loop` checks a gait against a system's shape space (a period, the dimension, the names, closed up
to whole turns of its angle coordinates, a regular locked inertia along it), and :func:`periodic_integral`
integrates a smooth periodic integrand over it to round-off (the trapezoidal rule, spectrally accurate).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import ConvergenceError, InputError, ShapeError
from ..systems.gait import Gait

__all__ = ["bind_loop", "periodic_integral"]


def bind_loop(system: Any, loop: Any, *, atol: float = 1e-9) -> np.ndarray:
    """Check that ``loop`` lives in ``system``'s shape space and is closed; return the winding integers.

    Raises :class:`ShapeError` for a wrong dimension, :class:`InputError` for an open loop (angle
    coordinates may wind by whole turns) and :class:`SingularityError` where the locked inertia is singular.
    """
    if not isinstance(loop, Gait):
        raise InputError(f"Expected `loop` to be a Gait, got {type(loop).__name__}.")
    if loop.T is None:
        raise InputError(f"Expected a closed loop: {loop!r} has no period; build it with `period=`.")
    names = [str(s) for s in system.shape]
    if loop.dim != system.sigma:
        raise ShapeError(
            f"Expected a shape loop in the {system.sigma}-D shape space ({', '.join(names)}) of "
            f"{system.name}, got one with {loop.dim} coordinate(s)."
        )
    if loop.names is not None and list(loop.names) != names:
        raise ShapeError(
            f"Expected the shape loop's coordinates to be ({', '.join(names)}), got ({', '.join(loop.names)})."
        )
    d = loop.r(loop.T) - loop.r(0.0)
    t_check = np.linspace(0.0, loop.T, 257)
    with np.errstate(all="ignore"):
        samples = np.asarray(loop.r(t_check), dtype=float)
        rates = np.asarray(loop.rdot(t_check), dtype=float)
    bad = ~(
        np.all(np.isfinite(samples.reshape(t_check.size, -1)), axis=1)
        & np.all(np.isfinite(rates.reshape(t_check.size, -1)), axis=1)
    )
    if np.any(bad) or not np.all(np.isfinite(d)):
        t_bad = float(t_check[np.argmax(bad)]) if np.any(bad) else loop.T
        raise InputError(
            f"Expected a shape loop with finite values and rates, got a non-finite one at t = {t_bad:.6g} "
            f"(of T = {loop.T:g}); a loop must be a smooth closed curve."
        )
    scale = max(1.0, float(np.abs(samples).max()))
    turns = np.zeros(loop.dim)
    for i in range(loop.dim):
        if i in system.shape_angles:
            turns[i] = np.round(d[i] / (2 * np.pi))
    gap = d - 2 * np.pi * turns
    if np.any(np.abs(gap) > atol * scale):
        raise InputError(
            f"Expected a closed shape loop: r(T) - r(0) = {np.round(d, 9).tolist()} for ({', '.join(names)}) "
            f"with T = {loop.T:g}; make the loop return to its start"
            + (" (angle coordinates may wind by whole turns)." if system.shape_angles else ".")
        )
    system.check_locked_inertia(loop.r(np.linspace(0.0, loop.T, 65)))
    return turns.astype(int)


def periodic_integral(
    f: Callable[[np.ndarray], np.ndarray],
    T: float,
    *,
    rtol: float = 1e-13,
    n0: int = 64,
    nmax: int = 2**17,
    what: str = "integral",
    atol: float = 0.0,
) -> np.ndarray:
    """:math:`\\int_0^T f`, ``f`` smooth and T-periodic, by the trapezoidal rule with doubling (spectrally
    accurate for smooth periodic integrands); falls back to adaptive Gauss-Kronrod for a kinked loop.
    Converged when the change is within ``rtol`` of the integral's or the integrand's size, or ``atol`` (the
    round-off of an integrand that cancels, which only its caller knows)."""
    n = n0
    t = np.arange(n) * (T / n)
    values = f(t)
    prev = values.sum(0) * (T / n)
    # the size of the integrand over the loop: an integral that cancels to zero converges against it
    size = float(np.abs(values).max()) * T
    while n < nmax:
        mid = (np.arange(n) + 0.5) * (T / n)
        values = f(mid)
        size = max(size, float(np.abs(values).max()) * T)
        cur = 0.5 * prev + values.sum(0) * (T / (2 * n))
        n *= 2
        scale = max(np.abs(cur).max(), size, 1e-300)
        if np.abs(cur - prev).max() <= rtol * scale + atol and n >= 2 * n0:
            return cur
        prev = cur
        t = np.arange(n) * (T / n)
        if n >= 4096:
            break
    from scipy.integrate import quad_vec

    val, err = quad_vec(lambda s: f(np.array([s]))[0], 0.0, T, epsabs=0.0, epsrel=max(rtol, 1e-13), limit=4000)
    scale = max(np.abs(val).max(), size, 1e-300)
    if np.max(err) > 1e-8 * scale + atol:
        raise ConvergenceError(
            f"The quadrature of the {what} over the loop did not converge (error estimate "
            f"{np.max(err):.3g}); the loop is probably not smooth enough."
        )
    return val
