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

import dataclasses
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
    def highest_order(self) -> float:
        """The highest mesh order of its stiffness, STE and force harmonics (0 without any):
        what a spectrum's sampling and the step advice's resonance orders must follow."""
        return max((hm.order for hm in (*self.stiffness_harmonics, *self.ste_harmonics,
                                        *self.force_harmonics)), default=0.0)

    @property
    def cycle_periods(self) -> int:
        """Mesh periods in one cycle of every excitation (1 unless some order is fractional)."""
        p = 1
        for hm in (*self.stiffness_harmonics, *self.ste_harmonics, *self.force_harmonics):
            den = self._order_fraction(hm.order).denominator
            p = p * den // math.gcd(p, den)
        return p

    def _order_fraction(self, order: float) -> Fraction:
        exact = Fraction(order)
        near = exact.limit_denominator(max(10 * self.teeth, 64))  # 0.0208333 is 1/48
        if abs(float(near) - order) > 1e-4 * order:  # a decimal of 5 digits is its
            near = exact.limit_denominator(10**6)  # fraction; 1/97 of 8 teeth is not 1/80
        return near

    def longest_cycle_order(self) -> tuple[float, Fraction] | None:
        """The order whose fraction has the largest denominator (the one that makes the
        excitation's cycle long), with that fraction; ``None`` when every order is whole."""
        orders = [h.order for h in (*self.stiffness_harmonics, *self.ste_harmonics,
                                    *self.force_harmonics)]
        fractions = [(o, self._order_fraction(o)) for o in orders]
        worst = max(fractions, key=lambda of: of[1].denominator, default=None)
        return worst if worst is not None and worst[1].denominator > 1 else None

    def scene(self, speed_rpm: float) -> Scene:
        """This model at one shaft speed, divided by the mass (the reference solvers' form)."""
        return gear_scene(
            mass=self.mass, damping=self.damping, k0=self.stiffness,
            mesh_frequency=float(mesh_frequency(speed_rpm, self.teeth)),
            k_harmonics=[(h.amplitude, h.order, h.phase) for h in self.stiffness_harmonics],
            ste_harmonics=[(h.amplitude, h.order, h.phase) for h in self.ste_harmonics],
            force_harmonics=[(h.amplitude, h.order, h.phase) for h in self.force_harmonics],
            force=self.mean_force, backlash=self.backlash or None)


@dataclass(frozen=True)
class MathieuModel:
    """Eq. (11): p'' + gamma p' + (alpha + beta cos tau) p = 0, in the time tau (period 2 pi)."""

    alpha: float
    beta: float
    gamma: float = 0.0


PAPER_RIG = MeshModel(
    mass=0.1527, teeth=48, stiffness=1.073e9, damping=5500.0, mean_force=833.0,
    stiffness_harmonics=(Harmonic(179e6, 1.0),),
)
"""The paper's rig in SI, each number printed in the paper: m_eq = 0.1527 kg and c = 5.5 N s/mm
(Fig. 6), k0 = 1073 kN/mm and k1 = 179 kN/mm (Fig. 7.2), N1 = 48 teeth (Table 1), and
F_m = 50 N m / 60 mm = 833 N (Fig. 6's 50 N m on the 60 mm pitch radius). No STE, no backlash:
scenes add what they need (``dataclasses.replace``)."""


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
        fm = mean_mesh_force(np.asarray(cases["torque"], dtype=float), model.base_radius)
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
    # Static scale of the response, for the divergence bound: with the start, |p0| and the swing
    # |p'0| / omega_n of a start's velocity (without it, a free decay from 1 m/s under no load
    # had a bound of 1 um and every case 'diverged' in its first mesh period)
    e_amp = sum(abs(hm.amplitude) * (1.0 + (hm.order * omega) ** 2 * mass / k0) for hm in eh)
    f_amp = sum(abs(hm.amplitude) for hm in fh)
    scale = ((np.abs(fm) + f_amp) / k0 + e_amp + backlash / 2.0 + np.abs(x0)
             + np.abs(v0) * np.sqrt(mass / k0))
    out["bound"] = divergence_factor * np.maximum(scale, 1e-12)
    out["x0"] = x0
    out["v0"] = v0
    return out


def mesh_frequency(speed_rpm: np.ndarray, teeth: int) -> np.ndarray:
    """Tooth-mesh frequency [Hz] of a driving-gear shaft speed [rpm]."""
    return np.asarray(speed_rpm, dtype=float) * teeth / 60.0


def hill_parameters(model: MeshModel | MathieuModel, params: dict[str, np.ndarray], n: int):
    """Eq. (12): the homogeneous equation of each case in Mathieu time tau = N w t.

    Parameters
    ----------
    model : MeshModel or MathieuModel
        The scene's fixed values.
    params : dict of ndarray (n,)
        Swept values per case (keys from ``SWEEPABLE``; speed in rpm, others SI).
    n : int
        Number of cases.

    Returns
    -------
    alpha, beta, gamma : ndarray (n,)
        ``alpha = k0 / (m (N w)^2)``, ``beta = 1 / (m (N w)^2)`` (the scale of the stiffness
        harmonics), ``gamma = c / (m N w)``; the Mathieu scene gives them directly.
    harmonics : (amplitudes, orders, phases) or None
        The stiffness harmonics shared by every case, their orders per period of the Hill
        equation: that of the stiffness orders' cycle, ``hill_cycle(model)[0]`` mesh periods
        (orders 0.5 and 1: 2 periods, orders 1 and 2; alpha, beta, gamma in that time too); None
        also where that cycle is longer than ``HILL_CYCLE_MAX`` (then alpha is NaN).
    kmax_over_m, c_over_m, period : ndarray (n,)
        Largest stiffness / mass [1/s^2], damping / mass [1/s] and mesh period [s] of each case
        (Mathieu scene: in units of tau).
    """

    def case(name: str, default: float) -> np.ndarray:
        v = params.get(name)
        return np.full(n, float(default)) if v is None else np.asarray(v, dtype=float)

    if isinstance(model, MathieuModel):
        a, b, g = case("alpha", model.alpha), case("beta", model.beta), case("gamma", model.gamma)
        return a, b, g, None, a + np.abs(b), g, np.full(n, 2.0 * math.pi)
    omega = model.teeth * case("speed", math.nan) * RPM  # mesh angular frequency [rad/s]
    mass = case("mass", model.mass)
    k0 = case("stiffness", model.stiffness)
    c = case("damping", model.damping)
    kh = model.stiffness_harmonics
    period = 2.0 * math.pi / omega
    cycle = hill_cycle(model)[0]
    omega = omega / max(cycle, 1)  # the Hill equation's period: the stiffness orders' cycle
    scale = 1.0 / (mass * omega**2)
    alpha, gamma = k0 * scale, c / (mass * omega)
    harmonics = None
    beta = np.zeros(n)
    if kh:
        if cycle == 0:
            alpha = np.full(n, math.nan)
        else:
            harmonics = ([h.amplitude for h in kh], [round(h.order * cycle) for h in kh],
                         [h.phase for h in kh])
            beta = scale
    kmax = (k0 + sum(abs(h.amplitude) for h in kh)) / mass
    return alpha, beta, gamma, harmonics, kmax, c / mass, period


HILL_CYCLE_MAX = 64
"""Most mesh periods in the cycle of a scene's stiffness orders that the Floquet analysis and the
step guard's map check cover (``hill_cycle``): their monodromy takes the cycle's steps, as the
kernel's table does. Orders 0.5 and 1: 2 periods; an order with no small common period with the
others (1/97 beside 1, 0.4142: an irrational-looking one) is not analysed (``hill_parameters``
gives alpha NaN, and the run says so)."""


def hill_cycle(model: MeshModel | MathieuModel) -> tuple[int, int]:
    """(P, q): the mesh periods in one period of the scene's Hill equation, the least common
    multiple of its stiffness orders' periods (1 for whole orders; 0 where that exceeds
    ``HILL_CYCLE_MAX``: not analysed), and the periods of that equation in one cycle of every
    excitation (``MeshModel.cycle_periods``: the forcing's period, whose periodic response the
    step guard's resonance test judges)."""
    if not isinstance(model, MeshModel) or not model.stiffness_harmonics:
        return 1, getattr(model, "cycle_periods", 1)
    p = 1
    for hm in model.stiffness_harmonics:
        den = model._order_fraction(hm.order).denominator
        p = p * den // math.gcd(p, den)
    if p > HILL_CYCLE_MAX:
        return 0, 1
    total = model.cycle_periods
    return p, max(total // p, 1)


# --------------------------------------------------------------------------- one case, per mass


@dataclass(frozen=True)
class Scene:
    """One case of Eq. (6) divided by the mass, the form the reference solvers integrate:

        p'' = G(t) - cm p' - K(t) f(p)
        K(t) = k_mean + sum_j ka_j cos(kr_j W t + kp_j)          stiffness / mass [1/s^2]
        G(t) = g_mean + sum_j ga_j cos(gr_j W t + gp_j)          force / mass     [m/s^2]

    with the mesh angular frequency W [rad/s], harmonic orders relative to the mesh frequency,
    and the dead zone f(p) = p - clip(p, -b, b) (``half_gap=None``: f(p) = p). The STE enters G
    through -e''(t): e_n cos(n W t + a_n) gives e_n (n W)^2 cos(n W t + a_n). Build one with
    ``MeshModel.scene(speed)`` or ``gear_scene``; its kernel arguments come from
    ``kernel_inputs`` like every study's.

    Parameters
    ----------
    omega : float
        Mesh angular frequency W [rad/s].
    damping : float
        c / m [1/s].
    k_mean : float
        Mean stiffness / mass [1/s^2].
    k_harmonics : tuple of (amplitude [1/s^2], order [1], phase [rad])
    g_mean : float
        Mean force / mass [m/s^2].
    g_harmonics : tuple of (amplitude [m/s^2], order [1], phase [rad])
        Periodic force / mass, the STE term -e''(t) included.
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
        """sqrt(k_mean + sum |ka_j|) [rad/s]: natural frequency at the largest stiffness."""
        return float(np.sqrt(self.k_mean + sum(abs(a) for a, _, _ in self.k_harmonics)))

    def _series(self, mean: float, harmonics, t):
        t = np.asarray(t, dtype=float)
        out = np.full_like(t, mean)
        for a, r, ph in harmonics:
            out = out + a * np.cos(r * self.omega * t + ph)
        return out

    def stiffness(self, t):
        """K(t) [1/s^2]."""
        return self._series(self.k_mean, self.k_harmonics, t)

    def forcing(self, t):
        """G(t) [m/s^2]."""
        return self._series(self.g_mean, self.g_harmonics, t)

    def response_scale(self) -> float:
        """Rough size of p [m]: static deflection under the largest force plus the half gap."""
        g = abs(self.g_mean) + sum(abs(a) for a, _, _ in self.g_harmonics)
        return g / max(self.k_mean, 1e-300) + (self.half_gap or 0.0)

    def model(self) -> MeshModel:
        """The same case as a ``MeshModel`` of unit mass (speed: ``omega / RPM`` at one tooth)."""
        return MeshModel(
            mass=1.0, teeth=1, stiffness=self.k_mean, damping=self.damping,
            mean_force=self.g_mean, backlash=2.0 * self.half_gap if self.half_gap else 0.0,
            stiffness_harmonics=tuple(Harmonic(*h) for h in self.k_harmonics),
            force_harmonics=tuple(Harmonic(*h) for h in self.g_harmonics))

    def kernel_kwargs(self, steps_per_period: int) -> dict:
        """Arguments of ``gearsweep.kernels.simulate`` for this case (without the step counts),
        from ``kernel_inputs``, plus ``steps_per_period``."""
        kw = kernel_inputs(self.model(), {"speed": np.array([self.omega / RPM])}, 1,
                           steps_per_period, divergence_factor=math.inf)
        kw["steps_per_period"] = steps_per_period
        if self.half_gap is not None and not self.half_gap:
            kw["half_gap"] = np.zeros(1)
        return kw


def gear_scene(*, mass: float, damping: float, k0: float, mesh_frequency: float, k_harmonics=(),
               ste_harmonics=(), force_harmonics=(), force: float = 0.0,
               backlash: float | None = None) -> Scene:
    """A ``Scene`` from the physical parameters of Eq. (6).

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
    ste_harmonics : sequence of (amplitude [m], order, phase [rad])
    force_harmonics : sequence of (amplitude [N], order, phase [rad])
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
        g_harmonics=tuple((e * (r * w) ** 2, r, ph) for e, r, ph in ste_harmonics)
        + tuple((f / mass, r, ph) for f, r, ph in force_harmonics),
        half_gap=None if backlash is None else 0.5 * backlash,
    )


# --------------------------------------------------------------------------- self-description


def model_record(model: MeshModel | MathieuModel) -> dict:
    """Every number of the model (SI) and which terms are on, as plain JSON-able data."""
    rec = {"kind": "mathieu" if isinstance(model, MathieuModel) else "mesh"}
    for f in dataclasses.fields(model):
        v = getattr(model, f.name)
        if isinstance(v, tuple):
            v = [dataclasses.asdict(h) for h in v]
        rec[f.name] = v
    return rec


def model_from_record(rec: dict) -> MeshModel | MathieuModel:
    """The inverse of ``model_record``."""
    rec = dict(rec)
    kind = rec.pop("kind")
    if kind == "mathieu":
        return MathieuModel(**rec)
    for name in ("stiffness_harmonics", "ste_harmonics", "force_harmonics"):
        rec[name] = tuple(Harmonic(**h) for h in rec.get(name, ()))
    return MeshModel(**rec)
