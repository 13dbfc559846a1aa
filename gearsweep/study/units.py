"""Quantities with units, parsed once at the boundary (pint) into SI floats.

A study may write ``"5.5 N*s/mm"``, ``"50 N*m"``, ``"0.5 mm"`` or ``"8000 rpm"``; a bare number is
taken in the quantity's canonical unit (SI, except shaft speed, which is in rpm as in DATA.md).
"""

from __future__ import annotations

import math
import re
from functools import cache

import pint

# Canonical unit of every kind of quantity a study can hold: SI, except speed in rpm (DATA.md).
CANONICAL = {
    "speed": "rpm",
    "length": "m",
    "mass": "kg",
    "force": "N",
    "torque": "N*m",
    "damping": "N*s/m",
    "stiffness": "N/m",
    "inertia": "kg*m**2",
    "pressure": "Pa",
    "angle": "rad",
    "dimensionless": "",
}


_INTEGER = re.compile(r"(?<![\w.])(?<![eE][-+])(\d[\d_]*)(?![\w.])")
"""An integer literal on its own (not part of a float, an exponent or a name)."""


@cache
def registry() -> pint.UnitRegistry:
    """The package's one unit registry (created on first use, not at import)."""
    return pint.UnitRegistry()


class UnitParseError(ValueError):
    """A value that is not a quantity of the expected kind (message says what is allowed)."""


def to_si(value: object, kind: str) -> float:
    """Parse ``value`` (number or string with units) into a float in the canonical unit of ``kind``.

    Raises
    ------
    UnitParseError
        With a message naming the expected kind and unit.
    """
    target = CANONICAL[kind]
    if isinstance(value, bool):
        raise UnitParseError(f"expected a {kind} quantity such as '1 {target or '(no unit)'}'")
    if isinstance(value, int | float):
        try:
            return float(value)
        except OverflowError:
            raise UnitParseError("a number too large for a float (at most about 1e308)") from None
    if not isinstance(value, str):
        raise UnitParseError(f"expected a number or a string with {kind} units, e.g. '1 {target}'")
    try:  # a bare number in a string, e.g. YAML reads 1e8 (no dot) as text
        number = float(value)
    except ValueError:
        number = math.nan
    if math.isfinite(number):
        return number
    ureg = registry()
    try:
        # Integer literals become floats before pint evaluates the text: with Python integers a
        # power tower such as "10**10**10 N" would take forever; with floats it overflows at once.
        q = ureg.Quantity(_INTEGER.sub(r"\1.0", value.strip()))
    except Exception as exc:  # pint raises many kinds of errors for malformed text
        raise UnitParseError(f"cannot read {value!r} as a quantity ({type(exc).__name__})") from None
    if not isinstance(q, pint.Quantity):
        return float(q)
    try:
        out = q.to(target) if target else q.to("dimensionless")
    except pint.DimensionalityError:
        raise UnitParseError(
            f"has units of {q.dimensionality}, expected {kind} (e.g. {target or 'no unit'})"
        ) from None
    return float(out.magnitude)


def kind_of(value: object, kinds: tuple[str, ...]) -> str:
    """Which of ``kinds`` the quantity ``value`` is (e.g. a fluctuation given as force or torque)."""
    for kind in kinds:
        try:
            to_si(value, kind)
            return kind
        except UnitParseError:
            continue
    raise UnitParseError(f"expected one of: {', '.join(kinds)}")
