"""What a study will cost, from arithmetic on its sizes: no grid of cases, no kernel call.

``quick_estimate`` gives the same ``Estimate`` as ``execute.estimate`` (stated kernel rate; on
the CPU: ``execute.estimate`` knows no GPU) for any number of cases in microseconds: the chunks
are counted, not listed, and nothing is compiled. When the kernel this study needs is not yet in
Numba's disk cache, its one-time compile time is added (``compile_seconds``), and the memory
the compile adds to the peak (``compile_bytes``), so that ``--estimate`` and ``validate`` state
the wait and the memory a first run really has.
"""

from __future__ import annotations

import math

import numpy as np

from gearsweep.kernels import LANES, cuda
from gearsweep.kernels.batch import (
    COLD_COMPILE_BYTES,
    COLD_COMPILE_SECONDS,
    compile_peak,
    not_compiled,
)
from gearsweep.study import execute
from gearsweep.study.chunk import kernel_calls
from gearsweep.study.execute import (
    BASELINE_MEMORY,
    FIXED_SECONDS,
    STATED_RATE,
    WRITE_RATE,
    Estimate,
    _case_bytes,
    chunk_overhead,
    chunks_held,
    cores,
    disk_bytes,
    kernel_threads,
    lanes_per_chunk,
    load_costs,
    measure_rate,
    output_seconds,
    table_bytes,
    with_short_ends,
)
from gearsweep.study.filelayout import output_bound
from gearsweep.study.plan import Plan


def compile_seconds(plan: Plan, ask_cache: bool = True) -> float:
    """The one-time compile time of the kernel specialisations a CPU run of ``plan`` calls
    (``chunk.kernel_calls``) that are neither in Numba's disk cache nor compiled in this process
    (``batch.compiled``); 0 when all are. ``ask_cache=False``: the most it can be, every
    specialisation counted as not compiled, without asking the cache (7-8 ms the first time in a
    process: typing the call's arguments, reading the cache's index).

    Each driver is compiled per combination of the terms a call gives (``rk.Specialised``:
    ``integrate_rk4_a0k1e1f0h0s0`` is RK4 with a shared stiffness table and an STE table, no
    force table, no backlash, no signal) and per argument types, so it is this study's
    combination that is looked up, with the types of its own call, and only in the cache files
    of the source as it is (Numba's index stamp). (Asking whether any specialisation of the
    method was cached said "no compile" for a study of other terms, which then compiled for
    seconds.) A GPU run compiles its CUDA kernel in every process instead, for a time not
    measured yet (``Estimate.line`` says so): 0 here."""
    return sum(COLD_COMPILE_SECONDS[key[:2]] for key in _not_compiled(plan, ask_cache))


def compile_bytes(plan: Plan, ask_cache: bool = True) -> float:
    """The memory the one-time compile of the kernel specialisations a CPU run of ``plan``
    calls adds to the run's peak [bytes]: ``batch.compile_peak`` of the ``COLD_COMPILE_BYTES`` of
    those not compiled (as ``compile_seconds`` asks); 0 when all are compiled, and on a GPU
    (``cuda.HOST_MEMORY_BYTES`` counts its process). It is counted on top of the chunks': the
    compile comes first, in the warm-up, and what LLVM frees is not all given back to the
    system."""
    return compile_peak([COLD_COMPILE_BYTES[key[:2]] for key in _not_compiled(plan, ask_cache)])


def _not_compiled(plan: Plan, ask_cache: bool) -> set[tuple]:
    """The ``specialisation`` keys of the kernel calls of a CPU run of ``plan`` that are
    neither in Numba's cache nor compiled in this process (every one: ``ask_cache=False``)."""
    return set() if plan.device == "cuda" else not_compiled(kernel_calls(plan), ask_cache)


def quick_estimate(plan: Plan, chunk_cases: int | None = None, threads: int | None = None,
                   rate: float | None = None, ask_cache: bool = True,
                   workers: int | None = None, new_process: bool = True
                   ) -> tuple[Estimate, float]:
    """(estimate at the stated rate, or at ``rate`` [Msteps/s per core] measured, of which
    seconds to compile the kernel on a cold cache). ``ask_cache=False``: an upper bound, with
    every specialisation the run calls counted as compiled on the spot (``compile_seconds``).
    ``workers``: the dask worker processes that run the chunks on ``threads`` cores in all
    (``None``: this process). ``new_process``: of a run in a process still to start (``gearsweep
    run``), which pays ``FIXED_SECONDS``; ``False``: of a run in this running process
    (``gearsweep.run``, ``gearsweep.estimate``), which does not (it estimated a 3-case study
    run in a notebook at 1.00 s that took 0.005 s; an outside tester)."""
    threads = threads or kernel_threads()  # (NUMBA_NUM_THREADS=1 was estimated on every core)
    s = plan.study.solver
    per = lanes_per_chunk(plan, chunk_cases) or plan.default_lanes_per_chunk()
    n = plan.n_lanes
    full, rest = divmod(n, per)
    ways = max(len(plan.directions), 1)

    def rounds(lanes: int) -> int:
        return math.ceil(math.ceil(lanes * ways / LANES) / threads)

    source = "measured" if rate else "stated"
    loads_s = 0.0
    if plan.device == "cuda":  # one thread per lane: the steps themselves, at the GPU's rate
        kernel_s = float(plan.n_cases) * plan.steps_per_case / cuda.STATED_STEPS_PER_SECOND
        rate = cuda.STATED_STEPS_PER_SECOND / 1e6
        source = "stated"
    else:
        lane_steps = float(full * rounds(per) + (rounds(rest) if rest else 0)) * plan.chain \
            * LANES * plan.steps_per_case
        if plan.gear_load_swept:  # one kernel call per load in a chunk, each load's model
            lane_steps, loads_s = load_costs(plan, *_chunk_bounds(plan, per, threads), threads)
        rate = rate or STATED_RATE[s.method]
        kernel_s = lane_steps / (rate * 1e6)
    per_case = _case_bytes(plan)
    output = float(output_bound(plan))
    compile_s = compile_seconds(plan, ask_cache)
    compile_b = compile_bytes(plan, ask_cache)
    start_s = FIXED_SECONDS if new_process else 0.0
    seconds = kernel_s + loads_s + start_s + output / WRITE_RATE + compile_s
    biggest = min(per, n) * plan.cases_per_lane
    signal = min(per, n) * plan.samples_per_period() * s.record_periods * 8
    memory = BASELINE_MEMORY + chunks_held(plan) * biggest * per_case + signal + compile_b
    if plan.device == "cuda":
        memory += cuda.HOST_MEMORY_BYTES
    count = full + (1 if rest else 0)
    memory += table_bytes(plan, several=count > 1)
    ends = [(0, min(per, n))] + ([(n - (rest or per), n)] if count > 1 else [])
    count += len(with_short_ends(plan, ends, threads)) - len(ends)  # as chunks_to_run cuts them
    outputs_s = output_seconds(plan, count)
    est = Estimate(cases=plan.n_cases, steps=float(plan.n_cases) * plan.steps_per_case,
                   chunks=count, threads=threads, rate=rate, rate_source=source,
                   seconds=seconds + count * chunk_overhead(workers) + outputs_s,
                   memory_bytes=memory, output_bytes=output, device=plan.device,
                   compile_seconds=compile_s, compile_bytes=compile_b, output_seconds=outputs_s,
                   disk_bytes=disk_bytes(plan, count), start_seconds=start_s,
                   worst_seconds=(seconds + count * chunk_overhead(workers)
                                  + output_seconds(plan, count, worst=True)),
                   workers=workers)
    return est, compile_s


def _chunk_bounds(plan: Plan, per: int, threads: int) -> tuple[np.ndarray, np.ndarray]:
    """(starts, stops) of the chunks of ``per`` lanes as ``chunks_to_run`` cuts them (the
    first and the last shorter: ``with_short_ends``), as arrays."""
    n = plan.n_lanes
    starts = np.arange(0, n, per, dtype=np.int64)
    stops = np.minimum(starts + per, n)
    ends = list(dict.fromkeys((int(starts[i]), int(stops[i])) for i in (0, -1)) if n else [])
    cut = np.array(with_short_ends(plan, ends, threads), np.int64).reshape(-1, 2)
    if len(starts) < 2:
        return cut[:, 0], cut[:, 1]
    head, tail = cut[cut[:, 0] < stops[0]], cut[cut[:, 0] >= starts[-1]]
    return (np.concatenate([head[:, 0], starts[1:-1], tail[:, 0]]),
            np.concatenate([head[:, 1], stops[1:-1], tail[:, 1]]))


MAX_SPEEDUP = 4.0
"""The most a machine's measured rate is taken to exceed the stated one (this 2-core AVX-512 VM:
2.0-2.4x): a study whose stated kernel time is beyond that many times the limit is refused
without measuring (and, on a cold cache, without compiling)."""


def before_refusing(plan: Plan, est: Estimate, chunk_cases: int | None = None,
                    threads: int | None = None, workers: int | None = None
                    ) -> tuple[Estimate, float]:
    """``est`` again at the rate measured on this machine, where the stated rate puts it over
    the time limit; else ``est`` as it is; with the seconds of it that are compiling (after
    measuring, none: the measurement compiled the kernel). (``validate`` printed the estimate
    of a study within the limits without its compile note: this returned 0 for them.)

    The stated rate is a floor for any AVX2 machine: on this 2-core AVX-512 one the kernel runs
    about twice as fast, so a study of 3-5 minutes was refused as over 10. Measuring costs about
    0.3 s with a warm cache (``execute.measure_rate``), or the one-time compile with a cold one,
    which the run would pay anyway; only a study that would otherwise be refused for its time
    alone, and that a faster rate could bring under the limit (``MAX_SPEEDUP``), pays it."""
    over = est.over()
    if over != [o for o in over if o.startswith("time")] or not over or est.device == "cuda":
        return est, est.compile_seconds  # within the limits, refused for memory or output
        # whatever the rate, or on the GPU (the CPU kernel's rate says nothing of it)
    kernel = (est.seconds - est.start_seconds - est.output_bytes / WRITE_RATE - est.compile_seconds
              - est.output_seconds - est.chunks * chunk_overhead(est.workers))
    if kernel / MAX_SPEEDUP > execute.LIMITS.seconds:
        return est, est.compile_seconds  # no machine is that much faster: refused at once,
        # nothing compiled
    rate = measure_rate(plan, min(threads or cores(), cores()))  # measured here, per core (a
    # cluster's cores are not this machine's)
    return quick_estimate(plan, chunk_cases, threads, rate=rate, workers=workers,
                          new_process=bool(est.start_seconds))


CHUNK_SECONDS = 30.0
"""Longest a chunk should take at the stated rate [s]: progress at least this often, and a kill
loses at most this much work."""

PROGRESS_CHUNKS = 10
"""A chunk is capped at about ``1 / PROGRESS_CHUNKS`` of the study's kernel time (but not below
``SHORTEST_CAP_SECONDS``): a study of more than ``PROGRESS_CHUNKS x SHORTEST_CAP_SECONDS``
seconds is cut into at least about this many chunks (where its lanes allow), so that progress
is shown while it runs."""

SHORTEST_CAP_SECONDS = 1.0
"""The cap of ``PROGRESS_CHUNKS`` goes no lower than this [s]: a chunk this long pays its
``CHUNK_OVERHEAD_SECONDS`` under 1% of its time."""

OVERHEAD_SHARE = 0.1
"""``small_chunk_note`` speaks of a requested chunk size whose ``CHUNK_OVERHEAD_SECONDS`` is
more than this share of the chunk's kernel time (at the stated rate)."""


def shortest_chunk_seconds(plan: Plan) -> float:
    """Predicted time of the smallest chunk [s]: one round of kernel blocks, each lane run
    whole (a continued sweep carries its state from speed to speed and is never split), at the
    stated rate. Above ``CHUNK_SECONDS`` a chunk cannot be made as short as the runner wants."""
    return plan.chain * LANES * plan.steps_per_case / (STATED_RATE[plan.study.solver.method] * 1e6)


CHUNKS_PER_WORKER = 3
"""With ``--workers N`` the default chunks are cut into at least about this many per worker
process, so that every worker has work and the last chunks' tail is short: at the default
1e9 steps a 1e6-case study was 3 chunks, and 8 or 16 workers ran its chunk phase no faster than
4 (2.0, 2.65 and 2.67 s; 16-core machine, 26 Nov 2026, docs/scale-log.md)."""

WORKER_CHUNK_STEPS = 1e8
"""... but a chunk of at least about this many steps (0.1 s of one core), so that dask's cost
per task (milliseconds) and the work around each kernel call stay small beside it."""


def small_chunk_note(plan: Plan, requested: int | None, threads: int | None = None,
                     workers: int | None = None) -> str | None:
    """What a requested chunk size too small for its cost costs, in words (``None`` when it
    is not): each chunk costs ``chunk_overhead`` beyond its kernel (more on a dask cluster of
    ``workers`` processes, whose ``threads`` cores they share: a chunk runs on one of them),
    and the kernel computes ``LANES`` lanes a block on each core, so a chunk of fewer
    lane-sweeps runs mostly empty blocks. (With ``--workers`` it was not said, and the chunks
    were priced at this process's cost: 40,000 cases in chunks of 64 estimated at 3.7 s took
    8.7 s; an outside tester.) The size it advises keeps the overhead under
    ``OVERHEAD_SHARE`` of a chunk's kernel time. (It advised one round of blocks, 64 cases
    on 2 cores: the 300,000-case cut of the 1e6-case study took 34.5 s in chunks of 64
    cases, 4,688 of them, where its 4 runner's chunks take 5-6 s; an outside tester. A
    continued 1e6-case study in chunks of 2,000 cases, 2 lanes of 1,000 speeds, took 58 s
    against 5.5 s by default.)"""
    if requested is None or plan.device != "cpu":
        return None
    threads = threads or kernel_threads()  # the kernel's (cores() warned of a round of blocks
    # on every core where NUMBA_NUM_THREADS=1 runs one)
    if workers:  # a chunk runs on one worker, with its share of the cores
        threads = max(1, threads // workers)
    overhead = chunk_overhead(workers)
    ways = max(len(plan.directions), 1)
    round_lanes = max(LANES * threads // ways, 1)
    rounds = math.ceil(overhead / (OVERHEAD_SHARE * shortest_chunk_seconds(plan)))
    enough = min(round_lanes * rounds, plan.n_lanes)
    lanes = lanes_per_chunk(plan, requested)
    if lanes >= enough:
        return None
    what = "continued sweeps" if plan.continued else "cases"

    def count(n: int, noun: str) -> str:
        return f"{n} {noun if n != 1 else noun[:-1]}"

    empty = (f" hold {count(lanes, what)} each, where the kernel computes {round_lanes} at a time on"
             f" {threads} core{'s' if threads != 1 else ''}: most of each chunk's work is empty"
             f" (up to {round_lanes / lanes:.0f}x the time); and" if lanes < round_lanes else ":")
    task = "its dask task, " if workers else ""
    return (f"chunks of {count(requested, 'cases')}{empty} each chunk costs about"
            f" {overhead * 1e3:.0f} ms beyond its kernel ({task}the call, its checkpoint"
            f" file, its part of the result file); at least {enough * plan.cases_per_lane} cases"
            f" per chunk keep that under {OVERHEAD_SHARE:.0%} of the time (or leave the chunk"
            " size to the runner)")


def _longest_chunk_seconds(plan: Plan, threads: int, seconds: float = CHUNK_SECONDS
                           ) -> tuple[float, float]:
    """(the longest a CPU chunk of ``plan`` may take, the study's kernel time) [s], at the stated
    rate on ``threads`` cores: about ``1 / PROGRESS_CHUNKS`` of the kernel time, at least
    ``SHORTEST_CAP_SECONDS``, at most ``seconds`` (``chunk_cases``'s cap)."""
    round_lanes = max(LANES * threads // max(len(plan.directions), 1), 1)
    total_s = math.ceil(plan.n_lanes / round_lanes) * shortest_chunk_seconds(plan)
    return min(seconds, max(total_s / PROGRESS_CHUNKS, SHORTEST_CAP_SECONDS)), total_s


def capped_chunk_note(plan: Plan, threads: int | None = None) -> str:
    """Why ``chunk_cases`` cut a requested chunk size, in words, with this study's numbers: the
    runner's longest chunk (it said "longer than the runner's", taken for its default chunks,
    and the help and docs/scale.md spoke of no cap). ``threads``: those ``chunk_cases`` was
    given (a cluster's; default this machine's cores)."""
    if plan.device == "cuda":
        return (f"chunks longer than the runner allows: at most about {CHUNK_SECONDS:.0f} s each"
                " at the GPU's stated rate, so that progress is shown and an interruption loses"
                " at most that")
    limit, total = _longest_chunk_seconds(plan, threads or cores())
    return (f"chunks longer than the runner allows: about 1/{PROGRESS_CHUNKS} of the study's"
            f" kernel time, for progress, but at least {SHORTEST_CAP_SECONDS:.0f} s and at most"
            f" {CHUNK_SECONDS:.0f} s, so that an interruption loses little ({limit:.2g} s of"
            f" {total:.2g} s here, at the stated rate)")


def chunk_cases(plan: Plan, requested: int | None, threads: int | None = None,
                seconds: float = CHUNK_SECONDS, workers: int | None = None
                ) -> tuple[int | None, bool]:
    """Cases per chunk to run with: ``requested`` (``None``: the runner's default, about 1e9
    steps, the fast size; with ``workers`` processes, at least ``CHUNKS_PER_WORKER`` chunks
    each where the study is big enough) capped so that a chunk takes at most about ``seconds``
    at the stated rate, and a study of more than ``PROGRESS_CHUNKS`` seconds is not one chunk.
    Returns (cases per chunk, or ``None`` for the default; whether it was capped).

    A lane (one case, or one continued sweep along speed) is never split, so a chunk is at
    least one round of kernel blocks over the cores (``LANES x threads`` lane-sweeps): smaller
    chunks would leave cores idle.

    With ``workers``, ``threads`` are the cluster's (the study's kernel time, and so the cap in
    seconds, is theirs) but a chunk runs on one worker, with its share of them: its rounds are
    of ``threads // workers`` cores. (Counted with the whole cluster's, scale_1e7 asked in one
    chunk on 16 workers of 4 threads was cut into a chunk of 8,749,056 cases, 87 % of the
    study, about 16 s on one worker while the others idled; a reviewer.)
    """
    threads = threads or cores()
    ways = max(len(plan.directions), 1)
    per_lane = plan.cases_per_lane
    if requested is None and workers and workers > 1 and plan.device == "cpu":
        default = plan.default_lanes_per_chunk()
        floor = math.ceil(WORKER_CHUNK_STEPS / (per_lane * plan.steps_per_case))
        lanes = max(math.ceil(plan.n_lanes / (CHUNKS_PER_WORKER * workers)), floor, 4 * LANES)
        if lanes < default:
            requested = lanes * per_lane
    if plan.device == "cuda":  # a lane per GPU thread: capped at ``seconds`` at the GPU's rate
        lanes_max = max(int(seconds * cuda.STATED_STEPS_PER_SECOND
                            / (per_lane * plan.steps_per_case)), 1)
        lanes = (lanes_per_chunk(plan, requested) if requested is not None
                 else plan.default_lanes_per_chunk())
        return (requested, False) if lanes <= lanes_max else (lanes_max * per_lane, True)
    round_s = shortest_chunk_seconds(plan)  # one round of blocks [s]
    chunk_threads = max(1, threads // workers) if workers else threads  # a chunk's cores
    round_lanes = max(LANES * chunk_threads // ways, 1)
    target = _longest_chunk_seconds(plan, threads, seconds)[0]
    lanes_max = max(int(target // round_s), 1) * round_lanes
    lanes = (lanes_per_chunk(plan, requested) if requested is not None
             else plan.default_lanes_per_chunk())
    if lanes <= lanes_max:
        return requested, False
    return lanes_max * per_lane, True
