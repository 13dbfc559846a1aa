"""The compile machinery of ``gearsweep.jit``: the kink-aware kernels' pipeline (``jit_block``:
memoized IR inlining, copy propagation) must compute what the Python functions compute, and
run Numba's untyped pipeline once per inlined function, however many call sites it has."""

import copy
from collections import Counter

import numpy as np
import pytest
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

    from numba.core.codegen import get_host_cpu_features
    from numba.core.registry import cpu_target

    features = cpu_target.target_context.codegen()._tm_features
    avx512 = "+avx512f" in get_host_cpu_features().split(",")  # NUMBA_ENABLE_AVX=0: off
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


_TWO_COPIES = '''
from gearsweep.jit import jit, jit_block, unique_name

def _make(k):
    def f(x):  # long enough that LLVM calls it rather than inlining it
        for i in range(3):
BODY
        return x + k
    return f

RENAME = {rename}
F1 = jit_block(unique_name(_make(1.0), "f_1") if RENAME else _make(1.0))
F2 = jit_block(unique_name(_make(2.0), "f_2") if RENAME else _make(2.0))

@jit
def d1(x):
    return F1(x)

@jit
def d2(x):
    return F2(x)
'''


def test_copies_of_one_function_compiled_in_two_processes_stay_apart(tmp_path):
    """Two copies of one function (the kink-aware driver of each method), each called by a cached
    driver compiled in a process of its own: a third process that loads both drivers must run
    each one's own copy. With the copies' names the same, Numba gave them the same symbol (its
    counter starts alike in every process) and the second driver ran the first one's copy."""
    import os
    import subprocess
    import sys

    from gearsweep.kernels import kink

    assert kink.INTEGRATE[kink.RK4].name != kink.INTEGRATE[kink.RK5].name
    assert (kink._FIXUPS[kink.RK4]["_fixup"].py_func.__qualname__
            != kink._FIXUPS[kink.RK5]["_fixup"].py_func.__qualname__)
    got = {}
    for rename in (False, True):
        folder = tmp_path / f"rename{rename}"
        folder.mkdir()
        body = "\n".join(f"            x = x * 0.5 + {j}.0 * x * x" for j in range(60))
        (folder / "twocopies.py").write_text(_TWO_COPIES.format(rename=rename)
                                             .replace("BODY", body))
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(folder), *sys.path]),
                   NUMBA_CACHE_DIR=str(folder / "cache"))

        def run(code, env=env):
            return subprocess.run([sys.executable, "-c", "import twocopies as t; " + code],
                                  env=env, check=True, capture_output=True, text=True).stdout

        run("t.d1(0.0)")  # each driver compiled (and cached) in a process of its own
        run("t.d2(0.0)")
        got[rename] = run("print(t.d1(0.0), t.d2(0.0), t.d1.stats.cache_hits, "
                          "t.d2.stats.cache_hits)").split()
    assert got[True][:2] == ["1.0", "2.0"]
    assert got[True][2:] != ["Counter()", "Counter()"]  # both loaded from the cache
    assert got[False][:2] == ["1.0", "1.0"]  # the failure the names prevent, still Numba's


_RUNTIME_EARLY = """\
import threading
import numpy as np
import numba
from numba.core.runtime import nrt
from gearsweep.jit import set_up_runtime_in_background

assert not nrt.rtsys._init
set_up_runtime_in_background()
set_up_runtime_in_background()  # a second call while the first runs: no second set-up
early = [t for t in threading.enumerate() if t.name == "gearsweep-nrt"]


@numba.njit(cache=False)
def f(a):  # compiled at once, racing the set-up: Numba's compiler lock orders the two
    return np.sort(a)[0] + a.sum()


print(len(early), f(np.array([3.0, 1.0, 2.0])), flush=True)
for t in early:
    t.join()
print(nrt.rtsys._init, len([t for t in threading.enumerate() if t.name == "gearsweep-nrt"]))
set_up_runtime_in_background()  # done already: nothing started
print(len([t for t in threading.enumerate() if t.name == "gearsweep-nrt"]))
"""


def test_runtime_set_up_in_background_then_compile_and_run():
    """``set_up_runtime_in_background`` (``gearsweep run`` calls it first) sets Numba's runtime up
    in one thread; a function compiled and run at once in the main thread waits for it and
    computes its result; once the runtime is set up, another call starts nothing."""
    import os
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _RUNTIME_EARLY], capture_output=True,
                         text=True, check=True, env=dict(os.environ)).stdout.split("\n")
    assert out[:3] == ["1 7.0", "True 0", "0"], out


def _twice(x):
    return 2.0 * x


def test_a_full_cache_disk_leaves_the_compiled_function_usable(monkeypatch, tmp_path):
    # Numba's disk cache is written after every compilation; a full disk (ENOSPC) there ended a
    # run before its first chunk, reported as the result file's disk being full.
    import errno

    from numba.core import caching

    def full(self, name, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(caching.IndexDataCacheFile, "_save_data", full)
    f = gj.jit(_twice)
    with pytest.warns(UserWarning, match="cache cannot be written .No space left on device"):
        assert f(1.5) == 3.0
    assert not list(tmp_path.rglob("*.nbi"))


def test_a_cache_that_cannot_be_kept_anywhere_compiles_in_the_process(monkeypatch):
    # A read-only installation run by a user whose home is not writable: Numba found no place
    # for the cache and raised RuntimeError on import of the package.
    from numba.core import caching

    monkeypatch.setattr(caching.CacheImpl, "_locator_classes", [])
    f = gj.jit(_twice)
    g = gj.jit_block_cached(_twice)
    assert f(1.5) == 3.0 and g(2.0) == 4.0
