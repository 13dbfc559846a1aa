"""The one place that sets Numba's JIT options for every kernel of the package.

``cache=True``: compiled once per machine and kept in ``__pycache__`` (a run loads, not compiles).
``nogil=True``: dask threads and Python threads can run kernels side by side.
``error_model="numpy"``: division by zero gives inf/nan as in NumPy instead of raising, and lets
LLVM vectorise divisions.
``fastmath={"contract"}``: only fused multiply-add contraction (what gcc does by default with
``-ffp-contract=fast``); no reassociation, no finite-math assumptions, so NaN/inf still flag
diverged cases and results agree with plain IEEE arithmetic to a few ulp.
"""

import contextlib
import copy
import importlib.util
import os
import pickle
import sys
import threading
import types
import warnings
from collections import Counter, defaultdict
from pathlib import Path

import numba
from numba.core import ir, ir_utils, postproc
from numba.core.analysis import compute_cfg_from_blocks
from numba.core.compiler import CompilerBase, DefaultPassBuilder
from numba.core.compiler_machinery import FunctionPass, register_pass
from numba.core.inline_closurecall import InlineWorker, callee_ir_validator
from numba.core.typed_passes import NopythonRewrites
from numba.core.untyped_passes import InlineInlinables

VECTOR_BITS_ENV = "GEARSWEEP_VECTOR_BITS"
"""Environment variable: ``256`` keeps LLVM's own preference for 256-bit vectors on AVX-512
machines (see ``_prefer_512_bit_vectors``)."""


def _prefer_512_bit_vectors() -> None:
    """On a CPU with AVX-512, let LLVM vectorise with 512-bit registers.

    LLVM's tuning for Intel's AVX-512 CPUs prefers 256-bit vectors (older ones lowered their
    clock under 512-bit work), which leaves the lane loops 16 vector registers: the RK4 step, its
    constants and the running statistics of a lane do not fit, and every recorded step moves
    them through memory. With 512-bit vectors (32 registers, 8 lanes each) B1 runs 1.3 and B2
    1.4 times faster on one core (``scripts/bench_kernel.py``, docs/benchmark.md), with results
    identical bit for bit (each lane's arithmetic is the same; tested).

    Numba takes the target's features once, when it creates its code generator (at the first
    jitted function of the process), so this runs on import, before the kernels are defined.
    It applies to every function Numba compiles in this process, and the features are part of
    Numba's cache key (code cached with other features is compiled again). Left alone: a CPU
    without AVX-512 (or with AVX off, ``NUMBA_ENABLE_AVX=0``), a target the user chose
    (``NUMBA_CPU_NAME`` or ``NUMBA_CPU_FEATURES``), a code generator that already exists, and
    ``GEARSWEEP_VECTOR_BITS=256``."""
    if os.environ.get(VECTOR_BITS_ENV, "512").strip() == "256":
        return
    if numba.config.CPU_NAME is not None or numba.config.CPU_FEATURES is not None:
        return
    from numba.core.registry import cpu_target

    if "_toplevel_target_context" in vars(cpu_target):  # pragma: no cover - compiled before
        return
    from numba.core.codegen import get_host_cpu_features

    features = get_host_cpu_features()  # Numba's own: '' where LLVM cannot tell, AVX off if
    if "+avx512f" in features.split(","):  # NUMBA_ENABLE_AVX=0
        numba.config.CPU_FEATURES = features + ",-prefer-256-bit"


_prefer_512_bit_vectors()

OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": {"contract"}}


def _cached(**options):
    """``numba.njit(**options)`` for a function kept in Numba's disk cache, or compiled in every
    process where no cache can be kept: Numba raises at import (``RuntimeError``, no locator
    available) when neither ``__pycache__`` beside the package nor the user's cache folder
    (``NUMBA_CACHE_DIR``, ``~/.cache``) can be written, a read-only installation run by a user
    without a writable home."""
    cached = numba.njit(**options)
    uncached = numba.njit(**{**options, "cache": False})

    def decorate(func):
        try:
            return cached(func)
        except RuntimeError as exc:
            if "no locator available" not in str(exc):
                raise
            return uncached(func)
    return decorate


def _save_overload_or_skip() -> None:
    """A specialisation that Numba cannot write to its disk cache (a full disk, a folder made
    read-only meanwhile) is used as compiled, and compiled again by the next process: Numba's
    own ``Cache.save_overload`` raises the ``OSError``, which ended the run before its first
    chunk and was reported as the result file's disk being full."""
    from numba.core import caching

    cls = getattr(caching, "Cache", None)
    real = vars(cls).get("save_overload") if cls is not None else None
    if real is None:  # pragma: no cover - another Numba layout
        return

    def save_overload(self, sig, data):
        try:
            real(self, sig, data)
        except OSError as exc:  # said once a process (Python's default filter: once per text)
            warnings.warn(f"Numba's cache cannot be written ({exc.strerror or exc}): the kernels"
                          " run as compiled, and are compiled again by every run until it can"
                          " (NUMBA_CACHE_DIR moves it)", stacklevel=2)

    cls.save_overload = save_overload


_save_overload_or_skip()

jit = _cached(**OPTIONS)
"""Decorator for scalar kernels and helpers."""


def ready(dispatcher, args: tuple) -> bool:
    """Whether ``dispatcher`` (a Numba function kept in its disk cache) runs ``args`` without
    compiling: compiled for their types in this process already, or in Numba's disk cache for
    this machine and this source.

    Asks Numba's cache what the dispatcher asks before compiling (``Cache.load_overload``: the
    index entry of the call's type signature and this machine's code generator, valid while the
    source file's stamp is the index's) without loading or compiling anything. ``False`` where
    the cache cannot be read the way this Numba version keeps it (an estimate then counts the
    compile)."""
    sig = tuple(dispatcher.typeof_pyval(a) for a in args)
    if sig in dispatcher.overloads:
        return True
    try:
        cache = dispatcher._cache
        key = cache._index_key(sig, dispatcher.targetctx.codegen())
        name = cache._cache_file._load_index().get(key)
        folder = cache.cache_path
    except (AttributeError, TypeError, ValueError, EOFError, OSError, pickle.UnpicklingError):
        return False  # another Numba's cache
    return name is not None and os.path.isfile(os.path.join(folder, name))

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


def inlined_copies(funcs: dict, constants: dict | None = None, keep: tuple = (),
                   tag: str = "") -> dict:
    """``jit_inline`` copies of jitted functions of one module (name -> dispatcher), whose calls
    of one another go to the copies; the functions named in ``keep`` are copied as functions of
    their own (``jit_block``: a scalar path for rare lanes, with its helpers inlined into it).
    ``constants``: module globals that the copies see with other values. Numba freezes globals
    into the code, so a branch on one is pruned before inlining: the RK4 copies of the
    kink-aware helpers do not inline, type and lower the RK5 code, and vice versa.
    ``tag``: appended to the names of the ``keep`` copies, which must differ from those of the
    other copies of the same function (see ``unique_name``).

    For the kink-aware drivers: with their helpers inlined by LLVM they ran B2 6.5 times slower
    (1.65-1.73 s against 0.26-0.31 s, ``scripts/bench_kink.py --threads 1``, same amplitudes):
    the literal flags they take (``rec``, ``kink``) stay run-time branches that stop
    vectorisation. Inlined at Numba IR level the flags are pruned; the plain drivers keep the
    LLVM-inlined helpers."""
    shared = None
    out = {}
    for name, d in funcs.items():
        f = d.py_func
        if shared is None:
            shared = dict(f.__globals__)
            shared.update(constants or {})
        copy_ = types.FunctionType(f.__code__, shared, f.__name__, f.__defaults__, f.__closure__)
        if name in keep:
            out[name] = jit_block(unique_name(copy_, f"{f.__name__}_{tag}" if tag else f.__name__))
        else:
            out[name] = jit_inline(copy_)
    if shared is not None:
        shared.update(out)
    return out


def unique_name(func: types.FunctionType, name: str) -> types.FunctionType:
    """``func`` renamed ``name`` (``__name__`` and ``__qualname__``), for a function compiled on
    its own (not inlined) of which other copies exist: the drivers per combination of terms, the
    kink block and its scalar fix-up per method.

    Numba names a compiled function's symbol after its module, qualified name and argument types
    and a counter of the process that compiled it. Two copies of one function (same qualified
    name) compiled in two processes can get the same symbol, and when a third process loads
    both drivers from the cache, the second one's calls are linked to the first one's copy: the
    kink-aware RK5 driver ran the RK4 block (its fitted order 4.06 instead of 5.1 in
    ``tests/test_precision.py``; the mechanism: ``tests/test_jit.py``)."""
    func.__name__ = func.__qualname__ = name
    return func


@register_pass(mutates_CFG=False, analysis_only=False)
class _CopyPropagation(FunctionPass):
    """Replace every variable that is only ever a copy of another variable (one definition each,
    ``a = b``, same type) by that variable, and drop the copies.

    Numba's IR inliner binds each argument of an inlined call to a new variable; a new variable
    that holds an array (or a tuple of them) is reference-counted, and in the lane loops those
    calls into Numba's runtime stop LLVM from vectorising. With one definition each, ``b`` cannot
    change after ``a = b`` and ``a`` holds its value wherever it is read, so the replacement is
    exact. (Numba's own copy propagation, which its parallel pipeline runs over a ``prange`` body,
    solves a data-flow problem over every block: 6.5 of the kink-aware RK5 driver's 40 s.)"""

    _name = "gearsweep_copy_propagation"

    def __init__(self):
        FunctionPass.__init__(self)

    def run_pass(self, state):
        blocks, typemap = state.func_ir.blocks, state.typemap
        defs = Counter(st.target.name for b in blocks.values() for st in b.body
                       if isinstance(st, ir.Assign))
        copy_of = {}
        for b in blocks.values():
            for st in b.body:
                if isinstance(st, ir.Assign) and isinstance(st.value, ir.Var):
                    a, v = st.target.name, st.value.name
                    if defs[a] == 1 and defs[v] == 1 and typemap[a] == typemap[v]:
                        copy_of[a] = st.value
        if not copy_of:
            return False

        def root(var):
            while var.name in copy_of:
                var = copy_of[var.name]
            return var

        ir_utils.replace_vars(blocks, {a: root(v) for a, v in copy_of.items()})
        for b in blocks.values():
            b.body = [st for st in b.body if not (isinstance(st, ir.Assign)
                                                  and isinstance(st.value, ir.Var)
                                                  and st.value.name == st.target.name)]
        state.func_ir._definitions = ir_utils.build_definitions(blocks)
        return True


class _MemoInlineWorker(InlineWorker):
    """Numba's inliner, running the untyped pipeline over each callee once per process instead
    of once per call site (``inline_ir`` copies the IR it is given before changing it, so one
    IR serves every call site). The IR depends on the function only: its globals are frozen
    when it is first translated, and every ``jit_block`` function has the same options."""

    _ir: dict = {}
    """(Python function, SSA flag) -> the callee's IR after the untyped pipeline."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._compiler_pipeline = _untyped_pipeline  # the callees' own inlining memoized too

    def run_untyped_passes(self, func, enable_ssa=False):
        key = (func, enable_ssa)
        found = self._ir.get(key)
        if found is None:
            found = self._ir[key] = super().run_untyped_passes(func, enable_ssa)
            for block in found.blocks.values():
                if type(block.scope) is ir.Scope:
                    block.scope.__class__ = _CopiedScope
        else:
            self.flags.enable_ssa = enable_ssa  # as the pipeline run would have set it
        return found


class _CopiedScope(ir.Scope):
    """The scope of a callee's IR that ``_MemoInlineWorker`` keeps, copied cheaply.

    The inliner copies a callee's blocks one by one with ``copy.deepcopy``, and every block (and
    every variable in it) carries the scope, which lists all of the callee's variables: each
    inlining copied every variable once per block (a callee of 100 blocks and 1000 variables,
    100,000 objects). The inliner only reads the names and places of the listed variables and
    defines new ones in the copy; this copy shares the listed (immutable) variables and copies
    the tables that the copy's definitions change."""

    def __deepcopy__(self, memo):
        new = copy.copy(self)
        new.localvars = copy.copy(self.localvars)
        new.localvars._con = dict(self.localvars._con)
        new.redefined = defaultdict(int, self.redefined)
        new.var_redefinitions = defaultdict(set, {k: set(v) for k, v in
                                                  self.var_redefinitions.items()})
        memo[id(self)] = new
        return new


@register_pass(mutates_CFG=True, analysis_only=False)
class _MemoInlineInlinables(InlineInlinables):
    """Numba's ``inline_inlinables`` pass, with ``_MemoInlineWorker``.

    Numba runs its whole untyped pipeline, inlining included, over the bytecode of a function
    it inlines at every call site and at every level: the kink-aware block inlines the lane
    steps, whose helpers inline theirs, and the same helpers were translated and inlined again
    for every call (6.3 of the kink-aware RK4 block's 18 s). The loop is Numba's own
    (``InlineInlinables.run_pass``); only the worker differs."""

    _name = "gearsweep_inline_inlinables"

    def run_pass(self, state):
        worker = _MemoInlineWorker(state.typingctx, state.targetctx, state.locals,
                                   state.pipeline, state.flags, validator=callee_ir_validator)
        modified = False
        work_list = list(state.func_ir.blocks.items())
        while work_list:
            _, block = work_list.pop()
            for i, instr in enumerate(block.body):
                if isinstance(instr, ir.Assign) and isinstance(instr.value, ir.Expr) \
                        and instr.value.op == "call":
                    if ir_utils.guard(self._do_work, state, work_list, block, i, instr.value,
                                      worker):
                        modified = True
                        break  # the block was split: its rest is on the work list
        if modified:
            cfg = compute_cfg_from_blocks(state.func_ir.blocks)
            for dead in cfg.dead_nodes():
                del state.func_ir.blocks[dead]
            postproc.PostProcessor(state.func_ir).run()
            state.func_ir.blocks = ir_utils.simplify_CFG(state.func_ir.blocks)
        return True


def _memo_inlining(pm):
    """``pm`` with Numba's ``InlineInlinables`` replaced by ``_MemoInlineInlinables``."""
    pm.passes = [(_MemoInlineInlinables if p is InlineInlinables else p, d) for p, d in pm.passes]
    pm.finalize()
    return pm


def _untyped_pipeline(state):
    """Numba's untyped pipeline (what its inliner runs over a callee), inlining memoized."""
    return _memo_inlining(DefaultPassBuilder.define_untyped_pipeline(state))


class _InlinedCompiler(CompilerBase):
    """Numba's nopython pipeline with memoized inlining (``_MemoInlineInlinables``) and
    ``_CopyPropagation`` where the parallel pipeline has its passes: after type inference and the
    phi nodes stripped; without Numba's post-inference rewrites (``NopythonRewrites``).

    Those rewrites fuse array expressions and fold constant arrays and string literals, none of
    which the kink-aware functions have; the pass itself computes the variables' lifetimes over
    the whole inlined body: 0.6 s of the 10.9 s a cold cache spent on the kink-aware RK4
    specialisation of ``studies/rattle_kink_aware.yaml`` (medians of 3 alternating runs of
    ``scripts/bench_compile.py``, 26 Nov 2026), the same code (``scripts/bench_kink.py``: the
    same time, the same amplitudes)."""

    def define_pipelines(self):
        pm = DefaultPassBuilder.define_nopython_pipeline(self.state)
        pm.add_pass_after(_CopyPropagation, NopythonRewrites)
        pm.passes = [(p, d) for p, d in pm.passes if p is not NopythonRewrites]
        return [_memo_inlining(pm)]


jit_block = numba.njit(pipeline_class=_InlinedCompiler, **{**OPTIONS, "cache": False})
"""Decorator for functions whose helpers are inlined at Numba IR level and which other compiled
functions call (the kink-aware fix-ups' scalar path, ``inlined_copies``; ``jit_block_cached``
for the kink-aware drivers' block ranges). Every inlined call binds its arguments to new
variables, and a new variable that holds an array is reference-counted: in the lane loops, calls
into Numba's runtime that stop LLVM from vectorising (B2's kink-aware kernel ran 6.4 times
slower). Copy propagation removes those copies, as Numba's parallel pipeline does for a
``prange`` body, without that pipeline's passes over the whole body (compiled inside the
``prange`` loop, the kink-aware RK4 driver took 73 s to compile, of which 28 s in parfor
fusion; as a function of its own compiled with this pipeline, see docs/benchmark.md)."""


jit_block_cached = _cached(pipeline_class=_InlinedCompiler, **OPTIONS)
"""``jit_block`` for a function called from Python (the kink-aware drivers' block ranges): its
own entry in Numba's disk cache."""


def _blas_check_without_import() -> None:
    """Numba's set-up on the first kernel call asks whether SciPy's BLAS is there by importing
    ``scipy.linalg`` (``numba.np.arraymath._check_blas``): 0.2 s of every run, which uses no BLAS.
    That one question is answered from the files instead (the extension module is there or
    not: the same answer); every other caller of ``ensure_blas`` (Numba compiling a linear
    algebra function) still gets Numba's own, import and checks included."""
    if "numba.np.arraymath" in sys.modules:
        return
    try:
        from numba.np import linalg
    except ImportError:  # pragma: no cover - another Numba layout: leave it alone
        return
    real = getattr(linalg, "ensure_blas", None)
    if real is None:  # pragma: no cover
        return

    def ensure_blas():
        if sys._getframe(1).f_code.co_name == "_check_blas" and _scipy_blas_installed():
            return None
        return real()

    linalg.ensure_blas = ensure_blas


def _scipy_blas_installed() -> bool:
    spec = importlib.util.find_spec("scipy")
    return spec is not None and spec.submodule_search_locations is not None and any(
        any(Path(d, "linalg").glob("cython_blas.*")) for d in spec.submodule_search_locations)


_blas_check_without_import()


@contextlib.contextmanager
def cache_loads_without_set_up():
    """Within: a specialisation Numba finds in its disk cache is loaded without first setting up
    its compiler (only its runtime, NRT, which the cached code calls).

    Numba's ``Cache.load_overload`` refreshes the target context before every load: on the
    first, that imports and installs every typing and lowering registry Numba has (random
    generators, typed containers, polynomials, datetimes, ...), 60-90 ms of every run's start
    on the 2-core machine, 70 % of the warm-up of a tiny study (26 Nov 2026). Loading and
    calling compiled code needs none of it: the code is linked against NRT and the C math
    functions (set up with the context) and dispatched on the argument types. Anything that
    compiles (a cache miss, another function) still sets up everything first: Numba's compiler
    refreshes both contexts itself (``CompilerBase.__init__``), so this is safe around code
    that may compile too. Where Numba's internals are not as expected (another version), this
    does nothing."""
    from numba.core import caching
    from numba.core.runtime import nrt

    cls = getattr(caching, "Cache", None)
    real = vars(cls).get("load_overload") if cls is not None else None
    if real is None or not all(hasattr(cls, n) for n in (
            "_load_overload", "_guard_against_spurious_io_errors")) or not hasattr(nrt, "rtsys"):
        yield  # pragma: no cover - another Numba layout: Numba's own loads
        return

    def load_overload(self, sig, target_context):
        nrt.rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)
        return None  # the guard swallowed an I/O error: not in the cache, as in Numba's own

    cls.load_overload = load_overload
    try:
        yield
    finally:
        cls.load_overload = real


def set_up_runtime_in_background() -> None:
    """Start setting up Numba's runtime (NRT) in a background thread, now.

    Every kernel call needs NRT, set up in the process before the first compiled function is
    loaded (``cache_loads_without_set_up``): Numba builds its small LLVM module and has LLVM
    optimise and compile it, 15 ms on the 2-core machine, the first LLVM compilation of the
    process. llvmlite calls LLVM through ctypes, which lets go of the GIL, so in a thread most
    of it runs on another core beside the command's Python work that follows (reading the
    study, the plan), instead of after it, in the warm-up. A 1e6-case ``gearsweep run`` on the
    2-core machine, from the imports' end to the warm-up's end: 57.6 ms against 66.0 ms
    (medians of 6 alternating runs, 26 Nov 2026; the warm-up 22-26 ms instead of 37, the
    Python before it 6-7 ms longer, its share of the GIL). Numba's compiler lock
    (``initialize`` holds it) keeps any compilation or load in another thread waiting until it
    is done; a failure here is left for Numba to raise where it sets NRT up itself. Called by
    commands that end with ``os._exit`` (``cli.entry``): no C++ destructor of LLVM runs while
    this thread may still be inside LLVM."""
    from numba.core.registry import cpu_target
    from numba.core.runtime import nrt

    global _runtime_thread
    rtsys = getattr(nrt, "rtsys", None)
    if rtsys is None or getattr(rtsys, "_init", True) or _runtime_thread is not None:
        return  # another Numba layout, set up already, or being set up
    context = cpu_target.target_context

    def set_up() -> None:
        try:
            rtsys.initialize(context)
        except Exception:  # noqa: BLE001 -- raised again where Numba sets NRT up itself
            pass

    _runtime_thread = threading.Thread(target=set_up, name="gearsweep-nrt", daemon=True)
    _runtime_thread.start()


_runtime_thread: threading.Thread | None = None
"""The thread of ``set_up_runtime_in_background``, once started."""
