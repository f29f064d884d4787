"""Hamilton's equations on the constraint momentum submanifold (:class:`~geomech.integrators.NonholonomicHamilton`),
the engine of :func:`~geomech.solve` for them: the almost-Poisson, Bates-Sniatycki or full-tensor vector field of
:mod:`geomech.reduction`, with the torques on the free shapes as a generalised force, stepped by scipy."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ...errors import InputError
from ...reduction import almost_poisson, bates_sniatycki, full_almost_poisson
from ._continuous import run_stepped
from ._inputs import _Setup
from ._trajectory import _Raw


def _field(system: Any, form: str, basis: str, parameters: Mapping[str, float] | None) -> tuple[Any, Any, Any]:
    """The vector field ``f(z, force)`` of ``form``, its ``response(z)`` (the free field and ``R``: ``f(z, F) = free
    + R F``) and the momenta ``pt(q, qdot)`` of its coordinates."""
    values = None if parameters is None else dict(parameters)
    if form == "full":
        if system.c == 0:
            raise InputError(
                f"{system.name} has no constraints: its full and truncated tensors are the canonical one; integrate "
                "it with NonholonomicHamilton(form='almost_poisson')."
            )
        num = full_almost_poisson(system, basis).numeric(values)
        return num["field"], num["response"], num["pt"]
    structure = almost_poisson(system, basis)
    pt = structure.numeric(values)["pt"]
    num = bates_sniatycki(system, basis).numeric(values) if form == "bates_sniatycki" else structure.numeric(values)
    return num["field"], num["response"], pt


def run_hamiltonian(
    setup: _Setup,
    q_init: np.ndarray,
    qd_init: np.ndarray,
    t0: float,
    times: np.ndarray,
    method: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    parameters: Mapping[str, float] | None,
    events: Any = None,
    max_events: int = 1000,
) -> _Raw:
    """Integrate ``z = (q, pt)`` (and the work of the torques) by ``method.solver``; the velocity at a saved state is
    the field's q rows, :math:`\\dot q = \\partial H/\\partial p` (on :math:`\\mathcal M`, in :math:`\\mathcal D`)."""
    system = setup.system
    name = f"NonholonomicHamilton({method.form!r})"
    if setup.prescribed:
        shapes = [system.shape[i].name for i in setup.prescribed]
        raise InputError(
            f"{name} integrates a system with free shapes (driven by `tau` or by nothing); {system.name}'s shapes "
            f"{shapes} have a prescribed gait, a time-dependent constraint outside the Hamiltonian forms. Use BKMM() "
            "or LagrangeDAlembert(), or drive the shapes by torques."
        )
    field, response, pt = _field(system, method.form, method.basis, parameters)
    driven = any(fn is not None for fn in setup.torques.fns)
    n, k = system.n, system.k
    shapes = [k + i for i in setup.free_shapes]

    def force(t: float, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tau = setup.torques(t, q, qd)
        F = np.zeros(n)
        F[shapes] = tau
        return F, tau

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        z = y[:-1]
        if not driven:
            return np.r_[field(z), 0.0]
        # the torques read the velocity, the field's q rows, which the force leaves alone: one evaluation
        free, R = response(z)
        F, tau = force(t, z[:n], free[:n])
        return np.r_[free + R @ F, tau @ free[shapes]]

    def evaluate(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, qdot, torques) of a state: qdot the field's q rows (which the torques leave alone)."""
        z = y[:-1]
        q, qd = z[:n], field(z)[:n]
        return q, qd, force(t, q, qd)[1]

    y0 = np.r_[q_init, pt(np.r_[q_init, qd_init])[:, 0], 0.0]
    return run_stepped(
        name, setup, rhs, evaluate, y0, t0, times, method, tolerances, max_evaluations, parameters, events, max_events
    )
