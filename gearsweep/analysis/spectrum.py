"""Line spectra of steady-state signals sampled over a whole number of periods.

A signal sampled ``n`` times, uniformly, over exactly ``periods`` periods of its excitation has its
harmonics on exact DFT bins: bin ``k`` is the order ``k / periods`` (frequency over the excitation
frequency). No window is needed and a periodic steady state leaks nothing into the bins between
the lines. Amplitudes are single-sided: a component ``a cos(2 pi r t / T + phase)`` shows as ``a``
at order ``r`` (and the mean as itself at order 0), so Parseval reads

    mean(x**2) = c_0**2 + sum_{0 < k < n/2} |c_k|**2 / 2 + |c_{n/2}|**2

(the last term only for even ``n``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["kept_bins", "line_spectrum", "mean_square"]


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
