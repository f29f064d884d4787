"""The result of :func:`geomech.integrators.solve`: an immutable trajectory that knows its system.

Numerical failure is data here (``status``, ``failures``), as in diffrax: :func:`solve` raises it as an
exception only when asked to (the default), and the exception carries the partial :class:`Solution`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Failure", "Solution", "STATUS"]

#: Status codes of the compiled loops and their names.
STATUS = {
    0: "success",
    1: "newton_failed",
    2: "nonfinite",
    3: "singular_jacobian",
    4: "adaptive_failed",
    5: "not_periodic",
    6: "left_chart",
}


@dataclass(frozen=True)
class Failure:
    """Where and why one trajectory of a run failed.

    ``batch_index`` is the position in the (flattened) batch, ``step`` the step that failed (the state
    saved before it is the last valid one), ``time`` the time at the start of that step, ``residual`` the
    max-norm of the implicit equations at the last Newton iterate (NaN when not applicable).
    """

    kind: str
    batch_index: tuple[int, ...]
    step: int
    time: float
    residual: float

    def describe(self) -> str:
        where = f" (batch index {self.batch_index})" if self.batch_index else ""
        what = {
            "newton_failed": "Newton's method did not converge",
            "singular_jacobian": "the Newton matrix is singular",
            "nonfinite": "the state became non-finite",
            "adaptive_failed": "the adaptive solver gave up",
            "not_periodic": "the orbit is not periodic (a separatrix, or it leaves L_bounds)",
            "left_chart": "the state reached the end of its chart (a pole of the coordinates, e.g. the "
            "Serret-Andoyer L = +-G or the Euler angle theta = 0, pi), where the formula means "
            "nothing; switch charts (GeneralizedSerretAndoyer.simulate does) or integrate on the "
            "group",
        }.get(self.kind, self.kind)
        res = f", residual {self.residual:.3g}" if np.isfinite(self.residual) else ""
        return f"{what} at step {self.step}, t = {self.time:.10g}{where}{res}"


@dataclass(frozen=True, eq=False)
class Solution:
    """A trajectory, or a batch of trajectories, computed by :func:`~geomech.integrators.solve`.

    Attributes
    ----------
    t : ndarray, shape (n_save,)
        Times of the saved states: ``t0``, every ``save_every`` steps, and the final time.
    states : ndarray, shape (*batch, n_save, d)
        The saved states in the method's layout: ``(q, p)`` for a canonical system, ``m`` or
        ``(m, R)`` (R row-major) for a left-invariant one. After a failure, a trajectory's later states are
        NaN (see ``failures``).
    system, method
        What was integrated and how.
    energy : ndarray, shape (*batch, n_save), or None
        The Hamiltonian along the trajectory.
    casimir : ndarray, shape (*batch, n_save), or None
        :math:`|m|` (left-invariant systems).
    spatial_momentum : ndarray, shape (*batch, n_save, 3), or None
        :math:`p = R m`, when the attitude was integrated.
    status : str
        ``"success"`` or the kind of the first failure (``"newton_failed"``, ``"singular_jacobian"``,
        ``"nonfinite"``, ``"adaptive_failed"``).
    message : str
        A sentence for people.
    failures : tuple of Failure
        One entry per failed trajectory.
    stats : dict
        Counters: ``n_steps`` (per trajectory), ``n_rhs`` (right-hand-side or gradient evaluations, summed
        over the batch), ``n_newton`` (Newton iterations, summed), ``backend`` (``"numba"`` or
        ``"python"``), ``compile_time`` and ``run_time`` in seconds.
    """

    t: np.ndarray
    states: np.ndarray
    system: Any
    method: Any
    layout: str
    energy: np.ndarray | None = None
    casimir: np.ndarray | None = None
    spatial_momentum: np.ndarray | None = None
    status: str = "success"
    message: str = ""
    failures: tuple[Failure, ...] = ()
    stats: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("t", "states", "energy", "casimir", "spatial_momentum"):
            value = getattr(self, name)
            if isinstance(value, np.ndarray):
                value.setflags(write=False)

    # -- views --------------------------------------------------------------------------------------
    @property
    def success(self) -> bool:
        """Whether every trajectory reached the final time."""
        return self.status == "success"

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

    @property
    def q(self) -> np.ndarray:
        """Canonical coordinates, shape ``(*batch, n_save, n)``."""
        self._need(("qp",), "q")
        return self.states[..., : self.states.shape[-1] // 2]

    @property
    def p(self) -> np.ndarray:
        """Canonical momenta, shape ``(*batch, n_save, n)``."""
        self._need(("qp",), "p")
        return self.states[..., self.states.shape[-1] // 2 :]

    @property
    def m(self) -> np.ndarray:
        """Body angular momentum, shape ``(*batch, n_save, 3)``."""
        self._need(("m", "mR"), "m")
        return self.states[..., :3]

    @property
    def R(self) -> np.ndarray:
        """Attitude (body to space), shape ``(*batch, n_save, 3, 3)``; only when it was integrated."""
        self._need(("mR",), "R")
        return self.states[..., 3:].reshape(self.states.shape[:-1] + (3, 3))

    # -- invariants --------------------------------------------------------------------------------
    @property
    def energy_error(self) -> np.ndarray:
        """:math:`\\max_k |H(y_k) - H(y_0)|` per trajectory, shape ``batch``."""
        if self.energy is None:
            raise AttributeError(f"{self.system!r} has no energy to compare.")
        return np.nanmax(np.abs(self.energy - self.energy[..., :1]), axis=-1)

    @property
    def casimir_error(self) -> np.ndarray:
        """:math:`\\max_k \\bigl||m_k| - |m_0|\\bigr|` per trajectory, shape ``batch``."""
        if self.casimir is None:
            raise AttributeError("This solution has no Casimir (not a left-invariant system).")
        return np.nanmax(np.abs(self.casimir - self.casimir[..., :1]), axis=-1)

    @property
    def momentum_error(self) -> np.ndarray:
        """:math:`\\max_k |p_k - p_0|` (spatial momentum), shape ``batch``."""
        if self.spatial_momentum is None:
            raise AttributeError("The attitude was not integrated: pass R0 to solve() to get p = R m.")
        diff = self.spatial_momentum - self.spatial_momentum[..., :1, :]
        return np.nanmax(np.linalg.norm(diff, axis=-1), axis=-1)

    def __repr__(self) -> str:
        name = getattr(self.system, "name", type(self.system).__name__)
        return (
            f"Solution({self.method!r} on {name}: {len(self.t)} saved states of batch {self.batch_shape}, "
            f"t in [{self.t[0]:g}, {self.t[-1]:g}], status {self.status!r})"
        )
