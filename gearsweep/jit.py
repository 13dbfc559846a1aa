"""The one place that sets Numba's JIT options for every kernel of the package.

``cache=True``: compiled once per machine and kept in ``__pycache__`` (a run loads, not compiles).
``nogil=True``: dask threads and Python threads can run kernels side by side.
``error_model="numpy"``: division by zero gives inf/nan as in NumPy instead of raising, and lets
LLVM vectorise divisions.
``fastmath={"contract"}``: only fused multiply-add contraction (what gcc does by default with
``-ffp-contract=fast``); no reassociation, no finite-math assumptions, so NaN/inf still flag
diverged cases and results agree with plain IEEE arithmetic to a few ulp.
"""

import types

import numba

OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": {"contract"}}

jit = numba.njit(**OPTIONS)
"""Decorator for scalar kernels and helpers."""

jit_helper = numba.njit(**{**OPTIONS, "cache": False})
"""Decorator for the helpers of the kernels (right-hand sides, dead zone, lane loops, fix-ups).

Each is compiled once per signature in the process that compiles a driver, and LLVM inlines it
into the drivers that call it. Not ``inline="always"``: inlining at Numba IR level made Numba's
``inline_inlinables`` pass the largest part of every specialisation's compile (the B1 driver:
58 of 100 s, with the parfor and type-inference passes over the inlined IR most of the rest; 4 s
without it), while LLVM inlines the same calls into code of the same speed (B1 and B2 of
``scripts/bench_kernel.py``: CPU seconds equal within 1 %, amplitudes identical bit for bit;
docs/benchmark.md). The kink-aware drivers call ``inlined_copies`` of them instead.

Not cached on their own (``cache=False``): a driver's cache entry holds their code, so a run that
loads a driver from the cache compiles none of them. Cached helpers would each keep a Numba index
of their own specialisations, which Numba updates by read-modify-write: two processes compiling
different specialisations at once (``batch.precompile``, dask workers on a cold cache) could
leave an index entry pointing at the other's data file."""

jit_inline = numba.njit(inline="always", **{**OPTIONS, "cache": False})
"""Decorator for helpers inlined at Numba IR level: the kink-aware driver's (see
``inlined_copies``)."""


def inlined_copies(funcs: dict) -> dict:
    """``jit_inline`` copies of ``jit_helper`` functions of one module (name -> dispatcher), whose
    calls of one another go to the copies.

    For the kink-aware drivers: with their helpers inlined by LLVM they ran B2 6.5 times slower
    (1.65-1.73 s against 0.26-0.31 s, ``scripts/bench_kink.py --threads 1``, same amplitudes):
    the lane loops and fix-ups are too large for LLVM's inliner, and not inlined, the literal
    flags they take (``rec``, ``kink``, ``rk4``) are run-time branches that stop vectorisation.
    Inlined at Numba IR level the flags are pruned as before, at the old compile cost (about a
    minute per kink-aware specialisation); the plain drivers keep the LLVM-inlined helpers."""
    shared = None
    out = {}
    for name, d in funcs.items():
        f = d.py_func
        if shared is None:
            shared = dict(f.__globals__)
        out[name] = jit_inline(types.FunctionType(f.__code__, shared, f.__name__, f.__defaults__,
                                                  f.__closure__))
    if shared is not None:
        shared.update(out)
    return out


jit_parallel = numba.njit(parallel=True, **OPTIONS)
"""Decorator for the batch drivers that spread blocks of cases over all cores with ``prange``."""
