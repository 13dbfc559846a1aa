"""Method stability chart: the largest stable h omega_n of each kernel method, measured by
integration with the batch kernel, next to the value from the method's stability polynomial.

Measured: the free linear oscillator p'' + 2 zeta omega_n p' + omega_n^2 p = 0 from p = 1,
p' = 0, for a fine grid of steps h at once (one batch call per method and zeta); the growth per
step, log(|state_N| / |state_0|) / N with |state| = sqrt(p^2 + (p'/omega_n)^2), is interpolated
to zero. Polynomial: ``gearsweep.analysis.advise.stability_limit`` (first h omega_n along the
eigenvalue ray where |R| reaches 1). The kink-aware kernel takes the plain step wherever no
boundary is crossed, so inside one contact region its limit is the plain method's.

    PYTHONPATH=. python scripts/method_stability.py
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gearsweep.analysis.advise import stability_limit  # noqa: E402
from gearsweep.kernels.batch import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ZETAS = (0.0, 0.02, 0.05, 0.1, 0.15, 0.215, 0.3, 0.4, 0.5, 0.6)
"""Damping ratios; 0.215 is the paper's rig (c = 5.5 N s/mm, m = 0.1527 kg, k = 1.073e9 N/m)."""
STEPS = 20_000


def measured_limit(method: str, zeta: float, lo: float = 0.5, hi: float = 4.0,
                   n: int = 3501) -> float:
    """Largest h omega_n below which the integrated free oscillator does not grow [1]:
    the first zero crossing of the measured growth per step, scanning up from ``lo``."""
    wn = 1.0
    hw = np.linspace(lo, hi, n)
    r = simulate(hw / wn, method=method, damping=2 * zeta * wn, k_mean=wn * wn, x0=1.0, v0=0.0,
                 n_transient=STEPS, n_record=0, steps_per_period=100)
    norm = np.hypot(r.x_final, r.v_final / wn)
    with np.errstate(divide="ignore"):
        rate = np.where(np.isfinite(norm), np.log(norm) / STEPS, np.inf)
    bad = np.nonzero(rate > 1e-9)[0]
    if len(bad) == 0:
        return np.inf
    k = bad[0]
    if k == 0:
        return lo
    r0, r1 = rate[k - 1], min(rate[k], 1.0)
    return float(hw[k - 1] + (hw[k] - hw[k - 1]) * (0.0 - r0) / (r1 - r0)) if r1 > r0 else hw[k]


def main() -> None:
    fig, ax = plt.subplots(figsize=(7.5, 5), constrained_layout=True)
    zfine = np.linspace(0, 0.6, 121)
    for method, color in (("rk4", "C0"), ("rk5", "C1")):
        poly = [stability_limit(method, float(z)) for z in zfine]
        ax.plot(zfine, poly, color=color,
                label=f"{method}: stability polynomial, $|R(h\\lambda)| = 1$")
        meas = [measured_limit(method, z) for z in ZETAS]
        ax.plot(ZETAS, meas, "o", mfc="none", color=color,
                label=f"{method}: measured by integration ({STEPS} steps)")
        for z, m in zip(ZETAS, meas, strict=True):
            print(f"{method} zeta={z:.3f} measured={m:.4f} polynomial="
                  f"{stability_limit(method, z):.4f}")
    ax.axvline(0.215, color="0.5", ls=":", lw=1)
    ax.text(0.22, 0.3, "paper's rig\n$\\zeta$ = 0.215", fontsize=8, color="0.4")
    ax.set_xlabel("damping ratio $\\zeta = c\\,/\\,(2 m \\omega_n)$ [-]")
    ax.set_ylabel("largest stable $h\\,\\omega_n$ [-]")
    ax.set_title("Stability limit of the fixed-step methods (free linear oscillator)\n"
                 "kink-aware forms: same steps inside a contact region, same limits", fontsize=10)
    ax.set_ylim(0, 4)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    (ROOT / "figures").mkdir(exist_ok=True)
    fig.savefig(ROOT / "figures" / "method_stability.png", dpi=130)


if __name__ == "__main__":
    main()
