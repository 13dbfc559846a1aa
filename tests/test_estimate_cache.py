"""The estimate's cold-compile note against Numba's real disk cache.

``--estimate`` and ``validate`` say "includes about N s to compile the kernel once (cold cache)"
exactly when a run of the study will compile: when the compiled function of the study's own
combination of terms (``rk.Specialised``: ``integrate_rk4_a0k1e1f0h0s0``) is not in the cache.
Asking whether any function of the method was cached said "no compile" to a study of other terms
that then compiled for seconds; and ``validate`` dropped the note that ``run --estimate`` gave.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import yaml

from gearsweep.kernels import batch
from gearsweep.study.chunk import kernel_calls
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study

ROOT = Path(__file__).resolve().parents[1]

TINY_RATTLE = """\
title: "tiny rattle (other terms than the whine: a force table and backlash, no k(t), no STE)"
scene:
  kind: rattle
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  damping: 4.92 N*s/mm
  backlash: 0.4698 mm
  torque: 50 N*m
  base_radius: 56.38 mm
  fluctuation: [{amplitude: 67.8 kN, order: 1}]
sweep:
  speed: {start: 5000 rpm, stop: 11000 rpm, num: 5}
solver: {method: rk4, steps_per_period: 32, transient_periods: 10, record_periods: 5}
"""

NOTE = "to compile the kernel once (cold cache)"

_ESTIMATES = """
import json, sys
from contextlib import redirect_stdout
from io import StringIO
from gearsweep.cli import main
out = {}
for study in sys.argv[1:]:
    for argv in (["validate", study], ["run", study, "--estimate", "-o", study + ".nc"]):
        buf = StringIO()
        with redirect_stdout(buf):
            assert main(argv) == 0
        out[argv[0] + " " + study] = buf.getvalue()
print(json.dumps(out))
"""


def _env(cache: Path) -> dict:
    return dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))


def _estimates(cache: Path, *studies: Path) -> dict[str, str]:
    """validate's and run --estimate's output for each study, in a process of its own."""
    proc = subprocess.run([sys.executable, "-c", _ESTIMATES, *map(str, studies)],
                          env=_env(cache), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


def _run(cache: Path, study: Path) -> None:
    subprocess.run([sys.executable, "-m", "gearsweep", "run", str(study), "-q", "-o",
                    str(study.with_suffix(".nc"))], env=_env(cache), check=True, timeout=600,
                   capture_output=True)


def _files(cache: Path) -> dict[str, tuple[int, int]]:
    """Every file Numba keeps in the cache: (size, mtime). Numba writes only when it compiles
    (``gearsweep/`` holds the package's own small caches, the unit factors and step limits:
    ``files.cache_folder``)."""
    return {str(p.relative_to(cache)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in cache.rglob("*") if p.is_file() and p.relative_to(cache).parts[0] != "gearsweep"}


def _drivers(files) -> set[str]:
    return {Path(f).name.split("-")[0] for f in files if "integrate_" in f and f.endswith(".nbi")}


def test_the_compile_note_follows_the_cache_of_the_studys_own_specialisation(
        tmp_path, write_study, small_whine):
    """With a fresh cache both commands say the estimate includes compiling; after one run of
    the study neither does (and a second run indeed compiles nothing); a study of other terms
    says so again, and its run indeed compiles a function of its own."""
    cache = tmp_path / "numba"
    whine = write_study(small_whine, "whine.yaml")
    rattle = write_study(TINY_RATTLE, "rattle.yaml")

    cold = _estimates(cache, whine, rattle)
    assert all(NOTE in text for text in cold.values()), cold
    assert _files(cache) == {}  # validate and --estimate compile nothing (the step guard too)
    assert cold[f"validate {whine}"].split("estimate: ")[1].strip() \
        == cold[f"run {whine}"].split(": ", 1)[1].strip()  # one estimate, said alike

    _run(cache, whine)  # compiles its specialisation (cold: seconds)
    after_whine = _files(cache)
    assert _drivers(after_whine) == {"rk.integrate_rk4_a0k1e1f0h0s0"}
    warm = _estimates(cache, whine, rattle)
    assert NOTE not in warm[f"validate {whine}"] and NOTE not in warm[f"run {whine}"], warm
    assert NOTE in warm[f"validate {rattle}"] and NOTE in warm[f"run {rattle}"], warm
    _run(cache, whine)
    assert _files(cache) == after_whine  # the estimate was right: nothing compiled

    _run(cache, rattle)  # its own specialisation: compiled (cold: seconds)
    assert _drivers(_files(cache)) == {"rk.integrate_rk4_a0k1e1f0h0s0",
                                       "rk.integrate_rk4_a0k0e0f1h1s0"}
    assert NOTE not in _estimates(cache, rattle)[f"validate {rattle}"]


def _called(monkeypatch, text: str) -> tuple[set[str], set[str]]:
    """(names of the compiled functions a real run of ``text`` called, of those the estimate
    looks up)."""
    import gearsweep

    plan = make_plan(parse_study(text, "s.yaml"), text)
    looked_up = {batch.dispatcher(call)[0].py_func.__name__ for call in kernel_calls(plan)}
    called = set()
    real = batch._driver_call

    def spy(*args, **kwargs):
        specialised, a = real(*args, **kwargs)
        called.add(specialised.driver(a).py_func.__name__)
        return specialised, a

    monkeypatch.setattr(batch, "_driver_call", spy)
    gearsweep.run(text)
    return called, looked_up


def test_the_estimate_looks_up_the_functions_a_run_calls(monkeypatch, small_whine):
    """The compiled functions whose cache entries the estimate asks for are those a real run
    calls: an RK5 whine study with a spectrum (a signal: ``s1``) and a Floquet output, whose
    monodromy maps call RK5 with a stiffness scale and table (``a1k1e0f0h0s0``)."""
    study = dict(small_whine, outputs=["stats", {"spectrum": {"max_order": 2}}, "floquet"])
    study["solver"]["method"] = "rk5"
    study["sweep"]["speed"]["num"] = 2
    called, looked_up = _called(monkeypatch, yaml.safe_dump(study))
    assert called == looked_up == {"integrate_rk5_a0k1e1f0h0s1", "integrate_rk5_a1k1e0f0h0s0"}


_ESTIMATE_AND_PEAK = """
import json, sys
from gearsweep.cli import main
from gearsweep.study.estimate import quick_estimate
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study
text = open(sys.argv[1], encoding="utf-8").read()
est = quick_estimate(make_plan(parse_study(text, sys.argv[1]), text))[0]
assert main(["run", sys.argv[1], "-q", "-o", sys.argv[2]]) == 0
hwm = next(ln for ln in open("/proc/self/status") if ln.startswith("VmHWM:"))
print(json.dumps({"estimate": est.memory_bytes, "compile": est.compile_bytes,
                  "peak": int(hwm.split()[1]) * 1024}))
"""
"""A study's estimate and its run's peak resident memory, in a process of its own (VmHWM: the
process's own; getrusage's ru_maxrss keeps the forking parent's, pytest's, across exec)."""


def test_the_memory_estimate_counts_a_cold_compile(tmp_path, write_study):
    """Compiling a kink-aware RK4 specialisation on a cold cache is hundreds of MB of LLVM: the
    run of studies/rattle_kink_aware.yaml peaked at 372 MB resident on a fresh cache, 168 MB on
    the cache that run filled, and the estimate said 300 MB of both. Truth: the peak resident
    memory of the run (its own process) on a fresh cache and again on the cache it filled. The
    estimate now holds both, and what it adds for the compile covers the difference without
    being over twice it."""
    study = write_study(TINY_RATTLE.replace("{method: rk4,", "{method: rk4, kink_aware: true,"),
                        "kink.yaml")
    plan = make_plan(parse_study(study.read_text(encoding="utf-8")))
    assert {batch.specialisation(c)[:2] for c in kernel_calls(plan)} == {("rk4", True)}
    cache = tmp_path / "numba"
    runs = []
    for out in ("cold.nc", "warm.nc"):
        proc = subprocess.run([sys.executable, "-c", _ESTIMATE_AND_PEAK, str(study),
                               str(tmp_path / out)], env=_env(cache), capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        runs.append(json.loads(proc.stdout.splitlines()[-1]))
    cold, warm = runs
    assert cold["compile"] == batch.COLD_COMPILE_BYTES[("rk4", True)] and warm["compile"] == 0
    assert cold["peak"] <= cold["estimate"] and warm["peak"] <= warm["estimate"], runs
    assert cold["peak"] - warm["peak"] <= cold["compile"] <= 2 * (cold["peak"] - warm["peak"])
