"""Physics of the gear pair: involute geometry, tooth compliance, load sharing, STE, stiffness.

Numerics on SI floats and NumPy arrays; no YAML, xarray or plotting here.
"""

from gearsweep.gear.compliance import hertz_compliance, pair_compliance, tooth_compliance
from gearsweep.gear.geometry import (
    GearPair,
    GeometryWarning,
    inverse_involute,
    involute,
    table1_as_printed,
    table1_consistent,
    table1_profile_shift,
)
from gearsweep.gear.mesh import (
    MeshCycle,
    TipRelief,
    fourier,
    fourier_series,
    iso6336_stiffness,
    mesh_cycle,
    mesh_cycles,
)

__all__ = [
    "GearPair",
    "GeometryWarning",
    "MeshCycle",
    "TipRelief",
    "fourier",
    "fourier_series",
    "hertz_compliance",
    "involute",
    "inverse_involute",
    "iso6336_stiffness",
    "mesh_cycle",
    "mesh_cycles",
    "pair_compliance",
    "table1_as_printed",
    "table1_consistent",
    "table1_profile_shift",
    "tooth_compliance",
]
