"""``solve(system, method, ...)``: one entry point for every integrator (as diffrax's ``diffeqsolve``)."""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import ConvergenceError, InputError, NumericalError
from . import _codegen
from ._adaptive import MAX_EVALUATIONS, MAX_EVALUATIONS_COMPILED, run_adaptive
from ._batch import batch_index, initial_states, left_chart, parameter_batch
from ._events import compile_events, event_table
from ._problem import Problem, make_problem
from ._runners import INFO_COLUMNS, run_atlas, run_compiled, run_embedded, run_ivp, run_periodic, run_taylor
from ._times import DEFAULT_SAVEAT, time_grid
from ._times import tolerances as method_tolerances
from ._variational import augment, sensitivity_names, split, variational_module
from .methods import (
    REGISTRY,
    RK4,
    AdamsBashforthMoulton4,
    AdaptiveAdams,
    DormandPrince,
    IncompatibleMethodError,
    Kind,
    Method,
    PeriodicOrbit,
    Quadrature,
    SerretAndoyerAtlas,
    SolveIVP,
    Taylor,
    get_method,
)
from .solution import STATUS, Failure, Solution, Status, run_stats

__all__ = ["solve", "prepare", "Prepared", "compatible_methods", "methods_for", "DEFAULT_SAVEAT"]

#: The cores a batch is spread over by default (read once: ``os.cpu_count`` reads the system's files each time).
CORES = os.cpu_count() or 1


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
    and call :meth:`Prepared.solve` for each: ``solve`` is ``prepare(...).solve(...)``.

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
    return prepare(
        system,
        method,
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
    ).solve(
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
    return Prepared(
        system,
        method,
        t_final=t_final,
        h=h,
        saveat=saveat,
        rtol=rtol,
        atol=atol,
        t0=t0,
        attitude=attitude,
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


class Prepared:
    """A system and a method made ready to solve, with the times, the tolerances and the options, made by
    :func:`prepare` (which takes the arguments this class does); :meth:`solve` runs it from an initial state with
    the parameters' values. Reusable and independent of earlier calls: each call is the run :func:`solve` makes
    with the same arguments."""

    def __init__(self, system: Any, method: Any, **options: Any) -> None:
        method = get_method(method)
        backend = options["backend"]
        if backend not in ("auto", "numba", "python"):
            raise InputError(f"Expected `backend` to be 'auto', 'numba' or 'python', got {backend!r}.")
        attitude = options["attitude"]
        if not isinstance(attitude, (bool, np.bool_)):
            raise InputError(f"Expected `attitude` to be True or False, got {attitude!r}.")
        problem = make_problem(system, attitude=bool(attitude))
        _check_compatible(problem, method)
        max_events, max_newton, threads = options["max_events"], options["max_newton"], options["threads"]
        if isinstance(max_events, bool) or not isinstance(max_events, (int, np.integer)) or max_events < 1:
            raise InputError(f"Expected `max_events` to be a positive integer, got {max_events!r}.")
        rtol, atol = options["rtol"], options["atol"]
        self.times = time_grid(method, options["t0"], options["t_final"], options["h"], options["saveat"], rtol, atol)
        self.t0 = float(options["t0"])
        self.newton_tol = V.positive_scalar(options["newton_tol"], "newton_tol")
        if isinstance(max_newton, bool) or not isinstance(max_newton, (int, np.integer)) or max_newton < 1:
            raise InputError(f"Expected `max_newton` to be a positive integer, got {max_newton!r}.")
        if threads is not None and (
            isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1
        ):
            raise InputError(f"Expected `threads` to be a positive integer or None, got {threads!r}.")
        self.system, self.method, self.attitude, self.backend = system, method, bool(attitude), backend
        self.max_newton, self.threads, self.max_events = int(max_newton), threads, int(max_events)
        self.max_steps, self.max_evaluations = options["max_steps"], options["max_evaluations"]
        self.memory_limit, self.raise_on_failure = options["memory_limit"], options["raise_on_failure"]
        self.t_final = float(options["t_final"])
        self.tolerances = method_tolerances(method, rtol, atol) if method.kind is Kind.ADAPTIVE else None
        self.lagrangian: Any = None
        self.compiled_events: Any = None
        self.wrt: tuple[str, ...] | None = None
        self.module: Any = None
        self.used = "python"
        shapes, tau, events = options["shapes"], options["tau"], options["events"]
        self.events = events
        if problem.kind == "group":
            for name, value in (("shapes", shapes), ("tau", tau), ("events", events)):
                if value is not None:
                    raise InputError(_group_start(problem, system, name))
        elif problem.kind == "lagrangian":
            from .nonholonomic._solve import PreparedLagrangian

            self.lagrangian = PreparedLagrangian(
                system,
                method,
                self.times,
                t0=self.t0,
                shapes=shapes,
                tau=tau,
                tolerances=self.tolerances,
                max_steps=self.max_steps,
                max_evaluations=self.max_evaluations,
                memory_limit=self.memory_limit,
                newton_tol=self.newton_tol,
                max_newton=self.max_newton,
                backend=backend,
                threads=threads,
                events=events,
                max_events=self.max_events,
                sensitivities=options["sensitivities"],
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
            self.wrt = sensitivity_names(problem, options["sensitivities"])
            if self.wrt is not None and not isinstance(
                method, (RK4, AdamsBashforthMoulton4, DormandPrince, SolveIVP, AdaptiveAdams)
            ):
                raise IncompatibleMethodError(
                    f"`sensitivities` integrates the variational equations with an explicit method (rk4, abm4, "
                    f"dop853, dopri5, adams, solve_ivp); {method!r} is not one."
                )
            if self.wrt is not None:
                self.module, self.used = variational_module(problem, self.wrt, backend)
            else:
                self.module, self.used = problem.module(frozenset(method.features & {"gf", "split", "taylor"}), backend)
            if isinstance(method, Taylor) and self.used != "numba":
                raise InputError(
                    f"Taylor's method runs compiled, from the formulas of a system (numba installed, backend 'auto' "
                    f"or 'numba'); {problem.name} has no compiled model here."
                )
            if events is not None:
                if self.wrt is not None:
                    raise InputError("`events` and `sensitivities` are not taken together; run them apart.")
                if not isinstance(method, (DormandPrince, Taylor, SolveIVP)):
                    raise IncompatibleMethodError(
                        f"`events` are located by the continuous extension of the compiled embedded pairs (dop853, "
                        f"dopri5), on the steps' polynomials of Taylor's method (taylor), or on the dense output of "
                        f"scipy's solvers (solve_ivp); {method!r} is not one of them."
                    )
                self.compiled_events = compile_events(problem, events, self.used)
        self.problem = problem

    def __repr__(self) -> str:
        return (
            f"Prepared({self.problem.name}, {self.method!r}, t0={self.t0:g}, t_final={self.t_final:g}, "
            f"{len(self.times.t)} outputs)"
        )

    def solve(
        self,
        *,
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
        parameters: Any = None,
    ) -> Solution:
        """Run from the initial state(s) with the values of ``parameters``: the arguments as :func:`solve`'s (leading
        axes a batch); ``R0`` where the problem was prepared with ``attitude=True``, and only then."""
        problem, method, system, times, t0 = self.problem, self.method, self.system, self.times, self.t0
        if R0 is not None and problem.kind not in ("lie_poisson", "rotor"):
            raise InputError(
                f"`R0` applies to left-invariant systems on T*SO(3) and bodies with rotors; {problem.name} is neither."
            )
        if (R0 is not None) != self.attitude:
            raise InputError(
                f"This problem was prepared with attitude={self.attitude}: "
                + (
                    "give `R0`, the initial attitude."
                    if self.attitude
                    else "prepare it with attitude=True to give `R0`."
                )
            )
        if problem.kind != "rotor":
            for name, value in (("Gamma0", Gamma0), ("gamma0", gamma0)):
                if value is not None:
                    raise InputError(f"`{name}` applies to bodies with rotors; {problem.name} is not one.")
        if problem.kind != "group" and g0 is not None:
            raise InputError(
                f"`g0` is the start of a body velocity on a group (a GroupFlow); {problem.name} is not one"
                + (" (its group coordinates are part of `q0`)." if problem.kind == "lagrangian" else ".")
            )
        if problem.kind == "group":
            given = (("y0", y0), ("m0", m0), ("q0", q0), ("qdot0", qdot0), ("rdot0", rdot0), ("p0", p0))
            for name, value in given + (("parameters", parameters),):
                if value is not None:
                    raise InputError(_group_start(problem, system, name))
            from ._group_flow import solve_group_flow

            solution = solve_group_flow(
                system,
                method,
                times,
                t0=t0,
                g0=g0,
                tolerances=self.tolerances,
                max_evaluations=MAX_EVALUATIONS if self.max_evaluations is None else self.max_evaluations,
                memory_limit=self.memory_limit,
            )
            return _finish(solution, self.raise_on_failure)
        if problem.kind == "lagrangian":
            for name, value in (("y0", y0), ("m0", m0)):
                if value is not None:
                    raise InputError(
                        f"{problem.name} is a Lagrangian system: give its initial state as `q0` with `qdot0`, or "
                        f"with `rdot0` and `p0`; not `{name}`."
                    )
            solution = self.lagrangian.solve(q0=q0, qdot0=qdot0, rdot0=rdot0, p0=p0, parameters=parameters)
            return _finish(solution, self.raise_on_failure)
        for name, value in (("q0", q0), ("qdot0", qdot0), ("rdot0", rdot0), ("p0", p0)):
            if value is not None:
                raise InputError(f"`{name}` applies to Lagrangian systems on G x S; {problem.name} is not one.")
        if problem.kind == "rotor":
            if y0 is not None:
                raise InputError(
                    f"{problem.name} is a body with rotors: give its initial state as `m0` and `Gamma0` (with `R0` "
                    "and `gamma0`), not `y0`."
                )
            from ._rotor import rotor_initial_states

            Y0, batch_shape = rotor_initial_states(problem, m0, R0, Gamma0, gamma0, t0)
        else:
            Y0, batch_shape = initial_states(problem, y0, m0, R0)
        swept, swept_shape = parameter_batch(problem, method, parameters)
        if swept:
            try:
                full = np.broadcast_shapes(batch_shape, swept_shape)
            except ValueError:
                raise InputError(
                    f"Expected the batch of initial states {batch_shape} and of `parameters` {swept_shape} to "
                    "broadcast."
                ) from None
            Y0 = np.broadcast_to(Y0.reshape(batch_shape + Y0.shape[1:]), full + Y0.shape[1:]).reshape(-1, Y0.shape[1])
            Y0, batch_shape = Y0.copy(), full
            swept = {k: np.broadcast_to(v, full).reshape(-1) for k, v in swept.items()}
        wrt = self.wrt
        d_state = Y0.shape[1]
        if wrt is not None:
            Y0 = augment(Y0, len(wrt))
        B, d = Y0.shape
        if method.kind is Kind.FIXED_STEP:
            V.work_budget(
                float(B) * times.n_steps,
                float(self.max_steps),
                f"The number of steps ({times.n_steps:.3g} of {B} trajectory(ies))",
                "max_steps",
                "take a larger h or a shorter span",
                seconds_each=1e-7,
            )
        V.memory_budget(
            float(B) * times.n_kernel_saved * (d + 1),
            float(self.memory_limit),
            f"Keeping {times.n_kernel_saved:.3g} states of {B} trajectory(ies)",
            "memory_limit",
            "save fewer times (`saveat`)",
        )
        if method.kind is Kind.FIXED_STEP:
            saved_steps = times.kernel_steps()
            saved_t = t0 + float(times.h) * saved_steps.astype(float)  # type: ignore[arg-type]
        else:
            saved_t = times.t
            saved_steps = np.arange(len(saved_t))
        OUT = np.empty((B, len(saved_steps), d))
        INFO = np.zeros((B, INFO_COLUMNS))
        module, used = self.module, self.used
        if swept and used != "numba":
            raise InputError(
                f"A batch of `parameters` runs in the compiled loops, which {problem.name} cannot use here (backend "
                f"{self.backend!r}, or numba missing): give one value per parameter."
            )
        # the parameter values: one row for all trajectories, or one per trajectory for a batch of them
        PRM = problem.parameter_rows(swept) if swept else np.ascontiguousarray(problem.prm[None, :])
        compiled_events = self.compiled_events
        max_events = self.max_events
        event_rows: dict[str, np.ndarray] = {}
        if compiled_events is not None:
            V.memory_budget(
                float(B) * max_events * (d + 2),
                float(self.memory_limit),
                f"Recording {max_events} events of {B} trajectory(ies)",
                "memory_limit",
                "lower `max_events`",
            )
        tolerances, tol, max_newton, threads = self.tolerances, self.newton_tol, self.max_newton, self.threads
        compile_time = 0.0
        loop_time: float | None = None  # the compiled loop's seconds, where there is one
        t_start = time.perf_counter()
        reasons: dict[int, str] = {}
        reached: dict[int, float] = {}
        along: dict[str, np.ndarray] = {}
        switches = np.zeros((0, 4))
        if isinstance(method, SerretAndoyerAtlas):
            assert tolerances is not None
            switches, along = run_atlas(problem, method, Y0, t0, saved_t, tolerances, OUT, INFO, reasons, reached)
            internal = 0
        elif isinstance(method, SolveIVP):
            assert tolerances is not None
            budget = MAX_EVALUATIONS if self.max_evaluations is None else self.max_evaluations
            ivp_args = (module, PRM, method, Y0, t0, saved_t, tolerances, budget, OUT, INFO, reasons, reached)
            internal, EVT, ECOUNT = run_ivp(*ivp_args, compiled_events, max_events)
            if compiled_events is not None:
                event_rows = event_table(compiled_events, EVT, ECOUNT, problem.timed, max_events)
        elif isinstance(method, (DormandPrince, Taylor)):
            assert tolerances is not None
            budget = MAX_EVALUATIONS_COMPILED if self.max_evaluations is None else self.max_evaluations
            n_threads = threads if threads is not None else (CORES if B > 1 else 1)
            common = (
                Y0,
                t0,
                saved_t,
                tolerances,
                V.positive_scalar(budget, "max_evaluations"),
                OUT,
                INFO,
                reasons,
                reached,
                int(n_threads) if B > 1 else 1,
                compiled_events,
                max_events,
            )
            if isinstance(method, Taylor):
                internal, compile_time, loop_time, EVT, ECOUNT = run_taylor(
                    module, PRM, *common, system, method.compact
                )
            else:
                internal, compile_time, loop_time, EVT, ECOUNT = run_embedded(
                    module, used, system, PRM, method, *common
                )
            t_start += compile_time
            if compiled_events is not None:
                event_rows = event_table(compiled_events, EVT, ECOUNT, problem.timed, max_events)
        elif isinstance(method, AdaptiveAdams):
            assert tolerances is not None
            with np.errstate(all="ignore"):
                internal = run_adaptive(module, PRM, method, Y0, t0, saved_t, tolerances, OUT, INFO)
        elif isinstance(method, (PeriodicOrbit, Quadrature)):
            internal, compile_time = run_periodic(problem.core, method, Y0, saved_t - t0, OUT, INFO, reasons)
            t_start += compile_time
        else:
            kern = getattr(module, method.kernel)
            calls = _codegen.model_functions(method.kernel)
            P = np.ascontiguousarray(method.constants(problem), dtype=float)
            h_step, nsteps, every = float(times.h), times.n_steps, times.save_every  # type: ignore[arg-type]
            FP = module.addresses(calls) if module.ready(calls) else None
            if used == "numba" and not (FP is not None and _codegen.loaded(kern)):
                # the first call compiles (or loads numba's disk cache) the model's C functions and, once for all
                # models, the loop: timed apart on a one-step problem
                from numba.core.errors import NumbaError

                try:
                    FP = module.addresses(calls)
                    kern(
                        FP,
                        Y0[:1].copy(),
                        h_step,
                        1,
                        1,
                        np.empty((1, 2, d)),
                        np.zeros((1, 5)),
                        tol,
                        int(max_newton),
                        P,
                        PRM[:1],
                    )
                except NumbaError:
                    # a function sympy prints but numba cannot compile: the same loop in Python, from now on
                    if self.backend == "numba":
                        raise
                    module, used = problem.module(frozenset(method.features & {"gf", "split"}), "python")
                    self.module, self.used = module, used
                    kern = getattr(module, method.kernel)
                    FP = module.addresses(calls)
                compile_time = time.perf_counter() - t_start
                t_start = time.perf_counter()
            n_threads = threads if threads is not None else CORES
            if used != "numba" or B < 2 or B * nsteps < 20_000:
                n_threads = 1
            with np.errstate(all="ignore"):  # the Python backend's overflow is detected as a non-finite state
                loop_time = run_compiled(
                    kern,
                    module.addresses(calls) if FP is None else FP,
                    Y0,
                    h_step,
                    nsteps,
                    every,
                    OUT,
                    INFO,
                    tol,
                    int(max_newton),
                    P,
                    PRM,
                    int(n_threads),
                )
            internal = B * nsteps
        run_time = time.perf_counter() - t_start

        failures = []
        for b in np.flatnonzero(INFO[:, 0] != 0):
            step = int(INFO[b, 1])
            if method.kind is Kind.FIXED_STEP:
                when = t0 + (step - 1) * float(times.h)  # type: ignore[arg-type]
            elif int(b) in reached:
                when = reached[int(b)]
            else:
                when = float(saved_t[max(step - 1, 0)])
            failures.append(
                Failure(
                    kind=STATUS.get(int(INFO[b, 0]), Status.NONFINITE),
                    batch_index=batch_index(int(b), batch_shape),
                    step=step,
                    time=when,
                    residual=float(INFO[b, 2]),
                    detail=reasons.get(int(b), ""),
                )
            )
        failures += left_chart(system, OUT, INFO, saved_steps, saved_t, batch_shape)
        pick = times.pick
        if pick is not None:
            OUT = OUT[:, pick]
        if problem.timed:
            OUT = OUT[..., :-1]  # the time, appended to the state for a torque law that reads it
        states = OUT.reshape(batch_shape + OUT.shape[1:])
        variational: dict[str, np.ndarray] = {}
        if wrt is not None:
            states, variational["stm"], sensitivity = split(states, d_state, len(wrt))
            if wrt:
                variational["parameter_sensitivity"] = sensitivity
        # a batch's quantities with each member's parameters; a body with rotors under a law of formulas, compiled,
        # has its energy and torques from them (generated once), not from the body's and the law's Python
        rows = None
        if swept:
            rows = PRM.reshape(batch_shape + PRM.shape[1:])
        elif problem.kind == "rotor" and problem.energy_expression is not None and used == "numba":
            rows = np.broadcast_to(PRM[0], batch_shape + PRM.shape[1:])
        inv = problem.invariants(states, times.t, rows)
        inv.update({k: v.reshape(batch_shape + v.shape[1:]) for k, v in along.items()})
        inv.update(variational)
        status = failures[0].kind if failures else Status.SUCCESS
        name = type(method).__name__
        if failures:
            extra = f" ({len(failures)} of {B} trajectories failed)" if B > 1 else ""
            message = f"{name} on {problem.name}: {failures[0].describe()}{extra}."
            if failures[0].kind in (Status.NEWTON_FAILED, Status.SINGULAR_JACOBIAN):
                message += (
                    f" Reduce h (now {abs(float(times.h)):g}), or loosen newton_tol (now {tol:g}) / raise max_newton "  # type: ignore[arg-type]
                    f"(now {max_newton})."
                )
        elif method.kind is Kind.FIXED_STEP:
            message = f"{name}: {times.n_steps} steps of h = {abs(float(times.h)):g} from t = {t0:g}."  # type: ignore[arg-type]
        elif isinstance(method, Quadrature):
            message = (
                f"Quadrature: {len(saved_t)} outputs from t = {t0:g}, each from the time-of-flight integral along the "
                "level curve."
            )
        elif isinstance(method, PeriodicOrbit):
            message = (
                f"PeriodicOrbit: {len(saved_t)} outputs from t = {t0:g}, each from one stored period ({internal} mesh "
                "steps in all)."
            )
        elif isinstance(method, SerretAndoyerAtlas):
            message = (
                f"{name}: {len(saved_t)} outputs from t = {t0:g} to {self.t_final:g}, {len(switches)} chart switches."
            )
        else:
            message = f"{name}: {len(saved_t)} outputs from t = {t0:g} to {self.t_final:g}, {internal} internal steps."
        solution = Solution(
            t=times.t,
            states=states,
            system=system,
            method=method,
            layout=problem.layout,
            labels=problem.labels,
            quantities={k: v for k, v in inv.items() if v is not None},
            status=status,
            message=message,
            failures=tuple(failures),
            stats=run_stats(
                times.n_steps,
                internal,
                int(INFO[:, 4].sum()),
                run_time,
                n_newton=int(INFO[:, 3].sum()),
                backend=used,
                compile_time=compile_time,
                **({"chart_switches": len(switches)} if isinstance(method, SerretAndoyerAtlas) else {}),
                **({"loop_time": loop_time} if loop_time is not None and used == "numba" else {}),
            ),
            parameters={
                **dict(getattr(problem.core, "parameters", {}) or {}),
                **{k: v.reshape(batch_shape) for k, v in swept.items()},
            },
            events={"chart_switch": switches} if isinstance(method, SerretAndoyerAtlas) else event_rows,
        )
        return _finish(solution, self.raise_on_failure)


def _group_start(problem: Problem, system: Any, name: str) -> str:
    """What a body velocity on a group starts from, told to a call that gave ``name``."""
    return (
        f"{problem.name} is a body velocity on {system.group.name}: give its start as `g0` (an element or its "
        f"coordinates), not `{name}`."
    )


def _finish(solution: Solution, raise_on_failure: bool) -> Solution:
    """``solution``, or its failure raised with the partial solution attached."""
    if solution.failures and raise_on_failure:
        failing = solution.status in (Status.NEWTON_FAILED, Status.ADAPTIVE_FAILED)
        cls = ConvergenceError if failing else NumericalError
        exc = cls(solution.message + " Pass raise_on_failure=False to get the partial solution instead.")
        exc.solution = solution  # type: ignore[attr-defined]
        raise exc
    return solution
