"""What a gear pair at a mean load gives the dynamic model: k0, k_n, e_n, N1 and r_b1 (SI).

The static mesh of :func:`gearsweep.gear.mesh_cycle` over one cycle, expanded in the Fourier series
of the paper's Eq. (1). Takes a :class:`GearPair` and its tip reliefs (plain objects, never a study
file's model) and is cached per (pair, reliefs, torque, harmonics): a study that sweeps torque
computes each distinct load once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from gearsweep.errors import GeometryError
from gearsweep.gear.geometry import GearPair
from gearsweep.gear.mesh import MeshCycle, TipRelief, mesh_cycle
from gearsweep.model import Harmonic

DEFAULT_HARMONICS = 10
"""Fourier harmonics of k(t) and e(t) passed to the dynamics when a scene does not say."""

POSITIONS = 200
"""Uniform positions per mesh cycle of a dynamic scene's static mesh (its harmonics come from
the mesh cycle's quadrature, not from these)."""

Reliefs = tuple[TipRelief | None, TipRelief | None]


def static_mesh(pair: GearPair, torque: float, reliefs: Reliefs = (None, None),
                n: int = POSITIONS, harmonics: int = DEFAULT_HARMONICS) -> MeshCycle:
    """Check the pair and compute its static mesh over one cycle at ``torque`` [N m].

    Parameters
    ----------
    pair : GearPair
        The gear pair (checked here: ``GearPair.check``).
    torque : float
        Torque on the driving gear 1 [N m].
    reliefs : (TipRelief or None, TipRelief or None)
        Tip relief of gear 1 and gear 2.
    n : int
        Positions per mesh cycle [-].
    harmonics : int
        Highest Fourier order of its harmonics (``MeshCycle.quadrature``) [-].

    Returns
    -------
    MeshCycle
        Load share, STE [m] and mesh stiffness [N/m] over the cycle.

    Raises
    ------
    GeometryError
        The pair cannot exist (every problem named), or a tip relief does not fit it.
    """
    return mesh_cycle(pair, torque, n=n, tip_relief=reliefs, harmonics=harmonics)  # (checks it)


@dataclass(frozen=True)
class GearExcitation:
    """What a gear pair at a mean load gives the dynamic model (SI units)."""

    pair: GearPair
    torque: float
    """Mean driving torque T1m at which the mesh was computed [N m]."""
    teeth: int
    """N1 = z1 of the driving gear."""
    base_radius_1: float
    """Driving base radius r_b1 [m]."""
    base_radius_2: float
    """Driven base radius r_b2 [m]."""
    stiffness: float
    """Mean mesh stiffness k0 [N/m]."""
    stiffness_harmonics: tuple[Harmonic, ...]
    """k_n [N/m] and a_n [rad], orders 1..harmonics."""
    ste_harmonics: tuple[Harmonic, ...]
    """Loaded STE harmonics e_n [m], b_n [rad], orders 1..harmonics (e_0 drops out of e'').
    The excitation e(t) of a scene with constant stiffness k0 (rattle)."""
    no_load_te_harmonics: tuple[Harmonic, ...]
    """Harmonics of ``STE - F_m / k(phase)`` [m], [rad]: the excitation e(t) of a scene with
    time-varying stiffness k(t) (whine, full). Zero for unmodified error-free teeth."""
    ste_mean: float
    """e_0, the mean STE [m] (not used by the dynamics)."""
    ste_max: float
    """The largest STE over the cycle's samples [m] (what ``mesh.load_cautions`` tests)."""
    backlash: float
    """The pair's backlash along the line of action [m] (for information; scenes type theirs)."""


@lru_cache(maxsize=256)
def _excitation(pair: GearPair, reliefs: Reliefs, torque: float, harmonics: int) -> GearExcitation:
    mc = static_mesh(pair, torque, reliefs, harmonics=harmonics)
    # integrated over the mesh cycle's quadrature, not from the uniform samples (their DFT is off
    # as 1/N at the jumps). With k(t) in the model, the static solution is p = F_m / k(t), so
    # e(t) must be what the STE holds beyond F_m / k(t) (the stiffness-weighted separation of
    # the loaded pairs, ``e_harmonic``); the loaded STE itself would count the elastic
    # deflection twice (docs/mesh.md).
    a = mc.as_arrays(harmonics)
    k, ka, e, ea = a["k_harmonic"], a["k_phase"], a["ste_harmonic"], a["ste_phase"]
    u, ua = a["e_harmonic"], a["e_phase"]
    pair = mc.pair
    return GearExcitation(
        pair=pair, torque=torque, teeth=pair.z1, base_radius_1=pair.base_radius1,
        base_radius_2=pair.base_radius2, stiffness=float(k[0]),
        stiffness_harmonics=tuple(Harmonic(float(k[n]), float(n), float(ka[n]))
                                  for n in range(1, harmonics + 1)),
        ste_harmonics=tuple(Harmonic(float(e[n]), float(n), float(ea[n]))
                            for n in range(1, harmonics + 1)),
        no_load_te_harmonics=tuple(Harmonic(float(u[n]), float(n), float(ua[n]))
                                   for n in range(1, harmonics + 1)),
        ste_mean=float(e[0] * math.cos(ea[0])), ste_max=float(mc.ste.max()),
        backlash=pair.backlash_loa,
    )  # fmt: skip


def gear_excitation(pair: GearPair, torque: float, reliefs: Reliefs = (None, None),
                    harmonics: int = DEFAULT_HARMONICS) -> GearExcitation:
    """k0, k_n, a_n, e_n, b_n, N1 and r_b1 of a gear pair at a mean driving torque.

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    torque : float
        Mean driving torque T1m [N m], > 0.
    reliefs : (TipRelief or None, TipRelief or None)
        Tip relief of gear 1 and gear 2.
    harmonics : int
        Fourier harmonics kept, >= 1.

    Returns
    -------
    GearExcitation
        Plain SI numbers in the paper's Eq. (1) convention, ``cos(2 pi n phi + phase)``.

    Raises
    ------
    GeometryError
        The pair cannot exist, the relief does not fit it, or the torque is not positive.
    """
    if not (math.isfinite(torque) and torque > 0):
        raise GeometryError(f"the mean torque {torque!r} N m must be positive to load the mesh")
    return _excitation(pair, tuple(reliefs), float(torque), int(harmonics))
