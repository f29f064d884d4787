"""The observation of a compiled run's saved states: what each state shows (a Lagrangian system's q, qdot, shape
forces, energy and constraints; a body with rotors' energy and torques), by a generated module's ``observe_all``
(its ``observe`` of one state, and :data:`OBSERVE_ALL` over the rows), as Python for a few small runs and compiled
once the Python has cost about what a compilation does; loaded at once where numba's disk cache has it
(milliseconds, the cost of a few hundred states as Python)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._storage import remember
from . import _codegen
from ._native import compiled, kinds, native_loop

__all__ = ["OBSERVE_ALL", "Observation", "bound_observation", "observe"]

#: The loop over the saved states of a module whose ``observe(y, out, prm)`` shows one: rows of Y (n_members x
#: n_saved, flattened), member i // per's parameters; NaN for a state that is not finite.
OBSERVE_ALL = """

@kernel
def observe_all(Y, OUT, PRM, per):
    for i in range(Y.shape[0]):
        finite = True
        for j in range(Y.shape[1]):
            if not math.isfinite(Y[i, j]):
                finite = False
        if finite:
            observe(Y[i], OUT[i], PRM[i // per if PRM.shape[0] > 1 else 0])
        else:
            for j in range(OUT.shape[1]):
                OUT[i, j] = math.nan
    return 0
"""


@dataclass(frozen=True)
class Observation:
    """A generated observation of saved states: the module's ``source`` (its ``observe(y, out, prm)`` of one state and
    :data:`OBSERVE_ALL`) and the width ``observed`` of a row of what it shows."""

    source: str
    observed: int


#: The observation runs as Python (about 25 us a state for the snakeboard) until the states observed so in a
#: process would pass this many; then it is compiled (seconds once per system and form of the gait, cached on disk;
#: a load from the cache afterwards), as at once for a larger run.
PYTHON_ROWS = 4000
_PYTHON: dict[str, Any] = {}
#: the states each module (by name) has observed as Python in this process
_PYTHON_SEEN: dict[str, int] = {}


def _compiled_observation(name: str, compiled: bool, rows: int) -> bool:
    """Whether ``rows`` states of module ``name`` are observed by the compiled code (``compiled``: compiled already, or
    on disk; made now where it is not), or as Python: compiled once the module's states observed as Python in this
    process would pass PYTHON_ROWS, when the Python has cost about what a compilation does."""
    if compiled:
        return True
    seen = _PYTHON_SEEN.get(name, 0) + rows
    if seen > PYTHON_ROWS:
        return True
    _PYTHON_SEEN[name] = seen
    return False


def observe(module: Any, made: Any, Y: np.ndarray, PRM: np.ndarray, per: int) -> tuple[np.ndarray, float]:
    """What the states ``Y`` (rows of the run's state) show, ``(rows, made.observed)``, by ``module``'s
    ``observe_all`` (``made``: its generated ``source`` and the width ``observed`` of a row, a
    :class:`~.nonholonomic._compiled.LagrangianSource` or a body with rotors' observation); NaN for a state that is
    not finite. Row i reads the parameters of member ``i // per`` (a batch's saved states, member by member).
    Returns them and the seconds spent compiling the observation (or loading it from the disk cache) in this
    call."""
    Y = np.ascontiguousarray(Y, dtype=float)
    OUT = np.empty((Y.shape[0], made.observed))
    observe_all = module.observe_all
    seconds = 0.0
    args = (Y, OUT, PRM, per)
    spec = kinds(args) if hasattr(observe_all, "py_func") else None  # (None: the Python twin)
    known, native = native_loop(module, "observe_all", spec) if spec else (False, None)
    if native is not None:  # its machine code of its own, loaded from the cache (no numba)
        native(*args)
        return OUT, seconds
    ready = known or _codegen.loaded(observe_all) or _codegen.on_disk(observe_all)
    if not _compiled_observation(module.__name__, ready, Y.shape[0]):
        namespace = _PYTHON.get(made.source)
        if namespace is None:  # the same source as plain Python
            namespace = dict(_codegen.python_helpers())
            exec(compile(_codegen.python_header() + made.source, "<geomech observation>", "exec"), namespace)
            remember(_PYTHON, made.source, namespace, 32)
        namespace["observe_all"](Y, OUT, PRM, per)
        return OUT, seconds
    # compiled (or loaded) on a row, and its C entry built, timed apart
    kernel, seconds = compiled(module, "observe_all", args, lambda: observe_all(Y[:1], OUT[:1], PRM[:1], 1))
    kernel(*args)
    return OUT, seconds


def bound_observation(
    module: Any, made: Any, Y: np.ndarray, PRM: np.ndarray, per: int
) -> tuple[Any, np.ndarray] | None:
    """:func:`observe` of the rows ``Y`` bound to them and to an output of its own: (a function of no arguments that
    observes ``Y``'s contents into it, the output), where ``module``'s observation has its C entry here (loaded, or
    on disk); else None (:func:`observe` at each call, which compiles it once that is worth it)."""
    if not hasattr(module.observe_all, "py_func"):  # the Python twin
        return None
    OUT = np.empty((Y.shape[0], made.observed))
    args = (Y, OUT, PRM, per)
    spec = kinds(args)
    native = native_loop(module, "observe_all", spec)[1] if spec else None
    return None if native is None else (native.bind(*args), OUT)
