"""The numerical study of section 8.1 of the Serret-Andoyer paper, reproduced and extended.

The seed compares five ways of simulating the closed loop of a rigid body with one rotor under the
control :math:`\\varphi(v) = 2\\tan(v/G)`, :math:`p = 0`, :math:`G = 1`, on the level :math:`H_c = 0.47`
(figures 5-7 there):

1. the full 6-D dynamics in 3-1-3 Euler-angle coordinates, with Adams' method;
2. Euler's equations :math:`\\dot m = m \\times \\nabla H_c`, with Adams' method;
3. the reduced Serret-Andoyer dynamics :math:`(l, L)`, with Adams' method;
4. the reduced dynamics with the second-order generating-function method;
5. the reduced dynamics with the implicit midpoint rule;

Adams as the seed's (variable order, adaptive, tolerance 1e-6, output every ``h``), ``h = 1`` ms, and the
symplectic methods' Newton tolerance 1e-8. geomech adds the Lie-Poisson splitting of Euler's equations
(:math:`H_c = f_1(m_1) + f_2(m_2) + f_3(m_3)`) and Gauss-Legendre collocation of the reduced system.

The seed gives neither the inertias nor the duration; the defaults here are admissible
(:math:`\\lambda_1 > \\lambda_2 > I_3 + J_3` and :math:`1/(2\\lambda_1) < 0.47 < 1/(2\\lambda_2)`, so that
:math:`H_c = 0.47` is an orbit about the intermediate axis) and are written into the output.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _validate as V
from .._storage import check_output_dir, dumps_json, write_set
from .._version import __version__
from ..errors import InputError
from .serret_andoyer_figures import figure5, figure6, figure7

__all__ = ["StudyConfig", "Approach", "run_study", "write_study", "prepare_output", "approaches"]


MAX_SAVED = 5e6
"""States kept per approach (with 9 approaches about 1 GB of momenta; the figures stay drawable)."""


#: Named inertias of the study (the seed gives none): ``default``, and ``cross-checked``, whose orbit at the
#: seed's H_c = 0.47 has a period computed independently of geomech (7.0155791512 s), checked by the tests
#: with the errors of every approach.
PRESETS: dict[str, dict[str, Any]] = {
    "default": {
        "inertias": {"lambda1": 1.2, "lambda2": 1.0, "I3": 0.6, "J3": 0.2},
        "about": "geomech's choice of admissible inertias",
    },
    "cross-checked": {
        "inertias": {"lambda1": 1.5, "lambda2": 1.0, "I3": 0.6, "J3": 0.3},
        "about": "an orbit of period 7.0155791512 s, by an independent computation",
    },
}


@dataclass(frozen=True)
class StudyConfig:
    """Parameters of the study (defaults: the seed's example with admissible inertias of our choice)."""

    lambda1: float = 1.2
    lambda2: float = 1.0
    I3: float = 0.6
    J3: float = 0.2
    phi: str = "2*tan(v/G)"
    G: float = 1.0
    p: float = 0.0
    Hc: float = 0.47
    h: float = 1e-3
    t_final: float = 100.0
    adams_tol: float = 1e-6
    newton_tol: float = 1e-8
    save_every: int = 10
    max_steps: float = 1e8
    """Ceiling on the steps of each approach, t_final / h: a longer run is refused before it starts."""
    extras: bool = True
    tilt: float = math.pi / 6
    """Angle between the spatial momentum and s3 in the frame of the 6-D Euler-angle dynamics (the
    seed does not say; 0 would make the 6-D dynamics the reduced one in disguise)."""

    @classmethod
    def preset(cls, name: str, **changes: Any) -> StudyConfig:
        """The study with the inertias of the preset ``name`` (:data:`PRESETS`), other fields from ``changes``."""
        if name not in PRESETS:
            raise InputError(f"Unknown preset {name!r}; the presets are {sorted(PRESETS)}.")
        return cls(**{**PRESETS[name]["inertias"], **changes})

    def validate(self) -> None:
        lam1, lam2, I3, J3 = self.lambda1, self.lambda2, self.I3, self.J3
        for name in ("lambda1", "lambda2", "I3", "J3", "G", "h", "t_final", "adams_tol", "newton_tol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"Expected `{name}` to be a positive number, got {v!r}.")
        if not (lam1 > lam2 > I3 + J3):
            raise InputError(
                f"Expected lambda1 > lambda2 > I3 + J3 (the second axis intermediate for the locked body), got "
                f"lambda1 = {lam1}, lambda2 = {lam2}, I3 + J3 = {I3 + J3}."
            )
        lo, hi = self.G**2 / (2 * lam1), self.G**2 / (2 * lam2)
        if not (lo < self.Hc < hi):
            raise InputError(
                f"Expected G^2/(2 lambda1) < Hc < G^2/(2 lambda2) = ({lo:.6g}, {hi:.6g}) so that H_c = Hc is an "
                f"orbit about the intermediate axis, got Hc = {self.Hc}."
            )
        n = self.t_final / self.h
        # every approach takes n steps (a few hundred ns each in the compiled loops, far more for Adams)
        V.work_budget(
            n,
            float(self.max_steps),
            f"The number of steps (t_final = {self.t_final:g} over h = {self.h:g})",
            "max_steps (--max-steps)",
            "shorten t_final (--t-final) or take a larger h (--h)",
            seconds_each=1e-6,
        )
        if abs(n - round(n)) > 1e-9 * n:
            raise InputError(f"Expected `t_final` to be a whole number of steps h = {self.h}, got {self.t_final}.")
        if not (isinstance(self.save_every, int) and self.save_every >= 1):
            raise InputError(f"Expected `save_every` to be a positive integer, got {self.save_every!r}.")
        saved = n / self.save_every
        if saved > MAX_SAVED:
            raise InputError(
                f"t_final = {self.t_final:g} with h = {self.h:g} would keep {saved:.3g} states of each approach "
                f"(at most {MAX_SAVED:.0e}); raise save_every (--save-every) to at least {math.ceil(n / MAX_SAVED)}."
            )


@dataclass(frozen=True)
class Approach:
    """One way of simulating the closed loop: a representation and a method."""

    key: str
    label: str
    representation: str  # "euler-angles-6d", "euler-equations", "reduced"
    method: Any
    in_seed: bool


@dataclass
class _Model:
    control: Any
    system: Any
    reduction: Any
    m0: np.ndarray
    R0: np.ndarray
    lL0: np.ndarray
    euler: Any = field(default=None)


def approaches(cfg: StudyConfig) -> list[Approach]:
    """The seed's five approaches, and geomech's extra curves when ``cfg.extras``."""
    from ..integrators.methods import (
        AdaptiveAdams,
        GaussLegendre,
        GeneratingFunction,
        ImplicitMidpoint,
        LiePoissonSplitting,
    )

    adams = AdaptiveAdams()  # tolerance cfg.adams_tol, given to solve() (run_approach)
    out = [
        Approach("full6d_adams", "full 6-D, Adams", "euler-angles-6d", adams, True),
        Approach("euler_adams", "Euler's equations, Adams", "euler-equations", adams, True),
        Approach("reduced_adams", "Serret-Andoyer, Adams", "reduced", adams, True),
        Approach("reduced_generating", "Serret-Andoyer, generating function", "reduced", GeneratingFunction(), True),
        Approach("reduced_midpoint", "Serret-Andoyer, midpoint", "reduced", ImplicitMidpoint(), True),
    ]
    if cfg.extras:
        out += [
            Approach("euler_midpoint", "Euler's equations, midpoint", "euler-equations", ImplicitMidpoint(), False),
            Approach(
                "euler_splitting2",
                "Euler's equations, Lie-Poisson splitting (Strang)",
                "euler-equations",
                LiePoissonSplitting(2),
                False,
            ),
            Approach(
                "euler_splitting4",
                "Euler's equations, Lie-Poisson splitting (order 4)",
                "euler-equations",
                LiePoissonSplitting(4, "yoshida"),
                False,
            ),
            Approach("reduced_gauss2", "Serret-Andoyer, Gauss-Legendre s=2", "reduced", GaussLegendre(2), False),
            Approach("reduced_gauss3", "Serret-Andoyer, Gauss-Legendre s=3", "reduced", GaussLegendre(3), False),
        ]
    return out


def build_model(cfg: StudyConfig) -> _Model:
    """The closed loop, its reduction, and an initial state on the level ``H_c = cfg.Hc`` with ``m3 = 0``."""
    from scipy.optimize import brentq

    from ..lie import so3
    from ..reduction import EulerCoordinates, GeneralizedSerretAndoyer, spatial_frame
    from ..systems.control import StructurePreservingControl
    from ..systems.rotors import RotorBody

    cfg.validate()
    body = RotorBody.one_rotor(cfg.lambda1, cfg.lambda2, cfg.I3, cfg.J3)
    control = StructurePreservingControl.one_rotor(body, cfg.phi, p=cfg.p, parameters={"G": cfg.G}, probe_radius=cfg.G)
    system = control.closed_loop()
    reduction = GeneralizedSerretAndoyer(system)
    G = cfg.G

    def level(l: float) -> float:
        return float(system.hamiltonian(np.array([G * math.sin(l), G * math.cos(l), 0.0]))) - cfg.Hc

    # on the equator m3 = 0, H_c runs from G^2/(2 lambda2) at l = 0 down to G^2/(2 lambda1) at l = pi/2
    l0 = brentq(level, 0.0, math.pi / 2, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    m0 = np.array([G * math.sin(l0), G * math.cos(l0), 0.0])
    R0 = so3.exp(np.array([cfg.tilt, 0.0, 0.0])) @ spatial_frame(m0).T
    model = _Model(control, system, reduction, m0, R0, np.array([l0, 0.0]))
    model.euler = EulerCoordinates(system)
    return model


def _momentum(model: _Model, approach: Approach, states: np.ndarray, G: float) -> np.ndarray:
    if approach.representation == "reduced":
        return model.reduction.charts[2].inverse(states[..., :2], G)
    if approach.representation == "euler-angles-6d":
        return model.euler.body_momentum(states)
    return states[..., :3]


FULL_RESOLUTION_STEPS = 2_000_000
"""Up to this many steps the errors are measured at every step (the seed's "output every h"); beyond, at the
saved states only, to bound memory."""


def _output_times(cfg: StudyConfig, every: int) -> np.ndarray:
    """Every ``every``-th time of the grid ``k h`` from 0 to ``t_final``, and ``t_final``."""
    n_steps = round(cfg.t_final / cfg.h)
    steps = np.arange(0, n_steps + 1, every)
    if steps[-1] != n_steps:
        steps = np.append(steps, n_steps)
    times = cfg.h * steps.astype(float)
    times[-1] = cfg.t_final  # not h * n_steps, which may round past t_final
    return times


def run_approach(model: _Model, approach: Approach, cfg: StudyConfig) -> dict[str, Any]:
    """Integrate one approach; return its saved times and body momenta, its errors (maxima over every step
    of ``h`` when there are at most :data:`FULL_RESOLUTION_STEPS`) and its timings."""
    from ..integrators.methods import Kind
    from ..integrators.solve import solve

    n_steps = round(cfg.t_final / cfg.h)
    every = 1 if n_steps <= FULL_RESOLUTION_STEPS else cfg.save_every
    # the fixed-step methods step by h, Adams outputs every h (the seed's): both at the same times
    kw: dict[str, Any] = dict(t_final=cfg.t_final, saveat=_output_times(cfg, every))
    if approach.method.kind is Kind.ADAPTIVE:
        kw.update(rtol=cfg.adams_tol, atol=cfg.adams_tol)
    else:
        kw.update(h=cfg.h, newton_tol=cfg.newton_tol)
    start = time.perf_counter()
    if approach.representation == "reduced":
        sol = solve(model.reduction.reduced_system(cfg.G), approach.method, y0=model.lL0, **kw)
    elif approach.representation == "euler-angles-6d":
        q0 = model.euler.forward(model.R0, model.m0)
        sol = solve(model.euler.canonical_system(), approach.method, y0=q0, **kw)
    else:
        sol = solve(model.system, approach.method, m0=model.m0, **kw)
    compile_time = float(sol.stats.get("compile_time", 0.0) or 0.0)
    # numba compiles (or loads from its disk cache) on a method's first use: reported apart, never in the time
    wall = time.perf_counter() - start - compile_time
    m = _momentum(model, approach, sol.states, cfg.G)
    H = model.system.hamiltonian(m)
    H0 = float(model.system.hamiltonian(model.m0))
    energy_error = np.abs(H - H0)
    momentum_error = np.abs(np.linalg.norm(m, axis=-1) - cfg.G)
    keep = slice(None, None, cfg.save_every // every)
    t = np.asarray(sol.t)
    if every == 1 and (t.size - 1) % cfg.save_every:
        keep = np.r_[np.arange(0, t.size, cfg.save_every), t.size - 1]
    return {
        "t": t[keep],
        "m": m[keep],
        "energy_error": energy_error[keep],
        "momentum_error": momentum_error[keep],
        "max_energy_error": float(energy_error.max()),
        "max_momentum_error": float(momentum_error.max()),
        "errors_sampled_every_s": every * cfg.h,
        "wall_time": wall,
        "compile_time": compile_time,
        "n_rhs": int(sol.stats.get("n_rhs", 0) or 0),
        "status": sol.status.value,
        "lL": sol.states[keep, :2] if approach.representation == "reduced" else None,
    }


def run_study(
    cfg: StudyConfig, *, progress: Callable[[list[Approach]], Iterable[Approach]] | None = None, command: str = ""
) -> tuple[Any, dict[str, Any], _Model]:
    """Run every approach; return the xarray Dataset, the summary and the model."""
    import xarray as xr

    model = build_model(cfg)
    todo = approaches(cfg)
    results: dict[str, dict[str, Any]] = {}
    for approach in progress(todo) if progress else todo:
        results[approach.key] = run_approach(model, approach, cfg)
    t = results[todo[0].key]["t"]
    keys = [a.key for a in todo]
    for k in keys:
        if results[k]["t"].shape != t.shape or np.abs(results[k]["t"] - t).max() > 1e-9 * cfg.t_final:
            raise InputError(f"internal: approach {k} saved on another time grid")
    reduced = [a.key for a in todo if a.representation == "reduced"]
    l_grid = np.linspace(-np.pi, np.pi, 241)
    L_grid = np.linspace(-cfg.G, cfg.G, 161)[1:-1]
    ll, LL = np.meshgrid(l_grid, L_grid)
    hp = model.reduction.reduced_hamiltonian(np.stack([ll, LL], -1), cfg.G, 2)
    ds = xr.Dataset(
        {
            "lL": (
                ("reduced_approach", "time", "canonical"),
                np.stack([results[k]["lL"] for k in reduced]),
                {"long_name": "Serret-Andoyer variables (l, L), chart about body axis 3", "units": "rad, kg m^2 / s"},
            ),
            "h_p": (
                ("L_grid", "l_grid"),
                hp,
                {"long_name": "reduced Hamiltonian h_p(l, L) = H_c(U_p(l, L))", "units": "J"},
            ),
            "m": (
                ("approach", "time", "component"),
                np.stack([results[k]["m"] for k in keys]),
                {"long_name": "body angular momentum", "units": "kg m^2 / s"},
            ),
            "energy_error": (
                ("approach", "time"),
                np.stack([results[k]["energy_error"] for k in keys]),
                {"long_name": "|H_c(t) - H_c(0)|", "units": "J"},
            ),
            "momentum_error": (
                ("approach", "time"),
                np.stack([results[k]["momentum_error"] for k in keys]),
                {"long_name": "| |m(t)| - G |", "units": "kg m^2 / s"},
            ),
            "wall_time": (
                ("approach",),
                np.array([results[k]["wall_time"] for k in keys]),
                {"long_name": "run time without compilation", "units": "s"},
            ),
            "compile_time": (
                ("approach",),
                np.array([results[k]["compile_time"] for k in keys]),
                {"long_name": "compilation (numba, first use) or loading from its cache", "units": "s"},
            ),
        },
        coords={
            "approach": keys,
            "time": ("time", t, {"units": "s"}),
            "component": ["m1", "m2", "m3"],
            "reduced_approach": reduced,
            "canonical": ["l", "L"],
            "l_grid": ("l_grid", l_grid, {"units": "rad"}),
            "L_grid": ("L_grid", L_grid, {"units": "kg m^2 / s"}),
            "label": ("approach", [a.label for a in todo]),
            "method": ("approach", [repr(a.method) for a in todo]),
            "representation": ("approach", [a.representation for a in todo]),
            "in_seed": ("approach", np.array([a.in_seed for a in todo])),
        },
        attrs={
            "title": "Serret-Andoyer paper, section 8.1: closed loop of a rigid body with one rotor",
            "geomech_version": __version__,
            "command": command,
            "parameters": json.dumps(asdict(cfg)),
            "initial_momentum": json.dumps(model.m0.tolist()),
            "initial_lL": json.dumps(model.lL0.tolist()),
        },
    )
    summary = _summary(cfg, model, todo, results, command)
    return ds, summary, model


def _summary(
    cfg: StudyConfig, model: _Model, todo: list[Approach], results: dict[str, dict[str, Any]], command: str
) -> dict[str, Any]:
    per = {
        a.key: {
            "label": a.label,
            "method": repr(a.method),
            "representation": a.representation,
            "in_seed": a.in_seed,
            "max_energy_error": results[a.key]["max_energy_error"],
            "max_momentum_error": results[a.key]["max_momentum_error"],
            "errors_sampled_every_s": results[a.key]["errors_sampled_every_s"],
            "wall_time_s": results[a.key]["wall_time"],
            "compile_time_s": results[a.key]["compile_time"],
            "rhs_evaluations": results[a.key]["n_rhs"],
            "status": results[a.key]["status"],
            **_drift(results[a.key]["m"], cfg.G),
        }
        for a in todo
    }
    seed = [a.key for a in todo if a.in_seed]
    E = {k: per[k]["max_energy_error"] for k in per}
    M = {k: per[k]["max_momentum_error"] for k in per}
    # |m| of the reduced representations is G by construction; "keeps the momentum" means to round-off
    keep_tol = 1e-12 * cfg.G
    comparisons = [("reduced_adams", "euler_adams"), ("reduced_adams", "full6d_adams")]
    if "euler_midpoint" in E:
        comparisons.append(("reduced_midpoint", "euler_midpoint"))
    claims = {
        "midpoint_best_on_energy": {
            "claim": "Among the seed's five approaches, the midpoint rule has the smallest energy error.",
            "holds": bool(E["reduced_midpoint"] <= min(E[k] for k in seed)),
            "evidence": {k: E[k] for k in seed},
        },
        "reduced_form_better_whatever_the_method": {
            "claim": "With the same method, the reduced Serret-Andoyer form has smaller energy and momentum "
            "errors than Euler's equations and the full 6-D dynamics (Adams on all three"
            + ("; the midpoint rule on the reduced form and on Euler's equations" if "euler_midpoint" in E else "")
            + ").",
            "holds": bool(all(E[red] <= E[other] and M[red] <= M[other] for red, other in comparisons)),
            "evidence": {
                f"{red} vs {other}": {"energy": [E[red], E[other]], "momentum": [M[red], M[other]]}
                for red, other in comparisons
            },
        },
        "full_6d_stays_inside_the_sphere": {
            "claim": "The full 6-D dynamics produce trajectories inside the sphere |m| = G (the seed's words for "
            "its drift): |m(T)| < G.",
            "holds": bool(per["full6d_adams"]["momentum_drift_final"] < 0),
            "evidence": {
                "momentum_drift_final": per["full6d_adams"]["momentum_drift_final"],
                "direction": per["full6d_adams"]["momentum_drift_direction"],
            },
        },
        "all_but_full_6d_keep_the_momentum": {
            "claim": f"Every approach but the full 6-D one keeps |m| = G (here: to {keep_tol:g}).",
            "holds": bool(all(M[k] <= keep_tol for k in seed if k != "full6d_adams") and M["full6d_adams"] > keep_tol),
            "evidence": {k: M[k] for k in seed},
        },
    }
    return {
        "study": "serret-andoyer section 8.1",
        "geomech_version": __version__,
        "command_line": command,
        "config": asdict(cfg),
        "choices": {
            "inertias": "not given by the seed; chosen admissible: lambda1 > lambda2 > I3 + J3 and "
            "G^2/(2 lambda1) < Hc < G^2/(2 lambda2)",
            "duration": f"{cfg.t_final} s (the seed gives none)",
            "initial_state": {
                "m0": model.m0.tolist(),
                "(l, L)": model.lL0.tolist(),
                "R0 (6-D frame)": model.R0.tolist(),
            },
        },
        "orbit": _orbit(cfg, model),
        "approaches": per,
        "claims": claims,
    }


def _drift(m: np.ndarray, G: float) -> dict[str, Any]:
    """The signed change of |m| at the end of a run: outward (> 0) or inward (< 0) of the sphere |m| = G, or
    none beyond round-off."""
    d = float(np.linalg.norm(np.asarray(m)[-1]) - G)
    direction = "none (round-off)" if abs(d) <= 1e-12 * G else ("outward" if d > 0 else "inward")
    return {"momentum_drift_final": d, "momentum_drift_direction": direction}


def _orbit(cfg: StudyConfig, model: _Model) -> dict[str, Any]:
    """The closed-loop orbit of the initial state: its kind and period, from the periodic-orbit propagator of
    the reduced system (one period integrated to near machine precision)."""
    from ..integrators.periodic import PeriodicOrbitPropagator

    orbit = PeriodicOrbitPropagator(model.reduction.reduced_system(cfg.G, 2), model.lL0)
    return {
        "kind": orbit.kind,
        "period_s": float(orbit.period),
        "period_error_estimate_s": float(orbit.period_error),
        "periods_in_run": float(cfg.t_final / orbit.period) if np.isfinite(orbit.period) else 0.0,
    }


def write_study(out: Path, ds: Any, summary: dict[str, Any], model: _Model, cfg: StudyConfig) -> list[Path]:
    """Write figures 5-7, the data file and summary.json into ``out``, all or nothing: each file is written
    under a temporary name and renamed into place only when every one is complete."""
    import matplotlib.pyplot as plt

    final = {
        "figure5_errors.png": lambda p: figure5(ds).savefig(p, dpi=130, format="png"),
        "figure6_trajectories.png": lambda p: figure6(ds, cfg.G).savefig(p, dpi=130, format="png"),
        "figure7_reduced_flow.png": lambda p: figure7(ds, cfg).savefig(p, dpi=130, format="png"),
        "serret_andoyer_study.nc": lambda p: ds.to_netcdf(p),
        "summary.json": lambda p: p.write_text(dumps_json(summary) + "\n"),
    }
    try:
        return write_set(out, final)
    finally:
        plt.close("all")


def prepare_output(out: Path) -> None:
    """Check that ``out`` can be written, before any work is done (nothing is created until the end)."""
    check_output_dir(out, "--out")


def terminal_progress(items: list[Approach]) -> Iterable[Approach]:
    """A progress bar on a terminal (click's), silent when stderr is not one."""
    import click

    if not sys.stderr.isatty():
        yield from items
        return
    with click.progressbar(
        items, label="integrating", file=sys.stderr, item_show_func=lambda a: a.label if a else ""
    ) as bar:
        yield from bar
