r"""Simulation of nonholonomic systems with symmetry, three ways that agree as the step shrinks.

* :func:`simulate_full`: the Lagrange-d'Alembert equations in coordinates, the multipliers solved at every
  evaluation from the differentiated constraints (the index-reduced DAE
  :math:`\mathbb M\ddot q - A^T\lambda = f + B\tau`, :math:`A\ddot q + \dot A\dot q = 0`), integrated by scipy;
  the constraint residual :math:`A(q)\dot q` is recorded (it drifts, slowly, since only its derivative is
  enforced; ``baumgarte=alpha`` adds :math:`2\alpha A\dot q` to damp the drift).
* :func:`simulate_reduced`: the BKMM equations (1.1)-(1.3) of the nonholonomic seed: momentum and shape
  equations for :math:`(r, \dot r, p)` and the reconstruction :math:`\dot q_G = \Lambda(q_G)^{-1}\xi`; the
  velocity satisfies the constraints exactly at every instant.
* :func:`simulate_discrete`: a discrete Lagrange-d'Alembert integrator with the midpoint discrete Lagrangian
  :math:`L_d(q_0, q_1) = hL\big(\tfrac{q_0+q_1}{2}, \tfrac{q_1-q_0}{h}\big)`,

  .. math::

      D_2L_d(q_{k-1}, q_k) + D_1L_d(q_k, q_{k+1}) + h\,\bar F_k + h\,A(q_k)^T\lambda_k = 0, \qquad
      A\big(\tfrac{q_k+q_{k+1}}{2}\big)(q_{k+1} - q_k) = 0,

  (Cortes and Martinez, Nonlinearity 14 (2001) 1365; McLachlan and Perlmutter, J. Nonlinear Sci. 16 (2006)
  283), second order, symmetric; :math:`\bar F_k` is the average of the shape forces at the two adjacent
  midpoints. One Newton solve of size (free coordinates + constraints) per step.

Shape variables are either prescribed functions of time (a gait, given as formulas in ``t``: their
derivatives are exact) or free, driven by torques :math:`\tau(t, q, \dot q)` (zero when not given). For
prescribed shapes the torques that realise the gait are computed, and the work they do is integrated
(:math:`W = \int \tau\cdot\dot r\,dt`; with no gait and no torque the energy is conserved).
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from .. import _validate as V
from ..errors import ConvergenceError, InputError, NumericalError
from ..reduction import bkmm_reduction, lagrange_dalembert
from ..symbolic.compile import compile_matrix, compile_scalar, compile_vector
from ..symbolic.formula import to_expression
from ..systems.nonholonomic import NonholonomicSystem

__all__ = [
    "Gait",
    "NonholonomicTrajectory",
    "simulate_full",
    "simulate_reduced",
    "simulate_discrete",
    "initial_state",
]

T_SYMBOL = sp.Symbol("t", real=True)


# --------------------------------------------------------------------------------------------------
# Inputs: gaits and torques
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Gait:
    """Prescribed shape motions :math:`r_P(t)` with their first and second derivatives (exact).

    Build with :meth:`from_expressions` (``{"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}``).
    """

    names: tuple[str, ...]
    expressions: tuple[sp.Expr, ...]
    _fn: Callable = field(repr=False, compare=False)

    @classmethod
    def from_expressions(cls, shapes: Mapping[str, Any] | None) -> Gait:
        shapes = dict(shapes or {})
        names, exprs = [], []
        for name, e in shapes.items():
            e = to_expression(e, f"shapes[{name!r}]", {"t": T_SYMBOL})
            extra = sorted(s.name for s in e.free_symbols - {T_SYMBOL})
            if extra:
                raise InputError(
                    f"Expected the gait of `{name}` to be a formula in t only, got symbols {extra} in {e}."
                )
            names.append(str(name))
            exprs.append(e)
        rows = [[e, sp.diff(e, T_SYMBOL), sp.diff(e, T_SYMBOL, 2)] for e in exprs]
        f = compile_matrix(sp.Matrix(len(rows), 3, sum(rows, [])), [T_SYMBOL])

        def fn(t: float) -> np.ndarray:
            return f(np.array([float(t)]))

        return cls(tuple(names), tuple(exprs), fn)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(r, rdot, rddot)`` of the prescribed shapes at time ``t``."""
        v = self._fn(t)
        return v[:, 0], v[:, 1], v[:, 2]


class _Torques:
    """Torques on the free shapes: formulas in ``t``, the coordinates and the velocities (by name), or callables
    ``f(t, q, qd)``."""

    def __init__(self, system: NonholonomicSystem, free: Sequence[int], tau: Mapping[str, Any] | None):
        shape_names = [r.name for r in system.shape]
        self.free = list(free)
        tau = dict(tau or {})
        local = {s.name: s for s in system.q + system.qdot}
        local["t"] = T_SYMBOL
        self.fns: list[Callable | None] = [None] * len(self.free)
        for name, spec in tau.items():
            if name not in shape_names:
                raise InputError(
                    f"`tau` names `{name}`, which is not a shape variable of {system.name} ({shape_names})."
                )
            i = shape_names.index(name)
            if i not in self.free:
                raise InputError(f"`tau` drives `{name}`, which also has a prescribed gait; give one or the other.")
            if callable(spec):
                fn = spec
            else:
                e = to_expression(spec, f"tau[{name!r}]", local)
                undefined = sorted(
                    str(f.func) for f in e.atoms(sp.Function) if isinstance(f, sp.core.function.AppliedUndef)
                )
                if undefined:
                    raise InputError(
                        f"The torque on `{name}` calls unknown function(s) {undefined}; use sympy's "
                        "(sin, cos, exp, tanh, ...) or pass a Python callable f(t, q, qd)."
                    )
                e = e.xreplace({s: local[s.name] for s in e.free_symbols if s.name in local})
                extra = sorted(s.name for s in e.free_symbols - set(local.values()))
                if extra:
                    raise InputError(
                        f"The torque on `{name}` has unknown symbols {extra}; it may use t, the "
                        f"coordinates and the velocities ({', '.join(local)})."
                    )
                f = compile_scalar(e, [T_SYMBOL, *system.q, *system.qdot])
                fn = (lambda f_: lambda t, q, qd: float(f_(np.concatenate([[t], q, qd]))))(f)
            self.fns[self.free.index(i)] = fn

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return np.array([0.0 if f is None else float(f(t, q, qd)) for f in self.fns])


@dataclass
class _Setup:
    system: NonholonomicSystem
    gait: Gait
    prescribed: list[int]  # shape indices (0..sigma-1) with a gait
    free_shapes: list[int]
    torques: _Torques

    @property
    def n(self) -> int:
        return self.system.n

    def free_coordinates(self) -> list[int]:
        s = self.system
        return list(range(s.k)) + [s.k + i for i in self.free_shapes]

    def prescribed_coordinates(self) -> list[int]:
        return [self.system.k + i for i in self.prescribed]


def _setup(system: NonholonomicSystem, shapes: Any, tau: Any) -> _Setup:
    if not isinstance(system, NonholonomicSystem):
        raise InputError(f"Expected `system` to be a NonholonomicSystem, got {type(system).__name__}.")
    gait = shapes if isinstance(shapes, Gait) else Gait.from_expressions(shapes)
    names = [r.name for r in system.shape]
    unknown = [n for n in gait.names if n not in names]
    if unknown:
        raise InputError(f"The gait names {unknown}, which are not shape variables of {system.name} ({names}).")
    prescribed = [names.index(n) for n in gait.names]
    free = [i for i in range(system.sigma) if i not in prescribed]
    return _Setup(system, gait, prescribed, free, _Torques(system, free, tau))


def _by_name(value: Any, names: Sequence[str], argname: str) -> dict[str, float]:
    if value is None:
        return {}
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(names))
        if unknown:
            raise InputError(f"`{argname}` names {unknown}, which are not among {list(names)}.")
        return {k: float(v) for k, v in value.items()}
    arr = V.finite(value, argname).ravel()
    if arr.size != len(names):
        raise InputError(f"Expected `{argname}` to have {len(names)} entries ({list(names)}), got {arr.size}.")
    return dict(zip(names, arr.tolist()))


def initial_state(
    system: NonholonomicSystem,
    shapes: Any = None,
    *,
    t0: float = 0.0,
    q0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    qd0: Any = None,
    parameters: Mapping[str, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    r"""A consistent initial state ``(q0, qd0)``.

    Group coordinates from ``q0`` (default: the identity), shapes from the gait at ``t0``, else ``q0``, else 0;
    shape velocities from the gait, else ``rdot0``, else 0; the group velocity from the reconstruction
    equation (1.1) with nonholonomic momentum ``p0`` (default 0), so that the constraints hold. For the
    snakeboard starting at :math:`\phi = 0` this is :math:`\dot x = \dot y = \dot\theta = 0`. An explicit ``qd0``
    is used as given after checking the constraints; ``qd0="rest"`` is the group at rest (:math:`\dot g = 0`)
    with the shape velocities above, an :class:`~geomech.errors.InputError` where that violates the
    constraints (when they involve the shape velocities).
    """
    setup = _setup(system, shapes, None)
    names = [s.name for s in system.q]
    given = _by_name(q0, names, "q0")
    q = np.array([given.get(n, 0.0) for n in names])
    r_p, rd_p, _ = setup.gait(t0)
    for j, i in enumerate(setup.prescribed):
        q[system.k + i] = r_p[j]
    lda = lagrange_dalembert(system).numeric(parameters)
    _require_positive_kinetic_energy(system, lda, q, parameters)
    if isinstance(qd0, str):
        if qd0 != "rest":
            raise InputError(f"Expected `qd0` to be velocities or 'rest', got {qd0!r}.")
        if p0 is not None:
            raise InputError(
                "Give `p0` or qd0='rest', not both: at rest the momentum follows from the shape velocities."
            )
        qd = np.r_[np.zeros(system.k), _shape_rates(system, setup, rdot0, rd_p)]
        res = np.abs(lda.constraint_residual(q, qd)).max(initial=0.0)
        if res > 1e-9 * max(1.0, np.abs(qd).max()):
            raise InputError(
                f"{system.name} cannot start at rest with these shape velocities: |A(q0) qd0| = {res:.3g} "
                "(its constraints involve the shape velocities); give `p0` instead."
            )
        return q, qd
    if qd0 is not None:
        qd = (
            np.array([_by_name(qd0, [s.name for s in system.qdot], "qd0").get(s.name, 0.0) for s in system.qdot])
            if isinstance(qd0, Mapping)
            else V.finite(qd0, "qd0").ravel()
        )
        if qd.size != system.n:
            raise InputError(f"Expected `qd0` to have {system.n} entries, got {qd.size}.")
        res = np.abs(lda.constraint_residual(q, qd)).max(initial=0.0)
        if res > 1e-9 * max(1.0, np.abs(qd).max()):
            raise InputError(
                f"`qd0` violates the constraints: |A(q0) qd0| = {res:.3g}; give a velocity in D, or "
                "give `rdot0` and `p0` and let the group velocity follow from eq. (1.1)."
            )
        return q, qd
    red = bkmm_reduction(system)
    rd = _shape_rates(system, setup, rdot0, rd_p)
    p = np.zeros(red.m) if p0 is None else V.finite(p0, "p0").ravel()
    if p.size != red.m:
        raise InputError(
            f"Expected `p0` to have {red.m} entries (the nonholonomic momentum of {system.name}, basis: "
            f"{red.normalization}), got {p.size}."
        )
    rn = red.numeric(parameters)
    xi = rn.xi(q[system.k :], rd, p)
    lam_inv = _group_rates(system)
    qd = np.r_[lam_inv(q[: system.k]) @ xi, rd]
    return q, qd


def _shape_rates(system: NonholonomicSystem, setup: Any, rdot0: Any, rd_p: np.ndarray) -> np.ndarray:
    """Shape velocities at the start: the gait's where prescribed, else ``rdot0``, else 0."""
    rd = np.zeros(system.sigma)
    rd_given = _by_name(rdot0, [r.name for r in system.shape], "rdot0")
    for i, r in enumerate(system.shape):
        rd[i] = rd_given.get(r.name, 0.0)
    for j, i in enumerate(setup.prescribed):
        rd[i] = rd_p[j]
    return rd


def _require_positive_kinetic_energy(
    system: NonholonomicSystem, lda: Any, q: np.ndarray, parameters: Mapping[str, float] | None
) -> None:
    """Parameter values (a negative mass, a wrong inertia) can make the kinetic energy indefinite on D, where
    the equations have no meaning: say so at the start, with the values, rather than integrate nonsense."""
    M, A = lda.mass_matrix(q), lda.constraint_matrix(q).reshape(system.c, system.n)
    if system.c:
        _, sv, vt = np.linalg.svd(A)
        X = vt[int(np.sum(sv > 1e-12 * max(1.0, sv.max()))) :].T
    else:
        X = np.eye(system.n)
    if X.size == 0:
        return
    MD = X.T @ M @ X
    low = float(np.linalg.eigvalsh(0.5 * (MD + MD.T)).min())
    if not low > 1e-12 * max(1.0, float(np.abs(MD).max())):
        values = {k: v for k, v in sorted(system.parameter_values(parameters).items(), key=lambda kv: kv[0].name)}
        shown = ", ".join(f"{k.name}={v:g}" for k, v in values.items())
        raise InputError(
            f"The kinetic energy of {system.name} is not positive definite on the constraint distribution "
            f"at q0 = {np.round(q, 6).tolist()} (smallest eigenvalue {low:.3g}) with {shown}: check the "
            "signs and sizes of the masses and inertias."
        )


def _group_rates(system: NonholonomicSystem) -> Callable[[np.ndarray], np.ndarray]:
    f = compile_vector(sp.Matrix(system.group.body_velocity_inverse).tolist(), list(system.group.coordinates))

    def rates(g: np.ndarray) -> np.ndarray:
        Li = f(np.asarray(g, dtype=float))
        if not np.all(np.isfinite(Li)):
            raise NumericalError(
                f"The coordinates of {system.group.name} are singular at {np.asarray(g)} (gimbal "
                "lock of the Euler-angle chart); start elsewhere or use another sequence."
            )
        return Li

    return rates


# --------------------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class NonholonomicTrajectory:
    """A simulated motion.

    Attributes
    ----------
    t : (N,) times; q, qd : (N, n) coordinates and velocities; p : (N, m) nonholonomic momentum;
    tau : (N, sigma) shape forces (given, or required by the gait); energy : (N,);
    residual : (N, c) constraint residual :math:`A(q)\\dot q`; work : (N,) work done by the shape forces;
    method, status (0 = success), message, nfev.
    """

    system: NonholonomicSystem = field(repr=False)
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    p: np.ndarray
    tau: np.ndarray
    energy: np.ndarray
    residual: np.ndarray
    work: np.ndarray
    method: str
    status: int = 0
    message: str = ""
    nfev: int = 0

    @property
    def max_residual(self) -> float:
        return float(np.abs(self.residual).max(initial=0.0))

    def final(self) -> dict[str, float]:
        """Final coordinates by name."""
        return {s.name: float(v) for s, v in zip(self.system.q, self.q[-1])}

    def summary(self) -> dict[str, Any]:
        s = self.system
        return {
            "system": s.name,
            "method": self.method,
            "t_final": float(self.t[-1]),
            "initial_velocity": {v.name: float(x) for v, x in zip(s.qdot, self.qd[0])},
            "initial_momentum": [float(x) for x in self.p[0]],
            "final_configuration": self.final(),
            "final_velocity": {v.name: float(x) for v, x in zip(s.qdot, self.qd[-1])},
            "nonholonomic_momentum": [float(x) for x in self.p[-1]],
            "constraint_residual_max": self.max_residual,
            "constraint_residual_final": float(np.abs(self.residual[-1]).max(initial=0.0)),
            "work_by_shape_inputs": float(self.work[-1]),
            "energy_initial": float(self.energy[0]),
            "energy_final": float(self.energy[-1]),
            "energy_change_minus_work": float(self.energy[-1] - self.energy[0] - self.work[-1]),
            "status": self.status,
            "message": self.message,
        }

    def to_dataset(self) -> Any:
        """The trajectory as a self-describing :class:`xarray.Dataset` (write it with ``.to_netcdf``)."""
        import xarray as xr

        from .._version import __version__

        s = self.system
        return xr.Dataset(
            {
                "q": (("t", "coordinate"), self.q, {"long_name": "generalized coordinates (group, then shape)"}),
                "qdot": (("t", "coordinate"), self.qd, {"long_name": "generalized velocities"}),
                "p": (("t", "momentum_index"), self.p, {"long_name": "nonholonomic momentum (BKMM basis)"}),
                "tau": (("t", "shape"), self.tau, {"long_name": "generalized force on each shape variable"}),
                "energy": ("t", self.energy, {"long_name": "energy (kinetic plus potential)"}),
                "work": ("t", self.work, {"long_name": "work done by the shape inputs since the start"}),
                "constraint_residual": (("t", "constraint"), self.residual, {"long_name": "A(q) qdot"}),
            },
            coords={
                "t": ("t", self.t, {"long_name": "time"}),
                "coordinate": [x.name for x in s.q],
                "shape": [r.name for r in s.shape],
                "momentum_index": np.arange(self.p.shape[1]) + 1,
                "constraint": np.arange(s.c) + 1,
            },
            attrs={
                "system": s.name,
                "group": s.group.name,
                "method": self.method,
                "status": self.status,
                "message": self.message,
                "geomech_version": __version__,
                "parameters": json.dumps({str(k): float(v) for k, v in s.parameters.items()}),
            },
        )

    def to_csv(self, path: str | Path) -> Path:
        """Write the trajectory (one row per time) to ``path``."""
        s = self.system
        cols = (
            ["t"]
            + [x.name for x in s.q]
            + [v.name for v in s.qdot]
            + [f"p{i + 1}" for i in range(self.p.shape[1])]
            + [f"tau_{r.name}" for r in s.shape]
            + ["energy", "work"]
            + [f"residual{a + 1}" for a in range(s.c)]
        )
        data = np.column_stack([self.t, self.q, self.qd, self.p, self.tau, self.energy, self.work, self.residual])
        path = Path(path)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            w.writerows(data.tolist())
        return path


def _finish(
    setup: _Setup,
    method: str,
    t: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    work: np.ndarray,
    parameters: Mapping | None,
    status: int = 0,
    message: str = "",
    nfev: int = 0,
) -> NonholonomicTrajectory:
    s = setup.system
    lda = lagrange_dalembert(s).numeric(parameters)
    rn = bkmm_reduction(s).numeric(parameters)
    return NonholonomicTrajectory(
        s,
        t,
        q,
        qd,
        rn.momentum(q, qd).reshape(len(t), -1),
        tau,
        lda.energy(q, qd),
        lda.constraint_residual(q, qd).reshape(len(t), s.c),
        work,
        method,
        status,
        message,
        nfev,
    )


def _time_grid(t_final: float, t_eval: Any, samples: int, t0: float) -> np.ndarray:
    if t_eval is not None:
        te = V.finite(t_eval, "t_eval").ravel()
        if te.size < 2 or np.any(np.diff(te) <= 0):
            raise InputError("Expected `t_eval` to be increasing with at least two times.")
        return te
    tf = float(t_final)
    if not np.isfinite(tf) or tf <= t0:
        raise InputError(f"Expected `t_final` > t0 = {t0}, got {t_final!r}.")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 2 <= samples <= 10**7:
        raise InputError(f"Expected `samples` to be an integer from 2 to 1e7, got {samples!r}.")
    te = np.linspace(t0, tf, int(samples))
    if np.any(np.diff(te) <= 0):
        raise InputError(
            f"Expected `t_final` - t0 = {tf - t0:.3g} to be resolvable into {samples} distinct times "
            "in double precision; take a longer span or fewer samples."
        )
    return te


# --------------------------------------------------------------------------------------------------
# (a) full equations with multipliers
# --------------------------------------------------------------------------------------------------
def _accelerations(
    setup: _Setup, funcs: dict, t: float, q: np.ndarray, qd: np.ndarray, rdd_p: np.ndarray, baumgarte: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Accelerations of the free coordinates, multipliers and the full shape-force vector at one state."""
    s = setup.system
    x = np.r_[q, qd]
    M, f, A, Adq = funcs["M"](x), funcs["f"](x)[:, 0], funcs["A"](x).reshape(s.c, s.n), funcs["Adq"](x)[:, 0]
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    tau_f = setup.torques(t, q, qd)
    F = f.copy()
    F[[s.k + i for i in setup.free_shapes]] += tau_f
    nf, c, npr = len(fr), s.c, len(pr)
    K = np.zeros((s.n + c, nf + c + npr))
    K[: s.n, :nf] = M[:, fr]
    K[: s.n, nf : nf + c] = -A.T
    for j, i in enumerate(pr):
        K[i, nf + c + j] = -1.0
    K[s.n :, :nf] = A[:, fr]
    rhs = np.r_[F - M[:, pr] @ rdd_p, -Adq - A[:, pr] @ rdd_p - 2.0 * baumgarte * (A @ qd)]
    try:
        z = np.linalg.solve(K, rhs)
    except np.linalg.LinAlgError as exc:
        raise NumericalError(f"The constrained equations are singular at t = {t:.6g}, q = {q}.") from exc
    tau = np.zeros(s.sigma)
    tau[setup.free_shapes] = tau_f
    tau[setup.prescribed] = z[nf + c :]
    return z[:nf], z[nf : nf + c], tau


#: Default ceiling on right-hand-side evaluations of the adaptive simulators (tens of seconds of work).
MAX_EVALUATIONS = 200_000


#: Evaluations after which the pace of the integration is measured and the whole run's cost projected.
_PILOT = 2_000


class _OverBudget(Exception):
    def __init__(self, t: float, count: int, projected: float | None = None):
        self.t, self.count, self.projected = t, count, projected


def _budgeted(rhs: Callable, max_evaluations: Any, t_span: tuple[float, float]) -> Callable:
    """``rhs`` that stops the integration (raising :class:`_OverBudget`) past ``max_evaluations`` calls, or
    early, after a pilot of :data:`_PILOT` calls, when the pace so far projects a total far above it."""
    limit = int(V.positive_scalar(max_evaluations, "max_evaluations"))
    t_start, t_end = t_span
    count = 0
    t_max = t_start

    def counted(t: float, y: np.ndarray) -> np.ndarray:
        nonlocal count, t_max
        count += 1
        t_max = max(t_max, t)
        if count == _PILOT and limit > _PILOT and t_max > t_start:
            projected = count * (t_end - t_start) / (t_max - t_start)
            if projected > 2.0 * limit:
                raise _OverBudget(t, count, projected)
        if count > limit:
            raise _OverBudget(t, count - 1)
        return rhs(t, y)

    return counted


def _integrate(name: str, rhs: Callable, te: np.ndarray, y0: np.ndarray, max_evaluations: Any, **kw: Any) -> Any:
    """solve_ivp within a budget of evaluations; a failure or an exhausted budget says where and why."""
    try:
        sol = solve_ivp(_budgeted(rhs, max_evaluations, (te[0], te[-1])), (te[0], te[-1]), y0, t_eval=te, **kw)
    except _OverBudget as stop:
        if stop.projected is not None:
            raise InputError(
                f"{name}: at the pace of its first {stop.count} evaluations (to t = {stop.t:.6g}) the run to "
                f"{te[-1]:.6g} needs about {min(stop.projected, 1e300):.3g} evaluations of the equations, above "
                f"`max_evaluations` = {int(max_evaluations)}; shorten t_final or raise `max_evaluations`."
            ) from None
        raise NumericalError(
            f"{name}: stopped after {stop.count} evaluations of the equations at t = {stop.t:.6g} of "
            f"{te[-1]:.6g} (`max_evaluations`): the motion is faster, or the time span longer, than the budget "
            "allows; shorten t_final or raise `max_evaluations`."
        ) from None
    if sol.status < 0:
        raise NumericalError(f"{name}: the integrator failed at t = {sol.t[-1]:.6g}: {sol.message}")
    return sol


def simulate_full(
    system: NonholonomicSystem,
    t_final: float | None = None,
    *,
    shapes: Any = None,
    tau: Any = None,
    q0: Any = None,
    qd0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    t0: float = 0.0,
    t_eval: Any = None,
    samples: int = 201,
    parameters: Mapping[str, float] | None = None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    baumgarte: float = 0.0,
    max_evaluations: int = MAX_EVALUATIONS,
) -> NonholonomicTrajectory:
    """Integrate the Lagrange-d'Alembert equations with multipliers (the index-reduced DAE), method (a).

    Parameters
    ----------
    system : NonholonomicSystem
    t_final : float
        Final time (or give ``t_eval``).
    shapes : mapping or Gait, optional
        Prescribed shapes, ``{"psi": "sin(2*pi*t)"}``; the others are free.
    tau : mapping, optional
        Torques on free shapes, formulas in ``t``, coordinates and velocities, or callables ``f(t, q, qd)``.
    q0, qd0, rdot0, p0 :
        Initial state, see :func:`initial_state`.
    parameters : mapping, optional
        Parameter values not stored in the system.
    method, rtol, atol :
        Passed to :func:`scipy.integrate.solve_ivp`.
    baumgarte : float
        :math:`\\alpha \\ge 0` of the stabilised constraint :math:`A\\ddot q + \\dot A\\dot q + 2\\alpha A\\dot q = 0`.
    max_evaluations : int
        Ceiling on evaluations of the equations (default 200,000, tens of seconds): past it the integration
        stops with a :class:`~geomech.errors.NumericalError` saying at which time.

    Returns
    -------
    NonholonomicTrajectory
    """
    setup = _setup(system, shapes, tau)
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qd0=qd0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    te = _time_grid(t_final, t_eval, samples, t0)
    funcs = lagrange_dalembert(system).numeric(parameters).funcs
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    nf = len(fr)

    def full_state(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd = np.empty(system.n), np.empty(system.n)
        q[fr], qd[fr] = y[:nf], y[nf : 2 * nf]
        r_p, rd_p, rdd_p = setup.gait(t)
        q[pr], qd[pr] = r_p, rd_p
        return q, qd, rdd_p

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, rdd_p = full_state(t, y)
        a, _, tau_v = _accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)
        return np.r_[qd[fr], a, tau_v @ qd[system.k :]]

    y0 = np.r_[q_init[fr], qd_init[fr], 0.0]
    sol = _integrate("simulate_full", rhs, te, y0, max_evaluations, method=method, rtol=rtol, atol=atol)
    Q, QD, TAU = [], [], []
    for t, y in zip(sol.t, sol.y.T):
        q, qd, rdd_p = full_state(t, y)
        TAU.append(_accelerations(setup, funcs, t, q, qd, rdd_p, baumgarte)[2])
        Q.append(q)
        QD.append(qd)
    return _finish(
        setup,
        f"full ({method})",
        sol.t,
        np.array(Q),
        np.array(QD),
        np.array(TAU).reshape(len(sol.t), -1),
        sol.y[-1],
        parameters,
        sol.status,
        sol.message,
        sol.nfev,
    )


# --------------------------------------------------------------------------------------------------
# (b) reduced equations
# --------------------------------------------------------------------------------------------------
def simulate_reduced(
    system: NonholonomicSystem,
    t_final: float | None = None,
    *,
    shapes: Any = None,
    tau: Any = None,
    q0: Any = None,
    qd0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    t0: float = 0.0,
    t_eval: Any = None,
    samples: int = 201,
    parameters: Mapping[str, float] | None = None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_evaluations: int = MAX_EVALUATIONS,
) -> NonholonomicTrajectory:
    """Integrate the BKMM equations (1.1)-(1.3): momentum, shape and reconstruction, method (b).

    Same arguments as :func:`simulate_full`. The state is ``(g, r_free, rdot_free, p, W)``; the group
    coordinates follow :math:`\\dot q_G = \\Lambda(q_G)^{-1}\\xi(r, \\dot r, p)`.
    """
    setup = _setup(system, shapes, tau)
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qd0=qd0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    te = _time_grid(t_final, t_eval, samples, t0)
    red = bkmm_reduction(system)
    rn = red.numeric(parameters)
    rates = _group_rates(system)
    k, sigma, m = system.k, system.sigma, red.m
    F, P = setup.free_shapes, setup.prescribed
    nF = len(F)

    def unpack(t: float, y: np.ndarray):
        g = y[:k]
        r, rd = np.empty(sigma), np.empty(sigma)
        r[F], rd[F] = y[k : k + nF], y[k + nF : k + 2 * nF]
        r_p, rd_p, rdd_p = setup.gait(t)
        r[P], rd[P] = r_p, rd_p
        p = y[k + 2 * nF : k + 2 * nF + m]
        return g, r, rd, rdd_p, p

    def evaluate(t: float, y: np.ndarray):
        g, r, rd, rdd_p, p = unpack(t, y)
        xi = rn.xi(r, rd, p)
        q, qd = np.r_[g, r], np.r_[rates(g) @ xi, rd]
        tau_f = setup.torques(t, q, qd)
        M, delta = rn.shape_mass(r, rd, p), rn.delta(r, rd, p)
        # Unknowns: free shape accelerations and the forces that realise the gait.
        K = np.zeros((sigma, sigma))
        K[:, :nF] = M[:, F]
        for j, i in enumerate(P):
            K[i, nF + j] = -1.0
        b = delta.copy()
        b[F] += tau_f
        b -= M[:, P] @ rdd_p
        z = np.linalg.solve(K, b) if sigma else np.zeros(0)
        tau_v = np.zeros(sigma)
        tau_v[F], tau_v[P] = tau_f, z[nF:]
        return q, qd, xi, z[:nF], tau_v, rn.pdot(r, rd, p)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd, _, rdd_f, tau_v, pdot = evaluate(t, y)
        return np.r_[qd[:k], qd[k:][F], rdd_f, pdot, tau_v @ qd[k:]]

    p_init = rn.momentum(q_init, qd_init)
    y0 = np.r_[q_init[:k], q_init[k:][F], qd_init[k:][F], p_init, 0.0]
    sol = _integrate("simulate_reduced", rhs, te, y0, max_evaluations, method=method, rtol=rtol, atol=atol)
    Q, QD, TAU = [], [], []
    for t, y in zip(sol.t, sol.y.T):
        q, qd, _, _, tau_v, _ = evaluate(t, y)
        Q.append(q)
        QD.append(qd)
        TAU.append(tau_v)
    return _finish(
        setup,
        f"reduced ({method})",
        sol.t,
        np.array(Q),
        np.array(QD),
        np.array(TAU).reshape(len(sol.t), -1),
        sol.y[-1],
        parameters,
        sol.status,
        sol.message,
        sol.nfev,
    )


# --------------------------------------------------------------------------------------------------
# (c) discrete Lagrange-d'Alembert
# --------------------------------------------------------------------------------------------------
class _DiscreteKernels:
    """Compiled derivatives of L and A for the midpoint discrete Lagrangian."""

    def __init__(self, system: NonholonomicSystem, parameters: Mapping | None):
        s = system
        pv = s.parameter_values(parameters)
        L = s.lagrangian.subs(pv)
        q, v = list(s.q), list(s.qdot)
        Lq = sp.Matrix([sp.diff(L, a) for a in q])
        Lv = sp.Matrix([sp.diff(L, a) for a in v])
        x = q + v
        self.Lq = compile_vector(list(Lq), x)
        self.Lv = compile_vector(list(Lv), x)
        self.Lqq = compile_vector(Lq.jacobian(q).tolist(), x)
        self.Lqv = compile_vector(Lq.jacobian(v).tolist(), x)
        self.Lvv = compile_vector(Lv.jacobian(v).tolist(), x)
        A = sp.Matrix(s.constraint_matrix).subs(pv)
        self.A = compile_vector(A.tolist(), q)
        dA = [[[sp.diff(A[a, i], qj) for qj in q] for i in range(s.n)] for a in range(s.c)]
        self.dA = compile_vector(dA, q) if s.c else None


def simulate_discrete(
    system: NonholonomicSystem,
    t_final: float,
    h: float,
    *,
    shapes: Any = None,
    tau: Any = None,
    q0: Any = None,
    qd0: Any = None,
    rdot0: Any = None,
    p0: Any = None,
    t0: float = 0.0,
    parameters: Mapping[str, float] | None = None,
    tol: float = 1e-12,
    max_iter: int = 30,
    max_steps: int = 1_000_000,
) -> NonholonomicTrajectory:
    r"""The discrete Lagrange-d'Alembert integrator with the midpoint rule, method (c); second order.

    Fixed step ``h`` (``t_final - t0`` is rounded to a whole number of steps). The velocity reported at a node
    is the discrete Legendre transform :math:`D_2L_d + \tfrac h2\bar F`, projected on :math:`\mathcal D` with
    the kinetic metric; the work is :math:`\sum_k h\,\tau_{k+1/2}\cdot(r_{k+1} - r_k)/h`.
    """
    setup = _setup(system, shapes, tau)
    s = system
    h = float(h)
    if not np.isfinite(h) or h <= 0:
        raise InputError(f"Expected the step `h` to be positive, got {h!r}.")
    span = (float(V.finite(t_final, "t_final")) - float(V.finite(t0, "t0"))) / h
    V.work_budget(
        span,
        float(max_steps),
        f"The number of steps (t_final - t0 = {span * h:.3g} over h = {h:.3g})",
        "max_steps",
        "take a larger h or a shorter span",
        seconds_each=2e-4,
    )
    nsteps = int(round(span))
    if nsteps < 1:
        raise InputError(f"Expected t_final - t0 >= h, got t_final = {t_final}, t0 = {t0}, h = {h}.")
    h = (float(t_final) - t0) / nsteps
    q_init, qd_init = initial_state(
        system, setup.gait, t0=t0, q0=q0, qd0=qd0, rdot0=rdot0, p0=p0, parameters=parameters
    )
    ker = _DiscreteKernels(system, parameters)
    fr, pr = setup.free_coordinates(), setup.prescribed_coordinates()
    shape_free = [s.k + i for i in setup.free_shapes]
    nf, c, n = len(fr), s.c, s.n

    def mid(q0_: np.ndarray, q1_: np.ndarray) -> np.ndarray:
        return np.r_[(q0_ + q1_) / 2, (q1_ - q0_) / h]

    def D1(q0_, q1_):
        x = mid(q0_, q1_)
        return h / 2 * ker.Lq(x) - ker.Lv(x)

    def D2(q0_, q1_):
        x = mid(q0_, q1_)
        return h / 2 * ker.Lq(x) + ker.Lv(x)

    def forcing(t_mid: float, q0_, q1_) -> np.ndarray:
        F = np.zeros(n)
        x = mid(q0_, q1_)
        F[shape_free] = setup.torques(t_mid, x[:n], x[n:])
        return F

    def dD1_dq1(q0_, q1_):
        x = mid(q0_, q1_)
        Lqq, Lqv, Lvv = ker.Lqq(x), ker.Lqv(x), ker.Lvv(x)
        return h / 2 * (Lqq / 2 + Lqv / h) - (Lqv.T / 2 + Lvv / h)

    def prescribed_at(t: float) -> np.ndarray:
        return setup.gait(t)[0]

    def newton(q0_, guess, base, t_next, lam_weight):
        """Solve base + D1(q0, q1) + h/2 F(k+1/2) + lam_weight A(q0)^T lam = 0 (free rows), A(mid)(q1 - q0) = 0."""
        q1 = guess.copy()
        q1[pr] = prescribed_at(t_next)
        lam = np.zeros(c)
        A0 = ker.A(q0_).reshape(c, n)
        for it in range(max_iter):
            tm = t_next - h / 2
            R1 = base + D1(q0_, q1) + h / 2 * forcing(tm, q0_, q1) + lam_weight * A0.T @ lam
            qm = (q0_ + q1) / 2
            Am = ker.A(qm).reshape(c, n)
            R2 = Am @ (q1 - q0_)
            R = np.r_[R1[fr], R2]
            scale = 1.0 + np.abs(base).max(initial=0.0)
            if np.abs(R).max(initial=0.0) < tol * scale and it > 0:
                return q1, lam
            J = np.zeros((nf + c, nf + c))
            J[:nf, :nf] = dD1_dq1(q0_, q1)[np.ix_(fr, fr)]
            J[:nf, nf:] = lam_weight * A0.T[fr]
            if c:
                dA = ker.dA(qm).reshape(c, n, n)
                J[nf:, :nf] = (Am + 0.5 * np.einsum("aij,i->aj", dA, q1 - q0_))[:, fr]
            try:
                dz = np.linalg.solve(J, -R)
            except np.linalg.LinAlgError as exc:
                raise NumericalError(f"simulate_discrete: singular Newton matrix at t = {t_next:.6g}.") from exc
            q1 = q1.copy()
            q1[fr] += dz[:nf]
            lam = lam + dz[nf:]
        raise ConvergenceError(
            f"simulate_discrete: Newton did not converge in {max_iter} iterations at "
            f"t = {t_next:.6g} (step {h:.3g}, residual {np.abs(R).max():.3g}); reduce h."
        )

    lda = lagrange_dalembert(system).numeric(parameters)
    times = t0 + h * np.arange(nsteps + 1)
    Q = np.empty((nsteps + 1, n))
    Q[0] = q_init
    p_plus = ker.Lv(np.r_[q_init, qd_init])
    tau_mid = np.zeros((nsteps, s.sigma))
    work = np.zeros(nsteps + 1)
    for k in range(nsteps):
        # First step: the continuous momentum p0 stands for D2 L_d of a previous step; half the impulse.
        if k == 0:
            q1, _ = newton(Q[0], Q[0] + h * qd_init, p_plus, times[1], h / 2)
        else:
            base = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
            q1, _ = newton(Q[k], 2 * Q[k] - Q[k - 1], base, times[k + 1], h)
        Q[k + 1] = q1
    # Node velocities from the discrete Legendre transform, projected on D; shape forces at midpoints.
    QD = np.empty_like(Q)
    QD[0] = qd_init
    for k in range(1, nsteps + 1):
        pk = D2(Q[k - 1], Q[k]) + h / 2 * forcing(times[k] - h / 2, Q[k - 1], Q[k])
        M = lda.mass_matrix(Q[k])
        A = lda.constraint_matrix(Q[k]).reshape(c, n)
        Kmat = np.block([[M, -A.T], [A, np.zeros((c, c))]])
        QD[k] = np.linalg.solve(Kmat, np.r_[pk, np.zeros(c)])[:n]
    for k in range(nsteps):
        x = mid(Q[k], Q[k + 1])
        tm = times[k] + h / 2
        tau_v = np.zeros(s.sigma)
        tau_v[setup.free_shapes] = setup.torques(tm, x[:n], x[n:])
        if pr:
            # Forces realising the gait, from the continuous equations at the midpoint state (O(h^2) accurate).
            _, _, rdd_p = setup.gait(tm)
            _, _, tau_full = _accelerations(setup, lda.funcs, tm, x[:n], x[n:], rdd_p)
            tau_v[setup.prescribed] = tau_full[setup.prescribed]
        tau_mid[k] = tau_v
        work[k + 1] = work[k] + tau_v @ (Q[k + 1, s.k :] - Q[k, s.k :])
    TAU = np.vstack([tau_mid, tau_mid[-1:]]) if nsteps else np.zeros((1, s.sigma))
    out = _finish(
        setup,
        f"discrete Lagrange-d'Alembert (midpoint, h = {h:.3g})",
        times,
        Q,
        QD,
        TAU,
        work,
        parameters,
        0,
        "",
        nsteps,
    )
    # The projected node velocities satisfy the constraints exactly; the honest residual of the scheme is that of
    # the centred difference quotient, A(q_k)(q_{k+1} - q_{k-1}) / 2h = O(h^2) (one-sided at the ends).
    V_fd = np.gradient(Q, times, axis=0, edge_order=2) if nsteps >= 2 else QD
    residual = lda.constraint_residual(Q, V_fd).reshape(nsteps + 1, c)
    return NonholonomicTrajectory(
        out.system,
        out.t,
        out.q,
        out.qd,
        out.p,
        out.tau,
        out.energy,
        residual,
        out.work,
        out.method,
        out.status,
        out.message,
        out.nfev,
    )
