"""Calling a model's compiled right-hand side through its address, so that one compiled loop serves every model.

A loop that calls ``rhs`` by name must be compiled once per model (numba links the callee into it, and
re-optimises the linked code in every caller): for the adaptive loops that is most of a new model's compile
time. The loops shared by all models instead take the address of the model's ``rhs`` as a C function
``void(double *y, double *out, double *prm, int64 d, int64 n_prm)`` (a numba ``cfunc`` defined lazily by the
generated model module, cached on disk like the rest) and call it with :func:`call_model`. The address is a
run-time integer, so the loop is compiled and cached once. Arrays passed must be contiguous.
"""

from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["call_model", "RHS_SIGNATURE"]

#: The C signature of a model's right-hand side for :func:`call_model`.
RHS_SIGNATURE = "void(CPointer(float64), CPointer(float64), CPointer(float64), int64, int64)"


@intrinsic
def call_model(typingctx: Any, fp: Any, y: Any, out: Any, prm: Any) -> Any:
    """``rhs(y, out, prm)`` of the model whose C right-hand side is at address ``fp`` (contiguous float64 arrays;
    ``out`` as long as ``y``)."""
    sig = types.void(fp, y, out, prm)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        dbl = ir.DoubleType().as_pointer()
        i64 = ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [dbl, dbl, dbl, i64, i64])
        target = builder.inttoptr(args[0], fnty.as_pointer())
        arrays = [context.make_array(t)(context, builder, v) for t, v in zip(signature.args[1:], args[1:])]
        d = builder.extract_value(arrays[0].shape, 0)
        n_prm = builder.extract_value(arrays[2].shape, 0)
        builder.call(target, [arrays[0].data, arrays[1].data, arrays[2].data, d, n_prm])
        return context.get_dummy_value()

    return sig, codegen
