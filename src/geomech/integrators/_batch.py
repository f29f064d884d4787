"""The batch of a run of :func:`~geomech.solve`: the initial states and the parameter values of its trajectories
(leading axes broadcast), and the failures of those that reach the end of their system's chart."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError
from ._problem import Problem
from .methods import Method, MoserVeselov, PeriodicOrbit, Quadrature, SerretAndoyerAtlas
from .solution import Failure, Status

__all__ = ["batch_index", "initial_states", "left_chart", "parameter_batch"]


def initial_states(problem: Problem, y0: Any, m0: Any, R0: Any) -> tuple[np.ndarray, tuple[int, ...]]:
    if problem.kind == "canonical":
        if m0 is not None or R0 is not None:
            raise InputError(
                f"{problem.name} is a canonical system: give its initial state as `y0` = (q, p), not `m0`/`R0`."
            )
        if y0 is None:
            raise InputError(f"Expected `y0`, the initial (q, p) of {problem.name} (shape (..., {problem.dim})).")
        Y = V.trailing_shape(y0, "y0", (problem.dim,))
        return Y.reshape(-1, problem.dim).copy(), Y.shape[:-1]
    if y0 is not None:
        raise InputError(
            f"{problem.name} is a left-invariant system: give the body momentum as `m0` (shape (..., 3)) and, to "
            "integrate the attitude too, `R0` (shape (..., 3, 3)); not `y0`."
        )
    if m0 is None:
        raise InputError(f"Expected `m0`, the initial body angular momentum of {problem.name} (shape (..., 3)).")
    m = V.trailing_shape(m0, "m0", (3,))
    if R0 is None:
        return m.reshape(-1, 3).copy(), m.shape[:-1]
    R = V.rotation_matrix(R0, "R0")
    try:
        shape = np.broadcast_shapes(m.shape[:-1], R.shape[:-2])
    except ValueError:
        raise InputError(
            f"Expected `m0` (batch {m.shape[:-1]}) and `R0` (batch {R.shape[:-2]}) to have broadcastable batch shapes."
        ) from None
    m = np.broadcast_to(m, shape + (3,))
    R = np.broadcast_to(R, shape + (3, 3))
    Y = np.concatenate([m, R.reshape(shape + (9,))], axis=-1)
    return Y.reshape(-1, 12).copy(), shape


def parameter_batch(problem: Problem, method: Method, parameters: Any) -> tuple[dict[str, np.ndarray], tuple[int, ...]]:
    """Values of a system's own parameters for this run (name -> array; their broadcast shape a batch of
    trajectories), checked against the names the compiled model reads at run time."""
    if parameters is None:
        return {}, ()
    names = [n for n in problem.parameter_names if not n.startswith(("u_", "_p"))]
    if problem.kind not in ("canonical", "lie_poisson", "rotor") or not names or problem.model_expression is None:
        raise InputError(
            f"`parameters` sets the named parameters of a system built from a formula (canonical, left-invariant, a "
            f"body with rotors of a named layout under a torque law of formulas) or of a Lagrangian system; "
            f"{problem.name} has none to set here"
            + (" (build a body with other inertias with `with_parameters`)." if problem.kind == "rotor" else ".")
        )
    if not isinstance(parameters, Mapping):
        raise InputError(f"Expected `parameters` to be a mapping name -> value(s), got {type(parameters).__name__}.")
    unknown = sorted(set(parameters) - set(names))
    if unknown:
        raise InputError(f"`parameters` names {unknown}, not parameters of {problem.name}; its parameters: {names}.")
    values = {str(k): V.finite(np.asarray(v, dtype=float), f"parameters[{k!r}]") for k, v in parameters.items()}
    # each member as the system would check one value: the symbols' signs, and the system's own rules
    signs = {s.name: s for s in problem.parameter_symbols}
    for k, v in values.items():
        if k in signs and signs[k].is_positive and not np.all(v > 0):
            raise InputError(f"Expected `parameters[{k!r}]` of {problem.name} to be positive, got {v.min():g}.")
    check = getattr(problem.system, "check_parameters", None)
    if check is not None:
        check(values)
    if isinstance(method, (MoserVeselov, SerretAndoyerAtlas, PeriodicOrbit, Quadrature)):
        raise InputError(
            f"{type(method).__name__} takes the system's own parameter values (they shape its constants or its "
            "propagator): build the system with other values instead of passing `parameters`."
        )
    try:
        shape = np.broadcast_shapes(*(v.shape for v in values.values()))
    except ValueError:
        raise InputError(
            f"Expected the values in `parameters` to broadcast, got shapes { {k: v.shape for k, v in values.items()} }."
        ) from None
    return {k: np.broadcast_to(v, shape) for k, v in values.items()}, shape


def left_chart(
    system: Any,
    OUT: np.ndarray,
    INFO: np.ndarray,
    steps: np.ndarray,
    times: np.ndarray,
    batch_shape: tuple[int, ...],
) -> list[Failure]:
    """A failure for each trajectory whose saved states reach the end of the system's chart."""
    failures = []
    for i, lo, hi in getattr(system, "chart", ()):
        x = OUT[:, :, i]
        outside = ~((x > lo) & (x < hi)) & np.isfinite(x)
        for b in np.flatnonzero(outside.any(axis=1) & (INFO[:, 0] == 0)):
            k = int(np.argmax(outside[b]))
            INFO[b, 0] = 6
            failures.append(
                Failure(
                    kind=Status.LEFT_CHART,
                    batch_index=batch_index(int(b), batch_shape),
                    step=int(steps[k]),
                    time=float(times[k]),
                    residual=float("nan"),
                )
            )
    return failures


def batch_index(b: int, batch_shape: tuple[int, ...]) -> tuple[int, ...]:
    return tuple(int(j) for j in np.unravel_index(b, batch_shape)) if batch_shape else ()
