"""One 1-DOF case of Eq. (6) as plain numbers, shared by the reference solvers, the kernels and
the step advisor.

The model, divided by the equivalent mass m (SI units throughout):

    p'' = G(t) - cm p' - K(t) f(p)
    K(t) = k_mean + sum_j ka_j cos(kr_j W t + kp_j)          stiffness / mass [1/s^2]
    G(t) = g_mean + sum_j ga_j cos(gr_j W t + gp_j)          force / mass     [m/s^2]

with the mesh angular frequency W [rad/s], harmonic orders relative to the mesh frequency, and the
dead zone f(p) = p - clip(p, -b, b) of half-width b (``half_gap=None``: f(p) = p). The STE enters
G through -e''(t): a term e_n cos(n W t + a_n) of e(t) gives e_n (n W)^2 cos(n W t + a_n) in G.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gearsweep.kernels.tables import fourier_table


@dataclass(frozen=True)
class Scene:
    """A single case of the 1-DOF mesh model (all values divided by the mass).

    Parameters
    ----------
    omega : float
        Mesh angular frequency W [rad/s].
    damping : float
        c / m [1/s].
    k_mean : float
        Mean stiffness / mass [1/s^2].
    k_harmonics : tuple of (amplitude [1/s^2], order [1], phase [rad])
        Stiffness fluctuation, orders relative to the mesh frequency.
    g_mean : float
        Mean force / mass [m/s^2].
    g_harmonics : tuple of (amplitude [m/s^2], order [1], phase [rad])
        Periodic force / mass, including the STE term -e''(t).
    half_gap : float or None
        Half the backlash b [m]; ``None``: no backlash.
    """

    omega: float
    damping: float
    k_mean: float
    k_harmonics: tuple[tuple[float, float, float], ...] = field(default=())
    g_mean: float = 0.0
    g_harmonics: tuple[tuple[float, float, float], ...] = field(default=())
    half_gap: float | None = None

    @property
    def period(self) -> float:
        """Mesh period [s]."""
        return 2.0 * np.pi / self.omega

    @property
    def omega_n(self) -> float:
        """Natural frequency at the largest stiffness, sqrt(max K) [rad/s] (bound used for step
        sizes: sqrt(k_mean + sum |ka_j|))."""
        return float(np.sqrt(self.k_mean + sum(abs(a) for a, _, _ in self.k_harmonics)))

    def stiffness(self, t):
        """K(t) [1/s^2]."""
        t = np.asarray(t, dtype=float)
        out = np.full_like(t, self.k_mean)
        for a, r, ph in self.k_harmonics:
            out = out + a * np.cos(r * self.omega * t + ph)
        return out

    def forcing(self, t):
        """G(t) [m/s^2]."""
        t = np.asarray(t, dtype=float)
        out = np.full_like(t, self.g_mean)
        for a, r, ph in self.g_harmonics:
            out = out + a * np.cos(r * self.omega * t + ph)
        return out

    def response_scale(self) -> float:
        """Rough size of p [m]: static deflection under the largest force plus the half gap
        (used to scale absolute tolerances)."""
        g = abs(self.g_mean) + sum(abs(a) for a, _, _ in self.g_harmonics)
        return g / max(self.k_mean, 1e-300) + (self.half_gap or 0.0)

    def kernel_kwargs(self, steps_per_period: int) -> dict:
        """Arguments of ``gearsweep.kernels.batch.simulate`` for this case (without the step
        counts): h [s], tables at the stage nodes of one mesh period, scales and half gap."""
        kw: dict = {
            "h": np.array([self.period / steps_per_period]),
            "damping": self.damping,
            "k_mean": self.k_mean,
            "force": self.g_mean,
            "half_gap": self.half_gap,
            "steps_per_period": steps_per_period,
        }
        cycle = _cycle(self.k_harmonics, self.g_harmonics)
        if self.k_harmonics:
            a, r, ph = zip(*self.k_harmonics, strict=True)
            kw["k_table"] = fourier_table(a, r, ph, steps_per_period, cycle)
            kw["k_scale"] = 1.0
        if self.g_harmonics:
            a, r, ph = zip(*self.g_harmonics, strict=True)
            kw["ste_table"] = fourier_table(a, r, ph, steps_per_period, cycle)
            kw["ste_scale"] = 1.0
        return kw


def _cycle(*harmonic_sets) -> int:
    """Mesh periods in one cycle of all harmonics (orders must be multiples of 1/cycle)."""
    cycle = 1
    for hs in harmonic_sets:
        for _, r, _ in hs:
            for c in range(1, 65):
                if abs(r * c - round(r * c)) < 1e-12:
                    cycle = int(np.lcm(cycle, c))
                    break
            else:
                raise ValueError(f"harmonic order {r} is not a multiple of 1/c for c <= 64")
    return cycle


def gear_scene(
    *,
    mass: float,
    damping: float,
    k0: float,
    mesh_frequency: float,
    k_harmonics=(),
    ste_harmonics=(),
    force: float = 0.0,
    backlash: float | None = None,
) -> Scene:
    """Build a ``Scene`` from the physical parameters of Eq. (6).

    Parameters
    ----------
    mass : float
        Equivalent mass m_eq [kg].
    damping : float
        Mesh viscous damping c [N s/m].
    k0 : float
        Mean mesh stiffness [N/m].
    mesh_frequency : float
        Tooth-mesh frequency [Hz].
    k_harmonics : sequence of (amplitude [N/m], order, phase [rad])
        Mesh stiffness harmonics k_n cos(n W t + a_n).
    ste_harmonics : sequence of (amplitude [m], order, phase [rad])
        STE harmonics e_n cos(n W t + a_n).
    force : float
        Mean mesh force F_m [N].
    backlash : float or None
        Total backlash [m] (the dead zone's half-width is backlash / 2); ``None``: none.
    """
    w = 2.0 * np.pi * mesh_frequency
    return Scene(
        omega=w,
        damping=damping / mass,
        k_mean=k0 / mass,
        k_harmonics=tuple((a / mass, r, ph) for a, r, ph in k_harmonics),
        g_mean=force / mass,
        g_harmonics=tuple((e * (r * w) ** 2, r, ph) for e, r, ph in ste_harmonics),
        half_gap=None if backlash is None else 0.5 * backlash,
    )
