"""Kernel benchmark: problems B1 and B2 (docs/benchmark.md) through the public API.

The problems are solved exactly as specified there (classic RK4, 64 steps per mesh period, 200 mesh
periods from rest, 10,000 speeds) by ``gearsweep.kernels.simulate`` (no copy of the kernel):

* stiffness/mass ``k(t)/m`` is one table shared by every case (``k_scale=None``, the fastest
  specialisation), built as ``(k0 + sum k_n cos(n phi)) * (1/m)`` as the reference does;
* force/mass ``F/m - e''(t)`` is ``force = F * (1/m)`` plus ``ste_scale = -Omega^2`` times
  ``ste_table = fourier_table(e_n, orders, phases, derivative=2)`` (= e''/Omega^2);
* B1 has no backlash (``half_gap=None``: f(p) = p); B2 passes ``half_gap = 2e-6`` m;
* the amplitude is max|p| = max(p_max, -p_min) over the states after steps 6401..12800.

Timings are the best of 3 after a warm-up, with 1 thread and with all cores. One JSON line per
problem and thread count. ``--reference`` builds and runs the C reference kernel in the same run
(interleaved with ours, ``--rounds`` times, best of each: the machine is shared, and the best of
several runs is the least disturbed estimate) and adds the ratio ours/C of Msteps/s
(``ratio_to_reference``), for 1 thread also of CPU time per step (``cpu_ratio_to_reference``,
the steadier figure when other processes share the cores), and the largest relative difference
of the 10,000 amplitudes. With ``--scipy``, a few B1 cases are also solved with
``scipy.integrate.solve_ivp`` (RK45, DOP853, LSODA) at tolerances that reach our accuracy, and
the per-case speed-up of our kernel on one thread over the fastest of them is printed.

With ``--device cuda`` the same problems run on a CUDA GPU through
``gearsweep.kernels.cuda.simulate_cuda`` at 1e4, 1e5, 1e6 and 4e6 cases (``--sizes``): case ``i``
has the speed of B1/B2 case ``i mod 10,000`` (the 10,000 speeds repeated; below 10,000 cases,
spread over them as on the CPU). One JSON line per problem and size, with the CPU lines' fields
(``device``, ``gpu`` and ``precision`` in place of ``threads``); each time is the best of 3 whole
``simulate_cuda`` calls after a warm-up (host packing, transfers and kernel), and every line gives
the largest relative difference of max|p| from our CPU kernel's (the 10,000 speeds, computed once)
and, with ``--reference``, from the C reference's. Without a GPU it stops with one line, exit 2
(under ``NUMBA_ENABLE_CUDASIM=1`` it runs on numba's simulator: a smoke test, not a timing).

Usage::

    python scripts/bench_kernel.py [--reference] [--dump DIR] [--problems B1,B2] [--cases N]
                                   [--scipy] [--scipy-cases I,J,K] [--scipy-budget SECONDS]
    python scripts/bench_kernel.py --device cuda [--reference] [--sizes 10000,100000,...]
                                   [--precision float32]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from gearsweep.kernels import fourier_table, simulate

BENCH_DIR = Path(__file__).resolve().parents[2] / "shared" / "bench"
"""Where ``run_reference.sh`` lives (``/work/shared/bench``); ``--bench-dir`` overrides it."""

# Problem data of B1 and B2 (docs/benchmark.md; SI units).
MASS = 0.1527  # equivalent mass m [kg]
DAMPING = 5500.0  # mesh damping c [N s/m]
K0 = 1.073e9  # mean mesh stiffness [N/m]
K_HARM = np.array([179e6, 40e6, 10e6])  # stiffness harmonics k_1..k_3 [N/m]
E_HARM = np.array([5e-6, 1e-6, 0.3e-6])  # STE harmonics e_1..e_3 [m]
ORDERS = np.array([1.0, 2.0, 3.0])  # mesh orders of the harmonics [-]
FORCE = 833.0  # mean force F [N]
TEETH = 48  # teeth of the gear whose speed is swept
N_CASES = 10_000
RPM_MIN, RPM_MAX = 1000.0, 20000.0  # speed range [rpm]
STEPS_PER_PERIOD = 64
PERIODS = 200
N_TRANSIENT = STEPS_PER_PERIOD * PERIODS // 2  # states after steps 1..6400 are discarded
N_RECORD = STEPS_PER_PERIOD * PERIODS - N_TRANSIENT  # those after 6401..12800 are recorded
HALF_GAP = {"B1": None, "B2": 2e-6}  # half the backlash [m]; None: no backlash, f(p) = p


def speeds(indices: np.ndarray) -> np.ndarray:
    """Speed [rpm] of the cases with the given indices: rpm_i = 1000 + 19000 i / 9999."""
    return RPM_MIN + (RPM_MAX - RPM_MIN) * indices / (N_CASES - 1)


def mesh_frequency(rpm: np.ndarray) -> np.ndarray:
    """Mesh angular frequency Omega [rad/s] at the given speed [rpm]."""
    return TEETH * rpm * 2.0 * np.pi / 60.0


def case_indices(cases: int) -> np.ndarray:
    """B1/B2 case index of each of ``cases`` cases: spread evenly over the 10,000 speeds (all of
    them by default), and above 10,000 cases the 10,000 speeds repeated (more work per thread,
    for the scaling on many cores, and the GPU's sizes)."""
    if cases > N_CASES:
        return np.arange(cases, dtype=np.int64) % N_CASES
    return np.unique(np.linspace(0, N_CASES - 1, cases).round().astype(np.int64))


def problem_inputs(problem: str, indices: np.ndarray) -> dict:
    """Keyword arguments of ``simulate`` that pose problem ``problem`` for the given cases."""
    inv_m = 1.0 / MASS
    omega = mesh_frequency(speeds(indices))
    zeros = np.zeros(3)
    k_over_m = (K0 + fourier_table(K_HARM, ORDERS, zeros, STEPS_PER_PERIOD)) * inv_m  # [1/s^2]
    half_gap = HALF_GAP[problem]
    return dict(
        h=2.0 * np.pi / omega / STEPS_PER_PERIOD,
        method="rk4",
        damping=DAMPING / MASS,
        k_scale=None,
        k_table=k_over_m,
        force=FORCE * inv_m,
        ste_scale=-omega * omega,
        ste_table=fourier_table(E_HARM, ORDERS, zeros, STEPS_PER_PERIOD, derivative=2),
        half_gap=None if half_gap is None else np.full(len(indices), half_gap),
        n_transient=N_TRANSIENT,
        n_record=N_RECORD,
        steps_per_period=STEPS_PER_PERIOD,
    )


def amplitudes(inputs: dict) -> np.ndarray:
    """max|p| over the recorded states of every case [m]."""
    stats = simulate(**inputs).stats
    return np.maximum(stats["p_max"], -stats["p_min"])


def best_time(inputs: dict, threads: int, repeats: int = 3) -> tuple[float, float]:
    """Best wall time and mean CPU time [s] of ``repeats`` kernel calls on ``threads`` threads,
    after a warm-up. (On a shared machine the CPU time of a 1-thread run is the steadier figure:
    time slices lost to other processes do not count.)"""
    numba.set_num_threads(threads)
    simulate(**inputs)
    best, cpu = math.inf, 0.0
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        simulate(**inputs)
        best = min(best, time.perf_counter() - t0)
        cpu += (time.process_time() - c0) / repeats
    return best, cpu


# ----------------------------------------------------------------------------- C reference
def build_reference(bench_dir: Path, outdir: Path) -> dict[tuple[str, int], float]:
    """Build and run ``run_reference.sh`` into ``outdir``; best times [s] by (problem, threads)."""
    out = subprocess.run([str(bench_dir / "run_reference.sh"), str(outdir)], check=True,
                         capture_output=True, text=True).stdout
    times = {}
    for line in out.splitlines():
        rec = json.loads(line)
        times[(rec["problem"], rec["threads"])] = rec["seconds"]
    return times


def time_reference(outdir: Path, problem: str, threads: int) -> tuple[float, float]:
    """One more run of the built reference binary: its best wall time of 3 runs and the mean CPU
    time of the 3 (user + system time of the process / 3, which includes its table set-up) [s]."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([str(outdir / "reference_kernel"), problem], check=True,
                         capture_output=True, text=True, env=env).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime) / 3
    return json.loads(out)["seconds"], cpu


# ----------------------------------------------------------------------------- scipy
def _rhs(omega: float):
    """Right-hand side of B1 for solve_ivp: the continuous model the tables sample."""
    k1, k2, k3 = K_HARM / MASS
    e1, e2, e3 = E_HARM * ORDERS**2 * omega**2  # -e''(t) = sum e_n n^2 Omega^2 cos(n Omega t)
    cm, fm, k0m = DAMPING / MASS, FORCE / MASS, K0 / MASS
    cos = math.cos

    def f(t, y):
        ph = omega * t
        c1, c2, c3 = cos(ph), cos(2.0 * ph), cos(3.0 * ph)
        p, v = y
        force = fm + e1 * c1 + e2 * c2 + e3 * c3
        return [v, force - cm * v - (k0m + k1 * c1 + k2 * c2 + k3 * c3) * p]

    return f


def _signal_error(p: np.ndarray, ref: np.ndarray) -> float:
    """Largest error over the recorded samples, relative to the amplitude of the reference."""
    return float(np.max(np.abs(p - ref)) / np.max(np.abs(ref)))


def scipy_comparison(indices: list[int], our_seconds_per_case: float, budget: float) -> list[dict]:
    """Time solve_ivp (RK45, DOP853, LSODA) on B1 cases at our accuracy; JSON records.

    ``our_seconds_per_case``: CPU time of one B1 case in our kernel on one thread (the 1-thread
    batch CPU time / cases), compared with the CPU time of each solve.

    Accuracy is the largest error of p over the 6400 recorded states (t = s h, s = 6401..12800)
    relative to max|p|, against DOP853 at rtol = 1e-13. For each method the tolerance
    (rtol, and atol = rtol times the static deflection F/k0 and F/k0 * sqrt(k0/m) for p and p')
    is moved in half-decades, on the first case from a guess until it is the loosest one whose error
    is no larger than ours, on later cases from the first case's value, tightened if needed. The
    CPU time of that solve is the method's time. No solve starts once ``budget`` seconds are spent.
    """
    from scipy.integrate import solve_ivp

    p_scale = FORCE / K0
    scale = np.array([p_scale, p_scale * math.sqrt(K0 / MASS)])
    simulate(**problem_inputs("B1", np.array(indices[:1])), signal_stride=1)  # compile/load first
    t_start = time.perf_counter()
    records = []
    guess: dict[str, float] = {}
    for i in indices:
        if time.perf_counter() - t_start > budget:
            records.append({"scipy": "stopped", "reason": f"time budget of {budget} s spent"})
            break
        inputs = problem_inputs("B1", np.array([i]))
        omega = float(mesh_frequency(speeds(np.array([i])))[0])
        h = float(inputs["h"][0])
        t_eval = h * np.arange(N_TRANSIENT + 1, N_TRANSIENT + N_RECORD + 1)
        ours = simulate(**inputs, signal_stride=1).signal[0]
        rhs = _rhs(omega)

        def solve(method, rtol, rhs=rhs, t_eval=t_eval):
            t0 = time.process_time()  # CPU time: a shared machine does not inflate it
            sol = solve_ivp(rhs, (0.0, t_eval[-1]), [0.0, 0.0], method=method, rtol=rtol,
                            atol=rtol * scale, t_eval=t_eval)
            return sol, time.process_time() - t0

        ref, ref_seconds = solve("DOP853", 1e-13)
        target = _signal_error(ours, ref.y[0])
        case = {"problem": "B1", "case": int(i), "rpm": float(speeds(np.array([i]))[0]),
                "our_error": target, "reference": "DOP853 rtol=1e-13",
                "reference_seconds": round(ref_seconds, 3)}
        fastest = None
        for method in ("RK45", "DOP853", "LSODA"):
            # rtol = 10^(-q/2); first case: from our error, loosen or tighten to the loosest
            # passing one; later cases: start from the first case's and tighten if needed.
            q = guess.get(method, max(4, min(26, round(-2 * math.log10(target)))))
            first = method not in guess
            tried: dict[int, tuple] = {}
            passing = None
            while time.perf_counter() - t_start < budget and 4 <= q <= 26:
                sol, sec = solve(method, 10.0 ** (-q / 2))
                err = _signal_error(sol.y[0], ref.y[0])
                tried[q] = (err, sec, sol.nfev)
                if sol.success and err <= target:
                    passing = q if passing is None else min(passing, q)
                    if not first or q - 1 in tried:
                        break
                    q -= 1  # loosen
                else:
                    if passing is not None:
                        break
                    q += 1  # tighten
            if not tried:
                records.append({**case, "scipy": method, "skipped": "time budget spent"})
                continue
            if passing is None:
                errors = {f"{10.0 ** (-k / 2):.3g}": v[0] for k, v in tried.items()}
                records.append({**case, "scipy": method, "reached": False, "tried": errors})
                continue
            guess[method] = passing
            err, sec, nfev = tried[passing]
            records.append({**case, "scipy": method, "rtol": float(f"{10.0 ** (-passing / 2):.3g}"),
                            "error": err, "seconds": round(sec, 4), "nfev": int(nfev)})
            if fastest is None or sec < fastest[1]:
                fastest = (method, sec)
        if fastest is not None:
            records.append({**case, "fastest_scipy": fastest[0],
                            "scipy_seconds": round(fastest[1], 4),
                            "our_cpu_seconds_per_case": our_seconds_per_case,
                            "speedup": round(fastest[1] / our_seconds_per_case)})
    return records


# ----------------------------------------------------------------------------- CUDA
CUDA_SIZES = "10000,100000,1000000,4000000"


def bench_cuda(args, problems: list[str]) -> int:
    """``--device cuda``: B1/B2 on the GPU at each size; one JSON line per problem and size."""
    from gearsweep.errors import DeviceError
    from gearsweep.kernels.cuda import resolve_device, simulate_cuda, simulator

    try:
        resolve_device("cuda")
    except DeviceError as exc:
        print(f"bench_kernel: {exc}", file=sys.stderr)
        return 2
    from numba import cuda

    gpu = "numba CUDA simulator" if simulator() else cuda.get_current_device().name
    gpu = gpu.decode() if isinstance(gpu, bytes) else str(gpu)
    sizes = [int(float(x)) for x in args.sizes.split(",") if x]
    ref_dir = None
    if args.reference:
        if shutil.which("gcc") is None:
            print(json.dumps({"reference": "skipped", "reason": "gcc not found"}), flush=True)
        else:
            ref_dir = Path(tempfile.mkdtemp(prefix="gearsweep-bench-"))
            build_reference(args.bench_dir, ref_dir)
    for problem in problems:
        # our CPU kernel's amplitudes of the cases the GPU runs (all 10,000 from 10,000 cases)
        cpu_idx = np.unique(case_indices(min(sizes)) if min(sizes) < N_CASES
                            else np.arange(N_CASES))
        cpu_amp = np.full(N_CASES, np.nan)
        cpu_amp[cpu_idx] = amplitudes(problem_inputs(problem, cpu_idx))
        ref_amp = np.loadtxt(ref_dir / f"{problem}.txt") if ref_dir is not None else None
        for cases in sizes:
            idx = case_indices(cases)
            inputs = problem_inputs(problem, idx)

            def run(inputs=inputs):
                return simulate_cuda(**inputs, precision=args.precision)

            stats = run().stats  # warm-up: compiles the kernel, allocates the buffers
            best = math.inf
            for _ in range(1 if simulator() else 3):
                t0 = time.perf_counter()
                stats = run().stats
                best = min(best, time.perf_counter() - t0)
            amp = np.maximum(stats["p_max"], -stats["p_min"])
            steps = cases * (N_TRANSIENT + N_RECORD)
            rec = {"problem": problem, "device": "cuda", "gpu": gpu, "precision": args.precision,
                   "cases": cases, "steps": steps, "seconds": round(best, 4),
                   "msteps_per_s": round(steps / best / 1e6, 1), "method": "rk4",
                   "steps_per_period": STEPS_PER_PERIOD, "periods": PERIODS}
            seen = ~np.isnan(cpu_amp[idx])
            rec["max_rel_diff_vs_cpu"] = float(np.max(np.abs(amp[seen] - cpu_amp[idx][seen])
                                                      / cpu_amp[idx][seen]))
            if ref_amp is not None:
                rec["max_rel_diff_vs_reference"] = float(np.max(np.abs(amp - ref_amp[idx])
                                                                / ref_amp[idx]))
            print(json.dumps(rec), flush=True)
    if ref_dir is not None:
        shutil.rmtree(ref_dir, ignore_errors=True)
    return 0


# ----------------------------------------------------------------------------- main
def _compile_aside(problem: str, cases: int) -> subprocess.Popen:
    """Start a process that compiles (or loads) ``problem``'s kernel specialisation into the
    Numba cache and exits; its output is discarded. It runs the same number of cases: the
    argument types, and so the specialisation, can depend on it (one case gives read-only
    broadcast arrays)."""
    return subprocess.Popen([sys.executable, __file__, "--compile-only", "--problems", problem,
                             "--cases", str(cases)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--problems", default="B1,B2", help="comma-separated subset of B1,B2")
    ap.add_argument("--cases", type=int, default=N_CASES,
                    help="number of cases: up to 10,000 spread evenly over the speeds (quick runs),"
                         " above that the 10,000 speeds repeated (more work per thread)")
    ap.add_argument("--dump", type=Path, help="write DIR/B1.txt, DIR/B2.txt: one max|p| a line")
    ap.add_argument("--reference", action="store_true",
                    help="build and run the C reference kernel too and compare")
    ap.add_argument("--bench-dir", type=Path, default=BENCH_DIR, help="where run_reference.sh is")
    ap.add_argument("--rounds", type=int, default=2,
                    help="with --reference: interleaved rounds of ours and C, best of each")
    ap.add_argument("--scipy", action="store_true",
                    help="also time scipy's solve_ivp on a few B1 cases (about 30 s more)")
    ap.add_argument("--scipy-cases", default="5000,7500,9999",
                    help="B1 case indices for the solve_ivp comparison")
    ap.add_argument("--scipy-budget", type=float, default=25.0,
                    help="seconds after which no further solve_ivp run is started")
    ap.add_argument("--device", choices=("cpu", "cuda"), default="cpu",
                    help="cuda: run on a CUDA GPU at --sizes cases (docs/gpu.md)")
    ap.add_argument("--sizes", default=CUDA_SIZES,
                    help="with --device cuda: comma-separated numbers of cases")
    ap.add_argument("--precision", choices=("float64", "float32"), default="float64",
                    help="with --device cuda: arithmetic of the state")
    ap.add_argument("--compile-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    problems = [p for p in args.problems.split(",") if p]
    unknown = set(problems) - set(HALF_GAP)
    if unknown:
        ap.error(f"unknown problem(s) {sorted(unknown)}; choose from B1, B2")
    if args.reference and not (args.bench_dir / "run_reference.sh").is_file():
        ap.error(f"--bench-dir {args.bench_dir}: no run_reference.sh there (the C reference of"
                 " ../shared/bench; give its folder with --bench-dir)")
    if args.cases < 1:
        ap.error("--cases must be at least 1")
    if args.device == "cuda":
        return bench_cuda(args, problems)
    indices = case_indices(args.cases)
    if args.compile_only:  # helper process of ``_compile_aside``: fill the Numba cache, exit
        for problem in problems:
            amplitudes(problem_inputs(problem, indices))
        return 0
    # With a cold Numba cache each problem's specialisation takes 15-30 s to compile, one after
    # the other in this process (compilation holds the GIL); the later problems are compiled
    # into the cache by helper processes meanwhile, and loaded from it when their turn comes.
    aside = {p: _compile_aside(p, args.cases) for p in problems[1:]}
    # the warm-up: every specialisation compiled or loaded before any timing, ours or C's
    amps = {}
    for problem in problems:
        if problem in aside:
            aside.pop(problem).wait()
        amps[problem] = amplitudes(problem_inputs(problem, indices))
    all_cores = numba.config.NUMBA_NUM_THREADS
    thread_counts = sorted({1, all_cores})

    ref_dir = None
    ref_times: dict[tuple[str, int], float] = {}
    if args.reference:
        if shutil.which("gcc") is None:
            print(json.dumps({"reference": "skipped", "reason": "gcc not found"}), flush=True)
        else:
            ref_dir = Path(tempfile.mkdtemp(prefix="gearsweep-bench-"))
            ref_times = build_reference(args.bench_dir, ref_dir)

    seconds_b1_1 = None
    one_thread = math.nan
    for problem in problems:
        inputs = problem_inputs(problem, indices)
        amp = amps[problem]
        if args.dump is not None:
            args.dump.mkdir(parents=True, exist_ok=True)
            np.savetxt(args.dump / f"{problem}.txt", amp, fmt="%.17g")
        ref_amp = None
        if ref_dir is not None:
            ref_amp = np.loadtxt(ref_dir / f"{problem}.txt")[indices]
        for threads in thread_counts:
            c_threads = os.cpu_count() if threads == all_cores else threads
            best = cpu = math.inf
            best_c = ref_times.get((problem, c_threads), math.inf)
            cpu_c = math.inf
            for _ in range(args.rounds if ref_dir is not None else 1):
                wall, used = best_time(inputs, threads)
                best, cpu = min(best, wall), min(cpu, used)
                if ref_dir is not None:
                    wall, used = time_reference(ref_dir, problem, c_threads)
                    best_c, cpu_c = min(best_c, wall), min(cpu_c, used)
            steps = len(indices) * (N_TRANSIENT + N_RECORD)
            rec = {"problem": problem, "threads": threads, "cases": len(indices), "steps": steps,
                   "seconds": round(best, 4), "msteps_per_s": round(steps / best / 1e6, 1),
                   "method": "rk4", "steps_per_period": STEPS_PER_PERIOD, "periods": PERIODS}
            if ref_dir is not None:
                c_msteps = N_CASES * (N_TRANSIENT + N_RECORD) / best_c / 1e6
                rec["reference_threads"] = c_threads
                rec["reference_msteps_per_s"] = round(c_msteps, 1)
                rec["ratio_to_reference"] = round(rec["msteps_per_s"] / c_msteps, 3)
                rec["max_rel_diff_vs_reference"] = float(np.max(np.abs(amp - ref_amp) / ref_amp))
            if threads == 1:
                rec["cpu_seconds"] = round(cpu, 4)
                if ref_dir is not None:
                    # same workload per step: ratio of CPU time per step, C / ours
                    rec["reference_cpu_seconds"] = round(cpu_c, 4)
                    rec["cpu_ratio_to_reference"] = round(
                        cpu_c / N_CASES / (cpu / len(indices)), 3)
                one_thread = best
                if problem == "B1":
                    seconds_b1_1 = cpu
            else:
                rec["speedup_vs_1_thread"] = round(one_thread / best, 2)
            print(json.dumps(rec), flush=True)
    numba.set_num_threads(all_cores)

    if args.scipy:
        if seconds_b1_1 is None:
            seconds_b1_1 = best_time(problem_inputs("B1", indices), 1)[1]
        numba.set_num_threads(all_cores)
        per_case = seconds_b1_1 / len(indices)
        sample = [int(s) for s in args.scipy_cases.split(",") if s]
        for rec in scipy_comparison(sample, per_case, args.scipy_budget):
            print(json.dumps(rec), flush=True)
    if ref_dir is not None:
        shutil.rmtree(ref_dir, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
