"""A rigid body with rotors through :func:`~geomech.solve`: the open-loop equations (26) / (38) of the
Serret-Andoyer paper in :math:`(m, R, \\Gamma, \\gamma)`, driven by a torque law, stepped by an adaptive
scipy solver, with the energy :math:`H_f`, the spatial momentum :math:`R m` and the torques along the run."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError, NumericalError
from ..systems.rotors import RotorBody, torque_function
from ._adaptive import integrate_ivp
from ._times import Times
from .solution import Failure, Solution, Status, run_stats


def rotor_labels(n: int) -> tuple[str, ...]:
    return (
        ("m1", "m2", "m3")
        + tuple(f"R{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
        + tuple(f"Gamma{i + 1}" for i in range(n))
        + tuple(f"gamma{i + 1}" for i in range(n))
    )


def solve_rotor(
    body: RotorBody,
    method: Any,
    times: Times,
    *,
    t0: float,
    m0: Any,
    R0: Any,
    Gamma0: Any,
    gamma0: Any,
    tau: Any,
    tolerances: tuple[float, float],
    max_evaluations: Any,
    memory_limit: float,
) -> Solution:
    """Integrate ``body`` from its initial total body momentum ``m0``, attitude ``R0`` (default identity),
    rotor momenta ``Gamma0`` and angles ``gamma0`` (default 0) under the torque law ``tau`` (internal:
    :func:`~geomech.solve` has checked the method and the times)."""
    body.require_rotor_inertia("Simulating a body with rotors")
    n = body.n_rotors
    if m0 is None or Gamma0 is None:
        raise InputError(
            f"{body.name} starts from `m0` (its total body angular momentum, shape (3,)) and `Gamma0` (the "
            f"rotors' axial momenta, shape ({n},); RotorBody.legendre gives them from omega and gamma_dot)."
        )
    m0 = V.exact_shape(m0, "m0", (3,))
    Gamma0 = V.exact_shape(np.atleast_1d(np.asarray(Gamma0, dtype=float)), "Gamma0", (n,))
    R0 = np.eye(3) if R0 is None else V.rotation_matrix(R0, "R0")
    gamma0 = np.zeros(n) if gamma0 is None else V.exact_shape(np.atleast_1d(gamma0), "gamma0", (n,))
    u_fn = torque_function(tau, n)
    d = 12 + 2 * n
    V.memory_budget(
        float(times.n_saved) * (d + n + 5),
        float(memory_limit),
        f"Keeping {times.n_saved:.3g} states",
        "memory_limit",
        "save fewer times (`saveat`)",
    )

    def unpack(y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return y[:3], y[3:12].reshape(3, 3), y[12 : 12 + n], y[12 + n :]

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        m, R, Gam, gam = unpack(y)
        with np.errstate(all="ignore"):
            u = u_fn(t, R, m, gam, Gam)
            dR, dm, dgam, dGam = body.vector_field(R, m, Gam, u)
            out = np.concatenate([dm, dR.ravel(), dGam, dgam])
        if not np.all(np.isfinite(out)):
            raise NumericalError(
                f"the right-hand side is not finite (m = {m.tolist()}, Gamma = {Gam.tolist()}, torque = "
                f"{np.asarray(u).tolist()}); is the torque defined along the trajectory?"
            )
        return out

    y0 = np.concatenate([m0, R0.ravel(), Gamma0, gamma0])
    scale = max(1.0, float(np.abs(y0).max()))
    rtol, atol = tolerances
    start = time.perf_counter()
    Y, failure, nfev, n_steps = integrate_ivp(
        type(method).__name__, rhs, y0, t0, times.t, method.solver, (rtol, atol * scale), max_evaluations
    )
    run_time = time.perf_counter() - start
    ok = np.all(np.isfinite(Y), axis=1)
    m, R, Gam = Y[:, :3], Y[:, 3:12].reshape(-1, 3, 3), Y[:, 12 : 12 + n]
    torque = np.full((len(Y), n), np.nan)
    energy = np.full(len(Y), np.nan)
    for i in np.flatnonzero(ok):
        torque[i] = u_fn(times.t[i], R[i], m[i], Y[i, 12 + n :], Gam[i])
    if ok.any():
        energy[ok] = body.hamiltonian(m[ok], Gam[ok])
    failures: tuple[Failure, ...] = () if failure is None else (failure,)
    name = type(method).__name__
    if failures:
        message = f"{name} on {body.name}: {failures[0].describe()}."
    else:
        message = f"{name} ({method.solver}): {times.n_saved} outputs from t = {t0:g} to {times.t[-1]:g}."
    return Solution(
        t=times.t,
        states=Y,
        system=body,
        method=method,
        layout="rotor",
        labels=rotor_labels(n),
        quantities={"energy": energy, "spatial_momentum": np.einsum("nij,nj->ni", R, m), "tau": torque},
        status=failures[0].kind if failures else Status.SUCCESS,
        message=message,
        failures=failures,
        stats=run_stats(times.n_steps, n_steps, nfev, run_time),
        parameters=body.parameter_values() if hasattr(body, "parameter_values") else {},
    )
