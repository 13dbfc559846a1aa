"""The one place that sets Numba's JIT options for every kernel of the package.

``cache=True``: compiled once per machine and kept in ``__pycache__`` (a run loads, not compiles).
``nogil=True``: dask threads and Python threads can run kernels side by side.
``error_model="numpy"``: division by zero gives inf/nan as in NumPy instead of raising, and lets
LLVM vectorise divisions.
``fastmath={"contract"}``: only fused multiply-add contraction (what gcc does by default with
``-ffp-contract=fast``); no reassociation, no finite-math assumptions, so NaN/inf still flag
diverged cases and results agree with plain IEEE arithmetic to a few ulp.
"""

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
docs/benchmark.md).

Not cached on their own (``cache=False``): a driver's cache entry holds their code, so a run that
loads a driver from the cache compiles none of them. Cached helpers would each keep a Numba index
of their own specialisations, which Numba updates by read-modify-write: two processes compiling
different specialisations at once (``batch.precompile``, dask workers on a cold cache) could
leave an index entry pointing at the other's data file."""

jit_parallel = numba.njit(parallel=True, **OPTIONS)
"""Decorator for the batch drivers that spread blocks of cases over all cores with ``prange``."""
