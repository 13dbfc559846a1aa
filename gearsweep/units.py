"""Quantities with units: the one table of every kind of quantity a study or a result holds.

Each kind has its SI unit (what the kernel computes in), its *display* unit (what a study is
written in and what a result file stores, so that the numbers in the file are the numbers in the
study), the spellings a study may use, and whether a bare number is accepted. ``to_si`` parses a
study's value (pint underneath) into an SI float; ``to_display`` converts SI values for a result.

Rules (docs/study-reference.md, "Units"):

* A quantity is written as one number (optionally signed, decimal or exponent form, ``_`` only
  between digits; or a product or quotient of numbers, ``200*32/48 rpm``) followed by a unit
  expression with no number in it but its powers (``kN/mm``, ``N*s/mm``, ``kg m^2``, ``kN
  mm-1``, ``1/s``): pint's ``parse_units`` without a scaling factor. A unit with no number
  (``mm``), a number inside or after the unit (``3 mm 2``, ``3mm/2``) and other arithmetic on
  the number (``2**1000 mm``, ``(3) mm``, sums) are refused, each with its own message.
* A bare number in a dimensioned field is refused (``module: 3`` -> ``3 has no unit; write e.g.
  '3 mm', or '3 m' if SI was meant``), except 0 (zero in any unit) and a shaft speed, which is read in rpm.
* An inch or foot mark (``0.004"``, ``2'``: pint drops it, a bare number) and ``mil`` (pint's
  angular mil, not a thousandth of an inch: ``thou``) are refused, saying to write ``in``,
  ``ft``, ``thou``.
* A frequency given for a shaft speed (``50 Hz``, ``3 kHz``) is read as revolutions per second:
  50 Hz = 3000 rpm (pint alone would read it as 50 rad/s, 2 pi off). An angular rate in rad/s or
  deg/s is converted as such.
* The common spellings of engineers are accepted (``RPM``, ``rev/min``, ``r/min``; ``N m``,
  ``N*m``, ``N.m``, ``N·m``, ``Nm``, with any SI prefix: ``mNm``, ``daNm``, ``kNm``; ``N mm``,
  ``Nmm``; ``N s/mm``; ``um``, ``µm``, ``micron``).
"""

from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass
from functools import cache

import numpy as np

from gearsweep.errors import article
from gearsweep.files import atomic_write, cache_folder


@dataclass(frozen=True)
class Kind:
    """One kind of quantity."""

    name: str
    si: str
    """SI unit (pint spelling); speed: rpm, the kernel's own unit of shaft speed."""
    display: str
    """Unit a study is written in and a result stores (pint spelling)."""
    cf: str
    """The display unit as a UDUNITS string (the netCDF ``units`` attribute)."""
    examples: tuple[str, ...]
    """Accepted spellings, as a reader would write them (documented; each one tested)."""
    bare: bool = False
    """A bare number is accepted, read in the display unit."""


@dataclass(frozen=True)
class QuantityKind:
    """Marks a float field of a study model as a quantity of ``kind`` (read by the field
    reference generator, scripts/gen_study_reference.py)."""

    kind: str


KINDS: dict[str, Kind] = {k.name: k for k in (
    Kind("speed", "rpm", "rpm", "rpm", ("rpm", "RPM", "rev/min", "r/min", "U/min", "Hz (rev/s)",
                                         "kHz", "rad/s"), bare=True),
    Kind("frequency", "Hz", "Hz", "Hz", ("Hz", "kHz")),
    Kind("length", "m", "mm", "mm", ("mm", "m", "um", "µm", "micron", "in")),
    Kind("displacement", "m", "um", "um", ("um", "µm", "micron", "mm", "m")),
    Kind("velocity", "m/s", "mm/s", "mm s-1", ("mm/s", "m/s", "um/s")),
    Kind("mass", "kg", "kg", "kg", ("kg", "g")),
    Kind("force", "N", "N", "N", ("N", "kN")),
    Kind("torque", "N*m", "N*m", "N m", ("N m", "N*m", "N.m", "N·m", "Nm", "N mm", "Nmm",
                                        "kN m")),
    Kind("damping", "N*s/m", "N*s/mm", "N s mm-1", ("N s/mm", "N*s/mm", "N s/m", "kg/s")),
    Kind("stiffness", "N/m", "kN/mm", "kN mm-1", ("kN/mm", "N/um", "N/m", "N/mm")),
    Kind("inertia", "kg*m**2", "kg*m**2", "kg m2", ("kg m^2", "kg*m**2", "kg mm^2")),
    Kind("pressure", "Pa", "GPa", "GPa", ("GPa", "MPa", "Pa", "N/mm^2")),
    Kind("angle", "rad", "deg", "degree", ("deg", "degree", "rad")),
    Kind("dimensionless", "", "", "1", ("(a bare number)",), bare=True),
)}
"""The one table of quantities: kind -> SI unit, display unit, spellings."""

_INTEGER = re.compile(r"(?<![\w.])(?<![eE][-+])(\d[\d_]*)(?![\w.])")
"""An integer literal on its own (not part of a float, an exponent or a name)."""

_DIGITS = r"\d+(?:_\d+)*"
_NUM = rf"(?:{_DIGITS}(?:\.(?:{_DIGITS})?)?|\.{_DIGITS})(?:[eE][-+]?\d+)?"
"""A number without its sign: decimal or exponent form, an underscore only between digits."""
_NUMBER = re.compile(rf"^\s*[-+]?{_NUM}")
"""The number at the start of a quantity's text."""
_PLAIN = re.compile(rf"\s*([-+]?{_NUM})\s*(\S.*?)\s*")
"""A number and the text after it, as written (``to_si``'s fast path: the unit's kept factor)."""
_LEAD = re.compile(rf"\s*[-+]?\s*(?:{_NUM}|(?:inf(?:inity)?|nan)(?![A-Za-z_]))"
                   rf"(?:\s*[*/]\s*{_NUM})*", re.IGNORECASE)
"""The numeric part of a quantity: one number, optionally signed, or a product or quotient of
numbers (a gear ratio: ``200*32/48 rpm``)."""
_EXPONENT = re.compile(r"(?:\*\*|\^)\s*\(?\s*[-+]?\s*(?:\d+(?:\.\d*)?|\.\d+)")
"""A power of a unit (``m**2``, ``mm^-1``): the one place a unit expression has digits."""

_WORD_ALIASES = {"RPM": "rpm", "Rpm": "rpm", "micron": "um", "microns": "um"}
_NEWTON_WORD = re.compile(r"(da|[yzafpnuµmcdhkMGTPEZY]?)N(mm|m)?(s?)")
"""A newton metre, millimetre or second written as one word, with any SI prefix: ``Nm``,
``kNm``, ``mNm``, ``daNm``, ``Nmm``, ``Nms``, ``Ns``, ``kNs``, ``mNs``. pint reads ``Nm`` as a
"number metre" ([length] / [mass]): ``500 mNm`` and ``15 daNm`` were refused as torques while
``kNm``, an alias, was taken; ``kNs`` was an alias and ``mNs`` an unknown unit."""


def _word(word: str) -> str:
    m = _NEWTON_WORD.fullmatch(word)
    if m and (m[2] or m[3]):
        return f"{m[1]}N" + (f"*{m[2]}" if m[2] else "") + ("*s" if m[3] else "")
    return _WORD_ALIASES.get(word, word)


_SPELLINGS = (
    (re.compile(r"\b(?:rev|r|U)\s*/\s*min\b"), "rpm"),  # U/min: German for rpm
    (re.compile(r"\b(?:rev|r)\s*/\s*s\b"), "Hz"),
    (re.compile("[µμ]"), "u"),
    (re.compile(r"(?<=[A-Za-z])\s*[·.]\s*(?=[A-Za-z])"), "*"),
    (re.compile(r"(?<=[A-Za-z])\^"), "**"),
)
_WORD = re.compile(r"[A-Za-z_]+")
_UDUNITS_POWER = re.compile(r"(?<=[A-Za-z])(-?\d+)(?![\w.])")
"""A power written straight after a unit, as UDUNITS and the netCDF ``units`` attributes do
(``kN mm-1``, ``kg m2``): pint's ``**``. Only after the number (``1e9``'s ``e9`` is not one)."""
_SI_SHOWN = {"N*s/m": "N s/m"}
"""The SI units of ``KINDS`` as a study would write them, where pint's spelling differs."""
_ANGLE_UNITS = ("radian", "degree", "revolution", "turn", "arcminute", "arcsecond", "grade",
                "revolutions_per_minute", "revolutions_per_second", "cycle")


@cache
def registry():
    """The package's one unit registry (pint: imported and created on first use, not at import)."""
    import pint

    try:  # definitions parsed once and kept in the user cache folder: 0.1 s instead of 1 s
        return pint.UnitRegistry(cache_folder=":auto:")
    except Exception:  # noqa: BLE001 -- no cache folder (read-only home): parse them each time
        return pint.UnitRegistry()


class UnitParseError(ValueError):
    """A value that is not a quantity of the expected kind (message says what is allowed)."""


def normalise(text: str) -> str:
    """A quantity's text with the engineers' spellings turned into pint's (``30 Nm`` ->
    ``30 N*m``, ``1000 RPM`` -> ``1000 rpm``, ``5 µm`` -> ``5 um``, ``1073 kN mm-1`` ->
    ``1073 kN mm**-1``: the result files' own ``units`` spelling is read back)."""
    out = text.strip()
    for pattern, repl in _SPELLINGS:
        out = pattern.sub(repl, out)
    out = _WORD.sub(lambda m: _word(m.group(0)), out)
    m = _NUMBER.match(out)
    number, unit = (out[:m.end()], out[m.end():]) if m else ("", out)
    return number + _UDUNITS_POWER.sub(r"**\1", unit)


def _shown(value: object) -> str:
    return value if isinstance(value, str) else f"{value:g}" if isinstance(value, float) \
        else str(value)


def _bare(value: object, kind: Kind, number: float) -> float:
    if not math.isfinite(number):
        raise UnitParseError("expected a finite number (not nan or inf)")
    if kind.bare or number == 0.0:
        return number
    shown = _shown(value)
    hint = f"'{shown} {kind.examples[0]}'"
    if to_si(f"1 {kind.examples[0]}", kind.name) != 1.0:  # the study's unit is not SI:
        hint += f", or '{shown} {_SI_SHOWN.get(kind.si, kind.si)}' if SI was meant"  # say both
    raise UnitParseError(f"{shown} has no unit; write e.g. {hint}")


_UNIT_ONLY = re.compile(r"^[A-Za-z][A-Za-z_]*(?:(?:\*\*|\^)-?\d+)?"
                        r"(?:(?:\s*[*/]\s*|\s+)[A-Za-z][A-Za-z_]*(?:(?:\*\*|\^)-?\d+)?)*$")
"""A unit after the number that scales it linearly (``kN/mm``, ``N*s/mm``, ``kg*m**2``): its
factor is the same for every number, so it can be kept (``to_si``'s cache)."""


@cache
def _factor_cache_path():
    import hashlib
    from importlib.metadata import version
    from pathlib import Path

    source = Path(__file__).read_bytes()  # pint's version from its metadata: no import of pint
    key = hashlib.sha256(source + version("pint").encode()).hexdigest()[:16]
    return cache_folder(__file__) / f"unit_factors.{key}.json"


@cache
def _factors() -> dict:
    """(normalised unit, kind) -> SI value of one such unit, kept on disk beside the Numba cache:
    a study whose units were all seen before is read without building pint's registry (about
    0.5 s of every run's start-up). Keyed by this module's source and pint's version."""
    import json

    try:
        return json.loads(_factor_cache_path().read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _keep_factor(key: str, factor: float) -> None:
    import json

    table = _factors()
    table[key] = factor
    try:  # a concurrent writer may drop an entry: it is computed again next time
        path = _factor_cache_path()
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda fh: fh.write(json.dumps(table).encode()), durable=False)
    except OSError:  # a read-only installation: pint in every process
        pass


_LOOSE_UNDERSCORE = re.compile(r"(?<=\d)_(?!\d)|(?<![\w])_\d|__")
"""An underscore in a number that is not between two digits (Python's rule, and pint's)."""

_SPLIT_NUMBER = re.compile(r"\d\s+\d+(?:\.\d*)?(?=\s|$|[A-Za-z_])")
"""Digits, a space, a number that is not the start of a unit (``2 000 rpm``, not ``50 1/s``)."""


_PINT_SYMBOLS = frozenset("°¹²³⋅∙•·")
"""The non-ASCII symbols pint reads (degree sign, superscript powers, product dots); ``µ``/``μ``
are letters."""


_MARK = re.compile("''|[\"'\u2032\u2033]")
"""An inch or foot mark (``0.004"``, ``0.004''``, ``2'``, the primes ″ ′): pint's tokenizer
drops it, leaving a bare number (``0.004"`` was told "has no unit; write e.g. '0.004" mm'", and
``3"`` for a speed, where a bare number is rpm, was 3 rpm)."""


def _mark_refusal(value: str, mark: str, kind: str) -> UnitParseError:
    k = KINDS[kind]
    number = _NUMBER.match(value)
    written = number.group().strip() if number else "1"
    if mark == "'" and re.search(r"\d'\d", value):  # 2'000: a digit-group mark (Swiss)
        grouped = re.sub(r"(?<=\d)'(?=\d)", "", value.strip())
        return UnitParseError(f"{mark!r} between digits (a digit-group mark) is not read; write"
                              f" the number without it, e.g. '{grouped}'")
    inch = mark in ('"', "''", "\u2033")
    if k.si == "rad":  # in an angle, the marks are the arcsecond and the arcminute
        unit, what = ("arcsec", "an arcsecond mark") if inch else ("arcmin", "an arcminute mark")
    else:
        unit, what = ("in", "an inch mark") if inch else ("ft", "a foot mark")
    hint = (f"write {unit}, e.g. '{written} {unit}'" if k.si in ("m", "rad")
            else f"{article(kind)} is written e.g. '1 {k.examples[0]}'")
    return UnitParseError(f"{mark!r} ({what}) is not read as a unit; {hint}")


def _mil_refusal(value: str, kind: str) -> UnitParseError:
    """``4 mil`` is pint's angular mil (an angle, pi/32000 rad: a plain number to pint), not a
    thousandth of an inch: it was told "is a plain number (no dimension)"."""
    k = KINDS[kind]
    m = re.match(rf"\s*({_NUM})", value)
    if k.si == "m":
        n = float(m.group(1).replace("_", "")) if m else 1.0
        hint = f"write '{n:g} thou' or '{n / 1000:g} in'"
    else:
        hint = f"{article(kind)} is written e.g. '1 {k.examples[0]}'"
    return UnitParseError("'mil' is read as pint's angular mil (an angle, pi/32000 rad), not a"
                          f" thousandth of an inch; {hint}")


def _check_number_text(value: str, kind: str) -> None:
    """Refuse the number spellings that pint would read as something else, silently: a decimal
    comma (``4,92 N s/mm``: a tuple, which came out as 0) and digit groups apart (``2 000 rpm``:
    2 times 0 times rpm, also 0), an inch or foot mark (``_MARK``), and a symbol pint's
    tokenizer drops without a word (``㎜``, the minus sign U+2212 of ``−3 mm``, which came out
    as +3 mm, is read as '-' by ``to_si``)."""
    mark = _MARK.search(value)
    if mark is not None:
        raise _mark_refusal(value, mark.group(), kind)
    for ch in value:
        if ord(ch) > 127 and ch not in _PINT_SYMBOLS and unicodedata.category(ch)[0] in "SP":
            raise UnitParseError(f"the character {ch!r} (U+{ord(ch):04X}) in a quantity; write"
                                 " the number and its unit in plain letters (e.g. '-3 mm')")
    if "," in value:
        raise UnitParseError("a comma in a quantity; write the decimal separator as '.' (e.g."
                             " 4.92) and no thousands separators")
    if _SPLIT_NUMBER.search(value):
        raise UnitParseError("a space inside a number; write it without (e.g. 2000)")
    if _LOOSE_UNDERSCORE.search(value):  # ('1__0 mm' read as 10 mm, '1_ mm' as 1 mm)
        raise UnitParseError("an underscore in a number stands between two digits (e.g. 10_000)")


def to_si(value: object, kind: str) -> float:
    """Parse ``value`` (a number or a string with units) into a float in the SI unit of ``kind``.

    A quantity's text is one number (optionally signed, decimal or exponent form, ``_`` between
    digits; or a product or quotient of numbers, ``200*32/48 rpm``) followed by a unit
    expression with no number in it but its powers (``kN/mm``, ``N*s/mm``, ``kg m^2``,
    ``kN mm-1``, ``1/s``): ``_read_text``. A number followed by a unit whose factor is kept
    (``1073 kN/mm``) is that number times the factor, which pint computes once per unit and
    kind (``_factors``); anything else goes through pint.

    Raises
    ------
    UnitParseError
        With a message naming the expected kind and a unit to write.
    """
    if isinstance(value, str):
        m = _PLAIN.fullmatch(value)
        if m:  # the unit as written: its factor was kept once the text was read in full
            factor = _factors().get(f"{m.group(2)}|{kind}")
            if factor is not None:
                result = float(m.group(1)) * factor
                if math.isfinite(result):
                    return result
        return _read_text(value, kind)
    return _to_si_pint(value, kind)


def _read_text(value: str, kind: str) -> float:
    """``to_si`` of a string whose unit has no kept factor: the grammar checked, then the
    unit's factor computed and kept, or the whole text read by pint."""
    value = value.replace("\u2212", "-")  # the minus sign, which pint dropped (−3 mm: +3 mm)
    _check_number_text(value, kind)
    unit = _unit_expression(value, kind)
    m = _PLAIN.fullmatch(value)
    if m and unit is not None and _UNIT_ONLY.match(unit) and normalise(m.group(2)) == unit:
        key = f"{m.group(2)}|{kind}"
        factor = _factors().get(key)
        if factor is None:
            try:
                factor = _to_si_pint(f"1 {unit}", kind)
            except UnitParseError:
                factor = None  # the value itself goes through pint for its own message
            else:
                _keep_factor(key, factor)
        if factor is not None:
            result = float(m.group(1)) * factor
            if math.isfinite(result):
                return result
    return _to_si_pint(value, kind)


def _example(kind: str) -> str:
    unit = KINDS[kind].examples[0]
    return "'1'" if unit.startswith("(") else f"'1 {unit}'"


def _unit_expression(value: str, kind: str) -> str | None:
    """The unit expression after the number of ``value`` (pint's spelling; ``None`` where the
    text is a number alone), or ``UnitParseError`` where the text is not one number followed by
    a unit expression without a numeric scaling factor: a unit with no number (``mm``, read by
    pint as 1 mm), a number inside or after the unit (``3 mm 2``, 6 mm; ``3mm/2``), arithmetic
    on the number (``2**1000 mm``, ``(3) mm``), a sign in the unit (``3 rpm - 2 rpm``, ``N-m``)."""
    example = _example(kind)
    lead = _LEAD.match(value)
    if lead is None:
        text = normalise(value)
        if re.search(r"\d", _EXPONENT.sub("", text)):
            if re.match(r"\s*[-+]?\s*[^\W\d]", value):  # 'mm 2': the unit, then a number
                raise _number_in_unit(value.strip(), example)
            raise UnitParseError(_ARITHMETIC_REFUSED.format(example))  # '(3) mm', '+-3 mm'
        try:
            registry().parse_units(text.lstrip(" +-"))
        except Exception as exc:  # noqa: BLE001 -- pint raises many kinds of errors
            if getattr(exc, "unit_names", None):  # an unknown unit: pint's message names it
                return text
        raise UnitParseError(f"a number is missing: write e.g. {example}")
    written = value[lead.end():].strip()
    rest = normalise(written)
    if not rest:
        return None
    if rest.startswith(("**", "^")) or re.match(r"[*/]\s*[-+]", rest):  # '2**1000 mm', '3*-1 mm'
        raise UnitParseError(_ARITHMETIC_REFUSED.format(example))
    unit = rest[1:].lstrip() if rest.startswith("*") else rest  # '3*mm'
    unit = "1" + unit if unit.startswith("/") else unit  # '10/s': 10 (1/s)
    bare = _EXPONENT.sub("", re.sub(r"^1\s*(?=/)", "", unit))  # its words and operators
    if re.search(r"(?<![*/(\s])\s*[-+]", bare):  # (not an operand's sign, 'mm*-1') pint's sums:
        # '1 um - m' was -0.999999 m, '3rpm-2rpm' 1 rpm, '5N+1N' 6 N
        if _DASH.search(written) and not re.search(r"\s[+-]|[+-]\s", written):
            raise _dash_refusal(value, kind)  # 'N-m', '1um-m': a dash meant to join units
        raise UnitParseError("a sum or difference in a quantity; write one number and its unit"
                             " (e.g. '1 rpm', not '3 rpm - 2 rpm'; a range of a sweep is"
                             " {start: 600 rpm, stop: 4000 rpm, num: 8})")
    refusal = _number_in_unit(written, example)
    if re.search(r"\d", bare):
        raise refusal
    if _UNIT_ONLY.match(unit):  # words and powers: no scaling factor (and no pint to say so)
        return unit
    try:  # pint's own rule, for any scaling factor the digits above did not show
        registry().parse_units(unit)
    except ValueError as exc:
        if "scaling factor" in str(exc):
            raise refusal from None
    except Exception:  # noqa: BLE001,S110 -- an unknown unit: pint's message names it, later
        pass
    return unit


def _number_in_unit(written: str, example: str) -> UnitParseError:
    return UnitParseError(f"a number inside or after the unit ({written!r}): write one number,"
                          f" then its unit, e.g. {example}")


_ARITHMETIC_REFUSED = "arithmetic on the number: write the number it comes to, then its unit, e.g. {}"


_DASH = re.compile(r"[^\W\d_]\s*-\s*[^\W\d_]")
"""A minus between two units ('150 N-m', '1um-m')."""


def _dash_refusal(value: str, kind: str) -> UnitParseError:
    k = KINDS[kind]
    dash = (" (a '-' between units is a minus: join units with a space, '*' or '.')"
            if _DASH.search(value) else "")
    return UnitParseError(f"cannot read {value!r} as {article(kind)}{dash}; write e.g."
                          f" '1 {k.examples[0]}' ({', '.join(k.examples)})")


def _to_si_pint(value: object, kind: str) -> float:
    """``to_si`` through pint's registry."""
    try:
        return _to_si_pint_checked(value, kind)
    except OverflowError:  # pint's own arithmetic on the units: '0.1527 N**1527 kg' (a fuzz find)
        raise UnitParseError(f"cannot read {value!r}: a power of a unit or a number too large;"
                             f" {article(kind)} is written e.g. '1 {KINDS[kind].examples[0]}'"
                             ) from None


def _to_si_pint_checked(value: object, kind: str) -> float:
    """``_to_si_pint`` but for pint's OverflowError."""
    k = KINDS[kind]
    unit_hint = k.examples[0]
    if isinstance(value, bool):
        raise UnitParseError(f"expected {article(kind)} quantity such as '1 {unit_hint}'")
    if isinstance(value, int | float):
        try:
            number = float(value)
        except OverflowError:
            raise UnitParseError("a number too large for a float (at most about 1e308)") from None
        return _bare(value, k, number)
    if not isinstance(value, str):
        raise UnitParseError(f"expected a number or a string with {kind} units, e.g. '1 {unit_hint}'")
    try:  # a bare number in a string, e.g. YAML reads 1e8 (no dot) as text
        number = float(value)
    except ValueError:
        number = math.nan
    if math.isfinite(number):
        return _bare(value, k, number)
    import pint

    ureg = registry()
    try:
        # Integer literals become floats before pint evaluates the text: with Python integers a
        # power tower such as "10**10**10 N" would take forever; with floats it overflows at once.
        q = ureg.Quantity(_INTEGER.sub(r"\1.0", normalise(value)))
    except Exception as exc:  # pint raises many kinds of errors for malformed text
        names = getattr(exc, "unit_names", None)
        if names:  # pint's UndefinedUnitError
            unknown = ", ".join(repr(n) for n in names)
            raise UnitParseError(f"unknown unit {unknown}; {article(kind)} is written e.g."
                                 f" '1 {unit_hint}' ({', '.join(k.examples)})") from None
        # ('150 N-m' is N minus m to pint: its DimensionalityError's name was the message)
        raise _dash_refusal(value, kind) from None
    if not isinstance(q, pint.Quantity):
        return _bare(value, k, float(q))
    units = dict(q.unit_items())
    if not units and k.name != "dimensionless":
        return _bare(value, k, float(q.magnitude))
    # Root names: a prefixed angle ('3 krpm' is pint's kilorevolutions_per_minute) is one too.
    roots = {root for u in units for _, root, _ in ureg.parse_unit_name(u)} | set(units)
    if "mil" in roots:  # before the angle's checks: 'is not an angle', 'a plain number'
        raise _mil_refusal(value, kind)
    if k.name == "speed" and q.check("1/[time]") and not any(u in _ANGLE_UNITS for u in roots):
        # A frequency (Hz, kHz, 1/s) of a shaft is revolutions per unit time: 50 Hz = 3000 rpm.
        return _bare(value, KINDS["dimensionless"], float(q.to("1/min").magnitude))
    if k.name == "angle" and q.dimensionless and not any(u in _ANGLE_UNITS for u in roots):
        raise UnitParseError(f"{value!r} is not an angle; write e.g. '30 deg' or '0.5 rad'")
    if k.name not in ("angle", "speed") and any(u in _ANGLE_UNITS for u in roots):
        # pint takes an angle for a plain number: '0.5 mm/rad' was read as 0.5 mm, '5 deg*mm'
        # as 0.087 mm, '1 rad/s' as a frequency of 1 Hz (an outside tester's finding)
        if k.name not in ("dimensionless", "frequency") and q.check("1/[time]"):
            # '833 rpm' for a force is a shaft speed: not 'has an angle unit'
            raise UnitParseError(f"{value!r} is a shaft speed (rpm), expected {article(kind)}"
                                 f" (e.g. '1 {unit_hint}')")
        if k.name == "dimensionless":
            raise UnitParseError(f"{value!r} has an angle unit, which a plain number does not"
                                 " have; write the number alone, e.g. '2'")
        raise UnitParseError(f"{value!r} has an angle unit, which {article(kind)} does not have;"
                             f" write e.g. '1 {unit_hint}'")
    try:
        out = q.to(k.si) if k.si else q.to("dimensionless")
    except pint.DimensionalityError:
        found = next((other.name for other in KINDS.values() if other.si and other.name != k.name
                      and ureg.Quantity(1.0, other.si).dimensionality == q.dimensionality), None)
        what = (f"is {article(found)} ({shown_unit(KINDS[found].display)})" if found
                else f"has units of {q.dimensionality}")  # 'is a torque', not '[mass] * ...'
        if q.dimensionless and not any(u in _ANGLE_UNITS for u in roots):
            what = "is a plain number (no dimension)"  # '5 %': not 'an angle (deg)'
        raise UnitParseError(f"{what}, expected {kind} (e.g. '1 {unit_hint}')") from None
    result = float(out.magnitude)
    if not math.isfinite(result):
        raise UnitParseError("expected a finite number (not nan or inf)")
    return result


def shown_unit(unit: str) -> str:
    """A unit of pint's spelling as a study writes it: ``kg*m**2`` is ``kg m^2``, ``N*s/mm``
    ``N s/mm`` (each '*' made a space had said "is an inertia (kg m  2)")."""
    return unit.replace("**", "^").replace("*", " ")


@cache
def display_factor(kind: str) -> float:
    """Display value per SI value of ``kind`` (e.g. 1000 for a length: m -> mm); pint's, kept
    with ``to_si``'s factors."""
    k = KINDS[kind]
    if k.si == k.display:
        return 1.0
    key = f"display:{kind}"  # no "|": never the key of a unit ("3 display")
    factor = _factors().get(key)
    if factor is None:
        factor = float(registry().Quantity(1.0, k.si).to(k.display).magnitude)
        _keep_factor(key, factor)
    return factor


def to_display(values, kind: str):
    """SI values of ``kind`` in its display unit (same type: float, NumPy or dask array)."""
    f = display_factor(kind)
    if f == 1.0:
        return values
    return values * f if not isinstance(values, list | tuple) else np.asarray(values) * f


COORDINATE_DIGITS = 14
"""Significant digits of a swept coordinate in the result (``decimal_coordinates``)."""


def decimal_coordinates(values) -> np.ndarray:
    """Swept values in their display unit, rounded to ``COORDINATE_DIGITS`` significant digits.

    The kernel runs in SI, and the way back to the unit a study was written in multiplies twice
    (``100 um`` is 9.999999999999999e-05 m, and 0.09999999999999999 mm): rounding to 14 digits
    gives back the decimal number that was written (0.1), so that ``ds.sel(backlash=0.1)`` finds
    it, while a value that needs all 15-17 digits moves by at most 5e-15 of itself. Points inside
    a ``{start, stop, num}`` range are rounded the same way; select those with
    ``method="nearest"``."""
    out = np.asarray(values, dtype=float)
    flat = out.ravel().copy()
    ok = np.isfinite(flat) & (flat != 0.0)
    exp = np.zeros(flat.shape, dtype=int)
    exp[ok] = np.floor(np.log10(np.abs(flat[ok]))).astype(int)
    keep = COORDINATE_DIGITS - 1 - exp  # decimals kept; k = round(v 10^keep) has 14 digits
    up = ok & (keep >= 0) & (keep <= 22)  # 10^keep is exact: k / 10^keep is the nearest double
    down = ok & (keep < 0) & (keep >= -22)  # to the decimal k 10^-keep, as float("...") gives
    p = 10.0 ** np.abs(np.clip(keep, -22, 22))
    flat[up] = np.round(flat[up] * p[up]) / p[up]  # a tie in the 15th digit may round either way
    flat[down] = np.round(flat[down] / p[down]) * p[down]
    rest = ok & ~up & ~down  # beyond 1e-9 .. 1e35: by way of text (one number at a time)
    flat[rest] = [float(f"{v:.{COORDINATE_DIGITS}g}") for v in flat[rest]]
    return flat.reshape(out.shape)


def from_display(values, kind: str):
    """Display values of ``kind`` back in SI (the inverse of ``to_display``)."""
    f = display_factor(kind)
    if f == 1.0:
        return values
    return values / f if not isinstance(values, list | tuple) else np.asarray(values) / f


def si_values(da) -> np.ndarray:
    """The values of a result's coordinate or variable in SI, read through its ``units``
    attribute: a display unit of a known kind (``mm``, ``N s mm-1``, ``kN mm-1``, ``um``, ...)
    is converted, anything else (an SI or dimensionless unit) is returned as it is."""
    if not hasattr(da, "attrs") or not hasattr(da, "dims") or hasattr(da, "data_vars"):
        raise TypeError(f"si_values takes one variable or coordinate of a result (ds.p_rms,"
                        f" ds.backlash), not {article(type(da).__name__)}; a whole Dataset:"
                        " si_data_vars(ds)")
    units = da.attrs.get("units")
    values = np.asarray(da.values)
    for kind in KINDS.values():
        if units == kind.cf:
            return np.asarray(from_display(values, kind.name), dtype=float)
    return values


_SI_CF = {"m": "m", "N*s/m": "N s m-1", "N/m": "N m-1", "Pa": "Pa", "rad": "rad",
          "kg*m**2": "kg m2", "N*m": "N m", "N": "N", "kg": "kg", "Hz": "Hz", "rpm": "rpm"}
"""The SI unit of each kind as a UDUNITS string (pint spelling -> CF)."""


def si_data_vars(ds):
    """``ds`` (a result Dataset) with every data variable stored in a display unit (p in um,
    stiffness in kN/mm, ...) converted to SI, its ``units`` attribute saying so; coordinates
    are left in their display units. For code that computes in SI; idempotent."""
    if not hasattr(ds, "data_vars"):
        raise TypeError(f"si_data_vars takes a result Dataset, not {article(type(ds).__name__)}; one"
                        " variable: si_values(ds.p_rms)")
    out = ds.copy()
    for name in ds.data_vars:
        da = ds[name]
        kind = next((k for k in KINDS.values() if k.cf == da.attrs.get("units")), None)
        if kind is None or display_factor(kind.name) == 1.0:
            continue
        out[name] = da.copy(data=from_display(np.asarray(da.values, float), kind.name))
        out[name].attrs["units"] = _SI_CF[kind.si]
    return out
