"""Calling a model's compiled functions through their addresses, so that one compiled loop serves every model.

A loop that calls ``rhs`` by name must be compiled once per model (numba links the callee into it, and
re-optimises the linked code in every caller): for a new model that is most of its compile time. The loops
shared by all models instead take the addresses of the model's functions (``MODEL_FUNCTIONS`` of the loop
templates: ``rhs``, ``fjac``, ``grad``, ...) as C functions and call them with :func:`call_model`,
:func:`call_model4` or :func:`call_model6` (by the number of array arguments, ``prm`` included). The C twin of
a model function ``f(a_1, ..., a_k, prm)`` is ``void f_c(double *a_1, ..., double *a_k, double *prm, int64 d,
int64 n_prm)``, with ``d`` the length of ``a_1``: each array is a vector of length ``d`` or a ``d x d`` matrix
(``MODEL_ARRAYS``). The twins are numba ``cfunc``\\ s defined lazily by the generated model module
(:class:`~._native.Addresses`), cached on disk like the rest. An address is a run-time integer, so a loop is
compiled and cached once. Arrays passed must be C-contiguous (checked when the loop is compiled).
"""

from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array

__all__ = [
    "borrowed",
    "call_model",
    "call_model4",
    "call_model6",
    "kept",
    "shaped",
]


def _codegen_for(n_arrays: int) -> Any:
    """The call of a C twin with ``n_arrays`` array arguments (an intrinsic has a fixed argument list, hence one
    intrinsic per count)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        dbl = ir.DoubleType().as_pointer()
        i64 = ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [dbl] * n_arrays + [i64, i64])
        target = builder.inttoptr(args[0], fnty.as_pointer())
        arrays = [context.make_array(t)(context, builder, v) for t, v in zip(signature.args[1:], args[1:])]
        d = builder.extract_value(arrays[0].shape, 0)
        n_prm = builder.extract_value(arrays[-1].shape, 0)
        builder.call(target, [a.data for a in arrays] + [d, n_prm])
        return context.get_dummy_value()

    return codegen


def _typed(fp: Any, arrays: tuple[Any, ...]) -> Any:
    for a in arrays:
        if not (isinstance(a, types.Array) and a.dtype == types.float64 and a.layout == "C"):
            raise TypingError(f"call_model takes C-contiguous float64 arrays, got {a}")
    return types.void(fp, *arrays)


@intrinsic
def call_model(typingctx: Any, fp: Any, y: Any, out: Any, prm: Any) -> Any:
    """``f(y, out, prm)`` of the model function (``rhs``, ``grad``) whose C twin is at address ``fp``."""
    return _typed(fp, (y, out, prm)), _codegen_for(3)


@intrinsic
def call_model4(typingctx: Any, fp: Any, a: Any, b: Any, c: Any, prm: Any) -> Any:
    """``f(a, b, c, prm)`` of the model function (``fjac``, ``ghess``, ``gf_grads``, ``ghess3``) at ``fp``."""
    return _typed(fp, (a, b, c, prm)), _codegen_for(4)


@intrinsic
def call_model6(typingctx: Any, fp: Any, a: Any, b: Any, c: Any, e: Any, f: Any, prm: Any) -> Any:
    """``f(a, b, c, e, f, prm)`` of the model function (``gf_all``) at ``fp``."""
    return _typed(fp, (a, b, c, e, f, prm)), _codegen_for(6)


@intrinsic
def borrowed(typingctx: Any, a: Any) -> Any:
    """``a`` without its reference count (or each array of the tuple ``a``): the same data, shape and strides, no
    owner. numba counts the references of an array atomically each time it is passed to a function it compiled
    apart (two atomic operations per array and call: in a Taylor step with its dozen arrays, a third of the step);
    a borrowed array's count is skipped. Valid while ``a`` lives: the loops borrow only their arguments (their
    caller holds them) and the work arrays they allocate and keep (:func:`kept`) to their end; a borrowed array is
    never returned or stored."""
    given: Any = a  # numba's types are not typed for mypy
    arrays = tuple(given) if isinstance(a, types.BaseTuple) else (a,)
    if not arrays or not all(isinstance(t, types.Array) for t in arrays):
        raise TypingError(f"borrowed takes an array or a tuple of arrays, got {a}")

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        def bare(t: Any, value: Any) -> Any:
            ary = context.make_array(t)(context, builder, value)
            ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
            ary.parent = cgutils.get_null_value(ary.parent.type)
            return ary._getvalue()

        if not isinstance(signature.args[0], types.BaseTuple):
            return bare(signature.args[0], args[0])
        out = cgutils.get_null_value(context.get_value_type(signature.return_type))
        elements: Any = signature.args[0]
        for i, t in enumerate(elements):
            out = builder.insert_value(out, bare(t, builder.extract_value(args[0], i)), i)
        return out

    return a(a), codegen


@intrinsic
def kept(typingctx: Any, arrays: Any) -> Any:
    """Nothing, at run time: the arrays of the tuple ``arrays`` live to this point (numba frees an array after its
    last use; the work arrays a loop uses through :func:`borrowed` views are kept to the loop's end by this)."""
    if not isinstance(arrays, types.BaseTuple):
        raise TypingError(f"kept takes a tuple of arrays, got {arrays}")

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return context.get_dummy_value()

    return types.void(arrays), codegen


@intrinsic
def shaped(typingctx: Any, buf: Any, start: Any, shape: Any) -> Any:
    """The entries ``start``, ``start + 1``, ... of the C-contiguous vector ``buf`` as a C-contiguous array of
    ``shape`` (a tuple of integers), borrowed (:func:`borrowed`: no owner, valid while ``buf`` lives). A loop
    carves its work arrays out of one buffer its caller allocates, so that it allocates nothing itself (numba's
    ``reshape`` would call a helper of numba's runtime; this is pointer arithmetic). The caller sizes ``buf``."""
    given: Any = shape
    if not (isinstance(buf, types.Array) and buf.ndim == 1 and buf.layout == "C"):
        raise TypingError(f"shaped takes a C-contiguous vector, got {buf}")
    if not isinstance(start, types.Integer):
        raise TypingError(f"shaped takes an integer start, got {start}")
    if isinstance(shape, types.Integer):
        dims: tuple[Any, ...] = (shape,)
    elif isinstance(shape, types.BaseTuple) and len(given) and all(isinstance(t, types.Integer) for t in given):
        dims = tuple(given)
    else:
        raise TypingError(f"shaped takes a shape of integers, got {shape}")
    out = types.Array(buf.dtype, len(dims), "C")

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        src = context.make_array(signature.args[0])(context, builder, args[0])
        ary = context.make_array(out)(context, builder)
        intp = context.get_value_type(types.intp)
        if isinstance(signature.args[2], types.BaseTuple):
            extents = cgutils.unpack_tuple(builder, args[2], len(dims))
        else:
            extents = [args[2]]
        extents = [context.cast(builder, v, t, types.intp) for v, t in zip(extents, dims)]
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(buf.dtype)))
        strides = [itemsize]
        for n in reversed(extents[1:]):
            strides.insert(0, builder.mul(strides[0], n))
        offset = context.cast(builder, args[1], signature.args[1], types.intp)
        populate_array(
            ary,
            data=builder.gep(src.data, [offset]),
            shape=cgutils.pack_array(builder, extents, ty=intp),
            strides=cgutils.pack_array(builder, strides, ty=intp),
            itemsize=itemsize,
            meminfo=None,
        )
        return ary._getvalue()

    return out(buf, start, shape), codegen
