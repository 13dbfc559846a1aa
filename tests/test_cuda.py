"""The CUDA backend (``gearsweep.kernels.cuda``) against the CPU kernel, on numba's CUDA simulator.

numba reads ``NUMBA_ENABLE_CUDASIM`` once, when it is imported, and this test process has
imported numba long before: the simulated runs happen in one child process (this file run as a
script, with the variable set), which writes the GPU kernel's results to a file; the tests here
compare them with the CPU kernel (``simulate``) run in this process, the independent truth. Few
cases and few periods: the simulator runs each GPU thread as a Python thread.

Tests that need a real GPU are marked ``gpu`` and skipped where numba-cuda sees none. Everything
is skipped (with the reason) when numba-cuda is not installed.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

from gearsweep.errors import DeviceError
from gearsweep.kernels import STAT_NAMES, STATUS_DIVERGED, fourier_table, simulate

HAS_NUMBA_CUDA = importlib.util.find_spec("numba_cuda") is not None
needs_numba_cuda = pytest.mark.skipif(
    not HAS_NUMBA_CUDA, reason="numba-cuda is not installed (pip install -e '.[cuda]' or '.[test]')")

S = 16  # steps per mesh period
N_TRANSIENT, N_RECORD, STRIDE = 3 * S, 4 * S, 3
METHODS = ("rk4", "rk5")
SCENES = ("whine", "mathieu", "rattle", "fluct")
RUNS = (("whine", "rk4"), ("whine", "rk5"), ("mathieu", "rk4"), ("mathieu", "rk5"),
        ("rattle", "rk4"), ("fluct", "rk5"))
"""Scene and method pairs. whine and mathieu are one specialisation of the CPU kernel with both
methods; rattle and fluct one method each: every CPU specialisation here is a cold compile of
15-25 s in CI, and each method meets each term (backlash with RK4 in rattle, with RK5 in fluct).
Constant stiffness and a fluctuation-only force go through the study test below."""
TOL = 1e-12


def scene(name: str) -> dict:
    """``simulate`` keyword arguments of a small scene (dimensionless: k_mean = 1, period ~ 2 pi).

    whine: time-varying stiffness (one table shared by all cases, ``k_scale=None``, as in
    benchmark B1) + STE excitation + mean force, no backlash.
    mathieu: the same specialisation with parametric excitation alone (x0 = 1, no force), cases
    on both sides of the first instability tongue: the last ones grow and are stopped by the bound.
    rattle: backlash + STE + mean force, cases in and out of contact.
    fluct: every term: stiffness with a per-case scale of its table, STE, torque fluctuation at
    half the mesh order (a 2-period cycle) and backlash.
    """
    k_tab = fourier_table([0.25, 0.05], [1, 2], [0.0, 0.3], S)
    e_tab = fourier_table([1.0, 0.3], [1, 2], [0.0, 0.5], S, derivative=2)
    if name == "whine":
        w = np.array([0.6, 0.95, 1.3])
        return dict(h=2 * np.pi / w / S, damping=0.08, k_table=1.0 + k_tab, force=0.2,
                    ste_scale=-0.02 * w * w, ste_table=e_tab)
    if name == "mathieu":
        w = np.array([1.2, 1.9, 2.0])  # 2.0: k(t) at twice the natural frequency, unstable
        return dict(h=2 * np.pi / w / S, damping=0.01,
                    k_table=1.0 + fourier_table([1.2], [1], [0.0], S), ste_scale=0.0,
                    ste_table=e_tab, x0=1.0, bound=3.0)
    if name == "rattle":
        w = np.array([0.7, 1.0, 1.6])
        return dict(h=2 * np.pi / w / S, damping=0.05, k_table=1.0 + 0.2 * k_tab, force=0.02,
                    ste_scale=0.15, ste_table=e_tab, half_gap=np.array([0.3, 0.1, 0.2]), x0=0.05)
    if name == "fluct":
        w = np.array([0.8, 1.1, 1.45])
        k2 = np.vstack([k_tab, k_tab])
        return dict(h=2 * np.pi / w / S, damping=0.05, k_mean=1.0, k_scale=np.array([1.0, 0.5, 0.8]),
                    k_table=k2, force=0.05, ste_scale=0.05, ste_table=np.vstack([e_tab, e_tab]),
                    fluct_scale=0.2, fluct_table=fourier_table([1.0], [0.5], [0.2], S, cycle_periods=2),
                    half_gap=0.15)
    raise ValueError(name)


def run_kw(name: str, method: str, cases: list[int] | None = None) -> dict:
    """Keyword arguments of a run of ``scene(name)``; ``cases``: only those of its cases."""
    kw = dict(scene(name), method=method, n_transient=N_TRANSIENT, n_record=N_RECORD,
              steps_per_period=S, signal_stride=STRIDE)
    if cases is not None:  # per-case arrays are 1-D, of the scene's number of cases
        n = len(kw["h"])
        kw = {k: v[cases] if isinstance(v, np.ndarray) and v.shape == (n,) else v
              for k, v in kw.items()}
    return kw


SIM_STUDY = """\
title: tiny rattle sweep on two devices
scene: {{kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, damping: 200 N*s/m,
        backlash: 4 um, mean_force: 100 N, fluctuation: [{{amplitude: 2000 N, order: 1}}]}}
sweep: {{speed: {{start: 12000 rpm, stop: 18000 rpm, num: 3}}}}
continuation: [up]
solver: {{method: rk4, steps_per_period: 16, transient_periods: 3, record_periods: 2,
         device: {device}}}
outputs: [stats, {{spectrum: {{phase: true}}}}]
"""
"""A study through the runner on each device (continued sweep: each case starts from the last),
with the spectrum's amplitudes and phases (made from the GPU's recorded signal)."""


LOW_OCCUPANCY_SEEN = ("\x1b[1mGrid size 1 will likely result in GPU under-utilization due to low"
                      " occupancy.\x1b[0m")
"""numba-cuda's warning for a launch of few blocks, as it read on an H200 (numba-cuda 0.30.4)."""


def _launch_warns_as_on_a_gpu(cuda_module) -> bool:
    """In the child: each launch of the kernel warns as numba-cuda does on a GPU for a launch of
    few blocks (the simulator does not); True when ``simulate_cuda`` runs through that with
    warnings as errors (pytest's filterwarnings=error failed every real-GPU test on it)."""
    import warnings

    real = cuda_module._kernel

    def warning_kernel(*args, **kwargs):
        kern = real(*args, **kwargs)

        class Launch:
            def __getitem__(self, config):
                def launch(*a):
                    warnings.warn(LOW_OCCUPANCY_SEEN, UserWarning, stacklevel=2)
                    return kern[config](*a)
                return launch
        return Launch()

    cuda_module._kernel = warning_kernel
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            cuda_module.simulate_cuda(**run_kw("whine", "rk4"), max_chunk=2)
        return True
    except UserWarning:
        return False
    finally:
        cuda_module._kernel = real


def _child_main(out: str) -> None:
    """In the child (simulator on): every scene and method through ``simulate_cuda``, f64 (with a
    chunk of 2 cases, so that chunks alternate between the two streams and the last is short),
    one f32 run; results into ``out`` (npz)."""
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
    from numba import cuda

    from gearsweep.kernels.cuda import kernel_for, simulate_cuda

    res = {"simulator": np.array("Fake" in type(cuda.to_device(np.zeros(1))).__name__)}
    res["cuda_resolves"] = np.array(kernel_for("cuda").func is simulate_cuda)
    for name, method in RUNS:
        r = simulate_cuda(**run_kw(name, method), max_chunk=2)
        key = f"{name}_{method}"
        for s, v in r.stats.items():
            res[f"{key}_{s}"] = v
        res[f"{key}_xf"], res[f"{key}_vf"] = r.x_final, r.v_final
        res[f"{key}_status"], res[f"{key}_signal"] = r.status, r.signal
    r = simulate_cuda(**run_kw("whine", "rk4"), precision="float32")
    res["f32_p_rms"], res["f32_xf"], res["f32_signal"] = r.stats["p_rms"], r.x_final, r.signal
    # the buffers kept between calls: the same call twice in a row reuses them, same results
    from gearsweep.kernels import cuda as cuda_module

    # whine (chunks of 2), then rattle on the same buffers, then one rattle case (k = 1 in
    # buffers 2 wide: only the used part copied): each against the CPU kernel in the parent
    simulate_cuda(**run_kw("whine", "rk4"), max_chunk=2)
    kept = [b["h_in"] for b in cuda_module._BUFFERS["sets"]]  # held: no id reused
    again = simulate_cuda(**run_kw("rattle", "rk4"), max_chunk=2)
    one = simulate_cuda(**run_kw("rattle", "rk4", cases=[2]), max_chunk=2)
    now = [b["h_in"] for b in cuda_module._BUFFERS["sets"]]
    res["buffers_reused"] = np.array(len(kept) == len(now) == 2 and now[0].shape[1] == 2
                                     and all(a is b for a, b in zip(kept, now, strict=True)))
    for key, r in (("reused", again), ("reused_one", one)):
        res[f"{key}_p_rms"], res[f"{key}_xf"], res[f"{key}_signal"] = (
            r.stats["p_rms"], r.x_final, r.signal)
    res["quiet_few_blocks"] = np.array(_launch_warns_as_on_a_gpu(cuda_module))
    np.savez(out, **res)
    from gearsweep.api import run_study
    from gearsweep.study.dataset import write_netcdf
    from gearsweep.study.schema import parse_study

    write_netcdf(run_study(parse_study(SIM_STUDY.format(device="cuda"))), out + ".nc")


@pytest.fixture(scope="module")
def gpu_results(tmp_path_factory) -> dict:
    """The simulated GPU kernel's results of every scene and method (one child process)."""
    if not HAS_NUMBA_CUDA:
        pytest.skip("numba-cuda is not installed")
    # Once per test session, also under pytest-xdist: the first worker runs the child, the
    # others wait for its files (under xdist the folder above a worker's basetemp is the
    # session's, shared by its workers; without xdist basetemp itself is the session's).
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    out = root / "cuda_sim.npz"  # and cuda_sim.npz.nc: the study's result
    failed = root / "cuda_sim.failed"
    try:
        os.close(os.open(root / "cuda_sim.lock", os.O_CREAT | os.O_EXCL))
    except FileExistsError:
        deadline = time.monotonic() + 900
        while not out.exists() and not failed.exists() and time.monotonic() < deadline:
            time.sleep(0.5)
    else:
        env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
        part = root / "cuda_sim.part.npz"
        proc = subprocess.run([sys.executable, __file__, str(part)], env=env, capture_output=True,
                              text=True, timeout=900)
        if proc.returncode != 0:
            failed.write_text(proc.stderr[-3000:])
        else:
            os.replace(str(part) + ".nc", str(out) + ".nc")
            os.replace(part, out)
    assert not failed.exists(), failed.read_text()
    assert out.exists(), "the simulator child did not finish"
    with np.load(out) as f:
        res = {k: f[k] for k in f.files}
    res["study_nc"] = str(out) + ".nc"
    return res


class _CpuResults(dict):
    """The CPU kernel's result of a (scene, method) run, computed when first asked for: a test
    process (an xdist worker) compiles only the specialisations its tests need."""

    def __missing__(self, run):
        self[run] = simulate(**run_kw(*run))
        return self[run]


@pytest.fixture(scope="module")
def cpu_results() -> dict:
    return _CpuResults()


def _rel(a: np.ndarray, b: np.ndarray, scale: float) -> float:
    """Largest |a - b| / scale over entries finite in both (NaN must match NaN: checked apart)."""
    both = np.isfinite(a) & np.isfinite(b)
    return float(np.max(np.abs(a[both] - b[both]), initial=0.0) / scale)


@needs_numba_cuda
@pytest.mark.parametrize(("name", "method"), RUNS)
def test_simulated_gpu_agrees_with_cpu(gpu_results, cpu_results, name, method):
    cpu = cpu_results[(name, method)]
    key = f"{name}_{method}"
    assert gpu_results["simulator"]
    np.testing.assert_array_equal(gpu_results[f"{key}_status"], cpu.status)
    scale = float(np.nanmax(np.abs(cpu.signal)))  # the response amplitude
    assert scale > 0
    for s in STAT_NAMES:
        g, c = gpu_results[f"{key}_{s}"], cpu.stats[s]
        np.testing.assert_array_equal(np.isnan(g), np.isnan(c), err_msg=s)
        # displacements relative to the amplitude, fractions and counts absolutely
        ref = scale if s.startswith("p_") else 1.0
        assert _rel(g, c, ref) <= TOL, (s, g, c)
    for part, c in (("xf", cpu.x_final), ("vf", cpu.v_final), ("signal", cpu.signal)):
        g = gpu_results[f"{key}_{part}"]
        np.testing.assert_array_equal(np.isnan(g), np.isnan(c), err_msg=part)
        vscale = scale if part != "vf" else float(np.nanmax(np.abs(cpu.v_final)))
        assert _rel(g, c, vscale) <= TOL, part


@needs_numba_cuda
def test_study_on_cuda_gives_the_cpu_result(gpu_results):
    """``solver.device: cuda`` through the runner and writer: the same variables as the CPU run,
    to 1e-12 of each variable's largest magnitude."""
    import xarray as xr

    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    cpu = run_study(parse_study(SIM_STUDY.format(device="cpu")))
    with xr.open_dataset(gpu_results["study_nc"]) as gpu:
        assert set(gpu.data_vars) == set(cpu.data_vars)
        assert cpu["status"].size == 3
        for name in ("spectrum_phase", "force_spectrum_phase"):  # compared below, not vacuous
            assert int(cpu[name].notnull().sum()) >= 3 * 4, name
        for name, c in cpu.data_vars.items():
            g, c = gpu[name].values, c.values
            assert g.shape == c.shape, name
            if c.dtype.kind != "f":
                np.testing.assert_array_equal(g, c, err_msg=name)
                continue
            np.testing.assert_array_equal(np.isnan(g), np.isnan(c), err_msg=name)
            scale = max(float(np.nanmax(np.abs(c), initial=0.0)), 1e-300)
            assert _rel(g, c, scale) <= TOL, name


@needs_numba_cuda
def test_scenes_exercise_what_they_claim(cpu_results):
    """The scenes are not vacuous: rattle loses contact, mathieu has stopped (diverged) cases and
    settled ones, fluct touches the back flank or loses contact."""
    rattle = cpu_results[("rattle", "rk4")].stats
    assert np.all(rattle["contact_loss_fraction"] > 0) and np.any(rattle["impacts_per_period"] > 0)
    st = cpu_results[("mathieu", "rk4")].status
    assert np.any(st == STATUS_DIVERGED) and np.any(st == 0)
    fl = cpu_results[("fluct", "rk5")].stats
    assert np.all(fl["contact_loss_fraction"] > 0)
    assert np.all(cpu_results[("whine", "rk4")].stats["contact_loss_fraction"] == 0)


@needs_numba_cuda
def test_float32_is_float32(gpu_results, cpu_results):
    """f32: within f32 round-off of the f64 CPU result, and not the f64 result itself."""
    cpu = cpu_results[("whine", "rk4")]
    scale = float(np.max(np.abs(cpu.signal)))
    err = _rel(gpu_results["f32_signal"], cpu.signal, scale)
    assert 1e-9 < err < 1e-4
    assert 1e-9 < _rel(gpu_results["f32_xf"], cpu.x_final, scale) < 1e-4


@needs_numba_cuda
def test_a_result_of_the_simulator_says_so(gpu_results):
    """A result computed under the CUDA simulator was labelled ``device: cuda`` alone, and
    ``inspect`` said "on cuda", as of a GPU (an outside tester): it records ``device_name``,
    the GPU's model or ``CUDA simulator``, and ``inspect`` shows it."""
    import xarray as xr

    from gearsweep.cli import describe

    with xr.open_dataset(gpu_results["study_nc"]) as ds:
        assert ds.attrs["device"] == "cuda" and ds.attrs["device_name"] == "CUDA simulator"
    assert ", on cuda (CUDA simulator) in float64" in describe(gpu_results["study_nc"])


@needs_numba_cuda
def test_device_cuda_resolves_on_simulator(gpu_results):
    assert gpu_results["cuda_resolves"]


def test_buffers_are_kept_between_calls(gpu_results, cpu_results):
    """simulate_cuda keeps its pinned and device buffers for the next call (the study runner
    calls it once per chunk): another scene after whine, and one case in buffers two wide, give
    the CPU kernel's results, nothing left over from the call before."""
    assert gpu_results["buffers_reused"]
    cpu = cpu_results[("rattle", "rk4")]
    one = simulate(**run_kw("rattle", "rk4", cases=[2]))
    np.testing.assert_array_equal(one.x_final, cpu.x_final[[2]])  # the subset is that case
    scale = float(np.nanmax(np.abs(cpu.signal)))
    for key, ref in (("reused", cpu), ("reused_one", one)):
        assert _rel(gpu_results[f"{key}_p_rms"], ref.stats["p_rms"], scale) <= TOL
        assert _rel(gpu_results[f"{key}_xf"], ref.x_final, scale) <= TOL
        assert _rel(gpu_results[f"{key}_signal"], ref.signal, scale) <= TOL


class _FakeCuda:
    """Stands in for numba.cuda where only the free memory is asked for."""

    def __init__(self, free: float) -> None:
        self.free = free

    def current_context(self):
        return self

    def get_memory_info(self):
        return self.free, 2 * self.free


@pytest.mark.parametrize(("n", "free", "per_case", "chunks"), [
    (4_000_000, 80e9, 169, 4),       # B1 at 4e6 cases on an H100: 4 chunks, overlapped
    (1_000_000, 80e9, 169, 2),       # 1e6: two chunks of at least 2^19
    (100_000, 80e9, 169, 1),         # small: one launch
    (1_000_000, 1e9, 169 + 6400, 27),  # a recorded signal: bounded by memory
])
def test_chunks_fit_memory_and_overlap(n, free, per_case, chunks):
    from gearsweep.kernels.cuda import MEMORY_FRACTION, THREADS_PER_BLOCK, _chunk_cases

    m = _chunk_cases(_FakeCuda(free), per_case, n, None)
    assert -(-n // m) == chunks
    assert 2 * m * per_case <= MEMORY_FRACTION * free
    assert m == n or m % THREADS_PER_BLOCK == 0
    assert _chunk_cases(_FakeCuda(free), per_case, n, 1000) == min(m, 1000)


def test_the_low_occupancy_warning_is_silenced_and_no_other(gpu_results):
    """A study of few cases launches few blocks, and numba-cuda warns of low occupancy; under
    pytest's filterwarnings=error that failed every real-GPU test (H200, numba-cuda 0.30.4, 26 Nov
    2026), because the filter did not match the message as numba-cuda writes it: with terminal
    colour codes in front. simulate_cuda runs through launches that warn so (the child), and the
    filter lets other warnings through."""
    from gearsweep.kernels.cuda import LOW_OCCUPANCY

    assert gpu_results["quiet_few_blocks"]
    other = "Host array used in CUDA kernel will incur copy overhead to/from device."
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", message=LOW_OCCUPANCY)
        warnings.warn(LOW_OCCUPANCY_SEEN, UserWarning, stacklevel=1)
        warnings.warn(other, UserWarning, stacklevel=1)
    assert [str(w.message) for w in caught] == [other]


def test_kink_aware_with_backlash_is_refused():
    from gearsweep.kernels.cuda import simulate_cuda

    with pytest.raises(DeviceError, match="kink-aware"):
        simulate_cuda(**run_kw("rattle", "rk4"), kink_aware=True)


def test_cpu_path_never_imports_numba_cuda():
    code = ("import sys; from gearsweep.kernels.cuda import kernel_for; import gearsweep.study.chunk;"
            " f = kernel_for('cpu'); assert f.__name__ == 'simulate', f;"
            " print(json.dumps(sorted(m for m in sys.modules"
            " if m.startswith(('numba.cuda', 'numba_cuda')))))")
    proc = subprocess.run([sys.executable, "-c", "import json; " + code], capture_output=True,
                          text=True, env={k: v for k, v in os.environ.items()
                                          if k != "NUMBA_ENABLE_CUDASIM"})
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == []


def _no_gpu_env() -> dict:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    env["CUDA_VISIBLE_DEVICES"] = ""  # hides any GPU this machine may have: 'no GPU' either way
    return env


STUDY = """\
title: tiny whine
scene: {{kind: whine, mass: 0.2 kg, teeth: 10, stiffness: 2.0e8 N/m, damping: 400 N*s/m,
        mean_force: 50 N}}
sweep: {{speed: [6000 rpm, 12000 rpm]}}
solver: {{device: {device}, transient_periods: 1, record_periods: 2}}
"""


@pytest.mark.parametrize("where", ["study", "flag"])
def test_device_cuda_without_gpu_is_one_line_exit_2(tmp_path, where):
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.format(device="cuda" if where == "study" else "cpu"))
    cmd = [sys.executable, "-m", "gearsweep.cli", "run", str(study), "-o", str(tmp_path / "o.nc"),
           "-q"] + (["--device", "cuda"] if where == "flag" else [])
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_no_gpu_env(), timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert "cuda" in lines[0] and not (tmp_path / "o.nc").exists()
    if where == "study":  # the file, line and field where the device was asked for
        assert f"{study}:" in lines[0] and ": solver.device: 'cuda' -- " in lines[0], lines[0]
        assert "use device: cpu or auto" in lines[0]
    else:  # the flag, and the advice for the flag
        assert "--device cuda: " in lines[0] and "use --device cpu or auto" in lines[0], lines[0]


def test_a_gpu_run_is_estimated_without_a_gpu(tmp_path):
    """--estimate of a GPU study answers on a machine without a GPU (planning a GPU run from a
    laptop): the GPU's estimate, exit 0; only running it needs the GPU."""
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.format(device="cuda"))
    cmd = [sys.executable, "-m", "gearsweep.cli", "run", str(study), "--estimate"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_no_gpu_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "on the GPU at" in proc.stdout and "Msteps/s (stated)" in proc.stdout


@pytest.mark.parametrize(("solver", "flag", "said"), [
    ("{precision: float32, transient_periods: 1, record_periods: 2}", "cuda", "on the GPU at"),
    ("{device: cuda, kink_aware: true, transient_periods: 1, record_periods: 2}", "cpu",
     "on 1 core"),
])
def test_device_flag_overrides_before_the_checks(tmp_path, solver, flag, said):
    """--device replaces solver.device (docs/gpu.md) before the study's device checks: a float32
    study run with --device cuda, and a kink-aware rattle study of device cuda run with --device
    cpu, were refused for the device the flag replaces."""
    study = tmp_path / "s.yaml"
    study.write_text("title: t\nscene: {kind: rattle, mass: 0.2 kg, teeth: 10, stiffness: 2.0e8"
                     " N/m, damping: 400 N*s/m, backlash: 0.1 mm, torque: 5 N*m, base_radius:"
                     " 30 mm}\nsweep: {speed: [6000 rpm, 12000 rpm]}\nsolver: " + solver + "\n")
    cmd = [sys.executable, "-m", "gearsweep.cli", "run", str(study), "--estimate",
           "--device", flag]
    env = {**_no_gpu_env(), "NUMBA_NUM_THREADS": "1"}
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert said in proc.stdout, proc.stdout


def test_auto_picks_cpu_without_gpu():
    code = ("from gearsweep.kernels.cuda import kernel_for, resolve_device;"
            " print(resolve_device('auto'), kernel_for('auto').__name__)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_no_gpu_env())
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["cpu", "simulate"]


def test_float32_needs_cuda():
    from gearsweep.kernels.cuda import kernel_for

    with pytest.raises(DeviceError, match="float32"):
        kernel_for("cpu", "float32")


PTX_CHILD = """
import json
from numba import cuda, types
from gearsweep.kernels import cuda as gk
def probe(a):
    a[0] = 1.0
try:  # a trivial kernel first: where it fails, the toolkit (NVVM, NVRTC) is missing, not our code
    cuda.compile_ptx(probe, (types.float64[::1],), cc=(9, 0))
except Exception as exc:
    print(json.dumps({"skip": f"no usable CUDA toolkit (the cuda extra's): {exc}"[:240]}))
    raise SystemExit(0)
out = {}
for method, gap, prec, kamp in ((4, True, "float64", False), (5, True, "float32", True)):
    kern = gk._kernel(method, True, kamp, True, True, gap, True, prec)
    a = (types.float64 if prec == "float64" else types.float32)[:, ::1]
    sig = (a, types.int64, a, a, a, *[types.int64] * 5, types.float64[:, ::1], types.int8[::1], a)
    ptx, _ = cuda.compile_ptx(kern.py_func, sig, cc=(9, 0))
    ops = [line.split()[0] for line in ptx.splitlines() if line.strip() and line.startswith("\t")]
    out[f"rk{method}_{prec}"] = {"local": sum(".local" in o for o in ops),
                                 "calls": sum(o.startswith("call") for o in ops),
                                 "fma": sum(o.startswith("fma") for o in ops)}
print(json.dumps(out))
"""


@needs_numba_cuda
def test_kernels_compile_for_a_real_gpu():
    """numba-cuda compiles the kernel (RK4 f64, RK5 f32, every term on) to PTX for sm_90 (H100)
    without a GPU: what the simulator cannot check (the typing and lowering of the CPU helpers as
    device functions). Registers only: no local memory, no calls. Needs NVVM, which the cuda
    extra's toolkit brings; skipped without it."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    proc = subprocess.run([sys.executable, "-c", PTX_CHILD], capture_output=True, text=True,
                          env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    if "skip" in out:
        pytest.skip(out["skip"])
    for name, ops in out.items():
        assert ops["local"] == 0 and ops["calls"] == 0 and ops["fma"] > 10, (name, ops)


CACHE_KEY_CHILD = """
import hashlib, json
from numba.cuda.serialize import dumps
from gearsweep.kernels import cuda as gk
out = {}
for spec in ((4, True, False, True, True, True, False, "float64"),
             (5, False, True, False, True, False, True, "float32")):
    k = gk._kernel(*spec)
    f = getattr(k, "py_func", None) or k.fn  # a CUDA dispatcher, or the simulator's kernel
    cells = tuple(c.cell_contents for c in f.__closure__)
    out[f.__qualname__] = hashlib.sha256(dumps(cells)).hexdigest()
print(json.dumps(out))
"""


@needs_numba_cuda
def test_kernel_cache_key_is_the_same_in_every_process():
    """numba-cuda finds a kernel in its disk cache by a hash of the values the kernel closes
    over (``dumps`` of its closure cells, as in numba-cuda's ``_index_key``). A closure over a
    function (a Numba dispatcher pickles with an identity made anew in each process) gave every
    process another key: the kernel was compiled in every run, and the cache grew. Two fresh
    processes must agree, and two specialisations must not."""
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    keys = [json.loads(subprocess.run([sys.executable, "-c", CACHE_KEY_CHILD], env=env, check=True,
                                      capture_output=True, text=True, timeout=300).stdout)
            for _ in range(2)]
    assert keys[0] == keys[1]
    assert len(set(keys[0].values())) == len(keys[0]) == 2


@pytest.fixture(scope="module")
def real_gpu() -> None:
    """Skips unless numba-cuda sees a real GPU (checked only when a ``gpu`` test runs: it loads
    the CUDA driver)."""
    if not HAS_NUMBA_CUDA:
        pytest.skip("numba-cuda is not installed")
    from gearsweep.kernels.cuda import gpu_present

    if not gpu_present():
        pytest.skip("no CUDA GPU on this machine")


@pytest.mark.gpu
@pytest.mark.parametrize(("name", "method"), RUNS)
def test_real_gpu_agrees_with_cpu(real_gpu, cpu_results, name, method):
    """On a real GPU: every scene and method to 1e-12 of the CPU kernel, in several chunks."""
    from gearsweep.kernels.cuda import simulate_cuda

    cpu = cpu_results[(name, method)]
    gpu = simulate_cuda(**run_kw(name, method), max_chunk=2)
    np.testing.assert_array_equal(gpu.status, cpu.status)
    scale = float(np.nanmax(np.abs(cpu.signal)))
    for s in STAT_NAMES:
        assert _rel(gpu.stats[s], cpu.stats[s], scale if s.startswith("p_") else 1.0) <= TOL, s
    assert _rel(gpu.signal, cpu.signal, scale) <= TOL


if __name__ == "__main__":
    _child_main(sys.argv[1])
