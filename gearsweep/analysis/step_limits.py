"""The stability limit of the batch kernel's methods, measured by integration.

The free linear oscillator ``p'' + 2 zeta w p' + w^2 p = 0`` from p = 1, p' = 0 is integrated for
a fine grid of steps h at once (one batch call); the growth per step,
``log(|state_N| / |state_0|) / N`` with ``|state| = sqrt(p^2 + (p'/w)^2)``, is interpolated to
zero. The stability polynomial's value (``gearsweep.analysis.advise.stability_limit``) is the
independent truth this is set against (``method_stability`` study, ``figures/method_stability.png``).
"""

from __future__ import annotations

import numpy as np

from gearsweep.kernels.batch import simulate


def measured_limit(method: str, zeta: float, *, lo: float = 0.5, hi: float = 4.0, n: int = 3501,
                   steps: int = 20_000) -> float:
    """Largest h omega_n below which the integrated free oscillator does not grow [1].

    The first zero crossing of the measured growth per step, scanning ``n`` values of h omega_n
    up from ``lo`` to ``hi``; ``lo`` if even that grows, ``inf`` if nothing up to ``hi`` does.
    The kink-aware kernel takes the plain step wherever no backlash boundary is crossed, so
    inside one contact region its limit is the plain method's.
    """
    wn = 1.0
    hw = np.linspace(lo, hi, n)
    r = simulate(hw / wn, method=method, damping=2 * zeta * wn, k_mean=wn * wn, x0=1.0, v0=0.0,
                 n_transient=steps, n_record=0, steps_per_period=100)
    norm = np.hypot(r.x_final, r.v_final / wn)
    with np.errstate(divide="ignore"):
        rate = np.where(np.isfinite(norm), np.log(norm) / steps, np.inf)
    bad = np.nonzero(rate > 1e-9)[0]
    if len(bad) == 0:
        return np.inf
    k = bad[0]
    if k == 0:
        return lo
    r0, r1 = rate[k - 1], min(rate[k], 1.0)
    return float(hw[k - 1] + (hw[k] - hw[k - 1]) * (0.0 - r0) / (r1 - r0)) if r1 > r0 else hw[k]
