"""Private helpers shared by the Lie-group modules: series branches, validation, small kernels."""

from __future__ import annotations

from fractions import Fraction
from math import factorial
from typing import Any, Callable, Sequence

import numpy as np
import sympy as sp

from .._validate import rotation_matrix, trailing_shape
from ..errors import InputError

# Absolute tolerance on ``R^T R - I`` and on the homogeneous bottom row when a group element is validated.
# It accepts products of many float64 rotations and rejects anything that is not close to a group element.
ELEMENT_ATOL = 1e-9


class EvenSeries:
    """An even function ``f(t)`` evaluated by its Taylor polynomial near 0 and its closed form elsewhere.

    ``coeffs`` are the Taylor coefficients of ``t^0, t^2, t^4, ...``; ``next_coeff`` is the coefficient of
    the first neglected power. The switch point is where that neglected term falls below one unit in the
    last place of ``f(0)`` for the dtype at hand, so the Taylor branch is exact to round-off and the
    closed form is only used where its cancellation (``t - sin t``, ``1 - cos t``, ...) is mild.
    """

    def __init__(
        self,
        coeffs: Sequence[Fraction | int],
        next_coeff: Fraction,
        closed: Callable[[np.ndarray], np.ndarray],
    ):
        self.coeffs = [float(c) for c in coeffs]
        self._lead = abs(float(coeffs[0])) if coeffs[0] != 0 else 1.0
        self._next = abs(float(next_coeff))
        self._power = 2 * len(coeffs)
        self.closed = closed
        self._tol64 = self.tol(np.dtype(np.float64))

    def tol(self, dtype: np.dtype) -> float:
        eps = float(np.finfo(dtype).eps)
        return (eps * self._lead / self._next) ** (1.0 / self._power)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t)
        if t.ndim == 0 and t.dtype == np.float64:
            # one double (a single element in a Python loop, e.g. a step of a group integrator): the same
            # operations on a scalar, without the array machinery
            x = float(t)
            if abs(x) < self._tol64:
                x2 = x * x
                value = 0.0
                for c in reversed(self.coeffs):
                    value = value * x2 + c
                return np.asarray(value)
            return np.asarray(self.closed(t))
        tol = self.tol(t.dtype)
        small = np.abs(t) < tol
        # The closed form is evaluated at a harmless stand-in where the series is used, so that no
        # division by zero is ever computed (warnings are errors in the test suite).
        t_safe = np.where(small, tol, t)
        t2 = t * t
        series = np.zeros_like(t2)
        for c in reversed(self.coeffs):
            series = series * t2 + c
        return np.where(small, series, self.closed(t_safe))


def _factorial_series(coeff: Callable[[int], Fraction], n_terms: int) -> tuple[list[Fraction], Fraction]:
    return [coeff(n) for n in range(n_terms)], coeff(n_terms)


def _bernoulli(n: int) -> Fraction:
    """Bernoulli number B_n (B_1 = +1/2 convention; only even n are used), Akiyama-Tanigawa algorithm."""
    a = [Fraction(0)] * (n + 1)
    for m in range(n + 1):
        a[m] = Fraction(1, m + 1)
        for j in range(m, 0, -1):
            a[j - 1] = j * (a[j - 1] - a[j])
    return a[0]


def _half_cot_half(n: int) -> Fraction:
    """Coefficient of t^(2n) in (t/2) cot(t/2) = sum (-1)^n B_2n t^2n / (2n)!."""
    return (-1) ** n * _bernoulli(2 * n) / factorial(2 * n)


F = Fraction
# The functions with cancellation in their closed form (t - sin t, 1 - cos t - t^2/2, 1 - (t/2) cot(t/2))
# carry 12 terms, so that the switch to the closed form happens near t ~ 1-2 where it has lost at most a
# few ulps; the others need only 3.

# sin t / t
SINC = EvenSeries([1, F(-1, 6), F(1, 120)], F(-1, 5040), lambda t: np.sin(t) / t)
# (1 - cos t) / t^2, written with sin^2(t/2) so that it has no cancellation
ONE_MINUS_COS_T2 = EvenSeries(
    [F(1, 2), F(-1, 24), F(1, 720)], F(-1, 40320), lambda t: 2.0 * np.sin(0.5 * t) ** 2 / (t * t)
)
# (t - sin t) / t^3 = sum (-1)^n t^2n / (2n + 3)!
T_MINUS_SIN_T3 = EvenSeries(
    *_factorial_series(lambda n: F((-1) ** n, factorial(2 * n + 3)), 12), lambda t: (t - np.sin(t)) / t**3
)
# (t/2) cot(t/2) = t sin t / (2 (1 - cos t)); no cancellation, radius of convergence 2 pi
HALF_COT_HALF = EvenSeries(*_factorial_series(_half_cot_half, 6), lambda t: 0.5 * t * np.cos(0.5 * t) / np.sin(0.5 * t))
# (1 - (t/2) cot(t/2)) / t^2 = 1/t^2 - (1 + cos t) / (2 t sin t)
JINV_D = EvenSeries(
    *_factorial_series(lambda n: -_half_cot_half(n + 1), 12),
    lambda t: (1.0 - 0.5 * t * np.cos(0.5 * t) / np.sin(0.5 * t)) / (t * t),
)
# t / sin t; no cancellation, radius of convergence pi (so few terms: the switch stays far below it)
T_OVER_SIN = EvenSeries([1, F(1, 6), F(7, 360)], F(31, 15120), lambda t: t / np.sin(t))
# (t^2 + 2 cos t - 2) / (2 t^4) = sum (-1)^n t^2n / (2n + 4)!
SE3_C2 = EvenSeries(
    *_factorial_series(lambda n: F((-1) ** n, factorial(2 * n + 4)), 12),
    lambda t: (t * t + 2.0 * np.cos(t) - 2.0) / (2.0 * t**4),
)
# (2 t - 3 sin t + t cos t) / (2 t^5) = sum (-1)^n (n + 1) t^2n / (2n + 5)!
SE3_C3 = EvenSeries(
    *_factorial_series(lambda n: F((-1) ** n * (n + 1), factorial(2 * n + 5)), 12),
    lambda t: (2.0 * t - 3.0 * np.sin(t) + t * np.cos(t)) / (2.0 * t**5),
)


def vector(value: Any, name: str, n: int) -> np.ndarray:
    return trailing_shape(value, name, (n,))


#: Largest rotation angle (radians) taken by the exponential maps: beyond it the spacing of floats near
#: the angle is above 0.1 rad, so the angle modulo 2 pi, hence the rotation, is not determined by the input.
MAX_ANGLE = 1e15


def angles(value: np.ndarray, name: str) -> np.ndarray:
    """``value`` (rotation vectors or angles) if no component exceeds :data:`MAX_ANGLE` in size."""
    big = np.abs(value) > MAX_ANGLE
    if np.any(big):
        raise InputError(
            f"Expected the rotation part of `{name}` to be below {MAX_ANGLE:g} rad in size, got "
            f"{np.abs(value).max():.3g}{_where(big)}: there the angle modulo 2 pi is lost to "
            "round-off; reduce it modulo 2 pi first."
        )
    return value


def matrix(value: Any, name: str, n: int) -> np.ndarray:
    return trailing_shape(value, name, (n, n))


def rotation(value: Any, name: str) -> np.ndarray:
    return rotation_matrix(value, name, atol=ELEMENT_ATOL)


def _where(bad: np.ndarray) -> str:
    idx = np.argwhere(bad)
    if idx.shape[1] == 0:
        return ""
    shown = ", ".join(str(tuple(int(i) for i in row)) for row in idx[:5])
    more = f" and {len(idx) - 5} more" if len(idx) > 5 else ""
    return f" at batch index {shown}{more}"


def rigid_motion(value: Any, name: str, n: int) -> np.ndarray:
    """Validate homogeneous matrices ``[[R, t], [0, 1]]`` of SE(n), shape ``(..., n+1, n+1)``."""
    arr = trailing_shape(value, name, (n + 1, n + 1))
    R = arr[..., :n, :n]
    bottom = arr[..., n, :].copy()
    bottom[..., n] -= 1.0
    err = np.maximum(
        np.abs(bottom).max(axis=-1),
        np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(n)).max(axis=(-2, -1)),
    )
    refuse_non_elements(
        err,
        name,
        f"SE({n}), a homogeneous matrix [[R, t], [0, 1]] with R^T R = I and det R = +1",
        bad=(err > ELEMENT_ATOL) | (np.linalg.det(R) <= 0),
    )
    return arr


def refuse_non_elements(err: np.ndarray, name: str, what: str, *, bad: np.ndarray | None = None) -> None:
    """Raise :class:`InputError` where ``err`` (the distance of each of a batch of matrices from the group,
    entrywise) exceeds :data:`ELEMENT_ATOL` (or where ``bad``), naming the group (``what``) and where."""
    bad = err > ELEMENT_ATOL if bad is None else bad
    if np.any(bad):
        raise InputError(
            f"Expected `{name}` to be an element of {what}, got one off by {float(np.max(err)):.3g}{_where(bad)}."
        )


def batch_shape_of(batch_shape: Any) -> tuple[int, ...]:
    if isinstance(batch_shape, (int, np.integer)):
        batch_shape = (int(batch_shape),)
    try:
        shape = tuple(int(s) for s in batch_shape)
    except TypeError as exc:
        raise InputError(f"Expected `batch_shape` to be a tuple of ints, got {batch_shape!r}.") from exc
    if any(s < 0 for s in shape):
        raise InputError(f"Expected `batch_shape` to have non-negative entries, got {shape}.")
    return shape


def eye(n: int, batch_shape: Any) -> np.ndarray:
    return np.broadcast_to(np.eye(n), batch_shape_of(batch_shape) + (n, n)).copy()


def generator(rng: Any) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    try:
        return np.random.default_rng(rng)
    except (TypeError, ValueError) as exc:
        raise InputError(f"Expected `rng` to be a numpy Generator, a seed or None, got {rng!r}.") from exc


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of unit quaternions ``(w, x, y, z)`` along the last axis (no validation)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    out = np.empty(q.shape[:-1] + (3, 3), dtype=q.dtype)
    out[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[..., 0, 1] = 2.0 * (x * y - z * w)
    out[..., 0, 2] = 2.0 * (x * z + y * w)
    out[..., 1, 0] = 2.0 * (x * y + z * w)
    out[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[..., 1, 2] = 2.0 * (y * z - x * w)
    out[..., 2, 0] = 2.0 * (x * z - y * w)
    out[..., 2, 1] = 2.0 * (y * z + x * w)
    out[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return out


def random_unit_quaternions(rng: np.random.Generator, size: Any) -> np.ndarray:
    """Haar-uniform unit quaternions ``(w, x, y, z)``: a normalised isotropic Gaussian in R^4."""
    shape = batch_shape_of(size)
    while True:
        q = rng.standard_normal(shape + (4,))
        norm = np.linalg.norm(q, axis=-1, keepdims=True)
        # A draw of exactly zero has probability zero; redraw rather than divide by it.
        if np.all(norm > 0):
            return q / norm


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles into (-pi, pi]."""
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def coordinate_names(names: Sequence[Any], default: Sequence[str], group: str, hint: str) -> tuple[str, ...]:
    """Coordinate names as strings (identifiers, or sympy Symbols by their names), ``default`` if none."""
    if len(names) == 1 and isinstance(names[0], (list, tuple)):
        names = tuple(names[0])
    names = tuple(names) or tuple(default)
    out = []
    for n in names:
        if isinstance(n, sp.Symbol):
            n = n.name
        if not (isinstance(n, str) and n.isidentifier()):
            raise InputError(f"Expected the coordinate names of {group} to be identifiers, got {n!r}.")
        out.append(n)
    if len(out) != len(default):
        raise InputError(f"Expected {len(default)} coordinate names for {group} ({hint}), got {len(out)}: {out}.")
    if len(set(out)) != len(out):
        raise InputError(f"Expected distinct coordinate names for {group}, got {out}.")
    return tuple(out)
