"""A rigid body with rotors through :func:`~geomech.solve`: the open-loop equations (26) / (38) of the
Serret-Andoyer paper in :math:`(m, R, \\Gamma, \\gamma)`, driven by a torque law, as one more problem of the
solver (every method for any ODE applies, batches included), with the energy :math:`H_f`, the spatial momentum
:math:`R m` and the torques along the run.

A torque law given by formulas (none, a :class:`~geomech.systems.StructurePreservingControl` with a formula
for :math:`\\varphi`, or a :class:`~geomech.Gait` of formulas in t) makes the equations a formula: they compile
with the loops (their Jacobian too, for the implicit methods), the body's named inertias and the law's numbers
read at run time. A torque law of Python callables runs the same loops in Python (explicit methods only: the
implicit ones need the Jacobian). A law that depends on time (a gait, a callable) appends the time to the
state: the loops stay autonomous, and :func:`~geomech.solve` drops that column from the solution.
"""

from __future__ import annotations

import dataclasses
import weakref
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, NumericalError
from ..symbolic.compile import M_SYMBOLS, FunctionSpec, compile_vector, kernel_source, number_form, runtime_parameters
from ..systems.gait import T_SYMBOL, Gait
from ..systems.rotors import RotorBody, torque_function
from ._observe import OBSERVE_ALL, Observation

__all__ = ["bind_torque", "rotor_initial_states", "rotor_labels"]


def rotor_labels(n: int) -> tuple[str, ...]:
    return (
        ("m1", "m2", "m3")
        + tuple(f"R{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
        + tuple(f"Gamma{i + 1}" for i in range(n))
        + tuple(f"gamma{i + 1}" for i in range(n))
    )


def _state_symbols(n: int, timed: bool) -> tuple[sp.Symbol, ...]:
    R = sp.symbols("r0:9", real=True)
    Gam = sp.symbols(f"Gamma1:{n + 1}", real=True)
    gam = sp.symbols(f"gamma1:{n + 1}", real=True)
    return (*M_SYMBOLS, *R, *Gam, *gam) + ((T_SYMBOL,) if timed else ())


def _torque_formulas(body: RotorBody, tau: Any, w: sp.Matrix) -> tuple[list[sp.Expr], dict[str, float]] | None:
    """The torques as formulas in the state (and t) with their parameters' values, or None for a law of callables.
    ``w`` is the angular velocity :math:`D_1H_f` as a formula (the feedback reads :math:`\\dot m = m\\times w`)."""
    n = body.n_rotors
    if tau is None:
        return [sp.Integer(0)] * n, {}
    if isinstance(tau, Gait):
        if tau.expressions is None:
            return None
        table: dict[sp.Symbol, float] = {}
        forms = [number_form(e, table, 0) for e in tau.expressions]
        return forms, {s.name: v for s, v in table.items()}
    phi = getattr(tau, "phi_expression", None)
    if hasattr(tau, "feedback") and phi is not None:
        # u = Dphi(m) m', the control's own numbers as parameters of their own (prefixed: no clash with the body's)
        rename = {s: sp.Symbol(f"u_{s.name}", real=True) for s in phi.free_symbols - set(M_SYMBOLS)}
        values = {rename[s].name: float(tau.parameters[s.name]) for s in rename}
        m = sp.Matrix(M_SYMBOLS)
        mdot = m.cross(w)
        u = phi.xreplace(rename).jacobian(m) * mdot
        return list(u), values
    return None


def bind_torque(problem: Any, tau: Any) -> Any:
    """``problem`` (a body with rotors) with its torque law ``tau``: the equations as a formula where the law is
    one (their parameters read at run time), and the numeric torque for the Python route and the quantities."""
    body: RotorBody = problem.core
    body.require_rotor_inertia("Simulating a body with rotors")
    n = body.n_rotors
    u_fn = torque_function(tau, n)  # validates tau
    timed = not (tau is None or hasattr(tau, "feedback"))
    key = _law_key(tau)
    known = _FORMULAS.setdefault(body, {})
    if key not in known:
        known[key] = _formulas(body, tau, timed)
    formulas = known[key] or {}
    return dataclasses.replace(problem, dim=12 + 2 * n + int(timed), law=tau, torque=u_fn, timed=timed, **formulas)


_FORMULAS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _law_key(tau: Any) -> Any:
    """What the equations depend on in a torque law: its formulas and their numbers (None: not formulas)."""
    if tau is None:
        return ()
    if isinstance(tau, Gait) and tau.expressions is not None:
        return ("gait", tuple(tau.expressions))
    phi = getattr(tau, "phi_expression", None)
    if hasattr(tau, "feedback") and phi is not None:
        key = _CONTROL_KEYS.get(tau)
        if key is None:
            key = _CONTROL_KEYS.setdefault(
                tau, ("feedback", sp.ImmutableMatrix(phi), tuple(sorted(tau.parameters.items())))
            )
        return key
    return None


_CONTROL_KEYS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _formulas(body: RotorBody, tau: Any, timed: bool) -> dict[str, Any] | None:
    """The problem's fields for the equations of ``body`` under ``tau`` as a formula, or None for a law of Python
    code (derived once per body and law)."""
    n = body.n_rotors
    variables = _state_symbols(n, timed)
    Gam = sp.Matrix(variables[12 : 12 + n])
    H = body.H_f.xreplace(dict(zip(body.Gamma_symbols, Gam)))
    w = sp.Matrix([sp.diff(H, s) for s in M_SYMBOLS])
    torques = _torque_formulas(body, tau, w)
    if torques is None:
        return None
    u, law_values = torques
    m = sp.Matrix(M_SYMBOLS)
    R = sp.Matrix(3, 3, variables[3:12])
    W = sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    rates = [sp.diff(H, g) for g in Gam]
    field = sp.ImmutableMatrix(list(m.cross(w)) + list(R * W) + list(u) + rates + ([sp.Integer(1)] if timed else []))
    runtime = runtime_parameters(field, variables, {**body.parameter_values(), **law_values})
    # what a saved state shows, the energy H_f and the torques, generated as the Lagrangian runs' observation is
    # (not for a law in time: the saved states are observed without their time)
    observation = None
    if not timed:
        try:
            spec = FunctionSpec("observe", ([H, *u],), variables, parameters=runtime["parameter_symbols"])
            observation = Observation(kernel_source([spec]) + OBSERVE_ALL, 1 + n)
        except NotImplementedError:  # a function numba lacks: the formulas by numpy
            observation = None
    # H_f in (m, Gamma) and the body's parameters: the energy of each member of a batch of parameter values
    # and the torques, for the same (a feedback reads the body's parameters through w)
    return {
        "expression": field,
        "variables": variables,
        "energy_expression": H,
        "torque_expressions": tuple(u),
        "observation": observation,
        **runtime,
    }


def rotor_initial_states(
    problem: Any, m0: Any, R0: Any, Gamma0: Any, gamma0: Any, t0: float
) -> tuple[np.ndarray, tuple[int, ...]]:
    """The rows ``(m, R, Gamma, gamma[, t])`` of a batch of initial states (leading axes broadcast) and its
    batch shape."""
    n = problem.core.n_rotors
    if m0 is None or Gamma0 is None:
        raise InputError(
            f"{problem.name} starts from `m0` (its total body angular momentum, shape (..., 3)) and `Gamma0` (the "
            f"rotors' axial momenta, shape (..., {n})); RotorBody.legendre gives them from omega and gamma_dot)."
        )
    m = V.trailing_shape(m0, "m0", (3,))
    Gam = V.trailing_shape(np.atleast_1d(np.asarray(Gamma0, dtype=float)), "Gamma0", (n,))
    R = np.eye(3) if R0 is None else V.rotation_matrix(R0, "R0")
    gam = np.zeros(n) if gamma0 is None else V.trailing_shape(np.atleast_1d(gamma0), "gamma0", (n,))
    batches = (m.shape[:-1], R.shape[:-2], Gam.shape[:-1], gam.shape[:-1])
    try:
        shape = np.broadcast_shapes(*batches) if any(batches) else ()
    except ValueError:
        raise InputError(
            f"Expected the batch shapes of `m0` {m.shape[:-1]}, `R0` {R.shape[:-2]}, `Gamma0` {Gam.shape[:-1]} and "
            f"`gamma0` {gam.shape[:-1]} to broadcast."
        ) from None
    if not shape:  # one state: its parts as they are
        return np.concatenate([m, R.ravel(), Gam, gam] + ([[float(t0)]] if problem.timed else []))[None], shape
    parts = [
        np.broadcast_to(m, shape + (3,)),
        np.broadcast_to(R, shape + (3, 3)).reshape(shape + (9,)),
        np.broadcast_to(Gam, shape + (n,)),
        np.broadcast_to(gam, shape + (n,)),
    ]
    if problem.timed:
        parts.append(np.full(shape + (1,), float(t0)))
    Y = np.concatenate(parts, axis=-1)
    return Y.reshape(-1, problem.dim).copy(), shape


def rotor_python(problem: Any) -> dict[str, Any]:
    """The model functions of the Python route: the right-hand side from the body and the numeric torque, and,
    where the equations are a formula, their Jacobian."""
    body: RotorBody = problem.core
    n, u_fn, timed = body.n_rotors, problem.torque, problem.timed

    def rhs(y: np.ndarray, out: np.ndarray, prm: np.ndarray) -> None:
        m, R, Gam, gam = y[:3], np.asarray(y[3:12]).reshape(3, 3), y[12 : 12 + n], y[12 + n : 12 + 2 * n]
        with np.errstate(all="ignore"):
            u = u_fn(y[-1] if timed else 0.0, R, m, gam, Gam)
            dR, dm, dgam, dGam = body.vector_field(R, m, Gam, u)
        out[:3], out[3:12], out[12 : 12 + n], out[12 + n : 12 + 2 * n] = dm, dR.ravel(), dGam, dgam
        if timed:
            out[-1] = 1.0
        if not np.all(np.isfinite(out)):
            raise NumericalError(
                f"the right-hand side is not finite (m = {np.asarray(m).tolist()}, Gamma = {np.asarray(Gam).tolist()}, "
                f"torque = {np.asarray(u).tolist()}); is the torque defined along the trajectory?"
            )

    out: dict[str, Any] = {"rhs": rhs}
    if problem.model_expression is not None:
        f = sp.Matrix(problem.model_expression)
        variables = list(problem.variables) + list(problem.parameter_symbols)
        jac = compile_vector(f.jacobian(sp.Matrix(problem.variables)).tolist(), variables)
        d = problem.dim

        def fjac(y: np.ndarray, out: np.ndarray, J: np.ndarray, prm: np.ndarray) -> None:
            rhs(y, out, prm)
            J[:, :] = np.asarray(jac(np.concatenate([y, prm])), dtype=float).reshape(d, d)

        out["fjac"] = fjac
    return out


def torques_along(problem: Any, t: np.ndarray, states: np.ndarray) -> np.ndarray:
    """The torques at the saved ``states`` (``(..., n_save, d)``, times ``t``), NaN where a state is not finite."""
    body: RotorBody = problem.core
    n, tau = body.n_rotors, problem.law
    m, R = states[..., :3], states[..., 3:12].reshape(states.shape[:-1] + (3, 3))
    Gam, gam = states[..., 12 : 12 + n], states[..., 12 + n : 12 + 2 * n]
    ok = np.all(np.isfinite(states), axis=-1)
    out = np.full(states.shape[:-1] + (n,), np.nan)
    if tau is None:
        out[ok] = 0.0
    elif hasattr(tau, "feedback"):
        out[ok] = tau.feedback(m[ok], Gam[ok])
    elif isinstance(tau, Gait):
        out[ok] = np.asarray(tau.r(np.broadcast_to(t, ok.shape)[ok]), dtype=float).reshape(-1, n)
    else:
        T = np.broadcast_to(t, ok.shape)
        for i in zip(*np.nonzero(ok)):
            out[i] = problem.torque(T[i], R[i], m[i], gam[i], Gam[i])
    return out
