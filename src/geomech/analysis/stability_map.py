"""Stability maps: the verdicts on a continued relative equilibrium over a grid of two parameters.

The result is an :class:`xarray.Dataset` (write it with ``ds.to_netcdf(path)``): one dimension per
parameter, the verdict codes of :data:`~geomech.analysis.stability.VERDICT_CODES` with CF
``flag_values``/``flag_meanings``, the equilibrium's momentum, the eigenvalues of the Hessian of
:math:`h_p`, the growth rate of the linearisation and the (normalised) determinant of the energy-Casimir
second variation, whose zero level is the stability boundary. xarray is imported when a map is made.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _validate as V
from .._version import __version__
from ..errors import ConvergenceError, InputError, NumericalError
from .equilibria import continue_equilibria, fibonacci_sphere, find_equilibria
from .stability import VERDICT_CODES, _ec_determinant, assess

__all__ = ["stability_map", "theorem5_margin"]


def _axis_values(spec: Any, argname: str) -> tuple[str, np.ndarray]:
    try:
        name, values = spec
    except (TypeError, ValueError) as exc:
        raise InputError(f"Expected `{argname}` to be a pair (parameter name, values), got {spec!r}.") from exc
    values = V.finite(values, f"{argname} values")
    if values.ndim != 1 or values.size < 2 or np.any(np.diff(values) <= 0):
        raise InputError(f"Expected the values of `{argname}` to be at least 2 increasing numbers, got {values}.")
    return str(name), values


def stability_map(
    family: Callable[..., Any],
    x: tuple[str, Sequence[float] | np.ndarray],
    y: tuple[str, Sequence[float] | np.ndarray],
    *,
    G: float = 1.0,
    near: Any = None,
    fixed: Mapping[str, float] | None = None,
    closed_form: Callable[[Mapping[str, float]], float] | None = None,
    description: str = "",
    n_points: int = 600,
    progress: Callable[[int], None] | None = None,
    max_points: int | None = None,
    out: Any = None,
    resume: bool = False,
    scheduler: Any = None,
    chunk: int | None = None,
    model: Mapping[str, Any] | None = None,
    backend: str = "auto",
):
    """The three verdicts on the relative equilibrium near ``near`` over a grid of two parameters.

    A family given by a formula (``control.family()`` for a control whose :math:`H_c` has a closed form, or
    ``system.family()`` for a :class:`~geomech.LeftInvariantSystem` from an expression) is compiled once with numba:
    the search and the verdicts of every point then run in one compiled call per block, with the same starting
    points, iterations, tolerances and thresholds as the Python search (:func:`~geomech.analysis.find_equilibria`,
    :func:`~geomech.analysis.assess`), whose verdicts they reproduce. Any other family runs point by point in Python.

    The grid runs as a study (:func:`~geomech.analysis.sweep`): blocks of whole rows (``chunk`` points, default one
    row), each one task on dask (every core of this machine, or the cluster of ``scheduler``), written to the Zarr
    store ``out`` as they complete and resumed from it with ``resume=True``.

    Parameters
    ----------
    family : ``family(**parameters) -> LeftInvariantSystem``, e.g. ``control.family()``.
    x, y : ``(name, values)`` of the two parameters swept.
    near : (3,) the reference, default :math:`(0, G, 0)` (spin about the intermediate axis, the seed's
        :math:`(l, L) = (0, 0)`). At each grid point the equilibrium assessed is the one nearest to ``near``
        among the relative equilibria found. They are continued from grid point to grid point along a block's
        rows, with Newton also started from ``near``, and searched afresh
        (:func:`~geomech.analysis.find_equilibria`) at a row's first point (so that the map does not depend on the
        blocks), wherever the continued set fails
        the Poincare-Hopf check, and wherever the start from ``near`` finds an equilibrium the previous point did
        not have (a pair born in a fold between grid points, which Poincare-Hopf cannot see). A pair born far
        from ``near`` and from every continued branch can still be missed until a fresh search; ``chunk=1``
        searches afresh at every point (about 20 times the cost).
    fixed : values of the other parameters.
    closed_form : optional ``f(values) -> float`` whose zero level is a predicted boundary (e.g.
        :func:`theorem5_margin`); stored as ``closed_form_margin``.
    progress : optional ``progress(n)``, called with the number of grid points done as blocks complete, from 0 to
        the grid's size (a progress bar; the command line draws one on a terminal).
    max_points : int, optional
        A larger grid is refused before any work; raise it to run one. Default 10,000 points in Python (10-15 ms a
        point) and 1,000,000 compiled (about 10-20 microseconds a point on one core).
    out, resume, scheduler, chunk :
        The study's store, its resumption, where it runs and the points per task (:func:`~geomech.analysis.sweep`).
    model : mapping, optional
        What identifies the family in its store (its JSON: the command line gives the model's); default the
        family's own ``to_json()`` where it has one (a control's family does), else its function's name and source
        with ``description``.
    backend : ``"auto"`` (compiled where the family has a formula and numba is available), ``"numba"`` (compiled,
        or an error saying why not) or ``"python"``.

    Returns
    -------
    xarray.Dataset
        Variables ``verdict``, ``lagrange_dirichlet``, ``energy_casimir``, ``linearisation`` (int8 codes),
        ``m`` (the equilibrium assessed), ``branch_jump`` (1 where it is not the continuation of the previous
        point's along the row, i.e. the nearest equilibrium changed identity; never at a row's first point, which
        has no previous one), ``complete`` (Poincare-Hopf check passed), ``hessian_eigenvalues``,
        ``growth_rate`` (largest real part of the linearisation eigenvalues), ``ec_determinant``, ``status`` (the
        study's: 1 where the assessment raised) and optionally ``closed_form_margin``.
    """
    from .sweep import _block_shape, sweep

    xname, xs = _axis_values(x, "x")
    yname, ys = _axis_values(y, "y")
    if xname == yname:
        raise InputError(f"Expected two different parameters for `x` and `y`, got {xname!r} twice.")
    compiled = _compiled_backend(family, backend)
    if max_points is None:
        max_points = 1_000_000 if compiled else 10_000
    V.work_budget(
        float(xs.size) * ys.size,
        float(max_points),
        f"The grid ({xs.size} x {ys.size} points)",
        "max_points",
        "take fewer points",
        seconds_each=2e-5 if compiled else 0.015,
    )
    G = V.positive_scalar(G, "G")
    near = np.array([0.0, G, 0.0]) if near is None else V.exact_shape(near, "near", (3,))
    fixed = {str(k): float(v) for k, v in dict(fixed or {}).items()}
    if model is None:
        to_json = getattr(getattr(family, "control", None), "to_json", None) or getattr(family, "to_json", None)
        model = to_json() if callable(to_json) else {"family": _family_identity(family)}
    identity = {
        "function": "geomech.analysis.stability_map",
        "model": dict(model),
        "description": description,
        "G": G,
        "near": near.tolist(),
        "fixed": fixed,
        "n_points": int(n_points),
        "closed_form": None if closed_form is None else _family_identity(closed_form),
    }
    study = functools.partial(
        _assess_points, family, xname, yname, fixed, G, near, closed_form, int(n_points), compiled
    )
    # compiled, a row is too little work for a task: blocks of about 4,096 points (whole rows)
    per_task = (xs.size * max(1, 4096 // xs.size) if compiled else xs.size) if chunk is None else chunk
    per_block = math.prod(_block_shape((ys.size, xs.size), per_task))
    report = None if progress is None else (lambda done, total: progress(min(done * per_block, xs.size * ys.size)))
    axes: dict[str, Any] = {yname: ys, xname: xs}
    ds = sweep(
        study,
        out=out,
        resume=resume,
        scheduler=scheduler,
        chunk=per_task,
        progress=report,
        identity=identity,
        max_members=int(max_points),
        **axes,
    )
    ds = ds.rename({"m_dim0": "component", "hessian_eigenvalues_dim0": "eigenvalue"})
    flags = {
        "flag_values": np.array(sorted(VERDICT_CODES.values()), dtype=np.int8),
        "flag_meanings": " ".join(k for k, _ in sorted(VERDICT_CODES.items(), key=lambda kv: kv[1])),
    }
    described = {
        "verdict": {
            **flags,
            "long_name": "combined verdict (stable if Lagrange-Dirichlet "
            "or energy-Casimir proves it, unstable if the linearisation does)",
        },
        "lagrange_dirichlet": {**flags, "long_name": "Lagrange-Dirichlet on h_p"},
        "energy_casimir": {**flags, "long_name": "energy-Casimir on so(3)*"},
        "linearisation": {**flags, "long_name": "linearisation eigenvalues"},
        "m": {"long_name": "body momentum of the continued equilibrium"},
        "hessian_eigenvalues": {"long_name": "eigenvalues of the Hessian of h_p (Serret-Andoyer chart)"},
        "branch_jump": {
            "long_name": "1 where the continuation left the followed branch (or started afresh at a block's first "
            "point), 0 where it followed it"
        },
        "complete": {"long_name": "1 where the equilibria found pass the Poincare-Hopf check"},
        "growth_rate": {"long_name": "largest real part of the linearisation eigenvalues"},
        "ec_determinant": {
            "long_name": "normalised determinant of the energy-Casimir second variation; its zero level is the "
            "stability boundary"
        },
        "closed_form_margin": {"long_name": "closed-form prediction; zero on the predicted boundary"},
    }
    for name, attrs in described.items():
        if name in ds:
            ds[name].attrs.update(attrs)
    if closed_form is None:
        ds = ds.drop_vars("closed_form_margin")
    return ds.assign_coords(component=["m1", "m2", "m3"], eigenvalue=[0, 1]).assign_attrs(
        {
            "title": "stability map of a relative equilibrium",
            "description": description,
            "G": G,
            "near": near.tolist(),
            "fixed_parameters": str(fixed),
            "x": xname,
            "y": yname,
            "source": f"geomech {__version__}",
        }
    )


_BACKENDS = ("auto", "numba", "python")


def _compiled_backend(family: Any, backend: str) -> bool:
    """Whether the map runs compiled: ``backend`` checked against what the family and the machine allow."""
    from ..integrators._codegen import numba_available

    if backend not in _BACKENDS:
        raise InputError(f"Expected `backend` to be one of {list(_BACKENDS)}, got {backend!r}.")
    if backend == "python":
        return False
    system = _formula_system(family)
    if system is not None and numba_available():
        return True
    if backend == "numba":
        why = (
            "numba is not available"
            if system is not None
            else "the family has no formula (a control's family whose H_c has a closed form, or system.family() "
            "of a LeftInvariantSystem built from an expression, has one)"
        )
        raise InputError(f"backend='numba' needs a family given by a formula and numba; {why}.")
    return False


def _formula_system(family: Any) -> Any:
    """The family's formula (a LeftInvariantSystem with an expression), or None."""
    get = getattr(family, "formula_system", None)
    system = get() if callable(get) else None
    return system if getattr(system, "expression", None) is not None else None


@functools.lru_cache(maxsize=8)
def _mesh(n: int, G: float) -> tuple[np.ndarray, np.ndarray]:
    """The quasi-uniform points of the fresh search (:func:`~geomech.analysis.find_equilibria`) and each one's
    8 nearest neighbours (itself first)."""
    from scipy.spatial import cKDTree

    pts = np.ascontiguousarray(fibonacci_sphere(n, G))
    _, nbr = cKDTree(pts).query(pts, k=9)
    return pts, np.ascontiguousarray(nbr, dtype=np.int64)


@functools.cache
def _kernels() -> Any:
    from pathlib import Path

    from ..integrators._codegen import template_module

    return template_module(Path(__file__).with_name("_k_equilibria.py"), "eq")


def _assess_compiled(
    family: Any,
    values: Mapping[str, Any],
    G: float,
    near: np.ndarray,
    n_points: int,
    restart: np.ndarray,
    out: dict[str, np.ndarray],
) -> None:
    """``_assess_points``' outputs for the points ``values`` (name -> array) in one compiled call."""
    from ..integrators._problem import make_problem

    system = _formula_system(family)
    family.check_values(values)  # the errors family(**point) raises
    problem = make_problem(system, attitude=False)
    module, _ = problem.module(frozenset(), "numba")
    n = restart.size
    names = set(problem.parameter_names)
    given = {k: np.broadcast_to(np.asarray(v, dtype=float), (n,)) for k, v in values.items() if k in names}
    rows = problem.parameter_rows(given)
    rows = np.ascontiguousarray(np.broadcast_to(rows, (n, rows.shape[1])))
    pts1, nbr1 = _mesh(n_points, G)
    pts2, nbr2 = _mesh(6 * n_points, G)
    codes = np.full((n, 4), VERDICT_CODES["none"], dtype=np.int8)
    info = np.zeros(2, dtype=np.int64)
    _kernels().stability_points(
        module.addresses(("ghess3",)),
        rows,
        G,
        np.ascontiguousarray(near, dtype=float),
        restart.astype(np.int8),
        1e-12,
        pts1,
        nbr1,
        pts2,
        nbr2,
        codes,
        out["m"],
        out["hessian_eigenvalues"],
        out["growth_rate"],
        out["ec_determinant"],
        out["branch_jump"],
        out["complete"],
        info,
    )
    for j, name in enumerate(("verdict", "lagrange_dirichlet", "energy_casimir", "linearisation")):
        out[name][:] = codes[:, j]
    if info[0] != 0:
        where = {k: float(np.broadcast_to(v, (n,))[info[1]]) for k, v in values.items()}
        raise NumericalError(
            f"At {where}: "
            + (
                "|m x grad H| has too many local minima over the sphere: H is not resolved in double precision "
                "there (parameters spanning too many orders of magnitude?)."
                if info[0] == 1
                else "the Hessian of h_p at an equilibrium is not finite (an overflow: parameter values too large "
                "for double precision?)."
            )
        )


def _family_identity(f: Any) -> dict[str, Any]:
    from .sweep import _identity

    return _identity(f)


def _assess_points(
    family: Callable[..., Any],
    xname: str,
    yname: str,
    fixed: Mapping[str, float],
    G: float,
    near: np.ndarray,
    closed_form: Callable[[Mapping[str, float]], float] | None,
    n_points: int,
    compiled: bool,
    **values: np.ndarray,
) -> dict[str, np.ndarray]:
    """The verdicts at the points ``values[xname][i], values[yname][i]``, in their order: all equilibria continued
    from the previous point's (searched afresh at a row's first point and where the continued set is not complete
    by Poincare-Hopf), the one nearest to ``near`` assessed."""
    xs, ys = values[xname], values[yname]
    n = xs.size
    # a row starts where x does not increase
    restart = np.ones(n, dtype=bool)
    restart[1:] = xs[1:] <= xs[:-1]
    codes = {
        k: np.full(n, VERDICT_CODES["none"], dtype=np.int8)
        for k in ("verdict", "lagrange_dirichlet", "energy_casimir", "linearisation")
    }
    m_all = np.full((n, 3), np.nan)
    hev = np.full((n, 2), np.nan)
    growth = np.full(n, np.nan)
    ecdet = np.full(n, np.nan)
    margin = np.full(n, np.nan)
    jumped = np.zeros(n, dtype=np.int8)
    complete = np.zeros(n, dtype=np.int8)
    if closed_form is not None:
        for i in range(n):
            margin[i] = float(closed_form({**fixed, xname: float(xs[i]), yname: float(ys[i])}))
    outputs = {
        **codes,
        "m": m_all,
        "hessian_eigenvalues": hev,
        "branch_jump": jumped,
        "complete": complete,
        "growth_rate": growth,
        "ec_determinant": ecdet,
        "closed_form_margin": margin,
    }
    if compiled:
        _assess_compiled(family, {**fixed, xname: xs, yname: ys}, G, near, n_points, restart, outputs)
        return outputs
    prev = None
    last: np.ndarray | None = None
    for i in range(n):
        if restart[i]:
            prev, last = None, None
        point = {**fixed, xname: float(xs[i]), yname: float(ys[i])}
        system = family(**point)
        # All equilibria, continued from the previous point's, with Newton also started from `near` (a full search
        # when the continued set is not complete by Poincare-Hopf, or when that start finds an equilibrium the
        # previous point did not have: a pair born in a fold between the points); the one assessed is the
        # nearest to `near`.
        try:
            eqs = (
                find_equilibria(system, G, n_points=n_points)
                if prev is None
                else continue_equilibria(system, prev, n_points=n_points, seeds=near)
            )
        except (ConvergenceError, InputError, FloatingPointError):
            prev = None
            continue
        if len(eqs) == 0:
            prev = None
            continue
        eq = eqs.nearest(near, prefer=last)
        # A step to a far point means the nearest equilibrium changed identity (its branch ended in a fold, or
        # another came nearer): flagged, since the verdict then belongs to another branch.
        jumped[i] = last is not None and np.linalg.norm(eq.m - last) > 0.25 * G
        prev, last = eqs, eq.m
        complete[i] = eqs.complete
        rep = assess(system, eq)
        codes["verdict"][i] = VERDICT_CODES[rep.verdict]
        codes["lagrange_dirichlet"][i] = VERDICT_CODES[rep.lagrange_dirichlet.verdict]
        codes["energy_casimir"][i] = VERDICT_CODES[rep.energy_casimir.verdict]
        codes["linearisation"][i] = VERDICT_CODES[rep.linearisation.verdict]
        m_all[i] = eq.m
        hev[i] = np.linalg.eigvalsh(eq.hessian)
        growth[i] = float(np.max(np.real(rep.linearisation.eigenvalues)))
        ecdet[i] = _ec_determinant(system, eq.m)
    return outputs


def theorem5_margin(control: Any) -> Callable[[Mapping[str, float]], float]:
    """Theorem 5's closed form for one rotor on axis 3: ``f(values) = phi'(0) - (1 - I3/lambda2)``.

    Zero on the boundary of stability of the spin about the intermediate axis, positive on the stable side,
    valid where :math:`\\varphi(0) + p = 0` (the equilibrium is then :math:`(l, L) = (0, 0)`); NaN elsewhere.
    """
    if getattr(control, "kind", None) != "one-rotor":
        raise InputError("Theorem 5 is the seed's result for one rotor on axis 3; `control` is not one.")
    origin = np.zeros((1, 3))

    def margin(values: Mapping[str, float]) -> float:
        vals = {**control.parameters, **{k: float(x) for k, x in values.items() if k in control.parameters}}
        phi0 = float(control.phi(origin, vals)[0, 0])
        if abs(phi0 + vals["p"]) > 1e-12 * max(1.0, abs(phi0)):
            return float("nan")
        dphi0 = float(control.phi_jacobian(origin, vals)[0, 0] @ control.body.axes[0])
        return dphi0 - (1.0 - vals["I3"] / vals["lambda2"])

    return margin
