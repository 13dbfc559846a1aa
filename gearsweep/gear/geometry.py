"""Involute spur gear pair geometry: radii, line of action, contact ratio, backlash, checks.

All lengths are in metres, angles in radians, moduli in pascals. Gear 1 drives gear 2.

Conventions
-----------
* Tooth thickness ``thickness1/2`` is the circular (arc) thickness at the reference (cutting)
  pitch circle ``r = m z / 2``.
* ``backlash`` (input) is the circumferential (transverse) backlash at the operating pitch
  circle, the figure usually written on a drawing. :attr:`GearPair.backlash_loa` is the same
  backlash measured along the line of action (``j_t cos(alpha_w)``), which is what the dynamic
  model's dead zone uses (its half-width is ``backlash_loa / 2``).
* Positions on the line of action are measured from ``T1``, the tangency point of the line of
  action with the base circle of gear 1, towards ``T2``. Contact runs from ``s_start`` (where
  the tip circle of gear 2 cuts the line of action) to ``s_end`` (tip circle of gear 1).
* Tooth flank: involute above the base circle, radial line below it, joined to the root circle
  by a circular fillet of radius ``fillet_radius`` tangent to both (the gear's own fillet, not
  the cutter's trochoid).

References
----------
ISO 21771:2007 (gear geometry); Litvin & Fuentes, *Gear Geometry and Applied Theory*, 2004.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from gearsweep.errors import GeometryError

__all__ = [
    "GEAR_MODULUS",
    "SAINSOT_ROOT_ANGLE",
    "SAINSOT_ROOT_ANGLE_WARNED",
    "GearPair",
    "GeometryWarning",
    "involute",
    "inverse_involute",
    "table1_as_printed",
    "table1_consistent",
    "rim_factor",
]

_TOL_BACKLASH = 1e-6  # [m] given and computed backlash agree within 1 um
MAX_FACE_MODULES = 100.0
"""Widest face a pair may have, in modules: spur gears are about 6 to 40 modules wide (ISO
6336's b/m), a helical or a very wide one up to about 60; 100 and above is a unit slip (a
module in um, a face in inches written as mm)."""


GEAR_MODULUS = (0.5e9, 700e9)
"""Young's moduli of gear materials [Pa], outside which ``GearPair.cautions`` warns of a unit
slip (206 MPa for steel's 206 GPa ran, k0 = 0.219 kN/mm: an outside tester): the softest gear
plastics (UHMW-PE about 0.7 GPa, wet polyamide about 1 GPa; POM about 3) to cemented carbide
(up to about 700 GPa), steel 206 GPa, cast iron 100-170, bronze about 100. Warned, not refused:
a softer gear (an elastomer) can exist; what a slip does to the load is refused by
``mesh.load_faults``, a deflection beyond the tooth's thickness."""


SAINSOT_ROOT_ANGLE = (0.01, 0.12)
"""Root half angle ``theta_f`` [rad] over which Sainsot et al. (2004) fitted their gear-body term
(the range the paper states beside ``compliance.SAINSOT_BORE_RATIO``'s, as public gear-mesh
codes that carry its Table 1 quote it: find_string "0.01 <= gear.theta_f <= 0.12"); here, not
in ``compliance`` (which imports this module), as ``GearPair.cautions`` reads it too. Below it
``compliance.tooth_compliance`` refuses the pair, the fit being meaningless: its 1/theta_f^2
terms take over, P* (the body's own compliance) falls to zero at theta_f = 0.0047 to 0.0077
(h_fi = 7 to 1.4) and turns negative, and at 0.008 the term lies up to 22 % from the fit at
0.01 (a gear of more than pi / 0.01 = 314 teeth is always below it: theta_f < pi / z). Above it
the fit changes slowly and is extrapolated: see ``SAINSOT_ROOT_ANGLE_WARNED``."""

SAINSOT_ROOT_ANGLE_WARNED = 0.19
"""Root half angle [rad] above which ``GearPair.cautions`` warns that Sainsot et al.'s
gear-body term is extrapolated: up to it the term lies within 5 % of its value at the fitted
range's top, 0.12 (the worst over h_fi = 1.4 to 7, u_f / S_f = 0.3 to 3 and tan(beta) up to
0.5; 1 % at 0.13, 2.6 % at 0.15), and beyond it up to 11 % (at pi / 4, the widest root a tooth
of four or more teeth has). Unshifted pinions of fewer than 23 teeth (the default fillet) lie
above 0.12, those of 14 to 22 below 0.19: warning for every one of them would say nothing a
difference of a few percent in one of four compliance terms deserves."""


class GeometryWarning(UserWarning):
    """A gear pair that can exist but is poor practice (e.g. nearly pointed teeth). ``fields``:
    those that set what it warns of, the most responsible first (as ``GeometryError.faults``)."""

    def __init__(self, message: str, fields: tuple[str, ...] = ()) -> None:
        super().__init__(message)
        self.fields = tuple(fields)


def _ranked(fields: tuple[str, ...]) -> tuple[str, ...]:
    """``fields`` once each, teeth and module (which set every radius) after the others: a
    standard tip of gear 2 beside a shifted gear 1's root is said at ``x1``, not at ``z2``."""
    once = tuple(dict.fromkeys(fields))
    return (*(f for f in once if f not in ("z1", "z2", "module")),
            *(f for f in once if f in ("z1", "z2", "module")))


def _mm_down(length: float) -> str:
    """``length`` [m] in mm, rounded down to 0.01 mm: a bound 'at most' that itself fits."""
    return f"{math.floor(length * 1e5) / 100:g}"


def _mm_up(length: float) -> str:
    """``length`` [m] in mm, rounded up to 0.01 mm: a bound 'at least' that itself fits."""
    return f"{math.ceil(length * 1e5) / 100:g}"


def involute(alpha: float | np.ndarray) -> float | np.ndarray:
    """Involute function ``inv(alpha) = tan(alpha) - alpha``.

    Parameters
    ----------
    alpha : float or ndarray
        Pressure angle [rad].

    Returns
    -------
    float or ndarray
        Involute polar angle [rad].
    """
    return np.tan(alpha) - alpha


def inverse_involute(value: float) -> float:
    """Pressure angle whose involute is ``value`` (Brent's method on [0, 1.5] rad).

    Parameters
    ----------
    value : float
        Involute function value [rad], must be >= 0.

    Returns
    -------
    float
        Pressure angle [rad].
    """
    if not (0.0 <= value < involute(1.5)):
        why = (f"involute value {value:.6g} rad is outside [0, {involute(1.5):.3g}): the profile"
               " shifts give no valid operating pressure angle")
        raise GeometryError(f"gear pair: {why}", [(why, ("x1", "x2"))])
    if value == 0.0:
        return 0.0
    from scipy.optimize import brentq  # here: scipy.optimize takes 0.35 s to import

    return brentq(lambda a: math.tan(a) - a - value, 0.0, 1.5, xtol=1e-15, rtol=1e-15)


@dataclass(frozen=True)
class GearPair:
    """An external involute spur gear pair (gear 1 drives gear 2).

    Parameters
    ----------
    module : float
        Module [m].
    z1, z2 : int
        Tooth numbers of the driving gear 1 and the driven gear 2 [-].
    face_width : float
        Face width [m].
    pressure_angle : float
        Reference (rack) pressure angle [rad].
    x1, x2 : float
        Profile shift coefficients [-].
    tip_radius1, tip_radius2 : float or None
        Tip radii [m]; default ``r + m (1 + x)``.
    root_radius1, root_radius2 : float or None
        Root radii [m]; default ``r - m (1.25 - x)``.
    fillet_radius : float or None
        Radius of the root fillet of both gears [m]; default ``0.38 m``.
    centre_distance : float or None
        Operating centre distance [m]; default from the shifts through ``inv(alpha_w)``.
    backlash : float or None
        Circumferential backlash at the operating pitch circle [m]. If given without thicknesses,
        the standard thicknesses are reduced equally to produce it.
    thickness1, thickness2 : float or None
        Circular tooth thickness at the reference circle [m]. If given with ``backlash``, both
        must agree at the centre distance.
    youngs_modulus : float
        Young's modulus of both gears [Pa].
    poisson : float
        Poisson's ratio [-].
    bore_radius1, bore_radius2 : float or None
        Radius where the gear body is clamped to a rigid shaft [m] (Sainsot's ``r_int``);
        default half the root radius. Root radius over it within
        ``compliance.SAINSOT_BORE_RATIO`` (else the compliance refuses it); a larger one is
        stiffer: a thin rim is ``rim_thickness``.
    rim_thickness1, rim_thickness2 : float or None
        Rim thickness below the root circle of a webbed gear [m]; ``None`` for a solid body. At
        most the root radius less the bore radius (refused beyond); below one module, outside
        ISO 6336-1's range of the rim factor, it is taken at one module (warned).
    web_width1, web_width2 : float or None
        Web width of a webbed gear [m]; default ``face_width`` (i.e. a full web). At most the
        face width (refused beyond); below 0.2 of it, outside ISO's range, taken at 0.2 (warned).
    contact_ratio_range : tuple of float or None
        Contact ratio range the source states [-]; :meth:`check` reports a pair outside it.
    name : str
        A label for messages.
    """

    module: float
    z1: int
    z2: int
    face_width: float
    pressure_angle: float = math.radians(20.0)
    x1: float = 0.0
    x2: float = 0.0
    tip_radius1: float | None = None
    tip_radius2: float | None = None
    root_radius1: float | None = None
    root_radius2: float | None = None
    fillet_radius: float | None = None
    centre_distance: float | None = None
    backlash: float | None = None
    thickness1: float | None = None
    thickness2: float | None = None
    youngs_modulus: float = 206e9
    poisson: float = 0.3
    bore_radius1: float | None = None
    bore_radius2: float | None = None
    rim_thickness1: float | None = None
    rim_thickness2: float | None = None
    web_width1: float | None = None
    web_width2: float | None = None
    contact_ratio_range: tuple[float, float] | None = None
    name: str = "gear pair"

    def __post_init__(self) -> None:
        for field in ("module", "face_width", "pressure_angle", "youngs_modulus"):
            value = getattr(self, field)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise GeometryError(f"{self.name}: {field} = {value!r} must be a positive number")
        for field in ("z1", "z2"):
            value = getattr(self, field)
            if not (isinstance(value, int | np.integer) and value >= 3):
                raise GeometryError(f"{self.name}: {field} = {value!r} must be an integer >= 3")
        if not (0.0 <= self.poisson < 0.5):
            raise GeometryError(f"{self.name}: poisson = {self.poisson!r} must be in [0, 0.5)")
        if not (0.0 < self.pressure_angle < math.radians(45.0)):
            raise GeometryError(
                f"{self.name}: pressure angle {math.degrees(self.pressure_angle):.3g} deg "
                "must be in (0, 45) deg"
            )
        optional_positive = (
            "tip_radius1", "tip_radius2", "root_radius1", "root_radius2", "fillet_radius",
            "centre_distance", "thickness1", "thickness2", "bore_radius1", "bore_radius2",
            "rim_thickness1", "rim_thickness2", "web_width1", "web_width2",
        )  # fmt: skip
        for field in optional_positive:
            value = getattr(self, field)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise GeometryError(f"{self.name}: {field} = {value!r} must be positive")
        if self.backlash is not None and not (math.isfinite(self.backlash) and self.backlash >= 0):
            raise GeometryError(f"{self.name}: backlash = {self.backlash!r} must be >= 0")

    # ---------------------------------------------------------------- radii
    @property
    def pitch_radius1(self) -> float:
        """Reference pitch radius of gear 1 [m]."""
        return 0.5 * self.module * self.z1

    @property
    def pitch_radius2(self) -> float:
        """Reference pitch radius of gear 2 [m]."""
        return 0.5 * self.module * self.z2

    @property
    def base_radius1(self) -> float:
        """Base radius of gear 1 [m]."""
        return self.pitch_radius1 * math.cos(self.pressure_angle)

    @property
    def base_radius2(self) -> float:
        """Base radius of gear 2 [m]."""
        return self.pitch_radius2 * math.cos(self.pressure_angle)

    @property
    def tip_radius(self) -> tuple[float, float]:
        """Tip radii of gears 1 and 2 [m]."""
        m = self.module
        ra1 = (
            self.tip_radius1
            if self.tip_radius1 is not None
            else self.pitch_radius1 + m * (1.0 + self.x1)
        )
        ra2 = (
            self.tip_radius2
            if self.tip_radius2 is not None
            else self.pitch_radius2 + m * (1.0 + self.x2)
        )
        return ra1, ra2

    @property
    def root_radius(self) -> tuple[float, float]:
        """Root radii of gears 1 and 2 [m]."""
        m = self.module
        rf1 = (
            self.root_radius1
            if self.root_radius1 is not None
            else self.pitch_radius1 - m * (1.25 - self.x1)
        )
        rf2 = (
            self.root_radius2
            if self.root_radius2 is not None
            else self.pitch_radius2 - m * (1.25 - self.x2)
        )
        return rf1, rf2

    @property
    def fillet(self) -> float:
        """Root fillet radius [m]."""
        return self.fillet_radius if self.fillet_radius is not None else 0.38 * self.module

    @property
    def bore_radius(self) -> tuple[float, float]:
        """Clamped bore radii of gears 1 and 2 [m] (default half the root radius)."""
        rf1, rf2 = self.root_radius
        b1 = self.bore_radius1 if self.bore_radius1 is not None else 0.5 * rf1
        b2 = self.bore_radius2 if self.bore_radius2 is not None else 0.5 * rf2
        return b1, b2

    @property
    def base_pitch(self) -> float:
        """Base (normal) pitch ``pi m cos(alpha)`` [m]."""
        return math.pi * self.module * math.cos(self.pressure_angle)

    @property
    def circular_pitch(self) -> float:
        """Circular pitch at the reference circle ``pi m`` [m]."""
        return math.pi * self.module

    @property
    def standard_centre_distance(self) -> float:
        """Reference centre distance ``m (z1 + z2) / 2`` [m]."""
        return self.pitch_radius1 + self.pitch_radius2

    # ---------------------------------------------------------- operating mesh
    @cached_property
    def operating_pressure_angle(self) -> float:
        """Operating (working) transverse pressure angle ``alpha_w`` [rad].

        From the given centre distance (``cos alpha_w = (rb1 + rb2) / a``), or else from the
        profile shifts by solving
        ``inv(alpha_w) = inv(alpha) + 2 tan(alpha) (x1 + x2) / (z1 + z2)``.
        """
        if self.centre_distance is not None:
            rb_sum = self.base_radius1 + self.base_radius2
            c = rb_sum / self.centre_distance
            if c >= 1.0:
                why = (f"centre distance {self.centre_distance * 1e3:.4g} mm is not more than"
                       f" the sum of base radii {rb_sum * 1e3:.4g} mm")
                raise GeometryError(f"{self.name}: {why}", [(why, ("centre_distance",))])
            return math.acos(c)
        a = self.pressure_angle
        inv_w = involute(a) + 2.0 * math.tan(a) * (self.x1 + self.x2) / (self.z1 + self.z2)
        return inverse_involute(float(inv_w))

    @cached_property
    def operating_centre_distance(self) -> float:
        """Operating centre distance ``a`` [m]."""
        if self.centre_distance is not None:
            return self.centre_distance
        return (self.base_radius1 + self.base_radius2) / math.cos(self.operating_pressure_angle)

    @property
    def operating_pitch_radius(self) -> tuple[float, float]:
        """Operating pitch radii ``r_w = r_b / cos(alpha_w)`` of gears 1 and 2 [m]."""
        c = math.cos(self.operating_pressure_angle)
        return self.base_radius1 / c, self.base_radius2 / c

    @property
    def line_of_action_length(self) -> float:
        """Length ``T1 T2`` of the line of action between the base tangency points [m]."""
        return self.operating_centre_distance * math.sin(self.operating_pressure_angle)

    @property
    def s_start(self) -> float:
        """Start of contact on the line of action, measured from ``T1`` [m]."""
        ra2 = self.tip_radius[1]
        return self.line_of_action_length - math.sqrt(max(ra2**2 - self.base_radius2**2, 0.0))

    @property
    def s_end(self) -> float:
        """End of contact on the line of action, measured from ``T1`` [m]."""
        ra1 = self.tip_radius[0]
        return math.sqrt(max(ra1**2 - self.base_radius1**2, 0.0))

    @property
    def s_pitch(self) -> float:
        """Pitch point on the line of action, measured from ``T1`` [m]."""
        return self.base_radius1 * math.tan(self.operating_pressure_angle)

    @property
    def path_of_contact(self) -> float:
        """Length of the path of contact ``g_alpha`` [m]."""
        return self.s_end - self.s_start

    @property
    def path_of_approach(self) -> float:
        """Approach part of the path of contact (start to pitch point) [m]."""
        return self.s_pitch - self.s_start

    @property
    def path_of_recess(self) -> float:
        """Recess part of the path of contact (pitch point to end) [m]."""
        return self.s_end - self.s_pitch

    @property
    def contact_ratio(self) -> float:
        """Transverse contact ratio ``epsilon_alpha = g_alpha / p_b`` [-]."""
        return self.path_of_contact / self.base_pitch

    def contact_radii(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Radii of the contact point on gear 1 and gear 2 at line-of-action positions ``s``.

        Parameters
        ----------
        s : float or ndarray
            Position on the line of action measured from ``T1`` [m].

        Returns
        -------
        tuple of ndarray
            Contact radius on gear 1 and on gear 2 [m].
        """
        s = np.asarray(s, dtype=float)
        r1 = np.sqrt(self.base_radius1**2 + s**2)
        r2 = np.sqrt(self.base_radius2**2 + (self.line_of_action_length - s) ** 2)
        return r1, r2

    # ---------------------------------------------------------- thickness
    def _standard_thickness(self, x: float) -> float:
        return self.module * (0.5 * math.pi + 2.0 * x * math.tan(self.pressure_angle))

    def _thickness_at_operating_circle(self, s_ref: float, r_ref: float, r_w: float) -> float:
        a, aw = self.pressure_angle, self.operating_pressure_angle
        return 2.0 * r_w * (s_ref / (2.0 * r_ref) + involute(a) - involute(aw))

    def _backlash_from(self, s1: float, s2: float) -> float:
        rw1, rw2 = self.operating_pitch_radius
        sw1 = self._thickness_at_operating_circle(s1, self.pitch_radius1, rw1)
        sw2 = self._thickness_at_operating_circle(s2, self.pitch_radius2, rw2)
        return 2.0 * math.pi * rw1 / self.z1 - sw1 - sw2

    @cached_property
    def thickness(self) -> tuple[float, float]:
        """Circular tooth thicknesses at the reference circles of gears 1 and 2 [m]."""
        s1 = self.thickness1 if self.thickness1 is not None else self._standard_thickness(self.x1)
        s2 = self.thickness2 if self.thickness2 is not None else self._standard_thickness(self.x2)
        if self.backlash is not None and self.thickness1 is None and self.thickness2 is None:
            extra = self.backlash - self._backlash_from(s1, s2)
            # A thinning ds at the reference circle is ds * r_w / r at the operating circle.
            scale = math.cos(self.operating_pressure_angle) / math.cos(self.pressure_angle)
            s1 -= 0.5 * extra * scale
            s2 -= 0.5 * extra * scale
        return float(s1), float(s2)

    @property
    def circumferential_backlash(self) -> float:
        """Circumferential backlash at the operating pitch circle from the thicknesses [m];
        exactly 0 for a pair given none of backlash, thicknesses and centre distance, which
        meshes tight by construction (the shift formula left 1.3e-18 m: an outside tester)."""
        if (self.backlash is None and self.thickness1 is None and self.thickness2 is None
                and self.centre_distance is None):
            return 0.0
        return self._backlash_from(*self.thickness)

    @property
    def backlash_loa(self) -> float:
        """Total backlash along the line of action ``j_t cos(alpha_w)`` [m]."""
        return self.circumferential_backlash * math.cos(self.operating_pressure_angle)

    def half_angle(self, r: np.ndarray | float, gear: int) -> np.ndarray:
        """Half tooth-thickness angle ``psi(r)`` of the involute flank at radius ``r``.

        Parameters
        ----------
        r : float or ndarray
            Radius >= base radius [m].
        gear : {1, 2}
            Which gear.

        Returns
        -------
        ndarray
            Angle between the tooth centre line and the flank point [rad].
        """
        rb = self.base_radius1 if gear == 1 else self.base_radius2
        rp = self.pitch_radius1 if gear == 1 else self.pitch_radius2
        s = self.thickness[gear - 1]
        r = np.asarray(r, dtype=float)
        alpha_r = np.arccos(np.clip(rb / r, -1.0, 1.0))
        return s / (2.0 * rp) + involute(self.pressure_angle) - involute(alpha_r)

    def tip_thickness(self, gear: int) -> float:
        """Chordal-free (arc) tooth thickness at the tip circle [m]."""
        ra = self.tip_radius[gear - 1]
        return float(2.0 * ra * self.half_angle(ra, gear))

    # ---------------------------------------------------------- tooth outline
    def fillet_geometry(self, gear: int) -> tuple[float, float, float]:
        """Fillet circle tangent to the root circle and to the flank.

        Parameters
        ----------
        gear : {1, 2}
            Which gear.

        Returns
        -------
        tuple of float
            ``(theta_f, r_tangent, psi_tangent)``: angle of the fillet centre (and of the
            fillet-root tangency) from the tooth centre line [rad], radius [m] and angle [rad]
            of the point where the fillet meets the flank.
        """
        rf = self.root_radius[gear - 1]
        rb = self.base_radius1 if gear == 1 else self.base_radius2
        rho = self.fillet
        rc = rf + rho  # fillet centre lies on this circle
        psi_b = float(self.half_angle(rb, gear))
        # Flank below the base circle: radial line at psi_b. Fillet tangent to it:
        theta_radial = psi_b + math.asin(rho / rc)
        r_tan_radial = math.sqrt(rc**2 - rho**2)
        if rf >= rb or r_tan_radial > rb:
            # The fillet meets the involute part: find the centre angle theta for which the
            # distance from the centre to the involute equals rho (Brent on theta).
            ra = self.tip_radius[gear - 1]
            rr = np.linspace(max(rb, rf), ra, 4001)
            psi = self.half_angle(rr, gear)
            px, py = rr * np.sin(psi), rr * np.cos(psi)

            def gap(theta: float) -> float:
                cx, cy = rc * math.sin(theta), rc * math.cos(theta)
                return float(np.min(np.hypot(px - cx, py - cy))) - rho

            lo = float(self.half_angle(max(rb, rf), gear))
            hi = lo + math.pi / 2
            if rf < rb:  # radial segment below rb still constrains from below
                lo = psi_b
            if gap(lo) > 0:
                theta = lo
            else:
                from scipy.optimize import brentq

                theta = brentq(gap, lo, hi, xtol=1e-13)
            cx, cy = rc * math.sin(theta), rc * math.cos(theta)
            k = int(np.argmin(np.hypot(px - cx, py - cy)))
            return theta, float(rr[k]), float(psi[k])
        return theta_radial, r_tan_radial, psi_b

    def active_root_radius(self, g: int) -> float:
        """Radius of gear ``g``'s lowest contact point, ISO 21771's start of active profile
        ``r_Nf = sqrt(r_b^2 + (a sin(alpha_w) - sqrt(r_a'^2 - r_b'^2))^2)`` (the mate's tip at
        ``r_a'`` cuts the line of action there) [m]."""
        rb = self.base_radius1 if g == 1 else self.base_radius2
        return math.hypot(rb, self._lowest_contact(g))

    def _rack_flank_depth(self, g: int) -> tuple[float, float]:
        """Depth below gear ``g``'s reference circle of the generating rack's tip line and of
        the end of its straight flank [m]: a rack whose tip is rounded by the fillet radius and
        reaches the root circle."""
        r = self.pitch_radius1 if g == 1 else self.pitch_radius2
        depth = r - self.root_radius[g - 1]
        return depth, depth - self.fillet * (1.0 - math.sin(self.pressure_angle))

    def undercut_radius(self, g: int) -> float | None:
        """Radius up to which the generating rack's rounded tip cuts gear ``g``'s involute
        (``None``: no undercut, the straight rack flank ends within ``r sin^2(alpha)`` of the
        reference line) [m].

        The rack rolls on the reference circle ``r``: at rolling angle ``t`` its flank makes the
        involute point at radius ``r sqrt(1 + 2 t sin(a) cos(a) + t^2 cos^2(a))`` (``t =
        -tan(a)``: the base circle), and the centre of its tip round (radius ``rho``) traces a
        trochoid; the involute is cut where it comes within ``rho`` of that trochoid, from the
        base circle up to the root (Brent on ``t``) of that clearance.
        """
        r = self.pitch_radius1 if g == 1 else self.pitch_radius2
        a, rho = self.pressure_angle, self.fillet
        sa, ca = math.sin(a), math.cos(a)
        depth, straight = self._rack_flank_depth(g)
        if straight <= r * sa**2 + 1e-12:
            return None
        # rack frame: reference line y = r, the flank through (0, r) with the tooth at x < 0
        cx, cy = -straight * math.tan(a) - rho * ca, r - depth + rho  # tip round's centre
        near = np.linspace(-1.0, 1.0, 2001) * min(4.0 * depth / r, 1.0)  # positions near it

        def clearance(t: float) -> float:  # of the involute point made at t, to the round
            vx, vy = -r * t * ca**2, r * (1.0 + t * sa * ca)  # its place while being made

            def gap(phi: np.ndarray) -> np.ndarray:  # with the rack at rolling angle phi
                d = phi - t
                x = r * phi + np.cos(d) * vx - np.sin(d) * vy
                return np.hypot(x - cx, np.sin(d) * vx + np.cos(d) * vy - cy) - rho

            phi = t + near
            k = int(np.argmin(gap(phi)))
            from scipy.optimize import minimize_scalar

            lo, hi = phi[max(k - 1, 0)], phi[min(k + 1, phi.size - 1)]
            return float(minimize_scalar(lambda p: float(gap(np.array(p))), bounds=(lo, hi),
                                         method="bounded", options={"xatol": 1e-14}).fun)

        base = -math.tan(a)
        t = base
        if clearance(base) < 0:
            from scipy.optimize import brentq

            t = brentq(clearance, base, 0.0, xtol=1e-14)
        return r * math.sqrt(1.0 + 2.0 * t * sa * ca + (t * ca) ** 2)

    # ---------------------------------------------------------- checks
    def problems(self) -> list[str]:
        """Every reason this pair cannot exist as specified, each with its numbers.

        Returns
        -------
        list of str
            Empty for a consistent pair (the messages of :meth:`faults`).
        """
        return [message for message, _ in self.faults()]

    def sets(self, quantity: str, g: int = 0) -> tuple[str, ...]:
        """The fields that set the pair's ``quantity`` (``tip`` or ``root`` radius of gear ``g``,
        ``centre`` distance, ``thickness`` of gear ``g``): the field itself where it is given,
        else those it follows (a standard tip ``r + m (1 + x)``: ``x1``, ``z1``, ``module``; the
        centre distance of the shifts: the larger shift first)."""
        own = {"tip": f"tip_radius{g}", "root": f"root_radius{g}", "centre": "centre_distance",
               "thickness": f"thickness{g}"}[quantity]
        if getattr(self, own) is not None:
            return (own,)
        if quantity == "centre":
            return tuple(sorted(("x1", "x2"), key=lambda f: -getattr(self, f)))
        return (f"x{g}", f"z{g}", "module")

    def _interference_sets(self, g: int) -> tuple[str, ...]:
        """The fields that set the involute interference of gear ``g``'s tip with its mate's
        flank below the base circle: its tip radius where given, else the mate's shift and teeth
        (a small mate's short line of action; a positive shift of it the usual cure), then its
        own, the centre distance."""
        mate = 3 - g
        own = (f"tip_radius{g}",) if getattr(self, f"tip_radius{g}") is not None else ()
        return tuple(dict.fromkeys((*own, f"x{mate}", f"z{mate}", *self.sets("tip", g),
                                    *self.sets("centre"))))

    def _path_blame(self, shorter: bool) -> tuple[str, ...]:
        """The fields that set the path of contact, those of the quantity (a tip radius, the
        centre distance) that shortens it most (``shorter``; else lengthens it most) against a
        standard pair's (tips ``r + m``, centre distance ``r1 + r2``) first: each alone."""
        m = self.module
        rb1, rb2 = self.base_radius1, self.base_radius2

        def reach(ra: float, rb: float) -> float:  # a tip's part of the path
            return math.sqrt(max(ra**2 - rb**2, 0.0))

        def loa(a: float) -> float:  # T1 T2 at centre distance a
            return math.sqrt(max(a**2 - (rb1 + rb2) ** 2, 0.0))

        ra1, ra2 = self.tip_radius
        shortening = {
            ("tip", 1): reach(self.pitch_radius1 + m, rb1) - reach(ra1, rb1),
            ("tip", 2): reach(self.pitch_radius2 + m, rb2) - reach(ra2, rb2),
            ("centre", 0): loa(self.operating_centre_distance) - loa(self.standard_centre_distance),
        }
        order = sorted(shortening, key=lambda q: -shortening[q] if shorter else shortening[q])
        return tuple(dict.fromkeys(f for q in order for f in self.sets(*q)))

    def faults(self) -> list[tuple[str, tuple[str, ...]]]:
        """Every reason this pair cannot exist as specified, each with its numbers and what would
        fit, as ``(message, fields)``: ``fields`` those that set it, the most responsible first
        (teeth and module, which set every radius, after the others).

        Returns
        -------
        list of tuple
            Empty for a consistent pair.
        """
        return list(_memo(_faults_of, self))

    def _faults(self) -> list[tuple[str, tuple[str, ...]]]:
        out: list[tuple[str, tuple[str, ...]]] = []
        mm = 1e3
        width = self.face_width / self.module
        if not 0.5 <= width <= MAX_FACE_MODULES:  # a unit slip ('module: 2 um' beside a 20 mm
            out.append((  # face ran, 1000x the tooth depth of STE; an outside tester's finding)
                (f"face width {self.face_width * mm:.4g} mm is"
                f" {f'{width:,.0f}' if width >= 10 else f'{width:.2g}'} modules of"
                f" {self.module * mm:.4g} mm: a spur gear's is 0.5 to {MAX_FACE_MODULES:g}"
                f" modules ({0.5 * self.module * mm:.4g} to"
                f" {MAX_FACE_MODULES * self.module * mm:.4g} mm; a unit slip?)"),
                ("face_width", "module")))
        out += self._rim_faults()
        a = self.operating_centre_distance
        ra1, ra2 = self.tip_radius
        rf1, rf2 = self.root_radius
        rb = (self.base_radius1, self.base_radius2)
        for g, (ra, rf_mate) in enumerate(((ra1, rf2), (ra2, rf1)), start=1):
            overlap = ra + rf_mate - a
            if overlap > 1e-9:
                out.append((
                    (f"tip-root interference: tip radius of gear {g} ({ra * mm:.4g} mm) + root "
                    f"radius of gear {3 - g} ({rf_mate * mm:.4g} mm) exceeds the centre distance "
                    f"{a * mm:.4g} mm by {overlap * mm:.3g} mm; a tip radius of gear {g} of at"
                    f" most {_mm_down(a - rf_mate)} mm fits (tip_radius{g})"
                    f"{self._own_centre_said(f'at least {_mm_up(ra + rf_mate)} mm')}"),
                    (*self.sets("tip", g), *self.sets("root", 3 - g), *self.sets("centre"))))
        basic: list[tuple[str, tuple[str, ...]]] = []
        for g in (1, 2):
            ra, rf = self.tip_radius[g - 1], self.root_radius[g - 1]
            if not rf < ra:
                basic.append((
                    (f"gear {g}: root radius {rf * mm:.4g} mm is not below tip radius "
                    f"{ra * mm:.4g} mm"), (*self.sets("root", g), *self.sets("tip", g))))
            if ra <= rb[g - 1]:
                basic.append((
                    (f"gear {g}: tip radius {ra * mm:.4g} mm is not above base radius "
                    f"{rb[g - 1] * mm:.4g} mm"), (*self.sets("tip", g), "pressure_angle")))
        if basic:
            return out + basic + self._thickness_faults()
        # Undercut in generation by a rack whose tip radius equals the fillet radius: refused
        # where it reaches the active profile (contact on a flank the model's involute is not)
        for g in (1, 2):
            top = self.undercut_radius(g)
            if top is not None and self._contact_on_cut(g, top):
                out.append((
                    (f"undercut: {self._undercut_said(g, top)}, on the cut flank, which the"
                    f" model's involute is not{self._mate_tip_cure(g, top)}"
                    f"{self._undercut_cure(g)}"), self.sets("root", g)))
        # Involute interference: contact outside the segment T1 T2.
        length = self.line_of_action_length
        if self.s_start < 0:
            out.append((
                (f"involute interference: the tip of gear 2 meets gear 1 below its base circle "
                f"(start of contact {-self.s_start * mm:.3g} mm before T1); a tip radius of gear"
                f" 2 of at most {_mm_down(math.hypot(rb[1], length))} mm fits (tip_radius2)"),
                self._interference_sets(2)))
        if self.s_end > length:
            out.append((
                (f"involute interference: the tip of gear 1 meets gear 2 below its base circle "
                f"(end of contact {(self.s_end - length) * mm:.3g} mm past T2); a tip radius of"
                f" gear 1 of at most {_mm_down(math.hypot(rb[0], length))} mm fits"
                " (tip_radius1)"), self._interference_sets(1)))
        eps = self.contact_ratio
        if ra1 + ra2 <= a:  # said as "contact ratio -1.916" (an outside tester's finding); and
            out.append((  # alone: its contact ratio, a fillet at a root the mate never meets,
                # are its consequences (a preset's 100 mm at module 2 mm said all three)
                (f"the teeth do not reach each other: tip radii {ra1 * mm:.4g} + {ra2 * mm:.4g} mm"
                f" = {(ra1 + ra2) * mm:.4g} mm, not more than the centre distance {a * mm:.4g} mm"
                f"{self._own_centre_said()}"),
                self._path_blame(shorter=True)))
            return out
        if eps < 1.0:
            out.append((
                (f"contact ratio {eps:.3f} is below 1: path of contact "
                f"{self.path_of_contact * mm:.4g} mm is shorter than the base pitch "
                f"{self.base_pitch * mm:.4g} mm{self._contact_ratio_cure()}"),
                self._path_blame(shorter=True)))
        if self.contact_ratio_range is not None:
            lo, hi = self.contact_ratio_range
            if not (lo <= eps <= hi):
                out.append((f"contact ratio {eps:.3f} is outside the stated range [{lo:g}, {hi:g}]",
                            self._path_blame(shorter=eps < lo)))
        out += self._thickness_faults()
        for g in (1, 2):
            sa = self.tip_thickness(g)
            if sa <= 0:
                cure, fields = self._pointed_cure(g)
                out.append((
                    (f"pointed teeth: gear {g} tip thickness {sa * mm:.3g} mm <= 0 at tip radius "
                    f"{self.tip_radius[g - 1] * mm:.4g} mm; {cure}"),
                    tuple(dict.fromkeys((*fields, *self._tip_thickness_sets(g))))))
        if any(p.startswith(("pointed", "tooth", "tip-root")) for p, _ in out):
            return out
        # Fillet: must fit in the tooth space and stay below the active profile.
        for g in (1, 2):
            z = self.z1 if g == 1 else self.z2
            theta_f, r_tan, _ = self.fillet_geometry(g)
            if theta_f > math.pi / z:
                default = " (the default, 0.38 module)" if self.fillet_radius is None else ""
                out.append((
                    (f"fillet radius {self.fillet * mm:.4g} mm{default} does not fit the tooth"
                    f" space of gear {g} at its root circle: fillet centre at"
                    f" {math.degrees(theta_f):.3g} deg from the tooth centre line, beyond the"
                    f" space centre at {180.0 / z:.3g} deg; at most"
                    f" {self._largest_fillet(g) * mm:.3g} mm fits (fillet_radius)"),
                    ("fillet_radius", *self.sets("root", g))))
                continue
            r_low = self.active_root_radius(g)
            if r_tan > r_low + 1e-12:
                out.append((
                    (f"tip-fillet interference: gear {g} fillet reaches radius {r_tan * mm:.4g} mm, "
                    f"above the lowest contact point at {r_low * mm:.4g} mm"
                    f"{self._mate_tip_cure(g, r_tan)}"),
                    (*self.sets("tip", 3 - g), "fillet_radius", *self.sets("root", g))))
        return out

    def _rim_faults(self) -> list[tuple[str, tuple[str, ...]]]:
        """A rim below the bore (thicker than the root radius less the bore radius) or a web
        wider than the face: accepted, a 200 mm web on a 20 mm face made the gear stiffer than a
        solid one (ISO's C_R > 1 beyond b_s = b; an outside tester)."""
        out = []
        for g in (1, 2):
            s_r, web = getattr(self, f"rim_thickness{g}"), getattr(self, f"web_width{g}")
            rf, bore = self.root_radius[g - 1], self.bore_radius[g - 1]
            if s_r is not None and s_r > rf - bore + 1e-12:
                default = (" (the default, half the root radius)"
                           if getattr(self, f"bore_radius{g}") is None else "")
                out.append(((f"gear {g}: rim thickness {s_r * 1e3:.4g} mm is more than the root"
                             f" radius {rf * 1e3:.4g} mm less the bore radius {bore * 1e3:.4g} mm"
                             f"{default}: at most {_mm_down(rf - bore)} mm fits"
                             f" (rim_thickness{g})"),
                            (f"rim_thickness{g}", f"bore_radius{g}", *self.sets("root", g))))
            if web is not None and web > self.face_width * (1 + 1e-12):
                out.append(((f"gear {g}: web width {web * 1e3:.4g} mm is more than the face width"
                             f" {self.face_width * 1e3:.4g} mm: at most"
                             f" {_mm_down(self.face_width)} mm fits (web_width{g}; a full web is"
                             " the face width)"), (f"web_width{g}", "face_width")))
        return out

    def _rim_cautions(self) -> list[tuple[str, tuple[str, ...]]]:
        """A rim or web outside the range ISO 6336-1 states for its rim factor (s_R >= m,
        b_s / b >= 0.2), where :func:`rim_factor` takes it at the bound: a 0.1 mm rim on
        a 1 mm web gave exactly the k0 of a 3 mm rim on a 4 mm web, unsaid (an outside
        tester). Warned, not refused: such a gear exists, and the empirical factor has no value
        beyond its range to give instead."""
        out = []
        m, b = self.module, self.face_width
        for g in (1, 2):
            s_r, web = getattr(self, f"rim_thickness{g}"), getattr(self, f"web_width{g}")
            if s_r is None:
                continue  # a solid gear: C_R = 1
            c_r = f"(C_R = {rim_factor(self, g):.4f})"
            if s_r < m * (1 - 1e-12):
                out.append(((f"gear {g}: rim thickness {s_r * 1e3:.4g} mm is {s_r / m:.3g} modules,"
                             " below ISO 6336-1's range of its rim factor (s_R >= m ="
                             f" {m * 1e3:.4g} mm): C_R is taken at s_R = m {c_r}"),
                            (f"rim_thickness{g}",)))
            if web is not None and web < 0.2 * b * (1 - 1e-12):
                out.append(((f"gear {g}: web width {web * 1e3:.4g} mm is {web / b:.3g} of the face"
                             " width, below ISO 6336-1's range of its rim factor (b_s / b >="
                             f" 0.2): C_R is taken at b_s = 0.2 b = {0.2 * b * 1e3:.4g} mm {c_r}"),
                            (f"web_width{g}",)))
        return out

    def _lowest_contact(self, g: int) -> float:
        """Where contact starts on gear ``g``'s flank, on the line of action from its base
        tangency point (``<= 0``: at or below its base circle) [m]."""
        return self.s_start if g == 1 else self.line_of_action_length - self.s_end

    def _contact_on_cut(self, g: int, top: float) -> bool:
        """Whether gear ``g``'s contact starts at or below ``top``, the radius its undercut
        reaches (:meth:`undercut_radius`): on a flank that the model's involute is not."""
        return self._lowest_contact(g) <= 0 or self.active_root_radius(g) <= top

    def _undercut_said(self, g: int, top: float) -> str:
        """What undercuts gear ``g``: the rack's straight flank past ``r sin^2(alpha)``, which
        cuts its involute from the base circle up to radius ``top`` (:meth:`undercut_radius`);
        and where its contact starts (:meth:`active_root_radius`), as heights above the base
        circle [um]."""
        r = self.pitch_radius1 if g == 1 else self.pitch_radius2
        rb = self.base_radius1 if g == 1 else self.base_radius2
        low = ("below it" if self._lowest_contact(g) <= 0 else
               f"{(self.active_root_radius(g) - rb) * 1e6:.3g} um above it")
        return (f"gear {g} (z = {self.z1 if g == 1 else self.z2},"
                f" x = {self.x1 if g == 1 else self.x2:.3g}) is undercut by the generating rack:"
                f" straight rack flank reaches {self._rack_flank_depth(g)[1] * 1e3:.3g} mm inside"
                f" the reference circle, more than r sin^2(alpha) ="
                f" {r * math.sin(self.pressure_angle) ** 2 * 1e3:.3g} mm; its involute is cut up"
                f" to {(top - rb) * 1e6:.3g} um above its base circle ({rb * 1e3:.5g} mm) and"
                f" contact starts {low}")

    def _undercut_cure(self, g: int) -> str:
        """What keeps gear ``g`` uncut: the root follows the shift (``m (1.25 - x)`` below
        ``r``) unless it is given; a shift ``x + (h - limit) / m`` (or that root radius) brings
        the rack's straight flank back to ``r sin^2(alpha)``."""
        r = self.pitch_radius1 if g == 1 else self.pitch_radius2
        x = self.x1 if g == 1 else self.x2
        limit = r * math.sin(self.pressure_angle) ** 2
        depth, straight = self._rack_flank_depth(g)
        if getattr(self, f"root_radius{g}") is not None:
            return (f"; a root radius of at least {_mm_up(r - limit - (depth - straight))} mm"
                    f" avoids it (root_radius{g})")
        return f"; a profile shift x{g} >= {x + (straight - limit) / self.module:.3g} avoids it"

    def _mate_tip_cure(self, g: int, radius: float) -> str:
        """The largest tip radius of gear ``g``'s mate whose contact starts on gear ``g`` above
        ``radius`` (ISO 21771's ``r_Nf`` at least ``radius``: the mate's tip at most
        ``sqrt(r_b'^2 + (a sin(alpha_w) - sqrt(radius^2 - r_b^2))^2)``), or that none does."""
        mate = 3 - g
        rb = self.base_radius1 if g == 1 else self.base_radius2
        rb_mate = self.base_radius2 if g == 1 else self.base_radius1
        reach = self.line_of_action_length - math.sqrt(max(radius**2 - rb**2, 0.0))
        if reach <= 0:
            return f"; no tip radius of gear {mate} fits"
        return (f"; a tip radius of gear {mate} of at most {_mm_down(math.hypot(rb_mate, reach))}"
                f" mm fits (tip_radius{mate})")

    def own_centre_distance(self) -> float | None:
        """The centre distance the teeth and shifts give (``inv(alpha_w)``, the default), where a
        given ``centre_distance`` differs from it by more than 1 nm (else ``None``) [m]."""
        if self.centre_distance is None:
            return None
        try:
            own = dataclasses.replace(self, centre_distance=None).operating_centre_distance
        except GeometryError:
            return None
        return own if abs(own - self.centre_distance) > 1e-9 else None

    def _own_centre_said(self, fits: str = "") -> str:
        """What a given centre distance that is not the teeth's and shifts' own changes: ``fits``
        (``at least 100.63 mm``) where one is known, and that own one; the field
        ``centre_distance``. Empty where it is their own (or none is given)."""
        own = self.own_centre_distance()
        if own is None:
            return ""
        given = (f"(centre_distance, given as {self.centre_distance * 1e3:.5g} mm; the teeth and"
                 f" shifts give {own * 1e3:.5g} mm)")
        return f"; or a centre distance of {fits} fits {given}" if fits else (
            f"; a centre distance below {_mm_down(self.tip_radius[0] + self.tip_radius[1])} mm"
            f" lets them reach {given}")

    def _contact_ratio_cure(self) -> str:
        """What alone gives a contact ratio of 1: the tip radius or the centre distance that
        shortens the path of contact most (:meth:`_path_blame`), the others kept."""
        rb1, rb2 = self.base_radius1, self.base_radius2
        ra1, ra2 = self.tip_radius
        reach2 = math.sqrt(ra2**2 - rb2**2)
        lead = self._path_blame(shorter=True)[0]
        if lead in self.sets("tip", 1):
            return (f"; a tip radius of gear 1 of at least"
                    f" {_mm_up(math.hypot(rb1, self.s_start + self.base_pitch))} mm gives 1"
                    " (tip_radius1)")
        if lead in self.sets("tip", 2):
            need = self.line_of_action_length - self.s_end + self.base_pitch
            return (f"; a tip radius of gear 2 of at least {_mm_up(math.hypot(rb2, need))} mm"
                    " gives 1 (tip_radius2)")
        length = self.s_end + reach2 - self.base_pitch  # T1 T2 that gives a path of p_b
        if length <= 0:
            return ""
        return (f"; a centre distance of at most {_mm_down(math.hypot(rb1 + rb2, length))} mm"
                " gives 1 (centre_distance)")

    def _tip_thickness_sets(self, g: int) -> tuple[str, ...]:
        """The fields that set the tip thickness of gear ``g``: its tip radius where given, its
        shift, its given thickness, the backlash that thins it, then teeth and module."""
        own = tuple(f for f in (f"tip_radius{g}", f"x{g}", f"thickness{g}")
                    if getattr(self, f) is not None)
        return tuple(dict.fromkeys((*own, "backlash", *self.sets("tip", g))))

    def _pointed_cure(self, g: int) -> tuple[str, tuple[str, ...]]:
        """What gives gear ``g``'s pointed tooth a tip, and the field it names first: a tip radius
        below the radius where its flanks meet; where they meet at or below the base circle
        (heavy thinning for backlash) no tip radius fits, but a smaller backlash, else a thicker
        tooth, does."""
        rb = self.base_radius1 if g == 1 else self.base_radius2
        meet = self.pointed_radius(g)
        if meet > rb:
            eps = dataclasses.replace(self, **{f"tip_radius{g}": meet}).contact_ratio
            if eps >= 1.0:
                return (f"its flanks meet at radius {meet * 1e3:.4g} mm: a tip radius below it"
                        f" fits (tip_radius{g})"), ()
            said = (f"its flanks meet at radius {meet * 1e3:.4g} mm, and a tip there leaves a"
                    f" contact ratio of {eps:.3f}, below 1")
        else:
            said = (f"its flanks meet at or below its base circle ({rb * 1e3:.4g} mm), so no"
                    " tip radius fits")
        most = self._backlash_leaving(g, 0.0)
        if most is not None and most >= 0:
            return (f"{said}; a backlash of at most {_mm_down(most)} mm leaves it a tooth to its"
                    " tip (backlash)"), ("backlash",)
        ra, rp = self.tip_radius[g - 1], self.pitch_radius1 if g == 1 else self.pitch_radius2
        least = self.thickness[g - 1] - self.tip_thickness(g) * rp / ra  # (its angle at r_p)
        return (f"{said}; a thickness{g} of at least {_mm_up(least)} mm does"
                f" (thickness{g})"), (f"thickness{g}",)

    def _backlash_leaving(self, g: int, tip: float) -> float | None:
        """The backlash that leaves gear ``g`` a tip thickness ``tip`` [m], where the backlash
        thins the teeth (given without thicknesses; else ``None``): less backlash thickens
        each tooth by half the difference at the operating pitch circle ``r_w``, by that
        angle at the tip radius ``r_a``."""
        if self.backlash is None or self.thickness1 is not None or self.thickness2 is not None:
            return None
        ra, rw = self.tip_radius[g - 1], self.operating_pitch_radius[g - 1]
        return self.backlash - 2.0 * (tip - self.tip_thickness(g)) * rw / ra

    def pointed_radius(self, g: int) -> float:
        """The radius where the flanks of gear ``g``'s tooth meet (its tip thickness 0) [m]."""
        rb = self.base_radius1 if g == 1 else self.base_radius2
        psi_b = float(self.half_angle(rb, g))  # = inv(alpha_r) where the flanks meet
        return rb / math.cos(inverse_involute(psi_b)) if psi_b > 0 else rb  # (at the base circle)

    def _largest_fillet(self, g: int) -> float:
        """The largest fillet radius whose centre lies within gear ``g``'s tooth space at its
        root circle [m] (bisection on ``fillet_geometry``, rounded down to 0.01 mm: a refusal
        names what fits; an outside gear engineer's 25 deg pair fitted 0.5 mm, not 0.76)."""
        z = self.z1 if g == 1 else self.z2
        lo, hi = 0.0, self.fillet
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            theta = dataclasses.replace(self, fillet_radius=mid).fillet_geometry(g)[0]
            lo, hi = (mid, hi) if theta <= math.pi / z else (lo, mid)
        return math.floor(lo * 1e5) / 1e5

    def _thickness_faults(self) -> list[tuple[str, tuple[str, ...]]]:
        out: list[tuple[str, tuple[str, ...]]] = []
        mm = 1e3
        s1, s2 = self.thickness
        j = self.circumferential_backlash
        p_w = 2.0 * math.pi * self.operating_pitch_radius[0] / self.z1
        if self.backlash is not None and (
            self.thickness1 is not None or self.thickness2 is not None
        ):
            if abs(j - self.backlash) > _TOL_BACKLASH:
                out.append((
                    (f"tooth thickness and backlash cannot coexist at centre distance "
                    f"{self.operating_centre_distance * mm:.4g} mm: thicknesses {s1 * mm:.4g} + "
                    f"{s2 * mm:.4g} mm leave a backlash of {j * mm:.4g} mm (circular pitch "
                    f"{p_w * mm:.4g} mm), not the given {self.backlash * mm:.4g} mm"),
                    ("backlash", "thickness1", "thickness2", *self.sets("centre"))))
                return out
        if j < -1e-12:  # [m] round-off of a zero-backlash pair
            given = [g for g in (1, 2) if getattr(self, f"thickness{g}") is not None]
            # a thinning ds at the reference circle is ds cos(alpha) / cos(alpha_w) at the
            # operating pitch circle, where the backlash is
            ratio = math.cos(self.operating_pressure_angle) / math.cos(self.pressure_angle)
            most = {g: self.thickness[g - 1] + j * ratio for g in given}
            fit = [g for g in given if math.floor(most[g] * 1e5) > 0]  # (0.01 mm and up)
            left = {1: self._backlash_from(0.0, s2), 2: self._backlash_from(s1, 0.0)}
            cure = "".join(f"; a thickness{g} of at most {_mm_down(most[g])} mm fits"
                           for g in fit[:1]) or "".join(
                f"; no thickness{g} fits: one of 0 leaves a backlash of {left[g] * mm:.4g} mm"
                for g in given)
            out.append((
                (f"tooth thicknesses {s1 * mm:.4g} + {s2 * mm:.4g} mm do not fit the circular pitch "
                f"{p_w * mm:.4g} mm at centre distance "
                f"{self.operating_centre_distance * mm:.4g} mm (backlash would be {j * mm:.4g} mm)"
                f"{cure}"),
                (*(f"thickness{g}" for g in given), *self.sets("centre"))))
        return out

    def check(self) -> GearPair:
        """Raise :class:`GeometryError` naming every problem; warn about nearly pointed teeth.

        Returns
        -------
        GearPair
            ``self``, for chaining.

        Raises
        ------
        GeometryError
            If :meth:`problems` is not empty; the message lists all of them.
        """
        found = self.faults()
        if found:
            raise GeometryError(f"{self.name}: " + "; ".join(m for m, _ in found), found)
        for message, fields in self.cautions():
            warnings.warn(GeometryWarning(f"{self.name}: {message}", fields), stacklevel=2)
        return self

    def cautions(self) -> list[tuple[str, tuple[str, ...]]]:
        """What :meth:`check` warns of, as ``(message, fields)`` (as :meth:`faults`): an undercut
        below the active profile (contact stays on the involute; the model's tooth is the
        uncut one), with the shift that avoids it; a root half angle far above Sainsot et al.'s
        fitted range (``SAINSOT_ROOT_ANGLE_WARNED``: the gear body's compliance is
        extrapolated); a tip thickness below 0.2 module (nearly pointed teeth), with the tip
        radius that gives it; a rim or web outside ISO 6336-1's range of C_R; a Young's modulus
        outside ``GEAR_MODULUS``."""
        return list(_memo(_cautions_of, self))

    def _cautions(self) -> list[tuple[str, tuple[str, ...]]]:
        out = self._rim_cautions()
        e = self.youngs_modulus
        if not GEAR_MODULUS[0] <= e <= GEAR_MODULUS[1]:
            out.append(((f"Young's modulus {e / 1e9:.4g} GPa is outside gear materials'"
                         f" {GEAR_MODULUS[0] / 1e9:g} to {GEAR_MODULUS[1] / 1e9:g} GPa (steel 206"
                         f" GPa, cast iron 100-170, polymers 0.7-10): a unit slip"
                         f"{' (MPa for GPa)' if e < GEAR_MODULUS[0] else ''}?"),
                        ("youngs_modulus",)))
        for g in (1, 2):
            top = self.undercut_radius(g)
            if top is not None and not self._contact_on_cut(g, top):
                out.append(((f"slight undercut: {self._undercut_said(g, top)}, on the involute"
                             f" (the model's tooth is the uncut one){self._undercut_cure(g)}"),
                            self.sets("root", g)))
        top = SAINSOT_ROOT_ANGLE[1]
        for g in (1, 2):
            theta_f = self.fillet_geometry(g)[0]
            if theta_f > SAINSOT_ROOT_ANGLE_WARNED:
                out.append(((f"gear {g} root half angle theta_f = {theta_f:.3g} rad is"
                             f" {theta_f - top:.2g} rad above the {SAINSOT_ROOT_ANGLE[0]:g} to"
                             f" {top:g} rad where Sainsot et al.'s gear-body fit holds, past the"
                             f" {SAINSOT_ROOT_ANGLE_WARNED:g} rad up to which extrapolating it"
                             f" moves that term less than 5 % from its value at {top:g}: up to"
                             " 11 % (more teeth bring theta_f down)"),
                            tuple(dict.fromkeys((f"z{g}", *self.sets("root", g),
                                                 "fillet_radius")))))
        for g in (1, 2):
            sa, keep = self.tip_thickness(g), 0.2 * self.module
            if sa < keep:
                from scipy.optimize import brentq

                rb = self.base_radius1 if g == 1 else self.base_radius2

                def excess(r: float, g: int = g, keep: float = keep) -> float:
                    return 2.0 * r * float(self.half_angle(r, g)) - keep

                cure = "" if excess(rb) <= 0 else (  # (thinner than that at the base circle)
                    f"; a tip radius of gear {g} of at most"
                    f" {_mm_down(brentq(excess, rb, self.pointed_radius(g), xtol=1e-12))} mm"
                    f" keeps 0.2 m (tip_radius{g})")
                out.append(((f"gear {g} tip thickness {sa * 1e3:.3g} mm is below 0.2 m ="
                            f" {keep * 1e3:.3g} mm (nearly pointed teeth){cure}"),
                            _ranked(self._tip_thickness_sets(g))))
        return out


CHECKED_PAIRS = 64
"""Gear pairs whose :meth:`GearPair.faults` and :meth:`GearPair.cautions` are kept (by value: a
frozen pair's are of its fields alone). A gear scene that sweeps its load builds each load's
pair anew and checked it twice per build (its tip reliefs, its mesh), 60 % of the CPU time of
each load's model (2.2 ms, 0.84 ms once kept: table1_consistent, 200 loads, this 2-core VM, 27
Nov 2026); kept, each pair is checked once. What :meth:`GearPair.check` raises or warns it says
at every check."""


@lru_cache(maxsize=CHECKED_PAIRS)
def _faults_of(pair: GearPair) -> tuple[tuple[str, tuple[str, ...]], ...]:
    return tuple((message, _ranked(fields)) for message, fields in pair._faults())


@lru_cache(maxsize=CHECKED_PAIRS)
def _cautions_of(pair: GearPair) -> tuple[tuple[str, tuple[str, ...]], ...]:
    return tuple(pair._cautions())


def _memo(kept, pair: GearPair) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """``kept(pair)``, computed anew for a pair that cannot be a key (a field of a type without
    a hash, such as a list for ``contact_ratio_range``)."""
    try:
        hash(pair)
    except TypeError:
        return kept.__wrapped__(pair)
    return kept(pair)


def table1_as_printed() -> GearPair:
    """The paper's Table 1 taken literally (gear, 48 teeth, drives the 32-tooth pinion).

    Tip radii 63.7 / 43.8 mm, root radii 57.7 / 37.8 mm, fillet 1.4224 mm, thickness 4 mm at the
    pitch circle on both, backlash 0.5 mm, b = 10 mm, m = 2.5 mm, 20 deg, standard centre
    distance 100 mm; E = 206 GPa, nu = 0.3 (steel, not given in the paper). The text says the
    contact ratio lies between 1 and 2. :meth:`GearPair.check` rejects it: tip-root interference
    of 1.5 mm on both gears, contact ratio about 2.43 against the stated 1..2, and 4 + 4 mm of
    thickness exceeding the 7.854 mm circular pitch (no room for 0.5 mm of backlash).

    Returns
    -------
    GearPair
        The pair as printed (construction succeeds, ``check()`` raises).
    """
    return GearPair(
        module=2.5e-3, z1=48, z2=32, face_width=10e-3, pressure_angle=math.radians(20.0),
        tip_radius1=63.7e-3, tip_radius2=43.8e-3, root_radius1=57.7e-3, root_radius2=37.8e-3,
        fillet_radius=1.4224e-3, centre_distance=100e-3, backlash=0.5e-3,
        thickness1=4e-3, thickness2=4e-3, contact_ratio_range=(1.0, 2.0),
        name="Table 1 as printed",
    )  # fmt: skip


def table1_consistent() -> GearPair:
    """The documented consistent interpretation of Table 1 used by gearsweep.

    Kept from the paper: m = 2.5 mm, z = 48 (gear, driving) and 32 (pinion, driven), 20 deg,
    b = 10 mm, pitch radii 60 / 40 mm at the standard centre distance 100 mm, fillet radius
    1.4224 mm, backlash 0.5 mm (taken as circumferential at the pitch circle, 0.470 mm along the
    line of action). Changed, because the printed values cannot coexist:

    * standard tip radii r + m = 62.5 / 42.5 mm (printed 63.7 / 43.8 mm interfere with the mating
      roots by 1.5 mm and give a contact ratio ~2.43, against the text's 1..2); the contact
      ratio becomes ~1.71;
    * standard root radii r - 1.25 m = 56.875 / 36.875 mm (the printed 57.7 / 37.8 mm would still
      interfere by 0.3 mm with the standard tips);
    * tooth thicknesses are not the printed 4 mm (4 + 4 > 7.854 mm circular pitch) but the
      standard pi m / 2 = 3.927 mm each, reduced equally by 0.25 mm to give the 0.5 mm backlash.

    Steel, E = 206 GPa, nu = 0.3 (not given in the paper). Gear bodies solid, clamped at half
    the root radius (not given in the paper).

    Returns
    -------
    GearPair
        A pair for which ``check()`` passes.
    """
    return GearPair(
        module=2.5e-3, z1=48, z2=32, face_width=10e-3, pressure_angle=math.radians(20.0),
        fillet_radius=1.4224e-3, centre_distance=100e-3, backlash=0.5e-3,
        contact_ratio_range=(1.0, 2.0), name="Table 1 (consistent interpretation)",
    )  # fmt: skip


def table1_profile_shift() -> GearPair:
    """Table 1 read as a profile-shifted pair: the printed radii kept, the shifts taken from them.

    The printed tip radii are r + m (1 + x) with x1 = (63.7 - 62.5) / 2.5 = 0.48 on the 48-tooth
    gear and x2 = (43.8 - 42.5) / 2.5 = 0.52 on the 32-tooth pinion. With these shifts the pair
    runs without backlash at the centre distance of ``inv(alpha_w)`` (102.31 mm, alpha_w =
    23.30 deg); both teeth are thinned equally to give Table 1's 0.5 mm of circumferential
    backlash there. Kept from the paper: m, z, 20 deg, b, tip radii 63.7 / 43.8 mm, root radii
    57.7 / 37.8 mm (tip-root clearance 0.81 mm on both sides), backlash 0.5 mm, input torque.

    Not reconciled: the printed fillet radius 1.4224 mm does not fit the tooth space at the root
    circle of the thicker shifted teeth (``GearPair.check`` says so); 1.2 mm, the largest
    0.05 mm step that fits both gears, is used. The printed 4 mm thickness "at the pitch circle"
    is neither the reference-circle thickness (4.56 / 4.63 mm) nor the operating-pitch-circle
    thickness (3.54 / 3.99 mm) of this pair; 4 + 4 + 0.5 mm exceeds the circular pitch at every
    pitch circle of these radii (7.85 mm at 100 mm, 8.03 mm at 102.31 mm). docs/mesh.md compares
    this reading with ``table1_consistent``. Steel, E = 206 GPa, nu = 0.3, as there.

    Returns
    -------
    GearPair
        A pair for which ``check()`` passes (contact ratio 1.58).
    """
    return GearPair(
        module=2.5e-3, z1=48, z2=32, face_width=10e-3, pressure_angle=math.radians(20.0),
        x1=0.48, x2=0.52, tip_radius1=63.7e-3, tip_radius2=43.8e-3, root_radius1=57.7e-3,
        root_radius2=37.8e-3, fillet_radius=1.2e-3, backlash=0.5e-3,
        contact_ratio_range=(1.0, 2.0), name="Table 1 (profile-shift reading)",
    )  # fmt: skip


def rim_factor(pair: GearPair, gear: int) -> float:
    """ISO 6336-1 rim factor ``C_R`` (1 for a solid gear) [-].

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    gear : {1, 2}
        Which gear.

    Returns
    -------
    float
        ``C_R = 1 + ln(b_s / b) / (5 exp(s_R / (5 m)))``, ``b_s/b`` limited to [0.2, 1.2] and
        ``s_R/m`` to >= 1 as in the standard.
    """
    s_r = pair.rim_thickness1 if gear == 1 else pair.rim_thickness2
    if s_r is None:
        return 1.0
    web = pair.web_width1 if gear == 1 else pair.web_width2
    bs_b = (web if web is not None else pair.face_width) / pair.face_width
    bs_b = min(max(bs_b, 0.2), 1.2)
    sr_m = max(s_r / pair.module, 1.0)
    return 1.0 + math.log(bs_b) / (5.0 * math.exp(sr_m / 5.0))
