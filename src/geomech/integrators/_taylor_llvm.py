"""Taylor coefficients unrolled for one order: a :class:`~geomech.symbolic.taylor.TaylorTape` printed as LLVM IR with
every recurrence's sum written out, compiled by LLVM (llvmlite, numba's code generator) and called by the Taylor
loop through its address (:func:`geomech.integrators._fptr.call_model`).

Why not numba: the unrolled code of a model is thousands of statements (the snakeboard's BKMM equations at order
19: 1,400 values, 7,000 multiply-adds), which numba's front end takes 15 s to compile where LLVM alone takes under
one; and the loop over the orders (:meth:`TaylorTape.source`, the "compact" form) spends about twice the time per
step on loop overhead and memory traffic that the unrolled code keeps in registers. Written out, the coefficients
that vanish are known when the code is printed (those of t beyond order 1, of a constant, of a sum or product of
such): their terms are dropped, so a gait's sin(omega t) costs one multiply an order instead of k.

The function is ``void name(double *X, double *K, double *prm, int64 d, int64 n_prm)``: ``X`` the ``d x (order
+ 1)`` coefficients (row-major; column 0 the state, the others filled), ``K`` the tape's constants (by the model's
``taylor_constants(K, prm)``), ``prm`` the parameters. The machine code is cached on disk beside the kernels,
named by the hash of the tape, the order, this module's source, llvmlite's version and the host CPU.
"""

from __future__ import annotations

import functools
import hashlib
import threading
from pathlib import Path
from typing import Any

from .._storage import write_atomic
from ..symbolic.taylor import TaylorTape
from ._codegen import cache_dir
from ._native import host_key, load_object, target

__all__ = ["horner_address", "horner_ir", "taylor_ir", "unrolled_address", "simd_lanes", "UNROLL_LIMIT"]

#: The largest pass (multiply-adds of :meth:`TaylorTape.multiply_adds`) compiled unrolled; larger ones run the
#: loop over the orders (LLVM's time grows with the code, about 1 s for 10,000 multiply-adds).
UNROLL_LIMIT = 60_000
_INTRINSICS = {"exp", "log", "sin", "cos"}

#: a multiply and an add may be one fused instruction (one rounding instead of two)
FLAGS = ("contract",)
_LOCK = threading.Lock()
_ADDRESSES: dict[str, int] = {}


def _function(name: str, lanes: int) -> tuple[Any, Any, tuple[Any, Any, Any], Any]:
    """A module with the function ``void name(double *, double *, double *, i64, i64)`` (the signature the compiled
    loops call; the three arrays never alias), its builder at the entry block, the three arrays, and ``address(ptr,
    i)``: the pointer to entry i of ``ptr`` (a vector of ``lanes`` doubles where ``lanes`` > 1)."""
    from llvmlite import ir

    D = ir.DoubleType()
    T = D if lanes == 1 else ir.VectorType(D, lanes)
    i64 = ir.IntType(64)
    mod = ir.Module(name=name)
    fn = ir.Function(mod, ir.FunctionType(ir.VoidType(), [D.as_pointer()] * 3 + [i64, i64]), name=name)
    for a in fn.args[:3]:
        a.add_attribute("noalias")
    b = ir.IRBuilder(fn.append_basic_block("entry"))

    def address(ptr: Any, i: int) -> Any:
        at = b.gep(ptr, [ir.Constant(i64, i * lanes)], inbounds=True)
        return at if lanes == 1 else b.bitcast(at, T.as_pointer())

    return mod, b, (fn.args[0], fn.args[1], fn.args[2]), address


def taylor_ir(tape: TaylorTape, name: str, order: int, lanes: int = 1) -> str:
    """The LLVM IR of ``name``: the Taylor coefficients to ``order`` of the tape's equations, unrolled; with
    ``lanes`` > 1, of that many trajectories at once, every value a vector of ``lanes`` numbers (the arrays then
    hold each entry's lanes side by side: entry i of lane l at ``i * lanes + l``)."""
    from llvmlite import ir

    mod, b, (X, Kp, P), address = _function(name, lanes)
    D = ir.DoubleType()
    T = D if lanes == 1 else ir.VectorType(D, lanes)
    i64 = ir.IntType(64)
    functions: dict[str, Any] = {}

    def call(f: str, *args: Any) -> Any:
        if f in _INTRINSICS or f in ("sqrt", "pow"):
            if f not in functions:  # llvm.sin.f64, llvm.sin.v4f64, ...
                suffix = "f64" if lanes == 1 else f"v{lanes}f64"
                functions[f] = ir.Function(mod, ir.FunctionType(T, [T] * len(args)), name=f"llvm.{f}.{suffix}")
            return b.call(functions[f], list(args))
        if f not in functions:
            functions[f] = ir.Function(mod, ir.FunctionType(D, [D] * len(args)), name=f)
        if lanes == 1:
            return b.call(functions[f], list(args))
        out = ir.Constant(T, ir.Undefined)
        for lane in range(lanes):  # the C library's function lane by lane
            at_lane = [b.extract_element(a, ir.Constant(i64, lane)) for a in args]
            out = b.insert_element(out, b.call(functions[f], at_lane), ir.Constant(i64, lane))
        return out

    def load(ptr: Any, i: int) -> Any:
        return b.load(address(ptr, i), align=8)

    def mul(u: Any, v: Any) -> Any:
        return b.fmul(u, v, flags=FLAGS)

    def add(u: Any, v: Any) -> Any:
        return b.fadd(u, v, flags=FLAGS)

    def num(c: float) -> Any:
        return ir.Constant(T, c)

    consts: dict[str, Any] = {f"_p{i}": load(P, i) for i in range(tape.n_parameters)}
    consts.update({c: load(Kp, int(c[2:])) for c, _ in tape.constants})
    series: dict[tuple[str, int], Any] = {}  # (row, k) -> value; None: the coefficient vanishes
    stride = order + 1
    for i in tape.state:
        series[(f"_x{i}", 0)] = load(X, i * stride)

    def scalar(c: Any) -> Any:
        return num(c) if isinstance(c, float) else consts[c]

    def at(r: Any, k: int) -> Any:
        """Order k of a reference (None where it vanishes)."""
        if isinstance(r, str) and r[1] in "xw":
            return series[(r, k)]
        if k > 0 or r == 0.0:
            return None
        return scalar(r)

    def times(u: Any, v: Any) -> Any:
        return None if u is None or v is None else mul(u, v)

    def plus(u: Any, v: Any) -> Any:
        return v if u is None else u if v is None else add(u, v)

    def minus(u: Any, v: Any) -> Any:
        if v is None:
            return u
        return b.fneg(v) if u is None else b.fsub(u, v)

    def total(terms: Any) -> Any:
        acc = None
        for t in terms:
            acc = plus(acc, t)
        return acc

    def scaled(c: Any, v: Any) -> Any:
        return v if (c == 1.0 or v is None) else mul(scalar(c), v)

    def cauchy(u: str, v: str, k: int, first: int, last: int) -> Any:
        """sum_{j=first..last} u^[j] v^[k-j], by halves where u is v."""
        if u != v:
            return total(times(at(u, j), at(v, k - j)) for j in range(first, last + 1))
        pairs = total(times(at(u, j), at(u, k - j)) for j in range(first, last + 1) if j < k - j)
        twice = None if pairs is None else mul(num(2.0), pairs)
        middle = times(at(u, k // 2), at(u, k // 2)) if k % 2 == 0 and first <= k // 2 <= last else None
        return plus(twice, middle)

    # a divisor that is the same at every order (b^[0] of a quotient, 2 w^[0] of a root, a^[0] of a power) divided
    # into 1 once, the orders multiplying by it: a division costs several multiplications' time
    reciprocals: dict[tuple[str, str], Any] = {}

    def reciprocal(key: tuple[str, str], value: Any) -> Any:
        if key not in reciprocals:
            reciprocals[key] = b.fdiv(num(1.0), value)
        return reciprocals[key]

    for k in range(order):
        for op in tape.ops:
            kind, w = op[0], op[1]
            if kind == "lin":
                value = total(scaled(c, at(r, k)) for c, r in op[2])
                if op[3] is not None and k == 0:
                    value = plus(value, scalar(op[3]))
            elif kind == "mul":
                value = cauchy(op[2], op[3], k, 0, k)
            elif kind == "quot":
                top = at(op[2], k) if op[3] is None else scaled(op[2], at(op[3], k))
                rest = minus(top, cauchy(op[4], w, k, 1, k))
                if rest is None:
                    value = None
                elif k == 0:
                    value = b.fdiv(rest, at(op[4], 0))
                else:
                    value = mul(rest, reciprocal(("quot", w), at(op[4], 0)))
            elif kind == "sqrt":
                a = op[2]
                if k == 0:
                    value = call("sqrt", at(a, 0))
                else:
                    rest = minus(at(a, k), cauchy(w, w, k, 1, k - 1))
                    half = reciprocal(("sqrt", w), mul(num(2.0), at(w, 0)))
                    value = None if rest is None else mul(rest, half)
            elif kind == "pow":
                a, e = op[2], op[3]
                if k == 0:
                    value = call("pow", at(a, 0), scalar(e))
                else:
                    terms = []
                    for j in range(k):
                        term = times(at(a, k - j), at(w, j))
                        if term is None:
                            continue
                        if isinstance(e, float):
                            factor = num(e * (k - j) - j)
                        else:
                            factor = b.fsub(mul(consts[e], num(float(k - j))), num(float(j)))
                        terms.append(mul(factor, term))
                    acc = total(terms)
                    inv = reciprocal(("pow", w), at(a, 0))
                    value = None if acc is None else mul(acc, mul(num(1.0 / k), inv))
            else:  # "int": w = f(a), f'(a) = r
                f, a, r = op[2], op[3], op[4]
                if k == 0:
                    value = call(f, at(a, 0))
                else:
                    terms = []
                    for j in range(1, k + 1):
                        aj = at(a, j)
                        term = times(aj if j == 1 or aj is None else mul(num(float(j)), aj), at(r, k - j))
                        terms.append(term)
                    acc = total(terms)
                    value = None if acc is None else mul(acc, num(1.0 / k))
            series[(w, k)] = value
        for i, o in enumerate(tape.outputs):
            v = at(o, k)
            v = None if v is None else mul(v, num(1.0 / (k + 1)))
            b.store(num(0.0) if v is None else v, address(X, i * stride + k + 1), align=8)
            series[(f"_x{i}", k + 1)] = v
    b.ret_void()
    return str(mod)


@functools.cache
def simd_lanes() -> int:
    """The members whose coefficients one pass computes at once on this host: the doubles of its widest vector
    registers (8 with AVX-512, 4 with AVX, 2 otherwise). On an AVX2 machine (the benchmarks') 4 lanes cost a pass
    3.6 times less per member than one, and 8 lanes no less than 4."""
    features = set(host_key().split("\n")[-1].split(","))
    if "+avx512f" in features:
        return 8
    return 4 if "+avx" in features else 2


def _compile(tm: Any, ir_text: str) -> bytes:
    """The machine code (an object file) of ``ir_text``, optimised at level 3 for this host."""
    import llvmlite.binding as llvm

    module = llvm.parse_assembly(ir_text)
    module.verify()
    pb = llvm.create_pass_builder(tm, llvm.create_pipeline_tuning_options(speed_level=3))
    pb.getModulePassManager().run(module, pb)
    return bytes(tm.emit_object(module))


@functools.cache
def _printer_fingerprint() -> str:
    """The hash of this module's source: the unrolled code cached on disk is printed by it."""
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def horner_ir(name: str, d: int, order: int, lanes: int) -> str:
    """The LLVM IR of ``name(X, H, Y, _, _)``: the Taylor polynomials of the ``d`` rows of ``X`` (the coefficients of
    :func:`taylor_ir` to ``order`` for ``lanes`` members, in its layout) at the steps ``H`` (one a lane), by Horner's
    rule on vectors of the lanes: ``Y[i lanes + l]``, the new states of the members, in one pass."""
    mod, b, (X, H, Y), address = _function(name, lanes)
    h = b.load(address(H, 0), align=8)
    stride = order + 1
    for i in range(d):
        acc = b.load(address(X, i * stride + order), align=8)
        for j in range(order - 1, -1, -1):
            acc = b.fadd(b.fmul(acc, h, flags=FLAGS), b.load(address(X, i * stride + j), align=8), flags=FLAGS)
        b.store(acc, address(Y, i), align=8)
    b.ret_void()
    return str(mod)


def horner_address(d: int, order: int, lanes: int) -> int:
    """The address of :func:`horner_ir`'s function for ``d`` rows, ``order`` and ``lanes`` (compiled once per
    process and cached on disk as :func:`unrolled_address`'s code is)."""
    return _machine_code(f"horner {d} {order} {lanes}", "taylor_horner", lambda name: horner_ir(name, d, order, lanes))


def unrolled_address(tape: TaylorTape, order: int, lanes: int = 1) -> int:
    """The address of the tape's coefficients to ``order``, unrolled (:func:`taylor_ir`) for ``lanes``
    trajectories at once, compiled once per process and cached on disk (named by the tape, the order, the lanes,
    this module's source, llvmlite and the host)."""
    return _machine_code(
        f"{order}\n{lanes}\n{tape.data()!r}", "taylor_unrolled", lambda name: taylor_ir(tape, name, order, lanes)
    )


def _machine_code(what: str, name: str, make_ir: Any) -> int:
    """The address of function ``name`` of the IR ``make_ir(name)`` describes (``what`` names it: the code cached
    on disk is named by it, this module's source, llvmlite and the host, and loads without printing its IR
    again), compiled once per process."""
    with _LOCK:
        key = "\n".join((host_key(), _printer_fingerprint(), what))
        digest = hashlib.sha256(key.encode()).hexdigest()[:24]
        if digest in _ADDRESSES:
            return _ADDRESSES[digest]
        path = cache_dir() / f"gm_taylor_{digest}.o"
        obj = path.read_bytes() if path.exists() else None
        if obj is None:
            obj = _compile(target(), make_ir(name))
            write_atomic(path, obj)
        (address,) = load_object(obj, (name,))
        _ADDRESSES[digest] = address
        return address
