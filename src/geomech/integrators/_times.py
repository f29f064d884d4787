"""The time grid of a run of :func:`~geomech.solve`, from the one way times are given: ``t_final``, ``saveat``,
and ``h`` (fixed step) or ``rtol``/``atol`` (adaptive). Sizes are known before any array is built, so that the
work and memory bounds are checked first."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError
from .methods import REGISTRY, Kind, Method

__all__ = ["DEFAULT_SAVEAT", "Times", "tolerances", "time_grid"]


@dataclass(frozen=True)
class Times:
    """When a run steps and what it saves (internal). Sizes are known before any array is built, so that
    the work and memory bounds are checked first."""

    t0: float
    t_final: float
    h: float | None  # the signed step of a fixed-step method
    n_steps: int  # steps of a fixed-step method, output intervals otherwise
    save_every: int = 1  # the compiled loop keeps every save_every-th state (and the last)
    k: np.ndarray | None = None  # fixed step: the step indices of the saveat times (None: every kept state)
    given: np.ndarray | None = None  # other methods: the saveat times (None: `count` equally spaced)
    count: int = 0

    @property
    def n_kernel_saved(self) -> int:
        """How many states the loop keeps."""
        if self.h is None:
            return self.n_saved
        return self.n_steps // self.save_every + 1 + (self.n_steps % self.save_every != 0)

    @property
    def n_saved(self) -> int:
        """How many states the Solution holds."""
        if self.h is None:
            return len(self.given) if self.given is not None else self.count
        return len(self.k) if self.k is not None else self.n_kernel_saved

    def kernel_steps(self) -> np.ndarray:
        """The step indices of the states the loop keeps (fixed step)."""
        saved = np.arange(0, self.n_steps + 1, self.save_every)
        return saved if saved[-1] == self.n_steps else np.append(saved, self.n_steps)

    @property
    def pick(self) -> np.ndarray | None:
        """Which of the loop's states are asked for (None: all)."""
        return None if self.k is None else np.searchsorted(self.kernel_steps(), self.k)

    @functools.cached_property
    def t(self) -> np.ndarray:
        """The saved times (made once: a run reads them several times)."""
        if self.h is None:
            if self.given is not None:
                return self.given
            return evenly_spaced(self.t0, self.t_final, self.count)
        steps = self.k if self.k is not None else self.kernel_steps()
        return self.t0 + self.h * steps.astype(float)


def evenly_spaced(start: float, stop: float, count: int) -> np.ndarray:
    """``np.linspace(start, stop, count)``, the same numbers (its arithmetic: start + k step, the last one stop)
    without its generality's cost (16 us for two times, a third of a short run's Python)."""
    step = (stop - start) / (count - 1) if count > 1 else 0.0
    if step == 0.0:
        return np.linspace(start, stop, count)
    t = np.arange(count, dtype=float) * step + start
    t[-1] = stop
    return t


def time_grid(method: Method, t0: Any, t_final: Any, h: Any, saveat: Any, rtol: Any, atol: Any) -> Times:
    """The time grid of a run, from the one way times are given: ``t_final``, ``saveat``, and ``h`` (fixed
    step) or ``rtol``/``atol`` (adaptive)."""
    name = type(method).__name__
    t0 = float(V.finite(t0, "t0"))
    if t_final is None:
        raise InputError("Expected `t_final`, the end of the integration (it may be before `t0`).")
    t_final = float(V.finite(t_final, "t_final"))
    span = t_final - t0
    if span == 0.0:
        raise InputError(f"Expected `t_final` to differ from `t0` = {t0:g}.")
    count = _saveat_count(saveat)
    if method.kind is Kind.FIXED_STEP:
        if rtol is not None or atol is not None:
            raise InputError(
                f"{name} takes fixed steps: give the step `h`, not `rtol`/`atol` (those are for adaptive methods "
                f"such as {', '.join(k for k, m in REGISTRY.items() if m.kind is Kind.ADAPTIVE)})."
            )
        if h is None:
            raise InputError(f"{name} takes fixed steps: give the step `h` (a positive number).")
        h = V.positive_scalar(h, "h")
        ratio = abs(span) / h
        if not math.isfinite(ratio):
            raise InputError(
                f"`t_final - t0` = {span:g} over h = {h:g} is not a finite number of steps; take a larger h or a "
                "shorter span."
            )
        n = round(ratio)
        if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
            raise InputError(
                f"Expected `t_final - t0` = {span:g} to be a whole number of steps h = {h:g}, got {ratio:.12g} "
                "steps; choose h = |t_final - t0| / N."
            )
        h = math.copysign(h, span)
        if saveat is None:
            return Times(t0, t_final, h, n, 1)
        if count:
            if n % (count - 1):
                raise InputError(
                    f"`saveat` = {count} equally spaced times are not on the step grid of {name}: {count - 1} "
                    f"intervals do not divide the {n} steps of h = {abs(h):g}; choose `saveat` - 1 a divisor of "
                    f"{n}, or give the times t0 + k h."
                )
            return Times(t0, t_final, h, n, n // (count - 1))
        wanted = _saveat(saveat, t0, t_final)
        k_float = (wanted - t0) / h
        k = np.rint(k_float).astype(np.int64)
        off = np.abs(k_float - k) > 1e-9 * np.maximum(1.0, np.abs(k_float))
        if np.any(off):
            bad = float(wanted[np.argmax(off)])
            raise InputError(
                f"`saveat` time {bad:.12g} is not on the step grid t0 + k h (h = {abs(h):g}) of {name}; give times "
                "t0 + k h, or use an adaptive method, which saves at any time."
            )
        inner = k[(k > 0) & (k < n)]  # the loop always keeps the first and the last state
        every = int(np.gcd.reduce(inner)) if inner.size else n
        return Times(t0, t_final, h, n, every, k=k)
    if h is not None:
        what = "chooses its own steps" if method.kind is Kind.ADAPTIVE else "takes no steps in time"
        raise InputError(
            f"{name} {what}: do not give `h`; give the output times as `saveat` (times, or their number)"
            + (" and the tolerances as `rtol`/`atol`." if method.kind is Kind.ADAPTIVE else ".")
        )
    if method.kind is Kind.EXACT and (rtol is not None or atol is not None):
        raise InputError(f"{name} is an exact propagator: its accuracy is its own `tol`, not `rtol`/`atol`.")
    if saveat is None or count:
        n_out = count or DEFAULT_SAVEAT
        return Times(t0, t_final, None, n_out - 1, count=n_out)
    given = _saveat(saveat, t0, t_final)
    return Times(t0, t_final, None, len(given) - 1, given=given)


#: Output times of an adaptive method or an exact propagator when ``saveat`` is not given.
DEFAULT_SAVEAT = 201


def _saveat_count(saveat: Any) -> int:
    """The number of output times when ``saveat`` is one, else 0."""
    if isinstance(saveat, (int, np.integer)) and not isinstance(saveat, bool):
        if not 2 <= saveat <= 2**53:
            raise InputError(f"Expected `saveat`, a number of output times, to be at least 2, got {saveat}.")
        return int(saveat)
    return 0


def _saveat(saveat: Any, t0: float, t_final: float) -> np.ndarray:
    """``saveat`` given as times: checked to run from ``t0`` towards ``t_final``."""
    t = V.finite(saveat, "saveat").ravel().astype(float)
    if t.size < 1:
        raise InputError("Expected `saveat` to hold at least one time (or to be their number).")
    sign = 1.0 if t_final > t0 else -1.0
    if t.size > 1 and np.any(sign * np.diff(t) <= 0):
        raise InputError(
            "Expected `saveat` to be strictly " + ("increasing" if sign > 0 else "decreasing (t_final < t0)") + "."
        )
    lo, hi = min(t0, t_final), max(t0, t_final)
    if t.min() < lo or t.max() > hi:
        raise InputError(f"Expected every `saveat` time within [{lo:g}, {hi:g}] (t0 to t_final).")
    return t


def tolerances(method: Method, rtol: Any, atol: Any) -> tuple[float, float]:
    r, a = method.default_tolerances
    out = []
    for name, value, default in (("rtol", rtol, r), ("atol", atol, a)):
        value = default if value is None else value
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not 0 < value < 1:
            raise InputError(f"Expected `{name}` in (0, 1), got {value!r}.")
        out.append(float(value))
    return out[0], out[1]
