"""Studies over many parameter values, on dask, resumable: :func:`sweep` over a grid and :func:`monte_carlo` over
random samples.

A study is a function of named parameters that takes one array per parameter (the members of a block, all the
same length) and returns a mapping of output arrays whose first axis is the members: one call is one ensemble
(``solve`` with ``parameters`` arrays runs a batch in one compiled call), never one simulation. The grid or the
samples are cut into blocks of about ``chunk`` members; each block is one dask task, which calls the study and
writes its outputs into a Zarr store (``out``; arrays in memory without one) at the block's place, then marks the
block done. On the local
machine the tasks run on dask's threaded scheduler over every core (the compiled loops release the GIL); given a
``dask.distributed.Client`` or a scheduler's address they run on that cluster, where dask reschedules the tasks of
a lost worker (a block written twice is written the same). The result is an :class:`xarray.Dataset` with one
dimension per swept parameter (or ``sample``), the outputs as variables, each member's ``status`` (0 done, 1 the
study raised on it: its outputs are NaN, the error is in the attributes), the units given, and the provenance
(the study, its fixed arguments, the axes, the seed, and the versions of geomech and its dependencies; mappings
as JSON text, so that the Dataset writes to NetCDF as it is).

Interrupted (Ctrl-C, a killed process, a lost machine), a study rerun with ``resume=True`` and the same arguments
computes only the blocks not marked done and ends with the same data, to the last bit, as an uninterrupted run:
the blocks are fixed by the arguments, each member's values do not depend on which task computes it, and the
random samples are drawn in fixed generation blocks of :data:`SEED_BLOCK` members from the recorded seed (each its
own ``SeedSequence(seed, spawn_key=(j,))``), so that they do not depend on the chunking, the workers or the
resumption. A store of another study, or an existing store without ``resume``, is refused with one line.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
import math
import os
import platform
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _validate as V
from .._version import __version__
from ..errors import InputError

__all__ = ["SEED_BLOCK", "DISTRIBUTIONS", "monte_carlo", "sweep"]

#: Random samples are drawn in generation blocks of this many members, each from its own child of the seed.
SEED_BLOCK = 4096
#: The distributions of :func:`monte_carlo`: name -> (number of parameters, what they are).
DISTRIBUTIONS = {
    "uniform": (2, "low, high"),
    "normal": (2, "mean, standard deviation"),
    "lognormal": (2, "mean and standard deviation of the logarithm"),
}
#: Default members per block (one dask task, one ensemble call of the study).
CHUNK = 1024
_FORMAT = 1  # the layout of the store; a store of another layout is refused


@dataclass
class _Plan:
    """What a study is: its function, dimensions and coordinates, how a block's parameter values are made, and what
    identifies it (``fingerprint``)."""

    study: Callable[..., Mapping[str, Any]]
    dims: tuple[str, ...]
    coords: dict[str, np.ndarray]
    block: tuple[int, ...]
    fixed: dict[str, Any]
    identity: dict[str, Any]
    units: dict[str, str]
    distributions: dict[str, tuple] = field(default_factory=dict)
    seed: int | None = None

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(self.coords[d]) for d in self.dims)

    @property
    def grid(self) -> tuple[int, ...]:
        """Blocks along each dimension."""
        return tuple(-(-n // b) for n, b in zip(self.shape, self.block))

    def slices(self, index: tuple[int, ...]) -> tuple[slice, ...]:
        return tuple(slice(i * b, min((i + 1) * b, n)) for i, b, n in zip(index, self.block, self.shape))

    def values(self, index: tuple[int, ...]) -> dict[str, np.ndarray]:
        """The parameter values of the members of block ``index``, flattened in C order."""
        where = self.slices(index)
        if self.seed is None:
            axes = [self.coords[d][s] for d, s in zip(self.dims, where)]
            mesh = np.meshgrid(*axes, indexing="ij")
            return {d: m.ravel() for d, m in zip(self.dims, mesh)}
        return draw(self.distributions, self.seed, where[0].start, where[0].stop)

    @property
    def fingerprint(self) -> str:
        return hashlib.sha256(json.dumps(self.identity, sort_keys=True, default=str).encode()).hexdigest()


def draw(distributions: Mapping[str, tuple], seed: int, start: int, stop: int) -> dict[str, np.ndarray]:
    """The samples ``start:stop`` of each parameter: generation block ``j`` (members ``j SEED_BLOCK`` to
    ``(j + 1) SEED_BLOCK``) comes from ``SeedSequence(seed, spawn_key=(j,))``, the parameters drawn in the order of
    their names, whatever the members asked for."""
    names = sorted(distributions)
    out = {n: np.empty(stop - start) for n in names}
    for j in range(start // SEED_BLOCK, -(-stop // SEED_BLOCK)):
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(j,)))
        lo, hi = j * SEED_BLOCK, (j + 1) * SEED_BLOCK
        a, b = max(lo, start), min(hi, stop)
        for n in names:
            kind, p, q = distributions[n]
            block = getattr(rng, kind)(p, q, SEED_BLOCK)
            out[n][a - start : b - start] = block[a - lo : b - lo]
    return out


def _identity(study: Callable) -> dict[str, Any]:
    """What names a study function: its module and qualified name, and a hash of its source where it has one
    (values a closure captured are not seen: pass them in ``fixed``)."""
    try:
        source = inspect.getsource(study)
    except (OSError, TypeError):
        source = ""
    return {
        "function": f"{getattr(study, '__module__', '?')}.{getattr(study, '__qualname__', repr(study))}",
        "source_sha256": hashlib.sha256(source.encode()).hexdigest() if source else None,
    }


def _json_identity(identity: Mapping[str, Any]) -> dict[str, Any]:
    try:
        return json.loads(json.dumps(dict(identity), sort_keys=True))
    except TypeError as exc:
        raise InputError(
            f"Expected `identity` to hold JSON values (numbers, strings, lists, mappings): {exc}."
        ) from None


def _block_shape(shape: tuple[int, ...], chunk: int) -> tuple[int, ...]:
    """Blocks of at most ``chunk`` members: whole trailing dimensions first (contiguous members), then part of the
    next."""
    block = [1] * len(shape)
    size = 1
    for i in range(len(shape) - 1, -1, -1):
        take = max(1, min(shape[i], chunk // size))
        block[i] = take
        size *= take
        if take < shape[i]:
            break
    return tuple(block)


def _chunk(chunk: Any) -> int:
    if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise InputError(f"Expected `chunk` (members per task) to be a positive integer, got {chunk!r}.")
    return int(chunk)


def _fixed(fixed: Mapping[str, Any] | None, names: set[str]) -> dict[str, Any]:
    fixed = dict(fixed or {})
    both = sorted(set(fixed) & names)
    if both:
        raise InputError(f"`fixed` names {both}, which are also swept; give each parameter once.")
    for k, v in fixed.items():
        try:
            json.dumps(v)
        except TypeError:
            raise InputError(
                f"Expected `fixed[{k!r}]` to be a number, a string, or a list of them (it identifies the study in "
                f"its store), got {type(v).__name__}."
            ) from None
    return fixed


def sweep(
    study: Callable[..., Mapping[str, Any]],
    *,
    out: str | os.PathLike | None = None,
    resume: bool = False,
    scheduler: Any = None,
    chunk: int = CHUNK,
    fixed: Mapping[str, Any] | None = None,
    units: Mapping[str, str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    max_members: int = 10**8,
    identity: Mapping[str, Any] | None = None,
    **axes: Any,
):
    """``study`` over the grid of the named ``axes`` (each a 1-D array of values): an :class:`xarray.Dataset` with
    one dimension per axis, in the order given.

    Parameters
    ----------
    study : ``study(**values, **fixed) -> {output: array}``
        Called once per block with one 1-D array per axis (the block's members, C order) and the ``fixed``
        values; returns arrays whose first axis is the members (numbers or booleans; further axes are kept). If it
        accepts ``threads``, it is told how many threads a task may use (the cores of its worker over the tasks
        the worker runs at once).
    out : path, optional
        The Zarr store the blocks are written to as they complete. Without it the blocks fill arrays in memory
        (the same data, without the store's cost: tens of milliseconds a block; nothing to resume then).
    resume : bool
        Continue the study in ``out``: only the blocks not marked done are computed. Without it an existing
        ``out`` is an error.
    scheduler : None, ``dask.distributed.Client`` or str
        None: dask's threaded scheduler over every core of this machine; a Client, or a scheduler address
        (``"tcp://host:8786"``), runs the tasks on that cluster.
    chunk : int
        Members per block (task); default 1024.
    fixed : mapping, optional
        Other arguments of ``study`` (numbers or strings): part of the study's identity in its store.
    units : mapping, optional
        Units of parameters and outputs by name (the ``units`` attribute of their variables).
    progress : ``progress(done, total)``, optional
        Called as blocks complete (done counts the blocks already in the store).
    max_members : int
        A larger grid is refused before any work.
    identity : mapping, optional
        What names the study in its store where its function cannot (a ``functools.partial`` over objects): JSON
        values, in place of the function's module, name and source.
    """
    if not axes:
        raise InputError("Expected at least one axis to sweep, as `name=values`.")
    coords = {}
    for name, values in axes.items():
        arr = V.finite(values, name)
        if arr.ndim != 1 or arr.size < 1:
            raise InputError(f"Expected the values of the axis `{name}` to be a 1-D array, got shape {arr.shape}.")
        coords[name] = arr.astype(float)
    dims = tuple(coords)
    shape = tuple(len(coords[d]) for d in dims)
    members = math.prod(shape)
    _bounded(members, max_members)
    chunk = _chunk(chunk)
    fixed_values = _fixed(fixed, set(dims))
    block = _block_shape(shape, chunk)
    identity = {
        "kind": "sweep",
        "study": _identity(study) if identity is None else _json_identity(identity),
        "fixed": fixed_values,
        "axes": {d: coords[d].tolist() for d in dims},
        "block": list(block),
        "format": _FORMAT,
    }
    plan = _Plan(study, dims, coords, block, fixed_values, identity, dict(units or {}))
    return _run(plan, out, resume, scheduler, progress)


def monte_carlo(
    study: Callable[..., Mapping[str, Any]],
    n: int,
    *,
    seed: int,
    out: str | os.PathLike | None = None,
    resume: bool = False,
    scheduler: Any = None,
    chunk: int = CHUNK,
    fixed: Mapping[str, Any] | None = None,
    units: Mapping[str, str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    max_members: int = 10**8,
    **distributions: Any,
):
    """``study`` over ``n`` random samples of the named parameters: an :class:`xarray.Dataset` with the dimension
    ``sample``, the sampled values as variables beside the outputs.

    Each parameter is ``(distribution, a, b)`` with a distribution of :data:`DISTRIBUTIONS` (``("normal", 3.0,
    0.05)``, ``("uniform", 0, 6.283)``). The samples come from ``seed`` (recorded in the store) in generation blocks
    of :data:`SEED_BLOCK` members, so that they are the same whatever the chunking, the workers or a resumption.
    The other arguments are those of :func:`sweep`.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"Expected `n` (the number of samples) to be a positive integer, got {n!r}.")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"Expected `seed` to be a non-negative integer (it is recorded with the data), got {seed!r}.")
    if not distributions:
        raise InputError("Expected at least one parameter to sample, as `name=(distribution, a, b)`.")
    specs = {}
    for name, spec in distributions.items():
        if not isinstance(spec, (tuple, list)) or not spec or spec[0] not in DISTRIBUTIONS:
            raise InputError(
                f"Expected `{name}` to be (distribution, a, b) with a distribution of {sorted(DISTRIBUTIONS)}, "
                f"got {spec!r}."
            )
        kind = str(spec[0])
        count, what = DISTRIBUTIONS[kind]
        params = V.finite(list(spec[1:]), name)
        if params.shape != (count,):
            raise InputError(f"Expected `{name}` = ({kind!r}, {what}): {count} numbers after the name, got {spec!r}.")
        if kind == "uniform" and not params[0] < params[1]:
            raise InputError(f"Expected `{name}` = ('uniform', low, high) with low < high, got {spec!r}.")
        if kind in ("normal", "lognormal") and not params[1] >= 0:
            raise InputError(f"Expected the standard deviation of `{name}` to be >= 0, got {spec!r}.")
        specs[name] = (kind, float(params[0]), float(params[1]))
    _bounded(int(n), max_members)
    chunk = _chunk(chunk)
    fixed_values = _fixed(fixed, set(specs))
    block = (min(chunk, int(n)),)
    identity = {
        "kind": "monte_carlo",
        "study": _identity(study),
        "fixed": fixed_values,
        "distributions": {k: list(v) for k, v in specs.items()},
        "n": int(n),
        "seed": int(seed),
        "seed_block": SEED_BLOCK,
        "block": list(block),
        "format": _FORMAT,
    }
    plan = _Plan(
        study,
        ("sample",),
        {"sample": np.arange(int(n))},
        block,
        fixed_values,
        identity,
        dict(units or {}),
        specs,
        int(seed),
    )
    return _run(plan, out, resume, scheduler, progress)


def _bounded(members: int, max_members: int) -> None:
    if members > max_members:
        raise InputError(
            f"The study has {members:.3g} members, above `max_members` = {max_members:.3g}; raise it to run it."
        )


# --------------------------------------------------------------------------------------------------
# the blocks: one dask task each
# --------------------------------------------------------------------------------------------------
def _call(plan: _Plan, values: Mapping[str, np.ndarray], threads: int) -> dict[str, np.ndarray]:
    """The study on the members ``values``, its outputs checked: arrays of numbers with the members first."""
    kwargs: dict[str, Any] = {**values, **plan.fixed}
    try:
        accepts = "threads" in inspect.signature(plan.study).parameters
    except (TypeError, ValueError):
        accepts = False
    if accepts:
        kwargs["threads"] = threads
    result = plan.study(**kwargs)
    if not isinstance(result, Mapping) or not result:
        raise InputError(f"Expected the study to return a mapping {{output name: array}}, got {type(result).__name__}.")
    m = len(next(iter(values.values())))
    outputs = {}
    for name, value in result.items():
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf" or arr.ndim < 1 or arr.shape[0] != m:
            raise InputError(
                f"Expected the study's output `{name}` to be an array of numbers with its first axis the {m} members, "
                f"got dtype {arr.dtype} and shape {arr.shape}."
            )
        outputs[str(name)] = arr
    return outputs


def _fill(dtype: np.dtype) -> Any:
    return np.nan if dtype.kind == "f" else (False if dtype.kind == "b" else -1)


def _threads_per_task() -> int:
    """The cores of this worker over the tasks it runs at once (numba threads times tasks = cores)."""
    cores = os.cpu_count() or 1
    try:
        from distributed import get_worker

        return max(1, cores // max(1, int(get_worker().state.nthreads)))
    except (ImportError, ValueError, AttributeError):
        return 1  # dask's threaded scheduler runs one task per core


class _Memory:
    """The outputs of a study without a store (``out`` not given, on this machine): one array per output, filled
    by the blocks in place, with the attributes a store would hold. Nothing to resume, nothing written to disk."""

    def __init__(self, plan: _Plan, schema: Mapping[str, Any]):
        self.arrays: dict[str, np.ndarray] = {}
        for name, spec in schema.items():
            dtype = np.dtype(spec["dtype"])
            self.arrays[name] = np.full(plan.shape + tuple(spec["shape"]), _fill(dtype), dtype=dtype)
        for name in plan.distributions:
            self.arrays[name] = np.full(plan.shape, np.nan)
        self.arrays["status"] = np.full(plan.shape, -1, dtype=np.int8)
        self.arrays["_done"] = np.zeros(plan.grid, dtype=np.int8)
        self.attrs = _store_attributes(plan, schema)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays[name]

    def dataset(self, plan: _Plan, schema: Mapping[str, Any]) -> Any:
        """The Dataset a store of the same study opens as."""
        import xarray as xr

        variables = {}
        for name, spec in schema.items():
            extra = tuple(f"{name}_dim{i}" for i in range(len(spec["shape"])))
            variables[name] = (plan.dims + extra, self.arrays[name], _units(plan, name))
        for name in plan.distributions:
            variables[name] = (plan.dims, self.arrays[name], _units(plan, name))
        variables["status"] = (plan.dims, self.arrays["status"], _STATUS_ATTRIBUTES)
        coords = {d: (d, plan.coords[d], _units(plan, d)) for d in plan.dims}
        return xr.Dataset(variables, coords=coords, attrs=self.attrs)


_STATUS_ATTRIBUTES = {"flag_values": [-1, 0, 1], "flag_meanings": "not_computed done study_raised"}


def _compute_block(plan: _Plan, path: Any, index: tuple[int, ...], schema: Mapping[str, Any]) -> dict[str, Any]:
    """One task: the study on block ``index``, written into the store at its place (``path``, or a :class:`_Memory`),
    then marked done. A block on which the study raises is run member by member: the members it raises on get the
    status 1 and NaN outputs."""
    import zarr

    values = plan.values(index)
    where = plan.slices(index)
    shape = tuple(s.stop - s.start for s in where)
    m = math.prod(shape)
    threads = _threads_per_task()
    failures: dict[int, str] = {}
    try:
        outputs = _call(plan, values, threads)
    except Exception as exc:  # noqa: BLE001 - each member is tried alone; its error is kept with the data
        if isinstance(exc, InputError) and "Expected the study" in str(exc):
            raise
        outputs = {name: np.full((m, *spec["shape"]), _fill(np.dtype(spec["dtype"]))) for name, spec in schema.items()}
        for i in range(m):
            try:
                one = _call(plan, {k: v[i : i + 1] for k, v in values.items()}, threads)
            except Exception as err:  # noqa: BLE001
                failures[i] = f"{type(err).__name__}: {err}"
                continue
            for name in schema:
                outputs[name][i] = one[name][0]
    root: Any = zarr.open_group(path, mode="r+") if isinstance(path, str) else path
    for name in plan.distributions:  # the samples, beside the outputs
        root[name][where] = values[name]
    for name, spec in schema.items():
        arr = np.asarray(outputs[name], dtype=spec["dtype"]).reshape(shape + tuple(spec["shape"]))
        root[name][where] = arr
    status = np.zeros(m, dtype=np.int8)
    status[list(failures)] = 1
    root["status"][where] = status.reshape(shape)
    root["_done"][index] = 1
    return {"index": list(index), "failures": {str(k): v for k, v in failures.items()}}


# --------------------------------------------------------------------------------------------------
# the store and the run
# --------------------------------------------------------------------------------------------------
def _versions() -> dict[str, str]:
    return dict(_package_versions())


@functools.cache
def _package_versions() -> tuple[tuple[str, str], ...]:
    """Read once per process: the packages' metadata take tens of milliseconds to read, a compiled block less."""
    import importlib.metadata as md

    out = {"geomech": __version__, "python": platform.python_version()}
    for name in ("numpy", "scipy", "sympy", "numba", "xarray", "dask", "distributed", "zarr"):
        try:
            out[name] = md.version(name)
        except md.PackageNotFoundError:
            pass
    return tuple(out.items())


def _schema(plan: _Plan) -> dict[str, Any]:
    """The outputs' dtypes and trailing shapes, from the study on the first member."""
    first = tuple(0 for _ in plan.dims)
    values = {k: v[:1] for k, v in plan.values(first).items()}
    outputs = _call(plan, values, 1)
    bad = sorted(set(outputs) & (set(plan.dims) | {"status"} | set(plan.distributions)))
    if bad:
        raise InputError(f"The study's outputs {bad} have the names of parameters or of `status`; rename them.")
    return {name: {"dtype": arr.dtype.str, "shape": list(arr.shape[1:])} for name, arr in outputs.items()}


def _create(plan: _Plan, path: Path, schema: Mapping[str, Any]) -> None:
    import zarr

    root: Any = zarr.open_group(str(path), mode="w-", zarr_format=3)
    for d in plan.dims:
        root.create_array(d, data=plan.coords[d], dimension_names=(d,), attributes=_units(plan, d))
    for name, spec in schema.items():
        dtype = np.dtype(spec["dtype"])
        trailing = tuple(spec["shape"])
        extra = tuple(f"{name}_dim{i}" for i in range(len(trailing)))
        root.create_array(
            name,
            shape=plan.shape + trailing,
            chunks=plan.block + trailing,
            dtype=dtype,
            fill_value=_fill(dtype),
            dimension_names=plan.dims + extra,
            attributes=_units(plan, name),
        )
    for name in plan.distributions:
        root.create_array(
            name,
            shape=plan.shape,
            chunks=plan.block,
            dtype=float,
            fill_value=np.nan,
            dimension_names=plan.dims,
            attributes=_units(plan, name),
        )
    root.create_array(
        "status",
        shape=plan.shape,
        chunks=plan.block,
        dtype=np.int8,
        fill_value=-1,
        dimension_names=plan.dims,
        attributes=_STATUS_ATTRIBUTES,
    )
    # one marker per block, written after its data: what a resumption skips
    root.create_array(
        "_done",
        shape=plan.grid,
        chunks=tuple(1 for _ in plan.grid),
        dtype=np.int8,
        fill_value=0,
        dimension_names=tuple(f"_block_{d}" for d in plan.dims),
    )
    root.attrs.update(_store_attributes(plan, schema))


def _store_attributes(plan: _Plan, schema: Mapping[str, Any]) -> dict[str, Any]:
    """What identifies a study and its data: held by its store, and by the Dataset it returns."""
    return {
        "geomech_study": plan.identity,
        "geomech_fingerprint": plan.fingerprint,
        "geomech_schema": dict(schema),
        "provenance": _provenance(plan),
        "versions": _versions(),
    }


def _units(plan: _Plan, name: str) -> dict[str, Any]:
    return {"units": plan.units[name]} if name in plan.units else {}


def _provenance(plan: _Plan) -> str:
    ident = plan.identity
    args = f", fixed={plan.fixed!r}" if plan.fixed else ""
    if ident["kind"] == "sweep":
        swept = ", ".join(
            f"{d}=<{len(plan.coords[d])} values in [{plan.coords[d][0]:g}, {plan.coords[d][-1]:g}]>" for d in plan.dims
        )
        return f"geomech.sweep({ident['study'].get('function', '<study>')}, {swept}{args})"
    dist = ", ".join(f"{k}={tuple(v)!r}" for k, v in ident["distributions"].items())
    name = ident["study"].get("function", "<study>")
    return f"geomech.monte_carlo({name}, n={ident['n']}, seed={ident['seed']}, {dist}{args})"


def _open_existing(plan: _Plan, path: Path, resume: bool) -> Any:
    import zarr

    if not resume:
        raise InputError(
            f"The store {path} exists: pass resume=True (--resume) to continue the study in it, or remove it."
        )
    try:
        root = zarr.open_group(str(path), mode="r+")
        attrs = dict(root.attrs)
    except Exception as exc:  # noqa: BLE001 - any unreadable store is the same answer to the user
        raise InputError(f"The store {path} cannot be read as a geomech study ({exc}); remove it.") from None
    if attrs.get("geomech_fingerprint") != plan.fingerprint:
        held = attrs.get("provenance", "something else")
        raise InputError(
            f"The store {path} holds another study ({held}); resume it with the same arguments, or use another `out`."
        )
    return root


def _client(scheduler: Any) -> Any:
    if scheduler is None:
        return None
    from distributed import Client

    if isinstance(scheduler, Client):
        return scheduler
    if isinstance(scheduler, str):
        try:
            return Client(scheduler, timeout="10s", set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise InputError(f"Cannot reach the dask scheduler at {scheduler!r} ({exc}); check `scheduler`.") from None
    raise InputError(
        "Expected `scheduler` to be None, a dask.distributed Client or a scheduler address, got "
        f"{type(scheduler).__name__}."
    )


def _run(plan: _Plan, out: Any, resume: bool, scheduler: Any, progress: Callable[[int, int], None] | None):
    import xarray as xr
    import zarr

    if out is None:
        if resume:
            raise InputError("`resume` continues a study in its store: give `out`.")
        if scheduler is not None:
            raise InputError("A study on a cluster writes to `out`, a path every worker can reach: give it.")
        # no store: the blocks fill arrays in memory (the study's data are the same; nothing to resume)
        schema = _schema(plan)
        memory = _Memory(plan, schema)
        reports = _execute(plan, memory, _pending(memory["_done"]), schema, None, progress, 0, memory["_done"].size)
        memory.attrs.update(_failures(reports, {}))
        return _json_attributes(memory.dataset(plan, schema))
    path = Path(os.fspath(out)).expanduser().absolute()
    if path.exists():
        root = _open_existing(plan, path, resume)
        schema = dict(root.attrs["geomech_schema"])
    else:
        if not path.parent.is_dir():
            raise InputError(f"The directory of `out` ({path.parent}) does not exist; create it first.")
        schema = _schema(plan)
        _create(plan, path, schema)
        root = zarr.open_group(str(path), mode="r+")
    done = np.asarray(root["_done"][...])
    pending = _pending(done)
    reports = _execute(plan, str(path), pending, schema, scheduler, progress, done.size - len(pending), done.size)
    failures = _failures(reports, root.attrs)
    if failures:
        root.attrs.update(failures)
    # no dask arrays (zarr's, read as indexed): reading needs no scheduler, whose pool would not survive a fork
    ds = xr.open_zarr(str(path), consolidated=False, zarr_format=3, chunks=None).drop_vars("_done")
    return _json_attributes(ds)


def _pending(done: np.ndarray) -> list[tuple[int, ...]]:
    return [tuple(int(i) for i in ix) for ix in np.argwhere(done == 0)]


def _failures(reports: list[dict[str, Any]], attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The ``failures`` attribute with the members that raised in ``reports`` added (empty if none raised)."""
    failures = {}
    for report in reports:
        for i, message in report["failures"].items():
            failures[f"block {tuple(report['index'])} member {i}"] = message
    if not failures:
        return {}
    return {"failures": {**dict(attrs.get("failures", {})), **failures}}


def _json_attributes(ds: Any) -> Any:
    """Mappings as JSON text, so that the Dataset writes to NetCDF as it is."""
    return ds.assign_attrs(
        {k: json.dumps(v, sort_keys=True) for k, v in ds.attrs.items() if isinstance(v, (dict, list))}
    )


def _execute(
    plan: _Plan,
    path: Any,
    pending: list[tuple[int, ...]],
    schema: Mapping[str, Any],
    scheduler: Any,
    progress: Callable[[int, int], None] | None,
    already: int,
    total: int,
) -> list[dict[str, Any]]:
    """The pending blocks as dask tasks: on a cluster (as they complete, retried by dask where a worker is lost), or
    on dask's threaded scheduler over every core."""
    import dask

    if progress is not None:
        progress(already, total)
    if not pending:
        return []
    client = _client(scheduler)
    if client is not None:
        from distributed import as_completed

        futures = [
            client.submit(
                _compute_block,
                plan,
                path,
                index,
                schema,
                retries=2,
                key=f"geomech-block-{plan.fingerprint[:16]}-{'-'.join(map(str, index))}",
            )
            for index in pending
        ]
        reports = []
        try:
            for future in as_completed(futures):
                reports.append(future.result())
                if progress is not None:
                    progress(already + len(reports), total)
        except BaseException:
            client.cancel(futures)  # interrupted: the cluster stops this study's work (a resumption redoes it)
            raise
        finally:
            if isinstance(scheduler, str):
                client.close()
        return reports
    from dask.callbacks import Callback

    count = [already]

    class _Progress(Callback):
        def _posttask(self, key: Any, result: Any, dsk: Any, state: Any, worker_id: Any) -> None:
            if isinstance(result, dict) and "failures" in result and progress is not None:
                count[0] += 1
                progress(count[0], total)

    tasks = [dask.delayed(_compute_block, pure=False)(plan, path, index, schema) for index in pending]
    # a pool of our own, so that an interruption returns once the blocks in flight are written (or abandoned
    # whole): the store is settled when the study stops
    pool = ThreadPoolExecutor(os.cpu_count() or 1)
    try:
        with _Progress():
            reports = dask.compute(*tasks, scheduler="threads", pool=pool)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return list(reports)
