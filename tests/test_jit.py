"""The compile machinery of ``gearsweep.jit``: the kink-aware kernels' pipeline (``jit_block``:
memoized IR inlining, copy propagation) must compute what the Python functions compute, and
run Numba's untyped pipeline once per inlined function, however many call sites it has."""

import copy
from collections import Counter

import numpy as np
from numba.core import inline_closurecall, ir

from gearsweep import jit as gj


@gj.jit_inline
def _leaf(x, k):
    return x * k + 1.0


@gj.jit_inline
def _middle(a, i):
    # two call sites of _leaf, and a branch on a module global frozen by inlined_copies
    if _SCALE_TWICE:
        return _leaf(a[i], 2.0) + _leaf(a[i], 2.0)
    return _leaf(a[i], 3.0)


_SCALE_TWICE = True


def _outer(a, out):
    # three call sites of _middle (six of _leaf after its inlining)
    for i in range(a.shape[0]):
        b = a  # a copy that _CopyPropagation removes
        out[i] = _middle(b, i) + _middle(a, i) - _middle(b, i)
    return out


def _python_outer(a, twice):
    leaf = lambda x, k: x * k + 1.0  # noqa: E731
    mid = (lambda x: 2 * leaf(x, 2.0)) if twice else (lambda x: leaf(x, 3.0))
    return np.array([mid(x) for x in a])


def test_jit_block_inlines_each_function_once_and_computes_the_python_result(monkeypatch):
    calls = Counter()
    real = inline_closurecall.InlineWorker.run_untyped_passes

    def counting(self, func, enable_ssa=False):
        calls[func.__name__] += 1
        return real(self, func, enable_ssa)

    monkeypatch.setattr(inline_closurecall.InlineWorker, "run_untyped_passes", counting)
    monkeypatch.setattr(gj._MemoInlineWorker, "_ir", {})
    a = np.linspace(-1.0, 2.0, 7)
    for twice in (True, False):
        copies = gj.inlined_copies({"_leaf": _leaf, "_middle": _middle},
                                   {"_SCALE_TWICE": twice})
        g = dict(_outer.__globals__, _middle=copies["_middle"])
        outer = gj.jit_block(type(_outer)(_outer.__code__, g, "_outer"))
        np.testing.assert_allclose(outer(a, np.empty_like(a)), _python_outer(a, twice),
                                   rtol=0, atol=1e-15)
    # Numba's own inliner translates _middle three times and _leaf six times per compile; the
    # memoized one once each per function (the two copies of each are two functions)
    assert calls["_middle"] == 2
    assert calls["_leaf"] == 2


def test_a_copied_scope_is_independent_of_its_original():
    loc = ir.Loc("f.py", 1)
    scope = ir.Scope(None, loc)
    x = scope.define("x", loc)
    scope.__class__ = gj._CopiedScope
    block = ir.Block(scope, loc)
    block.append(ir.Assign(ir.Const(1.0, loc), x, loc))
    twin = copy.deepcopy(block)
    assert twin.scope is not scope and twin.body[0].target.scope is twin.scope
    twin.scope.redefine("x", loc)
    twin.scope.define("y", loc)
    assert set(scope.localvars._con) == {"x"}
    assert set(twin.scope.localvars._con) == {"x", "x.1", "y"}
    assert scope.redefined == {} and twin.scope.redefined == {"x": 1}


_B2_LIKE = """
import sys, numpy as np
from gearsweep.kernels.batch import simulate
from gearsweep.kernels.tables import fourier_table
n, spp = 37, 16
w = 48 * np.linspace(1000.0, 20000.0, n) * 2 * np.pi / 60
ktab = (1.073e9 + fourier_table((179e6, 40e6, 10e6), (1, 2, 3), (0, 0, 0), spp)) / 0.1527
etab = fourier_table((5e-6, 1e-6, 0.3e-6), (1, 2, 3), (0, 0, 0), spp, derivative=2)
r = simulate(h=2 * np.pi / w / spp, damping=5500 / 0.1527, k_table=ktab, force=833 / 0.1527,
             ste_scale=-(w**2), ste_table=etab, half_gap=2e-6, n_transient=spp * 20,
             n_record=spp * 20 + 3, steps_per_period=spp)
np.save(sys.argv[1], np.column_stack([r.stats[k] for k in sorted(r.stats)] + [r.x_final]))
"""


def test_512_bit_vectors_give_the_results_of_256_bit_ones_bit_for_bit(tmp_path):
    """``_prefer_512_bit_vectors`` changes how LLVM vectorises, never a lane's arithmetic."""
    import os
    import subprocess
    import sys

    import llvmlite.binding as ll
    from numba.core.registry import cpu_target

    features = cpu_target.target_context.codegen()._tm_features
    avx512 = ll.get_host_cpu_features().get("avx512f", False)
    user_chose = os.environ.get("NUMBA_CPU_NAME") or os.environ.get("NUMBA_CPU_FEATURES") \
        or os.environ.get(gj.VECTOR_BITS_ENV) == "256"
    assert features.endswith(",-prefer-256-bit") == (avx512 and not user_chose)
    out = {}
    for bits in ("512", "256"):
        env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / f"cache{bits}"))
        env[gj.VECTOR_BITS_ENV] = bits
        env.pop("NUMBA_CPU_FEATURES", None)
        env.pop("NUMBA_CPU_NAME", None)
        path = tmp_path / f"r{bits}.npy"
        subprocess.run([sys.executable, "-c", _B2_LIKE, str(path)], env=env, check=True)
        out[bits] = np.load(path)
    assert np.isfinite(out["256"]).all(axis=1).sum() >= 30  # two low speeds diverge at 16 steps
    assert np.array_equal(out["512"], out["256"], equal_nan=True)
