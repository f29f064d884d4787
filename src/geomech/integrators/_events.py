"""User events of an adaptive run: zeros of functions of the state, located by the continuous extension of the
compiled embedded pairs (``erk_run`` of ``_k_embedded.py``), on the steps' polynomials of Taylor's method, or on
the dense output of scipy's solvers stepped from Python (:class:`~._adaptive.StepEvents`, with the same rule).

An event is a formula in the state's components, by the names of ``Solution.labels`` (and ``t`` where the time is
part of the state, as for a torque law that reads it) and the system's parameters; text is parsed by the formula
whitelist. Its zeros are found on each accepted step's continuous extension by bisection, to the resolution of
doubles in the step: their error is the method's, at the tolerances of the run. The event functions are compiled
into one model function ``event`` of their own, called through its address, so that the loop compiles once for
every model and event set; the runs stepped by scipy call the same function from Python (and the Lagrangian
equations in Python, formulas in the coordinates and velocities, :func:`stepped_lagrangian_events`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError
from ..symbolic.compile import M_SYMBOLS, FunctionSpec, kernel_source
from ..symbolic.formula import to_expression
from . import _codegen
from ._adaptive import StepEvents
from ._k_common import F_EVENT
from ._model_source import R_SYMBOLS

__all__ = [
    "CompiledEvents",
    "Event",
    "compile_events",
    "compile_lagrangian_events",
    "event_table",
    "events_need_adaptive",
    "stepped_lagrangian_events",
]


@dataclass(frozen=True)
class Event:
    """A zero of ``expression`` (a formula in the state's components, by the names of the solution's ``labels``, and
    the system's parameters), crossed in ``direction`` (+1 rising, -1 falling, 0 either); a ``terminal`` event ends
    the trajectory at its first occurrence (the saved states after it are NaN)."""

    expression: Any
    direction: int = 0
    terminal: bool = False

    def __post_init__(self) -> None:
        if self.direction not in (-1, 0, 1) or isinstance(self.direction, bool):
            raise InputError(f"Expected an event's `direction` to be -1, 0 or 1, got {self.direction!r}.")
        if not isinstance(self.terminal, bool):
            raise InputError(f"Expected an event's `terminal` to be True or False, got {self.terminal!r}.")


@dataclass(frozen=True)
class CompiledEvents:
    """The events of a run as the loop takes them: the address of their function, directions, terminal flags; and
    the function itself, ``function(y, out, prm)``, for the runs stepped from Python (scipy's solvers)."""

    names: tuple[str, ...]
    address: int
    directions: np.ndarray
    terminal: np.ndarray
    function: Any = None

    @classmethod
    def none(cls) -> CompiledEvents:
        """No events: one value for every run without them."""
        return _NO_EVENTS

    def stepped(self, prm: np.ndarray, d: int) -> StepEvents:
        """The events of one trajectory (its parameter row ``prm``, its state of length ``d``) for
        :func:`~geomech.integrators._adaptive.integrate_ivp`."""
        out = np.zeros(d)
        n = len(self.names)
        function = self.function

        def g(_t: float, y: np.ndarray) -> np.ndarray:
            function(np.ascontiguousarray(y, dtype=float), out, prm)
            return out[:n].copy()

        return StepEvents(g, self.directions, self.terminal)

    def record(self, rows: list[np.ndarray], EVT: np.ndarray, ECOUNT: np.ndarray, b: int) -> None:
        """Trajectory b's occurrences ``rows`` into the loops' record (EVT[b], ECOUNT[b]): as many as fit, all
        counted."""
        for c, row in enumerate(rows[: EVT.shape[1]]):
            EVT[b, c] = row
        ECOUNT[b] = len(rows)


#: no events (empty arrays, which nothing can write into; writable, as the compiled loops' signatures take them)
_NO_EVENTS = CompiledEvents((), 0, np.zeros(0), np.zeros(0))


def _specs(events: Any) -> dict[str, Event]:
    if not isinstance(events, Mapping) or not events:
        raise InputError(
            "Expected `events` to be a mapping name -> formula (or Event(formula, direction, terminal)), e.g. "
            f"{{'apex': Event('m1', direction=-1)}}; got {events!r}."
        )
    out = {}
    for name, spec in events.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise InputError(f"Expected each event's name to be an identifier, got {name!r}.")
        out[name] = spec if isinstance(spec, Event) else Event(spec)
    return out


def _state_symbols(problem: Any) -> tuple[sp.Symbol, ...]:
    if problem.kind == "lie_poisson":
        return tuple(M_SYMBOLS) + (tuple(R_SYMBOLS) if problem.layout == "mR" else ())
    return tuple(problem.variables)


def compile_events(problem: Any, events: Any, backend: str) -> CompiledEvents:
    """The events of ``events`` (name -> formula or :class:`Event`) compiled for ``problem``'s state; raises
    :class:`InputError` naming what does not fit."""
    specs = _specs(events)
    if problem.kind not in ("canonical", "lie_poisson", "rotor") or problem.model_expression is None:
        raise InputError(
            f"`events` are located on the compiled continuous extension of a system given by formulas (canonical, "
            f"left-invariant, or a body with rotors under a torque law given by formulas); {problem.name} is not one."
        )
    if backend == "python" or not _codegen.numba_available():
        raise InputError("`events` are located in the compiled loops: they need numba (backend 'auto' or 'numba').")
    state = _state_symbols(problem)
    labels = list(problem.labels) + (["t"] if problem.timed else [])
    names: dict[str, sp.Symbol] = dict(zip(labels, state))
    params = tuple(problem.parameter_symbols)
    inverse: dict[sp.Symbol, sp.Expr] = {}
    for sym, (name, is_inverse) in zip(params, problem.parameter_recipe):
        plain = sp.Symbol(name, real=True)
        if is_inverse:
            inverse.setdefault(plain, 1 / sym)
        else:
            inverse[plain] = sym
        names.setdefault(name, plain)
    outputs = []
    for key, spec in specs.items():
        expr = to_expression(spec.expression, f"events[{key!r}]", names).xreplace(inverse)
        unknown = sorted(str(s) for s in expr.free_symbols - set(state) - set(params))
        if unknown:
            raise InputError(
                f"`events[{key!r}]` reads {unknown}, which are neither components of the state ({labels}) nor "
                f"parameters of {problem.name}."
            )
        outputs.append(expr)
    return _compiled(specs, outputs, state, params)


def _compiled(specs: Mapping[str, Event], outputs: list, state: tuple, params: tuple) -> CompiledEvents:
    """The event formulas ``outputs`` (one per spec, in the state's and the parameters' symbols) as one compiled
    model function ``event`` (its output as long as the state: zeros past the events), and its address."""
    if len(outputs) > len(state):
        raise InputError(f"At most {len(state)} events (the state's dimension) in one run, got {len(outputs)}.")
    outputs = list(outputs) + [sp.Integer(0)] * (len(state) - len(outputs))
    source = kernel_source([FunctionSpec("event", (outputs,), tuple(state), parameters=tuple(params))])
    module = _codegen.compiled_module(source, "ev")
    return CompiledEvents(
        tuple(specs),
        int(module.addresses(("event",))[F_EVENT]),
        np.array([float(s.direction) for s in specs.values()]),
        np.array([float(s.terminal) for s in specs.values()]),
        module.event,
    )


def events_need_adaptive(name: str) -> str:
    return (
        f"`events` of {name} are located on the continuous extension of an adaptive method: BKMM, LagrangeDAlembert "
        "(compiled, or stepped by scipy's solvers) or NonholonomicHamilton; the discrete Lagrange-d'Alembert map has "
        "none."
    )


def compile_lagrangian_events(setup: Any, made: Any, slots: list[str | None], events: Any) -> CompiledEvents:
    """The events of a Lagrangian system run by a compiled loop (BKMM or Lagrange-d'Alembert), whose state's entries
    are named by ``slots`` (None for one no formula reads: the work; "t" the time) and whose ``prm`` holds the
    system's parameters, the numbers of the gait and torques, then their coefficients: formulas in the state's
    entries, every shape and its rate (a prescribed shape's from its gait), ``t``, the parameters and the
    coefficients. Made once per set-up (a prepared problem's runs share it), events and layout of the state."""
    from ..systems.gait import T_SYMBOL

    memo = getattr(setup, "compiled", None)
    made_key: tuple = ("events", id(events), made.equations, tuple(slots), made.parameters, len(made.constants))
    made_key += (made.coefficients,)
    if memo is not None and made_key in memo:
        return memo[made_key]
    specs = _specs(events)
    system = setup.system
    state = tuple(sp.Symbol(f"_y{i}", real=True) for i in range(len(slots)))
    names: dict[str, Any] = {name: sym for name, sym in zip(slots, state) if name is not None}
    t = names["t"]
    k = system.k
    for j, i in enumerate(setup.prescribed):
        form = setup.gait_forms[j].xreplace({T_SYMBOL: t})
        names[system.q[k + i].name] = form
        names[system.qdot[k + i].name] = sp.diff(form, t)
    prm = [sp.Symbol(name, real=True) for name in made.parameters]
    prm += [sp.Symbol(f"_constant{i}", real=True) for i in range(len(made.constants))]
    prm += [sp.Symbol(name, real=True) for name in made.coefficients]
    by_name = {s.name: s for s in prm if not s.name.startswith("_constant")}
    outputs = []
    for key, spec in specs.items():
        parsed = to_expression(spec.expression, f"events[{key!r}]", {**by_name, **{n: sp.Symbol(n) for n in names}})
        expr = parsed.xreplace({sp.Symbol(n): v for n, v in names.items()})
        expr = expr.xreplace({s: by_name[s.name] for s in expr.free_symbols if s.name in by_name})
        unknown = sorted(str(s) for s in expr.free_symbols - set(state) - set(prm))
        if unknown:
            raise InputError(
                f"`events[{key!r}]` reads {unknown}, which are neither the {made.equations} state of {system.name} "
                f"({', '.join(sorted(names))}) nor its parameters or the gait's coefficients."
            )
        outputs.append(expr)
    compiled = _compiled(specs, outputs, state, tuple(prm))
    if memo is not None:  # (the set-up holds its events: their id is theirs while it lives)
        memo[made_key] = compiled
    return compiled


def stepped_lagrangian_events(
    setup: Any, events: Any, values: Mapping[str, float], shown: Callable[[float, np.ndarray], np.ndarray]
) -> StepEvents:
    """The events of a Lagrangian system stepped from Python (scipy's solvers: BKMM and Lagrange-d'Alembert in
    Python, the Hamiltonian forms), as :class:`~._adaptive.StepEvents` of the run's state y: formulas in ``t``, the
    coordinates and velocities by name (``shown(t, y)`` gives ``(q, qdot)``), the system's parameters and the
    coefficients whose ``values`` are given."""
    from ..symbolic.compile import compile_scalar
    from ..systems.gait import T_SYMBOL

    specs = _specs(events)
    system = setup.system
    local: dict[str, Any] = {s.name: s for s in (*system.q, *system.qdot)}
    local["t"] = T_SYMBOL
    known = {**{k: float(v) for k, v in system.parameters.items()}, **{k: float(v) for k, v in values.items()}}
    variables = [T_SYMBOL, *system.q, *system.qdot]
    fns = []
    for key, spec in specs.items():
        e = to_expression(spec.expression, f"events[{key!r}]", local)
        e = e.xreplace({s: local[s.name] for s in e.free_symbols if s.name in local})
        e = e.xreplace({s: known[s.name] for s in e.free_symbols if s.name in known and s not in variables})
        unknown = sorted(str(s) for s in e.free_symbols - set(variables))
        if unknown:
            raise InputError(
                f"`events[{key!r}]` reads {unknown}, which are neither t, the coordinates and velocities of "
                f"{system.name} ({', '.join(n for n in local if n != 't')}) nor its parameters or coefficients given "
                "in `parameters`."
            )
        fns.append(compile_scalar(e, variables))

    def g(t: float, y: np.ndarray) -> np.ndarray:
        tx = np.r_[t, shown(t, y)]
        return np.array([float(f(tx)) for f in fns])

    return StepEvents(
        g,
        np.array([float(s.direction) for s in specs.values()]),
        np.array([float(s.terminal) for s in specs.values()]),
        tuple(specs),
    )


def event_table(
    events: CompiledEvents, EVT: np.ndarray, ECOUNT: np.ndarray, timed: bool, max_events: int
) -> dict[str, np.ndarray]:
    """Solution.events for the recorded rows: for each event a table of rows ``(trajectory, t, state...)`` in time
    order; raises when a trajectory had more events than ``max_events``."""
    counts = ECOUNT.astype(int)
    if counts.size and counts.max() > max_events:
        b = int(np.argmax(counts))
        raise InputError(
            f"Trajectory {b} had {counts[b]} events, more than `max_events` = {max_events}; raise it, or make the "
            "events rarer (a direction, a terminal event)."
        )
    rows: dict[str, list[np.ndarray]] = {name: [] for name in events.names}
    for b, c in enumerate(counts):
        for r in EVT[b, :c]:
            state = r[2:-1] if timed else r[2:]
            rows[events.names[int(r[0])]].append(np.r_[b, r[1], state])
    width = EVT.shape[2] - (1 if timed else 0)
    return {k: (np.array(v) if v else np.zeros((0, width))) for k, v in rows.items()}
