"""Quantity fields of the study models: a string with units (``gearsweep.units``), parsed once into
SI. Every pydantic model of a study file (``schema``, ``gearscene``, ``analysis_specs``) takes its
dimensioned fields from here, so that a quantity is parsed and checked the same way everywhere;
and its integer and plain (dimensionless) float fields (``Count``, ``Real``: true and false are
not numbers).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import partial
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict, PrivateAttr

from gearsweep.units import QuantityKind, UnitParseError, to_si


def _parse(kind: str, value: Any) -> Any:
    try:
        out = to_si(value, kind)
    except UnitParseError as exc:
        raise ValueError(str(exc)) from None
    if not math.isfinite(out):
        raise ValueError("expected a finite number")
    return out


def Q(kind: str) -> Any:  # noqa: N802 -- reads as a type in the models
    """A float field given as a string with units of ``kind`` (see ``gearsweep.units``)."""
    return Annotated[float, BeforeValidator(partial(_parse, kind)), QuantityKind(kind)]


Length, Mass, Force, Torque = Q("length"), Q("mass"), Q("force"), Q("torque")
Damping, Stiffness, Inertia, Angle, Speed = (Q("damping"), Q("stiffness"), Q("inertia"),
                                            Q("angle"), Q("speed"))
Displacement, Pressure, Velocity = Q("displacement"), Q("pressure"), Q("velocity")


_EXPONENT = re.compile(r"\s*[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)[eE][-+]?[0-9]+\s*")
"""A number with an exponent (``1e3``) that YAML 1.1 leaves as text (YAML 1.2 reads it as a
float): pydantic's ``int`` could not parse the text, though it takes ``1.0e+3`` (a float)."""


def _whole(value: Any) -> Any:
    if isinstance(value, bool):
        raise ValueError("a whole number (not true or false)")
    if isinstance(value, str) and _EXPONENT.fullmatch(value):
        number = float(value)  # then as the float YAML 1.2 reads: whole, within the bounds
        if not math.isfinite(number):
            raise ValueError(f"a whole number ({value.strip()} is beyond the largest number,"
                             " about 1.8e308)")
        return number
    return value


MAX_STEPS_PER_PERIOD = 65536
"""The most steps per mesh period a study takes (``solver.steps_per_period``, an analysis'
``steps_per_period``; a spectrum's ``samples_per_period`` divides it)."""

MAX_TEETH = 1000
"""The most teeth of a scene's driving gear (``scene.teeth``)."""

MAX_SPEED = 1e6
"""The highest driving-gear speed a study takes [rpm]: ten times the fastest gears' 1e5 rpm. At
1e10 rpm and beyond the whole run lasts nanoseconds and p cannot move in it (at 1e160 rpm not a
bit of it: every statistic 0, taken as settled)."""

SPEED_BEYOND = (f"a speed of at most {MAX_SPEED:.0e} rpm (ten times the fastest gears'; beyond it"
                " the whole run lasts nanoseconds and p cannot move in it)")


MIN_SPEED = 1e-3
"""The lowest driving-gear speed a study takes [rpm]. Below it a mesh period lasts over a minute
even with the most teeth a scene takes (``MAX_TEETH``: 60 / (1000 x 1e-3 rpm) = 60 s), and a mesh
whose natural frequency is 1 kHz or more needs T omega_n / (h omega_n)* > 60 x 2 pi x 1000 / 3.46
= 1.1e5 steps per period to be stable (3.46: the largest stable h omega_n of RK5 over every
damping ratio, RK4's 2.96), beyond the most a study takes (``MAX_STEPS_PER_PERIOD``): no run
there can be stable (at 1e-300 rpm one ran, diverged, and the aliasing warning printed an
integer of 300 digits; an outside tester)."""

SPEED_BELOW = (f"a speed of at least {MIN_SPEED:g} rpm (below it a mesh period lasts over a"
               f" minute even with {MAX_TEETH} teeth, and a 1 kHz mesh needs more than the"
               f" {MAX_STEPS_PER_PERIOD} steps per period a study takes to be stable)")


def speed_bound(v: float) -> float:
    if v > MAX_SPEED:
        raise ValueError(SPEED_BEYOND)
    if v < MIN_SPEED:
        raise ValueError(SPEED_BELOW)
    return v


MAX_STE = 1e-3
"""The largest static transmission error a study takes, typed as a harmonic or sampled in an
excitation file [m]: an STE is micrometres to tens of micrometres (a tip relief, at most 0.1
module, bounds it on a 'gear'), so 1 mm is a unit slip ('5 m' for '5 um': a CSV sample of 1e30 um
validated and ran to p_rms 6e28 um with status 0; an outside tester's finding)."""

STE_BEYOND = (f"an STE of at most {MAX_STE * 1e3:g} mm (STEs are micrometres to tens of"
              " micrometres: a unit slip?)")

Count = Annotated[int, BeforeValidator(_whole)]
"""An integer field of a study (teeth, steps, periods, harmonics, ...): YAML's ``true`` and
``false`` are refused (pydantic's lax mode took them as 1 and 0); otherwise pydantic's ``int``."""


def _number(value: Any) -> Any:
    if isinstance(value, bool):
        raise ValueError("a number (not true or false)")
    return value


Real = Annotated[float, BeforeValidator(_number)]
"""A plain float field of a study, one without units (Mathieu's alpha, beta and gamma, a
tolerance, an order, a damping ratio, ...): YAML's ``true`` and ``false`` are refused (pydantic's
lax mode took them as 1.0 and 0.0); otherwise pydantic's ``float`` (bounds, messages)."""


_RATIO = re.compile(r"^\s*(\d+)\s*/\s*(\d+)\s*$")


def _ratio(value: Any) -> Any:
    value = _number(value)
    m = _RATIO.match(value) if isinstance(value, str) else None
    if m is None:
        return value
    if int(m.group(2)) == 0:
        raise ValueError("a number or a ratio such as 1/48 (not over 0)")
    return int(m.group(1)) / int(m.group(2))


Order = Annotated[float, BeforeValidator(_ratio)]
"""A harmonic's order in mesh orders: a number, or a ratio of whole numbers (``1/48``: once per
revolution of a 48-tooth driving gear), as ``Real`` otherwise."""


def _flag(value: Any) -> Any:
    if not isinstance(value, bool):
        raise ValueError("true or false")
    return value


Flag = Annotated[bool, BeforeValidator(_flag)]
"""A yes/no field of a study (kink_aware, a spectrum's force and pinion): only YAML's ``true``
and ``false`` (and ``yes``/``no``, which YAML reads as them); pydantic's lax mode took ``1``,
``0`` and the strings ``'true'``, ``'off'`` as well."""


SEL_APART = "ds.sel() cannot tell them apart"
"""Why a list whose entries become a result's coordinate takes each value once."""


@dataclass(frozen=True)
class EachOnce:
    """Marks a list field of a study model whose entries become a coordinate of the result or
    name what is computed: each value once (``schema.analysis_problems`` refuses a repeat, at
    the repeat's line, as a sweep's; values compared as the result holds them, a quantity's in
    its display unit, so '1 mm' and '1000 um' are one value). ``why``: what a repeat breaks."""

    why: str = SEL_APART


EACH_ONCE = EachOnce()


class FieldProblems(ValueError):
    """Problems a model's validator finds between fields of the model, each ``(fields,
    message)``: ``fields`` (relative to the model: ``mass``, ``web_width1``) are those the message
    is about. The study file's error is reported at the one of them the file writes on the latest
    line (the one written beside the other, likely the one to change), not at the model's own
    line; messages with none of their fields written (what is missing) are joined in one line at
    the model's. Its text, every message joined, is the error of a model validated from Python."""

    def __init__(self, problems: list[tuple[tuple[str, ...], str]]) -> None:
        self.problems = [(tuple(fields), message) for fields, message in problems]
        super().__init__("; ".join(message for _, message in self.problems))


class Strict(BaseModel):
    """A study model: unknown keys and non-finite numbers are errors; frozen once validated.

    Each model's validator is built when it first validates (``defer_build``), not when its
    class is made: a run of a dynamic study builds ``Study``'s and what it holds, not those of
    mesh and analysis studies (an 8-case study's whole run 0.481 -> 0.473 s, medians of 6
    alternating runs, 26 Nov 2026)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, defer_build=True)


class WholeStudy(Strict):
    """A whole study (dynamic, mesh or analysis): also the YAML text it was validated from, if
    any (``source_text``, set by ``schema.parse_study``), so that running it again runs that
    text, with its units and comments."""

    _source_text: str | None = PrivateAttr(default=None)
    _base_folder: str | None = PrivateAttr(default=None)
    """The folder its relative file paths were read from (``schema.parse_study``)."""

    @property
    def source_text(self) -> str | None:
        return self._source_text
