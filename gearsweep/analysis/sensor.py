"""What the rig's sensors see of the model: the pinion's angular motion (paper section 7).

The paper's pick-up faces the pinion's teeth and its accelerometer sits on the pinion's bearing;
the authors read both as the pinion's torsional motion ("the change of rotation angle", Fig. 12).
In the model the pinion (gear 2) turns by Eq. (4),

    I2 theta2'' = r2 W(t) - T2m,   W(t) = k(t) f(p) + c p'   (the mesh force),

so, per spectral line k of W at frequency f_k > 0, the pinion's displacement at its base circle
is ``r2 theta2_k = (r2^2 / I2) W_k / (2 pi f_k)^2``: what a doubly integrated tangential
acceleration at the base circle shows (mean, and the rigid-body rotation, removed). Without
torque fluctuation ``W - F_m = -m_eq (p + e)''``, so this is the share ``m_eq r2^2 / I2`` of the
dynamic transmission error ``p + e``.

Pure numerics on arrays; the single-sided amplitude spectra come from the study output
``spectrum`` (``force_spectrum`` [N] with its ``frequency`` [Hz] coordinate).
"""

from __future__ import annotations

import numpy as np


def pinion_displacement(force_spectrum, frequency, *, base_radius_2: float,
                        inertia_2: float) -> np.ndarray:
    """Amplitude of ``r2 theta2`` [m] per spectral line of the mesh force.

    Parameters
    ----------
    force_spectrum : array_like
        Single-sided amplitudes of the mesh force W [N] (any shape).
    frequency : array_like
        Frequency of each line [Hz], broadcastable to ``force_spectrum``.
    base_radius_2, inertia_2 : float
        Pinion base radius r2 [m] and polar inertia I2 [kg m^2].

    Returns
    -------
    ndarray
        ``(r2^2 / I2) |W_k| / (2 pi f_k)^2`` [m]; 0 at f = 0 (the mean force turns the pinion
        steadily, which the sensor does not see).
    """
    w = 2.0 * np.pi * np.asarray(frequency, float)
    f = np.abs(np.asarray(force_spectrum, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = base_radius_2**2 / inertia_2 * f / w**2
    return np.where(w > 0, out, 0.0)


def spectrum_rms(amplitudes, axis: int = -1) -> np.ndarray:
    """rms about the mean of a signal from its single-sided line amplitudes (the mean, bin 0,
    must be left out or zero): ``sqrt(sum a_k^2 / 2)``. NaN lines give NaN."""
    a = np.asarray(amplitudes, float)
    return np.sqrt(0.5 * np.sum(a * a, axis=axis))
