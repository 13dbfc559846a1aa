"""Periodic shapes tabulated at the stage nodes of every step of one excitation cycle.

A cycle of ``cycle_periods`` mesh periods is cut into ``S = steps_per_period * cycle_periods``
equal steps; entry ``[s, c]`` is the shape at phase ``(s + NODES[c]) / steps_per_period`` mesh
periods. Fourier series use the paper's Eq. (1) convention, with the phase ``phi`` in mesh periods:

    x(phi) = sum_n a_n cos(2 pi r_n phi + alpha_n)

where ``r_n`` is the order relative to the mesh frequency (integer for mesh harmonics, a multiple
of ``1 / cycle_periods`` for slower excitations such as shaft-order torque fluctuation).
"""

import numpy as np

from gearsweep.kernels.rk import NODES


def phases(steps_per_period: int, cycle_periods: int = 1) -> np.ndarray:
    """Phase [mesh periods] of every stage node, shape (S, 5)."""
    s = np.arange(steps_per_period * cycle_periods, dtype=float)[:, None]
    return (s + np.asarray(NODES)[None, :]) / steps_per_period


def fourier_table(amplitudes, orders, phases_rad, steps_per_period: int, cycle_periods: int = 1,
                  derivative: int = 0) -> np.ndarray:
    """Tabulate ``sum a_n cos(2 pi r_n phi + alpha_n)`` (or its ``derivative``-th derivative with
    respect to the mesh angle ``2 pi phi``) at every stage node; shape (S, 5)."""
    phi = phases(steps_per_period, cycle_periods)
    out = np.zeros_like(phi)
    for a, r, al in zip(np.atleast_1d(amplitudes), np.atleast_1d(orders),
                        np.atleast_1d(phases_rad), strict=True):
        arg = 2.0 * np.pi * r * phi + al
        if derivative == 0:
            out += a * np.cos(arg)
        elif derivative == 2:
            out -= a * r * r * np.cos(arg)
        else:
            raise NotImplementedError("only the shape and its second derivative are tabulated")
    return out
