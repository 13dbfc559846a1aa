"""Linear stability of the time-stepping methods, and the step guard rail for every study.

Stability polynomial
--------------------
One step of an explicit Runge-Kutta method with tableau (A, b) applied to y' = lambda y maps
y_n to R(z) y_n, z = h lambda, with

    R(z) = 1 + z b^T (I - z A)^{-1} 1 = 1 + sum_{k=0}^{s-1} (b^T A^k 1) z^(k+1)

(A is strictly lower triangular, hence nilpotent, and the Neumann series stops after s terms).
The coefficients are computed exactly, in rational arithmetic, from the tableaux of
``gearsweep.kernels.tableaux`` (the one home of every method's coefficients):

* RK4:  R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24.
* RK5 (Butcher's six-stage method of ``gearsweep.kernels.rk``): the Taylor polynomial of e^z to
  z^5/120 plus z^6/640 (= b6 a65 a54 a43 a32 a21; e^z has 1/720 there).

Oscillator
----------
p'' + (c/m) p' + (k/m) p = 0 is y' = J y with eigenvalues
lambda = omega_n (-zeta +- i sqrt(1 - zeta^2)), omega_n = sqrt(k/m), zeta = (c/m) / (2 omega_n).
The RK map of a linear system is R(hJ), so the discrete solution stays bounded exactly when
|R(h lambda)| <= 1 for both eigenvalues. Along the ray z = r e^{i theta} of a pole, the step
limit is the first r > 0 with |R(r e^{i theta})| = 1 (``ray_limit``). For an undamped oscillator
(theta = pi/2):

* RK4: |R(iy)|^2 = 1 - y^6/72 + y^8/576, stable for h omega_n <= 2 sqrt(2) = 2.828;
* RK5: |R(iy)|^2 = 1 - y^6/2880 + y^8/1920 - 7 y^10/115200 + y^12/409600. The y^6 term is
  -2 (c6 - 1/720) with c6 = 1/640 the method's z^6 coefficient: because c6 exceeds e^z's 1/720,
  the method *damps* an undamped oscillation slightly for small h omega_n. The y^8 term, there
  because R is a polynomial of degree 6 and not e^z, is positive and overtakes it at
  h omega_n = 0.852: from there on Butcher's method *amplifies* an undamped oscillation, by a
  few parts in 1e5 per step at h omega_n = 1 and 3 % per step at 2. A little damping moves the
  limit out (zeta = 0.1: 2.72; zeta = 0.5: 3.46), so for this method damping itself decides
  where a fixed-step integration blows up. A fifth-order method with c6 < 1/720 (the
  fifth-order weights of Fehlberg, c6 = 1/2080, and of Cash-Karp, 1/800) has a positive y^6 term
  and amplifies an undamped oscillation at every step size
  (``gearsweep.kernels.tableaux.imaginary_stability_interval`` = 0).

For the mesh stiffness k(t) the frozen-coefficient argument uses the largest stiffness, k_max/m:
the step must resolve the stiffest instant of the mesh cycle (``max_stable_step``, ``check_step``).
The exact statement for a periodic linear equation is made by ``integrator_unstable``: the
discrete monodromy matrix at the chosen step has a multiplier > 1 while the converged Floquet
multiplier of the equation does not.
"""

from __future__ import annotations

import math
from fractions import Fraction as Fr

import numpy as np

from gearsweep.errors import GearsweepError
from gearsweep.kernels import STATUS_DIVERGED, simulate, tableaux
from gearsweep.kernels import floquet as fq
from gearsweep.kernels.floquet import (
    UNSTABLE_TOL,
    floquet,
    largest_multiplier,
    mathieu_parameters,
    paper_criterion,
)
from gearsweep.model import mesh_frequency

__all__ = [
    "TABLEAUX",
    "artifact_map",
    "growth_criterion",
    "reproduces_paper",
    "tableau_monodromy",
    "UnstableStepError",
    "amplification",
    "check_step",
    "frozen_map_multiplier",
    "frozen_poles",
    "frozen_step_ok",
    "integrator_edge",
    "integrator_unstable",
    "map_step_check",
    "map_step_limit",
    "RESONANCE_TOL",
    "resonance_error",
    "max_stable_step",
    "measured_step_limit",
    "operating_map",
    "ray_limit",
    "require_stable_step",
    "stability_polynomial",
    "step_limit_hw",
    "COARSE_STEPS",
    "STRONG_VARIATION",
    "needs_map_check",
    "TONGUE_MARGIN",
    "tongue_damping",
    "variation_ratio",
]


class UnstableStepError(GearsweepError):
    """The chosen method and steps per mesh period cannot integrate the case stably."""


TABLEAUX = tableaux.TABLEAUX
"""Butcher tableaux by name (``gearsweep.kernels.tableaux``: the one home of the coefficients)."""

ORDER = {name: t.order for name, t in TABLEAUX.items()}
"""Order of accuracy of each method (for Richardson error estimates)."""


def _method(method: str) -> str:
    if method not in TABLEAUX:
        raise GearsweepError(f"method must be one of {sorted(TABLEAUX)}, got {method!r}")
    return method


def stability_polynomial(method: str) -> tuple[Fr, ...]:
    """Exact coefficients of R(z), lowest power first: ``R(z) = sum coef[k] z^k``.

    Parameters
    ----------
    method : str
        A name in ``gearsweep.kernels.tableaux.TABLEAUX`` ("rk4", "rk5", "fehlberg5", ...).

    Returns
    -------
    tuple of Fraction
        Up to ``s + 1`` coefficients for an ``s``-stage method (derived from the tableau).
    """
    return tableaux.stability_polynomial(_method(method))


def amplification(method: str, z) -> np.ndarray:
    """R(z) of the method at complex z = h lambda (array_like), as a complex array."""
    z = np.asarray(z, dtype=complex)
    out = np.zeros_like(z)
    for c in reversed(stability_polynomial(method)):
        out = out * z + float(c)
    return out


def _ray_poly(method: str, theta: np.ndarray) -> np.ndarray:
    """Coefficients d_n(theta), n = 0..2s, of |R(r e^{i theta})|^2 - 1 as a polynomial in r,
    shape (len(theta), 2s + 1): d_n = sum_{j+k=n} c_j c_k cos((j - k) theta)."""
    c = np.array([float(x) for x in stability_polynomial(method)])
    deg = len(c) - 1
    d = np.zeros((theta.size, 2 * deg + 1))
    for j in range(deg + 1):
        for k in range(deg + 1):
            d[:, j + k] += c[j] * c[k] * np.cos((j - k) * theta)
    d[:, 0] -= 1.0
    return d


def _horner(d: np.ndarray, r: np.ndarray) -> np.ndarray:
    out = np.zeros(np.broadcast_shapes(d.shape[:1], r.shape))
    for n in range(d.shape[1] - 1, -1, -1):
        out = out * r + d[:, n]
    return out


def ray_limit(method: str, theta, r_max: float = 10.0) -> np.ndarray:
    """Largest r with |R(r' e^{i theta})| <= 1 for every 0 < r' <= r (the step limit h |lambda|
    of a pole at angle theta).

    Parameters
    ----------
    method : {"rk4", "rk5"}
    theta : array_like
        Angle of the pole in the complex plane [rad], pi/2 (undamped) .. pi (real, decaying).
        Angles below pi/2 (growing poles) give 0.
    r_max : float
        Search range; no limit below it gives ``inf``.

    Returns
    -------
    ndarray
        r* [-], to about 1e-13 relative.

    Notes
    -----
    ``|R|^2 - 1`` is scanned from r = 0.02 (below that |R|^2 - 1 ~ -r^6/72 on the imaginary axis is
    still far above rounding) on a grid of step 0.005 and the first sign change to positive is
    bisected. Both methods' stability regions are star-shaped along these rays at that resolution.
    """
    theta = np.asarray(theta, dtype=float)
    shape = theta.shape
    # Each distinct angle once (a study's cases share a few damping ratios), a block of them at
    # a time: the scan holds (angles x 1996 radii) values, 16 kB per angle; over a 33,000-case
    # chunk of a floquet output at once it made the run's peak 2.0 GB against 0.37 GB estimated.
    uniq, inverse = np.unique(np.atleast_1d(theta).ravel(), return_inverse=True)
    out = np.concatenate([_ray_limit(method, uniq[i:i + _RAY_BLOCK], r_max)
                          for i in range(0, uniq.size, _RAY_BLOCK)] or [np.empty(0)])
    return out[inverse].reshape(shape)


_RAY_BLOCK = 1024
"""Angles per block of ``ray_limit``'s scan (16 MB of scanned values)."""


def _ray_limit(method: str, theta: np.ndarray, r_max: float) -> np.ndarray:
    """``ray_limit`` of the 1-D ``theta``, all at once."""
    d = _ray_poly(method, theta)
    r = np.arange(0.02, r_max, 0.005)
    vals = np.stack([_horner(d, np.full(theta.size, ri)) for ri in r], axis=1)  # (n, nr)
    pos = vals > 0
    first = np.where(pos.any(axis=1), pos.argmax(axis=1), -1)
    out = np.full(theta.size, np.inf)
    out[first == 0] = 0.0  # |R| > 1 right from the start: a growing pole
    sel = first > 0
    lo = r[first[sel] - 1]
    hi = r[first[sel]]
    ds = d[sel]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = _horner(ds, mid) > 0
        hi = np.where(up, mid, hi)
        lo = np.where(up, lo, mid)
    out[sel] = 0.5 * (lo + hi)
    return out


def step_limit_hw(method: str, zeta) -> np.ndarray:
    """Largest stable h omega_n of the oscillator p'' + 2 zeta omega_n p' + omega_n^2 p = 0.

    Parameters
    ----------
    method : {"rk4", "rk5"}
    zeta : array_like
        Damping ratio [-], >= 0.

    Returns
    -------
    ndarray
        (h omega_n)* [-]: the discrete map is stable for h omega_n below it.
    """
    zeta = np.asarray(zeta, dtype=float)
    if np.any(zeta < 0):
        raise GearsweepError("the damping ratio must be >= 0")
    z = np.minimum(zeta, 1.0)
    under = ray_limit(method, np.arccos(-z))  # |lambda| = omega_n on the ray
    # Over-damped: two real poles -omega_n (zeta -+ sqrt(zeta^2 - 1)); the faster one binds.
    real_lim = ray_limit(method, np.pi)
    fast = np.maximum(zeta + np.sqrt(np.maximum(zeta * zeta - 1.0, 0.0)), 1.0)
    return np.where(zeta < 1.0, under, real_lim / fast)


def max_stable_step(method: str, k_over_m, c_over_m=0.0) -> np.ndarray:
    """Largest stable fixed step [s] of ``method`` for p'' + (c/m) p' + (k/m) p = 0.

    Parameters
    ----------
    method : {"rk4", "rk5"}
    k_over_m : array_like
        Stiffness / mass [1/s^2]; for a periodic stiffness pass its largest value k_max/m
        (frozen-coefficient estimate). Values <= 0 (no oscillation, the equation itself grows)
        are limited by the decaying pole only.
    c_over_m : array_like
        Damping / mass [1/s], >= 0.

    Returns
    -------
    ndarray
        h* [s]; ``inf`` when no pole limits the step (k = c = 0).
    """
    k, c = np.broadcast_arrays(np.asarray(k_over_m, float), np.asarray(c_over_m, float))
    if np.any(c < 0):
        raise GearsweepError("damping c/m must be >= 0")
    out = np.full(k.shape, np.inf)
    osc = k > 0
    wn = np.sqrt(np.where(osc, k, 1.0))
    hw = step_limit_hw(method, np.where(osc, c / (2 * wn), 0.0))
    out = np.where(osc, hw / wn, out)
    # k <= 0: real poles -c/2 +- sqrt(c^2/4 - k); only the negative one can limit the step.
    neg = -0.5 * c - np.sqrt(np.maximum(0.25 * c * c - k, 0.0))
    real_lim = ray_limit(method, np.pi)
    with np.errstate(divide="ignore"):
        out = np.where(~osc & (neg < 0), real_lim / np.abs(neg), out)
    return out


def frozen_poles(k_over_m, c_over_m) -> tuple[np.ndarray, np.ndarray]:
    """The two poles of p'' + (c/m) p' + (k/m) p = 0 (the roots of s^2 + (c/m) s + k/m).

    Parameters
    ----------
    k_over_m, c_over_m : array_like
        Stiffness / mass [1/s^2] and viscous damping / mass [1/s].

    Returns
    -------
    slow, fast : complex ndarray
        The pole with the larger real part (the slower to decay) and the other one. Below
        critical damping a conjugate pair, -c / 2m +- i sqrt(k/m - (c/2m)^2); above it two real
        poles, slow = -(k/m) / (c/2m + sqrt((c/2m)^2 - k/m)) = -omega_n (zeta - sqrt(zeta^2 - 1))
        (the product of the roots, k/m, over the fast one: no cancellation at large zeta) and
        fast = -(c/2m + sqrt((c/2m)^2 - k/m)).
    """
    k, c = np.broadcast_arrays(np.asarray(k_over_m, float), np.asarray(c_over_m, float))
    half = 0.5 * c
    d = half * half - k
    root = np.sqrt(np.abs(d))
    big = half + np.where(d >= 0, root, 0.0)  # -fast, for real poles
    with np.errstate(divide="ignore", invalid="ignore"):
        real_slow = np.where(big != 0, -k / np.where(big != 0, big, 1.0), 0.0)
    slow = np.where(d < 0, -half + 1j * root, real_slow + 0j)
    fast = np.where(d < 0, -half - 1j * root, -big + 0j)
    return slow, fast


def frozen_map_multiplier(method: str, k_over_m, c_over_m, h, steps) -> np.ndarray:
    """Largest |multiplier| of ``steps`` fixed steps ``h`` [s] of ``method`` on
    p'' + (c/m) p' + (k/m) p = 0 with constant coefficients: the map of one step is R(h A), whose
    eigenvalues are the stability polynomial at the poles (``frozen_poles``), so this is
    max |R(h lambda)|^steps over the two poles (exact; the floquet output's
    ``discrete_multiplier`` where the stiffness is constant, over ``steps`` = steps_per_period).

    Parameters
    ----------
    method : str
        A name in ``TABLEAUX``.
    k_over_m, c_over_m, h : array_like
        Stiffness / mass [1/s^2], damping / mass [1/s] and the step [s], per case.
    steps : int or array_like
        Steps the multiplier covers (steps_per_period: per mesh period).
    """
    slow, fast = frozen_poles(k_over_m, c_over_m)
    h = np.asarray(h, float)
    r = np.maximum(np.abs(amplification(method, h * slow)), np.abs(amplification(method, h * fast)))
    with np.errstate(over="ignore"):
        return r ** np.asarray(steps, float)


def check_step(method: str, steps_per_period, mesh_period, k_max_over_m, c_over_m=0.0,
               margin: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The guard rail: is ``steps_per_period`` fine enough for the method to be stable?

    Call it before integrating a study (frozen-coefficient estimate at the largest stiffness).

    Parameters
    ----------
    method : {"rk4", "rk5"}
    steps_per_period : array_like of int
        Steps per mesh period.
    mesh_period : array_like
        Mesh period 1 / f_mesh [s].
    k_max_over_m : array_like
        Largest mesh stiffness over the cycle / equivalent mass [1/s^2].
    c_over_m : array_like
        Viscous damping / mass [1/s].
    margin : float
        Safety factor >= 1 on the step limit (1: exactly at the limit of the stability polynomial).

    Returns
    -------
    ok : ndarray of bool
        True where ``steps_per_period >= limit_spp``.
    limit_spp : ndarray of int
        Fewest steps per mesh period that are stable (times ``margin``).
    """
    h_star = max_stable_step(method, k_max_over_m, c_over_m)
    T = np.asarray(mesh_period, dtype=float)
    with np.errstate(divide="ignore"):
        need = np.where(np.isfinite(h_star), np.ceil(margin * T / h_star), 1.0)
    spp = np.asarray(steps_per_period)
    limit = np.broadcast_to(np.maximum(need, 1.0).astype(np.int64),
                            np.broadcast_shapes(need.shape, spp.shape)).copy()
    return spp >= limit, limit


def frozen_step_ok(method: str, h, k_over_m, c_over_m=0.0, *, bracket=None) -> np.ndarray:
    """The frozen-coefficient rule, the one both the step guard (``study.plan``) and
    ``gearsweep advise`` apply: is the fixed step ``h`` [s] within the method's stability limit
    at the largest stiffness, h <= ``max_stable_step(method, k_over_m, c_over_m)``?

    Parameters
    ----------
    method : {"rk4", "rk5"}
    h : array_like
        The step [s] (the mesh period over the steps per period) per case.
    k_over_m, c_over_m : array_like
        Largest stiffness over the cycle / mass [1/s^2], viscous damping / mass [1/s].
    bracket : (h_lo, h_hi) of array_like, optional
        Bounds of that limit known beforehand (the step guard's table, ``study.plan``):
        h <= h_lo passes and h > h_hi fails without solving; only the steps between them are
        judged against the exact limit. Without it every case is solved.

    Returns
    -------
    ndarray of bool
        True where the step is within the limit (and where ``h`` is NaN: nothing to judge).
    """
    h, k, c = np.broadcast_arrays(np.asarray(h, float), np.asarray(k_over_m, float),
                                  np.asarray(c_over_m, float))
    if bracket is None:
        lo, hi = np.zeros(h.shape), np.full(h.shape, np.inf)
    else:
        lo, hi = (np.broadcast_to(np.asarray(x, float), h.shape) for x in bracket)
    with np.errstate(invalid="ignore"):
        bad = h > hi
        band = np.flatnonzero(~bad & (h > lo))
    if band.size:
        bad.flat[band] = h.flat[band] > max_stable_step(method, k.flat[band], c.flat[band])
    return ~bad


def require_stable_step(method: str, steps_per_period, mesh_period, k_max_over_m,
                        c_over_m=0.0, margin: float = 1.0) -> None:
    """Raise ``UnstableStepError`` naming the worst case when ``check_step`` fails anywhere."""
    ok, limit = check_step(method, steps_per_period, mesh_period, k_max_over_m, c_over_m, margin)
    if not np.all(ok):
        worst = int(np.max(limit))
        raise UnstableStepError(
            f"steps_per_period {int(np.min(steps_per_period))} is too coarse for {method}: "
            f"{int(np.count_nonzero(~ok))} case(s) need at least {worst} steps per mesh period "
            f"(stability polynomial at the largest stiffness)"
        )


def integrator_unstable(alpha, beta, gamma, steps_per_period: int, *, method: str = "rk5",
                        floquet=None, tol: float = UNSTABLE_TOL, harmonics=None):
    """Cases where the discrete map diverges although the equation does not.

    Parameters
    ----------
    alpha, beta, gamma : array_like
        Mathieu parameters of Eq. (11)-(12) [-].
    steps_per_period : int
        The step to judge, per mesh period.
    method : {"rk4", "rk5"}
    floquet : FloquetResult, optional
        The converged Floquet analysis of the same cases (computed here if not given).
    tol : float
        A multiplier counts as > 1 above ``1 + tol``.
    harmonics : see ``gearsweep.kernels.floquet.monodromy``.

    Returns
    -------
    flag : ndarray of bool
        Discrete multiplier > 1 + tol and the equation's multiplier <= 1 + tol.
    discrete : ndarray
        Largest |multiplier| of the discrete monodromy matrix at this step (inf when it overflows).
    """

    shape = np.broadcast_shapes(np.shape(alpha), np.shape(beta), np.shape(gamma))
    M = fq.monodromy(alpha, beta, gamma, steps_per_period, method=method, harmonics=harmonics)
    disc = fq.largest_multiplier(M).reshape(shape)
    if floquet is None:
        floquet = fq.floquet(alpha, beta, gamma, method=method, harmonics=harmonics)
    flag = (disc > 1 + tol) & ~(floquet.multiplier > 1 + tol)
    return flag, disc


STRONG_VARIATION = 0.2
"""Stiffness variation sum|k_n| / k0 (beta sum|r_n| / alpha) above which the frozen-coefficient
check (``check_step`` at k0 + sum|k_n|) is not conservative and the step guard also checks the
fixed-step map's monodromy (``map_step_check``; ``needs_map_check``). Scans of RK4 and RK5 from
the guard's fewest steps to twice as many (alpha 0.3-2000, zeta 0-0.2, 28,000 random cases a
method; ``scripts/scan_step_guard.py random``): cases beyond the limit appear at dampings up to
0.2 above it (the smallest ratio among them 0.269) and none at or below it, e.g. alpha = 58.29,
beta = 57.07, gamma = 0.1527 (beta / alpha = 0.979), RK5 at 38 steps per period: the map's
multiplier 1.19, the equation's 0.978 (docs/stability.md). Below it they appear only at fewer
than ``COARSE_STEPS`` steps per period."""
COARSE_STEPS = 32
"""Below this many steps per period the map's phase error moves a parametric tongue of Eq. (11)
off the equation's even for weak variation, and the step guard checks the map's monodromy
wherever k(t) varies at all. A scan of 60,000 cases a method with sum|k_n| / k0 < 0.2 (alpha
0.1-30, zeta 0-0.05, each step count from the frozen limit to twice it or 64;
``scripts/scan_step_guard.py weak``): RK4 diverges where the equation decays by more than 1e-3 a
period up to 14 steps per period (alpha near 1/4 and 1, the first two tongues), RK5 up to 9;
from 32 steps on, none beyond the limit (at a tongue's edge the map still can be:
``TONGUE_MARGIN``'s)."""


TONGUE_MARGIN = 2.0
"""Where the stiffness varies weakly, the step guard also checks the map's monodromy where the
case's damping ratio is at most this many times ``tongue_damping`` (the damping that closes the
parametric tongue nearest the case): the map's tongue sits O(h^p) beside the equation's, and at a
tongue's edge the map diverges where the equation does not. Scans of RK4 and RK5 at 16-256 steps
per period (beta / alpha 0.05-0.2, tongues 1-6; ``scripts/scan_step_guard.py close above``): the
equation's tongue n closes at 0.98-1.006 times ``tongue_damping``, and at 1.01, 1.1 and 1.5 times
it the map's largest |mu| stays below 1 + 1e-6 near the tongue at every one of those steps
(docs/stability.md)."""


def tongue_damping(alpha, beta, harmonics=None) -> np.ndarray:
    """The damping ratio above which the Hill equation p'' + gamma p' + (alpha + beta s(tau)) p = 0
    has no parametric tongue near ``alpha``.

    One stiffness harmonic r cos(o tau + a) (``variation_ratio`` r): the tongue nearest alpha is
    j = round(2 sqrt(alpha) / o) >= 1, at alpha = (o j)^2 / 4, and it closes at zeta =
    Delta_j / j^2 = 2 (r j^2 / 8)^j / (j!)^2 with Delta_j = 2 (r j^2 / 8)^j / ((j-1)!)^2, the
    first-order width in alpha of Mathieu's tongue j (a_j - b_j = q^j / (2^(2j-3) ((j-1)!)^2)
    in Mathieu's form y'' + (a - 2 q cos 2t) y = 0, a = 4 alpha, q = 2 beta):
    zeta_1 = r / 4, zeta_2 = r^2 / 8, zeta_3 = 81 r^3 / 1024, ... Several harmonics: r / 4, as
    if one harmonic carried the whole variation (harmonic o closes its own first-order tongue
    at r_o / 4; tongues of higher order are narrower by factors of order r). The damping ratio
    is zeta = gamma / (2 sqrt(alpha)).

    Returns
    -------
    ndarray
        zeta_n [-] (0 where the stiffness is constant; ``inf`` where alpha <= 0).
    """
    amps, orders, _ = harmonics if harmonics is not None else fq.MATHIEU
    amps = np.atleast_1d(np.asarray(amps, float))
    orders = np.atleast_1d(np.asarray(orders, float))
    r = variation_ratio(alpha, beta, harmonics)
    a = np.asarray(alpha, float)
    if np.count_nonzero(amps) != 1:
        return r / 4.0
    o = float(orders[np.flatnonzero(amps)[0]])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        j = np.maximum(np.round(2.0 * np.sqrt(np.where(a > 0, a, 0.0)) / o), 1.0)
        uniq, inverse = np.unique(j, return_inverse=True)  # (a study has few tongues)
        log_fact = np.array([math.lgamma(x + 1.0) for x in uniq.ravel()])[inverse].reshape(j.shape)
        log_z = math.log(2.0) + j * np.log(r * j * j / 8.0) - 2.0 * log_fact
        z = np.where(r > 0, np.exp(log_z), 0.0)
    return np.where(np.isfinite(r), z, np.inf)


def needs_map_check(alpha, beta, gamma, harmonics, steps_per_period: int) -> np.ndarray:
    """Where the step guard checks the fixed-step map's monodromy besides the frozen rule: where
    the stiffness varies (``variation_ratio`` > 0) and it varies by more than
    ``STRONG_VARIATION``, or the step is coarser than ``COARSE_STEPS`` per period, or the case's
    damping ratio gamma / (2 sqrt(alpha)) is at most ``TONGUE_MARGIN`` x ``tongue_damping`` (a
    parametric tongue near the case is open: every undamped case)."""
    ratio = variation_ratio(alpha, beta, harmonics)
    a = np.asarray(alpha, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = np.abs(np.asarray(gamma, float)) / (2.0 * np.sqrt(np.where(a > 0, a, np.nan)))
        near_tongue = ~(zeta > TONGUE_MARGIN * tongue_damping(alpha, beta, harmonics))
        return (ratio > STRONG_VARIATION) | ((ratio > 0) & (
            (int(steps_per_period) < COARSE_STEPS) | near_tongue))


def variation_ratio(alpha, beta, harmonics=None) -> np.ndarray:
    """sum|k_n| / k0 of Hill equations in Mathieu form: |beta| sum|r_n| / alpha (``inf`` where
    alpha <= 0 and beta != 0, 0 where beta = 0)."""
    amps = np.atleast_1d((harmonics if harmonics is not None else fq.MATHIEU)[0])
    var = np.abs(np.asarray(beta, float)) * float(np.sum(np.abs(np.asarray(amps, float))))
    a = np.asarray(alpha, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(var == 0, 0.0, np.where(a > 0, var / np.where(a > 0, a, 1.0), np.inf))


RESONANCE_TOL = 0.01
"""Largest relative error of the forced response's resonant part that the step guard lets a
fixed-step map bring (``resonance_error``): 1 %, the share the project holds a study's answers
to elsewhere (``settle_tolerance``, which the transient's residual is judged by too). Near a parametric
tongue a damped case's periodic response is amplified by 1 / det(I - M) (M the monodromy over the
forcing's period), and a map whose multiplier nearest 1 is off by a little there is off by a lot
in the response: an outside analyst's whine scene (k1 / k0 = 0.98, zeta 0.007, RK5) at 56 steps
per mesh period has the map's multiplier 0.99926 against the equation's 0.97881 and p_rms 28.5
times the truth, with status 0 (docs/stability.md)."""


def _det_i_minus(M: np.ndarray, cycles: int = 1) -> np.ndarray:
    """det(I - M^cycles) of 2x2 matrices (n, 2, 2): 1 - tr(M^q) + det(M)^q."""
    Mq = np.linalg.matrix_power(M, int(cycles)) if cycles != 1 else M
    det = np.linalg.det(M) ** int(cycles)
    return 1.0 - (Mq[:, 0, 0] + Mq[:, 1, 1]) + det


def resonance_error(M_map, M_eq, cycles: int = 1) -> np.ndarray:
    """Relative error of the resonant part of the periodic forced response that the fixed-step map
    ``M_map`` brings against the equation's monodromy ``M_eq`` (both (n, 2, 2), over one period
    of the Hill equation).

    A response periodic with the forcing (``cycles`` periods of the equation: a fractional forcing
    order) starts from (I - M^q)^-1 b, b the particular solution's end state, whose error is the
    step's ordinary error. (I - M)^-1 = adj(I - M) / det(I - M) with adj linear in M, so where
    det(I - M) is small (a multiplier near 1: near a parametric tongue, or undamped near its
    edge) the response is amplified by 1 / det(I - M), and the map's response differs from the
    equation's by the factor det(I - M_eq) / det(I - M_map):

        E = |det(I - M_eq^q) - det(I - M_map^q)| / |det(I - M_map^q)|.

    Invariant under a change of basis and needs no pairing of multipliers; a multiplier near -1
    does not amplify a response of the forcing's period and does not count. (The analyst's whine
    scene, RK5: E = 27.3, 0.69, 0.099, 0.024, 0.0020 at 56, 64, 80, 96, 128 steps per period,
    where p_rms was 28.5, 1.70, 1.10, 1.026, 1.0024 times scipy's; tests/test_step_guard_map.py.)
    ``inf`` where the map overflowed.
    """
    M_map, M_eq = np.asarray(M_map, float), np.asarray(M_eq, float)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        pm, pe = _det_i_minus(M_map, cycles), _det_i_minus(M_eq, cycles)
        e = np.abs(pe - pm) / np.abs(pm)
    return np.where(np.isfinite(e), e, np.inf)


_RESONANCE_SCREEN = 8.0
"""``map_step_check`` computes the equation's monodromy for the resonance test only where the
map's own Richardson estimate of E (the map at S against 2S) exceeds RESONANCE_TOL / this: well
below the tolerance the map at S and at 2S agree with each other and, in the asymptotic range,
with the equation (``scripts/scan_step_guard.py resonance`` counts the cases the screen passes
that the equation flags)."""


_SCREEN_HW = 1.0
"""The screen is trusted only where h omega at the stiffest instant is at most this: coarser,
the maps at S and 2S can both be far from the equation and agree with each other (RK4 near its
frozen limit, where both kill a free vibration the equation keeps at 0.3 a period: E 0.6 with
the screen's estimate 2e-5; ``scripts/scan_step_guard.py resonance``). Undamped cases are not
screened either: there the map's own damping is all the decay there is (RK4 at 384 steps, h omega
0.71: the map's |mu| 0.77 against the equation's 1, E 0.014 with the estimate 7e-4)."""


_SETTLED_MARGIN = 4.0
"""``_settled_equation`` stops refining a case once the last refinement moved its multiplier and
its resonance error each by less than 1 / this of their distance from their thresholds: RK5's
next refinements move them by about 1 / 31 of the last one, and all of them together by 1 / 31
of it (a geometric series of ratio 1 / 32), so the verdict is 4 x 31 = 124 times that from
changing."""


def _settled_equation(a, b, g, M_map, grow, *, tol: float, resonance_tol: float, cycles: int,
                      harmonics) -> tuple[np.ndarray, np.ndarray]:
    """The equation's monodromy and largest |mu| of the cases for ``map_step_check``'s forced
    test: ``floquet``'s refinement (RK5 from its first step count, doubling, rtol 1e-10: the same
    kernel calls), each case stopped as soon as its verdict is settled (``_SETTLED_MARGIN``):
    its multiplier clearly on one side of 1 + tol and, where that is stable and the map not
    diverging (``grow``), its resonance error clearly on one side of ``resonance_tol``. Most of
    ``floquet``'s work is in its finest levels, where a case whose E is 1e-4 or 0.5 needs none of
    it (the synthetic 1e5-case whine grid of docs/stability.md). Returns what ``floquet`` would,
    at the level where each case stopped."""
    n = a.size
    spp = np.minimum(fq._initial_spp(a, b, g, harmonics, fq.HW0, fq.SPP_MIN), fq.SPP_MAX)
    M = np.full((n, 2, 2), np.nan)
    mu, prev_mu, prev_e = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    active = np.ones(n, bool)
    factor = 2.0 ** fq.ORDER["rk5"] - 1.0
    while active.any():
        S = int(spp[active].min())
        idx = np.flatnonzero(active & (spp == S))
        Mi = fq.monodromy(a[idx], b[idx], g[idx], S, method="rk5", harmonics=harmonics)
        mi = largest_multiplier(Mi)
        p = prev_mu[idx]
        with np.errstate(invalid="ignore"):  # floquet's convergence, as it has it
            e = np.where(np.isnan(p), np.inf,
                         np.where(np.isinf(mi) & np.isinf(p), 0.0, np.abs(mi - p) / factor))
        e = np.where(np.isnan(e), np.inf, e)
        ok = e <= 1e-12 + 1e-10 * np.where(np.isfinite(mi), mi, 0.0)
        ok |= np.isinf(mi) & np.isinf(p)
        with np.errstate(invalid="ignore", over="ignore"):
            E = resonance_error(M_map[idx], Mi, cycles)
            dmu = np.abs(mi - p)
            dE = np.abs(E - prev_e[idx])
            mu_far = dmu * _SETTLED_MARGIN < np.abs(mi - (1.0 + tol))
            E_far = dE * _SETTLED_MARGIN < np.abs(E - resonance_tol)
        unstable = mi > 1 + tol
        settled = np.isfinite(mi) & np.isfinite(p) & mu_far & (
            unstable | grow[idx] | (np.isfinite(E) & np.isfinite(prev_e[idx]) & E_far))
        M[idx], mu[idx] = Mi, mi
        prev_mu[idx], prev_e[idx] = mi, E
        stop = ok | settled | (S >= fq.SPP_MAX)
        active[idx[stop]] = False
        spp[idx[~stop]] = 2 * S
    return M, mu


def map_step_check(alpha, beta, gamma, steps_per_period: int, *, method: str,
                   harmonics=None, tol: float = UNSTABLE_TOL, forced: bool = False,
                   cycles: int = 1, resonance_tol: float = RESONANCE_TOL,
                   screen: bool = True, equation=None) -> tuple[np.ndarray, np.ndarray]:
    """The step guard's check of the fixed-step map, where ``needs_map_check`` asks for it.

    Parameters
    ----------
    alpha, beta, gamma : array_like (n,)
        Hill equations in Mathieu form (``gearsweep.model.hill_parameters``).
    steps_per_period : int
        Steps per period of the Hill equation (2 pi of its time).
    method : str
        A kernel method (``rk4``, ``rk5``).
    harmonics : see ``gearsweep.kernels.floquet.monodromy``.
    tol : float
        A multiplier counts as > 1 above ``1 + tol`` (the floquet output's threshold).
    forced : bool
        The scene is forced (a gear scene: mean force, STE, fluctuation): also beyond where the
        map's resonant response is off by more than ``resonance_tol`` (``resonance_error``), the
        forcing repeating every ``cycles`` periods of the equation.
    screen : bool
        Compute the equation's monodromy only where the map's Richardson estimate of that error
        is above ``resonance_tol / _RESONANCE_SCREEN``, the step is coarse (h omega >
        ``_SCREEN_HW`` at the stiffest instant) or the case is undamped (False: everywhere).
    equation : (n, 2, 2) array, optional
        The equation's monodromy of the cases, if known (``map_step_limit`` computes it once).

    Returns
    -------
    beyond : ndarray of bool
        The map's largest |mu| over one period is > 1 + tol and the equation's (converged, RK5)
        is not (``integrator_unstable``'s rule), or (``forced``) the map's resonant response is
        off by more than ``resonance_tol``. The converged multiplier is computed only for the
        cases whose map is unstable or whose screen asks for it.
    discrete : ndarray
        The map's largest |mu| (inf where it overflows).
    """
    a, b, g = (np.ravel(x) for x in np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(gamma, float)))
    beyond = np.zeros(a.size, bool)
    if a.size == 0:
        return beyond, np.zeros(0)
    S = int(steps_per_period)
    M = fq.monodromy(a, b, g, S, method=method, harmonics=harmonics)
    disc = largest_multiplier(M)
    grow = disc > 1 + tol
    ask = grow.copy()
    if forced:
        if equation is not None or not screen:
            ask[:] = True
        else:
            M2 = fq.monodromy(a, b, g, 2 * S, method=method, harmonics=harmonics)
            p = fq.ORDER[method]
            est = resonance_error(M, M2, cycles) * 2.0**p / (2.0**p - 1.0)
            amps = np.atleast_1d((harmonics if harmonics is not None else fq.MATHIEU)[0])
            hw = 2.0 * np.pi * np.sqrt(np.abs(a) + np.abs(b) * np.sum(np.abs(amps))) / S
            ask |= ~(est <= resonance_tol / _RESONANCE_SCREEN) | ~(hw <= _SCREEN_HW) | (g == 0)
    idx = np.flatnonzero(ask)
    if idx.size:
        if equation is not None:
            M_eq = np.asarray(equation, float).reshape(-1, 2, 2)[idx]
            eq_mu = largest_multiplier(M_eq)
        elif forced:
            M_eq, eq_mu = _settled_equation(a[idx], b[idx], g[idx], M[idx], grow[idx], tol=tol,
                                            resonance_tol=resonance_tol, cycles=cycles,
                                            harmonics=harmonics)
        else:
            eq = floquet(a[idx], b[idx], g[idx], method="rk5", rtol=1e-8, tol=tol,
                         harmonics=harmonics)
            M_eq, eq_mu = eq.monodromy.reshape(-1, 2, 2), eq.multiplier
        stable = ~(eq_mu > 1 + tol)
        out = grow[idx] & stable
        if forced:  # (an unstable equation has no periodic response to get right)
            out |= stable & (resonance_error(M[idx], M_eq, cycles) > resonance_tol)
        beyond[idx] = out
    return beyond, disc


def map_step_limit(alpha, beta, gamma, start, *, method: str, harmonics=None,
                   tol: float = UNSTABLE_TOL, most: int = 8, forced: bool = False,
                   cycles: int = 1, spp_scale: int = 1) -> np.ndarray:
    """The fewest steps per period, from ``start`` (the frozen-coefficient limit, per case) on,
    that ``map_step_check`` passes: ``start`` where it passes there, else start + 1, + 2, ...
    (the map's multiplier need not fall monotonically with the step: the first count that
    passes), at most ``most`` x start (then that). ``spp_scale``: the map's steps per period of
    the equation per step count counted here (the periods of a fractional stiffness order's
    cycle: the count is per mesh period). With ``forced`` the equation's monodromy is computed
    once per case."""
    a, b, g, s0 = (np.ravel(x) for x in np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(gamma, float),
        np.asarray(start, np.int64)))
    out = s0.copy()
    active = np.ones(a.size, bool)
    M_eq = None
    if forced and a.size:
        M_eq = floquet(a, b, g, method="rk5", rtol=1e-10, tol=tol,
                       harmonics=harmonics).monodromy.reshape(-1, 2, 2)
    while active.any():
        S = int(out[active].min())
        idx = np.flatnonzero(active & (out == S))
        beyond, _ = map_step_check(a[idx], b[idx], g[idx], S * spp_scale, method=method,
                                   harmonics=harmonics, tol=tol, forced=forced, cycles=cycles,
                                   equation=None if M_eq is None else M_eq[idx])
        stop = ~beyond | (S >= most * s0[idx])
        active[idx[stop]] = False
        out[idx[~stop]] = S + 1
    return out


def integrator_edge(speeds_rpm: tuple[float, float], *, k0: float, k1: float, mass: float,
                    teeth: int, damping: float, steps_per_period: int, method: str = "rk5",
                    tol: float = UNSTABLE_TOL) -> float:
    """The speed [rpm] between the two of ``speeds_rpm`` at which the fixed-step map of the rig's
    Hill equation (Eq. 11-12, ``mathieu_parameters``) passes between diverging and not: its
    largest multiplier over one mesh period is ``1 + tol`` (``integrator_unstable``'s
    threshold), found by Brent's method on the multiplier's logarithm, to 1e-9 rpm.

    A grid of speeds puts this edge only between two of its points (the rig's 96 log-spaced
    speeds are 3.2 % apart: the last flagged one, 165.6 rpm at c = 5.5 N s/mm and 200 steps,
    lies 3 % below the edge, 170.56 rpm).

    Parameters
    ----------
    speeds_rpm : (float, float)
        Driving-gear speeds [rpm] that bracket the edge: the map diverges at one, not the other.
    k0, k1, mass, teeth, damping : float, float, float, int, float
        Mean and first-harmonic stiffness [N/m], m_eq [kg], teeth of the driving gear, viscous
        mesh damping [N s/m].
    steps_per_period : int
        Fixed steps per mesh period.
    method : {"rk4", "rk5"}
    tol : float

    Raises
    ------
    ValueError
        If the two speeds do not bracket the edge.
    """
    from scipy.optimize import brentq

    def excess(speed: float) -> float:
        a, b, g = mathieu_parameters(k0, k1, mass, damping, float(mesh_frequency(speed, teeth)))
        mu = float(largest_multiplier(fq.monodromy(a, b, g, steps_per_period, method=method))[0])
        return min(math.log(mu), 700.0) - math.log1p(tol)  # (an overflow: inf)

    lo, hi = (float(x) for x in speeds_rpm)
    if not excess(lo) * excess(hi) < 0:
        raise ValueError(f"the map's multiplier does not cross 1 + {tol:g} between {lo:g} and"
                         f" {hi:g} rpm: give speeds on either side of the edge")
    return float(brentq(excess, lo, hi, xtol=1e-9))


def trial_call(method: str, h: np.ndarray, zeta: np.ndarray, bound: float = 10.0) -> dict:
    """The ``simulate`` keyword arguments (without step counts) of a trial of
    ``measured_step_limit``: the oscillator from (1, 1) at steps ``h`` [1] per case (what
    ``analysis_cost`` asks Numba's cache for)."""
    return dict(h=h, method=_method(method), damping=2.0 * zeta, k_mean=1.0, bound=bound, x0=1.0,
                v0=1.0, steps_per_period=1000)


def measured_step_limit(method: str, zeta, n_steps: int = 2_000_000, bound: float = 10.0,
                        lo: float = 0.05, hi: float = 6.0, iterations: int = 22) -> np.ndarray:
    """Largest h omega_n at which an integration of the oscillator does not blow up.

    Bisection on h omega_n (vectorised over ``zeta``): the oscillator p'' + 2 zeta p' + p = 0 is
    integrated ``n_steps`` steps from (1, 1) with the batch kernel, and the step counts as
    unstable when |p| passes ``bound`` (the kernel's divergence flag). This is the measurement
    that the stability polynomial predicts (``step_limit_hw``); it lies slightly above the
    prediction, by the step at which |R|^n_steps reaches ``bound``.

    Parameters
    ----------
    method : {"rk4", "rk5"}
    zeta : array_like
        Damping ratios [-].
    n_steps : int
        Steps integrated per trial.
    bound : float
        Growth factor that counts as divergence.
    lo, hi : float
        Initial bracket of h omega_n (must be stable at ``lo`` and unstable at ``hi``).
    iterations : int
        Bisection steps (bracket / 2^iterations).

    Returns
    -------
    ndarray
        Measured limit of h omega_n [-].
    """

    zeta = np.atleast_1d(np.asarray(zeta, dtype=float))
    a = np.full(zeta.shape, lo)
    b = np.full(zeta.shape, hi)
    for _ in range(iterations):
        mid = 0.5 * (a + b)
        res = simulate(**trial_call(method, mid, zeta, bound), n_transient=int(n_steps),
                       n_record=0)
        bad = res.status == STATUS_DIVERGED
        b = np.where(bad, mid, b)
        a = np.where(bad, a, mid)
    return 0.5 * (a + b)


def operating_map(speed_rpm, damping, *, k0: float, k1: float, mass: float, teeth: int,
                  method: str = "rk5", coarse_spp: int = 200, fine_spp: int = 2048,
                  n_periods: int = 100, threshold: float = 1e3, tol: float = UNSTABLE_TOL,
                  rtol: float = 1e-7) -> dict:
    """Stability of the paper's rig over speed x damping, four ways (the data of Fig. 7.2).

    Parameters
    ----------
    speed_rpm : array_like (ns,)
        Driving-gear (gear 1) shaft speed [rpm].
    damping : array_like (nc,)
        Mesh viscous damping c [N s/m].
    k0, k1 : float
        Mean and first-harmonic mesh stiffness [N/m].
    mass : float
        Equivalent mass m_eq [kg].
    teeth : int
        Teeth of the driving gear (mesh frequency = teeth x speed / 60).
    method : {"rk4", "rk5"}
        Integrator of the paper's criterion.
    coarse_spp, fine_spp : int
        Steps per mesh period of the coarse and the fine fixed-step runs.
    n_periods, threshold : int, float
        Paper's criterion: growth by ``threshold`` within ``n_periods`` mesh periods.
    tol : float
        Multipliers count as > 1 above 1 + tol.
    rtol : float
        Convergence tolerance of the Floquet multipliers (well below ``tol``).

    Returns
    -------
    dict of ndarray (nc, ns)
        ``alpha``, ``beta``, ``gamma``; ``floquet`` (FloquetResult), ``unstable`` (converged
        Floquet), ``paper_coarse``, ``paper_fine`` (the growth criterion at the two steps),
        ``integrator_unstable`` (coarse step), ``discrete_multiplier`` (coarse step), and
        ``limit_speed`` (nc,): the speed [rpm] below which ``check_step`` refuses the coarse step.
    """

    speed = np.asarray(speed_rpm, dtype=float)
    c = np.asarray(damping, dtype=float)
    S, C = np.meshgrid(speed, c)
    fmesh = mesh_frequency(S, teeth)
    alpha, beta, gamma = mathieu_parameters(k0, k1, mass, C, fmesh)
    fl = floquet(alpha, beta, gamma, method=method, tol=tol, rtol=rtol)
    flag, disc = integrator_unstable(alpha, beta, gamma, coarse_spp, method=method, floquet=fl,
                                     tol=tol)
    coarse = paper_criterion(alpha, beta, gamma, coarse_spp, method=method,
                             n_periods=n_periods, threshold=threshold)
    fine = paper_criterion(alpha, beta, gamma, fine_spp, method=method, n_periods=n_periods,
                           threshold=threshold)
    # Guard rail: h* at the largest stiffness (k0 + k1) gives the slowest mesh period that the
    # coarse step resolves stably: T / coarse_spp = h*  ->  speed = 60 / (teeth coarse_spp h*).
    h_star = max_stable_step(method, (k0 + k1) / mass, c / mass)
    limit_speed = 60.0 / (teeth * coarse_spp * h_star)
    return dict(alpha=alpha, beta=beta, gamma=gamma, floquet=fl, unstable=fl.unstable,
                paper_coarse=coarse, paper_fine=fine, integrator_unstable=flag,
                discrete_multiplier=disc, limit_speed=limit_speed)


def tableau_monodromy(alpha, beta, gamma, steps_per_period: int, method: str,
                      harmonics=None) -> np.ndarray:
    """Monodromy matrices of the fixed-step map of ANY explicit tableau for the Hill equation.

    The equation p'' + gamma p' + (alpha + beta s(tau)) p = 0 is linear, so one step of an
    explicit Runge-Kutta method is a 2 x 2 matrix: with J_i = J(tau_n + c_i h) the stage
    matrices are K_i = J_i (I + h sum_j a_ij K_j) and the step is I + h sum_i b_i K_i. Their
    product over ``steps_per_period`` steps is the discrete monodromy matrix. This is the map that
    the compiled kernel computes for ``rk4`` and ``rk5`` (tests check the two agree to
    round-off); for the other tableaux of ``gearsweep.kernels.tableaux`` it is the only one.

    Parameters
    ----------
    alpha, beta, gamma : array_like (broadcast to n)
        Mathieu parameters [-].
    steps_per_period : int
        Steps per period 2 pi.
    method : str
        A name in ``gearsweep.kernels.tableaux.TABLEAUX``.
    harmonics : (amplitudes, orders, phases), optional
        s(tau) = sum r cos(n tau + a); default cos tau. Whole orders only (ValueError naming a
        fractional one: ``kernels.floquet.whole_orders``).

    Returns
    -------
    ndarray (n, 2, 2)
    """
    A, b, c = TABLEAUX[_method(method)].arrays()
    amps, orders, phases = fq.whole_orders(harmonics)
    a_, b_, g_ = (np.ravel(x) for x in np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(gamma, float)))
    n, S = a_.size, int(steps_per_period)
    h = 2.0 * np.pi / S
    eye = np.broadcast_to(np.eye(2), (n, 2, 2))
    M = np.array(eye)
    s_stages = len(b)
    for step in range(S):
        tau = (step + c) * h
        shape = sum(r * np.cos(k * tau + ph) for r, k, ph in zip(amps, orders, phases,
                                                                  strict=True))
        K = []
        for i in range(s_stages):
            J = np.zeros((n, 2, 2))
            J[:, 0, 1] = 1.0
            J[:, 1, 0] = -(a_ + b_ * shape[i])
            J[:, 1, 1] = -g_
            Y = np.array(eye)
            for j in range(i):
                if A[i, j] != 0.0:
                    Y = Y + (h * A[i, j]) * K[j]
            K.append(J @ Y)
        step_matrix = np.array(eye)
        for i in range(s_stages):
            if b[i] != 0.0:
                step_matrix = step_matrix + (h * b[i]) * K[i]
        with np.errstate(over="ignore", invalid="ignore"):
            M = step_matrix @ M
    return M


def growth_criterion(M: np.ndarray, n_periods: int = 100, threshold: float = 1e3,
                     perturbation: float = 1e-6) -> np.ndarray:
    """The paper's test on a monodromy matrix: start at p = p' = ``perturbation`` and flag growth
    of |p| past ``threshold * perturbation`` at the end of any of ``n_periods`` periods (or
    overflow), as ``gearsweep.kernels.floquet.paper_criterion`` checks once per mesh period."""
    y = np.full(M.shape[:-2] + (2,), float(perturbation))
    bad = np.zeros(M.shape[:-2], bool)
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(int(n_periods)):
            y = np.einsum("...ij,...j->...i", M, y)
            bad |= ~(np.abs(y[..., 0]) <= threshold * perturbation)
    return bad


def artifact_map(speed_rpm, damping, *, k0: float, k1: float, mass: float, teeth: int,
                 methods=tableaux.FIFTH_ORDER, steps_per_period=(100, 150, 200, 300, 400),
                 n_periods: int = 100, threshold: float = 1e3) -> dict:
    """The paper's criterion for several tableaux and fixed steps over speed x damping.

    Parameters
    ----------
    speed_rpm : array_like (ns,)
        Driving-gear speed [rpm] (mesh frequency = teeth x speed / 60).
    damping : array_like (nc,)
        Viscous mesh damping c [N s/m].
    k0, k1, mass, teeth : float, float, float, int
        Mean and first-harmonic stiffness [N/m], m_eq [kg], teeth of the driving gear.
    methods : sequence of str
        Tableaux (``gearsweep.kernels.tableaux``).
    steps_per_period : sequence of int
        Fixed steps per mesh period to try.
    n_periods, threshold : int, float
        The paper's criterion (growth ``threshold``-fold within ``n_periods`` periods).

    Returns
    -------
    dict
        ``flag`` (nm, nS, nc, ns) bool: the criterion reports instability; ``discrete_multiplier``
        (nm, nS, nc, ns); ``edge_speed`` (nm, nS, nc): the highest flagged speed [rpm] (NaN if
        none); ``real_interval``, ``imaginary_interval`` (nm,); ``zeta`` (nc,): damping ratio at
        k0; ``step_limit_hw`` (nm, nc): the largest stable h omega_n at that zeta; and the inputs.
    """
    speed = np.asarray(speed_rpm, dtype=float)
    c = np.asarray(damping, dtype=float)
    S_, C_ = np.meshgrid(speed, c)
    alpha, beta, gamma = mathieu_parameters(k0, k1, mass, C_, mesh_frequency(S_, teeth))
    methods = tuple(methods)
    spps = tuple(int(s) for s in steps_per_period)
    flag = np.zeros((len(methods), len(spps)) + alpha.shape, bool)
    disc = np.zeros(flag.shape)
    for im, m in enumerate(methods):
        for js, S in enumerate(spps):
            M = tableau_monodromy(alpha, beta, gamma, S, m)
            flag[im, js] = growth_criterion(M, n_periods, threshold).reshape(alpha.shape)
            disc[im, js] = largest_multiplier(M).reshape(alpha.shape)
    hi = np.where(flag, speed, -np.inf).max(axis=-1)
    edge = np.where(np.isfinite(hi), hi, np.nan)
    zeta = c / (2.0 * np.sqrt(k0 * mass))
    return dict(flag=flag, discrete_multiplier=disc, edge_speed=edge, methods=methods,
                steps_per_period=np.array(spps), speed=speed, damping=c, zeta=zeta,
                real_interval=np.array([tableaux.real_stability_interval(m) for m in methods]),
                imaginary_interval=np.array([tableaux.imaginary_stability_interval(m)
                                             for m in methods]),
                step_limit_hw=np.array([step_limit_hw(m, zeta) for m in methods]))


def reproduces_paper(edge_speed: np.ndarray, damping: np.ndarray, *, c_paper: float = 5500.0,
                     target_rpm: float = 200.0, rel: float = 0.25) -> np.ndarray:
    """Whether a map has the shape of the paper's Fig. 7.2, per (method, step): an unstable
    region at low speed without damping, an edge that does not grow with damping, and the edge
    at the paper's damping ``c_paper`` within ``rel`` of ``target_rpm`` (the paper's "unstable
    near 200 rpm").

    Parameters
    ----------
    edge_speed : ndarray (..., nc)
        Highest flagged speed per damping [rpm] (NaN: nothing flagged), ``artifact_map``'s.
    damping : ndarray (nc,)
        Damping values [N s/m], ascending.

    Returns
    -------
    ndarray of bool (...)
    """
    e = np.where(np.isnan(edge_speed), 0.0, edge_speed)
    has_region = e[..., 0] > 0
    shrinks = np.all(np.diff(e, axis=-1) <= 1e-9, axis=-1)
    i = int(np.argmin(np.abs(np.asarray(damping) - c_paper)))
    near = np.abs(e[..., i] / target_rpm - 1.0) <= rel
    return has_region & shrinks & near
