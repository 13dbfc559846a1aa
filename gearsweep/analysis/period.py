"""The period of a steady motion from its samples once per mesh period (a Poincare section).

A motion that repeats every ``P`` mesh periods has ``q[j] = q[j - P]`` for the samples ``q`` taken
at the same phase of every mesh period. ``motion_period`` returns, per case, the smallest such
``P`` up to half the record (so that every phase of the orbit is compared at least once) at a
tolerance relative to the motion's peak-to-peak, and the mismatch it found. Where no ``P`` fits,
the motion is irregular, or repeats over more than half the record: NaN.

This tells a period-1 motion from a period-2 or period-4 one (after a flip) and from an irregular
one, which the settle test (the extremes of the record's two halves) does not.
"""

from __future__ import annotations

import numpy as np

__all__ = ["motion_period"]


def motion_period(samples: np.ndarray, scale: np.ndarray, tolerance: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(period, mismatch) of each row of ``samples``.

    Parameters
    ----------
    samples : ndarray (cases, R)
        The motion once per mesh period, at one phase, over ``R`` recorded periods.
    scale : ndarray (cases,)
        What the mismatch is relative to (the motion's peak-to-peak over the record).
    tolerance : float
        Largest ``max_j |q[j] - q[j - P]| / scale`` that counts as repeating [-].

    Returns
    -------
    period : ndarray (cases,)
        The smallest ``P`` in ``1 .. R // 2`` within ``tolerance`` [mesh periods]; NaN where none
        is (or where a sample is not finite).
    mismatch : ndarray (cases,)
        ``max_j |q[j] - q[j - P]| / scale`` at that ``P``; where none fits, the smallest over
        ``P`` [-]. A scale of 0 (a motion at rest) counts as repeating every period.
    """
    q = np.asarray(samples, dtype=float)
    n, r = q.shape
    scale = np.broadcast_to(np.asarray(scale, dtype=float), (n,))
    period = np.full(n, np.nan)
    mismatch = np.full(n, np.inf)
    left = np.arange(n)  # the cases without a period yet: only they are compared further
    with np.errstate(invalid="ignore", divide="ignore"):
        for p in range(1, r // 2 + 1):
            if not left.size:
                break
            ql = q[left]
            diff = np.max(np.abs(ql[:, p:] - ql[:, :-p]), axis=1)
            d = np.where(diff == 0.0, 0.0, diff / scale[left])
            found = d <= tolerance
            period[left[found]] = p
            mismatch[left[found]] = d[found]
            mismatch[left[~found]] = np.fmin(mismatch[left[~found]], d[~found])
            left = left[~found]
    mismatch[~np.isfinite(mismatch)] = np.nan
    bad = ~np.isfinite(q).all(axis=1)
    period[bad] = np.nan
    mismatch[bad] = np.nan
    return period, mismatch
