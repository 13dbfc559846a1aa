"""Line spectra of steady-state signals sampled over a whole number of periods.

A signal sampled ``n`` times, uniformly, over exactly ``periods`` periods of its excitation has its
harmonics on exact DFT bins: bin ``k`` is the order ``k / periods`` (frequency over the excitation
frequency). No window is needed and a periodic steady state leaks nothing into the bins between
the lines. Amplitudes are single-sided: a component ``a cos(2 pi r t / T + phase)`` shows as ``a``
at order ``r`` (and the mean as itself at order 0), so Parseval reads

    mean(x**2) = c_0**2 + sum_{0 < k < n/2} |c_k|**2 / 2 + |c_{n/2}|**2

(the last term only for even ``n``).

Phases (``line_phase``) are referred to the start of the excitation (phase 0 at t = 0), not to
the first sample: with sample 0 at ``start`` periods, a component ``a cos(2 pi r t / T + phase)``
shows as ``phase`` at order ``r``, whatever the offset. The mean's phase is 0 or pi (its sign);
the Nyquist bin sees only ``a cos(.)`` at the samples, so its (amplitude, phase) is the one
line through the samples, not the component's own.
"""

from __future__ import annotations

import numpy as np

__all__ = ["kept_bins", "line_phase", "line_spectrum", "mean_square", "wrap_phase"]


def kept_bins(n_samples: int, periods: int, max_order: float) -> int:
    """Number of single-sided bins ``k = 0 .. K`` with order ``k / periods <= max_order``.

    Parameters
    ----------
    n_samples : int
        Samples in the window [-].
    periods : int
        Whole periods of the excitation in the window [-].
    max_order : float
        Highest order kept [-]; bins above the Nyquist bin ``n_samples // 2`` are never kept.
    """
    nyquist = n_samples // 2
    if max_order * periods >= nyquist:
        return nyquist + 1
    return int(np.floor(max_order * periods + 1e-9)) + 1


def line_spectrum(signal: np.ndarray, periods: int, max_order: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided complex line spectrum of signals sampled over whole periods.

    Parameters
    ----------
    signal : ndarray (..., n)
        Uniform samples over exactly ``periods`` periods [any unit].
    periods : int
        Whole periods in the window [-].
    max_order : float, optional
        Keep orders up to this one (default: up to the Nyquist bin).

    Returns
    -------
    order : ndarray (K,)
        ``k / periods`` for ``k = 0 .. K - 1`` [-] (exact ratios of integers).
    coeff : ndarray complex (..., K)
        ``c_k`` with ``x_j = sum_k Re(c_k exp(2 pi i k j / n))``: ``|c_k|`` is the amplitude of
        order ``k / periods`` [unit of ``signal``].
    """
    x = np.asarray(signal, dtype=float)
    n = x.shape[-1]
    if n < 1 or periods < 1:
        raise ValueError("a spectrum needs at least one sample and one period")
    keep = kept_bins(n, periods, np.inf if max_order is None else max_order)
    c = np.fft.rfft(x, axis=-1)[..., :keep] / n
    c[..., 1:] *= 2.0
    if n % 2 == 0 and keep == n // 2 + 1:
        c[..., -1] /= 2.0  # the Nyquist bin is its own mirror image
    order = np.arange(keep) / periods
    return order, c


def mean_square(coeff: np.ndarray, n_samples: int) -> np.ndarray:
    """Mean square of the signal from its full single-sided spectrum (Parseval) [unit^2].

    Parameters
    ----------
    coeff : ndarray complex (..., n_samples // 2 + 1)
        Every bin of ``line_spectrum`` (``max_order=None``).
    n_samples : int
        Samples of the signal [-].
    """
    a2 = np.abs(coeff) ** 2
    total = a2[..., 0] + 0.5 * a2[..., 1:].sum(axis=-1)
    if n_samples % 2 == 0:
        total = total + 0.5 * a2[..., -1]  # Nyquist: c = X / n, counted once, not halved
    return total


def wrap_phase(theta) -> np.ndarray:
    """Angles [rad] wrapped to (-pi, pi] (pi stays pi; -pi becomes pi)."""
    return np.pi - np.mod(np.pi - np.asarray(theta, dtype=float), 2.0 * np.pi)


def first_crossing(x, y, level: float) -> float:
    """The first ``x`` at which ``y`` passes below ``level`` (linear between the samples), NaN
    where it never does: e.g. the speed at which a line's phase lag passes a quarter period."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    below = np.flatnonzero(y < level)
    if below.size == 0 or below[0] == 0:
        return float("nan")
    i = int(below[0])
    return float(x[i - 1] + (x[i] - x[i - 1]) * (level - y[i - 1]) / (y[i] - y[i - 1]))


def line_phase(coeff: np.ndarray, periods: int, start_periods: int = 0,
               start_fraction: float = 0.0) -> np.ndarray:
    """Phase of each line of ``line_spectrum``, referred to t = 0 [rad], in (-pi, pi].

    With sample 0 at ``t / T = start_periods + start_fraction`` (``T`` the period of the
    excitation), the signal is ``x(t) ~= sum_k |c_k| cos(2 pi (k / periods) t / T + theta_k)``:
    ``theta_k = arg(c_k) - 2 pi (k / periods) (start_periods + start_fraction)``. The whole
    periods are taken modulo ``periods`` in integers, so that a start after 1e9 periods loses
    no digit (``k start_periods`` in floating point would keep none of the phase).

    Parameters
    ----------
    coeff : ndarray complex (..., K)
        ``c_k`` of ``line_spectrum`` for ``k = 0 .. K - 1``.
    periods : int
        Whole periods in the window [-].
    start_periods, start_fraction : int, float
        Where sample 0 lies: whole periods, and the fraction of one after them [-].
    """
    c = np.asarray(coeff)
    k = np.arange(c.shape[-1], dtype=np.int64)
    turns = (k * (int(start_periods) % periods)) % periods / periods \
        + k * (float(start_fraction) / periods)
    return wrap_phase(np.angle(c) - 2.0 * np.pi * np.mod(turns, 1.0))
