"""A float vector on the stack of a compiled function (the loop's state vector).

An array the time loop allocates with :func:`stack_vector` lives in the function's own
frame: indexed with the layout's constant indices and never handed to a function that is
not inlined, LLVM keeps its entries in registers (scalar replacement), so a state vector
costs no more than the same number of local variables.
"""

from __future__ import annotations

from numba import carray, types
from numba.core import cgutils
from numba.extending import intrinsic

from vehval.numba_cache import njit


@intrinsic
def _stack_buffer(typingctx, size):
    """Pointer to ``size`` float64 allocated on the stack of the calling frame."""

    def codegen(context, builder, signature, args):
        ty = context.get_value_type(types.float64)
        return cgutils.alloca_once(builder, ty, size=args[0])

    return types.CPointer(types.float64)(types.intp), codegen


@njit(cache=True, inline="always")
def stack_vector(n):
    """Float64 vector of ``n`` (a compile-time constant) entries on the stack, zeroed: a
    raw pointer indexed like an array (``x[k]``), with no reference counting."""
    x = _stack_buffer(n)
    for k in range(n):
        x[k] = 0.0
    return x


@intrinsic
def _data_pointer(typingctx, arr):
    """Pointer to the data of a C-contiguous array."""

    def codegen(context, builder, signature, args):
        return context.make_array(arr)(context, builder, args[0]).data

    return types.CPointer(arr.dtype)(arr), codegen


@njit(cache=True, inline="always")
def borrowed(a):
    """A view of the C-contiguous array ``a`` without reference counting (valid while ``a``
    lives): the loop's map tables, read every step, then cost no counter updates."""
    return carray(_data_pointer(a), a.shape)


@njit(cache=True, inline="always")
def borrowed_maps(m):
    """:func:`borrowed` views of the 18 map tables (:data:`vehval.sim.packing.MAP_NAMES`)."""
    return (borrowed(m[0]), borrowed(m[1]), borrowed(m[2]), borrowed(m[3]), borrowed(m[4]),
            borrowed(m[5]), borrowed(m[6]), borrowed(m[7]), borrowed(m[8]), borrowed(m[9]),
            borrowed(m[10]), borrowed(m[11]), borrowed(m[12]), borrowed(m[13]),
            borrowed(m[14]), borrowed(m[15]), borrowed(m[16]), borrowed(m[17]))
