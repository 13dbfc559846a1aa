"""Rattle provenance: the Fig. 8 fit, the distance of Eq. (15) from the integration, the
excitation a jump needs and what the gear pair supplies (paper section 6).

Pure numerics on plain arrays (SI units, speeds in rpm where named so): no study, no xarray.

* ``fit_turning_points``: the damping c and force amplitude F0 that put the describing
  function's turning points (``hb.df_curve``) at two target frequencies: how the Fig. 8 scene's
  c and F0 were chosen (a fit, not a prediction).
* ``eq15_distance``: how far the paper's analytical points (o, Eq. (15)) lie from the
  integration (*) on the same speeds, branch by branch.
* ``excitation_budget``: the force amplitudes the gear pair itself can supply at the mesh
  frequency (``k e_n``, ``m w^2 e_n``, the mean force) beside the one Fig. 8 needs.
* ``opening_force``, ``first_harmonic_opening``: the harmonic force that opens the mesh at each
  frequency (linear response), and the band of frequencies where the first STE harmonic's
  ``m w^2 e_1`` reaches it; ``contact_loss_threshold`` is its least value, at resonance only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearsweep.analysis import hb


def _amplitude_grid(half_gap: float, top: float = 3.0) -> np.ndarray:
    return np.unique(np.r_[np.linspace(0.005, 0.9999, 300) * half_gap,
                           half_gap * (1.0 + np.geomspace(1e-8, top, 4000))])


def df_turning_points(*, mass: float, stiffness: float, damping: float, half_gap: float,
                      force_amp: float, force_mean: float) -> np.ndarray:
    """Turning points of the describing-function curve [rad/s], sorted (empty: no fold)."""
    cv = hb.df_curve(_amplitude_grid(half_gap), mass=mass, stiffness=stiffness, damping=damping,
                     half_gap=half_gap, force_amp=force_amp, force_mean=force_mean)
    return np.sort(hb.turning_points(cv.omega, cv.amplitude))


def fit_turning_points(targets, *, mass: float, stiffness: float, half_gap: float,
                       force_mean: float, guess=(4.9e3, 72e3)) -> tuple[float, float]:
    """Damping c [N s/m] and force amplitude F0 [N] whose describing-function turning points
    are ``targets`` = (run-down rise, run-up drop) [rad/s].

    Solved by Newton's method on the two turning points (finite-difference Jacobian in the log
    of c and F0). Raises ``RuntimeError`` if it does not converge to 1e-6 of the targets.
    """
    target = np.sort(np.asarray(targets, float))
    x = np.log(np.asarray(guess, float))

    def resid(x):
        tp = df_turning_points(mass=mass, stiffness=stiffness, damping=math.exp(x[0]),
                               half_gap=half_gap, force_amp=math.exp(x[1]),
                               force_mean=force_mean)
        if tp.size != 2:
            raise RuntimeError(f"{tp.size} turning points at c = {math.exp(x[0]):.4g},"
                               f" F0 = {math.exp(x[1]):.4g}: no hysteresis loop to fit")
        return tp / target - 1.0

    for _ in range(30):
        r = resid(x)
        if np.max(np.abs(r)) < 1e-6:
            return float(math.exp(x[0])), float(math.exp(x[1]))
        jac = np.empty((2, 2))
        for j in range(2):
            dx = np.zeros(2)
            dx[j] = 1e-5
            jac[:, j] = (resid(x + dx) - r) / 1e-5
        x = x - np.linalg.solve(jac, r)
    raise RuntimeError("fit_turning_points did not converge")


@dataclass(frozen=True)
class Eq15Distance:
    """How far Eq. (15)'s points lie from the integration at the same speeds."""

    speed: np.ndarray
    """Speeds where both exist [rpm]."""
    eq15: np.ndarray
    """|p0| of the Eq. (15) root nearest the integration [m] (NaN where none)."""
    integration: np.ndarray
    """Integration amplitude (half peak-to-peak) [m]."""
    relative: np.ndarray
    """|eq15 - integration| / integration [1]."""
    rise_eq15: float
    """Where Eq. (15)'s run-down branch appears: w^2 = F0 / (m b) [rpm]."""
    drop_eq15: float
    """Where its in-phase root leaves to infinity: the linear resonance sqrt(k / m) [rpm]."""


def eq15_distance(speed, amplitude, *, omega_per_rpm: float, force_amp: float,
                  stiffness: float, mass: float, half_gap: float) -> Eq15Distance:
    """The Eq. (15) root nearest the integrated amplitude at each speed, and their distance.

    Parameters
    ----------
    speed : array_like
        Speeds [rpm].
    amplitude : array_like
        Integrated amplitude (half peak-to-peak of p) at those speeds [m], one sweep.
    omega_per_rpm : float
        Excitation angular frequency per rpm [rad/s / rpm].
    """
    speed = np.asarray(speed, float)
    amp = np.asarray(amplitude, float)
    roots = np.abs(hb.eq15_roots(speed * omega_per_rpm, force_amp, stiffness, mass, half_gap))
    dist = np.abs(roots - amp[:, None])
    has = np.isfinite(dist).any(axis=1)
    idx = np.where(has, np.nanargmin(np.where(np.isfinite(dist), dist, np.inf), axis=1), 0)
    near = np.where(has, roots[np.arange(speed.size), idx], np.nan)
    return Eq15Distance(
        speed=speed, eq15=near, integration=amp, relative=np.abs(near - amp) / amp,
        rise_eq15=math.sqrt(force_amp / (mass * half_gap)) / omega_per_rpm,
        drop_eq15=math.sqrt(stiffness / mass) / omega_per_rpm)


def opening_force(omega, *, mass: float, stiffness: float, damping: float,
                  force_mean: float) -> np.ndarray:
    """Harmonic force amplitude [N] at angular frequency omega [rad/s] that opens the mesh
    (linear response): ``F_m |k - m w^2 + i c w| / k``.

    In permanent contact the mesh is linear: ``p = F_m / k + A cos(w t - phi)`` with
    ``A = F0 / |k - m w^2 + i c w|``; the teeth first separate when ``A = F_m / k``, the static
    deflection. The force that does it depends on the frequency: ``F_m`` at w -> 0, its least
    value ``contact_loss_threshold`` near resonance, and ``F_m m w^2 / k`` far above it.
    """
    w = np.asarray(omega, float)  # (|F_m|: a negative one presses the back flank, as above)
    return abs(force_mean) * np.abs(stiffness - mass * w**2 + 1j * damping * w) / stiffness


def first_harmonic_opening(*, mass: float, stiffness: float, damping: float,
                           force_mean: float, ste_amplitude: float) -> tuple[float, float]:
    """Band of angular frequencies (low, high) [rad/s] where the force ``m w^2 e_1`` of an STE
    harmonic ``e_1`` [m] at w alone opens the mesh: ``m w^2 e_1 >= opening_force(w)``
    (linear response; ``high`` is inf where it stays open at every higher w, both NaN where
    it opens at none).

    Closed form: with ``x = m w^2 / k``, ``zeta = c / (2 sqrt(k m))`` and ``E = k e_1 / F_m``
    the condition is ``E^2 x^2 >= (1 - x)^2 + 4 zeta^2 x``, i.e.
    ``q(x) = (E^2 - 1) x^2 + (2 - 4 zeta^2) x - 1 >= 0``; ``q(0) = -1``, so for ``E > 1`` it
    holds above q's one positive root, for ``E < 1`` between its two roots (if real and
    positive), and for ``E = 1`` above ``1 / (2 - 4 zeta^2)`` (where ``zeta^2 < 1/2``).
    """
    zeta = damping / (2.0 * math.sqrt(stiffness * mass))
    e2 = (stiffness * ste_amplitude / force_mean) ** 2
    a, b = e2 - 1.0, 2.0 - 4.0 * zeta**2
    if a == 0.0:
        x = (1.0 / b, math.inf) if b > 0.0 else (math.nan, math.nan)
    elif a > 0.0:  # roots of opposite sign: the positive one
        x = ((-b + math.sqrt(b * b + 4.0 * a)) / (2.0 * a), math.inf)
    else:
        disc = b * b + 4.0 * a
        if b <= 0.0 or disc < 0.0:  # no positive root: q < 0 for every x > 0
            x = (math.nan, math.nan)
        else:  # two positive roots (product -1 / a > 0, sum -b / a > 0); q >= 0 between
            r = math.sqrt(disc)
            x = ((-b + r) / (2.0 * a), (-b - r) / (2.0 * a))
            x = (min(x), max(x))
    wn = math.sqrt(stiffness / mass)
    return (wn * math.sqrt(x[0]), wn * math.sqrt(x[1]))


def contact_loss_threshold(*, mass: float, stiffness: float, damping: float,
                           force_mean: float) -> float:
    """Smallest harmonic force amplitude [N] that opens the mesh at any frequency: the least
    ``opening_force`` (linear response), ``F_m min_w |k - m w^2 + i c w| / k``,
    ``F0 = F_m c sqrt(4 k m - c^2) / (2 k m)`` (``= 2 zeta sqrt(1 - zeta^2) F_m``) for
    ``zeta < 1/sqrt(2)``, else ``F_m``. It holds near resonance only: at any other frequency the
    force that opens the mesh is ``opening_force(w)``, larger. A negative F_m presses the back
    flank, which parts at the same amplitude: the threshold is that of ``|F_m|`` (an amplitude,
    never negative).
    """
    zeta = damping / (2.0 * math.sqrt(stiffness * mass))
    if zeta >= 1.0 / math.sqrt(2.0):
        return abs(float(force_mean))
    return float(2.0 * zeta * math.sqrt(1.0 - zeta**2) * abs(force_mean))


def excitation_budget(omega, *, mass: float, stiffness: float, ste_amplitude: float
                      ) -> dict[str, np.ndarray]:
    """Force amplitudes [N] an STE harmonic ``e_n`` [m] can supply at angular frequency omega:
    ``k e_n`` (the displacement excitation in contact) and ``m w^2 e_n`` (the ``m e''`` term of
    Eq. (6)), and the STE amplitude that would supply a force F by each route is ``F / k`` and
    ``F / (m w^2)``."""
    w2 = np.asarray(omega, float) ** 2
    return {"k_e": np.full_like(w2, stiffness * ste_amplitude),
            "m_w2_e": mass * w2 * ste_amplitude}
