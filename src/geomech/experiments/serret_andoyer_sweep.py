"""The Serret-Andoyer integrator study over a grid of step sizes and inertias, as a study on dask
(:func:`~geomech.analysis.sweep`): at each member the approaches of :mod:`.serret_andoyer_study` run to
``t_final``, and their largest energy and momentum errors are its outputs (one column per approach).

Each member is its own set of runs (a step size is not a parameter of a batch): a block is its members one after
the other, and the blocks run on every core or on a cluster, resumable from their store.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np

from ..errors import InputError
from .serret_andoyer_study import StudyConfig, approaches, build_model, run_approach

__all__ = ["SWEPT", "IntegratorSweep"]

#: What the sweep may vary: the step and the inertias (each a field of StudyConfig).
SWEPT = ("h", "lambda1", "lambda2", "I3", "J3")


class IntegratorSweep:
    """The approaches of the Serret-Andoyer study at every member of a grid of ``SWEPT`` values, the other fields
    of the study from ``config``. Calling it with arrays of the swept names returns ``max_energy_error``,
    ``max_momentum_error`` and ``wall_time`` ``(members, approaches)``, NaN where an approach did not succeed."""

    def __init__(self, config: StudyConfig):
        config.validate()
        self.config = config
        self.keys = tuple(a.key for a in approaches(config))

    def to_json(self) -> dict[str, Any]:
        return {"function": "geomech.experiments.IntegratorSweep", "config": asdict(self.config)}

    def __call__(self, **values: np.ndarray) -> dict[str, np.ndarray]:
        n = len(next(iter(values.values())))
        out = {name: np.full((n, len(self.keys)), np.nan) for name in ("max_energy_error", "max_momentum_error")}
        for i in range(n):
            cfg = StudyConfig(**{**asdict(self.config), **{k: float(v[i]) for k, v in values.items()}})
            cfg.validate()
            model = build_model(cfg)
            for j, approach in enumerate(approaches(cfg)):
                run = run_approach(model, approach, cfg)
                if run["status"] == "success":
                    out["max_energy_error"][i, j] = run["max_energy_error"]
                    out["max_momentum_error"][i, j] = run["max_momentum_error"]
        return out

    def run(
        self,
        *,
        out: Any = None,
        resume: bool = False,
        scheduler: Any = None,
        chunk: int = 1,
        progress: Any = None,
        **axes: Any,
    ) -> Any:
        """The sweep over ``axes`` (names of ``SWEPT``): an :class:`xarray.Dataset` with an ``approach``
        dimension."""
        from ..analysis.sweep import sweep

        unknown = sorted(set(axes) - set(SWEPT))
        if unknown:
            raise InputError(f"The integrator study sweeps {list(SWEPT)}; got {unknown}.")
        ds = sweep(
            self,
            out=out,
            resume=resume,
            scheduler=scheduler,
            chunk=chunk,
            progress=progress,
            identity=self.to_json(),
            units={"h": "s", "max_energy_error": "J"},
            **axes,
        )
        rename = {f"{name}_dim0": "approach" for name in ("max_energy_error", "max_momentum_error")}
        return ds.rename(rename).assign_coords(approach=list(self.keys))
