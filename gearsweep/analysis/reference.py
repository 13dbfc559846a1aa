"""Reference solutions of the 1-DOF model that do not share the fixed-step kernel's errors.

Two independent references for a ``gearsweep.model.Scene``:

``reference_ivp``
    scipy ``solve_ivp`` with DOP853 (rtol 1e-12, atol 1e-12 times the response scale). The
    backlash boundaries p = +-b are events: the integration stops at each crossing and restarts
    from the crossing state with the force law of the new region, so no step straddles a kink and
    within each segment the right-hand side is analytic (the integrator's stages never see the
    other branch of the dead zone).
``reference_exact``
    For constant stiffness and forcing made of a constant and harmonics: the closed-form solution
    in each region, where the equation is linear with constant coefficients. In contact
    (p > b or p < -b) it is a damped oscillator about a shifted equilibrium, y = p -+ b,
    ``y'' + c y' + K y = G(t)``; in the gap it is free motion ``p'' + c p' = G(t)``. Each region's
    solution is the particular solution (complex amplitudes per harmonic) plus the homogeneous
    solution through the 2x2 matrix exponential in closed form; crossings are found by scanning
    the closed form on a fine grid (with a check for touch-and-return between grid points) and
    ``brentq`` on it.

Both return a ``PiecewiseSolution``: callable on times, giving p [m] and p' [m/s].
A crossing that both enters and leaves a region within one accepted DOP853 step (grazing) is
missed by the event search of ``reference_ivp``; at rtol 1e-12 the steps are short, and the
exact solution's grid scan guards against it explicitly.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gearsweep.model import Scene

CONTACT, GAP, BACK = 1, 0, -1
"""Regions: drive-side contact p > b, gap |p| < b, back-side contact p < -b."""


def _region(x: float, v: float, b: float | None) -> int:
    if b is None:
        return CONTACT
    if x > b or (x == b and v >= 0):
        return CONTACT
    if x < -b or (x == -b and v <= 0):
        return BACK
    return GAP


def _shift(region: int, b: float | None) -> float:
    """Offset s of the linear force law f(p) = p - s in a contact region."""
    if b is None:
        return 0.0
    return b if region == CONTACT else -b


@dataclass
class PiecewiseSolution:
    """A solution made of segments, each valid on [t0, t1] and smooth inside.

    Attributes
    ----------
    breaks : list of float
        Segment start times [s], then the end time.
    regions : list of int
        Region of each segment (``CONTACT``, ``GAP``, ``BACK``).
    pieces : list of callable
        ``piece(t) -> (p [m], p' [m/s])`` for times inside the segment.
    """

    breaks: list[float] = field(default_factory=list)
    regions: list[int] = field(default_factory=list)
    pieces: list = field(default_factory=list)

    @property
    def crossings(self) -> np.ndarray:
        """Times of the backlash crossings [s]."""
        return np.asarray(self.breaks[1:-1])

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray]:
        """p [m] and p' [m/s] at times ``t`` [s] (within the integrated interval)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        x = np.full(t.shape, np.nan)
        v = np.full(t.shape, np.nan)
        idx = np.searchsorted(np.asarray(self.breaks), t, side="right") - 1
        idx = np.clip(idx, 0, len(self.pieces) - 1)
        for k in np.unique(idx):
            sel = idx == k
            x[sel], v[sel] = self.pieces[k](t[sel])
        return x, v


# --------------------------------------------------------------------------- adaptive reference


def reference_ivp(
    scene: Scene,
    t_end: float,
    x0: float = 0.0,
    v0: float = 0.0,
    *,
    rtol: float = 1e-12,
    atol_scale: float = 1e-12,
    method: str = "DOP853",
) -> PiecewiseSolution:
    """Adaptive high-order solution with the backlash crossings as events.

    Parameters
    ----------
    scene : Scene
        The case.
    t_end : float
        End time [s] (starts at t = 0).
    x0, v0 : float
        Initial p [m] and p' [m/s].
    rtol : float
        Relative tolerance of ``solve_ivp``.
    atol_scale : float
        Absolute tolerance relative to the response: ``atol = atol_scale * scale`` for p and
        ``atol_scale * scale * omega_n`` for p', with ``scale = scene.response_scale()``.
    method : str
        ``solve_ivp`` method (dense output of DOP853 is 7th order).

    Returns
    -------
    PiecewiseSolution
    """
    from scipy.integrate import solve_ivp  # heavy: loaded only where a reference is computed

    b = scene.half_gap
    scale = scene.response_scale()
    wn = max(scene.omega_n, scene.omega)
    atol = np.array([atol_scale * scale, atol_scale * scale * wn])
    cm = scene.damping
    k_harm = [(a, r * scene.omega, ph) for a, r, ph in scene.k_harmonics]
    g_harm = [(a, r * scene.omega, ph) for a, r, ph in scene.g_harmonics]

    def rhs_factory(region: int):
        s = _shift(region, b)
        spring = region != GAP

        def rhs(t, y):
            g = scene.g_mean
            for a, w, ph in g_harm:
                g += a * np.cos(w * t + ph)
            acc = g - cm * y[1]
            if spring:
                k = scene.k_mean
                for a, w, ph in k_harm:
                    k += a * np.cos(w * t + ph)
                acc -= k * (y[0] - s)
            return np.array([y[1], acc])

        return rhs

    def events_for(region: int):
        if b is None:
            return []
        evs = []
        if region == CONTACT:
            e = (lambda t, y: y[0] - b), -1
            evs.append(e)
        elif region == BACK:
            evs.append(((lambda t, y: y[0] + b), +1))
        else:
            evs.append(((lambda t, y: y[0] - b), +1))
            evs.append(((lambda t, y: y[0] + b), -1))
        out = []
        for fun, direction in evs:
            fun.terminal = True
            fun.direction = direction
            out.append(fun)
        return out

    sol = PiecewiseSolution()
    t0, y0 = 0.0, np.array([x0, v0], dtype=float)
    region = _region(x0, v0, b)
    for _ in range(10_000_000):
        r = solve_ivp(rhs_factory(region), (t0, t_end), y0, method=method, rtol=rtol, atol=atol,
                      dense_output=True, events=events_for(region))
        if r.status < 0:
            raise RuntimeError(f"solve_ivp failed: {r.message}")
        sol.breaks.append(t0)
        sol.regions.append(region)
        sol.pieces.append(_dense(r.sol))
        if r.status == 0:
            break
        # A terminal event: restart in the region entered.
        t0 = float(r.t[-1])
        y0 = r.y[:, -1].copy()
        if region == CONTACT:
            region, y0[0] = GAP, b
        elif region == BACK:
            region, y0[0] = GAP, -b
        elif len(r.t_events[0]):
            region, y0[0] = CONTACT, b
        else:
            region, y0[0] = BACK, -b
    sol.breaks.append(t_end)
    return sol


def _dense(ode_solution):
    def piece(t):
        y = ode_solution(t)
        return y[0], y[1]

    return piece


# --------------------------------------------------------------------------- exact solution


class _LinearRegion:
    """Closed-form solution of y'' + c y' + K y = g0 + sum_j a_j cos(w_j t + ph_j), K >= 0."""

    def __init__(self, c: float, K: float, g0: float, harm) -> None:
        self.c, self.K, self.g0 = c, K, g0
        self.harm = []
        for a, w, ph in harm:
            den = complex(K - w * w, c * w)
            if den == 0:
                raise ValueError("undamped resonance: no periodic particular solution")
            self.harm.append((w, a * np.exp(1j * ph) / den))
        if K == 0 and c == 0 and g0 != 0:
            raise NotImplementedError("free motion without damping under a mean force")
        s = -0.5 * c
        q2 = 0.25 * c * c - K
        self.s, self.q2 = s, q2

    def particular(self, t):
        t = np.asarray(t, dtype=float)
        c, K, g0 = self.c, self.K, self.g0
        if K > 0:
            y = np.full_like(t, g0 / K)
            v = np.zeros_like(t)
        else:
            y = g0 * t / c
            v = np.full_like(t, g0 / c)
        for w, Y in self.harm:
            e = np.exp(1j * w * t)
            y = y + (Y * e).real
            v = v + (1j * w * Y * e).real
        return y, v

    def propagate(self, tau, y0, v0):
        """Homogeneous solution after time ``tau`` from (y0, v0): exp(A tau) (y0, v0)."""
        tau = np.asarray(tau, dtype=float)
        s, q2, c, K = self.s, self.q2, self.c, self.K
        if q2 < 0:
            wd = np.sqrt(-q2)
            es = np.exp(s * tau)
            ch = es * np.cos(wd * tau)
            sh = es * np.sin(wd * tau) / wd
        elif q2 == 0:
            es = np.exp(s * tau)
            ch = es
            sh = es * tau
        else:
            q = np.sqrt(q2)
            e_minus = np.exp((s - q) * tau)
            ch = 0.5 * (np.exp((s + q) * tau) + e_minus)
            sh = e_minus * np.expm1(2.0 * q * tau) / (2.0 * q)
        # exp(A tau) = ch I + sh (A - s I), A - s I = [[c/2, 1], [-K, -c/2]]
        y = ch * y0 + sh * (0.5 * c * y0 + v0)
        v = ch * v0 + sh * (-K * y0 - 0.5 * c * v0)
        return y, v


def reference_exact(
    scene: Scene,
    t_end: float,
    x0: float = 0.0,
    v0: float = 0.0,
    *,
    samples_per_period: int = 256,
) -> PiecewiseSolution:
    """Exact piecewise-analytic solution for constant stiffness and harmonic forcing.

    Parameters
    ----------
    scene : Scene
        The case; ``scene.k_harmonics`` must be empty.
    t_end : float
        End time [s].
    x0, v0 : float
        Initial p [m] and p' [m/s].
    samples_per_period : int
        Grid on which crossings are searched, per period of the fastest of: the contact natural
        frequency, the damping rate and the forcing harmonics. Between grid points a
        touch-and-return is caught by a sign change of the velocity towards the boundary.

    Returns
    -------
    PiecewiseSolution
    """
    if scene.k_harmonics:
        raise ValueError("the exact solution needs constant stiffness (no k_harmonics)")
    b = scene.half_gap
    harm = [(a, r * scene.omega, ph) for a, r, ph in scene.g_harmonics]
    w_fast = max([np.sqrt(scene.k_mean), scene.damping] + [abs(w) for _, w, _ in harm])
    dtau = 2.0 * np.pi / w_fast / samples_per_period
    models = {
        CONTACT: _LinearRegion(scene.damping, scene.k_mean, scene.g_mean, harm),
        BACK: _LinearRegion(scene.damping, scene.k_mean, scene.g_mean, harm),
        GAP: _LinearRegion(scene.damping, 0.0, scene.g_mean, harm),
    }

    def piece_for(region: int, t0: float, X0: float, V0: float):
        model = models[region]
        shift = _shift(region, b) if region != GAP else 0.0
        yp0, vp0 = model.particular(t0)
        dy, dv = X0 - shift - yp0, V0 - vp0

        def piece(t):
            yp, vp = model.particular(t)
            yh, vh = model.propagate(np.asarray(t) - t0, dy, dv)
            return yp + yh + shift, vp + vh

        return piece

    sol = PiecewiseSolution()
    t0 = 0.0
    X, V = float(x0), float(v0)
    region = _region(X, V, b)
    while True:
        piece = piece_for(region, t0, X, V)
        sol.breaks.append(t0)
        sol.regions.append(region)
        sol.pieces.append(piece)
        if b is None:
            break
        hit = _first_crossing(piece, region, b, t0, t_end, dtau)
        if hit is None:
            break
        tc, bd = hit
        xc, vc = piece(np.array([tc]))
        t0, X, V = tc, bd, float(vc[0])
        if region == GAP:
            region = CONTACT if bd > 0 else BACK
        else:
            region = GAP
    sol.breaks.append(t_end)
    return sol


def _first_crossing(piece, region: int, b: float, t0: float, t_end: float, dtau: float):
    """First time in (t0, t_end] at which the solution leaves ``region``; (time, boundary)."""
    from scipy.optimize import brentq  # heavy: loaded only where a reference is computed

    bounds = {CONTACT: [(b, 1.0)], BACK: [(-b, -1.0)], GAP: [(b, -1.0), (-b, 1.0)]}[region]
    chunk = 512
    ta = t0
    while ta < t_end:
        t = ta + dtau * np.arange(chunk + 1)
        t[t > t_end] = t_end
        x, v = piece(t)
        best = None
        for bd, sigma in bounds:
            g = sigma * (x - bd)  # > 0 inside the region
            gv = sigma * v
            out = np.nonzero(g[1:] < 0)[0]
            first = out[0] if len(out) else len(g) - 1
            # touch-and-return between grid points before the first sign change:
            # moving towards the boundary at one node, away at the next
            turn = np.nonzero((gv[:-1] < 0) & (gv[1:] > 0))[0]
            turn = turn[turn < first]
            cand = None
            for k in turn:
                tm = brentq(lambda s, bd=bd, sigma=sigma: sigma * piece(np.array([s]))[1][0],
                            t[k], t[k + 1], xtol=1e-300, rtol=1e-15)
                if sigma * (piece(np.array([tm]))[0][0] - bd) < 0:
                    cand = (t[k], tm)
                    break
            if cand is None and len(out):
                cand = (t[first], t[first + 1])
            if cand is not None:
                lo, hi = cand
                if lo == t0:
                    # leaving at the very start only if moving outwards: skip the start point
                    lo = t0
                f = lambda s, bd=bd, sigma=sigma: sigma * (piece(np.array([s]))[0][0] - bd)  # noqa: E731
                flo = f(lo)
                if flo <= 0 and lo == t0:
                    # starting on the boundary (just entered): search beyond the start
                    lo = lo + 1e-9 * dtau
                    if f(lo) <= 0:
                        continue
                tc = brentq(f, lo, hi, xtol=1e-300, rtol=1e-15)
                if best is None or tc < best[0]:
                    best = (tc, bd)
        if best is not None:
            return best
        if t[-1] >= t_end:
            return None
        ta = t[-1]
    return None
