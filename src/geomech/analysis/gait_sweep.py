"""The net displacement of a periodic gait over a sweep of its coefficients and of the system's parameters: a study
(:func:`~geomech.analysis.sweep`) whose every block is one batch of the compiled BKMM equations.

:func:`~geomech.analysis.analyse_gait` takes one gait apart (connection and momentum terms, per period, figures);
this answers the question of a gait search (which amplitudes, frequencies and phases move the system most) over
thousands of gaits: for each member, the displacement :math:`g(0)^{-1}g(nT)` in the group's chart coordinates
(angles accumulated, not wrapped) and the change of the nonholonomic momentum, from one compiled ensemble call
per block.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError
from ..integrators import BKMM, solve
from ..symbolic.formula import to_expression
from ..systems.gait import T_SYMBOL
from ..systems.nonholonomic import NonholonomicSystem

__all__ = ["GaitSweep"]


class GaitSweep:
    """A periodic gait with named coefficients, as a study over them and the system's parameters.

    Parameters
    ----------
    system : NonholonomicSystem
        Its group's chart must be regular at the identity (SE(2), S^1, R^n and their products; not the Euler
        angles of SO(3)): the displacement is read from the group coordinates, which start there.
    loop : mapping
        Each shape variable as a formula in ``t``, ``T`` (the period) and named coefficients, e.g.
        ``{"psi": "a*sin(2*pi*t/T)", "phi": "b*sin(2*pi*t/T + c)"}``.
    period : float
        The period T (not swept: every member of a batch runs to the same time).
    periods : int
        Periods integrated.
    p0 : array, optional
        The initial nonholonomic momentum (default 0).
    parameters : mapping, optional
        Values of the system's parameters and the coefficients that are not swept.
    rtol, atol : float
        The BKMM run's tolerances (compiled DOP853).

    Calling it with arrays of the swept names (and ``threads``) returns ``net_displacement`` ``(B, k)``,
    ``momentum_change`` ``(B, m)`` and ``failed`` (1 where the member's run failed: a singular shape, a spent
    budget); :meth:`run` runs the sweep and names the coordinates.
    """

    def __init__(
        self,
        system: NonholonomicSystem,
        loop: Mapping[str, Any],
        *,
        period: float,
        periods: int = 1,
        p0: Any = None,
        parameters: Mapping[str, float] | None = None,
        rtol: float = 1e-10,
        atol: float = 1e-12,
    ):
        if not isinstance(system, NonholonomicSystem):
            raise InputError(f"Expected a NonholonomicSystem, got {type(system).__name__}.")
        if not isinstance(loop, Mapping) or not loop:
            raise InputError("Expected the gait as a mapping {shape name: formula in t, T and coefficients}.")
        self.system = system
        self.loop = {str(k): str(v) for k, v in loop.items()}
        self.period = float(V.positive_scalar(period, "period"))
        if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 1:
            raise InputError(f"Expected `periods` to be a positive integer, got {periods!r}.")
        self.periods = int(periods)
        self.p0 = None if p0 is None else V.finite(p0, "p0").ravel().tolist()
        self.parameters = {str(k): float(v) for k, v in dict(parameters or {}).items()}
        self.rtol, self.atol = float(rtol), float(atol)
        symbols = {
            s.name
            for name, e in self.loop.items()
            for s in to_expression(e, f"loop[{name!r}]", {"t": T_SYMBOL}).free_symbols
        }
        self._uses_T = "T" in symbols
        self.coefficients = tuple(sorted(symbols - {"t", "T"} - {q.name for q in system.parameter_symbols}))
        if not system.group.regular_at_identity:
            raise InputError(
                f"The chart of {system.group.name} is singular at the identity, where the displacement starts: run "
                "analyse_gait member by member (it reads the displacement in exponential coordinates)."
            )

    def to_json(self) -> dict[str, Any]:
        """What identifies the study in its store."""
        return {
            "function": "geomech.analysis.GaitSweep",
            "system": self.system.name,
            "system_key": str(self.system.key),
            "loop": self.loop,
            "period": self.period,
            "periods": self.periods,
            "p0": self.p0,
            "parameters": self.parameters,
            "rtol": self.rtol,
            "atol": self.atol,
        }

    def __call__(self, threads: int = 1, **values: Any) -> dict[str, np.ndarray]:
        if "T" in values:
            raise InputError("The period T is not swept (every member runs to the same time): sweep a frequency.")
        params: dict[str, Any] = {**self.parameters, **values}
        if self._uses_T:
            params["T"] = self.period
        t_end = self.period * self.periods
        sol = solve(
            self.system,
            BKMM(),
            t_final=t_end,
            saveat=[0.0, t_end],
            shapes=self.loop,
            parameters=params,
            p0=self.p0,
            rtol=self.rtol,
            atol=self.atol,
            threads=threads,
            raise_on_failure=False,
        )
        B = len(next(iter(values.values()))) if values else 1
        g = np.broadcast_to(sol.g, (B,) + sol.g.shape[-2:])
        p = np.broadcast_to(sol.p, (B,) + sol.p.shape[-2:])
        failed = np.zeros(B, dtype=np.int8)
        for f in sol.failures:
            failed[f.batch_index[0] if f.batch_index else 0] = 1
        return {
            # g(0) is the identity (chart coordinates 0): g(0)^-1 g(nT) is g(nT), its angles accumulated
            "net_displacement": g[:, -1] - g[:, 0],
            "momentum_change": p[:, -1] - p[:, 0],
            "failed": failed,
        }

    def run(
        self,
        *,
        out: Any = None,
        resume: bool = False,
        scheduler: Any = None,
        chunk: int = 1024,
        progress: Any = None,
        max_members: int = 10**8,
        **axes: Any,
    ) -> Any:
        """The sweep over ``axes`` (names of the system's parameters or the gait's coefficients, each an array):
        an :class:`xarray.Dataset` (:func:`~geomech.analysis.sweep`), the displacement by coordinate name."""
        from .sweep import sweep

        known = {q.name for q in self.system.parameter_symbols} | set(self.coefficients)
        unknown = sorted(set(axes) - known)
        if unknown:
            raise InputError(
                f"The sweep names {unknown}, which are neither parameters of {self.system.name} nor coefficients of "
                f"the gait ({sorted(known)})."
            )
        missing = sorted(set(self.coefficients) - set(axes) - set(self.parameters))
        if missing:
            raise InputError(f"The gait's coefficients {missing} have no value: sweep them or give them.")
        ds = sweep(
            self,
            out=out,
            resume=resume,
            scheduler=scheduler,
            chunk=chunk,
            progress=progress,
            max_members=max_members,
            identity=self.to_json(),
            **axes,
        )
        names = [c.name for c in self.system.group.coordinates]
        return ds.rename({"net_displacement_dim0": "coordinate", "momentum_change_dim0": "momentum"}).assign_coords(
            coordinate=names
        )
