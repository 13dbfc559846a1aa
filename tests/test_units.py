"""The one table of quantities (gearsweep.units): spellings, bare numbers, shaft speed in Hz."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from gearsweep.units import KINDS, UnitParseError, display_factor, to_display, to_si


@pytest.mark.parametrize(("text", "kind", "si"), [
    ("1000 rpm", "speed", 1000.0),
    ("1000 RPM", "speed", 1000.0),
    ("1000 rev/min", "speed", 1000.0),
    ("1000 r/min", "speed", 1000.0),
    ("1000 U/min", "speed", 1000.0),  # Umdrehungen pro Minute (was read as enzyme units)
    ("30 N m", "torque", 30.0),
    ("30 N*m", "torque", 30.0),
    ("30 N.m", "torque", 30.0),
    ("30 N·m", "torque", 30.0),
    ("30 Nm", "torque", 30.0),
    ("30000 N mm", "torque", 30.0),
    ("30000 Nmm", "torque", 30.0),
    # a newton metre in one word with an SI prefix (mNm, daNm were "[length] / [mass]": pint
    # reads Nm as a "number metre"; kNm alone was an alias)
    ("500 mNm", "torque", 0.5),
    ("15 daNm", "torque", 150.0),
    ("2 kNm", "torque", 2000.0),
    ("5 cNm", "torque", 0.05),
    ("3 MNm", "torque", 3e6),
    ("2 kNmm", "torque", 2.0),
    ("2 nNm", "torque", 2e-9),  # every SI prefix, as the README says (nNm, PNm were refused)
    ("1 PNm", "torque", 1e15),
    ("5 mNs/mm", "damping", 5.0),  # a newton second too (kNs was an alias, mNs unknown)
    ("5.5 kNs/m", "damping", 5500.0),
    ("5.5 N s/mm", "damping", 5500.0),
    ("5500 N s/m", "damping", 5500.0),
    ("5 um", "displacement", 5e-6),
    ("5 µm", "displacement", 5e-6),
    ("5 μm", "displacement", 5e-6),  # Greek mu as well as the micro sign
    ("5 micron", "displacement", 5e-6),
    ("0.1 mm", "length", 1e-4),
    ("1073 kN/mm", "stiffness", 1.073e9),
    ("90 deg", "angle", math.pi / 2),
    ("0.1527 kg", "mass", 0.1527),
])
def test_each_spelling_parses_to_the_right_quantity(text, kind, si):
    assert to_si(text, kind) == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize(("text", "rpm"), [
    ("50 Hz", 3000.0), ("0.05 kHz", 3000.0), ("50 rev/s", 3000.0), ("50 1/s", 3000.0),
    ("100 rad/s", 100 * 60 / (2 * math.pi)), ("360 deg/s", 60.0),
    ("3 krpm", 3000.0), ("3 kilorpm", 3000.0),  # prefixed rpm: an angular rate, not 2 pi off
    ("50 rps", 3000.0), ("50 revolutions_per_second", 3000.0),  # pint's rps: 2 pi rad/s, not 2 pi rev/s
])
def test_a_shaft_speed_in_hz_is_revolutions_per_second(text, rpm):
    """50 Hz at a shaft is 3000 rpm, not 50 rad/s (477.5 rpm): never 2 pi off."""
    assert to_si(text, "speed") == pytest.approx(rpm, rel=1e-12)


@pytest.mark.parametrize(("value", "kind", "message"), [
    (3, "length", "3 has no unit; write e.g. '3 mm', or '3 m' if SI was meant"),
    ("0.1", "length", "0.1 has no unit; write e.g. '0.1 mm', or '0.1 m' if SI was meant"),
    (0.1527, "mass", "0.1527 has no unit; write e.g. '0.1527 kg'"),
    # A user who meant N/m is shown N/m: the study's unit alone led to 1e9 kN/mm (1e15 N/m),
    # which validated.
    (1e9, "stiffness", ("1e+09 has no unit; write e.g. '1e+09 kN/mm', or '1e+09 N/m' if SI was"
                       " meant")),
    (2, "damping", "2 has no unit; write e.g. '2 N s/mm', or '2 N s/m' if SI was meant"),
    (0.5, "angle", "0.5 has no unit; write e.g. '0.5 deg', or '0.5 rad' if SI was meant"),
    (5, "torque", "5 has no unit; write e.g. '5 N m'"),
])
def test_a_bare_number_in_a_dimensioned_field_is_refused(value, kind, message):
    with pytest.raises(UnitParseError) as err:
        to_si(value, kind)
    assert str(err.value) == message


@pytest.mark.parametrize(("value", "kind", "message"), [
    ("4,92 N*s/mm", "damping", "a comma in a quantity"),
    ("0,1527 kg", "mass", "a comma in a quantity"),
    ("300,5 N", "force", "a comma in a quantity"),
    ("2 000 rpm", "speed", "a space inside a number"),
    ("1 073 kN/mm", "stiffness", "a space inside a number"),
    ("1__0 mm", "length", "an underscore in a number stands between two digits"),
    ("1_ mm", "length", "an underscore in a number stands between two digits"),
])
def test_decimal_commas_and_digit_gaps_are_refused(value, kind, message):
    """pint reads '4,92 N*s/mm' as a tuple and '2 000 rpm' as 2 * 0 rpm: both came out as 0.0
    and a study ran with no damping (an outside reader's finding); now one line says why.
    '1__0 mm' was read as 10 mm and '1_ mm' as 1 mm (pint refuses both; an outside fuzz
    tester); an underscore between digits groups them, as in Python."""
    with pytest.raises(UnitParseError, match=message):
        to_si(value, kind)
    assert to_si("10_000 rpm", "speed") == 10000.0


def test_an_unknown_unit_is_named_with_the_spellings_of_its_kind():
    """pint's UndefinedUnitError was the message; now the unit and what to write instead."""
    with pytest.raises(UnitParseError) as err:
        to_si("1073 kN/mmm", "stiffness")
    assert str(err.value) == ("unknown unit 'mmm'; a stiffness is written e.g. '1 kN/mm'"
                              " (kN/mm, N/um, N/m, N/mm)")
    assert to_si("4.92 Ns/mm", "damping") == pytest.approx(4920.0)  # as 'Nm' is N*m


@pytest.mark.parametrize(("text", "kind", "message"), [
    ("150 N-m", "torque", ("cannot read '150 N-m' as a torque (a '-' between units is a minus:"
     " join units with a space, '*' or '.'); write e.g. '1 N m' (N m, N*m, N.m, N\u00b7m, Nm,"
     " N mm, Nmm, kN m)")),
    ("5 N s-mm", "damping", ("cannot read '5 N s-mm' as a damping (a '-' between units is a"
     " minus")),
    ("3 mm)", "length", "cannot read '3 mm)' as a length; write e.g. '1 mm' (mm, m,"),
])
def test_a_quantity_pint_cannot_read_says_what_to_write(text, kind, message):
    """'150 N-m' (pint: N minus m) said only "cannot read '150 N-m' as a quantity
    (DimensionalityError)": pint's exception name, not what to write (an engineer new to the
    tool)."""
    with pytest.raises(UnitParseError) as err:
        to_si(text, kind)
    assert str(err.value).startswith(message), str(err.value)


def test_a_unit_to_a_huge_power_is_a_unit_error_not_a_traceback():
    """``mass: 0.1527 N**1527 kg`` (a mutation test_study_fuzz found) overflowed inside pint's
    dimensionality check: an OverflowError, a traceback and exit code 1."""
    with pytest.raises(UnitParseError, match="a power of a unit or a number too large; a mass is"
                       " written e.g. '1 kg'"):
        to_si("0.1527 N**1527 kg", "mass")
    with pytest.raises(UnitParseError, match="too large"):
        to_si("1 N**400 kg", "torque")


def test_documented_exceptions_to_the_bare_number_rule():
    assert to_si(3000, "speed") == 3000.0  # a shaft speed is read in rpm (study reference)
    assert to_si(0, "length") == 0.0  # zero is zero in any unit
    assert to_si(0.25, "dimensionless") == 0.25


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, "nan", "inf mm", "nan mm", "-inf N m"])
def test_non_finite_is_refused(value):
    with pytest.raises(UnitParseError, match="finite"):
        to_si(value, "torque" if "N" in str(value) else "length")


def test_display_units_round_trip_and_every_kind_is_complete():
    for name, k in KINDS.items():
        assert k.name == name and k.cf and k.examples
        display_factor(name)
    assert to_display(1e-4, "length") == pytest.approx(0.1)
    assert to_display(1e-6, "displacement") == pytest.approx(1.0)
    assert to_display(5500.0, "damping") == pytest.approx(5.5)
    assert to_display(1.073e9, "stiffness") == pytest.approx(1073.0)
    assert to_display(3000.0, "speed") == 3000.0


def test_decimal_coordinates_round_to_14_significant_digits():
    """The vectorised rounding equals Python's own 14-digit rounding of each value (the decimal
    text read back), apart from ties in the 15th digit, which may round the other way (within
    one unit of the 14th digit), over 24 decades and both signs; non-finite values and zero
    pass through."""
    from gearsweep.units import decimal_coordinates

    rng = np.random.default_rng(7)
    v = np.concatenate([rng.uniform(-1e6, 1e6, 20_000), 10.0 ** rng.uniform(-12, 12, 20_000)])
    ref = np.array([float(f"{x:.14g}") for x in v])
    got = decimal_coordinates(v)
    differ = got != ref
    assert differ.mean() < 0.01
    assert np.all(np.abs(got[differ] - ref[differ]) <= 1.01e-13 * np.abs(ref[differ]))
    special = np.array([0.09999999999999999, 0.7000000000000001, 3000.0000000000005, 0.0,
                        np.nan, np.inf, 1e-320, 1e300])
    np.testing.assert_array_equal(decimal_coordinates(special),
                                  [0.1, 0.7, 3000.0, 0.0, np.nan, np.inf, 1e-320, 1e300])


def test_swept_coordinates_are_in_the_studys_units():
    """``ds.sel(backlash=0.1)`` for a study that swept ``backlash: [100 um, 0.2 mm]``, and the
    same for values whose way through SI is not exact in floating point (100 um -> 1e-4 m ->
    0.09999999999999999 mm, 0.7 N s/mm -> 0.7000000000000001, 50 Hz -> 3000 rpm, the points of
    a range 0.1-0.7 mm: an outside reader's sel() raised KeyError on each before the
    coordinates were rounded to 14 significant digits)."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    text = """\
title: units in the file
scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, backlash: 0.1 mm,
        mean_force: 100 N, fluctuation: [{amplitude: 300 N, order: 1}]}
sweep:
  backlash: [100 um, 0.2 mm]
  damping: [100 N s/m, 0.7 N s/mm, 5.5 N s/mm]
  speed: [50 Hz, 6000 rpm]
solver: {steps_per_period: 32, transient_periods: 4, record_periods: 4}
"""
    ds = run_study(parse_study(text, "u.yaml"), text)
    assert ds["backlash"].attrs["units"] == "mm" and ds["damping"].attrs["units"] == "N s mm-1"
    assert ds["speed"].attrs["units"] == "rpm"
    assert ds.sel(backlash=0.1).sizes["damping"] == 3
    assert ds.sel(backlash=0.1, damping=0.7, speed=3000.0).p_rms.size == 1
    assert list(ds["damping"].values) == [0.1, 0.7, 5.5]  # exactly the decimals written
    assert list(ds["backlash"].values) == [0.1, 0.2]
    ranged = text.replace("backlash: [100 um, 0.2 mm]",
                          "backlash: {start: 0.1 mm, stop: 0.7 mm, num: 7}")
    ds = run_study(parse_study(ranged, "u.yaml"), ranged)
    assert list(ds["backlash"].values) == [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    for name in ds.variables:
        assert ds[name].attrs.get("units") != "-", name


def test_data_variables_are_in_display_units_too():
    """p in um (the mean deflection F_m / k0 of a linear scene), spectra in um, and
    ``si_data_vars`` gives SI back."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study
    from gearsweep.units import si_data_vars

    text = """\
title: p in um
scene: {kind: whine, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, damping: 5.5 N s/mm,
        mean_force: 100 N}
sweep:
  speed: [3000 rpm, 6000 rpm]
solver: {steps_per_period: 32, transient_periods: 40, record_periods: 4}
outputs: [stats, {spectrum: {max_order: 2}}]
"""
    ds = run_study(parse_study(text, "u.yaml"), text)
    static_um = 100.0 / 1.073e9 * 1e6  # F_m / k0 = 0.0932 um
    for name in ("p_rms", "p_pp", "p_mean", "spectrum"):
        assert ds[name].attrs["units"] == "um", name
    assert ds["p_mean"].values == pytest.approx([static_um] * 2, rel=1e-9)
    assert ds["spectrum"].sel(order=0.0).values == pytest.approx([static_um] * 2, rel=1e-9)
    si = si_data_vars(ds)
    assert si["p_mean"].attrs["units"] == "m"
    assert si["p_mean"].values == pytest.approx([static_um * 1e-6] * 2, rel=1e-12)
    assert si_data_vars(si)["p_mean"].values == pytest.approx(si["p_mean"].values)  # idempotent
    assert ds["speed"].values.tolist() == [3000.0, 6000.0]  # coordinates untouched


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_the_kept_unit_factors_give_pints_numbers(kind):
    """``to_si`` reads 'number unit' as number x the unit's kept factor: for every documented
    spelling the same float as pint on the whole text (bit for bit), twice (computed, then kept)."""
    from gearsweep.units import _to_si_pint

    for spelling in KINDS[kind].examples:
        if spelling.startswith("("):
            continue
        unit = spelling.split(" (")[0]
        for number in ("0.1", "2.5", "-3e-2", "1073"):
            text = f"{number} {unit}"
            try:
                want = _to_si_pint(text, kind)
            except UnitParseError:
                continue
            assert to_si(text, kind) == want, text
            assert to_si(text, kind) == want, text  # from the kept factor
    with pytest.raises(UnitParseError, match="expected"):
        to_si("3 mm", "stiffness")  # a wrong unit still gets pint's message
    assert to_si("200*32/48 rpm", "speed") == pytest.approx(133.333333333)  # arithmetic: pint


def test_a_percentage_for_a_dimensioned_field_is_not_called_an_angle():
    with pytest.raises(UnitParseError, match="is a plain number") as err:
        to_si("5 %", "damping")  # it was called 'an angle (deg)'
    assert "angle" not in str(err.value)


def test_si_helpers_refuse_the_wrong_kind_of_object():
    """si_values of a whole Dataset returned a bound method wrapped in an array (an outside
    reader's finding); each helper now names the other for the other kind of object."""
    import xarray as xr

    from gearsweep.units import si_data_vars, si_values

    ds = xr.Dataset({"p_rms": ("x", [1.0], {"units": "um"})}, coords={"x": [0.0]})
    assert si_values(ds.p_rms)[0] == pytest.approx(1e-6)
    with pytest.raises(TypeError, match="si_data_vars"):
        si_values(ds)
    with pytest.raises(TypeError, match="si_data_vars"):
        si_values(np.array([1.0]))
    with pytest.raises(TypeError, match=r"si_values\(ds\.p_rms\)"):
        si_data_vars(ds.p_rms)


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "dimensionless"])
def test_the_units_a_result_file_writes_are_read_back(kind):
    """Every kind's netCDF ``units`` spelling (UDUNITS: ``kN mm-1``, ``N s mm-1``, ``kg m2``),
    copied from a result or the reference into a study, is its display unit. ``kN mm-1`` was
    refused (pint reads ``mm-1`` as mm minus 1)."""
    k = KINDS[kind]
    assert to_si(f"2.5 {k.cf}", kind) == to_si(f"2.5 {k.display}", kind)


@pytest.mark.parametrize(("text", "kind", "si"), [
    ("1073 kN mm-1", "stiffness", 1.073e9), ("5.5 N s mm-1", "damping", 5500.0),
    ("2 kg m2", "inertia", 2.0), ("1e3 N m-2", "pressure", 1e3), ("1e-3 m", "length", 1e-3),
    ("4 mm**1", "length", 4e-3),
])
def test_udunits_powers_after_a_unit(text, kind, si):
    assert to_si(text, kind) == pytest.approx(si, rel=1e-15)


def test_the_unit_and_step_limit_caches_follow_numba_cache_dir(tmp_path):
    """A read-only installation points NUMBA_CACHE_DIR at a writable folder: the unit factors
    and the step-limit tables are kept there too (they were written beside the package whatever
    it said, refused there, and pint's registry was built again by every run)."""
    import os
    import subprocess
    import sys

    code = ("from gearsweep.units import to_si; from gearsweep.study.plan import _hw_table;"
            " to_si('50000 N*mm', 'torque'); _hw_table('rk4')")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    subprocess.run([sys.executable, "-c", code], env=env, check=True)
    kept = sorted(p.name.split(".")[0] for p in (tmp_path / "gearsweep").iterdir())
    assert kept == ["hw_table", "unit_factors"]


def test_an_unusable_numba_cache_dir_leaves_the_caches_beside_the_package(tmp_path, monkeypatch):
    """Numba passes over a NUMBA_CACHE_DIR it cannot make and caches in the package's
    __pycache__; the unit and step-limit caches were then kept nowhere (every run built pint's
    registry again, 0.69 s against 0.37 s a `gearsweep validate`). They follow Numba there."""
    from pathlib import Path

    import gearsweep.units as u
    from gearsweep.files import cache_folder

    (tmp_path / "a_file").write_text("", encoding="utf-8")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "a_file" / "cache"))
    assert cache_folder(u.__file__) == Path(u.__file__).parent / "__pycache__"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))  # one it can make: there
    assert cache_folder(u.__file__) == tmp_path / "cache" / "gearsweep"


@pytest.mark.parametrize(("text", "kind"), [("0.5 mm/rad", "length"), ("5 deg*mm", "length"),
                                            ("3 N*m/rad", "torque"), ("1 rad/s", "frequency"),
                                            ("1073 kN/mm/rad", "stiffness"),
                                            ("2 rad", "dimensionless")])
def test_an_angle_unit_in_a_quantity_that_has_none_is_refused(text, kind):
    """pint reads an angle as a plain number: '0.5 mm/rad' was taken for 0.5 mm and '1 rad/s'
    for a frequency of 1 Hz (2 pi off; an outside tester's finding). An angle and a speed keep
    theirs."""
    with pytest.raises(UnitParseError, match="has an angle unit"):
        to_si(text, kind)
    assert to_si("30 deg", "angle") == pytest.approx(math.pi / 6)
    assert to_si("2 pi rad/s", "speed") == pytest.approx(60.0)


@pytest.mark.parametrize(("text", "kind"), [("833 rpm", "force"), ("2 rad/s", "torque"),
                                            ("3 krpm", "length")])
def test_a_shaft_speed_where_another_quantity_belongs_is_named_a_speed(text, kind):
    """'833 rpm' given for a mean force was 'has an angle unit' (rpm is no angle to a user);
    it is named a shaft speed, as '1 m' for a mass is named a length."""
    with pytest.raises(UnitParseError, match=rf"^'{text}' is a shaft speed \(rpm\), expected a"):
        to_si(text, kind)


@pytest.mark.parametrize(("text", "kind"), [("1 um - m", "length"), ("3 rpm - 2 rpm", "speed"),
                                            ("5 N + 1 N", "force"), ("3 rpm -2 rpm", "speed")])
def test_a_sum_or_difference_is_not_a_quantity(text, kind):
    """pint added and subtracted: '1 um - m' was -0.999999 m, '3 rpm - 2 rpm' 1 rpm (an
    adversarial review); a sign in front, an exponent and a UDUNITS power stay numbers."""
    with pytest.raises(UnitParseError, match="a sum or difference in a quantity"):
        to_si(text, kind)


def test_a_range_written_as_a_difference_is_shown_the_sweeps_range():
    """``speed: '600-4000 rpm'`` meant a range: the line now shows {start, stop, num} (it said
    only "a sum or difference"; an outside tester), and 'RK4' is matched to 'rk4'."""
    with pytest.raises(UnitParseError, match=r"a range of a sweep is \{start: 600 rpm, stop:"):
        to_si("600-4000 rpm", "speed")
    from gearsweep.errors import StudyError
    from gearsweep.study.schema import parse_study

    text = ("title: t\nscene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm,"
            " backlash: 0.1 mm, speed: 3000 rpm}\nsolver: {method: RK4}\n")
    with pytest.raises(StudyError, match=r"solver.method: 'RK4' -- did you mean 'rk4'\?"):
        parse_study(text, "s.yaml")


@pytest.mark.parametrize(("text", "kind", "si"), [("-5 N", "force", -5.0), ("+3 mm", "length", 3e-3),
                                                  ("1e-3 m", "length", 1e-3),
                                                  ("1073 kN mm-1", "stiffness", 1.073e9)])
def test_signs_exponents_and_powers_are_not_sums(text, kind, si):
    assert to_si(text, kind) == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize(("text", "kind", "si"), [("\u22123 mm", "length", -3e-3),
                                                  ("\u22125 N", "force", -5.0),
                                                  ("30 \u00b0", "angle", math.pi / 6),
                                                  ("3 N\u22c5m", "torque", 3.0)])
def test_the_unicode_minus_sign_is_a_minus(text, kind, si):
    """pint's tokenizer dropped U+2212: '\u22123 mm' was +3 mm (a fuzz find); the symbols pint
    reads (degree sign, product dot) stay accepted."""
    assert to_si(text, kind) == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize(("text", "kind", "match"), [
    ("3 \u339c", "length", "U\\+339C"),  # the squared 'mm' symbol: read as a bare 3
    ("3 \u339c", "speed", "U\\+339C"),  # (3 rpm, silently)
    ("3 rpm \u2212 2 rpm", "speed", "a sum or difference")])
def test_a_symbol_pint_drops_is_refused(text, kind, match):
    with pytest.raises(UnitParseError, match=match):
        to_si(text, kind)


@pytest.mark.parametrize(("text", "kind", "match"), [
    ("3rpm-2rpm", "speed", "a sum or difference"), ("5N+1N", "force", "a sum or difference"),
    ("1 mm-1um", "length", "a sum or difference"), ("3 rpm+2rpm", "speed", "a sum or difference"),
    ("1um-m", "length", "a '-' between units is a minus")])
def test_a_sum_or_difference_without_spaces_is_not_a_quantity(text, kind, match):
    """The sum check looked for a space beside the sign: '3rpm-2rpm' was 1 rpm, '5N+1N' 6 N and
    '1um-m' -0.999999 m (pint's arithmetic; a fuzz find)."""
    with pytest.raises(UnitParseError, match=match):
        to_si(text, kind)


@pytest.mark.parametrize(("text", "kind", "si"), [("2e-3mm", "length", 2e-6),
                                                  ("1E+3 mm", "length", 1.0),
                                                  ("1 kg m-2 s-1 m2 s", "mass", 1.0),
                                                  ("1 m**-1 m**2", "length", 1.0)])
def test_exponents_and_powers_without_spaces_stay_numbers(text, kind, si):
    assert to_si(text, kind) == pytest.approx(si, rel=1e-12)


MISSING = "a number is missing: write e.g. {}"
IN_UNIT = "a number inside or after the unit ({!r}): write one number, then its unit, e.g. {}"
ARITHMETIC = "arithmetic on the number: write the number it comes to, then its unit, e.g. {}"


@pytest.mark.parametrize(("text", "kind", "message"), [
    ("mm", "length", MISSING.format("'1 mm'")),  # was 1 mm
    ("kN/mm", "stiffness", MISSING.format("'1 kN/mm'")),
    ("rpm", "speed", MISSING.format("'1 rpm'")),
    ("-mm", "length", MISSING.format("'1 mm'")),  # was -1 mm
    ("kg m2", "inertia", MISSING.format("'1 kg m^2'")),
    ("", "length", MISSING.format("'1 mm'")),
    ("mm", "dimensionless", MISSING.format("'1'")),
    ("3 mm 2", "length", IN_UNIT.format("mm 2", "'1 mm'")),  # was 6 mm
    ("3 mm 2", "speed", IN_UNIT.format("mm 2", "'1 rpm'")),  # was 'is a length'
    ("3mm/2", "length", IN_UNIT.format("mm/2", "'1 mm'")),  # was 1.5 mm
    ("3 mm*2", "length", IN_UNIT.format("mm*2", "'1 mm'")),
    ("3 mm 1", "length", IN_UNIT.format("mm 1", "'1 mm'")),  # harmless to pint, still a typo
    ("3 mm*-1", "length", IN_UNIT.format("mm*-1", "'1 mm'")),  # was -3 mm
    ("3 (2) mm", "length", IN_UNIT.format("(2) mm", "'1 mm'")),
    ("1.5.3 mm", "length", IN_UNIT.format(".3 mm", "'1 mm'")),  # was 0.45 mm
    ("mm 2", "length", IN_UNIT.format("mm 2", "'1 mm'")),  # was 2 mm
    ("1073 kN/mm 2", "stiffness", IN_UNIT.format("kN/mm 2", "'1 kN/mm'")),
    ("4.92 N*s/mm*10", "damping", IN_UNIT.format("N*s/mm*10", "'1 N s/mm'")),
    ("2**1000 mm", "length", ARITHMETIC.format("'1 mm'")),  # was 1.07e298 m
    ("2^3 mm", "length", ARITHMETIC.format("'1 mm'")),
    ("(3) mm", "length", ARITHMETIC.format("'1 mm'")),
    ("-(3) mm", "length", ARITHMETIC.format("'1 mm'")),
    ("(3 mm)", "length", ARITHMETIC.format("'1 mm'")),
    ("+-3 mm", "length", ARITHMETIC.format("'1 mm'")),
    ("6/-2 mm", "length", ARITHMETIC.format("'1 mm'")),  # was -3 mm
    ("2**3", "dimensionless", ARITHMETIC.format("'1'")),  # was 8
    ("(3000)", "speed", ARITHMETIC.format("'1 rpm'")),  # was 3000 rpm
])
def test_a_quantity_is_one_number_and_a_unit_expression(text, kind, message):
    """A quantity's text is one number followed by a unit expression without a numeric scaling
    factor: pint read the rest as arithmetic, silently ('3 mm 2' was 6 mm, 'mm' 1 mm, '3mm/2'
    1.5 mm; outside testers). Refused the same way when the unit's factor is kept."""
    if kind != "dimensionless":
        to_si(f"1 {KINDS[kind].examples[0]}", kind)  # the kind's unit read (its factor kept)
    for _ in range(2):
        with pytest.raises(UnitParseError) as err:
            to_si(text, kind)
        assert str(err.value) == message


@pytest.mark.parametrize(("text", "kind", "si"), [
    ("3 m*m/m", "length", 3.0), ("3 (mm)", "length", 3e-3), ("3 mm^1", "length", 3e-3),
    ("3 mm**1", "length", 3e-3), ("3*mm", "length", 3e-3), ("-3 mm", "length", -3e-3),
    ("- 3 mm", "length", -3e-3), ("+3 mm", "length", 3e-3), ("1e-3 m", "length", 1e-3),
    ("2e-3mm", "length", 2e-6), (".5 mm", "length", 5e-4), ("3. mm", "length", 3e-3),
    ("1_000 mm", "length", 1.0), ("1_0.2_5 mm", "length", 10.25e-3),
    ("1073 kN/mm", "stiffness", 1.073e9),
    ("1073 kN mm-1", "stiffness", 1.073e9), ("1073 kN mm**-1", "stiffness", 1.073e9),
    ("1073 kN*mm^-1", "stiffness", 1.073e9), ("1 kN/mm/rad*rad", "stiffness", 1e6),
    ("0.1 mm", "length", 1e-4), ("50 N*m", "torque", 50.0), ("4.92 N*s/mm", "damping", 4920.0),
    ("4.92 N s mm-1", "damping", 4920.0), ("2 kg m**2", "inertia", 2.0),
    ("2 kg*m^2", "inertia", 2.0), ("5 µm", "displacement", 5e-6), ("3000 rpm", "speed", 3000.0),
    ("2000 rpm", "speed", 2000.0), ("50 Hz", "speed", 3000.0), ("50 1/s", "speed", 3000.0),
    ("10/s", "speed", 600.0), ("100 rad/s", "speed", 100 * 60 / (2 * math.pi)),
    ("200*32/48 rpm", "speed", 200 * 32 / 48), ("3/2 mm", "length", 1.5e-3),
    ("2 pi rad/s", "speed", 60.0), ("30 deg", "angle", math.pi / 6), ("5 %", "dimensionless", 0.05),
    ("1e3 N m-2", "pressure", 1e3), ("210 GPa", "pressure", 2.1e11), ("3000", "speed", 3000.0),
    ("0.25", "dimensionless", 0.25), ("0", "length", 0.0),
])
def test_a_number_and_a_unit_expression_is_read(text, kind, si):
    """Every 'number unit-expression' that was read stays read, to the same value (twice: the
    unit's factor computed, then kept)."""
    assert to_si(text, kind) == pytest.approx(si, rel=1e-12)
    assert to_si(text, kind) == pytest.approx(si, rel=1e-12)


def test_the_kept_display_factors_are_no_unit():
    """The display factors are kept in the unit factors' table: '3 display' for a length was
    read with the key 'display|length' as 3000 m (an m -> mm factor taken for a unit)."""
    display_factor("length")
    with pytest.raises(UnitParseError, match="unknown unit 'display'"):
        to_si("3 display", "length")


def test_a_kept_unit_is_read_without_pint_in_any_spelling_of_its_number(tmp_path):
    """Once a unit's factor is kept, a study's values in it are read without building pint's
    registry (0.1-0.5 s of a run's start), also where the text takes the slow path (the minus
    sign U+2212): the grammar asks pint only about a unit with more than words and powers."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    keep = ("from gearsweep.units import to_si; to_si('1 mm', 'length');"
            " to_si('1 kN mm-1', 'stiffness')")
    subprocess.run([sys.executable, "-c", keep], env=env, check=True)
    code = ("import sys; from gearsweep.units import to_si;"
            " v = [to_si(t, 'length') for t in ('\u22123 mm', '+3 mm', '.5 mm', '1_000 mm')];"
            " v.append(to_si('1073 kN mm-1', 'stiffness'));"
            " print(v, 'pint' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True,
                         text=True).stdout.split()
    assert out[-1] == "False", out
    assert " ".join(out[:-1]) == "[-0.003, 0.003, 0.0005, 1.0, 1073000000.0]"


@pytest.mark.parametrize("kind", sorted(k for k in KINDS if KINDS[k].si))
def test_a_dimension_error_shows_the_unit_it_found_as_a_study_writes_it(kind):
    """'mass: 0.1527 kg m^2' said "is an inertia (kg m  2), expected mass": the display unit
    kg*m**2 with each '*' made a space. Every kind's display unit, given where another dimension
    is expected, is shown readably, as a study would write it, and reads back as that kind."""
    other = "mass" if kind not in ("mass", "inertia") else "length"
    with pytest.raises(UnitParseError) as err:
        to_si(f"1 {KINDS[kind].display}", other)
    m = re.match(r"is an? (\w+) \(([^()]+)\), expected", str(err.value))
    if m is None:  # a speed for a mass, an angle: said in their own words
        assert ("shaft speed (rpm)" in str(err.value) if kind in ("speed", "frequency")
                else kind == "angle" and "has an angle unit" in str(err.value)), err.value
        return
    found, shown = m.groups()  # (the first kind of that dimension: a displacement's is length)
    assert "*" not in shown and "  " not in shown, shown
    assert to_si(f"1 {shown}", found) == pytest.approx(to_si(f"1 {KINDS[found].display}", found))
    if kind == "inertia":
        assert shown == "kg m^2", shown


@pytest.mark.parametrize(("text", "kind", "message"), [
    ("0.004\"", "length", "'\"' (an inch mark) is not read as a unit; write in, e.g. '0.004 in'"),
    ("0.004 ''", "length", "an inch mark) is not read as a unit; write in, e.g. '0.004 in'"),
    ("0.004\u2033", "length", "an inch mark) is not read as a unit; write in, e.g. '0.004 in'"),
    ("2'", "length", "a foot mark) is not read as a unit; write ft, e.g. '2 ft'"),
    ("3\"", "speed", "an inch mark) is not read as a unit; a speed is written e.g. '1 rpm'")])
def test_an_inch_or_foot_mark_is_told_to_write_its_unit(text, kind, message):
    """pint's tokenizer drops a quote: ``backlash: 0.004"`` was told "has no unit; write e.g.
    '0.004" mm'", and ``3"`` for a speed (a bare number is rpm) was 3 rpm (an outside
    tester's finding)."""
    with pytest.raises(UnitParseError) as e:
        to_si(text, kind)
    assert message in str(e.value) and "mm'" not in str(e.value)


@pytest.mark.parametrize(("text", "kind", "message", "meant"), [
    ("3\"", "angle", "'\"' (an arcsecond mark) is not read as a unit; write arcsec, e.g. '3 arcsec'",
     "3 arcsec"),
    ("2'", "angle", "\"'\" (an arcminute mark) is not read as a unit; write arcmin, e.g. '2 arcmin'",
     "2 arcmin"),
    ("2'000 rpm", "speed", ("\"'\" between digits (a digit-group mark) is not read; write the number"
                           " without it, e.g. '2000 rpm'"), "2000 rpm")])
def test_a_mark_is_named_for_what_it_means_in_its_field(text, kind, message, meant):
    """In an angle the marks are the arcsecond and the arcminute (they were told inch and foot),
    and an apostrophe between digits is a digit-group mark (``2'000 rpm`` was told "a foot
    mark"); the spelling the message asks for is read (a reviewer's finding)."""
    with pytest.raises(UnitParseError) as e:
        to_si(text, kind)
    assert str(e.value) == message
    to_si(meant, kind)


def test_mil_in_a_compound_unit_keeps_the_number_written():
    """``2 mil/s`` was told to write '1 thou': the number written is kept in the hint."""
    with pytest.raises(UnitParseError, match="write '2 thou' or '0.002 in'"):
        to_si("2 mil/s", "length")


@pytest.mark.parametrize(("text", "kind", "hint"), [
    ("4 mil", "length", "write '4 thou' or '0.004 in'"),
    ("2.5 mils", "displacement", "write '2.5 thou' or '0.0025 in'"),
    ("4 mil", "force", "a force is written e.g. '1 N'")])
def test_mil_is_said_to_be_pints_angular_mil(text, kind, hint):
    """``backlash: 4 mil`` was told "is a plain number (no dimension), expected length": pint's
    ``mil`` is an angle (a plain number to it), not a thousandth of an inch (``thou``, read)."""
    with pytest.raises(UnitParseError) as e:
        to_si(text, kind)
    assert str(e.value) == ("'mil' is read as pint's angular mil (an angle, pi/32000 rad), not a"
                            f" thousandth of an inch; {hint}")
    assert to_si("4 thou", "length") == pytest.approx(to_si("0.004 in", "length"), rel=1e-12)
