"""Jumps and hysteresis from the amplitudes of an up and a down speed sweep.

Criterion
---------
A sweep *jumps* between neighbouring speeds ``i`` and ``i + 1`` when both hold:

1. the relative change of the amplitude ``|a[i+1] - a[i]| / max(a[i], a[i+1])`` exceeds
   ``threshold`` (default 0.25), and
2. the other sweep differs from this one by more than ``threshold`` (relative, same measure) at
   speed ``i`` or ``i + 1``: the response is two-valued there.

Why this separates jumps from steep smooth branches: on a smooth branch the relative change per
step is ``|d ln a / d ln n| * d ln n``. For a linear oscillator with damping ratio ``zeta`` the
log-slope of the response is at most about ``1 / (2 zeta)``, so at the Fig. 8 scene
(``zeta ~ 0.19``, 400 speeds over a factor 2 in speed, ``d ln n = 0.0017``) smooth branches change
by well under 1% per step, and even ``zeta = 0.01`` on 100 speeds stays near 0.35 only at the very
peak; at a jump the amplitude changes by a factor (in the Fig. 8 scene about 2.5, a relative
change near 0.6). Condition 2 removes steep single-valued responses (lightly damped resonances
without a fold), which are identical up and down, whatever the grid.

The *hysteresis band* is the interval between the run-down jump (up) and the run-up jump (down):
``[min, max]`` of the two jump speeds. All functions take the speed along the last axis and
broadcast over any leading axes (sweeps of a parameter study).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def relative_steps(amplitude: np.ndarray) -> np.ndarray:
    """Signed relative change between neighbours along the last axis, ``(n - 1)`` entries [1]."""
    a = np.asarray(amplitude, dtype=float)
    d = np.diff(a, axis=-1)
    scale = np.maximum(np.abs(a[..., 1:]), np.abs(a[..., :-1]))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(scale > 0, d / np.where(scale > 0, scale, 1.0), 0.0)


@dataclass(frozen=True)
class JumpSummary:
    """Jumps of an up and a down sweep (arrays over the leading axes; NaN: no jump)."""

    up_speed: np.ndarray
    """Speed at which the run-up jumps: midpoint of the two neighbouring speeds [speed unit]."""
    up_size: np.ndarray
    """Signed relative change of the run-up jump [1] (negative: the amplitude drops)."""
    down_speed: np.ndarray
    """Speed at which the run-down jumps [speed unit]."""
    down_size: np.ndarray
    """Signed relative change of the run-down jump, in the direction of decreasing speed [1]."""
    band_low: np.ndarray
    """Lower end of the hysteresis band [speed unit]."""
    band_high: np.ndarray
    """Upper end of the hysteresis band [speed unit]."""

    @property
    def width(self) -> np.ndarray:
        """Width of the hysteresis band [speed unit] (0 where neither sweep jumps)."""
        return np.nan_to_num(self.band_high - self.band_low, nan=0.0)


def _largest_jump(speed, steps, differs, threshold):
    """Speed and size of the largest qualifying step along the last axis."""
    two_valued = differs[..., :-1] | differs[..., 1:]
    ok = (np.abs(steps) > threshold) & two_valued
    score = np.where(ok, np.abs(steps), -1.0)
    i = np.argmax(score, axis=-1)
    found = np.take_along_axis(score, i[..., None], axis=-1)[..., 0] > 0
    mid = 0.5 * (speed[..., :-1] + speed[..., 1:])
    mid = np.broadcast_to(mid, steps.shape)
    at = np.take_along_axis(mid, i[..., None], axis=-1)[..., 0]
    size = np.take_along_axis(steps, i[..., None], axis=-1)[..., 0]
    return np.where(found, at, np.nan), np.where(found, size, np.nan)


def find_jumps(speed, amp_up, amp_down, threshold: float = 0.25) -> JumpSummary:
    """Jump speeds and hysteresis band of an up and a down sweep (criterion: module docstring).

    Parameters
    ----------
    speed : array_like (..., n)
        Speeds in increasing order (any unit; the results are in the same unit).
    amp_up, amp_down : array_like (..., n)
        Response amplitude of the run-up and the run-down, both ordered by increasing speed.
    threshold : float
        Relative change that marks a jump and relative difference that marks two values [1].
    """
    s = np.asarray(speed, dtype=float)
    if np.any(np.diff(s, axis=-1) <= 0):
        raise ValueError("speed must increase along the last axis")
    up = np.asarray(amp_up, dtype=float)
    down = np.asarray(amp_down, dtype=float)
    scale = np.maximum(np.abs(up), np.abs(down))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(scale > 0, np.abs(up - down) / np.where(scale > 0, scale, 1.0), 0.0)
    differs = rel > threshold
    up_speed, up_size = _largest_jump(s, relative_steps(up), differs, threshold)
    # the run-down travels towards lower speeds: its jump size is measured in that direction
    down_speed, down_size = _largest_jump(s, -relative_steps(down), differs, threshold)
    both = np.stack(np.broadcast_arrays(up_speed, down_speed))
    with np.errstate(invalid="ignore"):
        lo = np.where(np.all(np.isnan(both), axis=0), np.nan, np.nanmin(np.where(
            np.isnan(both), np.inf, both), axis=0))
        hi = np.where(np.all(np.isnan(both), axis=0), np.nan, np.nanmax(np.where(
            np.isnan(both), -np.inf, both), axis=0))
    return JumpSummary(up_speed=up_speed, up_size=up_size, down_speed=down_speed,
                       down_size=down_size, band_low=lo, band_high=hi)
