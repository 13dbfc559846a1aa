"""What an analysis study will cost, from arithmetic on its options: no integration, no compile.

An analysis study is computed in one piece, but its options reach far: ``work_precision`` with
``copies: 1000000`` and ``transient_periods: 100000`` validated and then ran for days (an outside
tester's finding, 27 Nov 2026). ``estimate`` counts each kind's work in its own unit and prices
it at rates measured on the 2-core machine this project is developed on (27 Nov 2026, medians of
a few runs; ``tests/test_analysis_cost.py`` checks the estimate against a run's own time), so that
``gearsweep validate``, ``gearsweep run`` (and ``--estimate``) and ``gearsweep.run`` say it, and
refuse beyond ``execute.LIMITS`` unless confirmed, as for a dynamic study. Rates are stated
floors, like ``execute.STATED_RATE`` for the kernel: a faster machine runs in less.

What is counted, per kind:

* ``method_stability``: 22 bisection trials of ``steps`` kernel steps for each method, its damping
  ratios in blocks of ``LANES`` cases (``stability.measured_step_limit``), at ``STATED_RATE``.
* ``artifact_map``: per tableau and step count, ``steps_per_period`` products of 2 x 2 stage
  matrices over the rig's speed x damping grid (``stability.tableau_monodromy``: NumPy over the
  grid, a fixed cost per step) and the paper's criterion; the grid is the rig result's, read
  from its file's dimensions (not there yet: priced at ``RIG_POINTS_UNKNOWN``).
* ``work_precision``: per scene, the reference solution (scipy DOP853 at rtol 1e-12 with crossing
  events, or the exact piecewise solution and its DOP853 cross-check without stiffness ripple),
  every peer at every rtol (scipy's ``solve_ivp`` with a Python right-hand side: evaluations per
  radian of the scene's fastest motion, growing as rtol^-q), and every fixed-step method at
  every step count on ``copies`` cases, ``repeat`` times, at ``STATED_RATE`` (``KINK_COST`` for
  the kink-aware step). Memory: the kernel's recorded signal of ``copies`` cases, and the
  largest scene's reference solution: DOP853's dense output keeps an interpolant per step
  (``REFERENCE_STEPS_PER_RADIAN`` steps per radian of the scene's fastest motion over the
  integrated time, ``DENSE_STEP_BYTES`` each: 250 MB at 3,020 periods of the whine scene).
* ``rattle_balance``: the harmonic-balance branch, growing with its harmonics and time samples
  (1.6 s at its study's 25 and 1,024; 66.5 s at the schema's most, 200 and 65,536); memory: its
  matrices of harmonics x samples (about 1 GB at the most).
* ``rattle_budget``, ``jump_map``: a fixed time (they read results and integrate nothing).

Compiling, every kind: where Numba's disk cache lacks what the study compiles (the batch kernel's
specialisations of ``method_stability`` and ``work_precision``, ``rattle_balance``'s Floquet
monodromy ``hb._monodromy``), the one-time compile's time and memory, as for a dynamic study
(``compile_cost``): the first run of studies/work_precision.yaml compiled for 56 s and peaked at
806 MB resident against 283 MB on the cache it filled, and was estimated at 13.7 s and 306 MB.

Memory, every kind: the results it reads are loaded whole, counted from their files' headers
(``input_bytes``), and while they load, the chunks HDF5 keeps in each variable's chunk cache
until the file closes (``loading_bytes``); ``jump_map``: then its jump summary's arrays
(``JUMP_MAP_BYTES`` per value of the input's p_pp), in the memory the chunk caches let go.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import netCDF4
import numpy as np

from gearsweep.analysis import hb
from gearsweep.analysis import precision as pr
from gearsweep.analysis import stability as st
from gearsweep.analysis.advise import KINK_COST
from gearsweep.errors import LimitError
from gearsweep.jit import ready
from gearsweep.kernels import LANES, rk
from gearsweep.kernels.batch import (
    COLD_COMPILE_BYTES,
    COLD_COMPILE_SECONDS,
    compile_peak,
    not_compiled,
)
from gearsweep.study.analysis_specs import (
    AnalysisStudy,
    ArtifactMap,
    MethodStability,
    RattleBalance,
    WorkPrecision,
)
from gearsweep.study.execute import (
    BASELINE_MEMORY,
    LIMITS,
    STATED_RATE,
    _duration,
    _size,
    kernel_threads,
)

BISECTION_TRIALS = 22
"""Trials of ``stability.measured_step_limit`` (its ``iterations``) per method."""

MONODROMY_CALL_SECONDS = 0.05
"""``artifact_map``: fixed time per tableau and step count (the criterion, the multipliers)
[s]; measured 0.049-0.054 s."""
MONODROMY_STEP_SECONDS = 5e-5
"""... per step of the period, whatever the grid [s] (NumPy's cost per call)."""
MONODROMY_POINT_STEP_SECONDS = 4.2e-7
"""... per step and grid point [s] (768 and 7,680 points, 100-400 steps: 0.32-0.42 us)."""
RIG_POINTS_UNKNOWN = 768
"""Grid points priced where the rig result is not there yet (``studies/stability_rig.yaml``'s
96 speeds x 8 dampings)."""

REFERENCE_SECONDS_PER_RADIAN = {"whine": 1e-3, "rattle": 1e-3}
"""``work_precision``'s reference solution per radian of the scene's fastest motion over the
integrated time [s]: DOP853 at rtol 1e-12 with events 0.25-0.55 ms (whine), the exact solution
0.03-0.22 ms plus its DOP853 cross-check 0.43 ms (rattle), on the idle machine; Python's speed
varies more between machines than the kernel's, so about twice that is stated."""
REFERENCE_STEPS_PER_RADIAN = 5.0
"""Steps of the reference's DOP853 (rtol 1e-12) per radian of the scene's fastest motion
(``_radians``) [1]: 1.75-4.36 measured (the whine scene at 500-100,000 rpm, the rattle scene's
cross-check with its crossings as events at 3,000-30,000 rpm; 4.36 at the study's 6,000 rpm). An
adaptive solver's steps are not known before it runs: stated above the most measured."""
DENSE_STEP_BYTES = 1000
"""Resident memory of one step of the reference's DOP853 solution with dense output [bytes],
counted: the step's interpolant (``Dop853DenseOutput``: its object and attribute values, 160 B;
its 7 x 2 coefficients F and its start state, two ndarrays of 96 B with data and shape blocks of
128 + 48 and 32 + 32 B from malloc; its end time and step, numpy scalars of 32 B) and its slots
in the solution's lists (16 B): 672 B held (759 B resident measured at 252,313 steps, 569 B
traced: pymalloc's pools keep the holes of each step's temporaries); while ``solve_ivp`` ends,
its list of states as 2-d views for ``np.vstack`` (136 B a step) and its arrays of times and
states (24 B): 988 B a step at the peak measured (whine scene, 3,020 periods). Stated: 1,000."""
PEER_RHS_PER_RADIAN = {"whine": {"RK45": 4.5, "DOP853": 4.4, "LSODA": 4.5},
                       "rattle": {"RK45": 6.6, "DOP853": 21.5, "LSODA": 8.8}}
"""Right-hand-side evaluations of each scipy peer per radian at rtol 1e-3, per scene (the dead
zone's kinks cost the rattle scene's high-order peer most)..."""
PEER_RTOL_EXPONENT = {"RK45": 0.2, "DOP853": 0.12, "LSODA": 0.11}
"""... growing as (rtol / 1e-3)^-q (fitted over rtol 1e-3 ... 1e-10: 0.185-0.193, 0.105-0.118,
0.082-0.106)."""
PEER_RHS_SECONDS = 8e-6
"""One evaluation of the Python right-hand side inside ``solve_ivp`` [s] (3.0-4.8 us measured on
the idle machine, 13.4 s for the whole work_precision study beside three other jobs against 7.2
s alone: stated with that margin)."""

BALANCE_SECONDS = 1.5
"""``rattle_balance``: its fixed part (the describing-function curves, Eq. (15)) [s], ..."""
BALANCE_HARMONIC_SECONDS = 0.045
"""... per harmonic of the AFT branch [s] (12-100 harmonics at 512-4,096 samples: 0.99-3.99 s) ..."""
BALANCE_SAMPLE_SECONDS = 6.5e-6
"""... and per harmonic and time sample [s] (200 harmonics, 65,536 samples: 66.5 s). The three
are about 1.5 times the fit to those measurements (1.0 s, 0.031 s, 4.5e-6 s), which gave the
Fig. 8 balance 1.9 s against 1.86 s measured: a stated rate is a floor, not a fit."""
BALANCE_SAMPLE_BYTES = 56
"""... and its memory per harmonic and time sample [bytes]: ``AFTBalance``'s matrices E and P
(2H + 1 by n_time each) and their making (cos, sin); 47-55 B measured (peak resident memory at
200 x 16,384, 50 x 65,536 and 200 x 65,536: 620 MB there)."""
JUMP_MAP_BYTES = 105
"""``jump_map``: its arrays beyond the input it holds, per value of the input's ``p_pp`` [bytes]:
``jump_summary``'s amplitude, settle_error and sweeps and ``find_jumps``' arrays of each sweep,
at their peak (tracemalloc: 99.7-100.0 B measured on results/rattle_map.nc and cuts of it of
0.2-2 million values, 27 Nov 2026; 95.1-95.4 B before a sweep's settle_error, as float32, was
held through ``find_jumps`` for its support)."""
FIXED_ANALYSIS_SECONDS = {"rattle_budget": 0.5, "jump_map": 1.0}
"""The kinds that only read results [s] (measured: the Fig. 8 budget 0.03-0.05 s; the rattle map's
jumps 0.25 s, and since the jump criterion asks for known points beside a jump
(``analysis.jumps._supported``, more than half of it) 0.69-0.82 s of CPU (fc871c9's criterion;
0.62-0.68 s before it), 27 Nov 2026: 0.5 s was stated then)."""


@dataclass(frozen=True)
class AnalysisEstimate:
    """An analysis study's predicted wall time and peak memory, with what makes them up."""

    kind: str
    seconds: float
    memory_bytes: float
    parts: tuple[tuple[str, float], ...] = ()
    """(what, seconds) of the larger contributions, in words."""
    note: str = ""
    compile_seconds: float = 0.0
    """Of ``seconds``, the one-time compile of what it calls that Numba's cache lacks
    (``compile_cost``)."""
    compile_bytes: float = 0.0
    """Of ``memory_bytes``, what that compile adds to the peak."""

    def line(self) -> str:
        what = "; ".join(f"{w} {_duration(s)}" for w, s in self.parts if s >= 0.05)
        return (f"about {_duration(self.seconds)} at stated rates" + (f" ({what})" if what else "")
                + (f", peak memory about {_size(self.memory_bytes)}"
                   if math.isfinite(self.memory_bytes) else ", peak memory without bound")
                + (f" ({_size(self.compile_bytes)} of it compiling)" if self.compile_bytes else "")
                + (f"; includes about {self.compile_seconds:.0f} s to compile once (cold cache)"
                   if self.compile_seconds else "")
                + (f"; {self.note}" if self.note else ""))

    def over(self) -> list[str]:
        out = []
        if self.seconds > LIMITS.seconds:
            out.append(f"time > {_duration(LIMITS.seconds)}")
        if self.memory_bytes > LIMITS.memory_bytes:
            out.append(f"memory > {_size(LIMITS.memory_bytes)}")
        return out


def _kernel_seconds(cases: int, steps: float, method: str, threads: int) -> float:
    """A batch kernel call of ``cases`` cases of ``steps`` steps at the stated rate: blocks of
    ``LANES`` cases, one block per core at a time."""
    rounds = math.ceil(math.ceil(cases / LANES) / threads)
    return rounds * LANES * steps / (STATED_RATE[method] * 1e6)


def _method_stability(o: MethodStability, threads: int) -> AnalysisEstimate:
    s = sum(BISECTION_TRIALS * _kernel_seconds(len(o.zeta), o.steps, m, threads)
            for m in o.methods)
    trials = BISECTION_TRIALS * len(o.methods)
    return AnalysisEstimate(o.kind, s, BASELINE_MEMORY,
                            ((f"{trials} trials of {o.steps:,} steps", s),))


def _rig_points(o: ArtifactMap, results: Path | None) -> tuple[int, str]:
    path = None if results is None else Path(results) / f"{o.rig}.nc"
    if path is not None and path.exists():
        try:
            with netCDF4.Dataset(path) as nc:
                dims = nc.dimensions
                return len(dims["speed"]) * len(dims["damping"]), ""
        except (OSError, KeyError):
            pass  # the analysis says what is wrong with it
    return RIG_POINTS_UNKNOWN, f"{o.rig}.nc not read: priced at {RIG_POINTS_UNKNOWN} grid points"


def _artifact_map(o: ArtifactMap, results: Path | None) -> AnalysisEstimate:
    points, note = _rig_points(o, results)
    per_method = sum(MONODROMY_CALL_SECONDS + spp * (MONODROMY_STEP_SECONDS
                                                     + MONODROMY_POINT_STEP_SECONDS * points)
                     for spp in o.steps_per_period)
    s = len(o.methods) * per_method
    # the monodromy matrices and stage products of the grid, and the flags kept per step
    memory = BASELINE_MEMORY + points * 8 * 40 + len(o.methods) * len(o.steps_per_period) \
        * points * 9
    what = f"{len(o.methods)} tableaux x {len(o.steps_per_period)} steps over {points} grid points"
    return AnalysisEstimate(o.kind, s, memory, ((what, s),), note)


def _radians(scene, window: pr.Window) -> float:
    """Radians of the scene's fastest motion (its natural frequency at the largest stiffness, or
    the highest order of its excitation) over the integrated time."""
    orders = [r for _, r, _ in (*scene.k_harmonics, *scene.g_harmonics)] or [1.0]
    fastest = max(scene.omega_n, scene.omega * max(orders))
    return window.periods * scene.period * fastest


def reference_bytes(scene, window: pr.Window) -> float:
    """The memory of a scene's reference solution at its peak [bytes]: its dense output, an
    interpolant per DOP853 step (``REFERENCE_STEPS_PER_RADIAN`` per radian of the scene's fastest
    motion over the integrated time: longer with the periods, and with a lower speed, whose mesh
    period holds more radians of the natural frequency), ``DENSE_STEP_BYTES`` each. The rattle
    scene's exact solution (a closed form per crossing) is small beside its DOP853 cross-check,
    counted here; ``analyses.work_precision`` keeps only the samples of one reference before the
    next is computed."""
    return REFERENCE_STEPS_PER_RADIAN * _radians(scene, window) * DENSE_STEP_BYTES


def _work_precision(o: WorkPrecision, threads: int) -> AnalysisEstimate:
    window = pr.Window(o.transient_periods, o.record_periods)
    make = {"whine": pr.whine_scene, "rattle": pr.rattle_scene}
    speed = {"whine": o.whine_speed, "rattle": o.rattle_speed}
    ref = peers = fixed = held = 0.0
    for name in o.scenes:
        scene = make[name](speed[name])
        rad = _radians(scene, window)
        held = max(held, reference_bytes(scene, window))
        ref += REFERENCE_SECONDS_PER_RADIAN[name] * rad
        peers += sum(PEER_RHS_PER_RADIAN[name][p] * (tol / 1e-3) ** -PEER_RTOL_EXPONENT[p] * rad
                     * PEER_RHS_SECONDS for p in o.peers for tol in o.rtol)
        for m in o.methods:
            method = m.split("-")[0]
            cost = KINK_COST if m.endswith("-kink") else 1.0
            fixed += sum(o.repeat * cost * _kernel_seconds(o.copies, window.periods * spp,
                                                           method, threads)
                         for spp in o.steps_per_period)
    samples = window.record_periods * pr.SAMPLES_PER_PERIOD  # the recorded signal per case
    stages = max(rk.STAGES[rk.METHODS[m.split("-")[0]]] for m in o.methods)
    memory = BASELINE_MEMORY + o.copies * 8 * (samples + 4 * stages + 16) + held
    runs = len(o.scenes) * len(o.methods) * len(o.steps_per_period)
    return AnalysisEstimate(o.kind, ref + peers + fixed, memory, (
        (f"{len(o.scenes)} reference solutions", ref),
        (f"{len(o.scenes) * len(o.peers) * len(o.rtol)} scipy runs", peers),
        (f"{runs} fixed-step runs of {o.copies:,} cases x {o.repeat}", fixed)))


def kernel_calls(study: AnalysisStudy) -> list[dict]:
    """The ``simulate`` calls (keyword arguments without the step counts, as
    ``gearsweep.kernels.batch.precompile`` takes them) of the batch kernel specialisations an
    analysis study calls: ``method_stability``'s trials, ``work_precision``'s fixed-step runs
    (the others call none). ``compile_cost`` asks Numba's cache for them; scripts/main_job.py
    compiles them beforehand, while the other studies run, so that work_precision's run times
    integration, not compilation."""
    o = study.analysis
    if isinstance(o, MethodStability):
        return [st.trial_call(m, np.ones(1), np.zeros(1)) for m in o.methods]
    if isinstance(o, WorkPrecision):
        make = {"whine": pr.whine_scene, "rattle": pr.rattle_scene}
        speed = {"whine": o.whine_speed, "rattle": o.rattle_speed}
        scenes = [make[name](speed[name]) for name in o.scenes]
        return [pr.fixed_call(scene, m.split("-")[0], o.steps_per_period[0], m.endswith("-kink"),
                              copies=1) for scene in scenes for m in o.methods]
    return []


def compile_cost(study: AnalysisStudy) -> tuple[float, float]:
    """(seconds, bytes) the one-time compile of what the study calls that Numba's disk cache
    lacks adds to its time and peak memory (0, 0 when the cache has it all): the batch
    kernel's specialisations (``kernel_calls``) at ``batch.COLD_COMPILE_SECONDS`` and
    ``COLD_COMPILE_BYTES``, ``rattle_balance``'s ``hb._monodromy`` at its own; their bytes
    together as ``batch.compile_peak``. The other kinds compile nothing (a first run of
    artifact_map, rattle_budget and jump_map compiled 0 s)."""
    costs = [(COLD_COMPILE_SECONDS[key[:2]], COLD_COMPILE_BYTES[key[:2]])
             for key in not_compiled(kernel_calls(study))]
    if isinstance(study.analysis, RattleBalance) and not ready(hb._monodromy,
                                                               hb.MONODROMY_CALL):
        costs.append((hb.MONODROMY_COLD_COMPILE_SECONDS, hb.MONODROMY_COLD_COMPILE_BYTES))
    return sum(s for s, _ in costs), compile_peak([b for _, b in costs])


def input_bytes(study: AnalysisStudy, results: Path | None) -> float:
    """The bytes of the results an analysis reads, as it holds them: each is loaded whole
    (``analyses._open_inputs``: ``xr.load_dataset``), every variable at its shape and type (a
    jump map of a 2 GB rattle map was priced at 300 MB); from the files' headers, nothing
    read. One not there or not readable counts 0 (the analysis says what is wrong with it)."""
    return sum(_value_bytes(v) for v in _input_variables(study, results))


def loading_bytes(study: AnalysisStudy, results: Path | None) -> float:
    """The bytes HDF5 holds beside the arrays while the results an analysis reads are loaded:
    each chunked variable keeps the chunks it decompressed in a chunk cache of its own, up to the
    cache's size (netCDF-C's default: 64 MB a variable), until the file closes, after every
    variable is read (studies/rattle_map_jumps.yaml peaked at 557 MB against 448 MB estimated:
    its 148 MB input took 296 MB to load, as a read of its variables with netCDF4 alone; 148 MB
    with each variable's cache set to 0). A chunk larger than the cache is not kept. From the
    files' headers, as ``input_bytes``."""
    total = 0.0
    for v in _input_variables(study, results):
        chunks = v.chunking()
        if chunks == "contiguous" or not v.shape:
            continue
        size = v.get_var_chunk_cache()[0]
        chunk = math.prod(chunks) * _itemsize(v)
        count = math.prod(math.ceil(n / c) for n, c in zip(v.shape, chunks, strict=True))
        total += min(count * chunk, size) if chunk <= size else 0.0
    return total


def work_bytes(study: AnalysisStudy, results: Path | None) -> float:
    """The bytes of an analysis's own arrays that grow with what it reads, at their peak, after
    its inputs are loaded: ``jump_map``'s jump summary (``JUMP_MAP_BYTES`` per value of the
    input's ``p_pp``); the other kinds' are counted by their options (``_estimate``) or small."""
    if study.analysis.kind != "jump_map":
        return 0.0
    return sum(JUMP_MAP_BYTES * math.prod(v.shape) for v in _input_variables(study, results)
               if v.name == "p_pp")


def _input_variables(study: AnalysisStudy, results: Path | None):
    """The variables (headers: netCDF4, the file open while each is looked at) of the results an
    analysis reads; none of one not there or not readable."""
    for name in getattr(study.analysis, "inputs", lambda: [])() if results is not None else []:
        try:
            with netCDF4.Dataset(Path(results) / f"{name}.nc") as nc:
                yield from _variables(nc)
        except OSError:
            pass


def _itemsize(v) -> int:
    return v.dtype.itemsize if isinstance(v.dtype, np.dtype) else 8


def _value_bytes(v) -> float:
    return math.prod(v.shape) * _itemsize(v)


def _variables(group):
    """Every variable of a netCDF group and its subgroups."""
    yield from group.variables.values()
    for sub in group.groups.values():
        yield from _variables(sub)


def estimate(study: AnalysisStudy, results: str | Path | None = None,
             threads: int | None = None) -> AnalysisEstimate:
    """The predicted time and memory of an analysis study; ``results``: the folder its inputs
    are read from (an artifact map's grid is its rig result's; the results it reads are held
    in memory whole: ``input_bytes``, and while they load, their chunk caches beside them:
    ``loading_bytes``; then the analysis's arrays that grow with them: ``work_bytes``, in the
    memory the caches let go when the files closed: the larger of the two counts); with the
    one-time compile of what Numba's cache lacks (``compile_cost``)."""
    folder = None if results is None else Path(results)
    est = _estimate(study, folder, threads)
    held = input_bytes(study, folder) + max(loading_bytes(study, folder),
                                            work_bytes(study, folder))
    seconds, compiling = compile_cost(study)
    return replace(est, seconds=est.seconds + seconds,
                   memory_bytes=est.memory_bytes + held + compiling, compile_seconds=seconds,
                   compile_bytes=compiling)


def _estimate(study: AnalysisStudy, results: Path | None,
              threads: int | None) -> AnalysisEstimate:
    o = study.analysis
    threads = threads or kernel_threads()
    if isinstance(o, MethodStability):
        return _method_stability(o, threads)
    if isinstance(o, ArtifactMap):
        return _artifact_map(o, results)
    if isinstance(o, WorkPrecision):
        return _work_precision(o, threads)
    if isinstance(o, RattleBalance):
        s = BALANCE_SECONDS + o.harmonics * (BALANCE_HARMONIC_SECONDS
                                             + BALANCE_SAMPLE_SECONDS * o.n_time)
        memory = BASELINE_MEMORY + BALANCE_SAMPLE_BYTES * o.harmonics * o.n_time
        return AnalysisEstimate(o.kind, s, memory, ((
            f"a harmonic-balance branch of {o.harmonics} harmonics, {o.n_time} samples", s),))
    return AnalysisEstimate(o.kind, FIXED_ANALYSIS_SECONDS[o.kind], BASELINE_MEMORY)


def check_limits(study: AnalysisStudy, results: str | Path | None, where: str,
                 ahead: str = "run with --yes to go ahead") -> AnalysisEstimate:
    """The estimate; one line (``LimitError``, then ``ahead``: how to go ahead) beyond the time
    or memory limit: the CLI without ``--yes``, ``gearsweep.run`` without ``yes=True``."""
    est = estimate(study, results)
    over = est.over()
    if over:
        raise LimitError(f"{where}: refused ({', '.join(over)}): analysis"
                         f" {study.analysis.kind!r}, {est.line()}; {ahead}")
    return est
