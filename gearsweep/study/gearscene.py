"""A gear pair in a study: the one YAML line from geometry to the dynamic model's k(t) and e(t).

A scene of the gear drive (whine, rattle, full) may name a gear pair instead of typing in its
Fourier coefficients::

    scene:
      kind: whine
      gear: table1_consistent        # a preset, or a mapping of GearPair fields (below)
      harmonics: 10                  # optional: Fourier harmonics kept (default 10)
      torque: 50 N*m                 # the mean load at which the static mesh is computed
      mass: 0.1527 kg
      damping: 5.5 N*s/mm

The scene's ``teeth`` (N1 = z1), ``stiffness`` (k0), ``stiffness_harmonics`` (k_n, a_n), ``ste``
(e_n, b_n) and the driving base radius (torque -> force) then come from
:func:`gearsweep.gear.mesh_cycle` at the scene's mean torque. A mapping gives the fields of
:class:`gearsweep.gear.GearPair` with units, optionally on top of a ``preset``::

    gear:
      preset: table1_consistent
      tip_relief: {amount: 6 um, start_at: single_contact}

    gear:
      module: 2 mm
      z1: 20
      z2: 40
      face_width: 20 mm
      x1: 0.2
      backlash: 0.1 mm

Nothing here runs the dynamics; :func:`gear_excitation` returns plain SI numbers.
"""

from __future__ import annotations

import dataclasses
import json
import math
from functools import lru_cache
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

from gearsweep.errors import GeometryError
from gearsweep.gear import GearPair, TipRelief, mesh_cycle, table1_as_printed, table1_consistent
from gearsweep.gear.mesh import MeshCycle, fourier
from gearsweep.model import Harmonic
from gearsweep.units import QuantityKind, UnitParseError, to_si

PRESETS = {"table1_consistent": table1_consistent, "table1_as_printed": table1_as_printed}
"""Named gear pairs a study can use as ``gear: NAME`` or ``gear: {preset: NAME, ...}``."""

DEFAULT_HARMONICS = 10
"""Fourier harmonics of k(t) and e(t) passed to the dynamics when a scene does not say."""

POSITIONS = 200
"""Positions per mesh cycle at which the static mesh is computed for a dynamic scene."""


def _parse(kind: str, value: Any, info: Any = None) -> Any:
    if isinstance(value, float) and (getattr(info, "context", None) or {}).get("si"):
        return value  # a spec read back from its own SI dump (``_excitation``)
    try:
        return to_si(value, kind)
    except UnitParseError as exc:
        raise ValueError(str(exc)) from None


def _q(kind: str) -> Any:
    # The same as gearsweep.study.schema.Q (not imported: schema imports this module).
    return Annotated[float, BeforeValidator(lambda value, info: _parse(kind, value, info)),
                     QuantityKind(kind)]


_Length, _Angle, _Pressure = _q("length"), _q("angle"), _q("pressure")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class TipReliefSpec(_Strict):
    """Tip relief of the driving, the driven or both gears (:class:`gearsweep.gear.TipRelief`)."""

    amount: _Length = Field(ge=0, description="relief at the tip C_a [m]")
    shape: Literal["linear", "parabolic"] = "linear"
    start_at: Literal["single_contact"] | None = Field(
        None, description="start where single-tooth contact ends on the gear's flank (long relief)")
    start_radius: _Length | None = Field(None, gt=0, description="radius where relief starts [m]")
    start_diameter: _Length | None = Field(None, gt=0, description="diameter where it starts [m]")
    start_roll_angle: _Angle | None = Field(None, gt=0, description="roll angle of the start [rad]")
    gears: Literal["both", "driving", "driven"] = Field("both", description="which gears are relieved")

    @model_validator(mode="after")
    def _one_start(self) -> TipReliefSpec:
        starts = (self.start_at, self.start_radius, self.start_diameter, self.start_roll_angle)
        if sum(v is not None for v in starts) != 1:
            raise ValueError("give exactly one of start_at, start_radius, start_diameter,"
                             " start_roll_angle")
        return self


def _preset_name(value: Any) -> Any:
    return {"preset": value} if isinstance(value, str) else value


class GearSpec(_Strict):
    """A gear pair: a ``preset`` and/or the fields of :class:`gearsweep.gear.GearPair` with units."""

    preset: Literal["table1_consistent", "table1_as_printed"] | None = None
    module: _Length | None = Field(None, gt=0, description="module [m]")
    z1: int | None = Field(None, ge=3, le=10_000, description="teeth of the driving gear 1")
    z2: int | None = Field(None, ge=3, le=10_000, description="teeth of the driven gear 2")
    face_width: _Length | None = Field(None, gt=0, description="face width [m]")
    pressure_angle: _Angle | None = Field(None, gt=0, description="reference pressure angle [rad]")
    x1: float | None = Field(None, description="profile shift coefficient of gear 1")
    x2: float | None = Field(None, description="profile shift coefficient of gear 2")
    tip_radius1: _Length | None = Field(None, gt=0)
    tip_radius2: _Length | None = Field(None, gt=0)
    root_radius1: _Length | None = Field(None, gt=0)
    root_radius2: _Length | None = Field(None, gt=0)
    fillet_radius: _Length | None = Field(None, gt=0)
    centre_distance: _Length | None = Field(None, gt=0)
    backlash: _Length | None = Field(None, ge=0, description="circumferential backlash [m]")
    thickness1: _Length | None = Field(None, gt=0, description="tooth thickness at r [m]")
    thickness2: _Length | None = Field(None, gt=0)
    youngs_modulus: _Pressure | None = Field(None, gt=0, description="Young's modulus [Pa]")
    poisson: float | None = Field(None, ge=0, lt=0.5)
    bore_radius1: _Length | None = Field(None, gt=0)
    bore_radius2: _Length | None = Field(None, gt=0)
    rim_thickness1: _Length | None = Field(None, gt=0)
    rim_thickness2: _Length | None = Field(None, gt=0)
    web_width1: _Length | None = Field(None, gt=0)
    web_width2: _Length | None = Field(None, gt=0)
    tip_relief: TipReliefSpec | None = None

    @model_validator(mode="after")
    def _complete(self) -> GearSpec:
        if self.preset is None:
            missing = [f for f in ("module", "z1", "z2", "face_width") if getattr(self, f) is None]
            if missing:
                raise ValueError(f"a gear needs a preset or {', '.join(missing)}")
        return self

    def overrides(self) -> dict[str, Any]:
        """The GearPair fields this spec sets (SI), without preset and tip relief."""
        skip = {"preset", "tip_relief"}
        return {k: v for k, v in self if k not in skip and v is not None}


GearField = Annotated[GearSpec, BeforeValidator(_preset_name)]
"""A scene's ``gear:``: a preset name or a mapping (see :class:`GearSpec`)."""


def gear_pair(spec: GearSpec) -> GearPair:
    """The :class:`gearsweep.gear.GearPair` of a spec (not yet checked; see ``GearPair.check``)."""
    fields = spec.overrides()
    if spec.preset is not None:
        base = PRESETS[spec.preset]()
        name = base.name if not fields else f"{base.name}, changed: {', '.join(fields)}"
        return dataclasses.replace(base, name=name, **fields)
    return GearPair(name="gear pair", **fields)


def tip_reliefs(spec: GearSpec, pair: GearPair) -> tuple[TipRelief | None, TipRelief | None]:
    """The tip relief of gear 1 and gear 2 described by ``spec`` (None where not relieved)."""
    r = spec.tip_relief
    if r is None:
        return None, None
    out: list[TipRelief | None] = []
    for g, side in ((1, "driving"), (2, "driven")):
        if r.gears not in ("both", side):
            out.append(None)
            continue
        if r.start_at == "single_contact":
            # Roll angle of the gear's flank where single-tooth contact ends towards its tip:
            # gear 1's tip is at s_end, single contact ends one base pitch after s_start.
            if g == 1:
                xi = (pair.s_start + pair.base_pitch) / pair.base_radius1
            else:
                xi = (pair.line_of_action_length - (pair.s_end - pair.base_pitch)) / pair.base_radius2
            out.append(TipRelief(r.amount, start_roll_angle=xi, shape=r.shape))
        else:
            out.append(TipRelief(r.amount, start_radius=r.start_radius,
                                 start_diameter=r.start_diameter,
                                 start_roll_angle=r.start_roll_angle, shape=r.shape))
    return out[0], out[1]


def static_mesh(spec: GearSpec, torque: float, n: int = POSITIONS) -> MeshCycle:
    """Check the pair and compute its static mesh over one cycle at ``torque`` [N m].

    Parameters
    ----------
    spec : GearSpec
        The gear pair and its tip relief.
    torque : float
        Torque on the driving gear 1 [N m].
    n : int
        Positions per mesh cycle [-].

    Returns
    -------
    MeshCycle
        Load share, STE [m] and mesh stiffness [N/m] over the cycle.

    Raises
    ------
    GeometryError
        The pair cannot exist (every problem named), or a tip relief does not fit it.
    """
    pair = gear_pair(spec).check()
    return mesh_cycle(pair, torque, n=n, tip_relief=tip_reliefs(spec, pair))


@dataclasses.dataclass(frozen=True)
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
    backlash: float
    """The pair's backlash along the line of action [m] (for information; scenes type theirs)."""


@lru_cache(maxsize=32)
def _excitation(spec_json: str, torque: float, harmonics: int) -> GearExcitation:
    spec = GearSpec.model_validate(json.loads(spec_json), context={"si": True})
    mc = static_mesh(spec, torque)
    arrays = mc.as_arrays(harmonics)
    k, ka = arrays["k_harmonic"], arrays["k_phase"]
    e, ea = arrays["ste_harmonic"], arrays["ste_phase"]
    # With k(t) in the model, the static solution is p = F_m / k(t), so e(t) must be what the
    # STE holds beyond F_m / k(t) (the stiffness-weighted separation of the loaded pairs);
    # the loaded STE itself would count the elastic deflection twice (docs/mesh.md).
    u, ua = fourier(mc.ste - mc.load / mc.mesh_stiffness, harmonics)
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
        ste_mean=float(e[0] * math.cos(ea[0])), backlash=pair.backlash_loa,
    )  # fmt: skip


def gear_excitation(spec: GearSpec, torque: float,
                    harmonics: int = DEFAULT_HARMONICS) -> GearExcitation:
    """k0, k_n, a_n, e_n, b_n, N1 and r_b1 of a gear pair at a mean driving torque.

    Parameters
    ----------
    spec : GearSpec
        The gear pair (preset and/or fields, tip relief).
    torque : float
        Mean driving torque T1m [N m], > 0.
    harmonics : int
        Fourier harmonics kept, 1 <= harmonics <= 100 (200 positions per mesh cycle).

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
    return _excitation(spec.model_dump_json(), float(torque), int(harmonics))


def scene_excitation(scene: Any) -> GearExcitation:
    """:func:`gear_excitation` of a scene with a ``gear`` at its mean ``torque`` or ``mean_force``.

    A ``mean_force`` F_m is turned into the torque ``F_m r_b1`` with the gear's base radius.
    """
    torque = scene.torque
    if torque is None:
        torque = scene.mean_force * gear_pair(scene.gear).base_radius1
    harmonics = scene.harmonics if scene.harmonics is not None else DEFAULT_HARMONICS
    return gear_excitation(scene.gear, torque, harmonics)
