"""Up/down speed sweeps of the rattle scene with the state carried from speed to speed.

A stand-in for the study runner's up/down sweeps until they land: one ``simulate`` call per speed,
every other parameter combination a lane of that call, each speed starting from the final state
of the previous one. The excitation is a harmonic force at ``order`` times the mesh frequency of
a gear with ``teeth`` teeth turning at the swept speed (Eq. (13) with constant stiffness):

    m p'' + c p' + k f(p) = F_m + F_0 cos(order * 2 pi f_mesh t),  f_mesh = teeth * rpm / 60.

Every call integrates a whole number of excitation cycles, so the phase of the force is 0 at the
start of every speed and the carried state is continuous in phase.

A sweep with no more lanes than one kernel block (``rk.LANES``) runs with one Numba thread: a
single block cannot use a second thread, and waking the thread pool for each of hundreds of short
calls costs milliseconds per call when the cores are shared (measured: 0.6 s instead of 6-9 s for
the 800 calls of a Fig. 8 sweep on the loaded 2-core machine).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from gearsweep.kernels import rk
from gearsweep.kernels.batch import simulate
from gearsweep.kernels.tables import fourier_table

STAT_KEYS = ("p_max", "p_min", "p_mean", "p_rms", "contact_loss_fraction",
             "backside_contact_fraction", "impacts_per_period", "settle_error")


@dataclass(frozen=True)
class SweepResult:
    """Statistics of a sweep, arrays shaped (lanes, speeds), speeds in increasing order."""

    speed: np.ndarray
    """Speed [rpm], increasing."""
    direction: str
    """``"up"`` or ``"down"``: the order in which the speeds were run."""
    stats: dict[str, np.ndarray]
    """Per lane and speed: the kernel statistics (``STAT_KEYS``) [m] or [1]."""
    diverged: np.ndarray
    """Lanes and speeds where the kernel stopped a case (bool)."""

    @property
    def amplitude(self) -> np.ndarray:
        """Half the peak-to-peak displacement (p_max - p_min) / 2 [m]."""
        return 0.5 * (self.stats["p_max"] - self.stats["p_min"])


def sweep(speed_rpm, direction: str, *, teeth: int, order: float = 1.0, mass: float,
          stiffness, damping, half_gap, force_mean, force_amp,
          steps_per_period: int = 64, transient_periods: int = 20, record_periods: int = 10,
          method: str = "rk4", x0=None, v0=None) -> SweepResult:
    """Run one up or down sweep for every lane.

    Parameters
    ----------
    speed_rpm : array_like (n_speed,)
        Speeds of the driving gear [rpm], increasing; ``direction`` decides the running order.
    direction : {"up", "down"}
    teeth : int
        Teeth on the gear whose speed is swept (sets the mesh frequency).
    order : float
        Excitation frequency / mesh frequency; must make ``order * steps_per_period`` steps an
        integer number of force cycles per mesh period (order 1 or an integer).
    mass : float
        Equivalent mass m_eq [kg].
    stiffness, damping, half_gap, force_mean, force_amp : array_like (lanes,) or scalar
        k [N/m], c [N s/m], b = backlash / 2 [m], F_m [N], F_0 [N].
    steps_per_period, transient_periods, record_periods : int
        Steps per mesh period; mesh periods discarded and recorded at every speed.
    method : {"rk4", "rk5"}
    x0, v0 : array_like, optional
        State at the first speed [m], [m/s]; default: the static equilibrium on the drive flank
        ``b + F_m / k`` at rest.
    """
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    speed = np.asarray(speed_rpm, dtype=float)
    if np.any(np.diff(speed) <= 0):
        raise ValueError("speed_rpm must increase")
    if float(order) != round(float(order)) or order < 1:
        raise ValueError("order must be a positive integer (one force cycle per mesh period)")
    arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, dtype=float)) for x in
                                   (stiffness, damping, half_gap, force_mean, force_amp)))
    k, c, b, fm, f0 = (np.ascontiguousarray(a) for a in arrays)
    lanes = k.shape[0]
    x = np.broadcast_to(b + fm / k if x0 is None else np.asarray(x0, float), (lanes,)).copy()
    v = np.broadcast_to(0.0 if v0 is None else np.asarray(v0, float), (lanes,)).copy()
    table = fourier_table([1.0], [float(order)], [0.0], steps_per_period)
    stats = {key: np.full((lanes, speed.size), np.nan) for key in STAT_KEYS}
    diverged = np.zeros((lanes, speed.size), dtype=bool)
    order_idx = range(speed.size) if direction == "up" else range(speed.size - 1, -1, -1)
    common = dict(method=method, damping=c / mass, k_mean=k / mass, force=fm / mass,
                  fluct_scale=f0 / mass, fluct_table=table, half_gap=b,
                  bound=1e3 * (b + np.abs(f0) / k + 1e-3),
                  n_transient=transient_periods * steps_per_period,
                  n_record=record_periods * steps_per_period, steps_per_period=steps_per_period)
    threads = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, -(-lanes // rk.LANES))))
    try:
        for j in order_idx:
            f_mesh = teeth * speed[j] / 60.0
            h = np.full(lanes, 1.0 / (f_mesh * steps_per_period))
            res = simulate(h, x0=x, v0=v, **common)
            for key in STAT_KEYS:
                stats[key][:, j] = res.stats[key]
            bad = res.status != 0
            diverged[:, j] = bad
            x = np.where(bad, b + fm / k, res.x_final)
            v = np.where(bad, 0.0, res.v_final)
    finally:
        numba.set_num_threads(threads)
    return SweepResult(speed=speed, direction=direction, stats=stats, diverged=diverged)
