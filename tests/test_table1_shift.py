"""Table 1 read as a profile-shifted pair (issue 28 item 7; docs/mesh.md): the numbers the doc
quotes from the geometry."""

from __future__ import annotations

import dataclasses
import math

import pytest

from gearsweep.errors import GeometryError
from gearsweep.gear import table1_profile_shift


def test_profile_shift_reading_reconciles_the_radii():
    p = table1_profile_shift().check()
    assert p.operating_centre_distance == pytest.approx(102.31e-3, abs=0.005e-3)
    assert math.degrees(p.operating_pressure_angle) == pytest.approx(23.30, abs=0.005)
    assert p.contact_ratio == pytest.approx(1.580, abs=0.0005)
    ra1, ra2 = p.tip_radius
    rf1, rf2 = p.root_radius
    a = p.operating_centre_distance
    assert a - ra1 - rf2 == pytest.approx(0.81e-3, abs=0.005e-3)
    assert a - ra2 - rf1 == pytest.approx(0.81e-3, abs=0.005e-3)
    assert p.circumferential_backlash == pytest.approx(0.5e-3, rel=1e-9)
    s1, s2 = p.thickness
    assert (s1 * 1e3, s2 * 1e3) == (pytest.approx(4.56, abs=0.005), pytest.approx(4.63, abs=0.005))


def test_profile_shift_reading_keeps_the_fillet_problem():
    """The printed 1.4224 mm fillet does not fit the shifted teeth: check() refuses it."""
    with pytest.raises(GeometryError, match="fillet radius 1.42"):
        dataclasses.replace(table1_profile_shift(), fillet_radius=1.4224e-3).check()
