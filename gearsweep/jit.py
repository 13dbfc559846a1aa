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

jit_inline = numba.njit(inline="always", **OPTIONS)
"""Decorator for tiny helpers (right-hand sides, dead zone) inlined at Numba IR level."""

jit_parallel = numba.njit(parallel=True, **OPTIONS)
"""Decorator for the batch drivers that spread blocks of cases over all cores with ``prange``."""
