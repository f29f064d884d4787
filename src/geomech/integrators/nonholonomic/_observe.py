"""The observation of a compiled Lagrangian run's saved states: what each state shows (q, qdot, the shape forces,
the energy, the constraints), by the generated module's ``observe_all`` (:mod:`._compiled`), as Python for a few
small runs and compiled once the Python has cost about what a compilation does; loaded at once where numba's disk
cache has it (milliseconds, the cost of a few hundred states as Python)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .. import _codegen
from ._compiled import LagrangianSource

__all__ = ["observe"]


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


def observe(module: Any, made: LagrangianSource, Y: np.ndarray, PRM: np.ndarray, per: int) -> tuple[np.ndarray, float]:
    """What the states ``Y`` (rows of ``(g, r_F, rdot_F, p, W, t)``) show, ``(rows, made.observed)``: q, qdot, the
    shape forces, the energy, the constraints; NaN for a state that is not finite. Row i reads the parameters of
    member ``i // per`` (a batch's saved states, member by member). Returns them and the seconds spent compiling
    the observation (or loading it from the disk cache) in this call."""
    Y = np.ascontiguousarray(Y, dtype=float)
    OUT = np.empty((Y.shape[0], made.observed))
    observe_all = module.observe_all
    seconds = 0.0
    ready = _codegen.loaded(observe_all) or _codegen.on_disk(observe_all)
    if not _compiled_observation(module.__name__, ready, Y.shape[0]):
        namespace = _PYTHON.get(made.source)
        if namespace is None:  # the same source as plain Python
            namespace = dict(_codegen.python_helpers())
            exec(compile(_codegen.python_header() + made.source, "<geomech BKMM>", "exec"), namespace)
            if len(_PYTHON) >= 32:
                _PYTHON.pop(next(iter(_PYTHON)))
            _PYTHON[made.source] = namespace
        namespace["observe_all"](Y, OUT, PRM, per)
        return OUT, seconds
    if not _codegen.loaded(observe_all):  # compiled (or loaded) on a row, timed apart
        start = time.perf_counter()
        observe_all(Y[:1], OUT[:1], PRM[:1], 1)
        seconds = time.perf_counter() - start
    observe_all(Y, OUT, PRM, per)
    return OUT, seconds
