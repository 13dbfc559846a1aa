"""Gear pair geometry against closed forms, and every inconsistent geometry as a GeometryError."""

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from gearsweep.errors import GeometryError
from gearsweep.gear.geometry import (
    GearPair,
    GeometryWarning,
    inverse_involute,
    involute,
    table1_as_printed,
    table1_consistent,
)

DEG20 = math.radians(20.0)

# (module [m], z1, z2, x1, x2): standard and shifted pairs, all consistent.
PAIRS = [
    (2.5e-3, 48, 32, 0.0, 0.0),
    (2e-3, 20, 40, 0.0, 0.0),
    (3e-3, 30, 90, 0.0, 0.0),
    (3e-3, 18, 36, 0.3, -0.3),
    (3e-3, 18, 36, 0.4, 0.2),
    (2e-3, 14, 40, 0.2, 0.0),
]


def _inv(a: float) -> float:
    return math.tan(a) - a


def _alpha_w_reference(z1: int, z2: int, x1: float, x2: float) -> float:
    """Operating pressure angle from inv(alpha_w) solved independently with scipy's brentq."""
    target = _inv(DEG20) + 2.0 * math.tan(DEG20) * (x1 + x2) / (z1 + z2)
    return brentq(lambda a: _inv(a) - target, 1e-6, 1.2, xtol=1e-14)


@pytest.mark.parametrize(("m", "z1", "z2", "x1", "x2"), PAIRS)
def test_operating_pressure_angle_and_centre_distance(m, z1, z2, x1, x2):
    pair = GearPair(module=m, z1=z1, z2=z2, face_width=10e-3, x1=x1, x2=x2)
    aw = _alpha_w_reference(z1, z2, x1, x2)
    # Both sides solve inv(alpha_w) to ~1e-14 rad; 1e-10 relative leaves room for round-off.
    assert_allclose(pair.operating_pressure_angle, aw, rtol=1e-10)
    a_ref = 0.5 * m * (z1 + z2) * math.cos(DEG20) / math.cos(aw)
    assert_allclose(pair.operating_centre_distance, a_ref, rtol=1e-10)
    # Given the centre distance instead of deriving it: cos(alpha_w) = (rb1 + rb2) / a.
    pair_a = GearPair(module=m, z1=z1, z2=z2, face_width=10e-3, x1=x1, x2=x2, centre_distance=a_ref)
    assert_allclose(pair_a.operating_pressure_angle, aw, rtol=1e-10)


def test_shifted_pair_has_larger_operating_pressure_angle():
    pair = GearPair(module=3e-3, z1=18, z2=36, face_width=10e-3, x1=0.4, x2=0.2)
    # inv(alpha_w) = 0.014904 + 2 tan20 * 0.6 / 54 = 0.022992 -> alpha_w = 22.98 deg (hand value).
    assert math.degrees(pair.operating_pressure_angle) == pytest.approx(22.98, abs=0.01)


@pytest.mark.parametrize(("m", "z1", "z2", "x1", "x2"), PAIRS)
def test_contact_ratio_and_base_pitch_closed_form(m, z1, z2, x1, x2):
    pair = GearPair(module=m, z1=z1, z2=z2, face_width=10e-3, x1=x1, x2=x2)
    aw = _alpha_w_reference(z1, z2, x1, x2)
    a = 0.5 * m * (z1 + z2) * math.cos(DEG20) / math.cos(aw)
    rb1, rb2 = 0.5 * m * z1 * math.cos(DEG20), 0.5 * m * z2 * math.cos(DEG20)
    ra1, ra2 = 0.5 * m * z1 + m * (1 + x1), 0.5 * m * z2 + m * (1 + x2)
    pb = math.pi * m * math.cos(DEG20)
    eps = (math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - a * math.sin(aw)) / pb
    assert_allclose(pair.base_pitch, pb, rtol=1e-14)
    assert_allclose(pair.contact_ratio, eps, rtol=1e-10)
    assert_allclose(pair.path_of_approach + pair.path_of_recess, pair.path_of_contact, rtol=1e-12)


def test_contact_ratio_textbook_value():
    # 20/40 teeth, 20 deg, m = 2, standard, by hand: (sqrt(22^2 - 18.794^2) + sqrt(42^2 - 37.588^2)
    # - 60 sin 20) / (2 pi cos 20) = (11.435 + 18.739 - 20.521) / 5.904 = 1.635.
    pair = GearPair(module=2e-3, z1=20, z2=40, face_width=10e-3)
    assert pair.contact_ratio == pytest.approx(1.635, abs=0.001)


def test_involute_inverse_round_trip():
    for a in (0.05, DEG20, 0.6, 1.2):
        assert_allclose(inverse_involute(float(involute(a))), a, rtol=1e-12)


def test_table1_consistent_numbers():
    pair = table1_consistent().check()
    assert pair.tip_radius == pytest.approx((62.5e-3, 42.5e-3), rel=1e-12)
    assert pair.root_radius == pytest.approx((56.875e-3, 36.875e-3), rel=1e-12)
    assert pair.contact_ratio == pytest.approx(1.7076, abs=1e-4)
    # 0.5 mm circumferential backlash, shared equally: each tooth 0.25 mm thinner than pi m / 2.
    assert_allclose(pair.circumferential_backlash, 0.5e-3, rtol=1e-9)
    assert_allclose(pair.backlash_loa, 0.5e-3 * math.cos(DEG20), rtol=1e-9)
    assert_allclose(pair.thickness, (math.pi * 2.5e-3 / 2 - 0.25e-3,) * 2, rtol=1e-9)


def test_thickness_gives_backlash_and_back():
    base = GearPair(module=2e-3, z1=20, z2=40, face_width=10e-3, backlash=0.2e-3)
    s1, s2 = base.thickness
    again = GearPair(module=2e-3, z1=20, z2=40, face_width=10e-3, thickness1=s1, thickness2=s2)
    assert_allclose(again.circumferential_backlash, 0.2e-3, rtol=1e-9)
    both = GearPair(
        module=2e-3, z1=20, z2=40, face_width=10e-3, thickness1=s1, thickness2=s2, backlash=0.2e-3
    )
    assert both.problems() == []


def test_table1_as_printed_fails_with_reasons():
    pair = table1_as_printed()
    with pytest.raises(GeometryError) as err:
        pair.check()
    msg = str(err.value)
    assert "Table 1 as printed" in msg
    assert msg.count("tip-root interference") == 2
    assert "by 1.5 mm" in msg
    assert "contact ratio 2.429 is outside the stated range [1, 2]" in msg
    assert "thicknesses 4 + 4 mm" in msg and "circular pitch 7.854 mm" in msg
    assert "cannot coexist" in msg


# (GearPair keyword arguments, text the message must contain)
INCONSISTENT = [
    ({"tip_radius1": 22.9e-3}, "tip-root interference"),
    ({"tip_radius1": 20.6e-3, "tip_radius2": 40.6e-3}, "contact ratio 0.552 is below 1"),
    ({"z1": 12}, "undercut: gear 1 (z = 12"),
    ({"z1": 12}, "involute interference"),
    ({"z1": 10}, "(start of contact 1.64 mm before T1)"),  # was "-1.64 mm before"
    ({"z1": 14, "x1": 1.0}, "pointed teeth: gear 1 tip thickness"),
    ({"thickness1": 3.3e-3, "thickness2": 3.3e-3}, "do not fit the circular pitch 6.283 mm"),
    ({"thickness1": 3.0e-3, "thickness2": 3.0e-3, "backlash": 0.5e-3}, "cannot coexist"),
    ({"fillet_radius": 1.5e-3}, "does not fit the tooth space"),
    ({"contact_ratio_range": (1.0, 1.5)}, "outside the stated range [1, 1.5]"),
    # a module in um beside a face in mm ran, with STE 1000x the tooth depth
    ({"module": 2e-6, "z1": 25, "z2": 50, "face_width": 20e-3},
     "face width 20 mm is 10,000 modules of 0.002 mm: a spur gear's is 0.5 to 100 modules"),
    ({"face_width": 0.5e-3}, "face width 0.5 mm is 0.25 modules of 2 mm"),
    # tips that do not reach (22 + 42 mm < 70 mm) were said as "contact ratio -1.916"
    ({"centre_distance": 70e-3}, ("the teeth do not reach each other: tip radii 22 + 42 mm ="
     " 64 mm, not more than the centre distance 70 mm")),
]


@pytest.mark.parametrize("z", [12, 14, 17])
def test_an_undercut_pinion_is_told_the_shift_that_avoids_it(z):
    """The undercut line said what was wrong, not what would do (an outside gear engineer: z =
    17 at 20 deg needs x1 >= 0.006). The shift it names is the least that passes: 0.1 % less
    is still undercut (the root follows the shift, m (1.25 - x) below the reference circle):
    refused, or warned where it stays below the active profile."""
    import re

    def said(x):
        pair = GearPair(module=2e-3, z1=z, z2=40, face_width=20e-3, x1=x)
        return [m for m in (*pair.problems(), *(c for c, _ in pair.cautions()))
                if "undercut: gear 1" in m]

    line = said(0.0)[0]
    x_min = float(re.search(r"a profile shift x1 >= ([0-9.]+) avoids it", line).group(1))
    # the closed form of the limit for a standard rack: x >= 1.25 - rho_f (1 - sin a) / m -
    # z sin^2(a) / 2 (ISO 53's rack: fillet 0.38 m)
    a = math.radians(20.0)
    assert x_min == pytest.approx(1.25 - 0.38 * (1 - math.sin(a)) - z * math.sin(a) ** 2 / 2,
                                  abs=6e-4)
    assert not said(x_min + 1e-3) and said(x_min - 1e-3)


def _cut_by_rack(m, r, alpha, depth, rho, radius):
    """Whether some position of a standard rack (module ``m``, teeth pi m / 2 thick at their
    reference line, flanks at ``alpha``, tip line ``depth`` below the reference line, tips
    rounded by ``rho``) rolling on the reference circle ``r`` covers the involute point of
    radius ``radius`` its flank makes: point-in-tool over 300,001 positions (the check the
    model's undercut radius must agree with, found another way)."""
    s, c = math.sin(alpha), math.cos(alpha)
    # the involute point made at rolling angle t, from its radius (t = -tan(a): base circle)
    t = (-s * c + math.sqrt((s * c) ** 2 - c**2 * (1 - (radius / r) ** 2))) / c**2
    vx, vy = -r * t * c**2, r * (1 + t * s * c)
    phi = t + np.linspace(-0.5, 0.5, 300_001)
    x = r * phi + np.cos(phi - t) * vx - np.sin(phi - t) * vy
    y = np.sin(phi - t) * vx + np.cos(phi - t) * vy
    half = math.pi * m / 4  # a rack tooth's half thickness at its reference line
    centre = -half + math.pi * m * np.round((x + half) / (math.pi * m))  # of the nearest tooth
    u = np.abs(x - centre) - half  # from its flank's reference point, as for the right flank
    straight = depth - rho * (1 - s)  # the flank's lowest point, where the round starts
    cx, cy = -straight * math.tan(alpha) - rho * c, r - depth + rho
    sharp = (y >= r - depth) & (u * c - (y - r) * s < -1e-12)  # in the unrounded tooth (1 pm)
    ang = np.arctan2(y - cy, u - cx)
    corner = (ang <= -alpha) & (ang >= -math.pi / 2) & (np.hypot(u - cx, y - cy) > rho)
    return bool(np.any(sharp & ~corner))


def test_a_slight_undercut_below_the_active_profile_warns_and_one_reaching_it_is_refused():
    """z1 = 17, x = 0 (a common pinion) was refused as undercut for 0.014 mm of rack flank past
    r sin^2(alpha) (an outside gear engineer's finding). The rack's round cuts the involute up
    to a radius (here found by point-in-tool over the rack's positions, not by the model); a
    pair whose contact starts above it (ISO 21771's r_Nf = sqrt(r_b1^2 + (a sin(alpha) -
    sqrt(r_a2^2 - r_b2^2))^2)) is warned at x1, one whose contact starts below it is refused,
    2 um either side of it by the mate's tip radius."""
    m, a = 2e-3, math.radians(20.0)
    common = GearPair(module=m, z1=17, z2=40, face_width=20e-3)
    assert common.problems() == []
    (text, fields), = common.cautions()
    assert text.startswith("slight undercut: gear 1 (z = 17") and fields[0] == "x1"
    x_min = 1.25 - 0.38 * (1 - math.sin(a)) - 17 * math.sin(a) ** 2 / 2  # (closed form)
    assert f"a profile shift x1 >= {x_min:.3g} avoids it" in text
    with pytest.warns(GeometryWarning, match="slight undercut"):
        common.check()
    assert GearPair(module=m, z1=17, z2=40, face_width=20e-3, x1=x_min + 1e-4).cautions() == []

    z1, z2 = 14, 40
    r1, rb1, rb2 = z1 * m / 2, z1 * m / 2 * math.cos(a), z2 * m / 2 * math.cos(a)
    cut = brentq(lambda rad: 0.5 - _cut_by_rack(m, r1, a, 1.25 * m, 0.38 * m, rad), rb1 * 1.000001,
                 rb1 + 0.1 * m, xtol=1e-10)
    length = (z1 + z2) * m / 2 * math.sin(a)
    for start, refused in ((cut + 2e-6, False), (cut - 2e-6, True)):
        tip2 = math.hypot(rb2, length - math.sqrt(start**2 - rb1**2))  # r_Nf1 = start
        pair = GearPair(module=m, z1=z1, z2=z2, face_width=20e-3, tip_radius2=tip2)
        assert pair.active_root_radius(1) == pytest.approx(start, abs=1e-12)
        faults = [p for p in pair.problems() if p.startswith("undercut: gear 1")]
        warned = [c for c, _ in pair.cautions() if c.startswith("slight undercut: gear 1")]
        assert (bool(faults), bool(warned)) == (refused, not refused), (start, cut)
    assert pair.undercut_radius(1) == pytest.approx(cut, abs=2e-8)


def test_a_fillet_that_does_not_fit_is_told_the_largest_that_does():
    """A standard 25 deg 25/50 pair was refused for its default fillet (0.38 m = 0.76 mm) with no
    word of the default or of what fits (an outside gear engineer's finding). The radius named
    fits, 0.02 mm more does not."""
    import re

    pair = dict(module=2e-3, z1=25, z2=50, face_width=20e-3, pressure_angle=math.radians(25))
    line = next(p for p in GearPair(**pair).problems() if p.startswith("fillet radius"))
    assert "0.76 mm (the default, 0.38 module) does not fit the tooth space of gear 2" in line
    most = float(re.search(r"at most ([0-9.]+) mm fits \(fillet_radius\)", line).group(1)) * 1e-3

    def fits(rho):
        return not any("fillet" in p for p in GearPair(**pair, fillet_radius=rho).problems())

    assert fits(most) and not fits(most + 2e-5)


def test_tip_fillet_interference_is_named():
    # 60/60 teeth with tips at r + 1.25 m: the mating tip reaches down to 58.11 mm, while a 1 mm
    # fillet runs up the flank to 58.24 mm.
    pair = GearPair(
        module=2e-3, z1=60, z2=60, face_width=10e-3, fillet_radius=1e-3,
        tip_radius1=62.5e-3, tip_radius2=62.5e-3,
    )  # fmt: skip
    with pytest.raises(GeometryError, match="tip-fillet interference: gear 1 fillet reaches"):
        pair.check()


@pytest.mark.parametrize(("kwargs", "text"), INCONSISTENT)
def test_inconsistent_geometry_names_the_problem(kwargs, text):
    args = {"module": 2e-3, "z1": 20, "z2": 40, "face_width": 10e-3} | kwargs
    with pytest.raises(GeometryError) as err:
        GearPair(**args).check()
    assert text in str(err.value)


def test_each_problem_carries_the_fields_that_set_it_and_what_fits():
    """``GeometryError.faults``: each problem with the fields that set it, the given one first
    (a standard tip follows x1), and the largest tip radius beside the mate's root, a - rf2
    (here 60 - (40 - 1.25 x 2) mm), rounded down to 0.01 mm; the pickled error keeps them."""
    import pickle

    given = {"module": 2e-3, "z1": 20, "z2": 40, "face_width": 20e-3, "tip_radius1": 23.5e-3}
    with pytest.raises(GeometryError) as err:
        GearPair(**given).check()
    message, fields = err.value.faults[0]
    assert fields[0] == "tip_radius1" and "root_radius2" not in fields  # (standard: x2, z2, m)
    assert message.startswith("tip-root interference") and message.endswith(
        f"at most {math.floor((60e-3 - (40e-3 - 2.5e-3)) * 1e5) / 100:g} mm fits (tip_radius1)")
    assert pickle.loads(pickle.dumps(err.value)).faults == err.value.faults
    # x1 1.2 at 61 mm: both tips meet the mate's root (24.4 + 37.5 and 42 + 19.9 mm); gear 2's
    # tip is standard (x2 0, not given), gear 1's root the shifted one: x2, then x1, before z2
    shifted = GearPair(module=2e-3, z1=20, z2=40, face_width=20e-3, x1=1.2, centre_distance=61e-3)
    (_, one), (_, two), (thin, _) = shifted.faults()
    assert one[:3] == ("x1", "x2", "centre_distance") and two[:3] == ("x2", "x1", "centre_distance")
    assert one[3:] == ("z1", "module", "z2") and thin.startswith("tooth thicknesses")


def test_nearly_pointed_teeth_warn():
    """(The 14-tooth pinion's root half angle, shifted 0.8, is past where Sainsot et al.'s
    gear-body fit is extrapolated without a word: that is warned too.)"""
    pair = GearPair(module=2e-3, z1=14, z2=40, face_width=10e-3, x1=0.8)
    with pytest.warns(GeometryWarning) as said:
        pair.check()
    assert [str(w.message).split(": ", 1)[1][:22] for w in said] == [
        "gear 1 root half angle", "gear 1 tip thickness 0"]
    assert "below 0.2 m" in str(said[1].message)


@pytest.mark.parametrize(
    "kwargs",
    [{"module": -1.0}, {"z1": 2}, {"face_width": 0.0}, {"poisson": 0.5}, {"backlash": -1e-4}],
)
def test_bad_numbers_rejected_at_construction(kwargs):
    args = {"module": 2e-3, "z1": 20, "z2": 40, "face_width": 10e-3} | kwargs
    with pytest.raises(GeometryError):
        GearPair(**args)


def test_teeth_too_thin_at_the_base_circle_without_backlash_are_told_the_thickness():
    """x1 -2.5 leaves the 12-tooth pinion a negative thickness at the reference circle,
    m (pi / 2 + 2 x tan(alpha)) < -2 r inv(alpha): its flanks meet below the base circle, no
    tip radius fits (was 'a tip radius below it fits'), and no backlash thins it. The least
    thickness that reaches the 13 mm tip: s(r_a) = r_a (s / r + 2 (inv(alpha) - inv(alpha_a)))
    = 0, rounded up to 0.01 mm."""
    a = math.radians(20.0)
    r, ra = 12e-3, 13e-3
    assert 2e-3 * (0.5 * math.pi + 2.0 * -2.5 * math.tan(a)) < -2.0 * r * involute(a)
    pair = GearPair(module=2e-3, z1=12, z2=40, face_width=20e-3, x1=-2.5, x2=2.5,
                    tip_radius1=ra)
    line = next(p for p in pair.problems() if p.startswith("pointed teeth: gear 1"))
    least = math.ceil(2.0 * r * (involute(math.acos(r * math.cos(a) / ra)) - involute(a))
                      * 1e5) / 100
    assert line.endswith(f"its flanks meet at or below its base circle (11.28 mm), so no tip"
                         f" radius fits; a thickness1 of at least {least:g} mm does (thickness1)")
    assert least == 0.92


def test_a_thickness_bound_that_cannot_fit_is_not_offered():
    """thickness1 0.92 mm beside the x2 = 2.5 gear's standard tooth, m (pi / 2 + 2 x2 tan(a)) =
    6.78 mm, was told 'a thickness1 of at most -0.5 mm fits'. The shifts sum to 0, so the pair
    runs at the reference circles (alpha_w = alpha): a thickness1 of 0 leaves a backlash of
    pi m - 6.78 mm < 0, and no thickness1 fits."""
    m, a = 2e-3, math.radians(20.0)
    pair = GearPair(module=m, z1=12, z2=40, face_width=20e-3, x1=-2.5, x2=2.5,
                    tip_radius1=13e-3, thickness1=0.92e-3)
    line = next(p for p in pair.problems() if p.startswith("tooth thicknesses"))
    left = math.pi * m - m * (0.5 * math.pi + 2.0 * 2.5 * math.tan(a))
    assert left < 0 and "at most -" not in line
    assert line.endswith(f"; no thickness1 fits: one of 0 leaves a backlash of {left * 1e3:.4g} mm")


def test_a_shifted_pair_without_backlash_has_exactly_none():
    """A pair with no backlash, thickness or centre distance given meshes tight by construction
    (the centre distance of inv(alpha_w) = inv(alpha) + 2 tan(alpha) (x1 + x2) / (z1 + z2)):
    its backlash is 0, not the round-off of the shift formula (gear_backlash was 1.17e-15 mm for
    z 18/55, m 2 mm, 25 deg, x 0.3/-0.1; an outside tester). A backlash asked for is kept; a
    larger centre distance da opens one, 2 da tan(alpha_w) to first order."""
    pair = GearPair(module=2e-3, z1=18, z2=55, face_width=20e-3, pressure_angle=math.radians(25),
                    x1=0.3, x2=-0.1)
    assert pair.circumferential_backlash == 0.0
    assert pair.backlash_loa == 0.0
    asked = dataclasses.replace(pair, backlash=0.1e-3)
    assert asked.circumferential_backlash == pytest.approx(0.1e-3, rel=1e-12)
    # an opened centre distance: j_t = 2 da tan(alpha_w) to first order in da (1 um here)
    opened = dataclasses.replace(pair, centre_distance=pair.operating_centre_distance + 1e-6)
    assert opened.circumferential_backlash == pytest.approx(
        2e-6 * math.tan(pair.operating_pressure_angle), rel=1e-3)
