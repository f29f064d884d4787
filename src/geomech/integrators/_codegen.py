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
all models instead of once per model. The adaptive loops go further: they call the model's ``rhs`` through
the address of its C twin (``rhs_address()`` of the model module, a ``cfunc`` compiled on first use; the
address is a run-time integer, so the cache holds; :mod:`._fptr`), which makes them shared too: a new model
then compiles only its right-hand side for them. The model's parameters (inertias, gains, the
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
import os
import sys
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .._storage import cache_subdir, scratch_dir, write_atomic
from ..symbolic.compile import FunctionSpec, kernel_source

__all__ = ["FunctionSpec", "kernel_source", "compiled_module", "python_module", "numba_available", "cache_dir"]

_TEMPLATES = (
    "_k_common.py",
    "_k_explicit.py",
    "_k_implicit.py",
    "_k_canonical.py",
    "_k_liepoisson.py",
)
_PREAMBLE_START = "# >>> template preamble"
_PREAMBLE_END = "# <<< template preamble"
_LOCK = threading.Lock()
_MODULES: dict[str, Any] = {}


def numba_available() -> bool:
    """Whether numba can be imported (the compiled backend); without it the loops run as Python."""
    try:
        import numba  # noqa: F401
    except ImportError:  # pragma: no cover - numba is a dependency, kept optional for odd platforms
        return False
    return os.environ.get("NUMBA_DISABLE_JIT", "0") in ("", "0")


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
    ``rhs``), or calls a function that does; everything else (constants, helpers) is shared.
    """
    functions: dict[str, tuple[ast.FunctionDef, str]] = {}
    order: list[tuple[str, str]] = []  # (kind, text) in template order; kind is a function name or ""
    defined: set[str] = set()
    for _, text in _template_sources():
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
    known = defined | set(dir(builtins)) | {"math", "np", "kernel", "call_model"}
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


_HEADER_NUMBA = (
    "import math\nimport numpy as np\nimport numba\n"
    "from geomech.integrators._fptr import RHS_SIGNATURE, call_model\n\n"
    "kernel = numba.njit(cache=True, nogil=True, error_model='numpy')\n\n"
)
# The model's right-hand side as a C function for the loops shared by all models (geomech.integrators._fptr),
# compiled (or loaded from numba's cache) on first use only.
_RHS_C_DEFAULT = """

def _rhs_c(y, out, prm, d, n_prm):
    rhs(numba.carray(y, (d,)), numba.carray(out, (d,)), numba.carray(prm, (n_prm,)))
"""
_RHS_ADDRESS = """

_RHS_C = []


def rhs_ready():
    return bool(_RHS_C)


def rhs_address():
    if not _RHS_C:
        _RHS_C.append(numba.cfunc(RHS_SIGNATURE, cache=True)(_rhs_c))
    return _RHS_C[0].address
"""
_HEADER_PYTHON = "import math\nimport numpy as np\n\n\ndef kernel(f):\n    return f\n\n"


def _load(source: str, tag: str) -> Any:
    """Import the generated ``source`` (written once into the cache, named by its hash); caller holds _LOCK."""
    import numba

    digest = hashlib.sha256((numba.__version__ + source).encode()).hexdigest()[:24]
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
            # a model may write its C twin itself (the body on the pointers: one compilation instead of two)
            + ("" if "\ndef _rhs_c(" in "\n" + model_src else _RHS_C_DEFAULT)
            + _RHS_ADDRESS
        )
        return _load(source, tag)


class _Namespace:
    def __init__(self, mapping: Mapping[str, Any]):
        self.__dict__.update(mapping)


def python_module(functions: Mapping[str, Any]) -> Any:
    """The loop templates as plain Python, calling the model ``functions`` (name -> callable)."""
    namespace: dict[str, Any] = {"__name__": "geomech_kernels_python"}
    exec(compile(_HEADER_PYTHON, "<geomech kernels>", "exec"), namespace)
    namespace.update(functions)

    def call_model(fp: Any, y: Any, out: Any, prm: Any) -> None:  # the Python twin: fp is not an address here
        namespace["rhs"](y, out, prm)

    namespace["call_model"] = call_model
    namespace["rhs_address"] = lambda: 0
    namespace["rhs_ready"] = lambda: True
    exec(compile(_template_text(), "<geomech kernels>", "exec"), namespace)
    return _Namespace(namespace)
