"""The result of :func:`geomech.solve`: one immutable trajectory type for every system and method.

Numerical failure is data here (``status``, ``failures``), as in diffrax: :func:`~geomech.solve` raises it as
an exception only when asked to (the default), and the exception carries the partial :class:`Solution`.
"""

from __future__ import annotations

import enum
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

__all__ = ["Failure", "Solution", "STATUS", "Status", "QUANTITIES", "run_stats"]


class Status(str, enum.Enum):
    """How a run ended: ``SUCCESS`` or the kind of its first failure (equal to its value as a string)."""

    SUCCESS = "success"
    NEWTON_FAILED = "newton_failed"
    NONFINITE = "nonfinite"
    SINGULAR_JACOBIAN = "singular_jacobian"
    ADAPTIVE_FAILED = "adaptive_failed"
    NOT_PERIODIC = "not_periodic"
    LEFT_CHART = "left_chart"
    SINGULAR_CONSTRAINTS = "singular_constraints"
    BUDGET_EXHAUSTED = "budget_exhausted"

    def __str__(self) -> str:
        return self.value


#: Status codes of the compiled loops (the first column of their INFO array).
STATUS = {
    0: Status.SUCCESS,
    1: Status.NEWTON_FAILED,
    2: Status.NONFINITE,
    3: Status.SINGULAR_JACOBIAN,
    4: Status.ADAPTIVE_FAILED,
    5: Status.NOT_PERIODIC,
    6: Status.LEFT_CHART,
    7: Status.SINGULAR_CONSTRAINTS,
    8: Status.BUDGET_EXHAUSTED,
}

_WHAT = {
    Status.NEWTON_FAILED: "Newton's method did not converge",
    Status.SINGULAR_JACOBIAN: "the Newton matrix is singular",
    Status.NONFINITE: "the state became non-finite",
    Status.ADAPTIVE_FAILED: "the adaptive solver gave up",
    Status.NOT_PERIODIC: "the orbit is not periodic (a separatrix, or it leaves L_bounds)",
    Status.LEFT_CHART: "the state reached the end of its chart (a pole of the coordinates, e.g. the "
    "Serret-Andoyer L = +-G or the Euler angle theta = 0, pi), where the formula means nothing; switch "
    "charts (GeneralizedSerretAndoyer.simulate does) or integrate on the group",
    Status.SINGULAR_CONSTRAINTS: "the constrained equations of motion became singular (the constraints are "
    "dependent there, or the mass matrix is degenerate)",
    Status.BUDGET_EXHAUSTED: "the run used up its budget of evaluations (`max_evaluations`)",
}

#: Quantities a solution may carry along its trajectory: name -> (description, component dimension or None).
QUANTITIES: dict[str, tuple[str, str | None]] = {
    "energy": ("energy (the Hamiltonian, or kinetic plus potential energy)", None),
    "casimir": ("Casimir |m| of so(3)*", None),
    "spatial_momentum": ("spatial momentum: the momentum map J = Ad*_{g^-1} p, R m for a body on SO(3)", "axis"),
    "momentum": (
        "nonholonomic momentum (components in the reduction's basis; the body momentum without constraints)",
        "momentum_index",
    ),
    "tau": ("generalized force on each shape variable (given, or required by the prescribed shapes)", "shape"),
    "work": ("work done by the shape forces since the start", None),
    "constraint_residual": ("constraint residual A(q) qdot", "constraint"),
    "serret_andoyer": ("Serret-Andoyer (l, L) and reconstruction angle phi in the chart in use", "lLphi"),
    "chart_axis": ("body axis (1 to 3) of the Serret-Andoyer chart in use", None),
    "stm": ("state transition matrix dy(t)/dy(t0): row a component of y(t), column one of y(t0)", None),
    "parameter_sensitivity": ("sensitivity dy(t)/dp: row a component of y(t), column a parameter", None),
}


def run_stats(
    n_steps: int,
    n_internal_steps: int,
    n_rhs: int,
    run_time: float,
    *,
    n_newton: int = 0,
    backend: str = "python",
    compile_time: float = 0.0,
    **extra: Any,
) -> dict[str, Any]:
    """The counters of :attr:`Solution.stats`, the same for every engine (``extra`` adds method-specific ones)."""
    return {
        "n_steps": int(n_steps),
        "n_internal_steps": int(n_internal_steps),
        "n_rhs": int(n_rhs),
        "n_newton": int(n_newton),
        "backend": backend,
        "compile_time": float(compile_time),
        "run_time": float(run_time),
        **extra,
    }


@dataclass(frozen=True)
class Failure:
    """Where and why one trajectory of a run failed.

    ``batch_index`` is the position in the batch, ``step`` the step that failed (the state saved before it
    is the last valid one; for adaptive methods, the number of the first output time not reached), ``time``
    the time at the start of that step (the last time reached), ``residual`` the max-norm of the implicit
    equations at the last Newton iterate (NaN when not applicable), ``detail`` the solver's own words.
    """

    kind: Status
    batch_index: tuple[int, ...]
    step: int
    time: float
    residual: float
    detail: str = ""

    def describe(self) -> str:
        where = f" (batch index {self.batch_index})" if self.batch_index else ""
        what = _WHAT.get(Status(self.kind), str(self.kind))
        res = f", residual {self.residual:.3g}" if np.isfinite(self.residual) else ""
        detail = f": {self.detail}" if self.detail else ""
        return f"{what} at step {self.step}, t = {self.time:.10g}{where}{res}{detail}"


_LAYOUT_VIEWS = {
    "qp": ("q", "p"),
    "m": ("m",),
    "mR": ("m", "R"),
    "qv": ("q", "qdot"),
    "rotor": ("m", "R", "Gamma", "gamma"),
    "group": ("g", "element"),
}


@dataclass(frozen=True, eq=False)
class Solution:
    """A trajectory, or a batch of trajectories, computed by :func:`~geomech.solve`.

    Attributes
    ----------
    t : ndarray, shape (n_save,)
        Times of the saved states (``saveat``).
    states : ndarray, shape ``(*batch, n_save, d)``
        The saved states in the system's layout (``layout``): ``"qp"``, canonical ``(q, p)``; ``"m"`` or
        ``"mR"``, body momentum and attitude (R row-major) of a left-invariant system; ``"qv"``,
        coordinates and velocities ``(q, qdot)`` of a Lagrangian system; ``"rotor"``, ``(m, R, Gamma,
        gamma)`` of a body with rotors; ``"group"``, the chart coordinates (angles unwrapped) and the element
        (row-major) of a path on a group. After a failure, a trajectory's
        later states are NaN (see ``failures``).
    system, method
        What was integrated and how.
    layout : str
    labels : tuple of str
        A name for each component of the state.
    quantities : mapping of str to ndarray
        What the run knows along the trajectory, each of shape ``(*batch, n_save[, k])``: ``energy``,
        ``casimir`` (:math:`|m|`), ``spatial_momentum`` (:math:`p = R m`), and for a Lagrangian system
        with constraints ``momentum`` (the nonholonomic momentum), ``tau``, ``work``,
        ``constraint_residual`` (see :data:`QUANTITIES`). Each is also an attribute.
    status : Status
        ``Status.SUCCESS`` or the kind of the first failure (compares equal to its string value).
    message : str
        A sentence for people.
    failures : tuple of Failure
        One entry per failed trajectory.
    stats : dict
        Counters: ``n_steps`` (steps, or output times, per trajectory), ``n_internal_steps``, ``n_rhs``
        (right-hand-side evaluations, summed over the batch), ``n_newton`` (summed), ``backend``,
        ``compile_time`` and ``run_time`` in seconds; a compiled run adds ``loop_time``, the wall time of the calls
        into the compiled loop alone (the rest of ``run_time`` is the Python around it: the set-up, the bound on
        the work, the quantities at the saved times).
    parameters : mapping
        The parameter values the system was evaluated with: numbers, and arrays of the batch's shape for the
        parameters a batch sweeps (``solve(..., parameters={name: array})``).
    group_dim : int or None
        For the ``"qv"`` and ``"group"`` layouts: how many of the coordinates are the group's (the rest are
        shapes, or the element).
    events : mapping of str to ndarray
        What happened between the saved states, located in time, each a table of rows in time order:
        ``chart_switch`` (the Serret-Andoyer atlas): ``(trajectory, t, from axis, to axis)``, the trajectory's
        flat index in the batch (0 for one trajectory) and the axes 1-based, at the exact time of the switch; the
        events given to :func:`~geomech.solve`, by their names: ``(trajectory, t, state...)``, the state in the
        order of ``labels``.
    """

    t: np.ndarray
    states: np.ndarray
    system: Any
    method: Any
    layout: str
    labels: tuple[str, ...] = ()
    quantities: Mapping[str, np.ndarray] = field(default_factory=dict)
    status: Status = Status.SUCCESS
    message: str = ""
    failures: tuple[Failure, ...] = ()
    stats: dict[str, Any] = field(default_factory=dict)
    parameters: Mapping[str, Any] = field(default_factory=dict)
    group_dim: int | None = None
    events: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "status", Status(self.status))
        quantities = {k: v for k, v in self.quantities.items() if v is not None}
        unknown = set(quantities) - set(QUANTITIES)
        if unknown:
            raise ValueError(f"Unknown quantities {sorted(unknown)}; known: {sorted(QUANTITIES)}.")
        for value in [self.t, self.states, *quantities.values()]:
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        object.__setattr__(self, "quantities", MappingProxyType(quantities))
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))

    # -- views --------------------------------------------------------------------------------------
    @property
    def success(self) -> bool:
        """Whether every trajectory reached the final time."""
        return self.status is Status.SUCCESS

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return self.states.shape[:-2]

    @property
    def y(self) -> np.ndarray:
        """Alias of :attr:`states`."""
        return self.states

    def _need(self, layouts: tuple[str, ...], what: str) -> None:
        if self.layout not in layouts:
            raise AttributeError(f"`{what}` is not defined for a solution with state layout {self.layout!r}.")

    def _half(self, second: bool) -> np.ndarray:
        n = self.states.shape[-1] // 2
        return self.states[..., n:] if second else self.states[..., :n]

    @property
    def q(self) -> np.ndarray:
        """Coordinates (canonical, or of a Lagrangian system), shape ``(*batch, n_save, n)``."""
        self._need(("qp", "qv"), "q")
        return self._half(False)

    @property
    def qdot(self) -> np.ndarray:
        """Velocities of a Lagrangian system, shape ``(*batch, n_save, n)``."""
        self._need(("qv",), "qdot")
        return self._half(True)

    @property
    def p(self) -> np.ndarray:
        """Momenta: the canonical momenta (layout ``"qp"``), or the nonholonomic momentum of a Lagrangian
        system (its ``momentum`` quantity), shape ``(*batch, n_save, k)``."""
        if self.layout == "qv":
            return self._quantity("momentum")
        self._need(("qp",), "p")
        return self._half(True)

    @property
    def g(self) -> np.ndarray:
        """Group coordinates of a Lagrangian system on G x S or of a path on a group, shape
        ``(*batch, n_save, dim G)`` (on a path, the angles of the group's angle components unwrapped)."""
        self._need(("qv", "group"), "g")
        return self.states[..., : self.group_dim]

    @property
    def element(self) -> np.ndarray:
        """Group elements (matrices) of a path on a group or of a Lagrangian system on G x S, shape
        ``(*batch, n_save, N, N)``."""
        self._need(("qv", "group"), "element")
        if self.layout == "group":
            n = int(round(np.sqrt(self.states.shape[-1] - int(self.group_dim or 0))))
            return self.states[..., self.group_dim :].reshape(self.states.shape[:-1] + (n, n))
        return np.asarray(self.system.group.from_coordinates(self.g), dtype=float)

    def displacement(self) -> np.ndarray:
        """:math:`g(t_0)^{-1}g(t_{end})`, the net motion in the body frame at the start, as a group element
        (layouts ``"group"`` and ``"qv"``), shape ``(*batch, N, N)``."""
        e = self.element
        G = self.system.group.numeric
        return np.asarray(G.compose(G.inverse(e[..., 0, :, :]), e[..., -1, :, :]), dtype=float)

    def net_motion(self) -> dict[str, float]:
        """The net motion of one trajectory by name: the change of each group coordinate (angles unwrapped), or
        where the chart is singular at the identity (SO(3) in 3-1-3 Euler angles, whose differences are no
        motion) the exponential coordinates of :meth:`displacement` (``log_<algebra name>``: the rotation
        vector)."""
        if self.batch_shape:
            raise ValueError(f"net_motion() reads one trajectory; this solution has batch shape {self.batch_shape}.")
        chart = self.system.group
        if chart.regular_at_identity:
            names = [c.name for c in chart.coordinates]
            values = self.g[-1] - self.g[0]
        else:
            names = [f"log_{n}" for n in chart.algebra_names]
            values = chart.numeric.log(self.displacement())
        return {n: float(v) for n, v in zip(names, values)}

    @property
    def r(self) -> np.ndarray:
        """Shape coordinates of a Lagrangian system on G x S, shape ``(*batch, n_save, dim S)``."""
        self._need(("qv",), "r")
        return self.q[..., self.group_dim :]

    @property
    def m(self) -> np.ndarray:
        """Body angular momentum, shape ``(*batch, n_save, 3)``."""
        self._need(("m", "mR", "rotor"), "m")
        return self.states[..., :3]

    @property
    def R(self) -> np.ndarray:
        """Attitude (body to space), shape ``(*batch, n_save, 3, 3)``; only when it was integrated."""
        self._need(("mR", "rotor"), "R")
        return self.states[..., 3:12].reshape(self.states.shape[:-1] + (3, 3))

    @property
    def Gamma(self) -> np.ndarray:
        """The rotors' axial momenta of a body with rotors, shape ``(*batch, n_save, N)``."""
        self._need(("rotor",), "Gamma")
        n = (self.states.shape[-1] - 12) // 2
        return self.states[..., 12 : 12 + n]

    @property
    def gamma(self) -> np.ndarray:
        """The rotor angles of a body with rotors, shape ``(*batch, n_save, N)``."""
        self._need(("rotor",), "gamma")
        n = (self.states.shape[-1] - 12) // 2
        return self.states[..., 12 + n :]

    def _quantity(self, name: str) -> np.ndarray:
        try:
            return self.quantities[name]
        except KeyError:
            hints = {
                "spatial_momentum": " Pass R0 to solve() to integrate the attitude.",
                "work": " BKMM integrates it unless given work=False.",
            }
            hint = hints.get(name, "")
            raise AttributeError(
                f"This solution ({self.layout!r} layout) has no `{name}`; it has {sorted(self.quantities)}.{hint}"
            ) from None

    @property
    def energy(self) -> np.ndarray:
        """The energy (Hamiltonian, or kinetic plus potential) along the trajectory, shape ``(*batch, n_save)``."""
        return self._quantity("energy")

    @property
    def casimir(self) -> np.ndarray:
        """:math:`|m|` along the trajectory (left-invariant systems)."""
        return self._quantity("casimir")

    @property
    def spatial_momentum(self) -> np.ndarray:
        """:math:`p = R m`, shape ``(*batch, n_save, 3)``, when the attitude was integrated."""
        return self._quantity("spatial_momentum")

    @property
    def momentum(self) -> np.ndarray:
        """The nonholonomic momentum of a Lagrangian system (the same as :attr:`p` for the ``"qv"`` layout)."""
        return self._quantity("momentum")

    @property
    def tau(self) -> np.ndarray:
        """The generalized force on each shape variable, given or required by the prescribed shapes."""
        return self._quantity("tau")

    @property
    def work(self) -> np.ndarray:
        """The work done by the shape forces since the start."""
        return self._quantity("work")

    @property
    def serret_andoyer(self) -> np.ndarray:
        """:math:`(l, L, \\varphi)` in the Serret-Andoyer chart in use, shape ``(*batch, n_save, 3)``
        (:class:`~geomech.integrators.SerretAndoyerAtlas`)."""
        return self._quantity("serret_andoyer")

    @property
    def chart_axis(self) -> np.ndarray:
        """The body axis (1 to 3) of the Serret-Andoyer chart in use, NaN where not reached."""
        return self._quantity("chart_axis")

    @property
    def constraint_residual(self) -> np.ndarray:
        """:math:`A(q)\\dot q` along the trajectory, shape ``(*batch, n_save, constraints)``."""
        return self._quantity("constraint_residual")

    # -- invariants --------------------------------------------------------------------------------
    def _drift(self, name: str) -> np.ndarray:
        x = self._quantity(name)
        d = x - x[..., :1] if x.ndim == len(self.batch_shape) + 1 else x - x[..., :1, :]
        if x.ndim > len(self.batch_shape) + 1:
            d = np.linalg.norm(d, axis=-1)
        return np.nanmax(np.abs(d), axis=-1)

    @property
    def energy_error(self) -> np.ndarray:
        """:math:`\\max_k |E(y_k) - E(y_0)|` per trajectory, shape ``batch``."""
        return self._drift("energy")

    @property
    def casimir_error(self) -> np.ndarray:
        """:math:`\\max_k \\bigl||m_k| - |m_0|\\bigr|` per trajectory, shape ``batch``."""
        return self._drift("casimir")

    @property
    def momentum_error(self) -> np.ndarray:
        """:math:`\\max_k |p_k - p_0|` (spatial momentum), shape ``batch``."""
        return self._drift("spatial_momentum")

    # -- export ------------------------------------------------------------------------------------
    def _fields(self) -> list[tuple[str, np.ndarray, tuple[str, ...], str]]:
        """(name, array, component dimensions, description) for every view and quantity."""
        n_b = len(self.batch_shape)
        out = []
        for view in _LAYOUT_VIEWS[self.layout]:
            arr = getattr(self, view)
            if view == "R":
                dims: tuple[str, ...] = ("row", "column")
                what = "attitude, body to space"
            elif view == "element":
                dims, what = ("row", "column"), "group element"
            elif view == "g":
                dims, what = ("coordinate",), "group coordinates (angles unwrapped)"
            elif view == "m":
                dims, what = ("axis",), "body angular momentum"
            elif view in ("Gamma", "gamma"):
                dims = ("rotor",)
                what = "rotor axial momenta" if view == "Gamma" else "rotor angles"
            else:
                dims = ("coordinate",)
                what = {"q": "coordinates", "p": "canonical momenta", "qdot": "velocities"}[view]
            out.append((view, arr, dims, what))
        for name, arr in self.quantities.items():
            what, dim = QUANTITIES[name]
            extra = arr.ndim - n_b - 1
            if name == "tau" and self.layout == "rotor":
                dim = "rotor"
            comp = (dim,) if extra == 1 and dim else tuple(f"{name}_{i}" for i in range(extra))
            out.append((name, arr, comp, what))
        return out

    def to_dataset(self, units: Mapping[str, str] | None = None) -> Any:
        """The solution as a self-describing :class:`xarray.Dataset` (write it with ``.to_netcdf``).

        One variable per view of the state (``q``, ``p``, ``qdot``, ``m``, ``R``) and per quantity, over
        the dimensions ``batch_0, ...`` (if any), ``t`` and the components. Attributes: the system, the
        method, the status, the message, the parameters (JSON), the run statistics and the geomech
        version. ``units`` maps a variable name (or ``"t"``) to its unit, written as its ``units``
        attribute; geomech itself is unit-free (every quantity is in the units of the parameters).
        """
        import xarray as xr

        from .._version import __version__

        units = dict(units or {})
        batch_dims = tuple(f"batch_{i}" for i in range(len(self.batch_shape)))
        data = {}
        for name, arr, comp, what in self._fields():
            attrs = {"long_name": what}
            if name in units:
                attrs["units"] = units[name]
            data[name] = (batch_dims + ("t",) + comp, np.asarray(arr), attrs)
        coords: dict[str, Any] = {"t": ("t", np.asarray(self.t), {"long_name": "time", **_unit(units, "t")})}
        if self.layout in ("qp", "qv") and self.labels:
            coords["coordinate"] = list(self.labels[: len(self.labels) // 2])
        if self.layout == "group" and self.labels:
            coords["coordinate"] = list(self.labels[: self.group_dim])
        if self.layout in ("m", "mR", "rotor"):
            coords["axis"] = [1, 2, 3]
        if self.layout == "qv" and self.group_dim is not None and "tau" in self.quantities:
            coords["shape"] = list(self.labels[self.group_dim : len(self.labels) // 2])
        for _name, arr, comp, _ in self._fields():
            for dim, size in zip(comp, np.shape(arr)[len(batch_dims) + 1 :]):
                if dim not in coords:
                    coords[dim] = np.arange(size) + 1
        stats = {k: v for k, v in self.stats.items() if isinstance(v, (int, float, str))}
        fixed = {str(k): float(v) for k, v in self.parameters.items() if np.ndim(v) == 0}
        for k, v in self.parameters.items():  # a batch of parameter values: a coordinate over the batch
            if np.ndim(v) > 0:
                coords[str(k)] = (batch_dims, np.asarray(v, dtype=float), {"long_name": f"parameter {k}"})
        return xr.Dataset(
            data,
            coords=coords,
            attrs={
                "system": getattr(self.system, "name", type(self.system).__name__),
                "method": repr(self.method),
                "layout": self.layout,
                "status": self.status.value,
                "message": self.message,
                "parameters": json.dumps(fixed),
                "stats": json.dumps(stats),
                "units": "those of the parameters (geomech is unit-free)",
                "geomech_version": __version__,
            },
        )

    def to_csv(self, path: Any) -> Any:
        """Write one trajectory (no batch) as CSV, one row per saved time; returns the path."""
        import csv
        from pathlib import Path

        if self.batch_shape:
            raise ValueError(f"to_csv writes one trajectory; this solution has batch shape {self.batch_shape}.")
        cols, blocks = ["t"], [self.t[:, None]]
        for name, arr, _, _ in self._fields():
            flat = np.asarray(arr).reshape(len(self.t), -1)
            n = len(self.labels) // 2
            if name in ("q", "p", "qdot") and self.labels:
                head = list(self.labels[:n] if name == "q" else self.labels[n:])
            elif self.layout == "group" and self.labels:
                k = int(self.group_dim or 0)
                head = list(self.labels[:k] if name == "g" else self.labels[k:])
            elif flat.shape[1] == 1:
                head = [name]
            else:
                head = [f"{name}{i + 1}" for i in range(flat.shape[1])]
            cols += head
            blocks.append(flat)
        path = Path(path)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            w.writerows(np.hstack(blocks).tolist())
        return path

    def final(self) -> dict[str, float]:
        """The last saved state by component name (one trajectory)."""
        if self.batch_shape:
            raise ValueError(f"final() reads one trajectory; this solution has batch shape {self.batch_shape}.")
        return {name: float(v) for name, v in zip(self.labels, self.states[-1])}

    def _repr_html_(self) -> str:
        """Jupyter: a compact table of the run (method, status, times, steps) and the drift of every conserved or
        constrained quantity it records."""
        from .._display import html_table

        name = getattr(self.system, "name", type(self.system).__name__)
        data: dict[str, Any] = {
            "system": name,
            "method": self.method,
            "status": self.status.value,
            "saved states": len(self.t),
            "t": [float(self.t[0]), float(self.t[-1])],
            "components": list(self.labels),
        }
        if self.batch_shape:
            data["batch shape"] = list(self.batch_shape)
        if self.message:
            data["message"] = self.message
        drifts = {}
        for label, attr in (
            ("energy", "energy_error"),
            ("Casimir |m|^2", "casimir_error"),
            ("momentum", "momentum_error"),
            ("constraints", "constraint_residual"),
        ):
            try:
                values = np.asarray(getattr(self, attr), dtype=float)
            except (AttributeError, KeyError, ValueError, TypeError):
                continue
            if values.size and np.isfinite(values).any():
                drifts[label] = float(np.nanmax(np.abs(values)))
        if drifts:
            data["largest drift"] = drifts
        data["stats"] = {k: v for k, v in dict(self.stats).items() if isinstance(v, (int, float, str, bool))}
        return html_table("Solution", data)

    def __repr__(self) -> str:
        name = getattr(self.system, "name", type(self.system).__name__)
        return (
            f"Solution({self.method!r} on {name}: {len(self.t)} saved states of batch {self.batch_shape}, "
            f"t in [{self.t[0]:g}, {self.t[-1]:g}], status {self.status.value!r})"
        )


def _unit(units: Mapping[str, str], name: str) -> dict[str, str]:
    return {"units": units[name]} if name in units else {}
