"""Tooth and tooth-pair compliance along the line of action.

Three parts per tooth, each a deflection along the load line (normal to the involute at the
contact point) per unit load [m/N]:

* **Bending, shear and axial compression** of the actual involute-and-fillet tooth by the
  potential-energy (Castigliano) method of Yang & Lin (1987) in the general-profile form of
  Tian (2004) / Chaari et al. (2009): with the tooth centre line along ``y``, the half width
  ``x(y)`` of the real outline (circular root fillet, radial flank below the base circle,
  involute above it), section ``A = 2 x b``, ``I = (2x)^3 b / 12``, load angle ``beta`` from the
  normal to the centre line and load point ``(x_c, y_c)``::

      1/k_b = int_{y0}^{y_c} [(y_c - y) cos(beta) - x_c sin(beta)]^2 / (E I) dy
      1/k_s = int_{y0}^{y_c} 1.2 cos^2(beta) / (G A) dy
      1/k_a = int_{y0}^{y_c} sin^2(beta) / (E A) dy

  integrated from the root section ``y0`` (where the fillet meets the root circle). The
  integrals are cumulative on a fine grid (2000 points), so any number of load points costs one
  interpolation each.
* **Foundation** (fillet and gear body) flexibility of Sainsot, Velex & Duverger (2004),
  J. Mech. Des. 126, 748-752::

      delta_f / F = cos^2(beta) / (E b) [L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q* tan^2 beta)]

  with ``X* = A/theta_f^2 + B h_fi^2 + C h_fi/theta_f + D/theta_f + E h_fi + F``,
  ``h_fi = r_f / r_int`` (root radius over the radius where the body is clamped),
  ``theta_f`` the root half angle, ``S_f = 2 r_f sin(theta_f)`` and ``u_f`` the distance from
  the root section to where the load line crosses the tooth centre line. Coefficients
  (Sainsot et al. 2004, Table 1) as found with the search tool in several public gear-mesh
  codes (find_string "-5.574e-5": a MATLAB ``toothmesh1`` and
  ``pg_chaari_foundation_compliance`` and Python gear-stiffness libraries, which all agree).
* **Hertzian contact** of the pair, load-independent line-contact form of Yang & Lin (1987):
  ``1/k_h = 4 (1 - nu^2) / (pi E b)``.

Rim: Sainsot's fits are for a solid body clamped at ``r_int``; in them a larger ``r_int``
(thinner annulus clamped on a rigid shaft) is *stiffer*, and they hold for ``r_f / r_int`` in
:data:`SAINSOT_BORE_RATIO` (refused outside), and for a root half angle ``theta_f`` in
:data:`SAINSOT_ROOT_ANGLE` (refused below; above, extrapolated, with a warning beyond
``geometry.SAINSOT_ROOT_ANGLE_WARNED``). A thin rim on a narrow web is softer;
for that the tooth-and-foundation stiffness is multiplied by ISO 6336-1's empirical rim factor
``C_R = 1 + ln(b_s/b) / (5 exp(s_R / (5 m)))`` (``C_R = 1`` for a solid gear).

Plane stress (``E``, ``G = E / (2 (1 + nu))``) throughout, as in Yang & Lin, Tian and Chaari.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from gearsweep.errors import GeometryError
from gearsweep.gear.geometry import SAINSOT_ROOT_ANGLE, GearPair, _mm_down, _mm_up, rim_factor

__all__ = [
    "SAINSOT_BORE_RATIO",
    "SAINSOT_COEFFICIENTS",
    "SAINSOT_ROOT_ANGLE",
    "ToothCompliance",
    "ToothProfile",
    "hertz_compliance",
    "pair_compliance",
    "rim_factor",
    "tooth_compliance",
    "tooth_profile",
]

SAINSOT_COEFFICIENTS = np.array(
    [  # A           B           C            D           E        F         row
        [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],  # L*
        [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],  # M*
        [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],  # P*
        [-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904],  # Q*
    ]
)
"""Sainsot, Velex & Duverger (2004) polynomial coefficients, rows L*, M*, P*, Q*."""

SAINSOT_BORE_RATIO = (1.4, 7.0)
"""Root radius over the radius where the body is clamped, ``h_fi = r_f / r_int``, for which
Sainsot et al. (2004) fitted their gear-body term [-] (the range the paper states, as public
gear-mesh codes that carry its Table 1 quote it: find_string "1.4 <= h <= 7"). The fit's body
is clamped rigidly at ``r_int``: within it a larger ``r_int`` is stiffer; towards ``h_fi = 1``
(a thin rim on a rigid shaft) it stays stiffer than a solid gear, and beyond 7 its
quadratic in ``h_fi`` softens the gear below ISO 6336's ``c_gamma``."""

SHEAR_FACTOR = 1.2
"""Shear correction of a rectangular section [-]."""


@dataclass(frozen=True)
class ToothProfile:
    """Half width of one tooth along its centre line, with cumulative compliance integrals.

    Attributes
    ----------
    eta : ndarray
        Height above the root section along the centre line [m].
    half_width : ndarray
        Half tooth width ``x`` at ``eta`` [m].
    y0 : float
        Centre-line coordinate of the root section (origin at the gear centre) [m].
    theta_f : float
        Root half angle (fillet-root tangency) [rad].
    root_radius : float
        Root radius [m].
    j0, j1, j2 : ndarray
        ``int_0^eta eta'^k / I dη`` for k = 0, 1, 2 [m^-4, m^-3, m^-2] (``I`` per unit b).
    ja : ndarray
        ``int_0^eta 1 / A dη`` [m^-1] (``A`` per unit b).
    """

    eta: np.ndarray
    half_width: np.ndarray
    y0: float
    theta_f: float
    root_radius: float
    j0: np.ndarray
    j1: np.ndarray
    j2: np.ndarray
    ja: np.ndarray


@lru_cache(maxsize=64)
def tooth_profile(pair: GearPair, gear: int, n: int = 2000) -> ToothProfile:
    """Outline of one tooth of ``pair`` (fillet arc, radial flank, involute) and its integrals.

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    gear : {1, 2}
        Which gear.
    n : int
        Grid points along the centre line [-].

    Returns
    -------
    ToothProfile
        Profile and cumulative integrals per unit face width.
    """
    rf = pair.root_radius[gear - 1]
    ra = pair.tip_radius[gear - 1]
    rb = pair.base_radius1 if gear == 1 else pair.base_radius2
    rho = pair.fillet
    theta_f, r_tan, psi_tan = pair.fillet_geometry(gear)
    rc = rf + rho
    cx, cy = rc * math.sin(theta_f), rc * math.cos(theta_f)
    # Fillet arc from the root tangency (direction towards the gear centre) to the flank.
    a0 = math.atan2(-cy, -cx)
    a1 = math.atan2(r_tan * math.cos(psi_tan) - cy, r_tan * math.sin(psi_tan) - cx)
    if a1 < a0:
        a1 += 2.0 * math.pi
    if a1 - a0 > math.pi:
        a1 -= 2.0 * math.pi
    ang = np.linspace(a0, a1, max(n // 10, 20))
    fx, fy = cx + rho * np.cos(ang), cy + rho * np.sin(ang)
    parts_x, parts_y = [fx], [fy]
    if r_tan < rb:
        psi_b = float(pair.half_angle(rb, gear))
        rr = np.linspace(r_tan, rb, max(n // 40, 5))[1:]
        parts_x.append(rr * math.sin(psi_b))
        parts_y.append(rr * math.cos(psi_b))
    rr = np.linspace(max(rb, r_tan), ra, max(n // 3, 50))[1:]
    psi = pair.half_angle(rr, gear)
    parts_x.append(rr * np.sin(psi))
    parts_y.append(rr * np.cos(psi))
    px, py = np.concatenate(parts_x), np.concatenate(parts_y)
    if np.any(np.diff(py) <= 0):
        why = (f"gear {gear} tooth outline is not single-valued along its centre line (fillet or"
               " flank turns back); check fillet radius and profile shift")
        raise GeometryError(f"{pair.name}: {why}", [(why, ("fillet_radius", f"x{gear}"))])
    y0 = float(py[0])
    eta = np.linspace(0.0, float(py[-1]) - y0, n)
    x = np.interp(eta + y0, py, px)
    if np.any(x <= 0):
        raise GeometryError(f"{pair.name}: gear {gear} tooth has zero width below its tip")
    from scipy.integrate import cumulative_trapezoid  # here: scipy.integrate takes 0.4 s to import

    inertia = (2.0 * x) ** 3 / 12.0
    area = 2.0 * x
    j0 = cumulative_trapezoid(1.0 / inertia, eta, initial=0.0)
    j1 = cumulative_trapezoid(eta / inertia, eta, initial=0.0)
    j2 = cumulative_trapezoid(eta**2 / inertia, eta, initial=0.0)
    ja = cumulative_trapezoid(1.0 / area, eta, initial=0.0)
    return ToothProfile(eta, x, y0, theta_f, rf, j0, j1, j2, ja)


@dataclass(frozen=True)
class ToothCompliance:
    """Compliance parts of one tooth at given contact radii [m/N].

    Attributes
    ----------
    bending, shear, axial, foundation : ndarray
        Compliance parts [m/N].
    beta : ndarray
        Load angle from the normal to the tooth centre line [rad].
    """

    bending: np.ndarray
    shear: np.ndarray
    axial: np.ndarray
    foundation: np.ndarray
    beta: np.ndarray

    @property
    def total(self) -> np.ndarray:
        """Sum of the parts [m/N]."""
        return self.bending + self.shear + self.axial + self.foundation


def _below(value: float, bound: float) -> str:
    """``value`` (below ``bound``) in 3 significant digits, or as many more as show it below:
    0.00996 printed as 0.01 read as inside a range that starts at 0.01."""
    for digits in range(3, 17):
        text = f"{value:.{digits}g}"
        if float(text) < bound:
            return text
    return repr(value)


def _most_teeth_within(pair: GearPair, gear: int) -> int | None:
    """The most teeth of gear ``gear`` whose root half angle is within Sainsot et al.'s range
    (:data:`SAINSOT_ROOT_ANGLE`), the rest of the pair as it is: found by bisection over the
    same check (theta_f falls as the teeth grow; above pi / 0.01 = 314 teeth none fits).
    ``None`` where the gear's radii, thickness or the centre distance are given as lengths (a
    count of teeth with them kept means another gear) or no count fits."""
    fixed = (f"tip_radius{gear}", f"root_radius{gear}", f"thickness{gear}", "centre_distance")
    if any(getattr(pair, f) is not None for f in fixed):
        return None

    def fits(z: int) -> bool:
        try:
            other = dataclasses.replace(pair, **{f"z{gear}": z})
            return other.fillet_geometry(gear)[0] >= SAINSOT_ROOT_ANGLE[0]
        except (GeometryError, ValueError, ArithmeticError):
            return False

    lo, hi = 3, min(pair.z1 if gear == 1 else pair.z2,
                    math.floor(math.pi / SAINSOT_ROOT_ANGLE[0]) + 1)
    if not fits(lo):
        return None
    while hi - lo > 1:  # fits(lo), not fits(hi)
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


def tooth_compliance(
    pair: GearPair, gear: int, r: np.ndarray | float, n: int = 2000
) -> ToothCompliance:
    """Compliance of one tooth for a load normal to the involute at contact radius ``r``.

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    gear : {1, 2}
        Which gear.
    r : float or ndarray
        Contact radius, between base and tip radius [m].
    n : int
        Grid points along the tooth centre line (see :func:`tooth_profile`) [-].

    Returns
    -------
    ToothCompliance
        Bending, shear, axial and foundation compliance along the load line [m/N].
    """
    prof = tooth_profile(pair, gear, n)
    r = np.atleast_1d(np.asarray(r, dtype=float))
    rb = pair.base_radius1 if gear == 1 else pair.base_radius2
    e, b, nu = pair.youngs_modulus, pair.face_width, pair.poisson
    g_mod = e / (2.0 * (1.0 + nu))
    psi = pair.half_angle(r, gear)
    alpha_r = np.arccos(np.clip(rb / r, -1.0, 1.0))
    beta = alpha_r - psi
    xc, yc = r * np.sin(psi), r * np.cos(psi)
    eta_c = yc - prof.y0
    j0 = np.interp(eta_c, prof.eta, prof.j0)
    j1 = np.interp(eta_c, prof.eta, prof.j1)
    j2 = np.interp(eta_c, prof.eta, prof.j2)
    ja = np.interp(eta_c, prof.eta, prof.ja)
    cb, sb = np.cos(beta), np.sin(beta)
    arm = eta_c * cb - xc * sb
    bending = (arm**2 * j0 - 2.0 * arm * cb * j1 + cb**2 * j2) / (e * b)
    shear = SHEAR_FACTOR * cb**2 * ja / (g_mod * b)
    axial = sb**2 * ja / (e * b)
    # Sainsot et al. (2004) foundation.
    rint, rf = pair.bore_radius[gear - 1], prof.root_radius
    h = rf / rint
    lo, hi = SAINSOT_BORE_RATIO
    if not lo <= h <= hi:  # (1.07 gave a gear 5 % stiffer than solid: an outside engineer's)
        why = (f"gear {gear} bore radius {rint * 1e3:.4g} mm gives a root-to-bore ratio r_f /"
               f" r_int = {h:.3f} (root radius {rf * 1e3:.4g} mm), outside {lo:g} to {hi:g},"
               " where Sainsot et al.'s gear-body fit holds ("
               + ("nearer 1 it makes a thinner rim stiffer" if h < lo else
                  "beyond it softens the gear without bound")
               + f"); a bore radius of {_mm_up(rf / hi)} to {_mm_down(rf / lo)} mm fits"
               f" (bore_radius{gear}; a thin rim is rim_thickness{gear})")
        raise GeometryError(f"{pair.name}: {why}",
                            [(why, (f"bore_radius{gear}", *pair.sets("root", gear)))])
    th = prof.theta_f
    if th < SAINSOT_ROOT_ANGLE[0]:  # (z2 = 1000: P* = -36, k0 1.5 times ISO's c_gamma)
        z = pair.z1 if gear == 1 else pair.z2
        most = _most_teeth_within(pair, gear)
        fits = (f"with this module, shift and fillet at most {most} teeth fit (z{gear})"
                if most is not None else f"fewer teeth fit (z{gear})")
        why = (f"gear {gear} root half angle theta_f = {_below(th, SAINSOT_ROOT_ANGLE[0])} rad"
               f" ({z} teeth), outside {SAINSOT_ROOT_ANGLE[0]:g} to {SAINSOT_ROOT_ANGLE[1]:g} rad,"
               " where Sainsot et al.'s gear-body fit holds (below it the body's compliance falls"
               f" to zero and turns negative); {fits}")
        raise GeometryError(f"{pair.name}: {why}",
                            [(why, tuple(dict.fromkeys((f"z{gear}", *pair.sets("root", gear),
                                                        "fillet_radius"))))])
    terms = np.array([1.0 / th**2, h**2, h / th, 1.0 / th, h, 1.0])
    lstar, mstar, pstar, qstar = SAINSOT_COEFFICIENTS @ terms
    s_f = 2.0 * prof.root_radius * math.sin(th)
    u_f = yc - xc * np.tan(beta) - prof.y0
    ratio = u_f / s_f
    foundation = (
        cb**2
        / (e * b)
        * (lstar * ratio**2 + mstar * ratio + pstar * (1.0 + qstar * np.tan(beta) ** 2))
    )
    c_r = rim_factor(pair, gear)
    return ToothCompliance(bending / c_r, shear / c_r, axial / c_r, foundation / c_r, beta)


def hertz_compliance(pair: GearPair) -> float:
    """Hertzian compliance of a tooth pair in line contact, ``4 (1 - nu^2) / (pi E b)`` [m/N].

    Parameters
    ----------
    pair : GearPair
        The gear pair (same material on both gears).

    Returns
    -------
    float
        Contact compliance along the line of action [m/N].
    """
    return 4.0 * (1.0 - pair.poisson**2) / (math.pi * pair.youngs_modulus * pair.face_width)


def pair_compliance(pair: GearPair, s: np.ndarray | float, n: int = 2000) -> np.ndarray:
    """Compliance of one tooth pair in contact at line-of-action position ``s``.

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    s : float or ndarray
        Position on the line of action measured from ``T1`` [m], within the path of contact.
    n : int
        Grid points along each tooth centre line [-].

    Returns
    -------
    ndarray
        Tooth 1 + tooth 2 + Hertz compliance [m/N].
    """
    r1, r2 = pair.contact_radii(s)
    c1 = tooth_compliance(pair, 1, r1, n).total
    c2 = tooth_compliance(pair, 2, r2, n).total
    return c1 + c2 + hertz_compliance(pair)
