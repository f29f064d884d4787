"""Sensitivities through :func:`~geomech.solve`: the variational equations integrated with the state, by the
same loops (compiled from the system's formulas, or in Python), for the state transition matrix dy(t)/dy(t0) and
the sensitivities dy(t)/dp to named parameters (Floquet and stability analysis, shooting and continuation,
gradients for optimisation and estimation)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from ..symbolic.compile import compile_vector
from . import _codegen
from ._model_source import variational_equations, variational_source

__all__ = ["augment", "named_sensitivities", "sensitivity_names", "split", "variational_module"]


def sensitivity_names(problem: Any, sensitivities: Any) -> tuple[str, ...] | None:
    """The parameters of ``sensitivities`` (True: the initial state only; names: those parameters too), checked;
    None for no variational equations."""
    if sensitivities is None or sensitivities is False:
        return None
    if problem.kind not in ("canonical", "lie_poisson", "rotor") or problem.expression is None or problem.timed:
        raise InputError(
            f"`sensitivities` integrates the variational equations of a system given by a formula (canonical, "
            f"left-invariant, or a body with rotors under a law of formulas that does not read the time); "
            f"{problem.name} is not one here."
        )
    known = [n for n in problem.parameter_names if not n.startswith("_p")]
    return named_sensitivities(sensitivities, known, f"parameters of {problem.name}")


def named_sensitivities(sensitivities: Any, known: list[str], owner: str) -> tuple[str, ...]:
    """The names of ``sensitivities`` (True: none, the initial state only), each one of ``known`` (the parameters
    of ``owner``, as the error names them) and given once."""
    if sensitivities is True:
        return ()
    names = (sensitivities,) if isinstance(sensitivities, str) else tuple(sensitivities)
    unknown = [n for n in names if not isinstance(n, str) or n not in known]
    if unknown or len(set(names)) != len(names):
        raise InputError(
            f"Expected `sensitivities` to be True (the initial state) or distinct names of {owner} "
            f"({known or 'it has none'}), got {sensitivities!r}."
        )
    return names


def variational_module(problem: Any, wrt: tuple[str, ...], backend: str) -> tuple[Any, str]:
    """The loop module whose right-hand side is the variational equations of ``problem`` (its parameter values,
    derived ones included, set on it), and the backend used."""
    model = problem.expression if problem.model_expression is None else problem.model_expression
    args = (problem.kind, problem.layout, model, problem.variables, problem.parameter_symbols, wrt)
    if backend != "python" and _codegen.numba_available():
        src, derived = variational_source(*args)
        problem.bind_derived(derived)
        return _codegen.compiled_module(src, "var"), "numba"
    outputs, aug = variational_equations(*args)
    f = compile_vector(outputs, [*aug, *problem.parameter_symbols])
    n_given = len(problem.parameter_symbols)

    def rhs(y: np.ndarray, out: np.ndarray, prm: np.ndarray) -> None:
        out[:] = f(np.concatenate([y, prm[:n_given]]))

    return _codegen.python_module({"rhs": rhs}), "python"


def augment(Y0: np.ndarray, k: int) -> np.ndarray:
    """Initial states ``(B, d)`` with Phi = I and S = 0 appended."""
    B, d = Y0.shape
    return np.concatenate([Y0, np.tile(np.eye(d).ravel(), (B, 1)), np.zeros((B, d * k))], axis=1)


def split(OUT: np.ndarray, d: int, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Saved augmented states ``(..., d + d^2 + d k)`` into the states, Phi ``(..., d, d)`` and S ``(..., d, k)``."""
    lead = OUT.shape[:-1]
    return OUT[..., :d], OUT[..., d : d + d * d].reshape(lead + (d, d)), OUT[..., d + d * d :].reshape(lead + (d, k))
