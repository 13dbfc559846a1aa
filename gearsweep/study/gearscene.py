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

This module is the study file's side: the ``gear:`` models and their translation into
:class:`GearPair` and :class:`TipRelief`; the physics is :mod:`gearsweep.gear.excitation`.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BeforeValidator, Field, model_validator

from gearsweep.errors import GeometryError
from gearsweep.gear import (
    GearPair,
    GeometryWarning,
    TipRelief,
    table1_as_printed,
    table1_consistent,
    table1_profile_shift,
)
from gearsweep.gear.compliance import SAINSOT_BORE_RATIO
from gearsweep.gear.excitation import DEFAULT_HARMONICS, GearExcitation, gear_excitation
from gearsweep.gear.geometry import _mm_down, _mm_up
from gearsweep.study.quantities import (
    Angle,
    Count,
    FieldProblems,
    Length,
    Pressure,
    Real,
    Strict,
)

PRESETS = {"table1_consistent": table1_consistent, "table1_as_printed": table1_as_printed,
           "table1_profile_shift": table1_profile_shift}
"""Named gear pairs a study can use as ``gear: NAME`` or ``gear: {preset: NAME, ...}``."""

class TipReliefSpec(Strict):
    """Tip relief of the driving, the driven or both gears (:class:`gearsweep.gear.TipRelief`)."""

    amount: Length = Field(ge=0, description="relief at the tip C_a [m]")
    shape: Literal["linear", "parabolic"] = "linear"
    start_at: Literal["single_contact"] | None = Field(
        None, description=("start where single-tooth contact ends on the gear's flank (long"
                           " relief); a contact ratio of 2 or more has none: refused"))
    start_radius: Length | None = Field(None, gt=0, description="radius where relief starts [m]")
    start_diameter: Length | None = Field(None, gt=0, description="diameter where it starts [m]")
    start_roll_angle: Angle | None = Field(None, gt=0, description="roll angle of the start [rad]")
    gears: Literal["both", "driving", "driven"] = Field("both", description="which gears are relieved")

    @model_validator(mode="after")
    def _one_start(self) -> TipReliefSpec:
        names = ("start_at", "start_radius", "start_diameter", "start_roll_angle")
        given = tuple(n for n in names if getattr(self, n) is not None)
        if len(given) != 1:  # two of them: at the line of the later (none: the relief's line)
            raise FieldProblems([(given, ("give exactly one of start_at, start_radius,"
                                  " start_diameter, start_roll_angle"))])
        return self


def _preset_name(value: Any) -> Any:
    return {"preset": value} if isinstance(value, str) else value


def _below_45_deg(angle: float) -> float:
    """A pressure angle below 45 deg, checked with the other fields (``GearPair.check`` said it
    only once the rest of the study passed, at the gear's line: an outside tester's finding)."""
    if not angle < math.pi / 4:
        raise ValueError("a pressure angle below 45 deg (involute spur gears: 14.5-30 deg, 20 deg"
                         " the standard)")
    return angle


def _external(value: Any) -> Any:
    """Teeth of an external gear: a negative count (an internal gear, as some codes write it)
    said only "greater than or equal to 3" (an outside tester)."""
    if isinstance(value, int | float) and not isinstance(value, bool) and value < 0:
        raise ValueError("internal gears are not supported (external spur pairs only): the"
                         " teeth of an external gear, at least 3")
    return value


Teeth = Annotated[Count, BeforeValidator(_external)]


class GearSpec(Strict):
    """A gear pair: a ``preset`` and/or the fields of :class:`gearsweep.gear.GearPair` with units."""

    preset: Literal["table1_consistent", "table1_as_printed", "table1_profile_shift"] | None = None
    module: Length | None = Field(None, gt=0, description="module [m]")
    z1: Teeth | None = Field(None, ge=3, le=10_000, description="teeth of the driving gear 1")
    z2: Teeth | None = Field(None, ge=3, le=10_000, description="teeth of the driven gear 2")
    face_width: Length | None = Field(None, gt=0, description="face width [m]")
    pressure_angle: Annotated[Angle, AfterValidator(_below_45_deg)] | None = Field(
        None, gt=0, description=(
        "reference pressure angle, below 45 deg (unset: 20 deg) [rad]"))
    x1: Real | None = Field(None, description="profile shift coefficient of gear 1")
    x2: Real | None = Field(None, description="profile shift coefficient of gear 2")
    tip_radius1: Length | None = Field(None, gt=0, description=(
        "tip radius (unset: m z1 / 2 + m (1 + x1), no tip shortening) [m]"))
    tip_radius2: Length | None = Field(None, gt=0)
    root_radius1: Length | None = Field(None, gt=0, description=(
        "root radius (unset: m z1 / 2 - m (1.25 - x1)) [m]"))
    root_radius2: Length | None = Field(None, gt=0)
    fillet_radius: Length | None = Field(None, gt=0, description=(
        "root fillet radius (unset: 0.38 module, which may not fit the tooth space at 25 deg) [m]"))
    centre_distance: Length | None = Field(None, gt=0)
    backlash: Length | None = Field(None, ge=0, description=(
        "circumferential backlash at the pitch circle (the pair's geometry: it thins the teeth"
        " for k(t) and e(t); a rattle or full scene's dead zone is scene.backlash or"
        " sweep.backlash, on the line of action, not taken from here) [m]"))
    thickness1: Length | None = Field(None, gt=0, description="tooth thickness at r [m]")
    thickness2: Length | None = Field(None, gt=0)
    youngs_modulus: Pressure | None = Field(None, gt=0, description=(
        "Young's modulus (unset: 206 GPa) [Pa]"))
    poisson: Real | None = Field(None, ge=0, lt=0.5, description="Poisson's ratio (unset: 0.3)")
    bore_radius1: Length | None = Field(None, gt=0, description=(
        "radius where the gear body is clamped to a rigid shaft, Sainsot et al.'s r_int (unset:"
        " half the root radius): root radius / bore radius from"
        f" {SAINSOT_BORE_RATIO[0]:g} to {SAINSOT_BORE_RATIO[1]:g}, where their fit holds; a"
        " larger one is stiffer (the rigid clamp nearer the teeth), so a thin rim is"
        " rim_thickness1, not this [m]"))
    bore_radius2: Length | None = Field(None, gt=0)
    rim_thickness1: Length | None = Field(None, gt=0, description=(
        "rim thickness below the root circle of a webbed gear, for ISO 6336-1's rim factor C_R,"
        " which softens the tooth (unset: a solid gear): at most the root radius less the bore"
        " radius (refused beyond); ISO states C_R for at least one module, and a thinner rim"
        " is taken at one module, with a warning [m]"))
    rim_thickness2: Length | None = Field(None, gt=0)
    web_width1: Length | None = Field(None, gt=0, description=(
        "web width of a webbed gear, with rim_thickness1 (unset: the face width): at most the"
        " face width (refused beyond); ISO states C_R for at least 0.2 of it, and a narrower"
        " web is taken at 0.2 face widths, with a warning [m]"))
    web_width2: Length | None = Field(None, gt=0)
    tip_relief: TipReliefSpec | None = None

    @model_validator(mode="after")
    def _complete(self) -> GearSpec:
        if self.preset is None:
            missing = [f for f in ("module", "z1", "z2", "face_width") if getattr(self, f) is None]
            if missing:
                raise ValueError(f"a gear needs a preset or {', '.join(missing)}")
        for g in (1, 2):  # a web carries a rim: alone it was ignored (ISO's C_R needs both)
            if getattr(self, f"web_width{g}") is not None and getattr(self,
                                                                     f"rim_thickness{g}") is None:
                raise FieldProblems([((f"web_width{g}",), (f"web_width{g} needs rim_thickness{g}"
                                      " (ISO 6336-1's rim factor takes both; a solid gear has"
                                      " neither)"))])
        return self

    def overrides(self) -> dict[str, Any]:
        """The GearPair fields this spec sets (SI), without preset and tip relief."""
        skip = {"preset", "tip_relief"}
        return {k: v for k, v in self if k not in skip and v is not None}


GearField = Annotated[GearSpec, BeforeValidator(_preset_name)]
"""A scene's ``gear:``: a preset name or a mapping (see :class:`GearSpec`)."""


@contextmanager
def warned_once() -> Iterator[None]:
    """A study's gear pair computed without its ``GeometryWarning`` (nearly pointed teeth): the
    study's validation warned it once, at the line of the field (``schema.gear_refusals``); each
    ``check`` of the computing after it said it again, at no field."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GeometryWarning)
        yield


def gear_pair(spec: GearSpec) -> GearPair:
    """The :class:`gearsweep.gear.GearPair` of a spec (not yet checked; see ``GearPair.check``)."""
    fields = spec.overrides()
    if spec.preset is not None:
        base = PRESETS[spec.preset]()
        if not fields:
            return base
        # The contact ratio range a preset's source states is about its own pair: a variant
        # inherited it (a 14.5 deg Table 1 of contact ratio 2.04, valid, was refused as outside
        # "the stated range [1, 2]": an outside tester).
        return dataclasses.replace(base, name=f"{base.name}, changed: {', '.join(fields)}",
                                   contact_ratio_range=None, **fields)
    return GearPair(name="gear pair", **fields)


def preset_centre_said(spec: GearSpec, pair: GearPair) -> str:
    """Where a preset's centre distance, which a variant keeps (the file writes none), is not the
    one its teeth and shifts give: that it is the preset's, and how to change it ("" otherwise).
    A preset at module 2 mm was told its fillets and its contact ratio, not the centre distance
    of 100 mm it kept (an outside tester)."""
    if spec.preset is None or spec.centre_distance is not None or pair.centre_distance is None:
        return ""
    if pair.own_centre_distance() is None:
        return ""
    return (f"; the centre distance {pair.centre_distance * 1e3:.5g} mm is preset {spec.preset}'s,"
            " kept when a variant changes its module, teeth or shifts: write centre_distance to"
            " change it")


MAX_RELIEF_MODULES = 0.1
"""Largest tip relief amount C_a taken, in modules (reliefs are tens of micrometres, some
hundredths of a module): a larger one is refused as a unit slip (an outside fuzz tester's
'amount: 10 m' gave a largest STE of 2,482,897 um)."""


def tip_reliefs(spec: GearSpec, pair: GearPair) -> tuple[TipRelief | None, TipRelief | None]:
    """The tip relief of gear 1 and gear 2 described by ``spec`` (None where not relieved)."""
    r = spec.tip_relief
    if r is None:
        return None, None
    if r.amount > MAX_RELIEF_MODULES * pair.module:  # ('10 m' for '10 um': an STE of 2.5 km)
        why = (f"{r.amount * 1e6:.6g} um is {r.amount / pair.module:.3g} modules; a tip relief"
               f" is at most {MAX_RELIEF_MODULES:g} module"
               f" ({MAX_RELIEF_MODULES * pair.module * 1e6:.4g} um here): a unit slip?")
        raise GeometryError(f"tip_relief.amount {why}", [(why, ("tip_relief.amount",))])
    if r.start_at == "single_contact" and pair.contact_ratio >= 2.0:
        # s_start + p_b is then inside a zone of two or more pairs (50/100 teeth at 15 deg,
        # eps 2.646: 62 % of the path relieved, validate ok; an outside tester)
        flanks = [f"gear {g}'s active flank is {_mm_up(2.0 * pair.contact_radii(s)[g - 1])} to"
                  f" {_mm_down(2.0 * pair.tip_radius[g - 1])} mm"
                  for g, s in ((1, pair.s_start), (2, pair.s_end))
                  if r.gears in ("both", ("driving", "driven")[g - 1])]
        why = (f"contact ratio {pair.contact_ratio:.3f}: no single-tooth contact (2 or more pairs"
               " carry the load everywhere), so no end of it to start the relief at; give"
               f" start_diameter (or start_radius, start_roll_angle): {', '.join(flanks)}")
        raise GeometryError(f"tip_relief.start_at {why}", [(why, ("tip_relief.start_at",))])
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


def reliefs(spec: GearSpec) -> tuple[TipRelief | None, TipRelief | None]:
    """The tip reliefs of a spec on its (checked) pair."""
    with warned_once():
        return tip_reliefs(spec, gear_pair(spec).check())


def scene_excitation(scene: Any, torque: float | None = None) -> GearExcitation:
    """:func:`gear_excitation` of a scene with a ``gear`` at ``torque`` [N m] (a swept load), or
    else at its mean ``torque`` or ``mean_force``.

    A ``mean_force`` F_m is turned into the torque ``F_m r_b1`` with the gear's base radius.
    """
    pair = gear_pair(scene.gear)
    if torque is None:
        torque = scene.torque
    if torque is None:
        torque = scene.mean_force * pair.base_radius1
    harmonics = scene.harmonics if scene.harmonics is not None else DEFAULT_HARMONICS
    with warned_once():
        return gear_excitation(pair, torque, reliefs(scene.gear), harmonics)
