"""The cache of derived symbolic objects: in memory (shared by every object with the same symbolic content, so
systems that differ only in parameter values share all symbolic work) and on disk (shared by processes, under
the one cache root of :mod:`geomech._storage`), with the compiled numeric functions of a set of parameter
values."""

from __future__ import annotations

import hashlib
import pickle
from collections.abc import Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import sympy as sp

from .._storage import cache_subdir, write_atomic
from .compile import compile_matrix

__all__ = ["DiskCache", "DISK_CACHE", "MISSING", "NumericCache", "cache_dir", "shared_property", "shared_value"]

#: Derived symbolic objects and compiled kernels, shared by every object with the same symbolic content
#: (``_cache_key``): systems that differ only in their parameter values share all symbolic work.
_SHARED: dict = {}

#: Bump when the layout of cached entries changes.
_CACHE_FORMAT = "2"
#: The modules whose code determines the derived objects: their source is part of every on-disk key, so that an
#: edited derivation never reads results of the code before it.
_SOURCES = (
    "reduction/nonholonomic.py",
    "reduction/lagrange_dalembert.py",
    "reduction/_derived.py",
    "reduction/almost_poisson.py",
    "symbolic/simplify.py",
    "symbolic/cache.py",
    "symbolic/charts.py",
    "systems/nonholonomic.py",
    "systems/_invariance.py",
)


def cache_dir() -> Path | None:
    """Directory of the derivation cache: ``derivations`` in the cache (:mod:`geomech._storage`:
    ``$GEOMECH_CACHE_DIR``, else ``$XDG_CACHE_HOME/geomech``, else ``~/.cache/geomech``); ``None`` (no disk
    cache) when ``GEOMECH_CACHE_DIR`` is ``off``, ``0`` or empty, or the directory is not private."""
    return cache_subdir("derivations")


@lru_cache(maxsize=1)
def _code_fingerprint() -> str:
    from .. import __version__

    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256(f"geomech {__version__} sympy {sp.__version__} format {_CACHE_FORMAT}".encode())
    for rel in _SOURCES:
        try:
            h.update((root / rel).read_bytes())
        except OSError:
            h.update(rel.encode())
    return h.hexdigest()


class DiskCache:
    """Pickled symbolic results under :func:`cache_dir`, one file per derived object.

    A file's name hashes the system's symbolic content (``system.key``, printed with ``srepr``: exact, and the
    same in every process), the object's own key, the geomech and sympy versions and the source of the
    derivation modules. A file that cannot be read or unpickled (truncated, corrupted, from an incompatible
    version) is ignored and rewritten; writes go to a temporary file that is renamed, so a reader never sees a
    partial file. Failing to write (read-only home, full disk) only costs the next process the derivation.
    """

    def __init__(self) -> None:
        self.hits = 0
        self.misses = 0

    def path(self, system_key: Any, key: Any) -> Path | None:
        root = cache_dir()
        if root is None:
            return None
        h = hashlib.sha256(_code_fingerprint().encode())
        h.update(key_text(system_key).encode())
        h.update(b"\0")
        h.update(key_text(key).encode())
        digest = h.hexdigest()
        return root / digest[:2] / f"{digest}.pkl"

    def load(self, system_key: Any, key: Any) -> Any:
        """The stored value, or :data:`MISSING`."""
        path = self.path(system_key, key)
        if path is None or not path.is_file():
            self.misses += 1
            return MISSING
        try:
            with path.open("rb") as fh:
                stored_key, value = pickle.load(fh)
            if stored_key != _key_digest(key):
                raise ValueError("key mismatch")
        except Exception:  # a damaged or foreign file: recompute (and overwrite) rather than fail
            self.misses += 1
            return MISSING
        self.hits += 1
        return value

    def save(self, system_key: Any, key: Any, value: Any) -> None:
        path = self.path(system_key, key)
        if path is None:
            return
        try:
            data = pickle.dumps((_key_digest(key), value), protocol=pickle.HIGHEST_PROTOCOL)
            path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
            write_atomic(path, data)
        except (OSError, pickle.PicklingError, TypeError, AttributeError, RecursionError):
            pass


#: The text of each key's parts (srepr), by part: a derivation's keys all hold the system's symbolic content
#: (120,000 characters for the three-link chain, a tenth of a second to print) and its derived matrices, and every
#: look-up of the disk cache printed them again.
_TEXT: dict = {}
_TEXT_LIMIT = 4096


def key_text(key: Any) -> str:
    """``key`` printed exactly (sympy's ``srepr`` of each part: the same text in every process), a tuple's parts
    printed once per process."""
    if isinstance(key, tuple):
        return "(" + ", ".join(key_text(part) for part in key) + ("," if len(key) == 1 else "") + ")"
    try:
        return _TEXT[(type(key), key)]
    except KeyError:
        pass
    except TypeError:  # unhashable: printed every time
        return sp.srepr(key)
    text = sp.srepr(key)
    if len(_TEXT) >= _TEXT_LIMIT:
        _TEXT.clear()
    _TEXT[(type(key), key)] = text
    return text


def _key_digest(key: Any) -> str:
    """What a stored entry keeps of its key: the digest of its text (a check against a file renamed or damaged)."""
    return hashlib.sha256(key_text(key).encode()).hexdigest()


MISSING = object()
#: The process-wide on-disk cache of derived symbolic objects.
DISK_CACHE = DiskCache()


def shared_value(obj: Any, name: str, compute: Any, extra: Any = ()) -> Any:
    """The derived object ``name`` of ``obj``: from memory (shared by every object with the same ``_cache_key``),
    else from the disk cache, else ``compute()`` (then stored in both)."""
    key = (type(obj).__name__, obj._cache_key, name) + ((extra,) if extra != () else ())
    try:
        return _SHARED[key]
    except KeyError:
        pass
    system_key = obj.system.key
    value = DISK_CACHE.load(system_key, key)
    if value is MISSING:
        value = compute()
        DISK_CACHE.save(system_key, key, value)
    _SHARED[key] = value
    return value


class shared_property:
    """Like ``functools.cached_property``, but stored under the owner's ``_cache_key`` (its symbolic content), so
    that a derivation done for one object is reused by every equivalent one, in this process (memory) and in
    later ones (:class:`DiskCache`)."""

    def __init__(self, func: Any):
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return shared_value(obj, self.name, lambda: self.func(obj))


class NumericCache:
    """Compile expressions with the parameter values substituted, once per set of values (shared store)."""

    system: Any

    if TYPE_CHECKING:

        @property
        def _cache_key(self) -> Any:
            """The symbolic content of the owner, provided by every subclass."""

    def _compile(self, values: Mapping[str, float] | None, exprs: dict, variables: Sequence[sp.Symbol]) -> dict:
        pv = self.system.parameter_values(values)
        key = (
            type(self).__name__,
            self._cache_key,
            "compiled",
            tuple(sorted((s.name, v) for s, v in pv.items())),
            tuple(exprs),
            tuple(variables),
        )
        cache = _SHARED
        if key not in cache:
            out = {}
            for name, e in exprs.items():
                e = sp.Matrix(e) if isinstance(e, (sp.MatrixBase, list, tuple)) else sp.Matrix([e])
                # xreplace, not subs: the same expression with the values in, several times faster on large
                # fields (subs re-evaluates and re-matches every node for each parameter)
                out[name] = compile_matrix(e.xreplace({s: sp.Float(v) for s, v in pv.items()}), variables)
            cache[key] = out
        return cache[key]
