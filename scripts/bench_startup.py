"""Where a process's start goes: the tiny-study target of issue 23 on any machine.

Medians of 3 fresh processes each, warm Numba cache (one run first): bare Python, the libraries
a run of a chunked study imports (``LIBRARIES``; until 26 Nov 2026 it imported xarray and pint
as well, and this script timed those too), ``import gearsweep.cli`` and the whole run of a tiny
study (``python -m gearsweep run``, the ``gearsweep`` command, of ``studies/heavy/scale_1e6.yaml``
cut to 8 speeds, nothing else swept), then the ratio tiny run / libraries (target <= 1.5) and the
20 largest cumulative import times of ``gearsweep.cli`` (``python -X importtime``).
``scripts/device_check.sh`` runs it on the device machine, whose image holds some 200 packages.

    PYTHONPATH=. python scripts/bench_startup.py
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIBRARIES = "import numpy, numba, netCDF4, pydantic, yaml, filelock"
"""What ``gearsweep run`` of a chunked study imports beside gearsweep (and the standard library)."""
ISSUE_LIBRARIES = "import numpy, xarray"
"""Issue 23: a tiny study's run "costs little more than importing numpy and xarray"."""


def tiny_study(folder: Path) -> Path:
    """The scale study with 8 speeds and its other sweeps removed (8 cases)."""
    text = (ROOT / "studies" / "heavy" / "scale_1e6.yaml").read_text(encoding="utf-8")
    keep = [ln for ln in text.splitlines()
            if not ln.lstrip().startswith(("torque:", "damping:", "backlash: {"))]
    text = "\n".join(keep).replace("num: 100}", "num: 8}") + "\n"
    assert "num: 8}" in text, "the scale study changed: update bench_startup.tiny_study"
    path = folder / "tiny.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def median_seconds(cmd: list[str], repeats: int = 3, fresh: Path | None = None) -> float:
    """Median wall time of ``cmd``; ``fresh``: a file removed before each run (a study's first
    run to its output, as bench_pipeline.py measures: a rerun also reads its own result's study)."""
    times = []
    for _ in range(repeats):
        if fresh is not None:
            fresh.unlink(missing_ok=True)
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, cwd=ROOT)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> None:
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args(argv)  # --help
    from bench_scale import byte_compile

    byte_compile()
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        study = tiny_study(Path(tmp))
        run = [py, "-m", "gearsweep", "run", str(study), "-o", str(Path(tmp) / "t.nc"), "-q",
               "--yes"]
        subprocess.run(run, check=True, cwd=ROOT)  # warms the cache
        rows = {"python -c pass": median_seconds([py, "-c", "pass"]),
                f"{LIBRARIES}": median_seconds([py, "-c", LIBRARIES]),
                ISSUE_LIBRARIES: median_seconds([py, "-c", ISSUE_LIBRARIES]),
                "import gearsweep.cli": median_seconds([py, "-c", "import gearsweep.cli"]),
                "tiny study (8 cases), whole run": median_seconds(run, fresh=Path(tmp) / "t.nc")}
    for what, seconds in rows.items():
        print(f"{seconds:7.3f} s  {what}")
    tiny = rows["tiny study (8 cases), whole run"]
    print(f"tiny run / libraries: {tiny / rows[LIBRARIES]:.2f} (target <= 1.5); / numpy and"
          f" xarray (the issue's words): {tiny / rows[ISSUE_LIBRARIES]:.2f}")
    lines = subprocess.run([py, "-X", "importtime", "-c", "import gearsweep.cli"], cwd=ROOT,
                           capture_output=True, text=True).stderr.splitlines()
    timed = sorted((int(ln.split("|")[1]), ln) for ln in lines[1:] if ln.count("|") == 2)
    print("import gearsweep.cli, 20 largest cumulative import times [us]:")
    for _, ln in timed[::-1][:20]:
        print(ln)


if __name__ == "__main__":
    main()
