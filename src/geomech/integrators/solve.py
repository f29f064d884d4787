"""``solve(system, method, ...)``: one entry point for every integrator (as diffrax's ``diffeqsolve``)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from .._storage import remember
from ..errors import InputError
from . import _codegen
from ._events import compile_events
from ._prepared import Prepared, group_start
from ._problem import Problem, make_problem
from ._times import DEFAULT_SAVEAT, time_grid
from ._times import tolerances as method_tolerances
from ._variational import sensitivity_names, variational_module
from .methods import (
    REGISTRY,
    RK4,
    AdamsBashforthMoulton4,
    AdaptiveAdams,
    DormandPrince,
    IncompatibleMethodError,
    Kind,
    Method,
    SolveIVP,
    Taylor,
    get_method,
)
from .solution import Solution

__all__ = ["solve", "prepare", "Prepared", "compatible_methods", "methods_for", "DEFAULT_SAVEAT"]


def compatible_methods(system: Any, *, attitude: bool = False) -> list[str]:
    """Keys of the registered methods that can integrate ``system``."""
    problem = make_problem(system, attitude=attitude)
    return [k for k, m in REGISTRY.items() if _why_not(problem, m) is None]


def methods_for(system: Any, *, attitude: bool = False) -> list[dict[str, Any]]:
    """Every registered method's traits (as :func:`~geomech.integrators.methods_table`) with, for ``system``,
    ``fits`` (bool) and ``why_not`` (the reason a method does not apply, or None): what ``solve`` would accept
    and refuse, without running anything."""
    problem = make_problem(system, attitude=attitude)
    out = []
    for m in REGISTRY.values():
        why = _why_not(problem, m)
        out.append({**m.describe(), "fits": why is None, "why_not": why})
    return out


def _why_not(problem: Problem, method: Method) -> str | None:
    if not problem.has(method.structure):
        return problem.missing[method.structure]
    if method.needs_expression and problem.expression is None:
        return f"{type(method).__name__} differentiates H symbolically, and {problem.name} has no formula"
    return None


def _check_compatible(problem: Problem, method: Method) -> None:
    why = _why_not(problem, method)
    if why is None:
        return
    fits = [k for k, m in REGISTRY.items() if _why_not(problem, m) is None]
    raise IncompatibleMethodError(
        f"{method!r} needs a system with structure '{method.structure.value}', and {problem.name} "
        f"({type(problem.system).__name__}) does not have it: {why}. Methods that apply to this system: "
        f"{', '.join(fits)}."
    )


def solve(
    system: Any,
    method: Any,
    *,
    t_final: float,
    h: float | None = None,
    saveat: Any = None,
    rtol: float | None = None,
    atol: float | None = None,
    t0: float = 0.0,
    y0: Any = None,
    m0: Any = None,
    R0: Any = None,
    q0: Any = None,
    qdot0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    Gamma0: Any = None,
    gamma0: Any = None,
    g0: Any = None,
    shapes: Any = None,
    tau: Any = None,
    parameters: Any = None,
    max_steps: int = V.MAX_STEPS,
    max_evaluations: int | None = None,
    memory_limit: float = V.MEMORY_LIMIT,
    newton_tol: float = 1e-14,
    max_newton: int = 20,
    raise_on_failure: bool = True,
    backend: str = "auto",
    threads: int | None = None,
    sensitivities: Any = None,
    events: Any = None,
    max_events: int = 1000,
) -> Solution:
    """Integrate ``system`` with ``method`` from ``t0`` to ``t_final``.

    Times are given one way, as in diffrax: the end ``t_final`` (before ``t0`` integrates backwards), the
    output times ``saveat``, and the step ``h`` for a fixed-step method or the tolerances ``rtol``/``atol``
    for an adaptive one (an exact propagator takes neither). A method's kind is ``method.kind``. Runs of one
    problem from many starts or parameter values (an optimiser's, a Monte Carlo loop's) :func:`prepare` it once
    and call :meth:`Prepared.solve` for each: ``solve`` is ``prepare(...).solve(...)``, and keeps the last few
    problems it prepared for a system (by their options' values: numbers, strings, arrays, formulas, methods; a
    function by identity), so that ``solve`` called in a loop with the same options prepares once too.

    Parameters
    ----------
    system : CanonicalSystem, LeftInvariantSystem, RigidBody, RotorBody, NonholonomicSystem, ...
        A canonical system takes its initial state as ``y0 = (q, p)``; a left-invariant system as ``m0``
        and, to integrate the attitude as well (and get the spatial momentum ``p = R m``), ``R0``; a body
        with rotors as ``m0`` and ``Gamma0`` (with ``R0`` and ``gamma0`` optional); a Lagrangian system on
        G x S (with constraints or none) as ``q0`` with ``qdot0``, ``rdot0`` or ``p0``; a body velocity on a
        group (:class:`~geomech.systems.GroupFlow`, the reconstruction equation) as ``g0``.
    method : Method or str
        A method value (``GaussLegendre(3)``, ``LiePoissonSplitting(order=4)``, ``BKMM()``, ...) or a
        registry key (``"implicit_midpoint"``, see :data:`~geomech.integrators.REGISTRY`). An incompatible
        pair raises :class:`~geomech.integrators.IncompatibleMethodError` before any work, naming the
        methods that fit.
    t_final : float
        The end of the integration; for a fixed-step method ``t_final - t0`` is a whole number of steps.
    h : float
        The step of a fixed-step method.
    saveat : int or array_like, optional
        The output times: a number of equally spaced times from ``t0`` to ``t_final``, or the times
        themselves (for a fixed-step method, on its grid ``t0 + k h``). Default: every step of a fixed-step
        method, :data:`DEFAULT_SAVEAT` times otherwise.
    rtol, atol : float, optional
        Tolerances of an adaptive method (default: the method's ``default_tolerances``).
    t0 : float
    y0, m0 : array_like, shape (..., d) or (..., 3)
        Initial state(s); leading axes are a batch, integrated in one call.
    R0 : array_like, shape (..., 3, 3), optional
        Initial attitude(s), body to space; broadcast against ``m0``.
    q0, qdot0, rdot0, p0 :
        The initial state of a Lagrangian system: coordinates, and velocities given as all of them
        (``qdot0``), or as the shape rates with the nonholonomic momentum (``rdot0``, ``p0``); see
        :func:`~geomech.integrators.initial_state`. ``q0``, ``rdot0`` and ``p0`` given as arrays with leading
        axes (``(..., n)``, ``(..., sigma)``, ``(..., m)``) are a batch (BKMM, compiled).
    Gamma0, gamma0 : array_like, shape (..., N)
        A body with rotors: the rotors' axial momenta and angles (default 0); broadcast against ``m0`` and
        ``R0`` (default the identity). Every method for an ODE applies; with a torque law given by formulas (none,
        a :class:`~geomech.Gait` of formulas, a :class:`~geomech.StructurePreservingControl` with a formula for
        phi) the equations compile, their Jacobian too for the implicit methods; a law of Python code runs the
        explicit methods in Python.
    g0 : array_like
        A body velocity on a group (:class:`~geomech.systems.GroupFlow`): the initial element, an ``(N, N)``
        matrix, or its chart coordinates ``(k,)`` (angles then unwrapped from their given values).
    shapes, tau : optional
        A Lagrangian system's prescribed shapes (``{"psi": "sin(2*pi*t)"}`` or a :class:`~geomech.Gait`)
        and the torques on its free shapes (a mapping of formulas in ``t``, the coordinates and velocities, or
        of callables; or open-loop torques in time as a :class:`~geomech.Gait`, the same type as the shapes);
        formulas may hold named coefficients (``"a*sin(w*t + c)"``) whose values are given in ``parameters``;
        the rotor torques of a body with rotors (a :class:`~geomech.Gait` in time, a callable
        ``u(t, R, m, gamma, Gamma)`` or a feedback law such as a :class:`~geomech.StructurePreservingControl`).
    parameters : mapping, optional
        Values of a Lagrangian system's parameters not stored in it, and of the coefficients of its gait's and
        torques' formulas, a number or an array for each: arrays (their broadcast shape, with the initial states'
        batch) make a batch of trajectories in one call of the compiled BKMM loop, across ``threads`` (a gait
        ensemble: ``{"a": amplitudes, "c": phases}``); for a canonical or left-invariant system
        built from a formula with named parameters, or a body with rotors of a named layout (``lambda1``,
        ``J1``, ...) under a torque law of formulas, values for this run, a number or an array for each: the
        arrays' broadcast shape is a batch of trajectories (broadcast with the initial states' batch), all of
        them in one compiled call (``Solution.parameters`` then holds the arrays, batch-shaped).
    max_steps : int
        Ceiling on steps times trajectories of a fixed-step method (default 1e9, tens of seconds to minutes
        of compiled work): a larger run is refused before it starts, with its estimated cost.
    max_evaluations : int
        Ceiling on right-hand-side evaluations of an adaptive method, per trajectory: a run that reaches it
        stops with the status ``budget_exhausted``, its states so far kept. Default 200,000 where the
        equations are evaluated in Python (then a run projected far above it is refused after a short pilot),
        and 10^8 for the compiled Dormand-Prince pairs (seconds of compiled work).
    memory_limit : float
        Ceiling in bytes (default 2 GiB) on the saved states: more is refused before any allocation.
    newton_tol : float
        Implicit methods: Newton stops when its correction (or the error its contraction rate predicts) is
        below ``newton_tol * max(1, |y|)``.
    max_newton : int
        Newton iterations allowed per step before the step is declared failed.
    raise_on_failure : bool
        Raise :class:`~geomech.errors.ConvergenceError` (Newton, adaptive solver) or
        :class:`~geomech.errors.NumericalError` (non-finite state, singular equations, exhausted budget) when
        a trajectory fails; the exception's ``solution`` attribute holds the partial result. With False,
        failures are reported in ``Solution.status`` and ``Solution.failures`` only.
    backend : {"auto", "numba", "python"}
        ``"auto"`` compiles the loops with numba for systems given by a formula and runs them as Python
        otherwise.
    threads : int, optional
        Threads over the batch (compiled loops release the GIL); default: the number of CPUs.
    sensitivities : True or sequence of str, optional
        Integrate the variational equations with the state (a canonical or left-invariant system, or a body
        with rotors, given by formulas; an explicit method: ``rk4``, ``abm4``, ``dop853``, ``dopri5``, ``adams``,
        ``solve_ivp``): True gives the state transition matrix ``dy(t)/dy(t0)`` as the quantity ``stm``
        (``(..., n_save, d, d)``), names of parameters add ``parameter_sensitivity``, ``dy(t)/dp``
        (``(..., n_save, d, k)``, a column per name in the given order). The error control of an adaptive method
        covers them too. For a Lagrangian system, with ``BKMM`` compiled (DOP853 or RK45): d is that of the BKMM
        state ``(g, r_F, rdot_F, p, W)`` (group coordinates, free shapes and their rates, momenta, work), and the
        names are the system's parameters and the gait's and torques' coefficients (the derivatives of the
        generated equations by forward differentiation of their straight-line code).
    events : mapping of str to formula or :class:`~geomech.integrators.Event`, optional
        Zeros of functions of the state to locate (``dop853``, ``dopri5`` or ``taylor``, compiled, or scipy's
        solvers through ``solve_ivp``; a canonical or left-invariant system, or a body with rotors, given by
        formulas): each a formula in the state's components,
        by the names of ``Solution.labels`` (and ``t`` where a torque law reads the time), and the system's
        parameters, e.g. ``{"apex": Event("m1", direction=-1)}``. For a Lagrangian system, with ``BKMM`` or
        ``LagrangeDAlembert`` compiled: formulas in the group coordinates, the shapes and their rates (a prescribed
        shape's from its gait), with BKMM the momenta ``p0, p1, ...``, with Lagrange-d'Alembert the group
        velocities, ``t``, the parameters and the gait's coefficients (``Event("psi", direction=1)``: the gait back
        at its start); stepped by scipy's solvers (``backend="python"``, a solver without a compiled twin, or
        ``NonholonomicHamilton``), formulas in every coordinate and velocity by name, ``t``, the parameters and the
        coefficients. Each zero is found on the continuous extension (Taylor's method: the polynomial) of the step
        that crosses it, to the accuracy of the run, and is reported in ``Solution.events[name]`` as a row
        ``(trajectory, t, state...)``. A terminal event ends its trajectory at its first zero (the saved states
        after it are NaN, the run a success).
    max_events : int
        Events recorded per trajectory (more is an error naming it).

    Returns
    -------
    Solution
    """
    options = dict(
        t_final=t_final,
        h=h,
        saveat=saveat,
        rtol=rtol,
        atol=atol,
        t0=t0,
        attitude=R0 is not None,
        shapes=shapes,
        tau=tau,
        max_steps=max_steps,
        max_evaluations=max_evaluations,
        memory_limit=memory_limit,
        newton_tol=newton_tol,
        max_newton=max_newton,
        raise_on_failure=raise_on_failure,
        backend=backend,
        threads=threads,
        sensitivities=sensitivities,
        events=events,
        max_events=max_events,
    )
    return _prepared(system, method, options).solve(
        y0=y0,
        m0=m0,
        R0=R0,
        q0=q0,
        qdot0=qdot0,
        rdot0=rdot0,
        p0=p0,
        Gamma0=Gamma0,
        gamma0=gamma0,
        g0=g0,
        parameters=parameters,
    )


#: The problems :func:`solve` prepared for a system, kept on it (``_Kept``, under this name): the last ``_KEPT`` by
#: their arguments, so that ``solve`` called in a loop with the same options pays :func:`prepare` once, as a prepared
#: problem's caller does.
_ATTRIBUTE = "_solve_prepared"
_KEPT = 8
#: Arrays and outputs up to this many numbers are remembered with a problem (a longer one is prepared each time).
_KEPT_SIZE = 100_000
_NONE = object()
_SCALARS = frozenset((bool, int, float, str, np.bool_, np.int64, np.float64))


def _prepared(system: Any, method: Any, options: dict[str, Any]) -> Prepared:
    """``prepare(system, method, **options)``, or the problem it made for the same arguments earlier: arguments
    whose values are data (numbers, strings, small arrays, formulas, methods and other frozen values, mappings and
    sequences of them) compared by value, functions and feedback laws by identity; anything else (a mapping of
    another type, an array of objects) is prepared afresh at every call."""
    parts = [_plain(method)]  # (the options in solve's order: their values alone)
    for value in options.values():
        parts.append(_plain(value))
    if _NONE in parts:
        return prepare(system, method, **options)
    try:
        attributes = vars(system)
    except TypeError:  # an object without attributes of its own: prepared each time
        return prepare(system, method, **options)
    kept = attributes.get(_ATTRIBUTE)
    key = tuple(parts)
    found = kept.get(key) if kept is not None else None
    if found is not None:
        return found
    made = prepare(system, method, **options)
    if made.times.n_saved <= _KEPT_SIZE:  # (the count: the times themselves are made when first asked)
        # on the system itself (a frozen value: its attributes' dictionary), where a dictionary of this module's
        # would keep alive every system it met (a problem holds its system); gone with the system
        remember(attributes.setdefault(_ATTRIBUTE, _Kept()), key, made, _KEPT)  # (the oldest goes first)
    return made


class _Kept(dict):
    """The problems :func:`solve` prepared for one system: not copied or pickled with it (a copy starts empty)."""

    def __reduce__(self) -> tuple:
        return (_Kept, ())


def _plain(value: Any) -> Any:
    """A hashable stand-in for an argument of :func:`prepare`, equal only for arguments of the same types and
    values; ``_NONE`` where the argument is not data whose value a later call can trust to be unchanged."""
    kind = type(value)
    if kind in _SCALARS:
        return (kind, value)
    if value is None:
        return None
    if kind is np.ndarray:
        if value.size > _KEPT_SIZE or value.dtype.kind not in "biuf":
            return _NONE
        return (kind, value.dtype.str, value.shape, value.tobytes())
    if kind is tuple or kind is list:
        items = tuple([_plain(v) for v in value])
        return _NONE if _NONE in items else (kind, items)
    if kind is dict:
        pairs = tuple([(_plain(k), _plain(v)) for k, v in value.items()])
        return _NONE if any(k is _NONE or v is _NONE for k, v in pairs) else (kind, pairs)
    if isinstance(value, sp.Basic):  # a formula: immutable
        return (sp.Basic, value)
    params = getattr(kind, "__dataclass_params__", None)
    if params is not None and params.frozen:  # a method, a gait, an event, a control law: frozen values
        fields = tuple(_plain(getattr(value, f.name)) for f in dataclasses.fields(value))
        if any(f is _NONE for f in fields):
            return _NONE
        # compared by their fields; one compared by identity is held by the key too (its id never reused)
        return (kind, None if params.eq else value, fields)
    if callable(value) or hasattr(value, "feedback"):
        # a function, a feedback law: the problem holds it and calls it at run time (as a prepared problem does),
        # so it is the same object that matters; the key holds it (its id never reused)
        return (object, value)
    return _NONE


def prepare(
    system: Any,
    method: Any,
    *,
    t_final: float,
    h: float | None = None,
    saveat: Any = None,
    rtol: float | None = None,
    atol: float | None = None,
    t0: float = 0.0,
    attitude: bool = False,
    shapes: Any = None,
    tau: Any = None,
    max_steps: int = V.MAX_STEPS,
    max_evaluations: int | None = None,
    memory_limit: float = V.MEMORY_LIMIT,
    newton_tol: float = 1e-14,
    max_newton: int = 20,
    raise_on_failure: bool = True,
    backend: str = "auto",
    threads: int | None = None,
    sensitivities: Any = None,
    events: Any = None,
    max_events: int = 1000,
) -> Prepared:
    """:func:`solve`'s first half: ``system`` and ``method`` with everything but the initial state and the
    parameters' values, checked and made ready once (the method against the system, the times, the torque law,
    the compiled model and events), for many runs from different starts or with different parameters
    (``prepared.solve(m0=...)``), as heyoka's integrator object is built once and propagated many times.
    ``solve(system, method, ..., m0=m0)`` is ``prepare(system, method, ...).solve(m0=m0)``: the same checks and
    the same run.

    The arguments are :func:`solve`'s, less the initial states and ``parameters``, plus ``attitude``: True to
    integrate a left-invariant system's or a body with rotors' attitude (:func:`solve` sets it where ``R0`` is
    given; each :meth:`Prepared.solve` then takes ``R0``). A Lagrangian system's gait and torques are checked at
    the first call (their coefficients' values come with it), and made into functions once per distinct values.

    Returns
    -------
    Prepared
    """
    method = get_method(method)
    if backend not in ("auto", "numba", "python"):
        raise InputError(f"Expected `backend` to be 'auto', 'numba' or 'python', got {backend!r}.")
    if not isinstance(attitude, (bool, np.bool_)):
        raise InputError(f"Expected `attitude` to be True or False, got {attitude!r}.")
    problem = make_problem(system, attitude=bool(attitude))
    _check_compatible(problem, method)
    if isinstance(max_events, bool) or not isinstance(max_events, (int, np.integer)) or max_events < 1:
        raise InputError(f"Expected `max_events` to be a positive integer, got {max_events!r}.")
    times = time_grid(method, t0, t_final, h, saveat, rtol, atol)
    newton_tol = V.positive_scalar(newton_tol, "newton_tol")
    if isinstance(max_newton, bool) or not isinstance(max_newton, (int, np.integer)) or max_newton < 1:
        raise InputError(f"Expected `max_newton` to be a positive integer, got {max_newton!r}.")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1):
        raise InputError(f"Expected `threads` to be a positive integer or None, got {threads!r}.")
    tolerances = method_tolerances(method, rtol, atol) if method.kind is Kind.ADAPTIVE else None
    lagrangian: Any = None
    compiled_events: Any = None
    wrt: tuple[str, ...] | None = None
    module: Any = None
    used = "python"
    constants = None
    if problem.kind == "group":
        for name, value in (("shapes", shapes), ("tau", tau), ("events", events)):
            if value is not None:
                raise InputError(group_start(problem, system, name))
    elif problem.kind == "lagrangian":
        from .nonholonomic._solve import PreparedLagrangian

        lagrangian = PreparedLagrangian(
            system,
            method,
            times,
            t0=float(t0),
            shapes=shapes,
            tau=tau,
            tolerances=tolerances,
            max_steps=max_steps,
            max_evaluations=max_evaluations,
            memory_limit=memory_limit,
            newton_tol=newton_tol,
            max_newton=int(max_newton),
            backend=backend,
            threads=threads,
            events=events,
            max_events=int(max_events),
            sensitivities=sensitivities,
        )
    else:
        if shapes is not None:
            raise InputError(f"`shapes` applies to Lagrangian systems on G x S; {problem.name} is not one.")
        if problem.kind == "rotor":
            from ._rotor import bind_torque

            problem = bind_torque(problem, tau)
            if problem.model_expression is None and "fjac" in _codegen.model_functions(method.kernel or ""):
                raise IncompatibleMethodError(
                    f"{method!r} solves implicit equations with their Jacobian, and the torque law of "
                    f"{problem.name} is Python code without one: give the torques as formulas (a Gait from "
                    "expressions, a StructurePreservingControl with a formula for phi), or take an explicit "
                    "method (rk4, dop853, solve_ivp)."
                )
        elif tau is not None:
            raise InputError(
                f"`tau` applies to Lagrangian systems on G x S and bodies with rotors; {problem.name} is neither."
            )
        wrt = sensitivity_names(problem, sensitivities)
        explicit = (RK4, AdamsBashforthMoulton4, DormandPrince, SolveIVP, AdaptiveAdams)
        if wrt is not None and not isinstance(method, explicit):
            raise IncompatibleMethodError(
                f"`sensitivities` integrates the variational equations with an explicit method (rk4, abm4, "
                f"dop853, dopri5, adams, solve_ivp); {method!r} is not one."
            )
        if wrt is not None:
            module, used = variational_module(problem, wrt, backend)
        else:
            module, used = problem.module(frozenset(method.features & {"gf", "split", "taylor"}), backend)
        if isinstance(method, Taylor) and used != "numba":
            raise InputError(
                f"Taylor's method runs compiled, from the formulas of a system (numba installed, backend 'auto' "
                f"or 'numba'); {problem.name} has no compiled model here."
            )
        if events is not None:
            if wrt is not None:
                raise InputError("`events` and `sensitivities` are not taken together; run them apart.")
            if not isinstance(method, (DormandPrince, Taylor, SolveIVP)):
                raise IncompatibleMethodError(
                    f"`events` are located by the continuous extension of the compiled embedded pairs (dop853, "
                    f"dopri5), on the steps' polynomials of Taylor's method (taylor), or on the dense output of "
                    f"scipy's solvers (solve_ivp); {method!r} is not one of them."
                )
            compiled_events = compile_events(problem, events, used)
        if method.kind is Kind.FIXED_STEP:
            constants = np.ascontiguousarray(method.constants(problem), dtype=float)
    return Prepared(
        system=system,
        method=method,
        problem=problem,
        times=times,
        t0=float(t0),
        t_final=float(t_final),
        attitude=bool(attitude),
        backend=backend,
        tolerances=tolerances,
        newton_tol=newton_tol,
        max_newton=int(max_newton),
        threads=threads,
        max_events=int(max_events),
        max_steps=max_steps,
        max_evaluations=max_evaluations,
        memory_limit=memory_limit,
        raise_on_failure=raise_on_failure,
        lagrangian=lagrangian,
        compiled_events=compiled_events,
        wrt=wrt,
        constants=constants,
        module=module,
        used=used,
    )
