"""Validation of arguments at the public boundary: one place for the wording of input errors."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import InputError, ShapeError


def _show(value: Any) -> str:
    arr = np.asarray(value)
    if arr.size <= 12:
        return np.array2string(arr, separator=", ", precision=6) if arr.ndim else repr(arr.item())
    return f"an array of shape {arr.shape}"


def parameter_update(values: Any, known: Any, owner: str, positive: Any = ()) -> dict[str, float]:
    """New values for named parameters (``with_parameters`` of every system): each name must be one of ``known``
    and each value a finite number (> 0 for the names in ``positive``: masses, lengths, inertias)."""
    known = sorted(known)
    unknown = sorted(set(values) - set(known))
    if unknown:
        raise InputError(f"Unknown parameter(s) {unknown}; the parameters of {owner} are {known or 'none'}.")
    out: dict[str, float] = {}
    for k, v in values.items():
        try:
            x = float(v)
        except (TypeError, ValueError) as exc:
            raise InputError(f"Expected parameter `{k}` of {owner} to be a number, got {v!r}.") from exc
        if not np.isfinite(x):
            raise InputError(f"Expected parameter `{k}` of {owner} to be finite, got {x}.")
        if k in positive and not x > 0:
            raise InputError(
                f"Expected parameter `{k}` of {owner} to be positive (a mass, length or inertia), got {x:g}."
            )
        out[k] = x
    return out


def as_float_array(value: Any, name: str) -> np.ndarray:
    """Return ``value`` as a float64 array, or raise :class:`InputError` naming ``name``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"Expected `{name}` to be numeric, got {value!r}.") from exc
    return arr


def finite(value: Any, name: str) -> np.ndarray:
    """Return ``value`` as a float array after checking that every entry is finite."""
    arr = as_float_array(value, name)
    # a few numbers (an initial state, a step, a tolerance: every run checks some) by Python's floats, which is
    # quicker than numpy's ufuncs below a few dozen
    if not (all(map(math.isfinite, arr.ravel().tolist())) if arr.size <= 32 else np.isfinite(arr).all()):
        raise InputError(f"Expected `{name}` to be finite, got {_show(arr)}.")
    return arr


def trailing_shape(value: Any, name: str, shape: tuple[int, ...], *, check_finite: bool = True) -> np.ndarray:
    """Return ``value`` as an array of shape ``(..., *shape)``; raise :class:`ShapeError` otherwise."""
    arr = finite(value, name) if check_finite else as_float_array(value, name)
    k = len(shape)
    if arr.ndim < k or arr.shape[arr.ndim - k :] != shape:
        want = "(..., " + ", ".join(str(s) for s in shape) + ")"
        raise ShapeError(f"Expected `{name}` to have shape {want}, got {arr.shape}.")
    return arr


def exact_shape(value: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """Return ``value`` as a finite float array of exactly ``shape``."""
    arr = finite(value, name)
    if arr.shape != shape:
        raise ShapeError(f"Expected `{name}` to have shape {shape}, got {arr.shape}.")
    return arr


def positive(value: Any, name: str) -> np.ndarray:
    """Return ``value`` as a finite float array whose entries are all > 0."""
    arr = finite(value, name)
    if not (arr > 0).all():
        raise InputError(f"Expected `{name}` to be positive, got {_show(arr)}.")
    return arr


def positive_scalar(value: Any, name: str) -> float:
    if type(value) in (float, int) and 0 < value < math.inf:  # a plain number (not a bool): nothing to convert
        return float(value)
    arr = positive(value, name)
    if arr.ndim != 0:
        raise ShapeError(f"Expected `{name}` to be a scalar, got shape {arr.shape}.")
    return float(arr)


def rotation_matrix(value: Any, name: str, *, atol: float = 1e-9) -> np.ndarray:
    """Return ``value`` as an array of rotation matrices ``(..., 3, 3)`` (orthogonal, det +1)."""
    arr = trailing_shape(value, name, (3, 3))
    if arr.ndim == 2:  # one matrix (every run from an attitude checks it): R^T R and det R by Python's floats
        (a, b, c), (d, e, f), (g, h, i) = arr.tolist()
        err = max(
            abs(a * a + d * d + g * g - 1.0),
            abs(b * b + e * e + h * h - 1.0),
            abs(c * c + f * f + i * i - 1.0),
            abs(a * b + d * e + g * h),
            abs(a * c + d * f + g * i),
            abs(b * c + e * f + h * i),
        )
        negative = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) <= 0
    else:
        err = np.abs(np.swapaxes(arr, -1, -2) @ arr - np.eye(3)).max(initial=0.0)
        negative = bool(np.any(np.linalg.det(arr) <= 0))
    if err > atol or negative:
        raise InputError(
            f"Expected `{name}` to be a rotation matrix (R^T R = I, det R = +1), "
            f"got one off by {err:.3g}; re-orthonormalise it (e.g. geomech.lie.so3.project)."
        )
    return arr


def positive_definite_along(
    I: np.ndarray, points: Any, what: str, consequence: str, *, rtol: float, global_scale: bool = False
) -> None:
    """Raise :class:`~geomech.errors.SingularityError` at the first point where the symmetric matrices ``I``
    (``(n, k, k)``) are not positive definite, naming the point, the eigenvalues and ``consequence``.

    The threshold is ``rtol`` times the largest eigenvalue at that point, or over all points with
    ``global_scale`` (a 1 x 1 matrix is otherwise its own scale)."""
    from .errors import SingularityError

    eig = np.linalg.eigvalsh(0.5 * (I + np.swapaxes(I, -1, -2)))
    scale = max(float(np.abs(eig).max()), 1e-300) if global_scale else np.maximum(np.abs(eig).max(-1), 1e-300)
    bad = eig.min(-1) <= rtol * scale
    if np.any(bad):
        i = int(np.argmax(bad))
        raise SingularityError(
            f"The {what} is singular (or not positive) at r = "
            f"{np.round(np.atleast_2d(points)[i], 6).tolist()} (eigenvalues "
            f"{np.round(eig[i], 12).tolist()}): {consequence}."
        )


#: Default ceilings of work decided before it starts; each is an argument (or option) a user can raise.
MAX_STEPS = 10**9
MEMORY_LIMIT = 2 * 2**30


def work_budget(count: float, limit: float, what: str, knob: str, fix: str, *, seconds_each: float = 0.0) -> None:
    """Refuse, before any work, ``count`` units of ``what`` above ``limit``: the error gives the estimate,
    the argument ``knob`` that raises the ceiling and the other ``fix``."""
    if not count <= limit:  # also catches NaN
        if not np.isfinite(count):
            shown, cost = "beyond the range of double precision", ""
        else:
            shown, cost = f"{count:.3g}", f" (about {count * seconds_each:.2g} s)" if seconds_each else ""
        raise InputError(f"{what} is {shown}{cost}, above the limit `{knob}` = {limit:.3g}; {fix}, or raise `{knob}`.")


def memory_budget(n_values: float, limit: float, what: str, knob: str, fix: str) -> None:
    """Refuse an output of ``n_values`` float64 values above ``limit`` bytes, before allocating it."""
    size = 8.0 * n_values
    if not size <= limit:
        raise InputError(
            f"{what} would hold {n_values:.3g} numbers ({size / 2**30:.3g} GiB), above the limit "
            f"`{knob}` = {limit / 2**30:.3g} GiB; {fix}, or raise `{knob}`."
        )
