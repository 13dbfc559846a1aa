"""Harmonic balance for the gear mesh with backlash, three ways (section 6 of the paper).

The rattle scene is Eq. (13) with constant stiffness,

    m p'' + c p' + k f(p) = F_m + F_0 cos(w t) [- m e''(t)],
    f(p) = p - clip(p, -b, b)          (dead zone of half-width b = backlash / 2, Eq. (8)),

and this module solves its periodic responses in three increasingly complete ways:

1. ``eq15_roots``: the paper's Eq. (15) (Den Hartog's graphical method), no damping and no mean
   force, ``p = p0 cos(w t)`` and the force balanced at the extreme of the cycle only:
   ``k f(p0) = F0 + m w^2 p0``. The straight line of slope ``m w^2`` through ``F0`` cuts the
   piecewise-linear spring once on each of its three pieces where the cut lies inside that piece:
   this is solved exactly, piece by piece (Fig. 9).
2. ``df_curve``: single-harmonic balance with the exact describing function of the dead zone,
   damping and mean force (the "biased" describing function: ``p = p_m + A cos(w t - phi)``, mean
   and first harmonic balanced together). The curve is parametrised by the amplitude ``A``: for
   each ``A`` the mean balance fixes ``p_m`` and the first harmonic gives a quadratic in ``w^2``,
   so every branch comes out, the unstable middle one included, with no continuation.
3. ``aft_continuation``: multi-harmonic balance by alternating frequency-time (AFT, FFT), with
   pseudo-arc-length continuation through the turning points and the stability of every solution
   from its Floquet multipliers (monodromy matrix of the linearisation, built exactly from 2x2
   matrix exponentials on a fine time grid), for Eq. (6): mean force, force harmonics, STE
   harmonics (entering as ``- m e''``) and mesh stiffness harmonics.

All quantities are SI: [m], [N], [N/m], [N s/m], [kg], angular frequencies [rad/s].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearsweep.jit import jit

# ---------------------------------------------------------------------------------------------
# the dead zone and its describing functions


def dead_zone(p: np.ndarray, half_gap: float) -> np.ndarray:
    """Backlash force law f(p) of Eq. (8) [m]: ``p - clip(p, -b, b)``."""
    p = np.asarray(p, dtype=float)
    return p - np.clip(p, -half_gap, half_gap)


def dead_zone_gain(amplitude, half_gap: float) -> np.ndarray:
    """Exact single-harmonic describing function of the centred dead zone, ``k_eq / k`` [1].

    For ``p = A cos(theta)`` the first Fourier coefficient of ``f(p)`` is ``N(A) A`` with

        N(A) = 1 - (2/pi) (asin(b/A) + (b/A) sqrt(1 - (b/A)^2))   (A > b),   0   (A <= b).

    Parameters
    ----------
    amplitude : array_like
        Amplitude A [m].
    half_gap : float
        Half the backlash b [m].
    """
    a = np.asarray(amplitude, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(a > half_gap, half_gap / np.where(a > 0, a, 1.0), 1.0)
    return 1.0 - (2.0 / np.pi) * (np.arcsin(r) + r * np.sqrt(np.maximum(1.0 - r * r, 0.0)))


def _ramp_moments(shift, amplitude, threshold):
    """Mean and first cosine coefficient of ``max(shift + A cos(theta) - threshold, 0)``."""
    a = np.maximum(amplitude, 1e-300)
    cos_c = np.clip((threshold - shift) / a, -1.0, 1.0)
    th = np.arccos(cos_c)  # the ramp is active for |theta| < th
    s = np.sin(th)
    d = shift - threshold
    mean = (d * th + amplitude * s) / np.pi
    first = (2.0 / np.pi) * (d * s + amplitude * (0.5 * th + 0.25 * np.sin(2.0 * th)))
    return mean, first


def biased_dead_zone(mean, amplitude, half_gap: float) -> tuple[np.ndarray, np.ndarray]:
    """Biased describing function of the dead zone for ``p = p_m + A cos(theta)``.

    Parameters
    ----------
    mean : array_like
        Mean displacement p_m [m].
    amplitude : array_like
        First-harmonic amplitude A >= 0 [m].
    half_gap : float
        Half the backlash b [m].

    Returns
    -------
    f0 : ndarray
        Cycle mean of f(p) [m].
    gain : ndarray
        First cosine coefficient of f(p) divided by A [1]; at A = 0 the slope f'(p_m).

    Notes
    -----
    ``f(p) = max(p - b, 0) - max(-p - b, 0)``; each ramp has a closed-form mean and first
    harmonic over the arc ``|theta| < arccos((b -/+ p_m) / A)`` where it is active.
    """
    pm = np.asarray(mean, dtype=float)
    amp = np.asarray(amplitude, dtype=float)
    m1, c1 = _ramp_moments(pm, amp, half_gap)
    m2, c2 = _ramp_moments(-pm, amp, half_gap)
    f0 = m1 - m2
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = np.where(amp > 0, (c1 + c2) / np.where(amp > 0, amp, 1.0),
                        (np.abs(pm) > half_gap).astype(float))
    return f0, gain


def mean_for_force(force_ratio, amplitude, half_gap: float, iterations: int = 200) -> np.ndarray:
    """Mean displacement p_m [m] at which the cycle mean of f equals ``force_ratio`` = F_m / k.

    The cycle mean of f is non-decreasing in p_m (strictly wherever part of the cycle is in
    contact), so bisection on ``[-b - |F_m/k| - A, b + |F_m/k| + A]`` converges to round-off.
    With ``F_m = 0`` the answer is 0 by symmetry.
    """
    fr, amp = np.broadcast_arrays(np.asarray(force_ratio, float), np.asarray(amplitude, float))
    hi = np.full(fr.shape, half_gap) + np.abs(fr) + amp + half_gap
    lo = -hi
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        f0, _g = biased_dead_zone(mid, amp, half_gap)
        above = f0 > fr
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
        if np.all(hi - lo <= 4e-16 * np.maximum(np.abs(mid), half_gap)):
            break
    out = 0.5 * (lo + hi)
    return np.where(fr == 0.0, 0.0, out)


# ---------------------------------------------------------------------------------------------
# (a) the paper's Eq. (15)


def eq15_roots(omega, force_amp: float, stiffness: float, mass: float,
               half_gap: float) -> np.ndarray:
    """Exact intersections of the paper's Eq. (15), ``k f(p0) = F0 + m w^2 p0`` (Fig. 9).

    On each piece of the spring the equation is linear in p0; a root counts only if it lies on
    its own piece.

    Parameters
    ----------
    omega : array_like
        Excitation frequency [rad/s].
    force_amp, stiffness, mass, half_gap : float
        F0 [N], k [N/m], m_eq [kg], b [m].

    Returns
    -------
    ndarray, shape omega.shape + (3,)
        p0 [m] on the pieces (p0 > b: in phase, contact on the drive flank at the extreme;
        |p0| <= b: free flight inside the gap; p0 < -b: contact on the back flank at the
        extreme); NaN where the line does not cut that piece.
    """
    w2 = np.asarray(omega, dtype=float) ** 2
    mw2 = mass * w2
    with np.errstate(divide="ignore", invalid="ignore"):
        right = (force_amp + stiffness * half_gap) / (stiffness - mw2)
        gap = -force_amp / mw2
        left = (force_amp - stiffness * half_gap) / (stiffness - mw2)
    right = np.where(right > half_gap, right, np.nan)
    gap = np.where(np.abs(gap) <= half_gap, gap, np.nan)
    left = np.where(left < -half_gap, left, np.nan)
    return np.stack([right, gap, left], axis=-1)


# ---------------------------------------------------------------------------------------------
# (b) exact describing function with damping and mean force


@dataclass(frozen=True)
class DFCurve:
    """Frequency-response curve of single-harmonic balance, ordered along the curve.

    Every array has one entry per point of the curve; the curve runs from low to high amplitude
    on its lower-frequency side and back down on its higher-frequency side, so that plotting
    ``omega`` against ``amplitude`` draws one connected line through the turning points.
    """

    amplitude: np.ndarray
    """First-harmonic amplitude A [m]."""
    omega: np.ndarray
    """Excitation frequency [rad/s]."""
    mean: np.ndarray
    """Mean displacement p_m [m]."""
    phase: np.ndarray
    """Lag phi of the response behind the force [rad]."""
    stable: np.ndarray
    """Stability of the averaged (slowly varying A, phi) equations: ``dG/dA > 0`` at fixed w."""

    @property
    def p_max(self) -> np.ndarray:
        """Largest displacement of the cycle p_m + A [m]."""
        return self.mean + self.amplitude

    @property
    def p_min(self) -> np.ndarray:
        """Smallest displacement of the cycle p_m - A [m]."""
        return self.mean - self.amplitude


def _df_balance(amplitude, omega2, mass, stiffness, damping, half_gap, force_amp, force_mean):
    """G(A, w) = A^2 ((k N1 - m w^2)^2 + c^2 w^2) - F0^2 [N^2] (zero on the curve)."""
    pm = mean_for_force(force_mean / stiffness, amplitude, half_gap)
    _f0, n1 = biased_dead_zone(pm, amplitude, half_gap)
    kn = stiffness * n1
    return amplitude**2 * ((kn - mass * omega2) ** 2 + damping**2 * omega2) - force_amp**2


def df_curve(amplitudes, *, mass: float, stiffness: float, damping: float, half_gap: float,
             force_amp: float, force_mean: float = 0.0) -> DFCurve:
    """Whole single-harmonic frequency-response curve, parametrised by the amplitude.

    Solves, with ``p = p_m + A cos(w t - phi)`` and the biased describing function
    (``f0``, ``N1``) of ``biased_dead_zone``,

        k f0(p_m, A) = F_m                                  (mean balance)
        (k N1 - m w^2) A = F0 cos(phi),  c w A = F0 sin(phi)  (first harmonic),

    i.e. ``m^2 W^2 + (c^2 - 2 k N1 m) W + k^2 N1^2 - F0^2 / A^2 = 0`` with ``W = w^2``: up to two
    frequencies per amplitude. Amplitudes with no real positive root (above the peak) are dropped.

    Parameters
    ----------
    amplitudes : array_like
        Amplitudes A to solve at [m] (sorted internally; use a fine grid, denser near b).
    mass, stiffness, damping, half_gap, force_amp, force_mean : float
        m_eq [kg], k [N/m], c [N s/m], b [m], F0 [N], F_m [N].

    Returns
    -------
    DFCurve
    """
    a = np.unique(np.asarray(amplitudes, dtype=float))
    a = a[a > 0]
    pm = mean_for_force(force_mean / stiffness, a, half_gap)
    _f0, n1 = biased_dead_zone(pm, a, half_gap)
    kn = stiffness * n1
    bq = damping**2 - 2.0 * kn * mass
    cq = kn**2 - (force_amp / a) ** 2
    disc = bq * bq - 4.0 * mass**2 * cq
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0.0))
    w2_lo = (-bq - sq) / (2.0 * mass**2)
    w2_hi = (-bq + sq) / (2.0 * mass**2)
    lo_ok = ok & (w2_lo > 0)
    hi_ok = ok & (w2_hi > 0)
    amp = np.concatenate([a[lo_ok], a[hi_ok][::-1]])
    w2 = np.concatenate([w2_lo[lo_ok], w2_hi[hi_ok][::-1]])
    mean = np.concatenate([pm[lo_ok], pm[hi_ok][::-1]])
    knn = np.concatenate([kn[lo_ok], kn[hi_ok][::-1]])
    omega = np.sqrt(w2)
    phase = np.arctan2(damping * omega * amp, (knn - mass * w2) * amp)
    # stability of the slow flow: the amplitude relation G(A) must increase through its root
    da = 1e-7 * amp
    args = (mass, stiffness, damping, half_gap, force_amp, force_mean)
    dg = _df_balance(amp + da, w2, *args) - _df_balance(amp - da, w2, *args)
    return DFCurve(amplitude=amp, omega=omega, mean=mean, phase=phase, stable=dg > 0)


def df_solutions(omega: float, *, mass: float, stiffness: float, damping: float,
                 half_gap: float, force_amp: float, force_mean: float = 0.0,
                 amplitude_max: float | None = None, n_grid: int = 4000
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Every single-harmonic amplitude at one frequency, with its stability.

    Roots of ``G(A) = A^2 ((k N1 - m w^2)^2 + c^2 w^2) - F0^2`` (see ``df_curve``), bracketed on a
    grid of ``n_grid`` amplitudes up to ``amplitude_max`` (default ``F0 / (c w) + 2 b``, above
    which G > 0 because c w A <= F0 on the curve) and refined with Brent's method to round-off.

    Returns
    -------
    amplitudes : ndarray
        A [m], increasing.
    stable : ndarray of bool
        ``dG/dA > 0`` (the averaged equations are stable).
    """
    from scipy.optimize import brentq

    w2 = float(omega) ** 2
    args = (mass, stiffness, damping, half_gap, force_amp, force_mean)
    if amplitude_max is None and damping <= 0:
        raise ValueError("without damping give amplitude_max (the amplitude is unbounded)")
    top = amplitude_max or force_amp / (damping * float(omega)) + 2.0 * half_gap
    grid = np.r_[np.linspace(1e-6 * half_gap, half_gap, n_grid // 4),
                 half_gap * (1.0 + np.geomspace(1e-9, top / half_gap, n_grid))]
    g = _df_balance(grid, w2, *args)
    roots, stable = [], []
    for i in np.nonzero(np.sign(g[:-1]) != np.sign(g[1:]))[0]:
        a = brentq(lambda x: float(_df_balance(x, w2, *args)), grid[i], grid[i + 1],
                   xtol=1e-16, rtol=1e-14)
        roots.append(a)
        stable.append(g[i + 1] > g[i])
    return np.asarray(roots), np.asarray(stable, dtype=bool)


def turning_points(curve_omega: np.ndarray, curve_amp: np.ndarray) -> np.ndarray:
    """Frequencies [rad/s] where a curve ordered along its arc turns back (``dw`` changes sign),
    refined by a parabola through the three points around each turn."""
    w = np.asarray(curve_omega, float)
    dw = np.diff(w)
    idx = np.nonzero(dw[:-1] * dw[1:] < 0)[0] + 1
    out = []
    for i in idx:
        s = np.arange(i - 1, i + 2)
        x = np.asarray(curve_amp, float)[s]
        coef = np.polyfit(x - x[1], w[s], 2)
        if coef[0] != 0:
            xv = -coef[1] / (2 * coef[0])
            out.append(np.polyval(coef, xv) if abs(xv) <= abs(x[2] - x[0]) else w[i])
        else:
            out.append(w[i])
    return np.asarray(out)


# ---------------------------------------------------------------------------------------------
# (c) multi-harmonic balance (AFT) with arc-length continuation and Floquet stability


@dataclass(frozen=True)
class MeshSystem:
    """Eq. (6) with harmonic inputs, all periodic in the base angle ``theta = w t``.

    ``w`` is the base angular frequency (the mesh frequency when STE or stiffness harmonics are
    present); harmonic ``n`` of an input ``z_n`` (complex) is ``Re(z_n exp(i n theta))``, i.e.
    amplitude ``|z_n|`` and phase ``angle(z_n)`` in the paper's Eq. (1) convention.
    """

    mass: float
    """Equivalent mass m_eq [kg]."""
    stiffness: float
    """Mean mesh stiffness k0 [N/m]."""
    damping: float
    """Viscous mesh damping c [N s/m]."""
    half_gap: float | None
    """Half the backlash b [m]; None: no backlash, f(p) = p."""
    force_mean: float = 0.0
    """Mean force F_m [N]."""
    force_harmonics: tuple[complex, ...] = ()
    """External force harmonics F_n, n = 1, 2, ... [N] (torque fluctuation)."""
    ste_harmonics: tuple[complex, ...] = ()
    """Static transmission error harmonics e_n [m]; they enter as ``- m e''``."""
    stiffness_harmonics: tuple[complex, ...] = ()
    """Mesh stiffness harmonics k_n [N/m]."""


@dataclass(frozen=True)
class HBBranch:
    """Solutions along a continued branch of multi-harmonic balance."""

    omega: np.ndarray
    """Base angular frequency [rad/s], shape (n,)."""
    coefficients: np.ndarray
    """Fourier coefficients ``[a0, a1, b1, a2, b2, ...]`` of p [m], shape (n, 2H + 1)."""
    p_max: np.ndarray
    """Largest displacement over a period [m]."""
    p_min: np.ndarray
    """Smallest displacement over a period [m]."""
    multiplier: np.ndarray
    """Largest Floquet multiplier modulus [1]."""
    stable: np.ndarray
    """``multiplier < 1``."""
    ended: str = "end"
    """Why the continuation stopped: ``"end"`` (omega passed ``omega_end``), ``"max_points"``
    or ``"min_step"`` (the corrector failed at the smallest step): the branch is then shorter
    than asked for (it stopped with no word of it; an outside tester's finding)."""

    @property
    def complete(self) -> bool:
        """Whether the branch reaches the ``omega_end`` it was asked for."""
        return self.ended == "end"

    @property
    def amplitude(self) -> np.ndarray:
        """Half the peak-to-peak displacement [m]."""
        return 0.5 * (self.p_max - self.p_min)


AFT_SAMPLES_PER_HARMONIC = 4
"""``AFTBalance`` takes at least this many time samples per harmonic (``n_time >= 4 H``): its
FFT projection then equals the matrix product exactly (``_weighted``), up to round-off."""


class AFTBalance:
    """Residual and Jacobian of multi-harmonic balance by alternating frequency-time.

    p(theta) = a0 + sum_{n=1..H} (a_n cos n theta + b_n sin n theta); the linear terms are
    balanced in the frequency domain, the nonlinear mesh force ``k(theta) f(p)`` is evaluated on
    ``n_time`` equally spaced angles and projected back with the FFT.

    Parameters
    ----------
    system : MeshSystem
    harmonics : int
        Number of harmonics H.
    n_time : int
        Time samples per period (at least 4 H; more resolves the kinks of the dead zone better).
    """

    def __init__(self, system: MeshSystem, harmonics: int = 20, n_time: int = 1024) -> None:
        if n_time < AFT_SAMPLES_PER_HARMONIC * harmonics:
            raise ValueError(f"n_time must be at least {AFT_SAMPLES_PER_HARMONIC} * harmonics")
        self.system = system
        self.H = int(harmonics)
        self.N = int(n_time)
        self.theta = 2.0 * np.pi * np.arange(self.N) / self.N
        n = np.arange(1, self.H + 1)
        cos = np.cos(np.outer(self.theta, n))
        sin = np.sin(np.outer(self.theta, n))
        E = np.empty((self.N, 2 * self.H + 1))
        E[:, 0] = 1.0
        E[:, 1::2] = cos
        E[:, 2::2] = sin
        self.E = E
        P = E.T * (2.0 / self.N)
        P[0] /= 2.0
        self.P = P
        self.k_theta = system.stiffness + self._series(system.stiffness_harmonics)
        self._n = n

    def _series(self, harmonics) -> np.ndarray:
        out = np.zeros(self.N)
        for j, z in enumerate(harmonics, start=1):
            out += np.real(complex(z) * np.exp(1j * j * self.theta))
        return out

    def _coef(self, harmonics) -> np.ndarray:
        """Cos/sin coefficients of ``sum Re(z_n e^{i n theta})`` up to H."""
        out = np.zeros(2 * self.H + 1)
        for j, z in enumerate(harmonics[: self.H], start=1):
            out[2 * j - 1] = np.real(z)
            out[2 * j] = -np.imag(z)
        return out

    def forcing(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Coefficients of the right-hand side [N] and their derivative in omega [N s/rad]."""
        s = self.system
        nn = np.zeros(2 * self.H + 1)
        nn[1::2] = self._n
        nn[2::2] = self._n
        ste = self._coef(s.ste_harmonics)
        f = self._coef(s.force_harmonics) + s.mass * omega**2 * nn**2 * ste
        f[0] += s.force_mean
        return f, 2.0 * s.mass * omega * nn**2 * ste

    def linear(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Matrix of the inertia and damping terms [N/m] and its omega-derivative."""
        s = self.system
        size = 2 * self.H + 1
        L = np.zeros((size, size))
        dL = np.zeros((size, size))
        for n in self._n:
            i, j = 2 * n - 1, 2 * n
            L[i, i] = L[j, j] = -s.mass * n * n * omega**2
            L[i, j] = s.damping * n * omega
            L[j, i] = -s.damping * n * omega
            dL[i, i] = dL[j, j] = -2.0 * s.mass * n * n * omega
            dL[i, j] = s.damping * n
            dL[j, i] = -s.damping * n
        return L, dL

    def signal(self, coefficients: np.ndarray) -> np.ndarray:
        """p at the ``n_time`` angles of one period [m]."""
        return self.E @ coefficients

    def nonlinear(self, coefficients: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coefficients of ``k(theta) f(p)`` [N] (by FFT) and their Jacobian [N/m]."""
        p = self.signal(coefficients)
        b = self.system.half_gap
        if b is None:
            fp, slope = p, np.ones_like(p)
        else:
            fp = dead_zone(p, b)
            slope = (np.abs(p) > b).astype(float)
        g = self.k_theta * fp
        spec = np.fft.rfft(g) / self.N
        out = np.empty(2 * self.H + 1)
        out[0] = spec[0].real
        out[1::2] = 2.0 * spec[1 : self.H + 1].real
        out[2::2] = -2.0 * spec[1 : self.H + 1].imag
        return out, self._weighted_jacobian(self.k_theta * slope)

    def _weighted_jacobian(self, weight: np.ndarray) -> np.ndarray:
        """``P diag(weight) E`` from the FFT of ``weight``, O(H^2) instead of O(N H^2).

        With ``c_k`` the complex Fourier coefficients of the weight, the product with
        ``cos m theta`` has coefficient ``(c_{n-m} + c_{n+m}) / 2`` at ``e^{i n theta}`` and the
        product with ``sin m theta`` has ``(c_{n-m} - c_{n+m}) / (2 i)``; on the discrete grid
        (``n_time >= 4 H``) this equals the matrix product exactly, up to round-off.
        """
        H = self.H
        c = np.fft.rfft(weight)[: 2 * H + 1] / self.N
        k = np.arange(-2 * H, 2 * H + 1)
        full = np.where(k >= 0, c[np.abs(k)], np.conj(c[np.abs(k)]))  # c_k, k = -2H..2H
        n = np.arange(H + 1)[:, None]
        m = np.arange(1, H + 1)[None, :]
        lo = full[n - m + 2 * H]
        hi = full[n + m + 2 * H]
        g = np.empty((H + 1, 2 * H + 1), dtype=complex)
        g[:, 0] = full[np.arange(H + 1) + 2 * H]
        g[:, 1::2] = 0.5 * (lo + hi)
        g[:, 2::2] = (lo - hi) / 2j
        jac = np.empty((2 * H + 1, 2 * H + 1))
        jac[0] = g[0].real
        jac[1::2] = 2.0 * g[1:].real
        jac[2::2] = -2.0 * g[1:].imag
        return jac

    def residual(self, coefficients: np.ndarray, omega: float):
        """Residual [N], its Jacobian in the coefficients [N/m] and in omega [N s/rad]."""
        L, dL = self.linear(omega)
        g, jg = self.nonlinear(coefficients)
        f, df = self.forcing(omega)
        return L @ coefficients + g - f, L + jg, dL @ coefficients - df

    def solve(self, omega: float, guess: np.ndarray, tol: float = 1e-10,
              max_iter: int = 50) -> np.ndarray:
        """Newton's method at fixed omega; tolerance on the residual relative to the largest
        forcing coefficient [N]."""
        x = np.array(guess, dtype=float)
        scale = max(np.max(np.abs(self.forcing(omega)[0])), 1e-300)
        r, j, _dw = self.residual(x, omega)
        for _ in range(max_iter):
            if np.max(np.abs(r)) < tol * scale:
                return x
            dx = np.linalg.solve(j, r)
            # backtracking: the dead zone makes the residual only piecewise smooth
            lam, norm0 = 1.0, np.linalg.norm(r)
            while True:
                xn = x - lam * dx
                rn, jn, _dw = self.residual(xn, omega)
                if np.linalg.norm(rn) < (1.0 - 0.25 * lam) * norm0 or lam < 1e-3:
                    break
                lam *= 0.5
            x, r, j = xn, rn, jn
        raise RuntimeError(f"harmonic balance did not converge at omega = {omega:.6g} rad/s")

    def monodromy_multiplier(self, coefficients: np.ndarray, omega: float,
                             n_fine: int = 4096) -> float:
        """Largest Floquet multiplier modulus of the solution [1] (see ``floquet_multipliers``)."""
        return float(np.max(np.abs(self.floquet_multipliers(coefficients, omega, n_fine))))

    def floquet_multipliers(self, coefficients: np.ndarray, omega: float,
                            n_fine: int = 4096) -> np.ndarray:
        """Both Floquet multipliers of the solution (complex) [1].

        The linearisation ``y'' + (c/m) y' + (k(theta)/m) f'(p(theta)) y = 0`` has piecewise
        constant coefficients between the angles where p crosses +/- b; on a grid of ``n_fine``
        intervals p is interpolated linearly, each interval is split at its crossings and every
        piece contributes its exact 2x2 matrix exponential. f is continuous, so no saltation
        matrix is needed at the crossings.
        """
        th = 2.0 * np.pi * np.arange(n_fine + 1) / n_fine
        n = np.arange(1, self.H + 1)
        p = coefficients[0] + np.cos(np.outer(th, n)) @ coefficients[1::2] + \
            np.sin(np.outer(th, n)) @ coefficients[2::2]
        thm = 0.5 * (th[1:] + th[:-1])
        kt = self.system.stiffness + np.zeros(n_fine)
        for j, z in enumerate(self.system.stiffness_harmonics, start=1):
            kt = kt + np.real(complex(z) * np.exp(1j * j * thm))
        s = self.system
        b = np.inf if s.half_gap is None else s.half_gap
        if s.half_gap is None:
            b = -1.0  # every sample "in contact": f' = 1
        M = _monodromy(p, kt / s.mass, s.damping / s.mass, b, 2.0 * np.pi / omega / n_fine)
        tr = M[0, 0] + M[1, 1]
        det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
        disc = complex(tr * tr - 4.0 * det)
        return np.array([(tr + np.sqrt(disc)) / 2.0, (tr - np.sqrt(disc)) / 2.0])


@jit
def _expm_companion(kappa, gamma, t, out):
    """exp(A t) for A = [[0, 1], [-kappa, -gamma]] (closed form), written into out (2x2)."""
    s = -0.5 * gamma
    q2 = s * s - kappa
    if q2 > 0.0:
        q = np.sqrt(q2)
        ch = np.cosh(q * t)
        sh = np.sinh(q * t) / q
    elif q2 < 0.0:
        q = np.sqrt(-q2)
        ch = np.cos(q * t)
        sh = np.sin(q * t) / q
    else:
        ch = 1.0
        sh = t
    e = np.exp(s * t)
    out[0, 0] = e * (ch - s * sh)
    out[0, 1] = e * sh
    out[1, 0] = -e * kappa * sh
    out[1, 1] = e * (ch + (-gamma - s) * sh)


MONODROMY_COLD_COMPILE_SECONDS = 5.0
"""One-time compile of ``_monodromy`` (the Floquet multipliers of a branch point) on a cold
Numba cache [s]: 3.6-4.1 s in a process that only compiles it, 3.9 s of the first run of
studies/fig08_rattle_balance.yaml (``scripts/bench_compile.py``; this 2-core machine beside other
jobs, load 5, 27 Nov 2026). ``analysis_cost`` adds it where the cache lacks it."""

MONODROMY_COLD_COMPILE_BYTES = 100e6
"""... and what it adds to the peak resident memory [bytes]: +90 MB in a process that only
compiles it (101 -> 191 MB), +51 MB on the study's run (308 MB on a fresh cache, 257 MB on the
cache it filled)."""

MONODROMY_CALL = (np.zeros(2), np.zeros(1), 0.0, 0.0, 1.0)
"""Arguments of ``_monodromy`` of the types ``MeshSystem.floquet_multipliers`` passes (what
``analysis_cost`` asks Numba's cache for)."""


@jit
def _monodromy(p, kappa, gamma, b, dt):
    """Product of the exact transfer matrices of the pieces of every grid interval."""
    M = np.eye(2)
    T = np.empty((2, 2))
    cuts = np.empty(4)
    n = kappa.shape[0]
    for i in range(n):
        p0 = p[i]
        p1 = p[i + 1]
        m = 0
        cuts[m] = 0.0
        m += 1
        if b >= 0.0:
            for lev in (b, -b):
                if (p0 - lev) * (p1 - lev) < 0.0:
                    cuts[m] = (lev - p0) / (p1 - p0)
                    m += 1
        cuts[m] = 1.0
        m += 1
        c = np.sort(cuts[:m])
        for j in range(m - 1):
            f0 = c[j]
            f1 = c[j + 1]
            if f1 <= f0:
                continue
            pm = p0 + 0.5 * (f0 + f1) * (p1 - p0)
            slope = 1.0 if (b < 0.0 or abs(pm) > b) else 0.0
            _expm_companion(kappa[i] * slope, gamma, (f1 - f0) * dt, T)
            M = T @ M
    return M


def aft_continuation(system: MeshSystem, omega_start: float, omega_end: float, *,
                     guess: np.ndarray | None = None, harmonics: int = 20, n_time: int = 1024,
                     step: float = 0.005, max_step: float = 0.01, min_step: float = 1e-6,
                     max_points: int = 2000, length: float | None = None) -> HBBranch:
    """Follow the periodic solutions of ``system`` from ``omega_start`` to ``omega_end``.

    Pseudo-arc-length continuation in the scaled unknowns ``(coefficients / length,
    omega / sqrt(k0 / m))``: tangent predictor, Newton corrector on the residual bordered with the
    arc-length condition, step halved on failure and grown after easy corrections. The branch
    turns at folds, so omega need not be monotonic; the run ends when omega passes
    ``omega_end`` or after ``max_points`` solutions, or where the corrector fails at
    ``min_step`` (``HBBranch.ended`` says which; ``complete``: the first).

    Parameters
    ----------
    system : MeshSystem
    omega_start, omega_end : float
        Base angular frequency range [rad/s].
    guess : ndarray, optional
        Coefficients [m] to start Newton from at ``omega_start``; default: the linear response
        with the teeth in contact (no backlash).
    harmonics, n_time : int
        See ``AFTBalance``.
    step, max_step, min_step : float
        Arc-length steps in the scaled unknowns.
    max_points : int
    length : float, optional
        Length scale of the coefficients [m]; default the half gap (or F_m / k0 without one).
    """
    bal = AFTBalance(system, harmonics, n_time)
    k0, m = system.stiffness, system.mass
    w0 = np.sqrt(k0 / m)
    ell = length or system.half_gap or max(abs(system.force_mean) / k0, 1e-9)
    scale_r = k0 * ell
    if guess is None:
        lin = AFTBalance(MeshSystem(**{**system.__dict__, "half_gap": None}), harmonics, n_time)
        guess = lin.solve(omega_start, np.zeros(2 * harmonics + 1))
        if system.half_gap is not None:
            guess = guess + np.sign(system.force_mean or 1.0) * system.half_gap * np.eye(
                2 * harmonics + 1)[0]
    x = bal.solve(omega_start, guess)
    y = np.concatenate([x / ell, [omega_start / w0]])
    size = y.size
    direction = np.sign(omega_end - omega_start)

    def sys(yy):
        r, jx, jw = bal.residual(yy[:-1] * ell, yy[-1] * w0)
        J = np.empty((size - 1, size))
        J[:, :-1] = jx * ell / scale_r
        J[:, -1] = jw * w0 / scale_r
        return r / scale_r, J

    def tangent(J, prev):
        A = np.vstack([J, prev])
        rhs = np.zeros(size)
        rhs[-1] = 1.0
        t = np.linalg.solve(A, rhs)
        t /= np.linalg.norm(t)
        return t if t @ prev > 0 else -t

    _r, J = sys(y)
    e_w = np.zeros(size)
    e_w[-1] = direction
    t = tangent(J, e_w)
    ys = [y.copy()]
    h = step
    ended = "max_points"
    while len(ys) < max_points:
        pred = y + h * t
        yn = pred.copy()
        ok = False
        it = 0
        while it < 12:
            r, J = sys(yn)
            F = np.concatenate([r, [t @ (yn - pred)]])
            if np.max(np.abs(F)) < 1e-10:
                ok = True
                break
            yn = yn - np.linalg.solve(np.vstack([J, t]), F)
            it += 1
        if not ok:
            h *= 0.5
            if h < min_step:
                ended = "min_step"
                break
            continue
        t = tangent(J, t)
        y = yn
        ys.append(y.copy())
        if it <= 3:
            h = min(1.3 * h, max_step)
        if direction * (y[-1] * w0 - omega_end) > 0:
            ended = "end"
            break
    ys = np.asarray(ys)
    coef = ys[:, :-1] * ell
    omega = ys[:, -1] * w0
    sig = coef @ bal.E.T
    mult = np.array([bal.monodromy_multiplier(cf, w) for cf, w in zip(coef, omega, strict=True)])
    return HBBranch(omega=omega, coefficients=coef, p_max=sig.max(axis=1), p_min=sig.min(axis=1),
                    multiplier=mult, stable=mult < 1.0, ended=ended)
