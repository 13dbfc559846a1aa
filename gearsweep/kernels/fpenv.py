"""Flush-to-zero inside the kernels' blocks: subnormal numbers cost 100-200 times a normal
operation on x86 (microcode assists), and a damped case whose state decays to zero runs through
them for the rest of its steps.

Measured (one block of 13 free oscillators, RK4, 200,000 steps, one thread): 0.005 s while p stays
normal, 0.33-0.93 s once it has decayed below 2.2e-308; the stability studies
(``method_stability``, ``stability_rig*``: damped, unforced cases over hundreds of thousands of
steps) spent most of their time there. With ``ftz_on`` the CPU flushes results below the smallest
normal number (2.2e-308) to 0 and reads subnormal inputs as 0 (MXCSR FTZ and DAZ); every
result that stays a normal number is unchanged, bit for bit.

``ftz_on()`` returns the thread's previous MXCSR, which ``ftz_restore`` puts back: the drivers
call both around the work of each block, because each thread that steps blocks (the drivers'
pool threads and the calling Python thread, ``rk.Threaded``) has its own register, and the
Python threads' NumPy must keep IEEE subnormals. Elsewhere than x86-64 both are no-ops.
"""

import platform

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from gearsweep.jit import jit_helper

X86 = platform.machine().lower() in ("x86_64", "amd64")
"""Whether the MXCSR register (SSE) is there to set."""

FTZ_DAZ = np.uint32(0x8040)
"""MXCSR bits flush-to-zero (15) and denormals-are-zero (6)."""


def _mxcsr(module: ir.Module, name: str) -> ir.Function:
    fty = ir.FunctionType(ir.VoidType(), [ir.IntType(8).as_pointer()])
    fn = module.globals.get(name)
    return fn if fn is not None else ir.Function(module, fty, name)


@intrinsic
def _mxcsr_swap(typingctx, bits):
    """Load ``bits`` into MXCSR; return the value it had."""
    sig = types.uint32(types.uint32)

    def codegen(context, builder, sig, args):
        slot = builder.alloca(ir.IntType(32))
        ptr = builder.bitcast(slot, ir.IntType(8).as_pointer())
        builder.call(_mxcsr(builder.module, "llvm.x86.sse.stmxcsr"), [ptr])
        old = builder.load(slot)
        builder.store(args[0], slot)
        builder.call(_mxcsr(builder.module, "llvm.x86.sse.ldmxcsr"), [ptr])
        return old

    return sig, codegen


@intrinsic
def _mxcsr_get(typingctx):
    """The value of MXCSR."""
    sig = types.uint32()

    def codegen(context, builder, sig, args):
        slot = builder.alloca(ir.IntType(32))
        ptr = builder.bitcast(slot, ir.IntType(8).as_pointer())
        builder.call(_mxcsr(builder.module, "llvm.x86.sse.stmxcsr"), [ptr])
        return builder.load(slot)

    return sig, codegen


if X86:

    @jit_helper
    def ftz_on():
        """Set FTZ and DAZ in this thread; return the previous MXCSR (for ``ftz_restore``)."""
        return _mxcsr_swap(_mxcsr_get() | FTZ_DAZ)

    @jit_helper
    def ftz_restore(old):
        """Put back the MXCSR that ``ftz_on`` returned."""
        _mxcsr_swap(old)

else:

    @jit_helper
    def ftz_on():
        return np.uint32(0)

    @jit_helper
    def ftz_restore(old):
        return None
