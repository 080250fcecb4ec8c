"""Software prefetch: ask the CPU to start loading an array row before the code reads it.

An event of a large system (N >~ 1e5) touches particles whose rows are far apart in memory and
not in any cache: the calendar orders events by time, not by place. Reading the rows of a
neighbour list one pair test after the other waits for each load in turn (a branch on every test
keeps the CPU from running far ahead); issuing all loads first lets them overlap
(benchmarks/README.md, "Large N").
"""

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def prefetch(typingctx, arr, j):
    """Prefetch the cache line of ``arr[j]`` (the start of row ``j`` of a 2-D array) for reading.

    A hint only (LLVM's ``llvm.prefetch``: read, keep in all cache levels): it never faults, not
    even for an index out of bounds, and changes no result.

    Example:
        >>> import numpy as np
        >>> from numba import njit
        >>> @njit
        ... def first_of_row(P, j):
        ...     prefetch(P, j)
        ...     return P[j, 0]
        >>> float(first_of_row(np.arange(16.0).reshape(2, 8), 1))
        8.0
    """
    if not isinstance(arr, types.Array) or not isinstance(j, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        aryty, jty = signature.args
        ary = context.make_array(aryty)(context, builder, args[0])
        index = [context.cast(builder, args[1], jty, types.intp)] + [context.get_constant(types.intp, 0)] * (aryty.ndim - 1)
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, index, wraparound=False, boundscheck=False)
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]), "llvm.prefetch.p0i8")
        builder.call(fn, [builder.bitcast(ptr, i8p), ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return types.void(arr, j), codegen
