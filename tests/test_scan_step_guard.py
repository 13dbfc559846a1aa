"""scripts/scan_step_guard.py, the script behind the step guard's measured thresholds
(docs/stability.md, "The step guard"): its quick mode runs, and its closing dampings agree with
scipy's Mathieu characteristic values."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
from scipy.special import mathieu_a, mathieu_b

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("scan_step_guard",
                                               ROOT / "scripts" / "scan_step_guard.py")
scan = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(scan)


def test_closing_damping_against_scipys_mathieu_widths():
    """The damping at which the equation's tongue n closes (the script's ``close`` on a tiny
    grid: r = 0.1, tongues 1 and 2) against the width of Mathieu's tongue from scipy: in
    Mathieu's form y'' + (a - 2 q cos 2t) y = 0, p'' + (alpha + r alpha cos tau) p = 0 has
    a = 4 alpha, q = 2 r alpha, tongue n at a = n^2 of width a_n(q) - b_n(q); its growth rate at
    the middle, (a_n - b_n) / (8 n) per unit tau, equals the damping's gamma / 2 at
    zeta = gamma / n = (a_n - b_n) / (4 n^2)."""
    r = 0.1
    out = scan.close(quick=True, cases=[(r, 1), (r, 2)])
    for n in (1, 2):
        q = r * n * n / 2
        truth = (mathieu_a(n, q) - mathieu_b(n, q)) / (4 * n * n)
        assert out[r, n]["zeta"] == pytest.approx(truth, rel=1e-2)
        assert out[r, n]["tongue_damping"] == pytest.approx(truth, rel=1e-2)


@pytest.mark.slow
def test_quick_mode_runs():
    """The whole quick mode (every section, small samples) runs and prints every section."""
    proc = subprocess.run([sys.executable, str(ROOT / "scripts" / "scan_step_guard.py"), "--quick"],
                          capture_output=True, text=True, check=True, timeout=600)
    for name in scan.SECTIONS:
        assert f"[{name}:" in proc.stdout
