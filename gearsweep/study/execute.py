"""Where the chunks of a study run: in this process, on an existing dask cluster, or on a local one.

A ``Plan`` (``gearsweep.study.plan``) is cut into chunks of lanes (a lane is one case, or one
whole continued sweep along speed, so a sweep direction never spans two chunks). ``run_plan``
computes the chunks that are not yet on disk with one of three backends and puts the results
together:

* ``InProcess`` (the default): chunk after chunk in this process, each kernel call spread over all
  cores (the drivers' threads, ``gearsweep.kernels.rk.Threaded``).
* ``DaskBackend(scheduler="tcp://HOST:PORT")``: an existing ``dask.distributed`` cluster.
* ``DaskBackend(workers=N)``: a ``LocalCluster`` of N single-threaded worker processes started on
  the spot and closed afterwards.

On a cluster every task sets Numba's thread count to ``cores // worker processes on its host``
(``numba.set_num_threads`` inside the task: the setting is per thread) and a worker process runs
one chunk at a time, so dask threads and Numba threads never oversubscribe the cores. The kernel's
arithmetic for one case does not depend on the block, thread or process that runs it, so the
results are bitwise identical whichever backend runs a study. A task that raises is retried twice
(``retries=2``); the chunks of a worker that dies are rescheduled by the dask scheduler.

With an output path ``run_to_file`` checkpoints every finished chunk (``gearsweep.study.checkpoint``)
and a re-run of the same study resumes. ``estimate`` predicts time, memory and output size
before a run; ``check_limits`` refuses a study beyond ``LIMITS`` unless confirmed.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import gc
import logging
import math
import os
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import urlparse

import numpy as np

from gearsweep.analysis.stability import RESONANCE_TOL
from gearsweep.errors import (
    ClusterError,
    ContactLossWarning,
    LimitError,
    ResultError,
    StepLimitWarning,
    signals_held,
)
from gearsweep.files import check_replaceable
from gearsweep.jit import cache_loads_without_set_up
from gearsweep.kernels import LANES
from gearsweep.kernels.batch import compiled
from gearsweep.model import HILL_CYCLE_MAX, MeshModel
from gearsweep.study.checkpoint import (
    WRITING,
    ChunkStore,
    RunLog,
    checkpoint_problem,
    header_bytes,
    remove_checkpoints,
    saved_layout,
    shared_mark,
)
from gearsweep.study.chunk import (
    KERNEL_CLOCK,
    Prepared,
    _integrate,
    kernel_calls,
    prepare,
    run_chunk,
    run_prepared,
)
from gearsweep.study.filelayout import output_bound
from gearsweep.study.outputs import OUTPUTS
from gearsweep.study.plan import Plan, _guard_table, _lane_params, _step_ok
from gearsweep.study.provenance import identity
from gearsweep.study.resultfile import ResultFile, history_line, result_layout

if TYPE_CHECKING:
    import xarray as xr

# ``gearsweep.study.dataset`` (and with it xarray and pandas: 0.3 s) is imported where an
# in-memory Dataset is built (``run_plan``), not here: a run that streams its file
# (``run_to_file``, ``gearsweep run``) never imports xarray (``resultfile.ResultFile``), and
# netCDF4 is imported by the writer thread, beside the first chunk's kernel.

STATED_RATE = {"rk4": 350.0, "rk5": 220.0}
"""Bare-kernel throughput per core [Msteps/s] assumed when none is measured: the estimate's
fallback, not a promise. Measured on this 2-core AVX-512 machine, rattle scene: about 700 per
core for RK4 (``scripts/bench_scale.py``, docs/scale.md); half that allows for AVX2 (4 lanes per
vector instead of 8), and RK5 takes 6 stages to RK4's 4."""

def output_seconds(plan: Plan, chunks: int, worst: bool = False) -> float:
    """Time of the outputs' own work beyond the kernel's [s] (``Output.seconds`` where an output
    has one: the ``floquet`` output's monodromy maps and step-limit scan, the ``period``
    output's comparisons), at the stated RK5 rate (those maps are RK5). ``worst``: at most
    (``Output.worst_seconds`` where an output's work depends on the motion: ``period``)."""
    def one(output) -> float:
        how = getattr(output, "worst_seconds", output.seconds) if worst else output.seconds
        return how(plan, chunks, STATED_RATE["rk5"])

    return sum(one(OUTPUTS[o]) for o in plan.outputs if hasattr(OUTPUTS[o], "seconds"))


BASELINE_MEMORY = 300e6
"""Resident memory of the interpreter with numpy, numba, xarray and the compiled kernels [bytes]."""

BASELINE_FILE_MEMORY = 80e6
"""Of ``BASELINE_MEMORY``, the libraries' file-backed resident pages [bytes] (79 MB measured with
gearsweep, netCDF4, xarray and scipy imported, 27 Nov 2026). They vary with how the files sit in
the page cache, not with the study: 144 MB in a virtual environment of the same wheels installed
by a newer pip (llvmlite's library 98 MB resident against 37 MB), the anonymous memory the same
89 MB in both. Tests compare a run's peak less its file-backed pages with an estimate less this."""

CHUNKS_HELD = 8
"""A run's memory beyond ``BASELINE_MEMORY``, in chunks' worth of result bytes, where a chunk is
one kernel call (``chunk.prepare``): the next chunk's kernel inputs (made while a chunk
computes), the computing chunk's outputs and three chunks' kernel results or arrays waiting
for, or in, the saver and writer threads (``InProcess``, ``_compute``); inputs
and kernel results take about twice a chunk's result bytes. Measured (26 Nov 2026, scale study,
2 cores): peak RSS 417 MB at 1e6 cases (estimate 454 MB), 514 MB at 1e7 (537 MB)."""

CHUNKS_HELD_WHOLE = 3
"""The same where ``run_chunk`` computes a chunk whole (a continued sweep, a gear scene that
sweeps its load): the computing chunk's arrays and two waiting for the saver and writer
threads."""


def chunks_held(plan: Plan) -> int:
    """Chunks' worth of result bytes a run of ``plan`` holds at once (memory estimate)."""
    return CHUNKS_HELD_WHOLE if plan.continued or plan.gear_load_swept else CHUNKS_HELD

FIXED_SECONDS = 1.0
"""Time of a run that does not depend on its size: starting Python, importing the libraries,
loading the compiled kernel, the file's set-up [s]. An 8-case study took 0.38 s from process start
to exit on the 2-core VM (``scripts/bench_startup.py``, 26 Nov 2026); 1 s allows for a slower
disk or CPU. (It was 3 s, from before the start was made fast: a 3-case study was estimated at
3.0 s and ran in 0.4 s.) Only a new process pays it: the estimate of a run in a running process
(``gearsweep.run``, ``gearsweep.estimate``) leaves it out (``quick_estimate(new_process=False)``)."""

CHUNK_OVERHEAD_SECONDS = 4e-3
"""Wall time each chunk costs beyond its kernel rounds [s]: the kernel call's set-up, its
arrays made, its checkpoint file written and, after the run, removed (an unlink of a 4 kB to
1 MB file took 2.8 ms on this VM's ext4 under load), its line in ``runs.jsonl`` and its part of
the result file. Negligible for the runner's chunks (about a second each), it is all of the
time of small ones: the 300,000-case cut of the 1e6-case study in chunks of 64 cases (4,688
chunks) took 34.5 s where 4 chunks take 5-6 s. Measured on this 2-core VM (27 Nov 2026,
docs/scale.md): 6-8 ms a chunk over chunk sizes of 1 to 1,024 cases with the machine at load
7 (other jobs beside), 2.0 ms quiet (600 chunks of one case: 1.53-1.69 s against 0.42 s in the
runner's chunks); 4 ms lies within a factor 2 of both."""

DASK_CHUNK_OVERHEAD_SECONDS = 10e-3
"""``CHUNK_OVERHEAD_SECONDS`` of a chunk run on a dask cluster (``--workers``, ``--scheduler``)
[s]: its task submitted, scheduled, run and its result sent back, beside the same kernel call,
arrays and files. Measured on this 2-core VM (27 Nov 2026, load 2.3), 40,000 rattle cases with
``--workers 2``: 6.41 and 6.82 s in chunks of 64 cases (about 625 chunks) against 1.06 and
0.98 s in chunks of 10,000, 9.0 ms a chunk; in-process the same 2.31 and 2.43 s against 0.58
and 0.60 s, 2.9 ms. An outside tester: about 12 ms. Priced at the in-process 4 ms, that study
in chunks of 64 was estimated at 3.7 s and took 8.7 s."""


def chunk_overhead(workers: int | None) -> float:
    """Seconds each chunk costs beyond its kernel: on a dask cluster of ``workers`` worker
    processes, or in this process (``None``)."""
    return DASK_CHUNK_OVERHEAD_SECONDS if workers else CHUNK_OVERHEAD_SECONDS


LOAD_MODEL_SECONDS = 3e-3
"""Building the model of one load of a gear scene that sweeps its load (its mesh cycle,
compliance and STE at that load, ``Plan.model_for_load``), once per distinct load [s].
Measured on this 2-core VM (27 Nov 2026), 200 loads, medians of 7: 0.84 ms of CPU a load for
``table1_consistent`` and 1.17 ms with a 6 um tip relief, 3.0 and 4.7 ms wall at load 8 (the
pair's geometry checked once per pair, ``geometry.CHECKED_PAIRS``; checked at each build it
took 2.2 and 2.5 ms of CPU, 7.1 and 6.6 ms wall at load 8, 8.5-11 ms measured before)."""

LOAD_CALL_SECONDS = 2e-3
"""Wall time each kernel call of a gear scene that sweeps its load costs beyond its kernel
rounds [s]: a chunk makes one call per load in it (per speed of a continued sweep,
``chunk._integrate_all``), each with its own kernel inputs and outputs. Measured on this
2-core VM (27 Nov 2026), 4 speeds x 300 loads: 0.8 ms a call with ``stats``, 2.5 ms with a
spectrum as well."""

CHUNK_FILE_BYTES = 4096 + 128
"""Disk a checkpoint file takes beyond its arrays and their headers [bytes], at most: the file
system's last, partly filled block (4 kB) and the chunk's line in ``runs.jsonl``."""

WRITE_RATE = 100e6
"""Bytes of results written per second [bytes/s], counted as if the writing were not overlapped
with the kernel (conservative: with zstd the writer thread writes about 250 MB/s here,
beside the kernel; docs/scale.md)."""


@dataclass(frozen=True)
class Limits:
    """A study predicted beyond any of these is refused unless the user confirms (``--yes``)."""

    seconds: float = 600.0
    """Wall time [s]."""
    output_bytes: float = 2e9
    """Size of the result file [bytes]."""
    memory_bytes: float = 2e9
    """Peak resident memory of the process that assembles the results [bytes]."""


LIMITS = Limits()


def cores() -> int:
    """CPU cores this process may use (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def kernel_threads() -> int:
    """Threads a kernel call in this process uses: Numba's (``NUMBA_NUM_THREADS``, default one
    per CPU), at most the cores this process may use (``cores``)."""
    import numba

    return max(1, min(int(numba.config.NUMBA_NUM_THREADS), cores()))


def lanes_per_chunk(plan: Plan, chunk_cases: int | None) -> int | None:
    """Lanes per chunk for about ``chunk_cases`` cases per chunk (``None``: the runner's default)."""
    if chunk_cases is None:
        return None
    return max(1, int(chunk_cases) // plan.cases_per_lane)


EDGE_SHARE = 4
"""The first and the last chunk of a CPU run are cut in two, a ``1 / EDGE_SHARE`` part at the
run's start and at its end (``with_short_ends``)."""


def with_short_ends(plan: Plan, chunks: list[tuple[int, int]], threads: int | None = None
                    ) -> list[tuple[int, int]]:
    """``chunks`` with a short first and a short last chunk: the pipeline's fill and drain.

    Before the first kernel call nothing else runs: the first chunk's inputs are made
    (``chunk.prepare``) while the cores wait; after the last kernel call its arrays are made,
    saved and written, and the file closed, while they wait again. Both take time in proportion
    to their chunk, so the first and the last are a quarter of a chunk each (rounded to whole
    rounds of kernel blocks over the ``threads`` cores): 1e6 cases on 2 cores waited 26 ms for
    the first chunk's inputs and 38 ms for the last chunk's write (docs/scale-log.md). A chunk is cut
    only if each part is still at least two rounds of blocks (a part that leaves cores idle
    would cost more than it saves); a GPU run is left as it is (a short chunk fills fewer of its
    threads)."""
    if plan.device != "cpu" or not chunks:
        return chunks
    rounds = max(LANES * (threads or cores()) // max(len(plan.directions), 1), 1)

    def cut(a: int, b: int, first: bool) -> list[tuple[int, int]]:
        part = (b - a) // EDGE_SHARE // rounds * rounds
        if part < 2 * rounds or b - a - part < 2 * rounds:
            return [(a, b)]
        return [(a, a + part), (a + part, b)] if first else [(a, b - part), (b - part, b)]

    if len(chunks) == 1:
        head = cut(*chunks[0], first=True)
        return head[:-1] + cut(*head[-1], first=False)
    return cut(*chunks[0], first=True) + chunks[1:-1] + cut(*chunks[-1], first=False)


# ------------------------------------------------------------------------------------ estimate


@dataclass(frozen=True)
class Estimate:
    """Predicted cost of a study on a given number of cores."""

    cases: int
    steps: float
    """Integration steps of all cases."""
    chunks: int
    threads: int
    """Cores the kernel runs on (all workers together)."""
    rate: float
    """Bare-kernel throughput per core [Msteps/s]."""
    rate_source: str
    """``"measured"`` or ``"stated"``."""
    seconds: float
    memory_bytes: float
    output_bytes: float
    device: str = "cpu"
    """``"cpu"`` or ``"cuda"``; on ``cuda``, ``rate`` is the whole GPU's and ``threads`` unused."""
    compile_seconds: float = 0.0
    """Of ``seconds``, the one-time compile of kernel specialisations not yet compiled
    (``estimate.compile_seconds``)."""
    compile_bytes: float = 0.0
    """Of ``memory_bytes``, what that compile adds to the peak (``estimate.compile_bytes``)."""
    output_seconds: float = 0.0
    """Of ``seconds``, the outputs' own work beyond the kernel (``output_seconds``)."""
    disk_bytes: float = 0.0
    """Disk the run needs at its peak [bytes] (``disk_bytes``): the checkpoint files beside
    the result file, just before the checkpoints are removed."""
    in_memory: bool = False
    """A run that writes no file (``gearsweep.run`` without ``output``): its result's arrays
    counted in ``memory_bytes``, and no output or disk (``api.estimate(in_memory=True)``)."""
    worst_seconds: float = 0.0
    """``seconds`` at most where an output's work depends on the motion (``period``: every
    case without a period), said beside it where it is more. The limit is held to ``seconds``,
    the typical time."""
    start_seconds: float = FIXED_SECONDS
    """Of ``seconds``, the start of a new process (0 for a run in this running process:
    ``gearsweep.run``, ``gearsweep.estimate``)."""
    workers: int | None = None
    """Dask worker processes the chunks run on (``--workers``, or an existing cluster's as its
    scheduler counts them: ``DaskBackend``), said beside the cores; ``None``: this process."""

    def line(self) -> str:
        """The estimate in one line, saying when it includes compiling the kernel."""
        chunks = f"{self.chunks} chunk" + ("s" if self.chunks != 1 else "")
        where = (f"on the GPU at {self.rate:.3g} Msteps/s ({self.rate_source}) and compiling"
                 " its kernel (every run)" if self.device == "cuda" else
                 f"on {self.threads} core{'s' if self.threads != 1 else ''} at"
                 f" {self.rate:.0f} Msteps/s per core ({self.rate_source})")
        if self.workers is not None and self.device != "cuda":  # a dask cluster's size
            where = (f"on {self.workers} worker{'s' if self.workers != 1 else ''},"
                     + where.removeprefix("on"))
        cold = (f"; includes about {self.compile_seconds:.0f} s to compile the kernel once"
                " (cold cache)" if self.compile_seconds else "")
        worst = (f" (at most {_duration(self.worst_seconds)} if no case's motion repeats within"
                 " half its record: the period output)"
                 if self.worst_seconds > self.seconds else "")
        return (f"{self.cases:,} cases, {self.steps:.3g} steps in {chunks}: about"
                f" {_duration(self.seconds)}{worst} {where}, peak memory"
                f" {_size(self.memory_bytes)}"
                + (f" ({_size(self.compile_bytes)} of it compiling)" if self.compile_bytes else "")
                + (", the result held in memory (no file)" if self.in_memory else
                   f", output at most {_size(self.output_bytes)}")
                + (f" (disk at most {_size(self.disk_bytes)} while it runs, its checkpoints"
                   " beside it)" if self.disk_bytes > self.output_bytes else "") + cold)

    def over(self, limits: Limits | None = None) -> list[str]:
        """The limits this estimate exceeds, in words (empty if none)."""
        limits = limits or LIMITS
        out = []
        if self.seconds > limits.seconds:
            out.append(f"time > {_duration(limits.seconds)}")
        if self.memory_bytes > limits.memory_bytes:
            out.append(f"memory > {_size(limits.memory_bytes)}")
        if self.output_bytes > limits.output_bytes:
            out.append(f"output > {_size(limits.output_bytes)}")
        return out


def _duration(s: float) -> str:
    if not math.isfinite(s):  # (an analysis at 1e-300 rpm: 'about inf h')
        return "without bound"
    if s < 90:
        return f"{s:.1f} s"
    if s < 5400:
        return f"{s / 60:.1f} min"
    if s < 3.6e9:
        return f"{s / 3600:.1f} h"
    return f"{s / 3600:.3g} h"  # (an analysis at 1e-300 rpm: 'h' after 300 digits)


def _size(b: float) -> str:
    if not math.isfinite(b):  # (an analysis at 1e-300 rpm: its reference's 'inf GB')
        return "without bound"
    for unit, f in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if b >= f:
            return f"{b / f:.3g} {unit}"
    return f"{b:.0f} B"


def _case_bytes(plan: Plan) -> int:
    """Bytes of results per case (every variable, with its extra dims, and status)."""
    total = 1  # status, int8
    for spec in plan.specs.values():
        extra = math.prod(len(spec.extra_coords[d]) for d in spec.extra_dims)
        total += extra * np.dtype(spec.dtype).itemsize
    return total


def disk_bytes(plan: Plan, chunks: int) -> float:
    """Disk a run of ``plan`` in ``chunks`` chunks needs at its peak [bytes]: every chunk's
    checkpoint file (the arrays uncompressed, their headers and ``CHUNK_FILE_BYTES``) and the
    result file (``output_bound``), side by side from the last chunk's write until the
    checkpoints are removed. The 300,000-case cut of the 1e6-case study (a 14.8 MB file, 22 MB
    of checkpoints) ran out of room on a 30 MB disk that its 28.6 MB output bound fitted."""
    per_file = header_bytes(result_layout(plan, plan.n_lanes)) + CHUNK_FILE_BYTES  # (the
    # widest shapes: the longest headers)
    return plan.n_cases * _case_bytes(plan) + chunks * per_file + output_bound(plan)


def _lane_steps(plan: Plan, chunks: list[tuple[int, int]], threads: int) -> float:
    """Lane-steps the kernel advances per thread over all calls (a partly filled block of
    ``LANES`` costs a full one; blocks are shared out over ``threads``).

    A chunk is one kernel call, or, for continued sweeps, one call per speed in which the up and
    the down sweeps of its lanes advance side by side (``runner.run_chunk``).
    """
    calls_per_chunk = plan.chain
    ways = max(len(plan.directions), 1)
    sizes = Counter(b - a for a, b in chunks)
    rounds = sum(k * math.ceil(math.ceil(n * ways / LANES) / threads) for n, k in sizes.items())
    return float(rounds) * calls_per_chunk * LANES * plan.steps_per_case


def load_costs(plan: Plan, starts: np.ndarray, stops: np.ndarray, threads: int
               ) -> tuple[float, float]:
    """(lane-steps per thread, seconds beyond the kernel) of the chunks ``[starts, stops)`` of
    a gear scene that sweeps its load: a chunk makes one kernel call per load in it (per speed
    of a continued sweep), each of whole blocks of that load's lanes (``chunk._integrate_all``),
    at ``LOAD_CALL_SECONDS`` each, and each distinct load's model is built once
    (``LOAD_MODEL_SECONDS``). The chunk's lanes run in C order over ``plan.lane_dims``: a load
    holds runs of ``stride`` lanes; a chunk that touches more runs than there are loads has
    every load, its lanes shared out evenly (to a lane). An estimate of one call a chunk put
    4 speeds x 300 loads at 1.1 s: each load's call computed a block of 32 lanes for its 4
    cases, and the run took 9 s."""
    dims = plan.lane_dims
    load = "torque" if "torque" in dims else "mean_force"
    at = dims.index(load)
    loads = len(plan.grids[load])
    stride = math.prod(len(plan.grids[d]) for d in dims[at + 1:])
    ways = max(len(plan.directions), 1)

    def rounds(lanes):
        return np.ceil(np.ceil(np.asarray(lanes) * ways / LANES) / threads)

    starts, stops = np.asarray(starts, np.int64), np.asarray(stops, np.int64)
    first_run, last_run = starts // stride, (stops - 1) // stride
    runs = last_run - first_run + 1
    head = np.minimum(stops, (first_run + 1) * stride) - starts
    tail = np.where(runs > 1, stops - last_run * stride, 0)
    few = runs <= loads
    calls = np.where(few, runs, loads)
    steps = np.where(few, rounds(head) + rounds(tail) + np.maximum(runs - 2, 0) * rounds(stride),
                     loads * rounds(np.ceil((stops - starts) / loads)))
    lane_steps = float(steps.sum()) * plan.chain * LANES * plan.steps_per_case
    return lane_steps, (float(calls.sum()) * plan.chain * LOAD_CALL_SECONDS
                        + loads * LOAD_MODEL_SECONDS)


def measure_rate(plan: Plan, threads: int, seconds: float = 0.3) -> float:
    """Throughput per core [Msteps/s] of this study's kernel and outputs, measured here.

    Runs ``4 LANES threads`` cases of the study (its first lanes, first speed) for about
    ``seconds`` at the stated rate, after one short warm-up call that loads the compiled kernel.
    """
    n = min(4 * LANES * threads, max(plan.n_lanes, 1) * 4 * LANES)
    s = plan.study.solver
    per_case = seconds * STATED_RATE[s.method] * 1e6 * threads / n
    periods = max(2, int(per_case // s.steps_per_period))
    first = min(n, max(plan.n_lanes, 1))  # the study's first lanes, repeated to n cases
    lanes = np.arange(n) % first
    params = {k: v[lanes] for k, v in _lane_params(plan, 0, first).items()}
    if plan.continued:
        params["speed"] = np.full(n, plan.grids["speed"][0])
    trial = None
    for record in (1, periods // 2):
        trial = plan.with_solver(transient_periods=periods - record, record_periods=record)
        t0 = time.perf_counter()
        _integrate(trial, params, n, None, None)
        dt = time.perf_counter() - t0
    steps = n * periods * s.steps_per_period
    return steps / dt / threads / 1e6


TABLE_TEMPORARIES = 5
"""Arrays of a table's size that building the tables holds besides the tables themselves
(``fourier_table``: the phases, the argument, its cosine, the scaled cosine; rounded up).
Measured on this 2-core machine (27 Nov 2026), peak resident memory of whine scenes whose
orders 0.0208333 and 0.02083 make a cycle of 300,000 mesh periods: one 768 MB table (64 steps
per period) 4.0 GB, 4.8 tables' worth beyond the baseline; three 384 MB tables (32 steps)
3.29 GB, 7.8 tables' worth; both were estimated at 300 MB and ran without --yes."""


def table_bytes(plan: Plan, several: bool = True) -> float:
    """Memory of the excitation tables of the kernel's inputs [bytes]: stiffness, STE and force,
    each 5 stage nodes per step over the excitation's cycle in float64, those of the next chunk
    made while one computes (``several`` chunks), and ``TABLE_TEMPORARIES`` while one is built.
    Negligible for mesh orders (one period); a shaft order's or a long cycle's is not."""
    m = plan.model
    if not isinstance(m, MeshModel):
        return 0.0
    n = sum(bool(h) for h in (m.stiffness_harmonics, m.ste_harmonics, m.force_harmonics))
    if not n:
        return 0.0
    size = 5.0 * 8 * plan.study.solver.steps_per_period * m.cycle_periods
    return size * ((2 if several else 1) * n + TABLE_TEMPORARIES)


def estimate(plan: Plan, chunks: list[tuple[int, int]], *, threads: int | None = None,
             rate: float | None = None, workers: int | None = None) -> Estimate:
    """Predict wall time, peak memory and output size of running ``chunks`` of ``plan``.

    Parameters
    ----------
    threads : int
        Cores the kernel runs on (default: this process's cores).
    rate : float
        Bare-kernel throughput per core [Msteps/s]; default ``STATED_RATE`` of the method.
    workers : int
        Dask worker processes that run the chunks (``None``: this process): a chunk's cost
        beyond its kernel is ``chunk_overhead(workers)``.

    Notes
    -----
    Time: every kernel call advances ``ceil(blocks / threads)`` rounds of ``LANES`` lanes (a
    partly filled block costs a full one), at ``rate`` per core; plus ``FIXED_SECONDS``,
    ``chunk_overhead`` per chunk and the writing of the file at ``WRITE_RATE``.
    Memory (of ``gearsweep run``, which streams the results to disk, ``run_to_file``):
    ``chunks_held`` chunks' worth and the interpreter's baseline, whatever the number of
    chunks; ``run_plan``, which returns the results in memory, needs the full result arrays
    on top. Output: an upper bound of the file's size (``filelayout.output_bound``: the
    variables uncompressed, their attributes and HDF5's own structures; a codec makes the file
    smaller); disk: with the checkpoints beside it (``disk_bytes``).
    """
    threads = threads or cores()
    source = "stated" if rate is None else "measured"
    rate = rate or STATED_RATE[plan.study.solver.method]
    steps_case = plan.steps_per_case
    per_case = _case_bytes(plan)
    output = float(output_bound(plan))
    outputs_s = output_seconds(plan, len(chunks))
    if plan.gear_load_swept:
        lane_steps, loads_s = load_costs(plan, *np.array(chunks, np.int64).reshape(-1, 2).T,
                                         threads)
    else:
        lane_steps, loads_s = _lane_steps(plan, chunks, threads), 0.0
    seconds = (lane_steps / (rate * 1e6) + FIXED_SECONDS + loads_s
               + len(chunks) * chunk_overhead(workers) + output / WRITE_RATE + outputs_s)
    biggest = max((b - a for a, b in chunks), default=0) * plan.cases_per_lane
    sps = plan.samples_per_period()
    signal = max((b - a for a, b in chunks), default=0) * sps * plan.study.solver.record_periods * 8
    memory = (BASELINE_MEMORY + chunks_held(plan) * biggest * per_case + signal
              + table_bytes(plan, several=len(chunks) > 1))
    return Estimate(cases=plan.n_cases, steps=float(plan.n_cases) * steps_case, chunks=len(chunks),
                    threads=threads, rate=rate, rate_source=source, seconds=seconds,
                    memory_bytes=memory, output_bytes=output, output_seconds=outputs_s,
                    disk_bytes=disk_bytes(plan, len(chunks)),
                    worst_seconds=seconds - outputs_s + output_seconds(plan, len(chunks), True),
                    workers=workers)


def check_limits(est: Estimate, where: str, limits: Limits | None = None,
                 ahead: str = "run with --yes to go ahead") -> None:
    """Raise ``LimitError`` (one line, with the estimate, then ``ahead``: how to go ahead) if
    ``est`` is beyond ``limits``."""
    over = est.over(limits or LIMITS)
    if over:
        raise LimitError(f"{where}: refused ({', '.join(over)}): {est.line()}; {ahead}")


# ------------------------------------------------------------------------------------ backends


def warm_up(plan: Plan, first: tuple[int, int] | None = None) -> None:
    """Load (or compile) this study's kernel specialisation with a one-case, two-period call,
    and solve the step guard's stability polynomial for the (k/m, c/m) pairs of the ``first``
    chunk (memoised in ``runner``), so that the timed chunk phase measures integration, not
    one-time set-up.

    Loading the first kernel from Numba's cache sets up Numba's target (its typing and lowering
    registries: some hundred thousand objects that live as long as the process); Python's cyclic
    collector walked everything the process holds once during it, and its younger generations a
    dozen times, freeing nothing (about 35 ms of a 1e6-case run's 0.12 s warm-up, before the
    first chunk). With the kernels in the cache, the collector is paused meanwhile; a compile
    (which makes garbage cycles by the million) runs with it, as ever. Cached kernels are
    loaded without Numba's compiler set-up (``jit.cache_loads_without_set_up``: 60-90 ms of
    every run's start); a kernel that is not cached compiles, and its compile sets it up."""
    with _collector_paused(_cached(plan)), cache_loads_without_set_up():
        _warm_up(plan, first)


def _cached(plan: Plan) -> bool:
    """Whether every kernel specialisation a CPU run of the plan calls is in Numba's cache or
    already compiled (``batch.compiled``, as ``estimate.compile_seconds`` asks); a GPU run's
    kernel is compiled in every process."""
    return plan.device == "cpu" and all(compiled(call) for call in kernel_calls(plan))


@contextlib.contextmanager
def _collector_paused(pause: bool = True):
    """Python's cyclic garbage collector paused (if ``pause``), then as it was."""
    was = gc.isenabled()
    if pause:
        gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _warm_up(plan: Plan, first: tuple[int, int] | None = None) -> None:
    s = plan.study.solver
    if first is not None and s.step_guard != "off":
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            if plan.continued:
                n = first[1] - first[0]
                params = dict(_lane_params(plan, *first), speed=np.full(n, plan.grids["speed"][0]))
                _step_ok(plan, params, n)
            else:
                _guard_table(plan)
    trial = plan.with_solver(transient_periods=1, record_periods=1)
    params = _lane_params(plan, 0, 1)
    if plan.continued:
        params["speed"] = plan.grids["speed"][:1]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        _integrate(trial, params, 1, None, None)


def _run_chunk(plan: Plan, lane0: int, lane1: int) -> dict[str, np.ndarray]:
    """``run_chunk`` without NumPy's overflow warnings: a case whose coefficients overflow (an
    absurd force, say) is integrated to non-finite values, which the kernel flags in ``status``."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return run_chunk(plan, lane0, lane1)


class InProcess:
    """Run chunks one after another in this process (each kernel call uses all cores).

    The kernel calls follow one another with no Python work between them where a chunk is one
    call of all its cases (``chunk.prepare``): a helper thread makes the next chunk's kernel
    inputs while a chunk computes, and a chunk is yielded as the function that makes its arrays
    (``chunk.run_prepared``), which the caller's writer thread calls while the next chunk
    computes. Before, the calling thread did both between two calls while the other cores
    waited: 0.75 s of a 1e7-case run's 14 s."""

    def __enter__(self) -> InProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    @property
    def threads(self) -> int:
        import numba

        return numba.get_num_threads()

    _first: tuple[tuple[int, int], Prepared | None] | None = None

    def prepare_first(self, plan: Plan, chunk: tuple[int, int]) -> None:
        """Make the first chunk's kernel inputs now, in the calling thread, before anything
        else starts: made by the helper thread beside the writer's set-up of the result file,
        they waited for the GIL (1e6 cases: 22 ms instead of 6) while the cores idled."""
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            self._first = (chunk, prepare(plan, *chunk))

    def run(self, plan: Plan, todo: list[tuple[int, int]]
            ) -> Iterator[tuple[int, int, dict[str, np.ndarray] | Callable[[], dict]]]:
        helper = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gearsweep-prepare")
        first, self._first = self._first, None
        try:
            ahead = [helper.submit(prepare, plan, *c) for c in todo[:1]] \
                if first is None or not todo or first[0] != todo[0] else [_done(first[1])]
            for i, (a, b) in enumerate(todo):
                prep = ahead.pop(0).result()
                if i + 1 < len(todo):
                    ahead.append(helper.submit(prepare, plan, *todo[i + 1]))
                yield a, b, (_run_chunk(plan, a, b) if prep is None else run_prepared(plan, prep))
        finally:
            helper.shutdown(cancel_futures=True)


def _done(value) -> Future:
    """A future that already holds ``value``."""
    f: Future = Future()
    f.set_result(value)
    return f


_KERNEL_LOCK = threading.Lock()
"""One chunk at a time per worker process: its Numba threads already fill its share of cores."""


OTHER_GEARSWEEP = "gearsweep-other"
"""First item of what ``_chunk_task`` returns, instead of a chunk, on a worker whose gearsweep
is not the client's (then its address and its ``provenance.identity``)."""


def other_gearsweep(address: str, theirs: str, client: str | None = None) -> ClusterError:
    """The one line for a dask worker that imports another gearsweep than this run (``client``:
    this process's ``provenance.identity``)."""
    return ClusterError(f"{address}: this dask worker runs {theirs}, this run {client or identity()}:"
                        " its results would differ from this gearsweep's and be recorded as"
                        " its; start the workers with the same gearsweep (installed, or on their"
                        " PYTHONPATH: docs/scale.md)")


def _chunk_task(plan: Plan, lane0: int, lane1: int, procs_per_host: dict[str, int],
                store: ChunkStore | None = None, mark: str | None = None,
                expected: str | None = None
                ) -> tuple[dict[str, np.ndarray] | None, float] | tuple[str, str, str]:
    """A chunk on a dask worker, with Numba's threads set to this worker's share of the cores:
    its arrays, or ``None`` where the worker saved them to ``store`` itself (it does where it
    sees the client's ``mark`` file in the store's folder: the same file system), and the
    seconds the worker spent in the kernel for it. On a worker whose gearsweep is not the
    ``expected`` one (``provenance.identity``: a worker that joined after the run's check),
    nothing is computed or saved: ``(OTHER_GEARSWEEP, its address, its identity)``."""
    import numba
    from distributed import get_worker

    address = get_worker().address
    if expected is not None and (mine := identity()) != expected:
        return OTHER_GEARSWEEP, address, mine
    host = urlparse(address).hostname or ""
    procs = procs_per_host.get(host) or max(procs_per_host.values(), default=1)
    threads = max(1, min(numba.config.NUMBA_NUM_THREADS, cores() // procs))
    with _KERNEL_LOCK:  # one chunk at a time per process: the clock's difference is this chunk's
        numba.set_num_threads(threads)
        k0 = KERNEL_CLOCK.seconds
        with cache_loads_without_set_up():  # a worker's first chunk loads the kernel
            arrays = _run_chunk(plan, lane0, lane1)
        seconds = KERNEL_CLOCK.seconds - k0
    if store is None or mark is None or not (store.folder / mark).is_file():
        return arrays, seconds
    # through the page cache: the client reads the file back at once (``SavedChunk``); written
    # past it, the reads went to the disk (--workers 2, 1e6 cases: 1.31-1.33x in-process
    # against 1.25-1.28x, three alternating medians of 5)
    store.save(lane0, lane1, arrays, direct=False)
    return None, seconds


READ_BACK_SECONDS = 5.0
"""How long the client retries reading a chunk file that a worker has saved (a network file
system may show a file written on another machine a moment late) [s]."""


def read_back(store: ChunkStore, a: int, b: int) -> dict[str, np.ndarray]:
    """The arrays of a saved chunk, read from ``store`` (retried for ``READ_BACK_SECONDS``)."""
    deadline, wait = time.monotonic() + READ_BACK_SECONDS, 0.05
    while (arrays := store.load(a, b)) is None and time.monotonic() < deadline:
        time.sleep(wait)
        wait = min(2 * wait, 1.0)
    if arrays is None:
        raise ResultError(f"{store.path(a, b)}: the saved chunk cannot be read back to write"
                          " the result file (it stays there: run the same command again to"
                          " resume)")
    return arrays


class SavedChunk:
    """A chunk that a worker saved to the checkpoint store itself (``DaskBackend``, where the
    workers see the store): its arrays are read from there when needed."""

    def __init__(self, store: ChunkStore, lane0: int, lane1: int) -> None:
        self.store, self.lane0, self.lane1 = store, lane0, lane1

    def load(self) -> dict[str, np.ndarray]:
        return read_back(self.store, self.lane0, self.lane1)


def _start_method(config) -> str:
    """How a local cluster starts its worker processes: ``"fork"`` where dask's default
    (``"spawn"``) is not overridden, on Linux, while this process has not started Numba's thread
    pool (the OpenMP layer's is not fork-safe); else dask's setting.

    A forked worker inherits the imported numpy, numba, xarray and gearsweep and the loaded
    kernel; a spawned one imports them again, on the same cores as the client: measured on this
    2-core machine, 1e6 cases with ``--workers 2``, the run outside its chunk phase took 2.1-2.3 s
    forked against 5.0-6.1 s spawned (load average about 4).
    """
    method = config.get("distributed.worker.multiprocessing-method", "spawn")
    try:
        from numba.np.ufunc import parallel

        started = bool(parallel._is_initialized)
    except (ImportError, AttributeError):
        started = True
    if method != "spawn" or started or not sys.platform.startswith("linux"):
        return method
    return "fork"


_STARTING_WORKERS = False
"""True while a local cluster starts its worker processes (``_starting_workers``): in this
process, and in a worker forked meanwhile, which has a copy."""


def _worker_forked() -> None:
    """In a process forked while a local cluster starts (a worker): SIGINT ignored, SIGTERM's
    default action; it had this process's handlers of the start, which hold both (a worker
    then outlived its nanny's SIGTERM at the cluster's close)."""
    if _STARTING_WORKERS:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_worker_forked)


@contextlib.contextmanager
def _starting_workers(method: str):
    """While a local cluster starts its worker processes: SIGINT and SIGTERM held in this
    process (``errors.signals_held``: given to its handlers once the workers are up), SIGINT
    blocked in this thread, and so in the threads started meanwhile (dask's) and in the
    processes they start, forked or spawned (a signal mask is inherited, across ``exec`` too);
    a forked one ignores SIGINT and has SIGTERM's default action (``_worker_forked``). Where
    they are not forked (``method``), multiprocessing's resource tracker is started first: its
    start unblocks SIGINT in the thread that starts it, which then spawned a worker that died of
    a Ctrl-C (a test).

    A Ctrl-C in a terminal goes to the whole process group: workers that died of it left the
    run waiting for their chunks for good (2 of 4 tries with ``--workers 2``), so the workers
    never hear it; this process stops cleanly after the chunks in flight (the CLI's handler).
    SIGINT was ignored here too during the start, where a Ctrl-C was lost and the run went on
    to its end, exit 0 (an outside tester: 3 in 6 Ctrl-C 1 s after the start), and SIGTERM
    ended the process without a word. Outside the main thread signals cannot be set: nothing
    is changed there."""
    global _STARTING_WORKERS
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    masks = hasattr(signal, "pthread_sigmask")  # (not on Windows)
    if masks and method != "fork":
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()
    with signals_held(signal.SIGINT, signal.SIGTERM):
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if masks else None
        _STARTING_WORKERS = True
        try:
            yield
        finally:
            _STARTING_WORKERS = False
            if masks:  # (a SIGINT pending is held now)
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)


class DaskBackend:
    """Run chunks on a dask.distributed cluster: an existing one or a local one started here.

    Parameters
    ----------
    scheduler : str
        Address of an existing scheduler, ``tcp://HOST:PORT``. Its workers must import the same
        gearsweep (``provenance.identity``: its version, and its commit where it runs from a git
        checkout): a cluster with another is refused on entering (``ClusterError``), and a worker
        that joins later by its first chunk, before computing it.
    workers : int
        Start a ``LocalCluster`` of this many single-threaded worker processes instead.
    timeout : float
        Seconds to wait for a first worker (for the scheduler: at most 10) [s].
    """

    def __init__(self, scheduler: str | None = None, workers: int | None = None,
                 timeout: float = 30.0) -> None:
        if (scheduler is None) == (workers is None):
            raise ValueError("give exactly one of scheduler and workers")
        self.scheduler, self.workers, self.timeout = scheduler, workers, timeout
        self.cluster = None
        self.client = None
        self._quiet = contextlib.ExitStack()
        self.kernel_seconds = 0.0
        """Seconds the workers spent in the kernel for the chunks of the last ``run``, summed
        over the workers (so up to workers x the wall time of the chunk phase)."""
        self.stop: Callable[[], bool] = lambda: False
        """Asked while ``run`` waits for chunks (every ``STOP_POLL_SECONDS``): once true, no
        chunk is submitted, those after every chunk begun are cancelled (``_cancel_not_begun``),
        and the others waited for and yielded, then ``run`` returns (the CLI's first Ctrl-C:
        its chunks in flight were dropped, one computing while a later one was saved; an
        outside tester)."""
        self.stopping: Callable[[int], None] = lambda n: None
        """Called once ``stop`` is true, with the number of chunks ``run`` waits for."""
        self.n_workers = 0
        """Worker processes of the cluster, counted when the backend connects (an existing
        cluster's as its scheduler knows them then): the chunks are cut and the estimate
        stated for them (the CLI)."""
        self._threads = 0

    def __enter__(self) -> DaskBackend:
        import dask
        from distributed import Client, LocalCluster
        from distributed.utils import silence_logging_cmgr

        where = self.scheduler or f"a local cluster of {self.workers} workers"
        try:
            if self.workers is not None:
                method = _start_method(dask.config)
                with dask.config.set({"distributed.worker.multiprocessing-method": method}), \
                        _starting_workers(method):
                    # CRITICAL: closing a cluster of 16 workers (16-core machine, 26 Nov 2026)
                    # stops the scheduler before the workers, whose heartbeats then logged a
                    # traceback each at ERROR; a chunk that fails reaches the user as one
                    # ClusterError line (``run``) whatever the workers log
                    # No dashboard; the scheduler's own HTTP routes (health, metrics) on a free
                    # port of 127.0.0.1: with dashboard_address None they took port 8787 on every
                    # interface, and where that was taken (a second run, a dask dashboard) the
                    # scheduler retried on another port with a warning and a socket left open
                    self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1,
                                                processes=True, dashboard_address=None,
                                                scheduler_kwargs={"dashboard": False,
                                                                  "dashboard_address":
                                                                      "127.0.0.1:0"},
                                                silence_logs=logging.CRITICAL)
                self.client = Client(self.cluster)
            else:  # the client's logs quiet, as a local cluster's (``silence_logs``): a lost
                # scheduler logged 23-31 lines of tracebacks before the run's one line
                self._quiet.enter_context(silence_logging_cmgr(logging.CRITICAL))
                self.client = Client(self.scheduler, timeout=f"{min(self.timeout, 10.0)}s")
            self.client.wait_for_workers(1, timeout=self.timeout)
            if self.scheduler is not None:  # (a local cluster's workers are this process's)
                self._check_workers()
            self._count_workers()
        except ClusterError:
            self.__exit__()
            raise
        except (OSError, TimeoutError, ValueError, TypeError) as exc:  # ValueError: an address without
            self.__exit__()  # a port ('tcp://localhost'), or no address ('notaurl')
            raise ClusterError(f"{where}: cannot use the dask cluster ({type(exc).__name__}:"
                               f" {str(exc).splitlines()[0] if str(exc) else 'no reason given'})"
                               ) from None
        except BaseException:  # a stop (KeyboardInterrupt): the cluster started is closed
            self.__exit__()  # (``with`` calls ``__exit__`` only after ``__enter__`` returned)
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self.cluster is not None:
            self.cluster.close()
            self.cluster = None
        self._quiet.close()

    def _check_workers(self) -> None:
        """Refuse a cluster with a worker whose gearsweep is not this process's
        (``provenance.identity``, asked of every worker at once): it computed other numbers
        under this run's history line, exit 0 (an outside tester: a worker with a modified
        copy on its PYTHONPATH). A worker that joins later is refused by its first chunk
        (``_chunk_task``)."""
        mine = identity()
        try:
            found = self.client.run(identity)
        except Exception as exc:  # noqa: BLE001 - a worker that cannot import gearsweep at all
            msg = str(exc).splitlines()[0] if str(exc) else ""
            raise ClusterError(f"{self.scheduler}: a dask worker cannot run gearsweep"
                               f" ({type(exc).__name__}: {msg}); start the workers with the"
                               " same gearsweep (installed, or on their PYTHONPATH:"
                               " docs/scale.md)") from None
        for address, theirs in sorted(found.items()):
            if theirs != mine:
                raise other_gearsweep(address, theirs, mine)

    def _procs_per_host(self) -> dict[str, int]:
        info = self.client.scheduler_info(n_workers=-1)["workers"]
        out: dict[str, int] = {}
        for addr in info:
            host = urlparse(addr).hostname or ""
            out[host] = out.get(host, 0) + 1
        return out

    def _count_workers(self) -> None:
        """``n_workers`` and ``threads``, asked of the scheduler once, on connecting."""
        info = self.client.scheduler_info(n_workers=-1)["workers"]
        self.n_workers = len(info) if self.cluster is None else self.workers
        self._threads = (cores() if self.cluster is not None  # the local workers share this
                         else max(1, sum(int(w.get("nthreads", 1)) for w in info.values())))
        # machine's cores

    @property
    def threads(self) -> int:
        """Cores of the cluster: its dask threads (dask's default is one per core), counted on
        connecting (``n_workers``)."""
        return self._threads

    def run(self, plan: Plan, todo: list[tuple[int, int]], store: ChunkStore | None = None
            ) -> Iterator[tuple[int, int, dict[str, np.ndarray] | SavedChunk]]:
        """Compute the chunks ``todo`` on the cluster; yield each chunk's arrays as it finishes.

        With a checkpoint ``store``, a worker that sees the store's folder (a local cluster's
        always; an existing cluster's on a shared file system) saves its chunks' arrays there
        itself, and a ``SavedChunk`` is yielded instead: the results do not pass through this
        process's sockets and its one thread of unpickling, and the checkpoint files are
        written by the workers side by side, not one after another here. (The 1e6-case study
        with two local workers on two cores: this process's CPU in the chunk phase 0.39 s
        before, 0.32 s after.) A worker sees the folder where it finds there the file this run
        marks it with (``checkpoint.shared_mark``); one that does not (another machine,
        another file system) sends its arrays, as before."""
        if self.client is None:
            raise RuntimeError("enter the backend first: with DaskBackend(...) as backend: ...")
        if store is not None:
            store = store.absolute()
        mark = shared_mark(store.folder) if store is not None else None
        try:
            yield from self._run(plan, todo, store, mark)
        finally:
            if mark is not None:
                (store.folder / mark).unlink(missing_ok=True)

    def _cancel_not_begun(self, futures: dict[str, object], where: dict[str, tuple[int, int]],
                          after: tuple[int, int] = (-1, -1)) -> None:
        """A stop: cancel the chunks of ``futures`` (by key) after, in lane order, every chunk
        a worker has begun (the workers are asked which they execute), every chunk finished
        (a future done) and ``after`` (the last chunk already yielded); the others are kept
        and waited for, so that the chunks saved are the first ones, with no hole (the
        scheduler may begin a chunk before an earlier one that waits on another worker, and
        finish it first). A worker that does not answer is skipped (its chunks are not
        computing); where the scheduler does not answer, which chunks compute is not known and
        every one is kept (a second Ctrl-C stops at once)."""
        try:
            answers = self.client.run(_executing, on_error="return")
        except Exception:  # noqa: BLE001 - the scheduler gone: the chunks fail when yielded
            return
        executing = {key for keys in answers.values() if not isinstance(keys, BaseException)
                     for key in keys}
        begun = [where[k] for k, f in futures.items() if k in executing or f.done()]
        last = max([after, *begun])
        waiting = [f for k, f in futures.items() if where[k] > last]
        for f in waiting:
            del futures[f.key]
        if waiting:
            self.client.cancel(waiting)

    def _run(self, plan: Plan, todo: list[tuple[int, int]], store: ChunkStore | None,
             mark: str | None) -> Iterator[tuple[int, int, dict[str, np.ndarray] | SavedChunk]]:
        from distributed import as_completed

        procs = self._procs_per_host()
        self.kernel_seconds = 0.0
        window = 2 * sum(procs.values()) + 2  # keeps every worker busy, bounds memory in flight
        sha = plan.study_key[:16]
        mine = identity()
        pending = iter(todo)
        where: dict[str, tuple[int, int]] = {}
        futures: dict[str, object] = {}  # submitted, not yet yielded or cancelled
        queue = as_completed()
        stopping = False
        yielded = (-1, -1)  # the last chunk yielded, in lane order

        def submit() -> bool:
            chunk = None if stopping else next(pending, None)
            if chunk is None:
                return False
            fut = self.client.submit(_chunk_task, plan, chunk[0], chunk[1], procs, store, mark,
                                     mine, retries=2, key=f"gearsweep-{sha}-{chunk[0]}-{chunk[1]}",
                                     pure=False)
            where[fut.key] = chunk
            futures[fut.key] = fut
            queue.add(fut)
            return True

        def finished() -> Iterator:
            """The futures as they finish, the stop asked between (``self.stop``)."""
            nonlocal stopping
            while True:
                if not stopping and self.stop():
                    stopping = True
                    self._cancel_not_begun(futures, where, yielded)
                    self.stopping(len(futures))
                if queue.has_ready():
                    yield next(queue)
                elif queue.is_empty():
                    return
                else:
                    with queue.thread_condition:
                        queue.thread_condition.wait(timeout=STOP_POLL_SECONDS)

        for _ in range(window):
            if not submit():
                break
        for fut in finished():
            if futures.pop(fut.key, None) is None:  # cancelled by a stop
                continue
            a, b = where.pop(fut.key)
            try:
                got = fut.result()
            except Exception as exc:
                msg = str(exc).splitlines()[0] if str(exc) else ""
                if fut.status != "error":  # the chunk did not fail: the client lost the
                    # scheduler (its futures cancelled, "scheduler-connection-lost", or an
                    # OSError of its own connection, said as a worker's failing disk)
                    why = getattr(exc, "reason", None) or f"{type(exc).__name__}: {msg}"
                    raise ClusterError(f"{self.scheduler or 'local cluster'}: lost the"
                                       f" connection to the dask scheduler ({why})") from None
                raise ClusterError(f"{self.scheduler or 'local cluster'}: chunk of lanes {a}-{b}"
                                   f" failed: {type(exc).__name__}: {msg}") from exc
            fut.release()
            if got[0] == OTHER_GEARSWEEP:  # a worker that joined after the check
                raise other_gearsweep(got[1], got[2], mine)
            arrays, seconds = got
            self.kernel_seconds += seconds
            yielded = max(yielded, (a, b))
            yield a, b, arrays if arrays is not None else SavedChunk(store, a, b)
            submit()


STOP_POLL_SECONDS = 0.05
"""How often ``DaskBackend.run`` asks ``stop`` while no chunk finishes [s]."""


def _executing(dask_worker) -> list[str]:
    """The keys of the tasks a dask worker is executing (``client.run``)."""
    return [ts.key for ts in dask_worker.state.executing]


# ------------------------------------------------------------------------------------ runs


def _fits(plan: Plan, a: int, b: int, arrays: dict[str, np.ndarray]) -> bool:
    """Whether a saved chunk has exactly the variables, shapes and dtypes the study expects."""
    want = result_layout(plan, b - a)
    return set(arrays) == set(want) and all(
        arr.shape == want[name][0] and arr.dtype == want[name][1] for name, arr in arrays.items())


def chunks_to_run(plan: Plan, output: str | Path | None, chunk_cases: int | None
                  ) -> list[tuple[int, int]]:
    """The chunks (lane ranges) of ``plan`` written to ``output``: those of an interrupted run
    of the same study there (``checkpoint.saved_layout``), else about ``chunk_cases`` cases
    each (``None``: the runner's default), the first and the last shorter
    (``with_short_ends``)."""
    saved = None if output is None else saved_layout(output, plan.study_key, plan.n_lanes)
    return saved or with_short_ends(plan, plan.chunks(lanes_per_chunk(plan, chunk_cases)))


def _open_store(plan: Plan, checkpoint: str | Path | None, chunks: list[tuple[int, int]]
                ) -> tuple[ChunkStore | None, list[tuple[int, int]]]:
    """The checkpoint store of ``plan`` next to ``checkpoint`` (``None``: no store) and the
    chunks already saved there intact; a chunk file that cannot be read or does not fit the
    study is removed, so that it is computed again."""
    if checkpoint is None:
        return None, []
    store = ChunkStore(checkpoint, plan.study_key, plan.n_lanes, chunks)
    done = []
    for a, b in store.open():
        try:
            ok = _fits(plan, a, b, store.records(a, b))
        except (OSError, ValueError, EOFError):
            ok = False
        if ok:
            done.append((a, b))
        else:
            store.discard(a, b)
    return store, done


def _compute(plan: Plan, todo: list[tuple[int, int]], done_cases: int,
             backend: InProcess | DaskBackend | None, store: ChunkStore | None, progress: bool | str,
             sink=None, open_file=None, done: list[tuple[int, int]] = ()
             ) -> tuple[float, float | None, ResultFile | None]:
    """Compute the chunks ``todo``; in background threads while the next one computes, make
    each chunk's arrays (where the backend yields the function that makes them: ``InProcess``),
    pass them to ``sink(lane0, lane1, arrays)`` (if given) and save them to ``store`` (the saver
    thread), and write them into the result file (if ``open_file`` is given; the writer thread).

    The writer thread first creates the result file (``open_file()``, a ``ResultFile``: its
    set-up overlaps the first chunk's kernel) and writes into it the chunks ``done`` (already in
    ``store``), while the first chunks compute. Returns the chunk phase's seconds (after the
    one-time warm-up), the part of them spent in the kernel (``KERNEL_CLOCK`` in this process;
    under dask, summed over the workers) and the result file, every chunk written, to be closed
    by the caller (on an error it is removed here).

    With a ``store``, each chunk saved is recorded there with the chunk phase's and the
    kernel's seconds so far (``checkpoint.RunLog``, in the saver thread): what a resumed run
    reads of this one (``ChunkStore.earlier_runs``), however this one ends.
    """
    per_lane = plan.cases_per_lane
    runlog = None
    if store is not None:  # its history line: the run's start, with this thread's command
        context, started = contextvars.copy_context(), datetime.now(UTC)  # (provenance), made
        runlog = RunLog(store.folder, lambda: context.run(history_line, started))  # when the
        # first chunk is saved, beside the next chunk's kernel
    bar = (_LogLines(plan, done_cases) if progress == "log"
           else _progress_bar(plan, done_cases) if progress else _NoBar())
    be = backend if backend is not None else InProcess()
    # Two background threads while the next chunk computes: one makes each chunk's arrays and
    # saves its checkpoint file, the other writes the result file, so that the two overlap on a
    # machine with cores to spare (the kernel releases the GIL, and so do the file writes and
    # netCDF4's compression: ``ResultFile``). In one thread they followed each other: on 16
    # cores about 1.9 s beside a 1e7-case run's 3 s kernel, and with compression the chunk
    # phase was 0.2 s longer than without (docs/scale-log.md). At most two chunks wait for them.
    saver = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gearsweep-saver")
    writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gearsweep-writer")

    files: list[ResultFile] = []
    order = InLaneOrder([*done, *todo], store) if open_file is not None else None

    def write(a: int, b: int, arrays: dict[str, np.ndarray] | None = None) -> None:
        if files:  # else the file could not be made: ``opened`` raises why
            order.add(files[0], a, b, arrays)

    def kernel_now() -> float | None:
        """The kernel's seconds in this run's chunk phase so far."""
        return KERNEL_CLOCK.seconds - k0 if isinstance(be, InProcess) \
            else getattr(be, "kernel_seconds", None)

    def keep(a: int, b: int, arrays) -> Future | None:
        """In the saver thread: the chunk's arrays, its checkpoint and its record; the file's
        write handed to the writer thread (returned: its future)."""
        if isinstance(arrays, SavedChunk):  # its dask worker saved it: read when needed
            if runlog is not None:
                runlog.chunk(a, b, time.perf_counter() - t0, kernel_now())
            if sink is not None:
                sink(a, b, arrays.load())
            return writer.submit(write, a, b) if order is not None else None
        if callable(arrays):  # InProcess: the chunk's arrays are made here (beside the next chunk)
            arrays = arrays()
        if sink is not None:
            sink(a, b, arrays)
        if store is not None:
            store.save(a, b, arrays)
            runlog.chunk(a, b, time.perf_counter() - t0, kernel_now())
        return writer.submit(write, a, b, arrays) if order is not None else None

    def start() -> None:
        files.append(open_file())
        for a, b in done:
            order.add(files[0], a, b)

    def settle(pending: Future) -> None:
        """Wait for a chunk to be saved and written (``pending``: the saver's future)."""
        written = pending.result()
        if written is not None:
            written.result()

    saves: list[Future] = []
    opened: Future | None = None
    try:
        if todo and isinstance(be, InProcess):
            warm_up(plan, todo[0])
        t0 = time.perf_counter()  # the chunk phase starts after the one-time warm-up
        k0 = KERNEL_CLOCK.seconds
        if todo and isinstance(be, InProcess):
            be.prepare_first(plan, todo[0])
        if open_file is not None:  # after the warm-up: Python beside Python gains nothing (the
            opened = writer.submit(contextvars.copy_context().run, start)  # GIL), beside the
            # kernel it does; with this thread's context: the history's command (provenance)
        chunks = be.run(plan, todo, store) if isinstance(be, DaskBackend) else be.run(plan, todo)
        for a, b, arrays in chunks:
            saves.append(saver.submit(keep, a, b, arrays))
            while len(saves) > 2:
                settle(saves.pop(0))
            if opened is not None and opened.done():
                opened.result()  # the file could not be made: stop now, not after every chunk
            del arrays
            bar.update((b - a) * per_lane)
        if opened is not None:
            opened.result()
        for f in saves:  # the chunk phase ends when the last chunk is saved and written
            settle(f)
        if order is not None:
            order.check()
        elapsed = time.perf_counter() - t0
    except BaseException:
        try:
            for f in saves:  # what was computed is saved, even if the run is failing
                if f.exception() is None and f.result() is not None:
                    f.result().exception()
        finally:
            saver.shutdown()
            writer.shutdown()
            bar.close()
            if runlog is not None:
                runlog.close()
            if files:
                files[0].abort()
        raise
    saver.shutdown()
    writer.shutdown()
    bar.close()
    if runlog is not None:
        runlog.close()
    return elapsed, kernel_now(), files[0] if files else None


class InLaneOrder:
    """Chunks go into the result file in the order of their lanes, whatever order they finish
    in: a chunk that finishes before the chunks in front of it waits in its checkpoint file
    (``store``), not in memory, and is written (read back from there) once they are.

    HDF5 compresses and stores a chunk of the file when it is complete and leaves the chunk
    cache (``ResultFile``: room for one per variable); a run's chunk of lanes that ends inside
    one leaves it partly filled until the next run chunk completes it. In lane order, that is
    the chunk written next, so every file chunk is stored once, where a run in one process
    stores it. Out of order (dask workers, up to 2N+2 chunks in flight), the partly filled
    chunk was stored, then read back, completed and stored again elsewhere: the 1e6-case file
    of ``--workers 16`` was 54.1 MB against 48.9 MB in-process (26 Nov 2026, 16-vCPU machine),
    the data the same. Now a run whose chunks finish out of order, or a resumed run, writes
    the bytes an in-process run of the same chunks writes (tested, ``tests/test_execute.py``).
    """

    def __init__(self, chunks: list[tuple[int, int]], store: ChunkStore | None) -> None:
        self.order = sorted(chunks)
        self.store = store
        self.next = 0
        self.waiting: dict[tuple[int, int], dict[str, np.ndarray] | None] = {}

    def add(self, file: ResultFile, a: int, b: int,
            arrays: dict[str, np.ndarray] | None = None) -> None:
        """Chunk ``[a, b)`` is finished (``arrays``; ``None``: read it from the store): write
        it, and the chunks waiting behind it, if its turn has come; else it waits."""
        if (a, b) != self.order[self.next]:
            # without a store (not a run that writes a file) the arrays wait in memory
            self.waiting[(a, b)] = None if self.store is not None else arrays
            return
        file.write(a, b, arrays if arrays is not None else self._load(a, b))
        self.next += 1
        while self.next < len(self.order) and self.order[self.next] in self.waiting:
            chunk = self.order[self.next]
            held = self.waiting.pop(chunk)
            file.write(*chunk, held if held is not None else self._load(*chunk))
            self.next += 1

    def _load(self, a: int, b: int) -> dict[str, np.ndarray]:
        if self.store is None:  # not reached: without a store, chunks wait in memory
            raise RuntimeError(f"chunk of lanes {(a, b)} is neither held nor saved")
        return read_back(self.store, a, b)

    def check(self) -> None:
        """Every chunk was written (a chunk that never arrived would leave a hole)."""
        if self.next != len(self.order):
            raise RuntimeError(f"chunk of lanes {self.order[self.next]} never reached the"
                               " result file")


def _progress_bar(plan: Plan, done_cases: int):
    """The progress bar of a run (tqdm, on stderr), refreshed per finished chunk."""
    from tqdm import tqdm

    return tqdm(total=plan.n_cases, initial=done_cases, unit="case",  # 1.2M cases, but 6 (not
                unit_scale=plan.n_cases >= 1000,  # '0.00/6.00': an adversarial test)
                desc=plan.study.title[:30], file=sys.stderr, leave=False, smoothing=0.1,
                mininterval=0, miniters=1)


LOG_PROGRESS_SECONDS = 30.0
"""Without a terminal (a batch job's log, ``nohup``, a pipe), ``progress="log"`` prints a plain
line on stderr at most this often [s], the first after this long: a run shorter than it prints
none (a run in a batch log showed nothing until its end; an engineer new to the tool)."""


class _LogLines:
    """Progress as plain lines for a log (``progress="log"``): cases done, time so far, time
    left at the rate of this run's chunks, per finished chunk but at most every
    ``LOG_PROGRESS_SECONDS``."""

    def __init__(self, plan: Plan, done_cases: int) -> None:
        self.total, self.done, self.first = plan.n_cases, done_cases, done_cases
        self.t0 = self.last = time.perf_counter()

    def update(self, n: int) -> None:
        self.done += n
        now = time.perf_counter()
        if now - self.last < LOG_PROGRESS_SECONDS or self.done >= self.total:
            return
        self.last = now
        rate = (self.done - self.first) / (now - self.t0)
        left = f", about {_duration((self.total - self.done) / rate)} left" if rate > 0 else ""
        print(f"gearsweep: {self.done:,} of {self.total:,} cases ({self.done / self.total:.0%}),"
              f" {_duration(now - self.t0)} so far{left}", file=sys.stderr, flush=True)

    def close(self) -> None:
        pass


class _NoBar:
    """No progress bar: without one, tqdm is not imported (20 ms) and starts no thread."""

    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def run_plan(plan: Plan, *, backend: InProcess | DaskBackend | None = None,
             checkpoint: str | Path | None = None, chunk_cases: int | None = None,
             progress: bool = False) -> xr.Dataset:
    """Run every chunk of ``plan`` (those not already checkpointed) and return the Dataset,
    held in memory (``run_to_file`` streams a study of any size to disk instead).

    Parameters
    ----------
    backend : InProcess or DaskBackend
        Where the chunks run (default ``InProcess()``); a ``DaskBackend`` must be entered
        (``with DaskBackend(...) as backend:``).
    checkpoint : path
        The result file the study will be written to: chunks are saved next to it as they finish
        and reused by a re-run (see ``gearsweep.study.checkpoint``). ``None``: no checkpoints.
    chunk_cases : int
        About this many cases per chunk (default: about ``runner.CHUNK_STEPS`` steps per chunk).
    progress : bool or "log"
        Show a progress bar (tqdm, on stderr) updated per finished chunk; ``"log"``: plain
        lines instead, at most every ``LOG_PROGRESS_SECONDS`` (for a log, not a terminal).

    The Dataset's ``elapsed_seconds`` is the chunk phase: computing the chunks and saving their
    checkpoints (in-process, after ``warm_up`` has loaded the compiled kernel); in-process, its
    ``kernel_seconds`` is the part of it spent in the kernel (``runner.KERNEL_CLOCK``), so their
    ratio is the study's overhead over the bare kernel, measured in the same run. A resumed run
    (saved chunks used) gives both summed over the runs that computed its chunks, a ``history``
    line per run and each run's share (``resultfile.run_attrs``).
    """
    from gearsweep.study.dataset import assemble, empty_results, store_chunk

    chunks = chunks_to_run(plan, checkpoint, chunk_cases)
    results = empty_results(plan)
    store, done = _open_store(plan, checkpoint, chunks)
    for a, b in done:
        store_chunk(results, plan, a, b, store.load(a, b))
    todo = [c for c in chunks if c not in done]
    earlier = store.earlier_runs(done) if store is not None else []
    per_lane = plan.cases_per_lane
    elapsed, kernel, _ = _compute(
        plan, todo, sum(b - a for a, b in done) * per_lane, backend, store, progress,
        sink=lambda a, b, arrays: store_chunk(results, plan, a, b, arrays))
    return assemble(plan, results, elapsed, kernel, earlier, len(todo))


@dataclass(frozen=True)
class Written:
    """What ``stream_to_file`` wrote: counted as the chunks were written, so that a caller that
    only reports them (the CLI) does not open the file again."""

    path: Path
    cases: int
    elapsed: float
    """The chunk phase [s] (the file's ``elapsed_seconds``): of a resumed run, summed over the
    runs that computed its chunks (NaN where an earlier run's was not recorded)."""
    flagged: int
    """Cases whose ``status`` is not 0."""
    beyond: int
    """Cases beyond the step limit (``beyond_step_limit``; 0 where it is not stored)."""
    contact_lost: int = 0
    """Cases whose teeth would separate (``contact_lost``; 0 where it is not stored)."""
    parted: int | None = None
    """Cases whose flanks parted (``outputs.parted_cases``; ``None`` where not stored)."""
    chunks: int = 0
    """Chunks of the study."""
    earlier_chunks: int = 0
    """Of them, those saved by earlier runs (a resumed run's; 0: computed by this run alone)."""
    earlier_runs: int = 0
    """The earlier runs that saved them."""
    run_elapsed: float = 0.0
    """This run's own chunk phase [s] (``elapsed`` where it is not resumed)."""


def run_to_file(plan: Plan, output: str | Path, *, backend: InProcess | DaskBackend | None = None,
                chunk_cases: int | None = None, progress: bool | str = False,
                codec: str | None = None) -> xr.Dataset:
    """Run ``plan`` with checkpoints next to ``output``, writing the netCDF as the chunks finish
    (``stream_to_file``), and return the file opened lazily.

    The results stream to disk: every finished chunk goes, in a background thread that overlaps
    the next chunk's kernel, to its checkpoint file and into the result file (``ResultFile``,
    being written as ``OUT.nc.chunks/<sha256>/writing.nc``), and is dropped from memory; after
    the last chunk the file gets its global attributes and is renamed to ``output``. So the
    memory a run needs depends on the chunk size, not on the number of cases, and no pass over
    the results follows the computation.
    A run killed at any point leaves the chunks it finished (the half-written netCDF is not
    trusted: a re-run writes it afresh); running the same study to the same output again
    computes only the others, writes the saved ones into the new file while they compute, and
    writes the same data, bit for bit, with a ``history`` line per run and the timings summed
    over the runs (``resultfile.run_attrs``, from each run's record in the checkpoint folder).

    Returns the written file opened lazily (``xr.open_dataset(output)``: each variable read
    when used; not dask arrays, whose first computation imports dask.distributed, 0.2-0.6 s).
    """
    stream_to_file(plan, output, backend=backend, chunk_cases=chunk_cases, progress=progress,
                   codec=codec)
    import xarray as xr

    # absolute: xarray expands a leading '~' that the writing did not (``output='~/r.nc'`` was
    # written to ./~/r.nc, then opened from the home folder: FileNotFoundError after the run)
    return xr.open_dataset(os.path.abspath(output))


def stream_to_file(plan: Plan, output: str | Path, *,
                   backend: InProcess | DaskBackend | None = None, chunk_cases: int | None = None,
                   progress: bool | str = False, codec: str | None = None) -> Written:
    """``run_to_file`` without opening the written file: what was written, counted on the
    way."""
    check_replaceable(output)  # before any computing
    problem = checkpoint_problem(output)
    if problem is not None:
        raise ResultError(f"{output}: {problem}")
    chunks = chunks_to_run(plan, output, chunk_cases)
    try:
        store, done = _open_store(plan, output, chunks)
    except OSError as exc:  # the folder cannot be made or written (/proc/x.nc, read-only)
        raise ResultError(f"{output}: cannot write the result here"
                          f" ({exc.strerror or type(exc).__name__})") from None
    todo = [c for c in chunks if c not in done]
    earlier = store.earlier_runs(done)
    per_lane = plan.cases_per_lane
    try:
        elapsed, kernel, file = _compute(
            plan, todo, sum(b - a for a, b in done) * per_lane, backend, store, progress,
            open_file=lambda: _result_file(plan, output, store.folder / WRITING, codec),
            done=done)
        file.close(elapsed, kernel, earlier, len(todo))
    except KeyboardInterrupt as stop:  # (the chunks computed are saved by now: ``_compute``)
        saved = sum(1 for c in chunks if store.path(*c).is_file())
        raise KeyboardInterrupt(  # what a caller of the Python API sees (it was empty; the
            f"{output}: interrupted: {saved} of {len(chunks)} chunks saved in {store.root};"
            " the same study run to the same output continues") from stop  # CLI says its own)
    except (OSError, ClusterError) as failed:  # a full disk, a folder gone or made read-only
        exc = failed if isinstance(failed, OSError) else failed.__cause__  # (on a dask worker)
        saved = sum(1 for c in chunks if store.path(*c).is_file())
        if not isinstance(exc, OSError):  # a chunk's error, a lost scheduler: what is kept
            raise ClusterError(f"{failed}; {saved} of {len(chunks)} chunks saved in"
                               f" {store.root}: run the same command to continue") from failed
        where = f" {exc.filename}" if exc.filename else ""
        if exc.filename2:  # a rename (the finished file onto the output): both its ends
            where = f" {exc.filename} to {exc.filename2}"
        what = (f"cannot {'rename' if exc.filename2 else 'write'}{where}" if exc is failed
                else f"a dask worker failed{' on' if where else ''}{where}")
        raise ResultError(
            f"{output}: {what}: {exc.strerror or exc}; {saved} of"
            f" {len(chunks)} chunks saved in {store.root}:"
            f" {_remedy(exc.errno)} and run the same command to continue") from failed
    try:  # the result is in place: what follows only tidies up
        remove_checkpoints(output)
    except KeyboardInterrupt:  # a stop now reported a failed run and left half the chunks,
        remove_checkpoints(output)  # which a run of the same study said it resumed (an
        # adversarial test): the run is done; the caller ends it as a run that finished
    return Written(path=Path(output), cases=plan.n_cases,
                   elapsed=float(file.written["elapsed_seconds"]), flagged=file.flagged,
                   beyond=file.beyond, contact_lost=file.contact_lost, parted=file.parted,
                   chunks=len(chunks), earlier_chunks=len(done),
                   earlier_runs=len(earlier), run_elapsed=round(elapsed, 3))


def _remedy(code: int | None) -> str:
    """What to do about a file that could not be written (its ``errno``)."""
    if code in (errno.ENOSPC, errno.EDQUOT):
        return "make room"
    if code == errno.EFBIG:  # a file past this process's file-size limit
        return "raise the file-size limit (ulimit -f)"
    return "fix that"


def step_limit_warning(plan: Plan, ds: xr.Dataset, where: str | Path) -> StepLimitWarning | None:
    """The one line about the cases of the result ``ds`` of ``plan`` whose step is beyond the
    method's stability limit (``solver.step_guard: warn``: its variable ``beyond_step_limit``),
    named after ``where`` (the result file, or the study); ``None`` when there are none.
    ``gearsweep.run`` warns it and the CLI prints it (``gearsweep: warning: ...``): one text."""
    if "beyond_step_limit" not in ds:  # step_guard skip or off
        return None
    return step_limit_text(plan, int(ds["beyond_step_limit"].sum()), where)


def contact_lost_warning(plan: Plan, ds: xr.Dataset, where: str | Path
                         ) -> ContactLossWarning | None:
    """The one line about the cases of the result ``ds`` whose teeth would separate (its
    variable ``contact_lost``), as ``step_limit_warning``; ``None`` when there are none."""
    if "contact_lost" not in ds:
        return None
    return contact_lost_text(plan, int(ds["contact_lost"].sum()), where)


def contact_lost_text(plan: Plan, n: int, where: str | Path) -> ContactLossWarning | None:
    """The line about ``n`` cases whose loaded flank left contact (``None`` when ``n`` is 0),
    naming the flank by the sign of the plan's mean forces (``outputs.loaded_flank_lost``)."""
    if not n:
        return None
    signs = plan.load_signs
    if signs == {1}:
        what, other = "leave drive-flank contact (p below 0", "the back flanks"
    elif signs == {-1}:
        what = ("leave back-flank contact, the flank their negative mean force presses (p"
                " above 0")
        other = "the drive flanks"
    elif signs == {0}:
        what, other = ("change flank without a mean force (p of both signs", "the other flanks")
    else:
        what = ("leave the flank their mean force presses (p below 0 under F_m > 0, above 0"
                " under F_m < 0, of both signs under F_m = 0")
        other = "the other flanks"
    return ContactLossWarning(
        f"{where}: {n} of {plan.n_cases} case(s) {what} in the steady state, variable"
        f" 'contact_lost'): a scene without backlash takes {other} into contact at once (a pair"
        " with no backlash), where a real pair's teeth would separate; a full scene with"
        " scene.backlash models that")


def step_limit_text(plan: Plan, n: int, where: str | Path, *, before: bool = False
                    ) -> StepLimitWarning | None:
    """The line about ``n`` cases beyond the step limit (``None`` when ``n`` is 0): of a result,
    or with ``before``, of a study not yet run (``gearsweep validate``), as its step guard
    will treat them."""
    if not n:
        return None
    s = plan.study.solver
    head = (f"{where}: {n} case(s) {'will use' if before else 'use'} a step beyond the stability"
            f" limit of {s.method} at {s.steps_per_period} steps/period")
    if plan.memo.get("unanalysed"):
        head += (f" (or whose fixed-step map it could not check: k(t)'s orders have no common"
                 f" period of at most {HILL_CYCLE_MAX} mesh periods; unchecked, not passed)")
    if plan.memo.get("resonance_flagged"):
        head += (f" (or where its fixed-step map's forced response, 1 / det(I - M) near a"
                 f" parametric resonance of k(t), is more than {RESONANCE_TOL:.0%} off the"
                 " equation's: docs/stability.md)")
    if s.step_guard == "skip":
        return StepLimitWarning(f"{head}; step_guard: skip leaves them uncomputed (status 3,"
                                " skipped; raise solver.steps_per_period to compute them)")
    return StepLimitWarning(
        f"{head}; their results may be spoiled by the integrator"
        " (variable 'beyond_step_limit'; raise solver.steps_per_period or set"
        " solver.step_guard: skip)")


def _result_file(plan: Plan, output: str | Path, tmp: Path, codec: str | None) -> ResultFile:
    """The streamed result file (made in the writer thread: its netCDF4 import and set-up
    overlap the first chunk's kernel)."""
    return ResultFile(plan, output, tmp=tmp, codec=codec)
