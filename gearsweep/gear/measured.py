"""Measured (or LTCA-computed) transmission error and mesh stiffness as the model's Fourier series.

An engineer's samples of the loaded static transmission error STE(phi) [m] and/or the mesh
stiffness k(phi) [N/m], over one mesh cycle or over a revolution of the driving gear, are fitted
by least squares with the series of the paper's Eq. (1),

    x(phi) = x_0 + sum_n x_n cos(2 pi o_n phi + phase_n)                                   (1)

with ``phi`` the mesh phase (mesh cycles since a reference) and the orders ``o_n`` in mesh
orders: ``1..H`` over a mesh cycle, ``k / N1`` for ``k = 1..H N1`` over a revolution (every shaft
order up to mesh order H; fractional orders are run by the kernel over ``N1`` mesh periods, see
``MeshModel.cycle_periods``). The samples need not be evenly spaced; for evenly spaced samples the
least-squares fit is the discrete Fourier transform (``gearsweep.gear.fourier``).

Which excitation e(t) the model gets (as for a gear pair, ``gearsweep.gear.excitation`` and
docs/mesh.md): with a time-varying stiffness k(t) (whine, full) the mesh force is
``k(t) (x - e)`` and the quasi-static solution is ``x = F_m / k(t) + e(t)``, which must be the
measured loaded STE, so ``e = STE - F_m / k(phi)`` (fitted from the samples, with k the measured
samples where the file has them, else the scene's series); with a constant stiffness (rattle,
Eq. (13)) e(t) is the loaded STE itself.

Plain SI floats and NumPy arrays: nothing here reads files (``gearsweep.study.measured`` does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearsweep.errors import GearsweepError
from gearsweep.model import Harmonic


class FitError(GearsweepError):
    """Samples that cannot determine the harmonics asked for (too few, or not spread over the period)."""


@dataclass(frozen=True)
class FourierFit:
    """A least-squares fit of samples with Eq. (1)."""

    mean: float
    """x_0 [unit of the samples]."""
    harmonics: tuple[Harmonic, ...]
    """x_n [unit], orders o_n [mesh orders], phases [rad], in the order of ``orders``."""
    residual_rms: float
    """rms of (samples - series at the samples) [unit]."""
    residual_max: float
    """largest |samples - series| [unit]."""
    samples: int

    def __call__(self, phi) -> np.ndarray:
        """The fitted series at mesh phases ``phi`` [unit]."""
        return series(self.mean, self.harmonics, phi)


def series(mean: float, harmonics, phi) -> np.ndarray:
    """``mean + sum_n a_n cos(2 pi o_n phi + phase_n)`` at mesh phases ``phi``."""
    phi = np.asarray(phi, dtype=float)
    out = np.full(phi.shape, float(mean))
    for h in harmonics:
        out = out + h.amplitude * np.cos(2.0 * math.pi * h.order * phi + h.phase)
    return out


def fit_orders(harmonics: int, teeth: int, revolution: bool) -> np.ndarray:
    """The mesh orders fitted for ``harmonics`` mesh orders: ``1..H`` over a mesh cycle, every
    shaft order ``k / teeth`` up to ``H`` over a revolution."""
    if revolution:
        return np.arange(1, harmonics * teeth + 1) / teeth
    return np.arange(1, harmonics + 1, dtype=float)


def min_samples(harmonics: int, teeth: int, revolution: bool) -> int:
    """Fewest distinct samples that determine the fit: a mean, a cosine and a sine per order."""
    return 2 * len(fit_orders(harmonics, teeth, revolution)) + 1


def largest_gap(phi, period: float) -> tuple[float, float]:
    """The longest stretch of the ``period`` (mesh cycles) without a sample, round the end of the
    period too, and the phase it starts after."""
    p = np.sort(np.mod(np.asarray(phi, dtype=float), period))
    gaps = np.diff(np.append(p, p[0] + period))
    i = int(np.argmax(gaps))
    return float(gaps[i]), float(p[i])


def positive_minimum(mean: float, harmonics, period: float = 1.0) -> tuple[float, float]:
    """The least value of ``series(mean, harmonics)`` over a ``period`` (mesh cycles) and the
    phase where it is; where ``mean - sum |a_n|`` is positive, that bound instead (phase NaN):
    the series cannot go below it, and a caller asking whether the series stays positive needs
    no more.

    Else a grid of 64 points per wave of the highest order (at most 2^16 points: a cycle of
    many mesh periods with high orders is sampled more coarsely), then the lowest grid points
    refined by a bounded scalar minimisation between their neighbours (a dip between two grid
    points was missed: k0 1000 kN/mm with a 1001 kN/mm harmonic phased by 2.8 deg went below
    zero unseen; a grid alone over a long cycle took gigabytes)."""
    harmonics = tuple(harmonics)
    bound = float(mean) - sum(abs(h.amplitude) for h in harmonics)
    if bound > 0 or not harmonics:
        return bound, math.nan
    from scipy.optimize import minimize_scalar

    top = max(h.order for h in harmonics)
    n = int(min(64 * max(top, 1.0) * period, 2**16))
    phi = np.linspace(0.0, period, n + 1)
    k = series(mean, harmonics, phi)
    step = period / n
    best = (float(k.min()), float(phi[int(np.argmin(k))]))
    for i in np.argsort(k)[:8]:  # the lowest grid points: each a dip's neighbourhood
        res = minimize_scalar(lambda x: float(series(mean, harmonics, x)), method="bounded",
                              bounds=(phi[i] - step, phi[i] + step),
                              options={"xatol": 1e-12 * max(period, 1.0)})
        if res.fun < best[0]:
            best = (float(res.fun), float(res.x) % period)
    return best


def _least(low: float, where: float, phi, stiffness) -> str:
    """Where a stiffness is not positive: the least value of its series and the mesh phase of
    it, or where that is the mean alone (constant stiffness: ``positive_minimum`` gives no
    phase), the mean and the least sample and its mesh phase ("at mesh phase nan" was said: an
    outside tester)."""
    if not math.isnan(where):
        return f"{low:.4g} N/m at mesh phase {where:.3g}"
    k = np.asarray(stiffness, dtype=float)
    i = int(np.argmin(k))
    return (f"a mean of {low:.4g} N/m; the least sample {k[i]:.4g} N/m at mesh phase"
            f" {float(np.asarray(phi, dtype=float)[i]):.3g}")


def fit_fourier(phi, values, orders) -> FourierFit:
    """Least-squares fit of ``values`` sampled at mesh phases ``phi`` with Eq. (1) at ``orders``.

    Parameters
    ----------
    phi : ndarray (N,)
        Mesh phase of each sample [mesh cycles]; any spacing, any offset.
    values : ndarray (N,)
        The samples [any unit].
    orders : ndarray (M,)
        Mesh orders fitted (> 0).

    Returns
    -------
    FourierFit
        Mean, one ``Harmonic`` per order (amplitude >= 0, phase in (-pi, pi]) and the residual.

    Raises
    ------
    FitError
        Fewer than ``2 M + 1`` distinct samples, or samples that do not tell the orders apart
        (bunched in a part of the period).
    """
    phi = np.asarray(phi, dtype=float)
    x = np.asarray(values, dtype=float)
    orders = np.asarray(orders, dtype=float)
    need = 2 * orders.size + 1
    distinct = np.unique(np.round(phi, 12)).size
    if distinct < need:
        raise FitError(f"{orders.size} harmonics need at least {need} distinct samples,"
                       f" there are {distinct}")
    gap, after = largest_gap(phi, 1.0 / orders.min())
    if gap > 1.0 / orders.max():  # no sample within a whole wave of the highest order: the fit
        raise FitError(  # there is an extrapolation (mean stiffness fitted negative, found so)
            f"the samples leave {gap:.3g} mesh cycles empty after phase {after:.3g}, more than"
            f" one wave of the highest order fitted ({1.0 / orders.max():.3g}): spread them over"
            " the whole period, or fit fewer harmonics")
    arg = 2.0 * math.pi * phi[:, None] * orders[None, :]
    a = np.concatenate([np.ones((phi.size, 1)), np.cos(arg), np.sin(arg)], axis=1)
    # Columns scaled to unit norm: the rank test is then about the samples' spread, not units.
    norm = np.linalg.norm(a, axis=0)
    coef, _, rank, sv = np.linalg.lstsq(a / norm, x, rcond=None)
    if rank < a.shape[1] or sv[-1] < 1e-8 * sv[0]:
        raise FitError(f"the samples do not determine {orders.size} harmonics (spread them over"
                       " the whole period)")
    coef = coef / norm
    m = orders.size
    c, s = coef[1:m + 1], coef[m + 1:]
    # a cos(t + p) = a cos(p) cos(t) - a sin(p) sin(t)
    amp, phase = np.hypot(c, s), np.arctan2(-s, c)
    harmonics = tuple(Harmonic(float(amp[i]), float(orders[i]), float(phase[i])) for i in range(m))
    resid = x - a @ coef
    return FourierFit(float(coef[0]), harmonics, float(np.sqrt(np.mean(resid**2))),
                      float(np.max(np.abs(resid))), int(phi.size))


@dataclass(frozen=True)
class MeasuredExcitation:
    """What measured STE and stiffness samples give the dynamic model (SI units)."""

    stiffness: float | None
    """k0 [N/m] from the samples (None: the file has no stiffness)."""
    stiffness_harmonics: tuple[Harmonic, ...]
    """k_n [N/m] for a scene with k(t); empty with constant stiffness or no stiffness samples."""
    ste_harmonics: tuple[Harmonic, ...]
    """The excitation e(t) the kernel uses [m] (empty: the file has no STE)."""
    stiffness_fit: FourierFit | None
    """The fit of the stiffness samples [N/m] (residual: samples - fitted series)."""
    excitation_fit: FourierFit | None
    """The fit of e = STE - F_m / k (or of the STE with constant stiffness) [m]."""
    ste_residual_rms: float
    """rms of measured STE - the STE the model holds quasi-statically (F_m / k(phi) + e(phi)
    with k(t), e(phi) + mean with constant stiffness) at the samples [m]; NaN without STE."""
    ste_residual_max: float
    """Largest |measured STE - model's quasi-static STE| [m]; NaN without STE."""
    source: str = "samples"
    """Where the harmonics come from: ``"samples"`` (fitted to them by least squares, the DFT
    of evenly spaced ones) or ``"integrated"`` (a mesh study's own, integrated between the
    breaks of its mesh cycle: ``integrated_excitation``)."""


def measured_excitation(phi, ste, stiffness, orders, *, time_varying: bool, mean_force: float,
                        k_mean: float | None = None, k_harmonics=()) -> MeasuredExcitation:
    """k0, k_n and e_n from samples of the loaded STE and/or the mesh stiffness.

    Parameters
    ----------
    phi : ndarray (N,)
        Mesh phase of each sample [mesh cycles].
    ste : ndarray (N,) or None
        Loaded static transmission error at the scene's mean load [m].
    stiffness : ndarray (N,) or None
        Mesh stiffness [N/m].
    orders : ndarray
        Mesh orders fitted (``fit_orders``).
    time_varying : bool
        The scene has k(t) (whine, full): e = STE - F_m / k; else (rattle) e = STE.
    mean_force : float
        Mean mesh force F_m [N] of the scene.
    k_mean, k_harmonics
        The scene's own k0 [N/m] and k_n when the samples hold no stiffness.

    Raises
    ------
    FitError
        Too few samples, or a stiffness sample that is not positive where e = STE - F_m / k.
    """
    phi = np.asarray(phi, dtype=float)
    k_fit = fit_fourier(phi, stiffness, orders) if stiffness is not None else None
    if k_fit is not None:
        low, where = positive_minimum(k_fit.mean, k_fit.harmonics if time_varying else (),
                                      1.0 / np.min(orders))
        if not low > 0:
            least = _least(low, where, phi, stiffness)
            raise FitError(f"the fitted mesh stiffness is not positive ({least}): check the"
                           " samples and their unit")
    k0 = k_fit.mean if k_fit is not None else None
    k_h = k_fit.harmonics if (k_fit is not None and time_varying) else ()
    e_fit, rms, mx = None, math.nan, math.nan
    if ste is not None:
        ste = np.asarray(ste, dtype=float)
        if time_varying and mean_force:
            if stiffness is not None:
                k_at = np.asarray(stiffness, dtype=float)
                k_model = k_fit(phi)
            else:
                k_at = k_model = series(k_mean, k_harmonics, phi)
            if np.any(~(k_at > 0)) or np.any(~(k_model > 0)):
                raise FitError("the mesh stiffness must be positive at every sample")
            e_fit = fit_fourier(phi, ste - mean_force / k_at, orders)
            model_ste = mean_force / k_model + e_fit(phi)
        else:
            e_fit = fit_fourier(phi, ste, orders)
            model_ste = e_fit(phi)
        resid = ste - model_ste
        rms, mx = float(np.sqrt(np.mean(resid**2))), float(np.max(np.abs(resid)))
    return MeasuredExcitation(
        stiffness=k0, stiffness_harmonics=k_h,
        ste_harmonics=e_fit.harmonics if e_fit is not None else (),
        stiffness_fit=k_fit, excitation_fit=e_fit, ste_residual_rms=rms, ste_residual_max=mx)


def _series_of(amplitude, phase, harmonics: int) -> tuple[float, tuple[Harmonic, ...]]:
    """The mean and ``Harmonic`` s 1..``harmonics`` of Eq. (1) coefficients over orders 0..H
    (``a[0] cos(phase[0])`` the mean: its phase is 0 or pi)."""
    amplitude, phase = np.asarray(amplitude, dtype=float), np.asarray(phase, dtype=float)
    return (float(amplitude[0] * math.cos(phase[0])),
            tuple(Harmonic(float(amplitude[n]), float(n), float(phase[n]))
                  for n in range(1, harmonics + 1)))


def _held(phi, values, mean: float, harmonics: tuple[Harmonic, ...]) -> FourierFit:
    """A series given (not fitted) and how far the samples are from it."""
    resid = np.asarray(values, dtype=float) - series(mean, harmonics, phi)
    return FourierFit(mean, harmonics, float(np.sqrt(np.mean(resid**2))),
                      float(np.max(np.abs(resid))), int(np.size(phi)))


def integrated_excitation(phi, ste, stiffness, k, ste_series, e_series, harmonics: int, *,
                          time_varying: bool, mean_force: float) -> MeasuredExcitation:
    """k0, k_n and e_n from harmonics integrated over a mesh cycle (a mesh study's result:
    ``gearsweep.gear.mesh.Quadrature``), with the samples beside them only for the residuals.

    The DFT of uniform samples is off by O(1/N) where k jumps (a pair enters or leaves contact);
    the integrated harmonics are the gear scene's own, so a scene fed a mesh study's result
    runs as the ``gear:`` scene of that pair and load.

    Parameters
    ----------
    phi, ste, stiffness : ndarray (N,)
        The samples [mesh cycles], [m], [N/m] (for the residuals only).
    k, ste_series : (ndarray, ndarray)
        Amplitudes and phases over orders 0..H of the mesh stiffness [N/m] and the loaded
        STE [m], [rad].
    e_series : (ndarray, ndarray) or None
        The same of ``STE - F / k`` at the file's load F [m], [rad]: e(t) with k(t).
    harmonics : int
        Orders 1..``harmonics`` kept, at most H.
    time_varying : bool
        The scene has k(t) (whine, full): e = STE - F_m / k; else (rattle) e = STE.
    mean_force : float
        Mean mesh force F_m of the scene [N] (0: e is the STE, as with samples).

    Raises
    ------
    FitError
        ``harmonics`` beyond H, e(t) with k(t) not given, or k(t) not positive.
    """
    top = min(np.size(k[0]), np.size(ste_series[0])) - 1
    if harmonics > top:
        raise FitError(f"the file holds the harmonics 0-{top} its mesh study integrated, fewer"
                       f" than the {harmonics} asked for")
    with_k = time_varying and bool(mean_force)
    if with_k and e_series is None:
        raise FitError("the file holds no e_harmonic (STE - F / k) for a scene with k(t)")
    phi = np.asarray(phi, dtype=float)
    k_fit = _held(phi, stiffness, *_series_of(*k, harmonics))
    low, where = positive_minimum(k_fit.mean, k_fit.harmonics if time_varying else ())
    if not low > 0:
        raise FitError(f"the mesh stiffness's series is not positive"
                       f" ({_least(low, where, phi, stiffness)})")
    ste = np.asarray(ste, dtype=float)
    if with_k:
        e_fit = _held(phi, ste - mean_force / stiffness, *_series_of(*e_series, harmonics))
        model_ste = mean_force / k_fit(phi) + e_fit(phi)
    else:
        e_fit = _held(phi, ste, *_series_of(*ste_series, harmonics))
        model_ste = e_fit(phi)
    resid = ste - model_ste
    return MeasuredExcitation(
        stiffness=k_fit.mean, stiffness_harmonics=k_fit.harmonics if time_varying else (),
        ste_harmonics=e_fit.harmonics, stiffness_fit=k_fit, excitation_fit=e_fit,
        ste_residual_rms=float(np.sqrt(np.mean(resid**2))),
        ste_residual_max=float(np.max(np.abs(resid))), source="integrated")
