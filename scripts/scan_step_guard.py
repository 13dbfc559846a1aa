"""Reproduce the measured numbers behind the step guard's rules (docs/stability.md, "The step
guard"): scans of the fixed-step RK4 / RK5 map's monodromy against the equation's converged
Floquet multiplier, with the library's own functions.

    python scripts/scan_step_guard.py [SECTION ...] [--quick]

Sections (all by default):

* ``examples``: the two worked cases of the docs (alpha = 58.29 at 38-56 steps; the sliver at
  alpha = 1.00945), the equation's multiplier also from scipy's ``solve_ivp``.
* ``random``: random cases with sum|k_n| / k0 = 0.05-0.99 (``STRONG_VARIATION``).
* ``weak``: targeted cases below 0.2 (``COARSE_STEPS``).
* ``edges``: the map's largest multiplier at the equation's tongue edges.
* ``close``: the damping that closes tongue n against zeta_n (``tongue_damping``) and against
  the same rule with scipy's Mathieu characteristic values for the width.
* ``above``: the map near tongue n at 1.01, 1.1 and 1.5 zeta_n (``TONGUE_MARGIN``).
* ``multi``: several harmonics (orders 1, 2, 3 of equal size).
* ``alias``: away from the low tongues, h w_n from 0.3 to the frozen limit.
* ``resonance``: the resonance test of forced scenes (``resonance_error``): the docs' whine scene
  against scipy's periodic response and runs of the study; the screen against the exact test.

Each figure is printed as ``quoted: ... | measured: ...``. Seeds are fixed. ``--quick`` runs
every section on a small sample (under a minute on 2 cores; not the docs' numbers); the full
run reproduces them (about 2 minutes on 2 cores). The equation's tongue n of
p'' + gamma p' + (alpha + r alpha cos tau) p = 0 lies at alpha = n^2 / 4, i.e. at nu = 2 sqrt(alpha)
= n; the damping ratio is zeta = gamma / (2 sqrt(alpha)).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import mathieu_a, mathieu_b

from gearsweep.analysis import stability as st
from gearsweep.kernels import floquet as fq

TOL = fq.UNSTABLE_TOL
METHODS = ("rk4", "rk5")
SEED = 20261127
GUARD_RTOL = 1e-8
"""rtol of the equation's converged multiplier in the guard (``map_step_check``)."""
FINE_RTOL = 1e-11
"""rtol of the equation's multiplier where a scan locates a tongue edge."""


# ---------------------------------------------------------------- helpers


def zeta_n(r: float, n: int) -> float:
    """The damping that closes tongue n by the guard's rule (``tongue_damping`` at alpha = n^2 / 4,
    beta / alpha = r: 2 (r n^2 / 8)^n / (n!)^2)."""
    return float(st.tongue_damping(n * n / 4, r * n * n / 4))


def zeta_n_scipy(r: float, n: int) -> float:
    """The same rule with the exact width of Mathieu's tongue n from scipy: in Mathieu's form
    y'' + (a - 2 q cos 2t) y = 0 the equation p'' + (alpha + r alpha cos tau) p = 0 is
    a = 4 alpha, q = 2 r alpha, tongue n at a = n^2 (q = r n^2 / 2) of width a_n - b_n; in alpha
    that is (a_n - b_n) / 4, and zeta = width / n^2."""
    q = r * n * n / 2.0
    return float(mathieu_a(n, q) - mathieu_b(n, q)) / 4.0 / n**2


def eq_mu(alpha, beta, gamma, rtol=FINE_RTOL, harmonics=None) -> np.ndarray:
    """The equation's converged largest |mu| (RK5, steps doubled to ``rtol``)."""
    return fq.floquet(alpha, beta, gamma, method="rk5", rtol=rtol, harmonics=harmonics).multiplier


def map_mu(alpha, beta, gamma, steps: int, method: str, harmonics=None) -> np.ndarray:
    """The fixed-step map's largest |mu| over one period."""
    return fq.largest_multiplier(fq.monodromy(alpha, beta, gamma, steps, method=method,
                                              harmonics=harmonics))


def frozen_limit(method: str, kmax, gamma) -> np.ndarray:
    """The frozen-coefficient rule's fewest steps per period (``check_step``, Mathieu time)."""
    return st.check_step(method, 1, 2 * np.pi, kmax, gamma)[1]


def scipy_mu(alpha: float, beta: float, gamma: float) -> float:
    """The equation's largest |mu| from scipy's DOP853 (rtol 1e-13): independent of the kernels."""
    def f(t, y):
        return [y[1], -gamma * y[1] - (alpha + beta * np.cos(t)) * y[0]]
    cols = [solve_ivp(f, (0, 2 * np.pi), y0, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
            for y0 in ([1.0, 0.0], [0.0, 1.0])]
    return float(np.max(np.abs(np.linalg.eigvals(np.column_stack(cols)))))


def show(label: str, quoted: str, measured: str) -> None:
    print(f"  {label}: quoted {quoted} | measured {measured}", flush=True)


def undamped_tongue(r: float, n: int, points: int, harmonics=None):
    """The nu = 2 sqrt(alpha) where the undamped equation's multiplier exceeds 1 + TOL near tongue
    n (on a grid of ``points`` over [n - 0.2 r n, n + 0.3 r n]), and the largest multiplier."""
    nu = np.linspace(n - 0.2 * r * n, n + 0.3 * r * n, points)
    a = nu * nu / 4
    m0 = eq_mu(a, r * a, 0 * a, harmonics=harmonics)
    return nu[m0 > 1 + TOL], float(m0.max())


def closing_zeta(r: float, n: int, points: int, window: int, iters: int, harmonics=None):
    """The damping ratio at which tongue n closes: the equation's largest |mu| over the undamped
    tongue's nu <= 1 + TOL (bisection, ``iters`` halvings). None where the undamped tongue does
    not exceed 1 + TOL on the grid."""
    sel, top = undamped_tongue(r, n, points, harmonics)
    if sel.size == 0:
        return None, top
    win = np.linspace(sel.min(), sel.max(), window)
    a = win * win / 4

    def opened(z):
        return eq_mu(a, r * a, 2 * z * np.sqrt(a), harmonics=harmonics).max() > 1 + TOL
    lo, hi = 0.0, 0.02 if harmonics is not None else 20 * zeta_n(r, n)
    while opened(hi):
        hi *= 2
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if opened(mid) else (lo, mid)
    return hi, top


# ---------------------------------------------------------------- sections


def examples(quick: bool) -> dict:
    """The docs' two worked cases."""
    out = {}
    a, b, g = 58.29, 57.07, 0.1527
    print("outside analyst's case alpha 58.29, beta 57.07, gamma 0.1527, RK5")
    show("frozen limit", "38", f"{int(frozen_limit('rk5', a + b, g))}")
    eq = float(eq_mu(a, b, g, GUARD_RTOL))
    show("equation's multiplier", "0.978", f"{eq:.4f} (scipy {scipy_mu(a, b, g):.4f})")
    for S, q in ((38, "1.19"), (48, "1.032"), (55, "1.0017"), (56, "0.9992")):
        out[f"map{S}"] = m = float(map_mu(a, b, g, S, "rk5")[0])
        show(f"map at {S} steps", q, f"{m:.6f}")
    lim = int(st.map_step_limit(a, b, g, 38, method="rk5")[0])
    show("map_step_limit from 38", "56", str(lim))
    flagged = [S for S in range(38, 57) if st.map_step_check(a, b, g, S, method="rk5")[0][0]]
    show("steps the guard flags", "38-55", f"{min(flagged)}-{max(flagged)} ({len(flagged)} counts)")
    a = 1.00945
    b = 0.15 * a
    print("sliver: alpha 1.00945, beta / alpha 0.15, RK4 at 32 steps")
    out["sliver_map"] = m = float(map_mu(a, b, 0.0, 32, "rk4")[0])
    show("map's multiplier", "1.0013", f"{m:.5f}")
    out["sliver_eq"] = e = scipy_mu(a, b, 0.0)
    lib = float(eq_mu(a, b, 0.0))
    show("equation's (scipy) - 1", "within 3e-14", f"{e - 1:.1e} (library {lib - 1:.1e})")
    show("second tongue's upper edge 1 + 5 beta^2 / 12 (first order)", "above it",
         f"{1 + 5 * 0.15**2 / 12:.5f} < {a}")
    return out


def _scan(method, alpha, r, zeta, smax_of_s0):
    """Every step count from the frozen limit S0 to ``smax_of_s0(S0)``: the map's multiplier, and
    the guard's verdict (map > 1 + TOL and the equation's converged multiplier, RK5 to rtol 1e-8,
    <= 1 + TOL). Returns (case index, steps, map's |mu|) of every beyond, and the equation's
    multipliers (NaN where no map exceeded 1 + TOL)."""
    beta, gamma = r * alpha, 2 * zeta * np.sqrt(alpha)
    s0 = frozen_limit(method, alpha + beta, gamma)
    s1 = smax_of_s0(s0)
    hits = []
    for S in range(int(s0.min()), int(s1.max()) + 1):
        idx = np.flatnonzero((s0 <= S) & (S <= s1))
        if idx.size:
            d = map_mu(alpha[idx], beta[idx], gamma[idx], S, method)
            up = d > 1 + TOL
            hits += [(i, S, x) for i, x in zip(idx[up], d[up], strict=True)]
    eq = np.full(alpha.size, np.nan)
    cand = np.unique([h[0] for h in hits]).astype(int)
    if cand.size:
        eq[cand] = eq_mu(alpha[cand], beta[cand], gamma[cand], GUARD_RTOL)
    beyond = [h for h in hits if not eq[h[0]] > 1 + TOL]
    return beyond, eq


SMALLEST = {"rk4": "0.300 (undamped)", "rk5": "0.269 (undamped, 5 steps, alpha 0.314)"}
SMALLEST_DAMPED = {"rk4": "0.452", "rk5": "0.386 (zeta 0.005, 7 steps, alpha 2.28)"}


def random(quick: bool) -> dict:
    """sum|k_n| / k0 0.05-0.99, alpha 0.3-2000 (log-uniform), zeta one of ZETAS, every step count
    from the frozen limit to twice it."""
    n = 600 if quick else 28_000
    zetas = np.array([0, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2])
    print(f"random: {n} cases a method, ratio 0.05-0.99, alpha 0.3-2000, zeta {zetas.tolist()}")
    out = {}
    for k, method in enumerate(METHODS):
        rng = np.random.default_rng(SEED + k)
        alpha = np.exp(rng.uniform(np.log(0.3), np.log(2000), n))
        r = rng.uniform(0.05, 0.99, n)
        zeta = zetas[rng.integers(0, zetas.size, n)]
        beyond, eq = _scan(method, alpha, r, zeta, lambda s0: 2 * s0)
        cases = np.unique([h[0] for h in beyond]).astype(int)
        per = {float(z): int(np.count_nonzero(zeta[cases] == z)) for z in zetas}
        out[method] = {"cases": cases, "per_zeta": per,
                       "min_ratio": float(r[cases].min()) if cases.size else None}
        print(f" {method}: {cases.size} cases beyond at some step count; per damping {per}")
        show(f"{method} ratio <= 0.2 among them", "none",
             str(int(np.count_nonzero(r[cases] <= 0.2))))
        for label, sub, q in (("", cases, SMALLEST[method]),
                              (" damped", cases[zeta[cases] > 0], SMALLEST_DAMPED[method])):
            if sub.size:
                i = sub[np.argmin(r[sub])]
                steps = sorted(h[1] for h in beyond if h[0] == i)
                show(f"{method} smallest ratio among them{label}", q,
                     f"{r[i]:.3f} (zeta {zeta[i]:g}, {steps} steps, alpha {alpha[i]:.3f}, "
                     f"nu = 2 sqrt(alpha) = {2 * np.sqrt(alpha[i]):.2f})")
    show("RK4 cases per damping", "8-42 up to zeta 0.02, none from 0.05",
         str(out["rk4"]["per_zeta"]))
    show("RK5 cases per damping", "487 undamped, 2-14 from 0.001 to 0.1, 2 at 0.2",
         str(out["rk5"]["per_zeta"]))
    return out


def weak(quick: bool) -> dict:
    """sum|k_n| / k0 below 0.2, alpha 0.1-30 (log-uniform), zeta one of ZETAS, every step count
    from the frozen limit to max(2 x it, 64)."""
    n = 2000 if quick else 60_000
    zetas = np.array([0, 0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05])
    print(f"weak: {n} cases a method, ratio 0-0.2, alpha 0.1-30, zeta {zetas.tolist()}, "
          "steps from the frozen limit to max(2 x it, 64)")
    out = {}
    for k, method in enumerate(METHODS):
        rng = np.random.default_rng(SEED + 10 + k)
        alpha = np.exp(rng.uniform(np.log(0.1), np.log(30), n))
        r = rng.uniform(0.0, 0.2, n)
        zeta = zetas[rng.integers(0, zetas.size, n)]
        beyond, eq = _scan(method, alpha, r, zeta, lambda s0: np.maximum(2 * s0, 64))
        decays = [h for h in beyond if eq[h[0]] < 1 - 1e-3]
        coarse = max((h[1] for h in decays), default=None)
        top = max((h[2] for h in decays), default=None)
        tongues = sorted({int(round(2 * np.sqrt(alpha[h[0]]))) for h in decays})
        fine = [h for h in beyond if h[1] >= 32]
        out[method] = {"coarsest": coarse, "fine": len(fine)}
        show(f"{method} most steps with a beyond case whose equation decays by > 1e-3 a period",
             {"rk4": "14 (up to 1.038, tongues 1, 2)", "rk5": "9 (up to 1.022)"}[method],
             f"{coarse} (map up to {top:.4g}, tongues {tongues})"
             if decays else "none")
        if fine:
            idx = [h[0] for h in fine]
            show(f"{method} beyond at >= 32 steps", "none",
                 f"{len(fine)} (step counts {min(h[1] for h in fine)}-{max(h[1] for h in fine)}, "
                 f"equation's 1 - mu {np.min(1 - eq[idx]):.1e} to {np.max(1 - eq[idx]):.1e}, "
                 f"alpha {np.min(alpha[idx]):.3f}-{np.max(alpha[idx]):.3f})")
        else:
            show(f"{method} beyond at >= 32 steps", "none", "none")
    return out


def tongue_edges(r: float, z: float, nu_max: float, dnu: float) -> np.ndarray:
    """nu = 2 sqrt(alpha) of the equation's tongue edges (multiplier = 1 + TOL, on the side where
    it is <= 1 + TOL) in [0.55, nu_max): a grid, then bisection to 1e-13."""
    def m(nu):
        a = nu * nu / 4
        return eq_mu(a, r * a, 2 * z * np.sqrt(a)) - (1 + TOL)
    nu = np.arange(0.55, nu_max, dnu)
    v = m(nu)
    i = np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))
    lo, hi, vlo = nu[i], nu[i + 1], v[i]
    for _ in range(45):
        mid = 0.5 * (lo + hi)
        same = np.sign(m(mid)) == np.sign(vlo)
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return np.where(vlo <= 0, lo, hi)


def edge_excess(r: float, z: float, method: str, S: int, e: np.ndarray):
    """The map's largest |mu| - 1 at the edges ``e`` the frozen rule passes at S, and where."""
    a = e * e / 4
    g = 2 * z * np.sqrt(a)
    ok = S >= frozen_limit(method, a * (1 + r), g)
    if not ok.any():
        return -np.inf, None
    d = map_mu(a[ok], r * a[ok], g[ok], S, method) - 1
    k = int(np.argmax(d))
    return float(d[k]), float(e[ok][k])


def edges(quick: bool) -> dict:
    """The map's largest multiplier at the equation's tongue edges, tongues 1-4."""
    rs = (0.1, 0.2) if quick else (0.02, 0.05, 0.1, 0.15, 0.2)
    dnu = 2e-3 if quick else 2e-4
    steps = (16, 32, 64, 128, 256)
    quoted = {"rk4": ("8.4e-3", "2.5e-3", "6.8e-4", "1.7e-4", "4.3e-5"),
              "rk5": ("1.2e-3", "1.8e-4", "2.5e-5", "3.3e-6", "1.1e-6")}
    print(f"edges: beta / alpha {rs}, nu = 2 sqrt(alpha) 0.55-4.5 (tongues 1-4), grid {dnu}")
    out = {}
    cache = {}
    for z in (0.0, 0.002, 0.01):
        for r in rs:
            cache[z, r] = tongue_edges(r, z, 4.5, dnu)
    for method in METHODS:
        for S, q in zip(steps, quoted[method], strict=True):
            best = max(((*edge_excess(r, 0.0, method, S, cache[0.0, r]), r) for r in rs),
                       key=lambda t: t[0])
            out[method, S] = best[0]
            show(f"undamped {method} {S} steps: map - 1", q,
                 f"{best[0]:.1e} (r {best[2]}, nu {best[1]:.3f})")
    for z, S, q in ((0.01, 32, "1.4e-5 (r 0.2, tongue 1)"), (0.01, 64, "1.8e-6"),
                    (0.002, 32, "1.7e-4 (tongue 2)")):
        best = max(((*edge_excess(r, z, "rk4", S, cache[z, r]), r) for r in rs),
                   key=lambda t: t[0])
        out[z, S] = best[0]
        show(f"zeta {z} rk4 {S} steps: map - 1", q,
             f"{best[0]:.1e} (r {best[2]}, nu {best[1]:.3f})" if best[1] else "no edge")
    return out


def close(quick: bool, cases=None) -> dict:
    """The damping at which tongue n closes, over zeta_n and over scipy's zeta_n."""
    if cases is None:
        cases = ([(0.2, 1), (0.2, 2)] if quick else
                 [(r, n) for r in (0.05, 0.1) for n in range(1, 5)]
                 + [(0.2, n) for n in range(1, 7)])
    points, window, iters = (4001, 401, 20) if quick else (40001, 4001, 30)
    print("close: the equation's tongue n closes (largest |mu| over the undamped tongue <= 1 + 1e-6)")
    out = {}
    for r, n in cases:
        z, top = closing_zeta(r, n, points, window, iters)
        if z is None:
            print(f"  r {r} n {n}: undamped tongue not above 1 + 1e-6 on the grid")
            continue
        zn, zs = zeta_n(r, n), zeta_n_scipy(r, n)
        td = float(st.tongue_damping(n * n / 4, r * n * n / 4))
        out[r, n] = {"zeta": z, "zeta_n": zn, "scipy": zs, "tongue_damping": td}
        print(f"  r {r} n {n}: closes at zeta {z:.4e}; zeta_n {zn:.4e} (tongue_damping {td:.4e}), "
              f"ratio {z / zn:.4f}; scipy's width {zs:.4e}, ratio {z / zs:.4f}; "
              f"undamped max mu - 1 {top - 1:.1e}", flush=True)
    ratios = [v["zeta"] / v["zeta_n"] for (r, n), v in out.items() if not (r == 0.05 and n == 4)]
    if ratios:
        show("closing / zeta_n", "0.98-1.006", f"{min(ratios):.3f}-{max(ratios):.3f}")
    dev = [v["scipy"] / v["zeta_n"] - 1 for v in out.values()]
    show("scipy's zeta_n / the formula's - 1", "0-2.1 % below", f"{min(dev):+.3f} to {max(dev):+.3f}")
    if (0.05, 4) in out:
        show("r 0.05, n 4", "0.76", f"{out[0.05, 4]['zeta'] / out[0.05, 4]['zeta_n']:.2f}")
    return out


def above(quick: bool) -> dict:
    """The map's largest |mu| near tongue n at 1.01, 1.1 and 1.5 zeta_n, every step count of
    STEPS that the frozen rule passes."""
    cases = ([(0.2, 1), (0.2, 2)] if quick else
             [(r, n) for r in (0.05, 0.1) for n in range(1, 5)] + [(0.2, n) for n in range(1, 7)])
    steps = (16, 32, 64) if quick else (16, 24, 32, 48, 64, 96, 128, 192, 256)
    points = 2001 if quick else 20001
    print(f"above: the map near tongue n (+- 2 widths) at f zeta_n, steps {steps}")
    worst = -np.inf
    for r, n in cases:
        sel, _ = undamped_tongue(r, n, points)
        if sel.size == 0:
            continue
        w = sel.max() - sel.min()
        nu = np.linspace(sel.min() - 2 * w, sel.max() + 2 * w, points)
        a = nu * nu / 4
        for f in (1.01, 1.1, 1.5):
            g = 2 * f * zeta_n(r, n) * np.sqrt(a)
            for method in METHODS:
                need = frozen_limit(method, a * (1 + r), g)
                for S in steps:
                    ok = S >= need
                    if ok.any():
                        worst = max(worst, float(map_mu(a[ok], r * a[ok], g[ok], S, method).max()))
    show("largest map |mu| - 1 near tongue n above 1.01 zeta_n", "below 1e-6", f"{worst - 1:.1e}")
    return {"worst": worst}


def multi(quick: bool) -> dict:
    """Orders 1, 2 and 3 of equal size (r = 0.2 in all): where tongues 1-4 close."""
    H = ((1 / 3, 1 / 3, 1 / 3), (1, 2, 3), (0.0, 0.7, 1.9))
    r = 0.2
    points, window, iters = (4001, 401, 20) if quick else (40001, 4001, 30)
    print("multi: harmonics of orders 1, 2, 3 of equal size, phases 0, 0.7, 1.9, r = 0.2")
    out = {}
    for n in ((1, 2) if quick else (1, 2, 3, 4)):
        z, _ = closing_zeta(r, n, points, window, iters, harmonics=H)
        out[n] = z
        print(f"  tongue {n}: closes at zeta {z if z is None else f'{z:.4f}'}")
    show("tongues 1-3 close at", "0.016-0.017", " ".join(f"{out[n]:.4f}" for n in out if n <= 3))
    if 4 in out:
        show("tongue 4 closes at", "0.002", f"{out[4]:.4f}")
    show("the rule's bound r / 4", "0.05", f"{float(st.tongue_damping(1.0, r, H)):.3f}")
    return out


def alias(quick: bool) -> dict:
    """h w_n from 0.3 to the frozen limit (where the map's phase error is largest)."""
    steps = (32,) if quick else (32, 64, 128)
    values = 2001 if quick else 20001
    print(f"alias: steps {steps}, r 0.05-0.2, zeta 0-0.05, {values} values of h w_n from 0.3")
    total = 0
    for method in METHODS:
        for S in steps:
            for r in (0.05, 0.1, 0.2):
                for z in (0.0, 0.001, 0.01, 0.05):
                    hw = np.linspace(0.3, 3.5, values)
                    a = (hw * S / (2 * np.pi)) ** 2
                    g = 2 * z * np.sqrt(a)
                    ok = st.check_step(method, S, 2 * np.pi, a * (1 + r), g)[0]
                    total += int(np.count_nonzero(st.map_step_check(
                        a[ok], r * a[ok], g[ok], S, method=method)[0]))
    show("cases beyond the limit", "none", str(total))
    return {"beyond": total}


def _scipy_monodromy(alpha: float, beta: float, gamma: float) -> np.ndarray:
    def f(t, y):
        return [y[1], -gamma * y[1] - (alpha + beta * np.cos(t)) * y[0]]
    return np.column_stack([solve_ivp(f, (0, 2 * np.pi), y0, method="DOP853", rtol=1e-13,
                                      atol=1e-15).y[:, -1] for y0 in ([1.0, 0.0], [0.0, 1.0])])


def _whine_response(steps: int | None) -> float:
    """p_rms [um] of the docs' whine scene (k1 = 1050 of k0 = 1073 kN/mm, c = 256 N s/m, STE
    5 um, 2184.4 rpm): ``None``: scipy's periodic response, (I - M)^-1 b, DOP853 at rtol 1e-11;
    else a run of the study at that many RK5 steps per mesh period, its transient long enough
    for the map's own decay to leave 1e-6."""
    import warnings

    import gearsweep
    k0, k1, m, c, rpm = 1073e6, 1050e6, 0.1527, 256.0, 2184.4
    w = 48 * rpm / 60 * 2 * np.pi
    if steps is None:
        T, kw = 2 * np.pi / w, dict(method="DOP853", rtol=1e-11, atol=1e-18)

        def f(t, y, forced=True):
            g = (833.0 / m + 5e-6 * w * w * np.cos(w * t)) if forced else 0.0
            return [y[1], g - c / m * y[1] - (k0 + k1 * np.cos(w * t)) / m * y[0]]
        M = np.column_stack([solve_ivp(f, (0, T), y0, args=(False,), **kw).y[:, -1]
                             for y0 in ([1.0, 0.0], [0.0, 1.0])])
        x0 = np.linalg.solve(np.eye(2) - M, solve_ivp(f, (0, T), [0.0, 0.0], **kw).y[:, -1])
        p = solve_ivp(f, (0, T), x0, t_eval=np.linspace(0, T, 4001)[:-1], **kw).y[0]
        return float(np.sqrt(np.mean((p - p.mean()) ** 2))) * 1e6
    a, b, g = k0 / (m * w * w), k1 / (m * w * w), c / (m * w)
    mu = float(map_mu(a, b, g, steps, "rk5")[0])
    study = {"title": "w", "outputs": ["stats"], "scene": {
        "kind": "whine", "mass": "0.1527 kg", "teeth": 48, "stiffness": "1073 kN/mm",
        "damping": "256 N*s/m", "mean_force": "833 N",
        "stiffness_harmonics": [{"amplitude": "1050 kN/mm"}], "ste": [{"amplitude": "5 um"}]},
        "sweep": {"speed": [f"{rpm} rpm"]},
        "solver": {"method": "rk5", "steps_per_period": steps, "record_periods": 50,
                   "transient_periods": int(np.log(1e-6) / np.log(mu)) + 1}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(gearsweep.run(study).p_rms.values.ravel()[0])


def resonance(quick: bool) -> dict:
    """The resonance test (``resonance_error``, ``RESONANCE_TOL``): the docs' whine scene, and
    the screen of ``map_step_check`` (the map at S against 2S) against the exact test on random
    forced cases."""
    out = {}
    k0, k1, m, c, w = 1073e6, 1050e6, 0.1527, 256.0, 48 * 2184.4 / 60 * 2 * np.pi
    a, b, g = k0 / (m * w * w), k1 / (m * w * w), c / (m * w)
    print("whine scene at 2184.4 rpm (alpha 58.285, beta / alpha 0.979, zeta 0.0071), RK5")
    Me = _scipy_monodromy(a, b, g)
    show("equation's multipliers (scipy)", "0.97881, 0.39144",
         ", ".join(f"{abs(x):.5f}" for x in sorted(np.linalg.eigvals(Me), key=abs)[::-1]))
    truth = _whine_response(None)
    show("p_rms of the periodic response (scipy)", "224.66 um", f"{truth:.2f} um")
    for S, qe, qr in ((56, "27.3", "28.5"), (64, "0.69", "1.70"), (80, "0.099", "1.10"),
                      (96, "0.024", "1.026"), (128, "0.0020", "1.0024")):
        M = fq.monodromy(a, b, g, S, method="rk5")
        e = float(st.resonance_error(M, Me[None])[0])
        mu = float(fq.largest_multiplier(M)[0])
        ratio = _whine_response(S) / truth if not quick or S in (56, 128) else float("nan")
        show(f"{S} steps: map's |mu|, E, p_rms / truth", f"E {qe}, p_rms x{qr}",
             f"|mu| {mu:.5f}, E {e:.3g}, p_rms x{ratio:.4g}")
    lim = int(st.map_step_limit(a, b, g, 38, method="rk5", forced=True)[0])
    show("map_step_limit from 38 (forced)", "108", str(lim))
    # The screen: random forced cases, every step count from the frozen limit S0 to twice it, and
    # 3, 4, 6 and 8 times it.
    rng = np.random.default_rng(SEED)
    n = 300 if quick else 3000
    for method in METHODS:
        alpha = np.exp(rng.uniform(np.log(0.3), np.log(2000), n))
        r = rng.uniform(0.05, 0.99, n)
        zeta = rng.choice([0.0, 0.001, 0.005, 0.01, 0.05, 0.2], n)
        beta, gamma = r * alpha, 2 * zeta * np.sqrt(alpha)
        Me = fq.floquet(alpha, beta, gamma, method="rk5", rtol=1e-10).monodromy
        stable = ~(fq.floquet(alpha, beta, gamma, method="rk5", rtol=1e-8).multiplier > 1 + TOL)
        s0 = frozen_limit(method, alpha + beta, gamma).astype(int)
        checked = missed = flagged = screened_total = 0
        pairs = [(S, np.flatnonzero((s0 <= S) & (S <= 2 * s0) & stable))
                 for S in range(int(s0.min()), int(2 * s0.max()) + 1)]
        pairs += [(int(f * S0), np.flatnonzero((s0 == S0) & stable))
                  for S0 in np.unique(s0) for f in (3, 4, 6, 8)]
        for S, idx in pairs:
            if not idx.size:
                continue
            M = fq.monodromy(alpha[idx], beta[idx], gamma[idx], S, method=method)
            M2 = fq.monodromy(alpha[idx], beta[idx], gamma[idx], 2 * S, method=method)
            p = fq.ORDER[method]
            est = st.resonance_error(M, M2) * 2.0**p / (2.0**p - 1.0)
            exact = st.resonance_error(M, Me[idx])
            ok = fq.largest_multiplier(M) <= 1 + TOL
            hw = 2 * np.pi * np.sqrt(alpha[idx] + beta[idx]) / S
            screened = ((est <= st.RESONANCE_TOL / st._RESONANCE_SCREEN) & (hw <= st._SCREEN_HW)
                        & (gamma[idx] != 0))
            checked += int(ok.sum())
            flagged += int((ok & (exact > st.RESONANCE_TOL)).sum())
            missed += int((ok & screened & (exact > st.RESONANCE_TOL)).sum())
            screened_total += int((ok & screened).sum())
        out[f"missed_{method}"] = missed
        show(f"{method}: (case, step) pairs whose map decays; resonance flagged; passed by the"
             " screen but flagged exactly", "0 missed",
             f"{checked}; {flagged}; {missed} (screened {screened_total})")
        out[f"screened_{method}"] = screened_total
    return out


SECTIONS = {f.__name__: f for f in (examples, random, weak, edges, close, above, multi, alias,
                                    resonance)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("sections", nargs="*", metavar="SECTION",
                   help=f"any of {', '.join(SECTIONS)} (default: all)")
    p.add_argument("--quick", action="store_true", help="small samples, under a minute")
    args = p.parse_args()
    unknown = set(args.sections) - set(SECTIONS)
    if unknown:
        p.error(f"unknown section(s) {sorted(unknown)}; choose from {', '.join(SECTIONS)}")
    for name in args.sections or SECTIONS:
        t = time.perf_counter()
        SECTIONS[name](args.quick)
        print(f"[{name}: {time.perf_counter() - t:.1f} s]", flush=True)


if __name__ == "__main__":
    main()
