"""The paper's dynamic model, Eq. (6)-(7), as plain SI numbers, and its map onto the kernel.

    m p'' + c p' + k(t) f(p) = F_m + F_v(t) - m e''(t)                                 (6)
    m = 1 / (r1^2/I1 + r2^2/I2),  F_m = T1m / r1,  F_v(t) = m T1v(t) r1 / I1             (7)
    k(t) = k0 + sum_n k_n cos(2 pi n phi + a_n),  e(t) = sum_n e_n cos(2 pi n phi + b_n)   (1)

with ``phi = N1 w1 t / (2 pi)`` the mesh phase (N1 teeth and shaft speed w1 of the driving gear,
``N1 w1`` the mesh angular frequency, the same for both gears). ``f`` is the backlash dead zone of
Eq. (8) with half-width b = backlash / 2. The Mathieu scene, Eq. (11)-(12), is the homogeneous
equation with k0 and k1 only, in the time ``tau = N w t``.

Nothing here knows of YAML, units or xarray: the study layer builds a ``MeshModel`` from a
validated study, and ``kernel_inputs`` turns it plus the per-case swept values into the
arguments of ``gearsweep.kernels.simulate``. A term that is absent (no harmonics, zero backlash
that is not swept) is passed as ``None``, so the kernel specialises and does not pay for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from gearsweep.kernels import fourier_table

RPM = 2.0 * math.pi / 60.0
"""rad/s per rpm."""


@dataclass(frozen=True)
class Harmonic:
    """One term ``amplitude * cos(2 pi order phi + phase)``; ``order`` in mesh orders."""

    amplitude: float
    order: float
    phase: float = 0.0


def equivalent_mass(inertia_1: float, inertia_2: float, base_radius_1: float,
                    base_radius_2: float) -> float:
    """Eq. (7): m_eq = 1 / (r1^2/I1 + r2^2/I2) [kg] from inertias [kg m^2] and base radii [m]."""
    return 1.0 / (base_radius_1**2 / inertia_1 + base_radius_2**2 / inertia_2)


def mean_mesh_force(torque_1: float, base_radius_1: float) -> float:
    """Eq. (7): F_m = T1m / r1 [N] from the mean driving torque [N m] and base radius [m]."""
    return torque_1 / base_radius_1


def fluctuating_force(torque_amplitude: float, mass: float, base_radius_1: float,
                      inertia_1: float) -> float:
    """Eq. (7): F_v = m_eq T1v r1 / I1 [N] for a driving-torque fluctuation amplitude [N m]."""
    return mass * torque_amplitude * base_radius_1 / inertia_1


@dataclass(frozen=True)
class MeshModel:
    """Eq. (6) with every coefficient in SI units. Absent terms are empty or zero."""

    mass: float
    """Equivalent mass m_eq [kg]."""
    teeth: int
    """Teeth of the driving gear N1: mesh frequency = N1 x shaft speed."""
    stiffness: float
    """Mean mesh stiffness k0 [N/m]."""
    damping: float = 0.0
    """Mesh viscous damping c [N s/m]."""
    mean_force: float = 0.0
    """Mean transmitted force F_m [N]."""
    base_radius: float | None = None
    """Base radius r1 of the driving gear [m], needed when torque is swept."""
    backlash: float = 0.0
    """Total backlash along the line of action [m]; 0 means no backlash."""
    stiffness_harmonics: tuple[Harmonic, ...] = field(default_factory=tuple)
    """k_n [N/m] of Eq. (1)."""
    ste_harmonics: tuple[Harmonic, ...] = field(default_factory=tuple)
    """e_n [m] of the static transmission error."""
    force_harmonics: tuple[Harmonic, ...] = field(default_factory=tuple)
    """Fluctuating force F_v [N] (torque fluctuation through Eq. (7))."""

    @property
    def cycle_periods(self) -> int:
        """Mesh periods in one cycle of every excitation (1 unless some order is fractional)."""
        p = 1
        for hm in (*self.stiffness_harmonics, *self.ste_harmonics, *self.force_harmonics):
            den = Fraction(hm.order).limit_denominator(10 * max(self.teeth, 1)).denominator
            p = p * den // math.gcd(p, den)
        return p


@dataclass(frozen=True)
class MathieuModel:
    """Eq. (11): p'' + gamma p' + (alpha + beta cos tau) p = 0, in the time tau (period 2 pi)."""

    alpha: float
    beta: float
    gamma: float = 0.0


SWEEPABLE = {
    "speed": "speed",
    "torque": "torque",
    "mean_force": "force",
    "damping": "damping",
    "backlash": "length",
    "mass": "mass",
    "stiffness": "stiffness",
    "alpha": "dimensionless",
    "beta": "dimensionless",
    "gamma": "dimensionless",
}
"""Parameters a study can sweep, with the kind of quantity each is (see study.units)."""


def _case(cases: dict[str, np.ndarray], name: str, default: float, n: int) -> np.ndarray:
    if name in cases:
        return np.asarray(cases[name], dtype=float)
    return np.full(n, float(default))


def kernel_inputs(model: MeshModel | MathieuModel, cases: dict[str, np.ndarray], n: int,
                  steps_per_period: int, divergence_factor: float = 1e6,
                  x0: float = 0.0, v0: float = 0.0) -> dict:
    """Arguments of ``gearsweep.kernels.simulate`` (all but the step counts) for ``n`` cases.

    Parameters
    ----------
    model : MeshModel or MathieuModel
        The fixed values of the scene.
    cases : dict of ndarray (n,)
        Swept values per case (keys from ``SWEEPABLE``; speed in rpm, others SI).
    steps_per_period : int
        Steps per mesh period (per 2 pi of tau for the Mathieu scene).
    divergence_factor : float
        A case is stopped as diverged when |p| exceeds this multiple of its static scale.
    """
    if isinstance(model, MathieuModel):
        alpha = _case(cases, "alpha", model.alpha, n)
        beta = _case(cases, "beta", model.beta, n)
        gamma = _case(cases, "gamma", model.gamma, n)
        cos_tab = fourier_table([1.0], [1.0], [0.0], steps_per_period)
        scale = max(abs(x0), abs(v0), 1e-300)
        return dict(
            h=np.full(n, 2.0 * math.pi / steps_per_period),
            damping=gamma,
            k_mean=alpha,
            k_scale=beta,
            k_table=cos_tab,
            half_gap=None,
            bound=np.full(n, divergence_factor * scale),
            x0=x0,
            v0=v0,
        )

    speed = _case(cases, "speed", np.nan, n)
    omega = model.teeth * speed * RPM  # mesh angular frequency [rad/s]
    cycle = model.cycle_periods
    spp = steps_per_period
    mass = _case(cases, "mass", model.mass, n)
    k0 = _case(cases, "stiffness", model.stiffness, n)
    if "torque" in cases:
        if model.base_radius is None:
            raise ValueError("sweeping torque needs the driving gear's base radius")
        fm = np.asarray(cases["torque"], dtype=float) / model.base_radius
    else:
        fm = _case(cases, "mean_force", model.mean_force, n)

    out: dict = dict(h=2.0 * math.pi / omega / spp, damping=_case(cases, "damping", model.damping,
                                                                 n) / mass, force=fm / mass)
    # Stiffness: constant, shared table (fast path), or per-case mean + scale * shape.
    kh = model.stiffness_harmonics
    if not kh:
        out["k_mean"] = k0 / mass
    else:
        shape = fourier_table([hm.amplitude for hm in kh], [hm.order for hm in kh],
                              [hm.phase for hm in kh], spp, cycle)
        if "mass" in cases or "stiffness" in cases:
            out.update(k_mean=k0 / mass, k_scale=1.0 / mass, k_table=shape)
        else:
            out.update(k_table=(model.stiffness + shape) / model.mass, k_scale=None)
    # STE: -e''(t) = -omega^2 d2e/dtheta2, theta the mesh angle.
    eh = model.ste_harmonics
    if eh:
        out["ste_table"] = fourier_table([hm.amplitude for hm in eh], [hm.order for hm in eh],
                                         [hm.phase for hm in eh], spp, cycle, derivative=2)
        out["ste_scale"] = -(omega**2)
    fh = model.force_harmonics
    if fh:
        out["fluct_table"] = fourier_table([hm.amplitude for hm in fh], [hm.order for hm in fh],
                                           [hm.phase for hm in fh], spp, cycle)
        out["fluct_scale"] = 1.0 / mass
    backlash = _case(cases, "backlash", model.backlash, n)
    has_gap = "backlash" in cases or model.backlash > 0.0
    out["half_gap"] = backlash / 2.0 if has_gap else None
    # Static scale of the response, for the divergence bound.
    e_amp = sum(abs(hm.amplitude) * (1.0 + (hm.order * omega) ** 2 * mass / k0) for hm in eh)
    f_amp = sum(abs(hm.amplitude) for hm in fh)
    scale = (np.abs(fm) + f_amp) / k0 + e_amp + backlash / 2.0 + abs(x0)
    out["bound"] = divergence_factor * np.maximum(scale, 1e-12)
    out["x0"] = x0
    out["v0"] = v0
    return out


def mesh_frequency(speed_rpm: np.ndarray, teeth: int) -> np.ndarray:
    """Tooth-mesh frequency [Hz] of a driving-gear shaft speed [rpm]."""
    return np.asarray(speed_rpm, dtype=float) * teeth / 60.0
