"""Dynamic scheduling inside a ``prange`` loop, the same on every Numba threading layer.

A ``prange`` loop gives each thread a fixed share of its items (:func:`numba.set_parallel_chunksize`
changes that on the OpenMP and TBB layers, not on workqueue, and makes any reduction in the loop depend
on timing). Where the items differ widely in cost — the droplets of a batch, one ending after a step
and the next after two thousand — the threads then wait for the one that drew the longest. Here the
loop runs one lane per thread, and each lane takes the next item from a shared counter
(:func:`take`, one atomic fetch-and-add), so a thread that finishes early takes more.

Numba has no atomic operation for CPU code, hence this one intrinsic: an LLVM ``atomicrmw add`` on
element 0 of an ``int64`` array. Which lane runs which item then depends on timing, so a kernel
using it must make each item's result independent of its lane (per-lane scratch cleared per item,
results written to the item's own row); the items' results are then the same for any thread count.
The compiler does not see :func:`take` write the counter: read the counter outside the kernel.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def take(typingctx, counter):
    """counter[0] += 1 atomically; returns the value before (the index of the item taken)."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64 and counter.ndim == 1):
        return None

    def codegen(context, builder, signature, args):
        (ary_t,) = signature.args
        ary = context.make_array(ary_t)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, ary_t, ary, [context.get_constant(types.intp, 0)])
        return builder.atomic_rmw("add", ptr, context.get_constant(types.int64, 1), "monotonic")

    return types.int64(counter), codegen


__all__ = ["take"]
