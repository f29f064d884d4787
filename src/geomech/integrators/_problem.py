"""What the solver needs to know about a system: its state layout, which structures it has (and why not,
when it lacks one), its model functions compiled for the loops, and its invariants.

A :class:`~geomech.systems.CanonicalSystem` is a canonical problem with state ``(q, p)``; a left-invariant
system (:class:`~geomech.LeftInvariantSystem`, :class:`~geomech.RigidBody`, anything wrapping one) is a
Lie-Poisson problem with state ``m`` or, given an initial attitude, ``(m, R)``.
"""

from __future__ import annotations

import functools
import math
import weakref
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from .._storage import remember
from ..errors import InputError
from ..lie.so3 import hat
from ..symbolic.compile import M_SYMBOLS, compile_scalar, compile_vector, runtime_parameters
from ..symbolic.simplify import vanishes
from ..systems.canonical import CanonicalSystem
from ..systems.group_flow import GroupFlow
from ..systems.left_invariant import LeftInvariantSystem, as_left_invariant
from ..systems.nonholonomic import NonholonomicSystem
from ..systems.rotors import RotorBody
from . import _codegen
from ._model_source import model_source
from .methods import Structure

__all__ = ["Problem", "make_problem"]

#: The rows of a model's given and derived parameters (by its function of the derived ones), by the given values.
_DERIVED_ROWS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(eq=False)
class Problem:
    """A system as the solver sees it (internal)."""

    kind: str  # "canonical" | "lie_poisson" | "lagrangian" | "rotor" | "group"
    layout: str  # "qp" | "m" | "mR" | "qv" | "rotor" | "group"
    dim: int
    system: Any  # the object the user passed
    core: Any  # CanonicalSystem or LeftInvariantSystem
    expression: sp.Expr | None
    variables: tuple[sp.Symbol, ...]
    missing: dict[Structure, str] = field(default_factory=dict)
    split_axis_order: tuple[int, int, int] = (0, 1, 2)
    inertia_tensor: np.ndarray | None = None
    # The compiled model is generated from ``model_expression`` (``expression`` before its numeric parameters
    # were substituted) and reads the values ``prm`` of ``parameter_symbols`` at run time: one compilation
    # serves every value of the parameters (a sweep over inertias compiles once).
    model_expression: sp.Expr | None = None
    parameter_symbols: tuple[sp.Symbol, ...] = ()
    prm: np.ndarray = field(default_factory=lambda: np.empty(0))
    # for each entry of prm before the derived ones: (parameter name, whether it is its reciprocal)
    parameter_recipe: tuple[tuple[str, bool], ...] = ()
    derived: Any = None  # the derived parameters (coefficients hoisted by the code generator) from the given ones
    _bound: bool = False  # prm holds the derived parameters' values of ``derived``
    # A body with rotors, bound to its torque law by ._rotor.bind_torque: the law, the torque as a function
    # u(t, R, m, gamma, Gamma), and whether it depends on time (the time is then the state's last component)
    law: Any = None
    torque: Any = None
    timed: bool = False
    energy_expression: Any = None  # its H_f in (m, Gamma) and the parameters, for a batch of parameter values
    torque_expressions: Any = None  # and its torques in the state and the parameters
    observation: Any = None  # both generated (an ._observe.Observation), for the saved states of a law not in time

    @functools.cached_property
    def labels(self) -> tuple[str, ...]:
        """A name for each component of the state (made once: every run's Solution carries them)."""
        if self.kind == "canonical":
            return tuple(str(v) for v in self.variables)
        if self.kind == "lagrangian":
            return tuple(s.name for s in self.core.q) + tuple(s.name for s in self.core.qdot)
        if self.kind == "rotor":
            from ._rotor import rotor_labels

            return rotor_labels(self.core.n_rotors)
        if self.kind == "group":
            from ._group_flow import group_labels

            return group_labels(self.core)
        names: tuple[str, ...] = ("m1", "m2", "m3")
        if self.layout == "mR":
            names += tuple(f"R{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
        return names

    @property
    def name(self) -> str:
        return getattr(self.core, "name", type(self.core).__name__)

    def has(self, structure: Structure) -> bool:
        return structure not in self.missing

    # -- compiled model ---------------------------------------------------------------------------
    def module(self, features: frozenset[str], backend: str) -> tuple[Any, str]:
        """The loop module for ``features`` and the backend actually used."""
        if backend != "python" and self.expression is not None and _codegen.numba_available():
            if self.kind == "lie_poisson" and self.has(Structure.LIE_POISSON_SPLIT):
                # cheap to add, and one module per model and layout keeps numba's compilations down
                features = features | {"split"}
            if self.kind == "canonical" and self.dim == 2:
                # likewise the generating-function terms of a one-degree-of-freedom system (third derivatives
                # of H(q, p), cheap there): every method then shares one module
                features = features | {"gf"}
            try:
                model = self.expression if self.model_expression is None else self.model_expression
                src, derived = model_source(
                    self.kind, self.layout, model, self.variables, self.parameter_symbols, features
                )
                tag = "c" if self.kind == "canonical" else self.layout
                module = _codegen.compiled_module(src, tag)
                self.bind_derived(derived)
                return module, "numba"
            except NotImplementedError:
                if backend == "numba":
                    raise
        elif backend == "numba":
            why = "numba is not available" if self.expression is not None else "the system has no formula"
            raise InputError(f"backend='numba' needs a system built from a formula and numba; {why}.")
        return _codegen.python_module(self._python_functions(features)), "python"

    def bind_derived(self, derived: Any) -> None:
        """Use the generated model's ``derived`` parameters: ``prm`` becomes the system's values and theirs (made
        once per model: the same ``derived`` keeps them)."""
        if derived is self.derived and self._bound:
            return
        self.derived = derived
        self._bound = True
        if derived is None:
            self.prm = self.parameter_rows({})[0]
            return
        # the same model and values in a later call (a new Problem each call): the row made then
        rows = _DERIVED_ROWS.setdefault(derived, {})
        key = (self.prm[: len(self.parameter_symbols)].tobytes(), self.parameter_recipe)
        row = rows.get(key)
        if row is None:
            row = remember(rows, key, self.parameter_rows({})[0], 64)
        self.prm = row.copy()

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The names of the parameters the compiled model reads at run time (a batch of values may be given)."""
        return tuple(dict.fromkeys(name for name, _ in self.parameter_recipe))

    def parameter_rows(self, values: Mapping[str, np.ndarray]) -> np.ndarray:
        """The compiled model's parameter rows ``(N, n_prm)`` for ``values`` (name -> ``(N,)`` array; the others
        keep the system's values), the derived parameters included (after :meth:`module`)."""
        base = self.prm[: len(self.parameter_symbols)]
        if not values and self.derived is None:  # the system's own values: one row
            return np.ascontiguousarray(base[None, :], dtype=float)
        n = len(next(iter(values.values()))) if values else 1
        own = {
            name: base[i] if not inverse else 1.0 / base[i] for i, (name, inverse) in enumerate(self.parameter_recipe)
        }
        columns = [
            np.broadcast_to(np.asarray(values.get(name, own[name]), dtype=float), (n,))
            for name, _ in self.parameter_recipe
        ]
        given = [1.0 / c if inverse else c for c, (_, inverse) in zip(columns, self.parameter_recipe)]
        rows = np.stack(given, -1) if given else np.empty((n, 0))
        if self.derived is not None:
            extra = np.asarray(self.derived(rows), dtype=float).reshape(n, -1)
            rows = np.concatenate([rows, extra], axis=1)
        return np.ascontiguousarray(rows)

    def _python_functions(self, features: frozenset[str]) -> dict[str, Any]:
        if self.kind == "rotor":
            from ._rotor import rotor_python

            return rotor_python(self)
        if self.kind == "canonical":
            return _canonical_python(self.core, features)
        return _lie_poisson_python(self.core, self.expression, features)

    # -- invariants -------------------------------------------------------------------------------
    def _observed(self, rows: np.ndarray | None) -> bool:
        """Whether the quantities of a body with rotors under a law of formulas not in time are the compiled
        observation's (its energy and torques; NaN where a state is not finite)."""
        return (
            self.kind == "rotor"
            and rows is not None
            and self.observation is not None
            and not self.timed
            and _codegen.numba_available()
        )

    def bound_observation(self, states: np.ndarray, rows: np.ndarray) -> tuple[Any, np.ndarray] | None:
        """The compiled observation of the saved ``states`` ``(n_save, d)`` of one run with the parameter ``rows``
        ``(1, n_prm)`` (:func:`~._observe.bound_observation`) bound to them: for :meth:`invariants`' ``shown``;
        None where the quantities are not the observation's or it has no C entry here."""
        if not self._observed(rows):
            return None
        from ._observe import bound_observation

        assert self.observation is not None
        module = _codegen.compiled_module(self.observation.source, "ro")
        return bound_observation(module, self.observation, states, rows, states.shape[0])

    def invariants(
        self, states: np.ndarray, t: np.ndarray, rows: np.ndarray | None = None, shown: np.ndarray | None = None
    ) -> dict[str, Any]:
        """The quantities along saved ``states`` (``(..., n_save, d)`` at times ``t``): energy, Casimir, spatial
        momentum, and the torques of a body with rotors; NaN where a state is not finite. ``rows``: the parameter
        rows of a batch of parameter values (``(..., n_prm)``, the batch's shape), the energy then evaluated with
        each trajectory's own. ``shown``: the compiled observation of the states of a body with rotors where it was
        made already (:meth:`bound_observation`)."""
        out: dict[str, np.ndarray | None] = {"energy": None, "casimir": None, "spatial_momentum": None}
        # a body with rotors under a law of formulas not in time: the compiled observation (NaN where a state is not
        # finite)
        observed = self._observed(rows)
        if not observed:
            ok = np.all(np.isfinite(states), axis=-1)
        if rows is not None and self.kind != "rotor":
            out.update(self._lie_poisson_views(states) if self.kind == "lie_poisson" else {})
            out["energy"] = self._energy_with(states, rows, ok)
            return out
        if self.kind == "rotor":
            from ._rotor import torques_along

            n = self.core.n_rotors
            m, Gam = states[..., :3], states[..., 12 : 12 + n]
            R = states[..., 3:12].reshape(states.shape[:-1] + (3, 3))
            out["spatial_momentum"] = np.matmul(R, m[..., None])[..., 0]
            if observed and shown is None:
                from ._observe import observe

                assert rows is not None and self.observation is not None

                module = _codegen.compiled_module(self.observation.source, "ro")
                shown, _ = observe(
                    module,
                    self.observation,
                    states.reshape(-1, states.shape[-1]),
                    np.ascontiguousarray(rows.reshape(math.prod(rows.shape[:-1]), rows.shape[-1])),
                    states.shape[-2],
                )
            if observed:
                assert shown is not None
                shown = shown.reshape(states.shape[:-1] + (1 + n,))
                out["energy"], out["tau"] = shown[..., 0], shown[..., 1:]
                return out
            if rows is None:
                energy = np.full(states.shape[:-1], np.nan)
                energy[ok] = self.core.hamiltonian(m[ok], Gam[ok])
            else:
                energy = self._energy_with(states, rows, ok)
            out["energy"] = energy
            if rows is None or self.timed:  # (a law in time does not read the body's parameters)
                out["tau"] = torques_along(self, t, states)
            else:
                u = _vector_function(self.torque_expressions, self.variables, self.parameter_symbols)
                given = np.broadcast_to(
                    rows[..., None, : len(self.parameter_symbols)], states.shape[:-1] + (len(self.parameter_symbols),)
                )
                tau = np.full(states.shape[:-1] + (n,), np.nan)
                tau[ok] = u(np.concatenate([states, given], axis=-1)[ok])
                out["tau"] = tau
            return out
        if self.kind == "canonical":
            energy = np.full(states.shape[:-1], np.nan)
            energy[ok] = self.core.hamiltonian(states[ok])
            out["energy"] = energy
            return out
        m = states[..., :3]
        energy = np.full(states.shape[:-1], np.nan)
        energy[ok] = self.core.hamiltonian(m[ok])
        out["energy"] = energy
        out.update(self._lie_poisson_views(states))
        return out

    def _lie_poisson_views(self, states: np.ndarray) -> dict[str, np.ndarray]:
        m = states[..., :3]
        out = {"casimir": np.linalg.norm(m, axis=-1)}
        if self.layout == "mR":
            R = states[..., 3:].reshape(states.shape[:-1] + (3, 3))
            out["spatial_momentum"] = np.einsum("...ij,...j->...i", R, m)
        return out

    def _energy_with(self, states: np.ndarray, rows: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """H at ``states`` with each trajectory's parameter row (the model's formula, its parameters read from the
        rows as the compiled loops read them)."""
        if self.kind == "rotor":  # H_f(m, Gamma)
            n = self.core.n_rotors
            variables = tuple(self.variables[:3]) + tuple(self.variables[12 : 12 + n])
            H = _energy_function(self.energy_expression, variables, self.parameter_symbols)
            point = np.concatenate([states[..., :3], states[..., 12 : 12 + n]], axis=-1)
        else:
            variables = tuple(M_SYMBOLS) if self.kind == "lie_poisson" else self.variables
            H = _energy_function(self.model_expression, variables, self.parameter_symbols)
            point = states[..., : len(variables)]
        given = np.broadcast_to(
            rows[..., None, : len(self.parameter_symbols)], states.shape[:-1] + (len(self.parameter_symbols),)
        )
        energy = np.full(states.shape[:-1], np.nan)
        energy[ok] = H(np.concatenate([point, given], axis=-1)[ok])
        return energy


@functools.lru_cache(maxsize=32)
def _energy_function(expr: sp.Expr, variables: tuple, parameters: tuple) -> Any:
    return compile_scalar(expr, [*variables, *parameters])


@functools.lru_cache(maxsize=32)
def _vector_function(exprs: tuple, variables: tuple, parameters: tuple) -> Any:
    return compile_vector(list(exprs), [*variables, *parameters])


# -- problems from systems ----------------------------------------------------------------------------
_ANALYSIS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@functools.lru_cache(maxsize=None)
def _all_but(kept: Structure) -> tuple[Structure, ...]:
    """Every structure but ``kept`` (what a body with rotors, a group flow, a Lagrangian system lacks), listed once:
    an enum's iteration costs microseconds at every run."""
    return tuple(s for s in Structure if s is not kept)


def make_problem(system: Any, *, attitude: bool) -> Problem:
    """Classify ``system``; raises :class:`InputError` for something that is not a system."""
    core: CanonicalSystem | LeftInvariantSystem
    if isinstance(system, RotorBody):
        why = (
            f"{system.name} is a body with rotors driven by a torque law: its open-loop equations in (m, R, Gamma, "
            "gamma) are an ODE without further structure"
        )
        return Problem(
            kind="rotor",
            layout="rotor",
            dim=12 + 2 * system.n_rotors,
            system=system,
            core=system,
            expression=None,
            variables=(),
            missing=dict.fromkeys(_all_but(Structure.ODE), why),
        )
    if isinstance(system, GroupFlow):
        if attitude:
            raise InputError(f"`R0` applies to left-invariant systems on T*SO(3); give {system.name}'s start as `g0`.")
        why = (
            f"{system.name} is a body velocity on {system.group.name}, integrated on the group by the methods of "
            "Structure.GROUP_FLOW (rkmk, rkmk4)"
        )
        n = system.group.numeric.matrix_size
        return Problem(
            kind="group",
            layout="group",
            dim=system.k + n * n,
            system=system,
            core=system,
            expression=None,
            variables=(),
            missing=dict.fromkeys(_all_but(Structure.GROUP_FLOW), why),
        )
    if isinstance(system, NonholonomicSystem):
        if attitude:
            raise InputError(f"`R0` applies to left-invariant systems on T*SO(3); {system.name} is Lagrangian.")
        why = (
            f"{system.name} is a Lagrangian system on G x S with constraints, integrated by the methods of "
            "Structure.LAGRANGIAN"
        )
        missing: dict[Structure, str] = dict.fromkeys(_all_but(Structure.LAGRANGIAN), why)
        return Problem(
            kind="lagrangian",
            layout="qv",
            dim=2 * system.n,
            system=system,
            core=system,
            expression=system.lagrangian,
            variables=tuple(system.q) + tuple(system.qdot),
            missing=missing,
        )
    if isinstance(system, CanonicalSystem):
        core = system
        analysis = _ANALYSIS.get(core)
        if analysis is None:
            analysis = _ANALYSIS.setdefault(core, _analyse_canonical(core))
        if attitude:
            raise InputError(f"`R0` applies to left-invariant systems on T*SO(3); {core.name} is canonical.")
        return Problem(kind="canonical", layout="qp", dim=2 * core.n, system=system, core=core, **analysis)
    try:
        core = as_left_invariant(system)
    except InputError:
        raise InputError(
            "Expected `system` to be a CanonicalSystem, a left-invariant system (LeftInvariantSystem, "
            f"RigidBody, ...), a RotorBody, a NonholonomicSystem or a GroupFlow, got {type(system).__name__}."
        ) from None
    analysis = _ANALYSIS.get(core)
    if analysis is None:
        analysis = _ANALYSIS.setdefault(core, _analyse_lie_poisson(core))
    layout = "mR" if attitude else "m"
    return Problem(kind="lie_poisson", layout=layout, dim=12 if attitude else 3, system=system, core=core, **analysis)


def _shown(expr: sp.Expr, limit: int = 120) -> str:
    """`` = expr`` for a message when it is short; nothing when it is long (simplifying it to show it could take
    longer than the whole simulation: it is computed for every problem, and read only on a refusal)."""
    text = str(expr)
    return f" = {text}" if len(text) <= limit else ""


def _analyse_canonical(core: CanonicalSystem) -> dict[str, Any]:
    variables = tuple(core.q_symbols) + tuple(core.p_symbols)
    missing: dict[Structure, str] = {}
    expr = core.expression
    runtime: dict[str, Any] = {}
    if core.template is not None:
        template, values = core.template
        runtime = runtime_parameters(template, variables, values)
    if expr is None:
        missing[Structure.SEPARABLE_CANONICAL] = (
            f"{core.name} was built from Python callables, so its separability cannot be checked; build it "
            "with CanonicalSystem.from_expression"
        )
    else:
        for q in core.q_symbols:
            for p in core.p_symbols:
                mixed = sp.diff(expr, q, p)
                if not vanishes(mixed):
                    missing[Structure.SEPARABLE_CANONICAL] = (
                        f"{core.name} is not separable: d^2H/d{q} d{p}{_shown(mixed)} is not zero"
                    )
                    break
            if Structure.SEPARABLE_CANONICAL in missing:
                break
    for s in (Structure.LIE_POISSON, Structure.LIE_POISSON_SPLIT, Structure.LIE_POISSON_QUADRATIC, Structure.LIE_GROUP):
        missing[s] = f"{core.name} is a canonical system in (q, p), not a left-invariant system on T*SO(3)"
    missing[Structure.LAGRANGIAN] = (
        f"{core.name} is a canonical system in (q, p), not a Lagrangian system on G x S "
        "(build one with NonholonomicSystem.from_lagrangian)"
    )
    missing[Structure.GROUP_FLOW] = f"{core.name} is a canonical system in (q, p), not a body velocity on a group"
    if core.n != 1:
        missing[Structure.ONE_DOF] = (
            f"{core.name} has {core.n} degrees of freedom; propagation by the period "
            "needs one (a reduced system: GeneralizedSerretAndoyer(H).reduced_system(G))"
        )
    return {"expression": expr, "variables": variables, "missing": missing, **runtime}


def _analyse_lie_poisson(core: LeftInvariantSystem) -> dict[str, Any]:
    missing: dict[Structure, str] = {
        Structure.CANONICAL: (
            f"{core.name} is Lie-Poisson on so(3)*, not canonical; reduce it to canonical variables first "
            "(GeneralizedSerretAndoyer(system).reduced_system(G) or EulerCoordinates(system).canonical_system())"
        ),
    }
    missing[Structure.SEPARABLE_CANONICAL] = missing[Structure.CANONICAL]
    missing[Structure.ONE_DOF] = missing[Structure.CANONICAL]
    missing[Structure.LAGRANGIAN] = (
        f"{core.name} is a Hamiltonian on so(3)*, not a Lagrangian system on G x S "
        "(build one with NonholonomicSystem.from_lagrangian)"
    )
    missing[Structure.GROUP_FLOW] = (
        f"{core.name} is a Hamiltonian on so(3)*; its attitude is integrated with the momentum (give `R0`)"
    )
    result: dict[str, Any] = {"expression": None, "variables": tuple(M_SYMBOLS), "missing": missing}
    if core.expression is None:
        why = f"{core.name} was built from a Python callable; build it with LeftInvariantSystem.from_expression"
        missing[Structure.LIE_POISSON_SPLIT] = f"proving H = f1(m1) + f2(m2) + f3(m3) needs a formula: {why}"
        missing[Structure.LIE_POISSON_QUADRATIC] = f"proving H quadratic needs a formula: {why}"
        return result
    subs = {sp.Symbol(k, real=True): v for k, v in core.parameters.items()}
    H = core.expression.subs(subs)
    result["expression"] = H
    result.update(runtime_parameters(core.expression, tuple(M_SYMBOLS), dict(core.parameters)))
    grad = [sp.diff(H, s) for s in M_SYMBOLS]
    for i in range(3):
        for j in range(i + 1, 3):
            mixed = sp.diff(grad[i], M_SYMBOLS[j])
            if not vanishes(mixed):
                missing[Structure.LIE_POISSON_SPLIT] = (
                    f"H is not a sum f1(m1) + f2(m2) + f3(m3): d^2H/dm{i + 1} dm{j + 1}{_shown(mixed)} is not zero"
                )
                break
        if Structure.LIE_POISSON_SPLIT in missing:
            break
    if Structure.LIE_POISSON_SPLIT not in missing:
        parts = [grad[i].subs({M_SYMBOLS[j]: 0 for j in range(3) if j != i}) for i in range(3)]
        cost = [sp.count_ops(p) for p in parts]
        # The middle flow of Strang's composition runs once a step, the outer ones merge across steps:
        # the costliest in the middle, the cheapest outside.
        by_cost = sorted(range(3), key=lambda i: (cost[i], i))
        result["split_axis_order"] = (by_cost[0], by_cost[1], by_cost[2])
    hess = sp.Matrix(3, 3, lambda i, j: sp.diff(grad[i], M_SYMBOLS[j]))
    constant = all(not (e.free_symbols & set(M_SYMBOLS)) or vanishes(sp.diff(e, s)) for e in hess for s in M_SYMBOLS)
    if not constant:
        missing[Structure.LIE_POISSON_QUADRATIC] = "H is not quadratic in m (its Hessian is not constant)"
    else:
        A = np.array(hess.subs({s: 0 for s in M_SYMBOLS}).evalf(), dtype=float)
        g0 = np.array([float(g.subs({s: 0 for s in M_SYMBOLS})) for g in grad])
        if np.any(g0 != 0):
            missing[Structure.LIE_POISSON_QUADRATIC] = (
                f"H has terms linear in m (grad H(0) = {g0.tolist()}): it is not a free rigid body"
            )
        elif np.any(np.linalg.eigvalsh(0.5 * (A + A.T)) <= 0):
            missing[Structure.LIE_POISSON_QUADRATIC] = "the quadratic form of H is not positive definite"
        else:
            result["inertia_tensor"] = np.linalg.inv(0.5 * (A + A.T))
    if core.hyperregularity().status == "no":
        missing[Structure.LIE_GROUP] = "H is not hyperregular (its Hessian is singular): no Lagrangian exists"
    return result


def _fd_hessian(gradient: Any, y: np.ndarray) -> np.ndarray:
    step = np.cbrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(y))
    cols = []
    for j in range(y.shape[0]):
        e = np.zeros_like(y)
        e[j] = step[j]
        cols.append((np.asarray(gradient(y + e)) - np.asarray(gradient(y - e))) / (2 * step[j]))
    hess = np.stack(cols, -1)
    return 0.5 * (hess + hess.T)


def _canonical_python(core: CanonicalSystem, features: frozenset[str]) -> dict[str, Any]:
    n = core.n
    G = core._gradient

    def H2(y: np.ndarray) -> np.ndarray:
        return core._hessian(y) if core._hessian is not None else _fd_hessian(G, y)

    def ham(y, prm):
        return float(core._hamiltonian(np.asarray(y)))

    def grad(y, g, prm):
        g[:] = G(np.asarray(y))

    def ghess(y, g, hm, prm):
        g[:] = G(np.asarray(y))
        hm[:, :] = H2(np.asarray(y))

    def rhs(y, f, prm):
        g = G(np.asarray(y))
        f[:n] = g[n:]
        f[n:] = -g[:n]

    def fjac(y, f, jac, prm):
        rhs(y, f, prm)
        hm = H2(np.asarray(y))
        jac[:n, :] = hm[n:, :]
        jac[n:, :] = -hm[:n, :]

    out = {"ham": ham, "grad": grad, "ghess": ghess, "rhs": rhs, "fjac": fjac}
    if "gf" in features and core.expression is not None:
        out.update(_gf_python(core))
    return out


def _gf_python(core: CanonicalSystem) -> dict[str, Any]:
    """gf_all and gf_grads (W = H_q . H_p and its derivatives) from the formula, for the Python backend."""
    variables = tuple(core.q_symbols) + tuple(core.p_symbols)
    n = core.n
    g = [sp.diff(core.expression, v) for v in variables]
    w = sum(g[i] * g[n + i] for i in range(n))
    gw = [sp.diff(w, v) for v in variables]
    hm = [[sp.diff(e, v) for v in variables] for e in g]
    hw = [[sp.diff(e, v) for v in variables] for e in gw]
    N = len(variables)
    # one function of the four outputs, their common subexpressions shared, split afterwards
    f_all = compile_vector(
        list(g) + [e for row in hm for e in row] + list(gw) + [e for row in hw for e in row], variables
    )

    def parts(y):
        v = f_all(np.asarray(y, dtype=float))
        return v[:N], v[N : N + N * N].reshape(N, N), v[N + N * N : 2 * N + N * N], v[2 * N + N * N :].reshape(N, N)

    def gf_all(y, g_out, hm_out, gw_out, hw_out, prm):
        a, b, c, d = parts(y)
        g_out[:], hm_out[:, :], gw_out[:], hw_out[:, :] = a, b, c, d

    def gf_grads(y, g_out, gw_out, prm):
        a, _, c, _ = parts(y)
        g_out[:], gw_out[:] = a, c

    return {"gf_all": gf_all, "gf_grads": gf_grads}


def _lie_poisson_python(core: LeftInvariantSystem, expr: sp.Expr | None, features: frozenset[str]) -> dict[str, Any]:
    G, Hs = core._gradient, core._hessian

    def ham(y, prm):
        return float(core._hamiltonian(np.asarray(y[:3])))

    def ghess3(m, g, hm, prm):
        g[:] = G(np.asarray(m))
        hm[:, :] = Hs(np.asarray(m))

    def rhs(y, f, prm):
        m = np.asarray(y[:3])
        w = G(m)
        f[:3] = np.cross(m, w)
        if y.shape[0] == 12:
            f[3:] = (np.asarray(y[3:]).reshape(3, 3) @ hat(w, check=False)).ravel()

    def fjac(y, f, jac, prm):
        rhs(y, f, prm)
        m = np.asarray(y[:3])
        w, hm = G(m), Hs(m)
        jac[:, :] = 0.0
        jac[:3, :3] = -hat(w, check=False) + hat(m, check=False) @ hm
        if y.shape[0] == 12:
            R = np.asarray(y[3:]).reshape(3, 3)
            W = hat(w, check=False)
            for a in range(3):
                for b in range(3):
                    row = 3 + 3 * a + b
                    for c in range(3):
                        jac[row, 3 + 3 * a + c] = W[c, b]
                    for j in range(3):
                        jac[row, j] = (R @ hat(hm[:, j], check=False))[a, b]

    out = {"ham": ham, "ghess3": ghess3, "rhs": rhs, "fjac": fjac}
    if "split" in features and expr is not None:
        for i in range(3):
            part = sp.diff(expr, M_SYMBOLS[i]).subs({M_SYMBOLS[j]: 0 for j in range(3) if j != i})
            out[f"dh{i}"] = _scalar_function(compile_scalar(part, [M_SYMBOLS[i]]))
    return out


def _scalar_function(fn: Any) -> Any:
    def scalar(x: float, prm: Any = None) -> float:
        return float(fn(np.array([x], dtype=float)))

    return scalar
