"""A study's impossible gear pair is refused at the line of the field at fault, with the value as
written and what would fit; the bounds against closed forms of involute geometry (ISO 21771),
not against the code's own numbers."""

import math
import re
import warnings
from pathlib import Path

import pytest
from scipy.optimize import brentq

from gearsweep.cli import main
from gearsweep.gear import GeometryWarning
from gearsweep.study.schema import parse_study

STUDIES = Path(__file__).resolve().parent.parent / "studies"
M = 1e-3  # [m] per mm
ALPHA = math.radians(20.0)


def inv(a: float) -> float:
    return math.tan(a) - a


def operating(m: float, z1: int, z2: int, x1: float, x2: float) -> tuple[float, float]:
    """Centre distance [m] and operating pressure angle of a zero-backlash shifted pair."""
    target = inv(ALPHA) + 2.0 * math.tan(ALPHA) * (x1 + x2) / (z1 + z2)
    aw = brentq(lambda a: inv(a) - target, 1e-9, 1.4, xtol=1e-15)
    return 0.5 * m * (z1 + z2) * math.cos(ALPHA) / math.cos(aw), aw


def floor_mm(length: float) -> float:
    """``length`` [m] in mm, rounded down to 0.01 mm."""
    return math.floor(length / M * 100.0) / 100.0


def line_no(text: str, key: str) -> int:
    """The 1-based line of ``text`` where ``key:`` is written (the first)."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if line.strip().startswith(key))


def refused(tmp_path, capsys, text: str) -> tuple[str, list[str]]:
    """(the file's path, the error lines without 'gearsweep: error: ') of ``validate``."""
    path = tmp_path / "s.yaml"
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    return str(path), [line.removeprefix("gearsweep: error: ") for line in err.splitlines()]


def test_a_tip_radius_that_does_not_fit_is_refused_at_its_line_with_what_fits(tmp_path, capsys):
    """studies/table1_profile_shift.yaml with tip_radius1 70 mm: tip-root interference, involute
    interference and pointed teeth, each at tip_radius1's line (was the gear's, line 15, in one
    line), with the largest tip radius each allows: ra1 + rf2 <= a and ra1 <= sqrt(rb1^2 + (a
    sin alpha_w)^2), a and alpha_w of inv(alpha_w) of the shifts 0.48 / 0.52."""
    text = (STUDIES / "table1_profile_shift.yaml").read_text().replace(
        "tip_radius1: 63.7 mm", "tip_radius1: 70 mm")
    path, lines = refused(tmp_path, capsys, text)
    at = f"{path}:{line_no(text, 'tip_radius1')}: gear.tip_radius1: '70 mm' -- "
    assert len(lines) == 3 and all(line.startswith(at) for line in lines), lines
    m, z1, z2 = 2.5 * M, 48, 32
    a, aw = operating(m, z1, z2, 0.48, 0.52)
    assert a / M == pytest.approx(102.31, abs=0.005)  # the study's own comment
    tip_root = floor_mm(a - 37.8 * M)
    rb1 = 0.5 * m * z1 * math.cos(ALPHA)
    involute_limit = floor_mm(math.hypot(rb1, a * math.sin(aw)))
    assert "tip-root interference" in lines[0] and (
        f"a tip radius of gear 1 of at most {tip_root:g} mm fits (tip_radius1)" in lines[0])
    assert tip_root == 64.51
    assert "; also set by root_radius2: 37.8 mm, x2: 0.52, x1: 0.48" in lines[0]  # (a: shifts)
    assert "involute interference" in lines[1] and (
        f"of at most {involute_limit:g} mm fits (tip_radius1)" in lines[1])
    assert "pointed teeth: gear 1" in lines[2]


def test_a_shift_that_leaves_contact_ratio_below_1_is_refused_at_the_shift(tmp_path, capsys):
    """x1 2.5 beside the printed tip radii: the shifts' centre distance shortens the path of
    contact to 0.33 base pitches; said at x1's line (the tips are the printed ones), with the
    largest centre distance that gives 1: sqrt(ra1^2 - rb1^2) + sqrt(ra2^2 - rb2^2) - sqrt(a^2 -
    (rb1 + rb2)^2) = p_b. The fillet that no longer fits, at fillet_radius's line."""
    text = (STUDIES / "table1_profile_shift.yaml").read_text().replace("x1: 0.48", "x1: 2.5")
    path, lines = refused(tmp_path, capsys, text)
    m, z1, z2 = 2.5 * M, 48, 32
    rb1, rb2 = 0.5 * m * z1 * math.cos(ALPHA), 0.5 * m * z2 * math.cos(ALPHA)
    pb = math.pi * m * math.cos(ALPHA)
    reach = math.sqrt((63.7 * M) ** 2 - rb1**2) + math.sqrt((43.8 * M) ** 2 - rb2**2)

    def eps(a: float) -> float:
        return (reach - math.sqrt(a**2 - (rb1 + rb2) ** 2)) / pb

    a_max = floor_mm(math.hypot(rb1 + rb2, reach - pb))
    assert eps(a_max * M) >= 1.0 > eps((a_max + 0.01) * M)
    assert eps(operating(m, z1, z2, 2.5, 0.52)[0]) == pytest.approx(0.330, abs=5e-4)
    x1 = f"{path}:{line_no(text, 'x1')}: gear.x1: 2.5 -- contact ratio 0.330 is below 1"
    assert any(line.startswith(x1) and f"a centre distance of at most {a_max:g} mm gives 1"
               " (centre_distance); also set by x2: 0.52, tip_radius2: 43.8 mm, tip_radius1:"
               " 63.7 mm" in line for line in lines), lines
    fillet = f"{path}:{line_no(text, 'fillet_radius')}: gear.fillet_radius: '1.2 mm' -- fillet"
    assert any(line.startswith(fillet) for line in lines), lines
    assert len(lines) == 2


def test_pointed_teeth_of_a_standard_tip_are_said_at_the_shift(tmp_path, capsys):
    """No tip radius written: the standard tip r + m (1 + x1) follows x1, the line said is x1's;
    the radius where the flanks meet solves inv(alpha_r) = s / (2 r) + inv(alpha), s = m (pi / 2
    + 2 x1 tan(alpha))."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  z1: 12\n  z2: 40\n"
            "  face_width: 20 mm\n  x1: 1.2\ntorque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    m, z, x = 2 * M, 12, 1.2
    r, rb = 0.5 * m * z, 0.5 * m * z * math.cos(ALPHA)
    s = m * (0.5 * math.pi + 2.0 * x * math.tan(ALPHA))
    alpha_r = brentq(lambda a: inv(a) - (s / (2.0 * r) + inv(ALPHA)), 1e-9, 1.5, xtol=1e-15)
    meet = rb / math.cos(alpha_r)
    said = (f"{path}:8: gear.x1: 1.2 -- pointed teeth: gear 1 tip thickness -0.813 mm <= 0 at tip"
            f" radius 16.4 mm; its flanks meet at radius {meet / M:.4g} mm: a tip radius below it"
            " fits (tip_radius1)")
    assert lines == [said]


def test_undercut_interference_and_thickness_bounds_at_their_fields(tmp_path, capsys):
    """A given root radius too deep for z1 = 8: undercut at root_radius1's line, at least r -
    r sin^2(alpha) - rho (1 - sin(alpha)) (rho = 0.38 m, the rack's tip); gear 2's tip meeting
    gear 1 below its base circle at z1's line (no shift written), at most sqrt(rb2^2 + (a
    sin(alpha))^2) at the standard centre distance; thickness1 beyond the circular pitch, at
    most pi m - pi m / 2 there (gear 2 standard, no backlash)."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  z1: 8\n  z2: 40\n  face_width: 20 mm\n"
            "  root_radius1: 5 mm\n  thickness1: 4 mm\ntorque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    m = 2 * M
    r1, rb2, a = 8 * M, 40 * M * math.cos(ALPHA), 48 * M
    root_min = math.ceil((r1 - r1 * math.sin(ALPHA) ** 2 - 0.38 * m * (1 - math.sin(ALPHA)))
                         / M * 100) / 100
    tip2_max = floor_mm(math.hypot(rb2, a * math.sin(ALPHA)))
    expected = {
        (f"{path}:8: gear.root_radius1: '5 mm' -- undercut: gear 1 (z = 8",
         f"a root radius of at least {root_min:g} mm avoids it (root_radius1)"),
        (f"{path}:5: gear.z1: 8 -- involute interference: the tip of gear 2",
         f"of at most {tip2_max:g} mm fits (tip_radius2)"),
        (f"{path}:9: gear.thickness1: '4 mm' -- tooth thicknesses 4 + 3.142 mm do not fit",
         f"a thickness1 of at most {floor_mm(0.5 * math.pi * m):g} mm fits"),
    }
    for start, bound in expected:
        assert any(line.startswith(start) and bound in line for line in lines), (start, lines)


def test_a_bore_radius_outside_sainsot_s_range_is_refused_at_its_line(tmp_path, capsys):
    """bore_radius2 45 mm under a 48.125 mm root (r_f / r_int = 1.07) made gear 2 stiffer than
    solid and validate said nothing: refused at its line, with the bore radii Sainsot et al.'s
    1.4 <= r_f / r_int <= 7 allows."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 2.5 mm\n  z1: 27\n  z2: 41\n"
            "  face_width: 18 mm\n  bore_radius2: 45 mm\ntorque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    rf = 2.5 * M * (41 / 2 - 1.25)
    assert len(lines) == 1 and lines[0].startswith(f"{path}:8: gear.bore_radius2: '45 mm' -- ")
    assert (f"a bore radius of {math.ceil(rf / 7 / M * 100) / 100:g} to {floor_mm(rf / 1.4):g}"
            " mm fits") in lines[0]


def test_every_variant_of_a_mesh_study_at_its_own_fields(tmp_path, capsys):
    """Two refused variants in one run: a preset changed by a written tip radius, at that line
    (at most a - rf2 = 100 - (40 - 1.25 x 2.5) mm); a preset as it is, at its own line."""
    text = ("type: mesh\ntitle: t\ngears:\n  longer:\n    preset: table1_consistent\n"
            "    tip_radius1: 63.7 mm\n  printed: table1_as_printed\ntorque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    assert lines[0] == (
        f"{path}:6: gears.longer.tip_radius1: '63.7 mm' -- tip-root interference: tip radius of"
        " gear 1 (63.7 mm) + root radius of gear 2 (36.88 mm) exceeds the centre distance 100 mm"
        f" by 0.575 mm; a tip radius of gear 1 of at most {floor_mm(100 * M - 36.875 * M):g} mm"
        " fits (tip_radius1)")
    assert all(line.startswith(f"{path}:7: gears.printed: Table 1 as printed: ")
               for line in lines[-4:]) and len(lines) >= 5


NEARLY_POINTED = ("type: mesh\ntitle: t\npositions: 16\nharmonics: 4\ngear:\n  module: 2 mm\n"
                  "  z1: 12\n  z2: 40\n  face_width: 20 mm\n  x1: 0.75\ntorque: 50 N*m\n")


def test_nearly_pointed_teeth_warn_once_at_the_field(tmp_path, capsys):
    """The warning (tip thickness below 0.2 m) at x1's line, one ``gearsweep: warning:`` line from
    validate and from run (was Python's warning with a source line, three times, at no field),
    with the tip radius that keeps 0.2 m: 2 r (s / (2 r_p) + inv(alpha) - inv(alpha_r)) = 0.2 m."""
    m, z, x = 2 * M, 12, 0.75
    rp, rb = 0.5 * m * z, 0.5 * m * z * math.cos(ALPHA)
    s = m * (0.5 * math.pi + 2.0 * x * math.tan(ALPHA))

    def thickness(r: float) -> float:
        return 2.0 * r * (s / (2.0 * rp) + inv(ALPHA) - inv(math.acos(rb / r)))

    keep = floor_mm(brentq(lambda r: thickness(r) - 0.2 * m, rb, rp + 2 * m, xtol=1e-15))
    assert thickness(keep * M) >= 0.2 * m > thickness((keep + 0.01) * M)
    path = tmp_path / "s.yaml"
    path.write_text(NEARLY_POINTED)
    said = (f"gearsweep: warning: {path}:10: gear.x1: 0.75 -- gear 1 tip thickness"
            f" {thickness(rp + m * (1 + x)) / M:.3g} mm is below 0.2 m = 0.4 mm (nearly pointed"
            f" teeth); a tip radius of gear 1 of at most {keep:g} mm keeps 0.2 m (tip_radius1)\n")
    for command in (["validate", str(path)], ["run", str(path), "-o", str(tmp_path / "r.nc")]):
        with warnings.catch_warnings():
            warnings.simplefilter("always", GeometryWarning)  # as outside pytest: shown, not raised
            assert main(command) == 0
        root, pointed = capsys.readouterr().err.splitlines(keepends=True)
        assert pointed == said  # (and the pinion's root half angle, at z1, also set by x1)
        assert root.startswith(f"gearsweep: warning: {path}:7: gear.z1: 12 -- gear 1 root half"
                               " angle theta_f = ") and root.endswith("; also set by x1: 0.75\n")
    with pytest.warns(GeometryWarning) as warned:
        parse_study(NEARLY_POINTED.replace("x1: 0.75", "x1: 0.75  # shifted"), str(path))
    assert [str(w.message) for w in warned][1] == said[len("gearsweep: warning: "):-1]


def test_a_good_gear_says_nothing():
    """The paper's profile-shift study: no problem, no warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_study((STUDIES / "table1_profile_shift.yaml").read_text(), "s.yaml")


SHIFTED_PINION = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  z1: 12\n  z2: 40\n"
                  "  face_width: 20 mm\n  x1: 0.3\n  x2: 0.8\n  backlash: {backlash}\n"
                  "torque: 50 N*m\n")
PINION_RADII = (6 * 2 * M * math.cos(ALPHA), 6 * 2 * M + 2 * M * 1.3)  # base, standard tip


def pinion_thickness(r: float, j: float) -> float:
    """Tooth thickness at radius ``r`` [m] of SHIFTED_PINION's gear 1 with backlash ``j`` [m]:
    s(r) = r (s_p / r_p + 2 (inv(alpha) - inv(alpha_r))), s_p = m (pi / 2 + 2 x1 tan(alpha)) -
    (j / 2) cos(alpha_w) / cos(alpha) (half the backlash, at the operating pitch circle r_w =
    r_p cos(alpha) / cos(alpha_w), taken off each tooth)."""
    m, rp, x = 2 * M, 12 * M, 0.3
    _, aw = operating(m, 12, 40, 0.3, 0.8)
    s_p = m * (0.5 * math.pi + 2.0 * x * math.tan(ALPHA)) - 0.5 * j * math.cos(aw) / math.cos(ALPHA)
    return r * (s_p / rp + 2.0 * (inv(ALPHA) - inv(math.acos(PINION_RADII[0] / r))))


def test_teeth_thinned_to_below_the_base_circle_are_told_the_backlash_that_leaves_a_tooth(
        tmp_path, capsys):
    """9 mm of backlash thins the shifted 12-tooth pinion's teeth (x1 0.3) so far that its flanks
    would meet below the base circle: no tip radius fits (was 'a tip radius below it fits'); the
    largest backlash that leaves a tooth to the tip, at backlash's line, from the involute
    tooth thickness s(r) = r (s_p / r_p + 2 (inv(alpha) - inv(alpha_r))) = 0 at the tip radius
    r_a = r_p + m (1 + x1); s_p = m (pi / 2 + 2 x1 tan(alpha)) - (j / 2) cos(alpha_w) /
    cos(alpha), half the backlash j (at the operating pitch circle, r_w = r_p cos(alpha) /
    cos(alpha_w)) taken off each tooth there."""
    path, lines = refused(tmp_path, capsys, SHIFTED_PINION.format(backlash="9 mm"))
    s, rb, ra = pinion_thickness, *PINION_RADII
    assert s(rb, 9 * M) < 0  # the flanks meet below the base circle: no tip radius fits
    most = floor_mm(brentq(lambda j: s(ra, j), 0.0, 9 * M, xtol=1e-15))
    assert s(ra, most * M) >= 0 > s(ra, (most + 0.01) * M) and most == 1.48
    said = (f"{path}:10: gear.backlash: '9 mm' -- pointed teeth: gear 1 tip thickness"
            f" {s(ra, 9 * M) / M:.3g} mm <= 0 at tip radius {ra / M:.4g} mm; its flanks meet at or"
            f" below its base circle ({rb / M:.4g} mm), so no tip radius fits; a backlash of at"
            f" most {most:g} mm leaves it a tooth to its tip (backlash); also set by x1: 0.3")
    assert said in lines, lines


def test_tip_fillet_interference_is_told_the_largest_mating_tip_that_fits(tmp_path, capsys):
    """A 1 mm fillet on the 30-tooth gear 1 (x1 0.3) and gear 2's tip at 52.6 mm: the mate's tip
    reaches into the fillet (was said with no bound). The fillet, tangent to the root circle r_f
    and to the involute, whose normal is tangent to the base circle, leaves the involute at the
    form radius r_F = sqrt(r_b1^2 + u^2), u = sqrt((r_f + rho)^2 - r_b1^2) - rho; contact on
    gear 1 starts at ISO 21771's active root radius r_Nf1 = sqrt(r_b1^2 + (a sin(alpha_w) -
    sqrt(r_a2^2 - r_b2^2))^2), at least r_F for r_a2 up to sqrt(r_b2^2 + (a sin(alpha_w) -
    u)^2); said at tip_radius2's line."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  z1: 30\n  z2: 50\n  face_width: 20 mm\n"
            "  x1: 0.3\n  x2: 0.1\n  tip_radius2: 52.6 mm\n  fillet_radius: 1 mm\n"
            "torque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    m, rho = 2 * M, 1 * M
    a, aw = operating(m, 30, 50, 0.3, 0.1)
    rb1, rb2 = 15 * m * math.cos(ALPHA), 25 * m * math.cos(ALPHA)
    rf1 = 15 * m - m * (1.25 - 0.3)
    u = math.sqrt((rf1 + rho) ** 2 - rb1**2) - rho
    form = math.hypot(rb1, u)

    def active_root(ra2: float) -> float:
        return math.hypot(rb1, a * math.sin(aw) - math.sqrt(ra2**2 - rb2**2))

    most = floor_mm(math.hypot(rb2, a * math.sin(aw) - u))
    assert active_root(most * M) >= form > active_root((most + 0.01) * M) and most == 52.45
    said = (f"{path}:10: gear.tip_radius2: '52.6 mm' -- tip-fillet interference: gear 1 fillet"
            f" reaches radius {form / M:.4g} mm, above the lowest contact point at"
            f" {active_root(52.6 * M) / M:.4g} mm; a tip radius of gear 2 of at most {most:g} mm"
            " fits (tip_radius2); also set by fillet_radius: 1 mm, x1: 0.3")
    assert lines == [said]


def test_teeth_whose_flanks_meet_too_low_for_a_contact_ratio_are_told_the_backlash(tmp_path,
                                                                                   capsys):
    """8 mm of backlash: the pinion's flanks meet just above its base circle (11.54 mm), and
    'a tip radius below it fits' was true but useless: with its tip there the path of contact,
    sqrt(r_m^2 - r_b1^2) - (a sin(alpha_w) - sqrt(r_a2^2 - r_b2^2)), is under a base pitch. The
    largest backlash that leaves it a tooth to its tip is said instead (closed forms as above)."""
    path, lines = refused(tmp_path, capsys, SHIFTED_PINION.format(backlash="8 mm"))
    s, rb, ra = pinion_thickness, *PINION_RADII
    meet = brentq(lambda r: s(r, 8 * M), rb, ra, xtol=1e-15)
    a, aw = operating(2 * M, 12, 40, 0.3, 0.8)
    rb2, ra2 = 40 * M * math.cos(ALPHA), 40 * M + 2 * M * 1.8
    eps = (math.sqrt(meet**2 - rb**2) - (a * math.sin(aw) - math.sqrt(ra2**2 - rb2**2))) / (
        math.pi * 2 * M * math.cos(ALPHA))
    assert rb < meet and eps < 1
    most = floor_mm(brentq(lambda j: s(ra, j), 0.0, 8 * M, xtol=1e-15))
    assert s(ra, most * M) >= 0 > s(ra, (most + 0.01) * M)
    said = (f"{path}:10: gear.backlash: '8 mm' -- pointed teeth: gear 1 tip thickness"
            f" {s(ra, 8 * M) / M:.3g} mm <= 0 at tip radius {ra / M:.4g} mm; its flanks meet at"
            f" radius {meet / M:.4g} mm, and a tip there leaves a contact ratio of {eps:.3f},"
            f" below 1; a backlash of at most {most:g} mm leaves it a tooth to its tip"
            " (backlash)")
    assert any(line.startswith(said) for line in lines), lines


def test_a_root_half_angle_below_sainsot_s_range_is_refused_at_the_teeth(tmp_path, capsys):
    """A 400-tooth gear's root half angle is below pi / 400 = 0.0079 rad, under the 0.01 rad
    Sainsot et al.'s gear-body fit starts at (below it the fit's body compliance falls to zero):
    refused at z2's line, as a bore radius outside the fit's other range is at its own."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 1 mm\n  z1: 30\n  z2: 400\n"
            "  face_width: 20 mm\ntorque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    assert len(lines) == 1 and lines[0].startswith(
        f"{path}:6: gear.z2: 400 -- gear 2 root half angle theta_f = ")
    assert "rad (400 teeth), outside 0.01 to 0.12 rad" in lines[0]

def test_a_root_half_angle_just_below_sainsot_s_range_names_its_value_and_the_teeth_that_fit(
        tmp_path, capsys):
    """Module 2 mm, z2 = 300: theta_f = 0.009996 rad was printed as "0.01 rad ..., outside 0.01
    to 0.12 rad" (read as inside), and "more than 314 teeth never fit" is only a bound (300 is
    refused, 299 passes): the value has the digits that put it outside, and the message names
    the most teeth that fit with this module, shift and fillet, the same check's own answer."""
    from gearsweep.gear.compliance import tooth_compliance
    from gearsweep.gear.geometry import GearPair, GeometryError

    text = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  z1: 20\n  z2: 300\n"
            "  face_width: 20 mm\ntorque: 50 N*m\n")
    path, lines = refused(tmp_path, capsys, text)
    assert len(lines) == 1 and lines[0].startswith(
        f"{path}:6: gear.z2: 300 -- gear 2 root half angle theta_f = 0.009996 rad (300 teeth),"
        " outside 0.01 to 0.12 rad"), lines
    most = int(re.search(r"at most (\d+) teeth fit", lines[0]).group(1))
    pair = GearPair(module=2e-3, z1=20, z2=most, face_width=20e-3)
    tooth_compliance(pair, 2, pair.base_radius2 * 1.05)  # passes
    with pytest.raises(GeometryError, match="root half angle"):
        more = GearPair(module=2e-3, z1=20, z2=most + 1, face_width=20e-3)
        tooth_compliance(more, 2, more.base_radius2 * 1.05)


@pytest.mark.parametrize("field", ["z1", "z2"])


def test_negative_teeth_are_said_to_be_an_internal_gear_which_is_not_supported(tmp_path, capsys,
                                                                               field):
    """``z2: -60`` (an internal gear, as some codes write it) said only "Input should be greater
    than or equal to 3"; the line says internal gears are not supported (external spur pairs
    only), at the field, exit 2. Teeth 0-2 keep the plain bound."""
    text = ("type: mesh\ntitle: internal\ngear: {module: 2 mm, z1: 20, z2: 60,"
            " face_width: 20 mm}\ntorque: 50 N*m\n").replace(f"{field}: ", f"{field}: -")
    path = tmp_path / "s.yaml"
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert f"{path}:3: gear.{field}: -" in line, line
    assert "internal gears are not supported (external spur pairs only)" in line, line
    path.write_text(re.sub(rf"{field}: -\d+", f"{field}: 2", text))
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "greater than or equal to 3" in line and "internal" not in line, line


RIMMED = ("type: mesh\ntitle: rim\ngear:\n  module: 3 mm\n  z1: 20\n  z2: 40\n"
          "  face_width: 20 mm\n  rim_thickness1: {rim}\n  web_width1: {web}\ntorque: 50 N*m\n")


def iso_rim_factor(s_r: float, b_s: float, b: float, m: float) -> float:
    """ISO 6336-1 C_R = 1 + ln(b_s / b) / (5 exp(s_R / (5 m))), inside its range only."""
    assert s_r / m >= 1.0 and 0.2 <= b_s / b <= 1.2
    return 1.0 + math.log(b_s / b) / (5.0 * math.exp(s_r / (5.0 * m)))


@pytest.mark.parametrize(("rim", "web", "field", "said"), [
    # gear 1: root radius 3 (20 / 2 - 1.25) = 26.25 mm, bore half of it: a rim of at most 13.12
    ("100 mm", "10 mm", "rim_thickness1", ("gear 1: rim thickness 100 mm is more than the root"
     " radius 26.25 mm less the bore radius 13.12 mm (the default, half the root radius): at most"
     " 13.12 mm fits (rim_thickness1)")),
    ("5 mm", "200 mm", "web_width1", ("gear 1: web width 200 mm is more than the face width 20 mm:"
     " at most 20 mm fits (web_width1; a full web is the face width)")),
])
def test_an_impossible_rim_or_web_is_refused_at_its_field(tmp_path, capsys, rim, web, field,
                                                          said):
    """A 100 mm rim on a gear of root radius 26.25 mm, and a 200 mm web on a 20 mm face (stiffer
    than a solid gear: ISO's C_R > 1 for b_s > b), were accepted (an outside tester). Refused,
    one line at the field, with what fits, exit 2."""
    path = tmp_path / "s.yaml"
    text = RIMMED.format(rim=rim, web=web)
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    at = next(i for i, ln in enumerate(text.splitlines(), 1) if ln.strip().startswith(field))
    assert f"{path}:{at}: gear.{field}: '{rim if field.startswith('rim') else web}' -- {said}" \
        in line, line


def test_a_rim_or_web_outside_iso_s_range_warns_that_its_factor_is_taken_at_the_bound(tmp_path):
    """ISO 6336-1 states its rim factor for s_R >= m and 0.2 <= b_s / b <= 1.2; rim_factor takes
    it at the bound outside, unsaid: a 0.1 mm rim on a 1 mm web gave exactly the k0 of a 3 mm
    rim on a 4 mm web (an outside tester). Each bound passed warns, at its field, with the
    factor taken (ISO's formula at the bound, computed here); within the range, no warning."""
    from gearsweep.gear import GearPair, mesh_cycle
    from gearsweep.gear.compliance import rim_factor

    path = tmp_path / "s.yaml"
    path.write_text(RIMMED.format(rim="0.1 mm", web="1 mm"))
    at_bound = iso_rim_factor(3e-3, 4e-3, 20e-3, 3e-3)
    with pytest.warns(GeometryWarning) as got:
        parse_study(path.read_text(), str(path))
    said = sorted(str(w.message) for w in got)
    assert len(said) == 2, said
    assert said[0].startswith(f"{path}:8: gear.rim_thickness1: '0.1 mm' -- gear 1: rim"
                              " thickness 0.1 mm is 0.0333 modules, below ISO 6336-1's range of"
                              " its rim factor (s_R >= m = 3 mm): C_R is taken at s_R = m"), said
    assert said[1].startswith(f"{path}:9: gear.web_width1: '1 mm' -- gear 1: web width 1 mm is"
                              " 0.05 of the face width, below ISO 6336-1's range of its rim"
                              " factor (b_s / b >= 0.2): C_R is taken at b_s = 0.2 b = 4 mm"), said
    assert said[1].endswith(f"(C_R = {at_bound:.4f})"), said
    thin = GearPair(module=3e-3, z1=20, z2=40, face_width=20e-3, rim_thickness1=0.1e-3,
                    web_width1=1e-3)
    assert rim_factor(thin, 1) == pytest.approx(at_bound, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        inside = GearPair(module=3e-3, z1=20, z2=40, face_width=20e-3, rim_thickness1=6e-3,
                          web_width1=8e-3).check()
        assert rim_factor(inside, 1) == pytest.approx(iso_rim_factor(6e-3, 8e-3, 20e-3, 3e-3),
                                                      rel=1e-12)
        mesh_cycle(inside, 50.0)


# ------------------------------------------------------------ loads and moduli out of scale

HEAVY = "type: mesh\ntitle: t\npositions: 40\nharmonics: 4\ngear: {gear}\ntorque: {torque}\n"


def table1_peak_ste_at_50() -> float:
    """The Table 1 pair's largest STE at 50 N m [m] (a load the checks pass)."""
    from gearsweep.gear import mesh_cycle, table1_consistent

    return float(mesh_cycle(table1_consistent(), 50.0, n=40).ste.max())


def test_a_load_in_the_wrong_unit_is_refused_at_the_torque_with_the_deflection(tmp_path, capsys):
    """50000 N m, the paper's 50000 N mm written N m, ran with a peak STE of 6166 um (exit 0),
    1.7 times the 3.68 mm teeth. The STE of unmodified teeth is proportional to the load, so it
    is 1000 times that at 50 N m; the preset's teeth are pi m / 2 less half the 0.5 mm
    backlash (at the standard centre distance) thick: refused at the torque's line, naming the
    deflection, the thickness and the slip."""
    peak = 1000 * table1_peak_ste_at_50()
    thinnest = math.pi * 2.5 * M / 2 - 0.25 * M
    assert peak > thinnest
    text = HEAVY.format(gear="table1_consistent", torque="50000 N*m")
    path, lines = refused(tmp_path, capsys, text)
    assert len(lines) == 1
    assert lines[0].startswith(f"{path}:6: torque: '50000 N*m' -- peak static transmission error"
                               f" {peak * 1e6:,.0f} um at a torque of 50,000 N m (line load F_t /"
                               f" b = {50000 / 0.060 / 10:,.0f} N/mm on the 10 mm face)")
    assert f"thickness {thinnest / M:.4g} mm" in lines[0]
    assert lines[0].endswith("a unit slip in the torque (N*mm written as N*m?)")


def test_a_modulus_in_mpa_is_refused_at_its_line(tmp_path, capsys):
    """206 MPa for steel's 206 GPa: every compliance term is 1/E, so the STE is 1000 times the
    steel pair's at the same load; said at youngs_modulus, the slip named there."""
    peak = 1000 * table1_peak_ste_at_50()
    text = HEAVY.format(gear="{preset: table1_consistent, youngs_modulus: 206 MPa}",
                        torque="50 N*m")
    path, lines = refused(tmp_path, capsys, text)
    assert len(lines) == 1 and lines[0].startswith(
        f"{path}:5: gear.youngs_modulus: '206 MPa' -- peak static transmission error"
        f" {peak * 1e6:,.0f} um at a torque of 50 N m")
    assert "a unit slip in youngs_modulus (0.206 GPa; steel is 206 GPa)?" in lines[0]


@pytest.mark.parametrize("torque, warned", [("900 N*m", False), ("3000 N*m", True)])
def test_a_deflection_beyond_a_tenth_of_a_module_warns_at_the_largest_torque(tmp_path, capsys,
                                                                             torque, warned):
    """A swept torque is tested at its largest value, at that item's line: 3000 N m gives 60
    times the STE at 50 N m, above 0.1 module (250 um) and below the tooth: warned, exit 0;
    900 N m (18 times) is not."""
    peak = float(torque.split()[0]) / 50 * table1_peak_ste_at_50()
    assert (peak > 0.1 * 2.5 * M) == warned
    text = ("type: mesh\ntitle: t\npositions: 40\nharmonics: 4\ngear: table1_consistent\n"
            f"sweep:\n  torque:\n    - 50 N*m\n    - {torque}\n")
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("always", GeometryWarning)
        assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err
    said = (f"gearsweep: warning: {path}:9: sweep.torque[1]: '{torque}' -- peak static"
            f" transmission error {peak * 1e6:.4g} um at a torque of")
    assert (said in err) == warned and (err == "") != warned, err


@pytest.mark.parametrize("modulus, warned", [("3 GPa", False), ("206 GPa", False),
                                             ("0.2 GPa", True), ("2000 GPa", True)])
def test_a_modulus_outside_gear_materials_warns_at_its_line(tmp_path, capsys, modulus, warned):
    """Polymer gears (3 GPa) and steel pass silently; 0.2 GPa and 2000 GPa (at a load light
    enough to pass) are warned at youngs_modulus as a likely unit slip."""
    text = HEAVY.format(gear=f"{{preset: table1_consistent, youngs_modulus: {modulus}}}",
                        torque="0.05 N*m")
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("always", GeometryWarning)
        assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err
    assert (f"gearsweep: warning: {path}:5: gear.youngs_modulus: '{modulus}' -- Young's modulus"
            in err) == warned, err
    assert ("outside gear materials' 0.5 to 700 GPa" in err) == warned


def test_a_preset_changed_does_not_inherit_its_source_s_contact_ratio_range(tmp_path, capsys):
    """Table 1 at 14.5 deg (a 0.5 mm fillet to fit the space) has a contact ratio above 2 (the
    path of contact of standard tips at the standard centre distance over the base pitch): a
    valid pair, refused as outside "the stated range [1, 2]", which the paper states of its own
    Table 1. Changed, it validates; unchanged, Table 1 as printed is still refused by it."""
    m, a = 2.5 * M, math.radians(14.5)
    rb1, rb2 = 60 * M * math.cos(a), 40 * M * math.cos(a)
    eps = (math.sqrt(62.5**2 * M**2 - rb1**2) + math.sqrt(42.5**2 * M**2 - rb2**2)
           - 100 * M * math.sin(a)) / (math.pi * m * math.cos(a))
    assert eps == pytest.approx(2.043, abs=5e-4)
    path = tmp_path / "s.yaml"
    path.write_text(HEAVY.format(gear=("{preset: table1_consistent, pressure_angle: 14.5 deg,"
                                       " fillet_radius: 0.5 mm}"), torque="50 N*m"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GeometryWarning)  # (a slight undercut of the pinion)
        assert main(["validate", str(path)]) == 0
    capsys.readouterr()
    _, lines = refused(tmp_path, capsys, HEAVY.format(gear="table1_as_printed", torque="50 N*m"))
    assert any("contact ratio 2.429 is outside the stated range [1, 2]" in line for line in lines)


def test_a_preset_at_another_module_is_told_only_that_its_kept_centre_distance_is_too_far(
        tmp_path, capsys):
    """Table 1 at module 2 mm keeps the preset's 100 mm: the tips (48 + 1 and 32 + 1 modules of
    1 mm radius) do not reach. Said once, at module's line, naming centre_distance, the standard
    m (z1 + z2) / 2 = 80 mm and that 100 mm is the preset's; its consequences (a contact ratio of
    -4.8 "outside the stated range", fillets at roots the mate never meets) are not said."""
    text = HEAVY.format(gear="{preset: table1_consistent, module: 2 mm}", torque="50 N*m")
    path, lines = refused(tmp_path, capsys, text)
    assert len(lines) == 1, lines
    tips = (48 + 2) * 1.0 + (32 + 2) * 1.0
    assert lines[0].startswith(f"{path}:5: gear.module: '2 mm' -- the teeth do not reach each"
                               f" other: tip radii 50 + 34 mm = {tips:g} mm, not more than the"
                               " centre distance 100 mm")
    assert f"the teeth and shifts give {2.0 * (48 + 32) / 2:g} mm" in lines[0]
    assert lines[0].endswith("the centre distance 100 mm is preset table1_consistent's, kept when"
                             " a variant changes its module, teeth or shifts: write"
                             " centre_distance to change it")


def test_a_shifted_preset_is_told_the_centre_distance_of_its_shifts(tmp_path, capsys):
    """x1 = 0.5 on Table 1 keeps the preset's 100 mm, not the centre distance of the shifts the
    docs give by default (inv(alpha_w)): both tip-root interferences name the centre distance that
    clears them (r1 + 1.5 m + r2 - 1.25 m, rounded up to 0.01 mm) and the shifts' own."""
    m = 2.5 * M
    a, _ = operating(m, 48, 32, 0.5, 0.0)
    text = HEAVY.format(gear="{preset: table1_consistent, x1: 0.5}", torque="50 N*m")
    path, lines = refused(tmp_path, capsys, text)
    clear = math.ceil((60 * M + 1.5 * m + 40 * M - 1.25 * m) / M * 100) / 100
    assert len(lines) == 2 and all(line.startswith(f"{path}:5: gear.x1: 0.5 -- tip-root") and (
        f"; or a centre distance of at least {clear:g} mm fits (centre_distance, given as 100 mm;"
        f" the teeth and shifts give {a / M:.5g} mm); the centre distance 100 mm is preset"
        " table1_consistent's") in line for line in lines), lines
