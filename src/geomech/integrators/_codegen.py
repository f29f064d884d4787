"""Compile symbolic models and the integrator loops into one numba module, cached on disk.

The integrator loops are written once, as plain Python in the template modules ``_k_*.py``, calling the
model through a few fixed names (``rhs``, ``fjac``, ``grad``, ...). For a model given by a formula the
symbolic layer prints those functions from sympy (:func:`geomech.symbolic.compile.kernel_source`: common
subexpressions shared, floats printed to round-trip); this module writes model and templates together
into one source file named by a hash of its text, imports it, and lets numba compile each loop with
``cache=True``: a later run, or another process, loads the machine code from disk. Passing compiled model
functions to compiled loops as arguments would defeat numba's disk cache (the function type differs in
every process), hence one generated file per model. The loop helpers that never call the model (status
codes, saving, Newton updates, small solves, rotations) are split off, by reading the templates' syntax
trees, into one shared generated module that every model module imports: numba compiles them once for
all models instead of once per model. The loops go further: they call the model's functions through the
addresses of their C twins (``addresses(names)`` of the model module, each a ``cfunc`` compiled on first use;
an address is a run-time integer, so the cache holds; :mod:`._fptr`), which makes them shared too: a new model
then compiles only its functions. Two loops keep calling the model by name, compiled per model, for speed: the
Lie-Poisson splitting (its scalar derivatives inlined in the throughput loop) and symplectic Euler (the
compiler drops the parts of the Hessian a variant does not read). The model's parameters (inertias, gains, the
momentum G of a reduced system) are not written into it: the functions read them from an array ``prm``
at run time, so a sweep over parameter values compiles once.

Without numba, or for a model given as Python callables, the same template source runs as plain Python
with wrappers around the callables (slow but identical arithmetic), so every method works everywhere.
"""

from __future__ import annotations

import ast
import builtins
import functools
import hashlib
import importlib.util
import json
import os
import sys
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._storage import cache_subdir, scratch_dir, write_atomic
from ..symbolic.compile import FunctionSpec, kernel_source
from ._deferred import Pending
from ._k_common import MODEL_ARRAYS, MODEL_FUNCTIONS

__all__ = [
    "FunctionSpec",
    "RHS",
    "cache_dir",
    "compiled_module",
    "kernel_source",
    "model_functions",
    "numba_available",
    "python_header",
    "python_helpers",
    "python_module",
    "rhs_address",
    "template_module",
]

_TEMPLATES = (
    "_k_common.py",
    "_k_explicit.py",
    "_k_embedded.py",
    "_k_implicit.py",
    "_k_canonical.py",
    "_k_liepoisson.py",
    "_k_taylor.py",
    "_k_groups.py",
)
_PREAMBLE_START = "# >>> template preamble"
_PREAMBLE_END = "# <<< template preamble"
_LOCK = threading.Lock()
_MODULES: dict[str, Any] = {}
_BY_MODEL: dict[tuple[str, str], Any] = {}


def numba_available() -> bool:
    """Whether numba is installed (the compiled backend), and not disabled by NUMBA_DISABLE_JIT; without it the
    loops run as Python. Asked without importing numba (a model whose loops load as machine code of their own
    never imports it, :mod:`._deferred`); known once asked, as numba reads NUMBA_DISABLE_JIT once, at its import."""
    global _NUMBA
    if _NUMBA is None:
        if _numba_version() is None:  # pragma: no cover - numba is a dependency, kept optional for odd platforms
            return False
        _NUMBA = os.environ.get("NUMBA_DISABLE_JIT", "0") in ("", "0")
    return _NUMBA


_NUMBA: bool | None = None


@functools.cache
def _numba_version() -> str | None:
    """numba's version, read from its installed metadata (None where it is not installed)."""
    if "numba" in sys.modules:
        return str(sys.modules["numba"].__version__)
    import importlib.metadata

    try:
        return importlib.metadata.version("numba")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover - see numba_available
        return None


def cache_dir() -> Path:
    """Directory of the generated kernel sources (and numba's cache of their machine code): ``kernels`` in
    the cache (:mod:`geomech._storage`), or, with the cache disabled or not private, this process's scratch
    directory (kernels then compile anew in each process)."""
    directory = cache_subdir("kernels")
    if directory is None:
        directory = scratch_dir() / "kernels"
        directory.mkdir(exist_ok=True)
    return directory


def _template_text() -> str:
    return "\n\n".join(f"# ---- {name} ----\n" + text for name, text in _template_sources())


def _template_sources() -> list[tuple[str, str]]:
    """Each template's text without its preamble."""
    here = Path(__file__).parent
    sources = []
    for name in _TEMPLATES:
        text = (here / name).read_text()
        start, end = text.index(_PREAMBLE_START), text.index(_PREAMBLE_END)
        end = text.index("\n", end) + 1
        sources.append((name, text[:start] + text[end:]))
    return sources


@functools.cache
def _template_split() -> tuple[str, str, tuple[str, ...]]:
    """The templates split into (shared source, per-model source, names the shared source defines).

    A function belongs to the model when it reads a name no template defines (a model function such as
    ``rhs``), or calls a function that does; everything else (constants, helpers) is shared. Reading the syntax
    trees takes a tenth of a second: the split is kept beside the kernels, named by a hash of the templates' text.
    """
    sources = _template_sources()
    digest = hashlib.sha256("\0".join(text for _, text in sources).encode()).hexdigest()[:24]
    path = cache_dir() / f"split_{digest}.json"
    try:
        shared, model, names = json.loads(path.read_text())
        if isinstance(shared, str) and isinstance(model, str) and all(isinstance(n, str) for n in names):
            return shared, model, tuple(names)
    except (OSError, ValueError, TypeError):  # not there yet, or unreadable: computed again, and written
        pass
    split = _split_sources(sources)
    write_atomic(path, json.dumps(split))
    return split


def _split_sources(sources: list[tuple[str, str]]) -> tuple[str, str, tuple[str, ...]]:
    """:func:`_template_split` from the templates' text."""
    functions: dict[str, tuple[ast.FunctionDef, str]] = {}
    order: list[tuple[str, str]] = []  # (kind, text) in template order; kind is a function name or ""
    defined: set[str] = set()
    for _, text in sources:
        lines = text.splitlines()
        for node in ast.parse(text).body:
            first = min([node.lineno] + [d.lineno for d in getattr(node, "decorator_list", [])])
            segment = "\n".join(lines[first - 1 : node.end_lineno])
            if isinstance(node, ast.FunctionDef):
                functions[node.name] = (node, segment)
                order.append((node.name, segment))
                defined.add(node.name)
            elif isinstance(node, ast.Assign):
                defined.update(t.id for t in node.targets if isinstance(t, ast.Name))
                order.append(("", segment))
    known = (
        defined
        | set(dir(builtins))
        | {"math", "np", "kernel", "inlined", "call_model", "call_model4", "call_model6", "borrowed", "kept", "shaped"}
    )
    reads = {
        name: {n.id for n in ast.walk(node) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}
        - {n.id for n in ast.walk(node) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}
        - {a.arg for a in node.args.args}
        for name, (node, _) in functions.items()
    }
    per_model = {name for name, used in reads.items() if used - known}
    while True:
        more = {name for name, used in reads.items() if used & per_model} - per_model
        if not more:
            break
        per_model |= more
    shared = [text for kind, text in order if kind not in per_model]
    model = [text for kind, text in order if kind in per_model]
    names = tuple(sorted(defined - per_model))
    return "\n\n\n".join(shared) + "\n", "\n\n\n".join(model) + "\n", names


# numba's names bound at the module's first use of numba (geomech.integrators._deferred): importing the module
# imports no numba
_HEADER_NUMBA = (
    "import math\nimport numpy as np\nfrom geomech.integrators._deferred import Deferred\n"
    "from geomech.integrators._native import Addresses\n\n"
    "_DEFERRED = Deferred(globals())\nnumba = _DEFERRED.numba\n"
    "borrowed, call_model, call_model4, call_model6, kept, shaped = _DEFERRED.intrinsics()\n"
    "kernel = _DEFERRED.kernel(cache=True, nogil=True, error_model='numpy')\n"
    "inlined = _DEFERRED.kernel(cache=True, nogil=True, error_model='numpy', inline='always')\n\n"
)
# The model functions' addresses for the loops shared by all models (geomech.integrators._fptr): each C twin is
# loaded as code of its own (geomech.integrators._native) or compiled by numba, on first request only.
_ADDRESSES = """

_ADDRESSES = Addresses(globals())
addresses = _ADDRESSES
ready = _ADDRESSES.ready
"""
_HEADER_PYTHON = (
    "import math\nimport numpy as np\n\n\ndef kernel(f):\n    return f\n\n\ninlined = kernel\n\n\n"
    "def borrowed(a):\n    return a\n\n\ndef kept(arrays):\n    return None\n\n\n"
    "def shaped(buf, start, shape):\n    return buf[start : start + int(np.prod(shape))].reshape(shape)\n\n"
)


def _load(source: str, tag: str) -> Any:
    """Import the generated ``source`` (written once into the cache, named by its hash); caller holds _LOCK."""
    digest = hashlib.sha256((str(_numba_version()) + source).encode()).hexdigest()[:24]
    if digest in _MODULES:
        return _MODULES[digest]
    path = cache_dir() / f"gm_{tag}_{digest}.py"
    if not path.exists() or path.read_text() != source:
        write_atomic(path, source)  # concurrent processes never import a half-written file
    name = f"geomech_kernels_{tag}_{digest}"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None  # always set for a ``.py`` file location
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _MODULES[digest] = module
    return module


def compiled_module(model_src: str, tag: str) -> Any:
    """Import (generating once) the numba module made of ``model_src`` and the loop templates.

    The model-independent helpers live in one shared module (``gm_k_*``) that the model module imports.
    Kept in memory for the process; the generated files and numba's cache persist across runs.
    """
    known = _BY_MODEL.get((tag, model_src))
    if known is not None:  # the source built, hashed and imported once per model and process
        return known
    shared_src, model_part, names = _template_split()
    with _LOCK:
        shared = _load(_HEADER_NUMBA + shared_src, "k")
        imports = "".join(f"{name} = _shared.{name}\n" for name in names)
        source = (
            _HEADER_NUMBA
            + f"import {shared.__name__} as _shared\n\n{imports}\n\n"
            + model_src
            + "\n\n"
            + model_part
            + _twins(model_src)
            + _ADDRESSES
        )
        module = _load(source, tag)
        _BY_MODEL[(tag, model_src)] = module
        return module


def template_module(path: Path, tag: str) -> Any:
    """Import (generating once) the numba module of a kernel template outside the integrator loops (``path``, with
    a preamble like theirs): compiled after the loops' shared helpers (status codes, the model functions' indices
    ``F_*``, ``call_model4``), it calls a model's functions through their addresses, so that it compiles once for
    every model. Kept in memory for the process; the generated file and numba's cache persist across runs."""
    text = path.read_text()
    start, end = text.index(_PREAMBLE_START), text.index(_PREAMBLE_END)
    body = text[:start] + text[text.index("\n", end) + 1 :]
    known = _BY_MODEL.get((tag, body))
    if known is not None:
        return known
    shared_src, _, names = _template_split()
    with _LOCK:
        shared = _load(_HEADER_NUMBA + shared_src, "k")
        imports = "".join(f"{name} = _shared.{name}\n" for name in names)
        module = _load(_HEADER_NUMBA + f"import {shared.__name__} as _shared\n\n{imports}\n\n" + body, tag)
        _BY_MODEL[(tag, body)] = module
        return module


def _twin_source(name: str) -> str:
    """Source of ``_{name}_c``: the model function ``name`` on the pointers of its C signature (:mod:`._fptr`)."""
    ndims = MODEL_ARRAYS[name]
    args = [f"a{i}" for i in range(len(ndims))]
    views = [f"numba.carray({a}, (d,{' d' if k == 2 else ''}))" for a, k in zip(args, ndims)]
    return (
        f"def _{name}_c({', '.join(args)}, prm, d, n_prm):\n"
        f"    {name}({', '.join(views)}, numba.carray(prm, (n_prm,)))\n"
    )


def _missing_source(name: str) -> str:
    """Source of ``_{name}_c`` for a model without ``name``: its outputs (every array but the first) set to NaN, so
    that a loop that called it would report a non-finite state instead of reading garbage."""
    ndims = MODEL_ARRAYS[name]
    args = [f"a{i}" for i in range(len(ndims))]
    fills = [f"    numba.carray({a}, ({'d * d' if k == 2 else 'd'},))[:] = math.nan\n" for a, k in zip(args, ndims)]
    return f"def _{name}_c({', '.join(args)}, prm, d, n_prm):\n" + "".join(fills[1:])


def _twins(model_src: str) -> str:
    """The C twins of the model functions (:mod:`._fptr`): of those ``model_src`` defines, except those it writes
    itself (BKMM writes its right-hand side's body on the pointers: one compilation instead of two), and a NaN
    filler for the others."""
    text = "\n" + model_src
    return "".join(
        "\n\n" + (_twin_source(name) if f"\ndef {name}(" in text else _missing_source(name))
        for name in MODEL_FUNCTIONS
        if f"\ndef _{name}_c(" not in text
    )


#: The model functions of a loop that calls only the right-hand side.
RHS = ("rhs",)


#: The kernels with machine code in this process (compiled, or loaded from numba's disk cache).
_LOADED: set = set()


def loaded(function: Any) -> bool:
    """Whether the kernel ``function`` (a numba dispatcher) has machine code in this process: compiled, or loaded
    from the disk cache, by an earlier call. Remembered once true (numba's ``signatures`` builds a list at every
    call of a run). A kernel of a module not bound to numba yet (:class:`._deferred.Pending`) has none."""
    if function in _LOADED:
        return True
    if isinstance(function, Pending) and function.real is None:
        return False
    if function.signatures:
        _LOADED.add(function)
        return True
    return False


def on_disk(function: Any) -> bool:
    """Whether numba's disk cache holds machine code of the kernel ``function`` (a dispatcher with ``cache=True``):
    loading it costs milliseconds where compiling it costs seconds. False where it cannot tell (no cache, another
    numba's internals), or where its module has not been bound to numba (:mod:`._deferred`: asking would import
    numba, which a model loaded as machine code of its own never needs)."""
    if isinstance(function, Pending) and function.real is None:
        return False
    try:
        return os.path.exists(function._cache._cache_file._index_path)
    except AttributeError:
        return False


def rhs_address(module: Any) -> int:
    """The address of ``module``'s right-hand side for :func:`._fptr.call_model` (its C twin compiled, or loaded
    from numba's cache, on first request; for the Python backend, its index)."""
    return int(module.addresses(RHS)[MODEL_FUNCTIONS.index("rhs")])


@functools.cache
def model_functions(loop: str) -> tuple[str, ...]:
    """The model functions the template function ``loop`` calls through its addresses (``FP[F_...]``), directly
    or through the functions it calls."""
    functions = {
        node.name: node
        for _, text in _template_sources()
        for node in ast.parse(text).body
        if isinstance(node, ast.FunctionDef)
    }
    index = {f"F_{name.upper()}": name for name in MODEL_FUNCTIONS}
    seen: set[str] = set()
    found: set[str] = set()
    todo = [loop]
    while todo:
        name = todo.pop()
        if name in seen or name not in functions:
            continue
        seen.add(name)
        for node in ast.walk(functions[name]):
            if isinstance(node, ast.Name):
                if node.id in index:
                    found.add(index[node.id])
                elif node.id in functions:
                    todo.append(node.id)
    return tuple(name for name in MODEL_FUNCTIONS if name in found)


@functools.cache
def python_helpers() -> dict[str, Any]:
    """The loops' shared helpers (status codes, small solves, ...) as plain Python, for generated source run without
    numba."""
    shared_src, _, names = _template_split()
    namespace: dict[str, Any] = {}
    exec(compile(_HEADER_PYTHON + shared_src, "<geomech helpers>", "exec"), namespace)
    return {name: namespace[name] for name in names}


def python_header() -> str:
    """The header of generated source run as plain Python (``kernel`` the identity)."""
    return _HEADER_PYTHON


class _Namespace:
    def __init__(self, mapping: Mapping[str, Any]):
        self.__dict__.update(mapping)


def python_module(functions: Mapping[str, Any]) -> Any:
    """The loop templates as plain Python, calling the model ``functions`` (name -> callable)."""
    namespace: dict[str, Any] = {"__name__": "geomech_kernels_python"}
    exec(compile(_HEADER_PYTHON, "<geomech kernels>", "exec"), namespace)
    namespace.update(functions)

    def call_model(fp: Any, *args: Any) -> None:  # the Python twin: fp is the function's index, not an address
        namespace[MODEL_FUNCTIONS[int(fp)]](*args)

    def addresses(names: tuple[str, ...]) -> np.ndarray:
        return np.arange(len(MODEL_FUNCTIONS), dtype=np.int64)

    namespace.update(call_model=call_model, call_model4=call_model, call_model6=call_model)
    namespace.update(addresses=addresses, ready=lambda names: True)
    exec(compile(_template_text(), "<geomech kernels>", "exec"), namespace)
    return _Namespace(namespace)
