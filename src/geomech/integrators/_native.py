"""Compiled loops as machine code of their own: loaded and called without numba.

numba caches a loop's machine code on disk, but loading it back costs a process numba's import and the
initialisation of its CPU target (about 0.3 s, most of a compiled model's load from a warm cache). This module
keeps, beside numba's cache, an object file of the loop that needs neither: a C entry ``int64 entry(void **P,
int64 *S, double *F)`` compiled by numba around the loop (each array argument ``P[i]`` with its shape in ``S``,
each integer in ``S``, each float in ``F``; the loop's integer result returned), whose module LLVM emits as an
object file once numba's few run-time helpers it declares are defined in it:

- ``numba_gil_ensure`` and ``numba_gil_release`` (its error path takes the GIL), as numba defines them (by
  ``PyGILState_Ensure`` and ``PyGILState_Release``);
- numba's allocator, for the arrays a loop makes (``np.empty`` and the like): ``NRT_MemInfo_alloc``,
  ``NRT_MemInfo_alloc_aligned`` (one ``malloc`` for numba's ``MemInfo`` record, its reference count 1 and no
  destructor, and the data after it, aligned as asked), ``NRT_MemInfo_call_dtor`` (the release of an array whose
  last reference went: ``free``), ``NRT_Allocate`` and ``NRT_Free``; numba's compiled code counts the references
  itself and reads the record's fields (count, data) at numba's offsets, which the record written here keeps. The
  arrays a loop receives have no owner (the entry makes them on the caller's data), so every record a loop
  releases is one of these. A loop that asks for any other part of numba's run time (its lists, its random
  generator, its statistics) is refused.

Every other symbol the object leaves undefined must resolve in this process (the C and math libraries, Python's C
API), read from the object's symbol table (ELF: Linux) before it is written; where one does not, or the platform's
objects are not ELF, the loop runs through numba as before. The object loads by llvmlite (LLVM's MCJIT), whose
import and target take milliseconds, and is called by ctypes, which releases the GIL for the call. The file is
named by the loop's generated module (its source and numba's version), the loop, the arguments' kinds, this
module's source, llvmlite's version and the host CPU. :mod:`._taylor_llvm`'s coefficient code loads the same way.
"""

from __future__ import annotations

import array
import ctypes
import ctypes.util
import functools
import hashlib
import json
import struct
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._storage import write_atomic
from ._codegen import cache_dir, loaded
from ._deferred import Deferred, c_signature
from ._k_common import MODEL_ARRAYS, MODEL_FUNCTIONS

__all__ = [
    "Addresses",
    "NativeLoop",
    "build",
    "compiled",
    "host_key",
    "kinds",
    "load_object",
    "loop_of",
    "native_loop",
    "target",
]

_LOCK = threading.RLock()
_TARGET: list[Any] = []
_ENGINES: list[Any] = []  # kept alive: the code lives as long as its engine
#: (module, loop, kinds) -> (built, the entry or None): what the cache holds, read once per process; for a model
#: function's C twin (kinds "twin"), its address or None
_LOOPS: dict[tuple[str, str, str], tuple[bool, Any]] = {}
#: The C library's functions code may call (LLVM's intrinsics lower to some of them), registered by name.
_LIBM = (
    "exp", "log", "sin", "cos", "tan", "pow", "sqrt", "sinh", "cosh", "tanh", "atan", "asin", "acos", "asinh",
    "acosh", "atanh", "nextafter", "atan2", "fmod", "log1p", "expm1", "hypot", "sincos",
)  # fmt: skip
_MAGIC = b"gm-native-2\n"
#: numba's helpers a loop's module may declare, defined here (see the module's text). numba's MemInfo record:
#: reference count, destructor, its argument, data, size (and numba's external allocator, null), 8 bytes each.
_RECORD = 48
_RUNTIME_IR = f"""
declare i32 @PyGILState_Ensure()
declare void @PyGILState_Release(i32)
declare ptr @malloc(i64)
declare void @free(ptr)

define void @numba_gil_ensure(ptr %state) {{
  %s = call i32 @PyGILState_Ensure()
  store i32 %s, ptr %state
  ret void
}}

define void @numba_gil_release(ptr %state) {{
  %s = load i32, ptr %state
  call void @PyGILState_Release(i32 %s)
  ret void
}}

define ptr @NRT_Allocate(i64 %size) {{
  %p = call ptr @malloc(i64 %size)
  ret ptr %p
}}

define void @NRT_Free(ptr %p) {{
  call void @free(ptr %p)
  ret void
}}

define internal void @geomech_record(ptr %mi, ptr %data, i64 %size) {{
  store i64 1, ptr %mi
  %dtor = getelementptr i8, ptr %mi, i64 8
  store ptr null, ptr %dtor
  %info = getelementptr i8, ptr %mi, i64 16
  store ptr null, ptr %info
  %at = getelementptr i8, ptr %mi, i64 24
  store ptr %data, ptr %at
  %sz = getelementptr i8, ptr %mi, i64 32
  store i64 %size, ptr %sz
  %ext = getelementptr i8, ptr %mi, i64 40
  store ptr null, ptr %ext
  ret void
}}

define ptr @NRT_MemInfo_alloc(i64 %size) {{
  %base = call ptr @NRT_MemInfo_alloc_aligned(i64 %size, i32 1)
  ret ptr %base
}}

define ptr @NRT_MemInfo_alloc_aligned(i64 %size, i32 %align) {{
  %a32 = zext i32 %align to i64
  %zero = icmp eq i64 %a32, 0
  %a = select i1 %zero, i64 1, i64 %a32
  %pad2 = shl i64 %a, 1
  %s1 = add i64 %size, %pad2
  %total = add i64 %s1, {_RECORD}
  %base = call ptr @malloc(i64 %total)
  %none = icmp eq ptr %base, null
  br i1 %none, label %failed, label %made
failed:
  ret ptr null
made:
  %start = getelementptr i8, ptr %base, i64 {_RECORD}
  %addr = ptrtoint ptr %start to i64
  %rem = urem i64 %addr, %a
  %aligned = icmp eq i64 %rem, 0
  %gap = sub i64 %a, %rem
  %off = select i1 %aligned, i64 0, i64 %gap
  %data = getelementptr i8, ptr %start, i64 %off
  call void @geomech_record(ptr %base, ptr %data, i64 %size)
  ret ptr %base
}}

define void @NRT_MemInfo_call_dtor(ptr %mi) {{
  call void @free(ptr %mi)
  ret void
}}
"""
_RUNTIME = (
    "numba_gil_ensure", "numba_gil_release", "NRT_Allocate", "NRT_Free", "NRT_MemInfo_alloc",
    "NRT_MemInfo_alloc_aligned", "NRT_MemInfo_call_dtor",
)  # fmt: skip
#: the functions of an entry's object: the entry on pointers, and on numpy's array objects (:func:`_objects_ir`)
_EXPORTED = ("geomech_entry", "geomech_objects")
#: the function of a model function's C twin's object (:func:`_twin_ir`)
_TWIN = "geomech_twin"
TWIN = "twin"  # the kinds of a twin's cache entry
#: The entry's result where the loop raised (numba's status not 0): the exception is numba's to build, and the
#: entry built here does not carry numba's wrapper that would.
RAISED = -(2**62)
#: The C entry: numba's compiled function (its calling convention: status, the result through a pointer, the
#: exception's record through another) called, its status turned into the result RAISED.
_ENTRY_IR = """
declare i32 @"{inner}"(ptr, ptr, ptr, ptr, ptr)

define i64 @geomech_entry(ptr %P, ptr %S, ptr %F) {{
  %ret = alloca i64
  store i64 0, ptr %ret
  %exc = alloca ptr
  store ptr null, ptr %exc
  %status = call i32 @"{inner}"(ptr %ret, ptr %exc, ptr %P, ptr %S, ptr %F)
  %ok = icmp eq i32 %status, 0
  %value = load i64, ptr %ret
  %out = select i1 %ok, i64 %value, i64 {raised}
  ret i64 %out
}}
"""


def target() -> Any:
    """LLVM's target machine for this host (created once; the math library's functions registered with it)."""
    import llvmlite.binding as llvm

    with _LOCK:
        if not _TARGET:
            llvm.initialize_native_target()
            llvm.initialize_native_asmprinter()
            triple = llvm.get_process_triple()
            tm = llvm.Target.from_triple(triple).create_target_machine(
                cpu=llvm.get_host_cpu_name(), features=_host_features(llvm), opt=3, jit=True
            )
            for name in _LIBM:
                address = _process_symbol(name)
                if address:
                    llvm.add_symbol(name, address)
            _TARGET.append(tm)
        return _TARGET[0]


def _host_features(llvm: Any) -> str:
    """The host CPU's features for LLVM ("" where LLVM cannot tell: the generic CPU's code)."""
    try:
        return str(llvm.get_host_cpu_features().flatten())
    except RuntimeError:  # pragma: no cover - some platforms do not report them
        return ""


@functools.cache
def host_key() -> str:
    """What machine code depends on besides its source: llvmlite's version, the process's triple, the host CPU and
    its features."""
    import llvmlite
    import llvmlite.binding as llvm

    target()
    return "\n".join((llvmlite.__version__, llvm.get_process_triple(), llvm.get_host_cpu_name(), _host_features(llvm)))


@functools.cache
def _handles() -> tuple[Any, ...]:
    """The math library, Python's C API (its shared library where it has one) and the process (its executable
    and the libraries loaded globally)."""
    handles: list[Any] = []
    for name in (ctypes.util.find_library("m"), None):
        try:
            handles.append(ctypes.CDLL(name))
        except (OSError, TypeError):  # pragma: no cover - no such library, or no process handle (Windows)
            continue
        if name is None:
            handles.insert(-1, ctypes.pythonapi)
    return tuple(handles)


def _process_symbol(name: str) -> int:
    """The address of the function or variable ``name`` in this process, 0 where there is none."""
    for h in _handles():
        try:
            return ctypes.addressof(ctypes.c_char.in_dll(h, name))
        except ValueError:
            continue
    return 0


def load_object(obj: bytes, names: tuple[str, ...], undefined: tuple[str, ...] = ()) -> tuple[int, ...]:
    """The addresses of the functions ``names`` of the object file ``obj``, loaded into an engine kept for the
    process. ``undefined`` are the symbols it needs from this process (registered with LLVM by their addresses
    here: each must resolve, as :func:`build` checked when it wrote the object)."""
    import llvmlite.binding as llvm

    with _LOCK:
        tm = target()
        for name in undefined:
            address = _process_symbol(name)
            if not address:
                raise RuntimeError(f"the compiled loop needs {name}, which this process does not define")
            llvm.add_symbol(name, address)
        engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), tm)
        engine.add_object_file(llvm.ObjectFileRef.from_data(obj))
        engine.finalize_object()
        addresses = tuple(engine.get_function_address(n) for n in names)
        if not all(addresses):  # pragma: no cover - a corrupt cache entry
            raise RuntimeError(f"a cached object defines none of {names}: delete the cache's kernels")
        _ENGINES.append(engine)
        return addresses


def undefined_symbols(obj: bytes) -> tuple[str, ...] | None:
    """The symbols an ELF64 little-endian object file leaves undefined (read from its symbol table); None for
    any other format."""
    if obj[:4] != b"\x7fELF" or obj[4] != 2 or obj[5] != 1:
        return None
    (shoff,) = struct.unpack_from("<Q", obj, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", obj, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", obj, shoff + i * shentsize) for i in range(shnum)]
    out = set()
    for _, kind, _, _, offset, size, link, _, _, entsize in sections:
        if kind != 2 or not entsize:  # SHT_SYMTAB
            continue
        str_offset = sections[link][4]
        for at in range(offset + entsize, offset + size, entsize):  # entry 0 is the null symbol
            name_at, _, _, shndx = struct.unpack_from("<IBBH", obj, at)
            if shndx == 0 and name_at:
                end = obj.index(b"\0", str_offset + name_at)
                out.add(obj[str_offset + name_at : end].decode())
    return tuple(sorted(out))


def kinds(args: tuple[Any, ...]) -> str | None:
    """The kinds of a loop's arguments, one token each (``f2``: a C-contiguous float64 array of 2 dimensions,
    ``i1`` an int64 vector, ``d`` a float, ``n`` an integer); None where one has no C form here."""
    out = []
    for a in args:
        if isinstance(a, np.ndarray):
            if not a.flags.c_contiguous or a.dtype not in (np.float64, np.int64) or a.ndim == 0:
                return None
            out.append(("f" if a.dtype == np.float64 else "i") + str(a.ndim))
        elif isinstance(a, (bool, np.bool_)):
            return None
        elif isinstance(a, (int, np.integer)):
            out.append("n")
        elif isinstance(a, (float, np.floating)):
            out.append("d")
        else:
            return None
    return " ".join(out)


_DTYPES = {"f": np.dtype(np.float64), "i": np.dtype(np.int64)}


def _check_array(i: int, a: Any, dtype: np.dtype, ndim: int) -> None:
    """Argument ``i`` of a compiled loop, an array of ``dtype`` with ``ndim`` dimensions, C-contiguous: or a
    TypeError that says which and why."""
    if not (isinstance(a, np.ndarray) and a.dtype == dtype and a.ndim == ndim):
        raise TypeError(f"argument {i} of the compiled loop: an array of {dtype}, {ndim}-D")
    if not a.flags.c_contiguous:
        raise TypeError(f"argument {i} of the compiled loop: the loop takes C-contiguous arrays")


class NativeLoop:
    """A loop's C entry (:func:`build`), called with the loop's own arguments, of the kinds it was built for."""

    def __init__(self, raw: int, objects: int, spec: str):
        self.spec = spec
        tokens = spec.split()
        #: per argument: None for a float, 0 for an integer, (dtype, ndim) for an array
        self._plan = tuple(None if t == "d" else 0 if t == "n" else (_DTYPES[t[0]], int(t[1:])) for t in tokens)
        # where each kind of argument is (a call gathers them by position)
        self._float_at = tuple(i for i, kind in enumerate(self._plan) if kind is None)
        self._int_at = tuple(i for i, kind in enumerate(self._plan) if kind == 0)
        self._array_at = tuple(i for i, kind in enumerate(self._plan) if isinstance(kind, tuple))
        self._array_kinds = tuple(kind for kind in self._plan if isinstance(kind, tuple))
        proto = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
        layout = _layout()
        self._layout = None if layout is None else array.array("q", layout)
        self._fn = proto(raw if layout is None else objects)

    def __call__(self, *args: Any) -> int:
        return self._run(*self._buffers(args))

    def bind(self, *args: Any) -> Callable[[], int]:
        """The call with ``args``, checked and gathered once: a function of no arguments that runs the loop on them
        again (their arrays' contents read and written at each call, the arrays themselves and the numbers fixed)."""
        buffers = self._buffers(args)

        def again() -> int:
            return self._run(*buffers, args)

        return again

    def _run(self, first: array.array, ints: array.array, floats: array.array, *held: Any) -> int:
        """The C entry on gathered arguments (``held``: what must live through the call)."""
        out = int(self._fn(first.buffer_info()[0], ints.buffer_info()[0], floats.buffer_info()[0]))
        if out == RAISED:
            raise RuntimeError(
                "the compiled loop raised an exception, which its code loaded without numba cannot report: delete "
                "the gm_native_* files of the cache's kernels to run it through numba and see it"
            )
        return out

    def _buffers(self, args: tuple[Any, ...]) -> tuple[array.array, array.array, array.array]:
        """The arguments checked and gathered as the C entry reads them: the arrays (their objects, or their data
        and shapes), the integers, the floats."""
        if len(args) != len(self._plan):
            raise TypeError(f"the compiled loop takes {len(self._plan)} arguments, got {len(args)}")
        arrays = [args[i] for i in self._array_at]
        for i, a, (dtype, ndim) in zip(self._array_at, arrays, self._array_kinds):
            if type(a) is not np.ndarray or a.dtype is not dtype or a.ndim != ndim or not a.flags.c_contiguous:
                _check_array(i, a, dtype, ndim)  # (an array of an equal dtype, or of a subclass, passes)
        floats = array.array("d", [args[i] for i in self._float_at])
        floats.append(0.0)
        ints = array.array("q", [args[i] for i in self._int_at])
        if self._layout is not None:  # the array objects themselves (the arguments hold them through the call)
            first = array.array("q", [id(a) for a in arrays] or [0])
            ints = self._layout + ints
        else:
            first = array.array("q", [int(a.ctypes.data) for a in arrays] or [0])
            shapes = array.array("q")
            for a in arrays:
                shapes.extend(a.shape)
            ints = shapes + ints
        ints.append(0)
        return first, ints, floats


def bound(loop: Any, args: tuple[Any, ...]) -> Callable[[], Any]:
    """``loop`` (a :class:`NativeLoop`, numba's kernel or the Python function) bound to ``args``: a function of no
    arguments that runs it on them again, their arrays' contents the run's input and output."""
    if isinstance(loop, NativeLoop):
        return loop.bind(*args)
    return functools.partial(loop, *args)


def compiled(module: Any, name: str, args: tuple[Any, ...], warm_up: Any = None) -> tuple[Any, float]:
    """The kernel ``name`` of the generated ``module`` to call with arguments like ``args``, and the seconds it
    took to get it (0 for the Python function itself, where numba is off): its C entry loaded without numba where
    the cache has it, else numba's kernel (compiled, or loaded from numba's cache, by ``warm_up()`` where it has no
    machine code yet) and its C entry built for the next process (or this one's next call). The kernel returns an
    integer (its status) or nothing (the entry then returns 0)."""
    function = getattr(module, name)
    if not hasattr(function, "py_func"):  # the Python twin
        return function, 0.0
    start = time.perf_counter()
    spec = kinds(args)
    known, native = native_loop(module, name, spec) if spec else (True, None)
    if native is not None:
        return native, time.perf_counter() - start
    if warm_up is not None and not loaded(function):
        warm_up()
    if spec and not known:
        native = build(module, name, spec)
    return (function if native is None else native), time.perf_counter() - start


def loop_of(
    module: Any, loop: str, args: tuple[Any, ...] | Callable[[], tuple[Any, ...]], warm_up: Any
) -> tuple[Any, float]:
    """``module``'s compiled ``loop`` to call with arguments like ``args`` (:func:`._native.compiled`: its C entry
    where it has one, else numba's kernel, made ready by ``warm_up()``), and the seconds that took: found once per
    module, loop and process, the seconds 0 at every later call (a runner counts them as compile time where they
    are not). A runner gives a loop arguments of the same kinds at every call (the inputs C-contiguous, the outputs
    its own). The entry of a loop shared by every model is the shared module's, built once for all models. ``args``
    may be a function that makes them, called only where the loop is not found yet (a run's arguments are made for
    its call: a probe made at every call would be made twice)."""
    loops = module.__dict__.setdefault("_LOOPS", {})
    if loop in loops:
        return loops[loop], 0.0
    if callable(args):
        args = args()
    shared = getattr(module, "_shared", None)
    home = shared if shared is not None and loop in vars(shared) else module
    function, seconds = compiled(home, loop, args, warm_up)
    loops[loop] = function
    return function, seconds


def _entry_source(spec: str, returns: bool = True) -> str:
    """The Python source of the C entry of a loop ``loop`` whose arguments are of the kinds ``spec``: ``P`` the
    arrays' data, ``S`` their shapes one after the other and then the integers, ``F`` the floats; the entry returns
    the loop's integer, or 0 where the loop ``returns`` nothing."""
    tokens = spec.split()
    args = []
    p = f = 0
    s = sum(int(t[1:]) for t in tokens if t not in ("d", "n"))  # the integers after the shapes
    at = 0
    for token in tokens:
        if token == "d":
            args.append(f"F[{f}]")
            f += 1
        elif token == "n":
            args.append(f"S[{s}]")
            s += 1
        else:
            ndim = int(token[1:])
            shape = ", ".join(f"S[{at + j}]" for j in range(ndim))
            dtype = "np.float64" if token[0] == "f" else "np.int64"
            args.append(f"carray(P[{p}], ({shape},), {dtype})")
            p += 1
            at += ndim
    call = "loop(\n        " + ",\n        ".join(args) + ",\n    )"
    body = f"return {call}" if returns else f"{call}\n    return 0"
    return f"def entry(P, S, F):\n    {body}\n"


def _objects_ir(spec: str) -> str:
    """The IR of ``geomech_objects(O, I, F)``: the entry called with numpy's array objects themselves (``O`` their
    addresses; ``I`` the offsets of an array object's data pointer and shape pointer, :func:`_layout`, then the
    integers), their data pointers and shapes read here, where numpy's attributes would cost a microsecond each."""
    tokens = spec.split()
    ndims = [int(t[1:]) for t in tokens if t not in ("d", "n")]
    n_ints = tokens.count("n")
    k, m = max(len(ndims), 1), max(sum(ndims) + n_ints, 1)
    lines = [
        "define i64 @geomech_objects(ptr %O, ptr %I, ptr %F) {",
        f"  %P = alloca [{k} x ptr]",
        f"  %S = alloca [{m} x i64]",
        "  %offd = load i64, ptr %I",
        "  %offs.at = getelementptr i64, ptr %I, i64 1",
        "  %offs = load i64, ptr %offs.at",
    ]
    at = 0
    for i, nd in enumerate(ndims):
        lines += [
            f"  %o{i}.at = getelementptr i64, ptr %O, i64 {i}",
            f"  %o{i}.int = load i64, ptr %o{i}.at",
            f"  %o{i} = inttoptr i64 %o{i}.int to ptr",
            f"  %d{i}.at = getelementptr i8, ptr %o{i}, i64 %offd",
            f"  %d{i} = load ptr, ptr %d{i}.at",
            f"  %p{i} = getelementptr [{k} x ptr], ptr %P, i64 0, i64 {i}",
            f"  store ptr %d{i}, ptr %p{i}",
            f"  %s{i}.at = getelementptr i8, ptr %o{i}, i64 %offs",
            f"  %s{i} = load ptr, ptr %s{i}.at",
        ]
        for j in range(nd):  # the shape's extents
            lines += _copied(f"e{i}_{j}", f"%s{i}", j, m, at)
            at += 1
    for r in range(n_ints):  # the integers, after the offsets
        lines += _copied(f"n{r}", "%I", 2 + r, m, at)
        at += 1
    lines += ["  %out = call i64 @geomech_entry(ptr %P, ptr %S, ptr %F)", "  ret i64 %out", "}", ""]
    return "declare i64 @geomech_entry(ptr, ptr, ptr)\n\n" + "\n".join(lines)


def _copied(name: str, source: str, index: int, m: int, at: int) -> list[str]:
    """IR lines storing the int64 entry ``index`` of ``source`` into entry ``at`` of the ``m`` of ``%S``."""
    return [
        f"  %{name}.at = getelementptr i64, ptr {source}, i64 {index}",
        f"  %{name} = load i64, ptr %{name}.at",
        f"  %{name}.to = getelementptr [{m} x i64], ptr %S, i64 0, i64 {at}",
        f"  store i64 %{name}, ptr %{name}.to",
    ]


@functools.cache
def _layout() -> tuple[int, int] | None:
    """The byte offsets, in a numpy array object, of its data pointer and of its shape's (numpy's
    ``PyArrayObject_fields``, after Python's object header, whose size depends on the build), found on probe
    arrays and checked on others; None where they are not found (the entries are then given the pointers and
    shapes read by numpy's attributes)."""
    probes = [np.zeros((4, 5))[1:], np.zeros((7, 2, 3), dtype=np.int64)[:, 1], np.zeros(9)[2:]]

    def word(a: np.ndarray, at: int) -> int:
        return int(ctypes.c_int64.from_address(id(a) + at).value)

    offsets = range(8, 72, 8)
    data = [k for k in offsets if all(word(a, k) == a.ctypes.data for a in probes)]
    if len(data) != 1:
        return None

    def shape_at(a: np.ndarray, k: int) -> bool:
        p = word(a, k)
        return p > 4096 and all(ctypes.c_int64.from_address(p + 8 * j).value == n for j, n in enumerate(a.shape))

    shapes = [k for k in offsets if k != data[0] and all(shape_at(a, k) for a in probes)]
    return (data[0], shapes[0]) if len(shapes) == 1 else None


@functools.cache
def _fingerprint() -> str:
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def _path(module_name: str, loop_name: str, spec: str) -> Path:
    key = "\n".join((_fingerprint(), host_key(), module_name, loop_name, spec))
    return cache_dir() / f"gm_native_{hashlib.sha256(key.encode()).hexdigest()[:24]}.bin"


def native_loop(module: Any, loop_name: str, spec: str) -> tuple[bool, NativeLoop | None]:
    """Whether the C entry of ``module``'s loop ``loop_name`` for arguments of the kinds ``spec`` has been built
    (:func:`build`; in this process or in the cache), and the entry, loaded from the cache without numba (None
    where it was refused). The cache is read once per process and loop (a run asks at every call)."""
    return _cached((module.__name__, loop_name, spec))


def _cached(key: tuple[str, str, str]) -> tuple[bool, Any]:
    """What the cache holds for ``key`` (module, function, kinds), read once per process: (built, the loaded entry
    or twin's address, None where it was refused)."""
    known = _LOOPS.get(key)
    if known is not None:
        return known
    with _LOCK:
        try:
            data = _path(*key).read_bytes()
        except OSError:
            data = b""
        if _parts(data) is None:  # not there (or not a file this module wrote): until this process builds it
            _LOOPS[key] = (False, None)
            return _LOOPS[key]
        _LOOPS[key] = (True, _read(data, key[2]))
        return _LOOPS[key]


def _parts(data: bytes) -> tuple[dict[str, Any], bytes] | None:
    """A cache file's header and object (None where the content is not such a file)."""
    if not data.startswith(_MAGIC):
        return None
    start = len(_MAGIC) + 8
    size = int.from_bytes(data[len(_MAGIC) : start], "little")
    try:
        header = json.loads(data[start : start + size])
    except ValueError:
        return None
    if not isinstance(header, dict) or not (header.get("refused") or ("names" in header and "undefined" in header)):
        return None
    return header, data[start + size :]


def _read(data: bytes, spec: str) -> Any:
    """The loop of a cache file's content, or for a twin (``spec`` TWIN) its address (None for a refusal recorded
    there)."""
    parts = _parts(data)
    if parts is None:  # pragma: no cover - checked by the callers
        raise RuntimeError("a cached compiled loop is not one of this version's: delete the cache's kernels")
    header, obj = parts
    if header.get("refused"):
        return None
    addresses = load_object(obj, tuple(header["names"]), tuple(header["undefined"]))
    if spec == TWIN:
        return addresses[0]
    return NativeLoop(addresses[0], addresses[1], spec)


def build(module: Any, loop_name: str, spec: str) -> NativeLoop | None:
    """Compile (numba) the C entry of ``module``'s loop ``loop_name`` for arguments of the kinds ``spec``, emit its
    module as an object file with numba's helpers defined in it, check every symbol it leaves undefined resolves
    in this process, and cache it; the loop loaded from it, or None (recorded too, so that later runs do not try
    again) where the loop needs numba's run time or the platform's objects cannot be read."""
    import llvmlite.binding as llvm
    import numba
    from numba import types

    loop = getattr(module, loop_name)
    # a loop that returns nothing (the fixed-step methods') gets an entry that returns 0
    returns = any(sig.return_type != types.none for sig in loop.nopython_signatures) or not loop.nopython_signatures
    namespace: dict[str, Any] = {"loop": loop, "carray": numba.carray, "np": np}
    exec(compile(_entry_source(spec, returns), f"<entry of {loop_name}>", "exec"), namespace)  # source printed here
    signature = types.int64(types.CPointer(types.voidptr), types.CPointer(types.int64), types.CPointer(types.float64))
    cfunc: Any = numba.cfunc(signature, error_model="numpy")(namespace["entry"])
    with _LOCK:
        mod = cfunc._library._final_module.clone()
        inner = cfunc.native_name.removeprefix("cfunc.")  # numba's function, that its C wrapper calls
        mod.link_in(llvm.parse_assembly(_ENTRY_IR.format(inner=inner, raised=RAISED)))
        mod.link_in(llvm.parse_assembly(_objects_ir(spec)))
        return _emit(mod, _EXPORTED, (module.__name__, loop_name, spec))


def _emit(mod: Any, exported: tuple[str, ...], key: tuple[str, str, str]) -> Any:
    """Write the cache entry ``key`` of the LLVM module ``mod`` (numba's code, linked with the functions
    ``exported`` that call it): everything else made internal and what they do not reach removed, numba's helpers
    defined, the object's undefined symbols checked; the entry loaded from it (:func:`_read`), or None where it was
    refused (the refusal recorded)."""
    import llvmlite.binding as llvm

    tm = target()
    for f in mod.functions:
        if not f.is_declaration and f.name not in exported:
            f.linkage = "internal"
    # what the entry does not reach goes (numba's wrappers for calls from Python, among them)
    pb = llvm.create_pass_builder(tm, llvm.create_pipeline_tuning_options(speed_level=0))
    pm = llvm.create_new_module_pass_manager()
    pm.add_global_dead_code_eliminate_pass()
    pm.run(mod, pb)
    reached = {f.name for f in mod.functions if f.is_declaration and not f.name.startswith("llvm.")}
    if reached & set(_RUNTIME):
        mod.link_in(llvm.parse_assembly(_RUNTIME_IR))
        for f in mod.functions:
            if f.name in _RUNTIME or f.name == "geomech_record":
                f.linkage = "internal"
        pm.run(mod, pb)  # the helpers nothing calls go
    extra = sorted(n for n in reached if n.startswith(("NRT_", "numba_")) and n not in _RUNTIME)
    reason, undefined = "", None
    if extra:
        reason = "needs numba's run time: " + ", ".join(extra)
    else:
        obj = bytes(tm.emit_object(mod))
        undefined = undefined_symbols(obj)
        if undefined is None:
            reason = "this platform's object files are not read here"
        else:
            missing = [n for n in undefined if not _process_symbol(n)]
            if missing:
                reason = "needs symbols this process does not define: " + ", ".join(missing)
    header = {"refused": reason} if reason else {"names": list(exported), "undefined": list(undefined or ())}
    text = json.dumps(header).encode()
    data = _MAGIC + len(text).to_bytes(8, "little") + text + (b"" if reason else obj)
    write_atomic(_path(*key), data)
    entry = _read(data, key[2])
    _LOOPS[key] = (True, entry)
    return entry


def _twin_ir(inner: str, name: str) -> str:
    """The IR of ``geomech_twin``, the C twin of model function ``name`` (:mod:`._fptr`'s signature): numba's compiled
    function ``inner`` called directly, every output (every array but the first) filled with NaN where it raised,
    so that the loop that called it reports a state that is not finite."""
    ndims = MODEL_ARRAYS[name]
    n = len(ndims) + 1  # the arrays and prm
    params = ", ".join(f"ptr %a{i}" for i in range(n))
    fills = []
    for i, k in enumerate(ndims[1:], start=1):
        size = "%dd" if k == 2 else "%d"
        fills.append(f"  call void @geomech_nan(ptr %a{i}, i64 {size})")
    return f"""
declare i32 @"{inner}"(ptr, ptr, {", ".join(["ptr"] * n)}, i64, i64)

define void @geomech_twin({params}, i64 %d, i64 %n) {{
  %ret = alloca i64
  %exc = alloca ptr
  store ptr null, ptr %exc
  %status = call i32 @"{inner}"(ptr %ret, ptr %exc, {params}, i64 %d, i64 %n)
  %ok = icmp eq i32 %status, 0
  br i1 %ok, label %done, label %failed
failed:
  %dd = mul i64 %d, %d
{chr(10).join(fills)}
  br label %done
done:
  ret void
}}

define internal void @geomech_nan(ptr %p, i64 %n) {{
entry:
  %empty = icmp sle i64 %n, 0
  br i1 %empty, label %out, label %loop
loop:
  %i = phi i64 [0, %entry], [%next, %loop]
  %at = getelementptr double, ptr %p, i64 %i
  store double 0x7FF8000000000000, ptr %at
  %next = add i64 %i, 1
  %more = icmp slt i64 %next, %n
  br i1 %more, label %loop, label %out
out:
  ret void
}}
"""


def build_twin(module_name: str, name: str, cfunc: Any) -> int | None:
    """The C twin of model function ``name`` of the generated module ``module_name`` as code of its own, from
    numba's ``cfunc`` of it (compiled, or loaded from numba's cache: its library keeps the code's IR for linking):
    cached, and its address, or None where it was refused (:func:`_emit`)."""
    import llvmlite.binding as llvm

    with _LOCK:
        mod = cfunc._library._get_module_for_linking().clone()
        inner = cfunc.native_name.removeprefix("cfunc.")
        mod.link_in(llvm.parse_assembly(_twin_ir(inner, name)))
        return _emit(mod, (_TWIN,), (module_name, f"_{name}_c", TWIN))


class Addresses:
    """The addresses of a generated module's model functions (``namespace`` is the module's globals): each C twin
    loaded as code of its own where the cache has it (numba not imported), else compiled by numba (or loaded from
    numba's cache) and its code of its own built for the next process, on first request."""

    def __init__(self, namespace: dict[str, Any]):
        self._namespace = namespace
        self._known: dict[str, int] = {}
        self._cfuncs: dict[str, Any] = {}  # numba's, kept alive where their code is called

    def ready(self, names: tuple[str, ...]) -> bool:
        """Whether the address of every twin of ``names`` is known in this process (no compilation to wait for)."""
        return all(name in self._known for name in names)

    def __call__(self, names: tuple[str, ...]) -> np.ndarray:
        """The address array ``FP`` for a loop that calls ``names`` (zero for the functions it does not call)."""
        out = np.zeros(len(MODEL_FUNCTIONS), dtype=np.int64)
        for name in names:
            if name not in self._known:
                self._known[name] = self._address(name)
            out[MODEL_FUNCTIONS.index(name)] = self._known[name]
        return out

    def _address(self, name: str) -> int:
        module_name = str(self._namespace["__name__"])
        built, address = _cached((module_name, f"_{name}_c", TWIN))
        if address is not None:
            return int(address)
        import numba

        deferred = self._namespace.get("_DEFERRED")
        if isinstance(deferred, Deferred):
            deferred.bind()
        cfunc: Any = numba.cfunc(c_signature(name), cache=True)(self._namespace[f"_{name}_c"])
        self._cfuncs[name] = cfunc
        if not built:
            own = build_twin(module_name, name, cfunc)
            if own is not None:
                return int(own)
        return int(cfunc.address)
