"""Where geomech keeps things: its one on-disk cache, a private scratch directory, atomic output files, and the
bounded in-memory memos (:func:`remember`).

The cache (derivations pickled by the symbolic layer, generated kernel modules and numba's machine code)
lives under one root, read from one place:

- ``$GEOMECH_CACHE_DIR`` if set; ``off``, ``0``, ``none``, ``false`` or an empty value disable the cache;
- else ``$XDG_CACHE_HOME/geomech``, else ``~/.cache/geomech``.

What is read back from the cache is executed (kernel modules are imported, derivations unpickled), so a
directory is used only if it belongs to the current user and nobody else can write to it; otherwise geomech
works without it (kernels are generated in a private scratch directory, derivations are recomputed). The
scratch directory is made by :func:`tempfile.mkdtemp` (mode 0700, an unpredictable name) and removed when
the process exits.
"""

from __future__ import annotations

import atexit
import os
import shutil
import stat
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

__all__ = [
    "remember",
    "cache_root",
    "cache_subdir",
    "scratch_dir",
    "write_atomic",
    "atomic_path",
    "check_output_dir",
    "write_set",
    "dumps_json",
]

_OFF = {"", "0", "off", "none", "false", "no"}
_LOCK = threading.Lock()
_SCRATCH: Path | None = None


_MEMO_LOCK = threading.Lock()


def remember(store: Any, key: Any, value: Any, limit: int) -> Any:
    """Keep ``value`` under ``key`` in the in-memory memo ``store`` (a dict, in the order of insertion), the oldest
    entries dropped first so that it holds at most ``limit``; safe where threads share the store (a solve's prepared
    problem, a study's tasks). Returns ``value``."""
    with _MEMO_LOCK:
        store.pop(key, None)
        while len(store) >= limit:
            store.pop(next(iter(store)))
        store[key] = value
    return value


def cache_root() -> Path | None:
    """The configured cache directory (not created here), or ``None`` when the cache is disabled."""
    env = os.environ.get("GEOMECH_CACHE_DIR")
    if env is not None:
        if env.strip().lower() in _OFF:
            return None
        return Path(env).expanduser().absolute()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser().absolute() / "geomech"


def _private(path: Path) -> bool:
    """``path`` is a directory of this user that no other user can write to."""
    try:
        st = path.stat()
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode):
        return False
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return False
    return not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def cache_subdir(name: str) -> Path | None:
    """``cache_root()/name``, created (mode 0700) if needed; ``None`` if the cache is disabled, cannot be
    created or written, or is not private to this user."""
    root = cache_root()
    if root is None:
        return None
    path = root / name
    try:
        path.mkdir(parents=True, exist_ok=True, mode=0o700)
        if not (_private(path) and os.access(path, os.W_OK | os.X_OK)):
            return None
    except OSError:
        return None
    return path


def scratch_dir() -> Path:
    """This process's private temporary directory (made once, removed at exit)."""
    global _SCRATCH
    with _LOCK:
        if _SCRATCH is None or not _SCRATCH.is_dir():
            _SCRATCH = Path(tempfile.mkdtemp(prefix="geomech-"))
            atexit.register(shutil.rmtree, _SCRATCH, True)
        return _SCRATCH


def write_atomic(
    path: str | Path, data: bytes | str | Callable[[IO[Any]], None], *, binary: bool | None = None
) -> Path:
    """Write ``path`` completely or not at all: into a temporary file in the same directory, renamed over
    ``path`` when done. ``data`` is bytes, text, or a function that writes to the open file."""
    path = Path(path)
    if binary is None:
        binary = isinstance(data, (bytes, bytearray)) or callable(data)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb" if binary else "w") as fh:
            if callable(data):
                data(fh)
            else:
                fh.write(data)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


class atomic_path:
    """A context manager giving a temporary path beside ``path`` for a writer that takes a file name
    (``savefig``, ``to_netcdf``); renamed to ``path`` on success, removed on failure.

    >>> with atomic_path(out / "map.png") as tmp:   # doctest: +SKIP
    ...     fig.savefig(tmp)
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.tmp: Path | None = None

    def __enter__(self) -> Path:
        fd, tmp = tempfile.mkstemp(dir=self.path.parent, prefix=f".{self.path.stem}.", suffix=self.path.suffix)
        os.close(fd)
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        assert self.tmp is not None
        if exc_type is None:
            os.chmod(self.tmp, 0o666 & ~_umask())
            os.replace(self.tmp, self.path)
        else:
            self.tmp.unlink(missing_ok=True)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_output_dir(out: str | Path, option: str = "--out") -> Path:
    """Check, before any work, that ``out`` can be made a directory to write into (nothing is created).

    Raises :class:`~geomech.errors.InputError` naming ``option`` for an empty path, an existing file, or a
    place this user cannot write to.
    """
    from .errors import InputError

    text = str(out)
    if not text.strip():
        raise InputError(f"`{option}` is empty; give a directory, e.g. {option} results.")

    def refuse(reason: str) -> InputError:
        return InputError(f"Cannot write into `{option}` {text!r}: {reason}.")

    path = Path(text).expanduser().absolute()
    probe = path
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if probe == path and not path.is_dir():
        raise refuse("it is a file, not a directory")
    if not probe.is_dir():
        raise refuse(f"{str(probe)!r} is a file")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise refuse(f"no permission to write in {str(probe)!r}; choose another directory")
    try:  # what access() cannot tell (a read-only or special file system): a file made and removed at once
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError as exc:
        raise refuse(f"{str(probe)!r} does not take new files ({exc.strerror or exc})") from None
    return path


def write_set(out: str | Path, writers: dict[str, Callable[[Path], Any]]) -> list[Path]:
    """Write a set of files into ``out``, all or nothing.

    Each ``writers[name](path)`` writes one file to a temporary path in ``out``; only when every one has
    succeeded are they renamed into place (with Ctrl-C held back for those few renames), so an interrupted
    or failed run leaves the previous files, never a mixed set. A directory made here and left empty by a
    failure is removed.
    """
    import signal

    from .errors import InputError

    out = Path(out)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"Cannot write into {str(out)!r}: {exc.strerror or exc}.") from None
    staged: dict[Path, Path] = {}
    try:
        for name, write in writers.items():
            target = out / name
            fd, tmp_name = tempfile.mkstemp(dir=out, prefix=f".{target.stem}.", suffix=f".partial{target.suffix}")
            os.close(fd)
            staged[Path(tmp_name)] = target
            write(Path(tmp_name))
        mask = 0o666 & ~_umask()
        held: list[Any] = []
        in_main = threading.current_thread() is threading.main_thread()
        previous = signal.getsignal(signal.SIGINT) if in_main else None
        if in_main:
            signal.signal(signal.SIGINT, lambda *a: held.append(a))
        try:
            for tmp, target in staged.items():
                os.chmod(tmp, mask)
                os.replace(tmp, target)
        finally:
            if in_main:
                signal.signal(signal.SIGINT, signal.default_int_handler if previous is None else previous)
        if held:
            raise KeyboardInterrupt
    finally:
        for tmp in staged:
            tmp.unlink(missing_ok=True)
        if created:
            try:
                out.rmdir()  # only succeeds if nothing was written
            except OSError:
                pass
    return list(staged.values())


def _nonfinite_paths(obj: Any, path: str = "") -> list[str]:
    import math

    if isinstance(obj, float):
        return [] if math.isfinite(obj) else [path or "(the value)"]
    if isinstance(obj, dict):
        return [p for k, v in obj.items() for p in _nonfinite_paths(v, f"{path}.{k}" if path else str(k))]
    if isinstance(obj, (list, tuple)):
        return [p for i, v in enumerate(obj) for p in _nonfinite_paths(v, f"{path}[{i}]")]
    return []


def dumps_json(obj: Any, indent: int | None = 2) -> str:
    """JSON text of ``obj``; a NaN or an infinity (which JSON cannot hold) is a
    :class:`~geomech.errors.NumericalError` naming where in the result it is."""
    import json

    import numpy as np

    def default(o: Any) -> Any:
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, Path):
            return str(o)
        raise TypeError(f"Object of type {type(o).__name__} is not JSON serializable")

    try:
        return json.dumps(obj, indent=indent, allow_nan=False, default=default)
    except ValueError:
        from .errors import NumericalError

        plain = json.loads(json.dumps(obj, default=default))
        where = _nonfinite_paths(plain)
        shown = ", ".join(where[:5]) + (f" and {len(where) - 5} more" if len(where) > 5 else "")
        raise NumericalError(
            f"The result is not finite (NaN or inf) at {shown}; the computation failed there "
            "(check the inputs' ranges, or reduce the step or the time span)."
        ) from None
