"""Floquet multipliers of the homogeneous Hill / damped Mathieu equation, in batch.

In the Mathieu time tau = N w t (mesh period 2 pi, unit mass), Eq. (11) of the paper reads

    p'' + gamma p' + (alpha + beta s(tau)) p = 0,     s(tau) = cos tau  (Mathieu)
                                                       s(tau) = sum_n r_n cos(n tau + a_n)  (Hill)

with alpha = k0 / (m (N w)^2), beta = k1 / (m (N w)^2), gamma = c / (m N w) (Eq. 12;
``mathieu_parameters``) and, for the Hill equation, r_n = k_n / k1 with whole orders n (a
fractional order is refused, ValueError: s(tau) would not have the period 2 pi; a study analyses
one over the common period of its orders, ``model.hill_parameters``, and reports |mu|^(1/P) per
mesh period). The monodromy matrix M maps (p, p') at tau = 0 to tau = 2 pi; its eigenvalues
mu_1, mu_2 are the Floquet multipliers, mu_1 mu_2 = det M = exp(-2 pi gamma) (Liouville), and the
equation is unstable when the largest |mu| exceeds 1 (for gamma > 0: |tr M| > 1 + det M).

M is computed with the batch kernel ``simulate``: two lanes per case start from (1, 0) and (0, 1),
run ``steps_per_period`` steps with no force and no backlash, and their end states are the
columns of M. ``floquet`` doubles the step count of every case until the largest |mu| has
converged (only the cases not yet converged are run again) and stores the Richardson error
estimate |mu_S - mu_{S/2}| / (2^p - 1) of the finest value (p = order of the method).

Since time is rescaled exactly, a case given in SI units (k/m, c/m, mesh period T) has the same
multipliers as its Mathieu form, and a fixed-step map with S steps per mesh period is the same
map in both: h omega = (2 pi / S) sqrt(alpha) = (T / S) sqrt(k/m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearsweep.errors import GearsweepError
from gearsweep.kernels import rk, tableaux
from gearsweep.kernels.batch import simulate
from gearsweep.kernels.tables import fourier_table

__all__ = [
    "FloquetResult",
    "floquet",
    "largest_multiplier",
    "mathieu_parameters",
    "monodromy",
    "paper_criterion",
    "whole_orders",
]

ORDER = {m: tableaux.get(m).order for m in tableaux.KERNEL_METHODS}
"""Order of each kernel method (``gearsweep.kernels.tableaux``), for the Richardson estimate."""
MATHIEU = ((1.0,), (1,), (0.0,))
"""Harmonics (relative amplitudes, orders, phases [rad]) of s(tau) for the Mathieu equation."""


def mathieu_parameters(k0, k1, m, c, mesh_frequency):
    """alpha, beta, gamma of Eq. (12).

    Parameters
    ----------
    k0, k1 : array_like
        Mean and first-harmonic mesh stiffness [N/m].
    m : array_like
        Equivalent mass m_eq [kg].
    c : array_like
        Mesh viscous damping [N s/m].
    mesh_frequency : array_like
        Tooth-mesh frequency N w / (2 pi) [Hz].

    Returns
    -------
    alpha, beta, gamma : ndarray [-]
    """
    Nw = 2.0 * np.pi * np.asarray(mesh_frequency, dtype=float)
    m = np.asarray(m, dtype=float)
    return (np.asarray(k0, float) / (m * Nw**2), np.asarray(k1, float) / (m * Nw**2),
            np.asarray(c, float) / (m * Nw))


def whole_orders(harmonics) -> tuple:
    """``harmonics`` (amplitudes, orders, phases) of s(tau), ``MATHIEU`` for None, its orders
    checked to be whole: a monodromy over the period 2 pi of tau is one of the equation only
    then (an outside tester: order 1.5 gave a multiplier 1.6016 where the equation's, per 2 pi
    over its true period 4 pi, is 1.0000).

    Raises
    ------
    ValueError
        Naming a fractional order and the way to analyse it.
    """
    amps, orders, phases = harmonics if harmonics is not None else MATHIEU
    for order in np.atleast_1d(np.asarray(orders, dtype=float)):
        if not float(order).is_integer():
            raise ValueError(
                f"harmonics: order {float(order):g} is not a whole number: the orders are per"
                " period 2 pi of tau, over which the monodromy is taken. A fractional order is"
                " analysed over the common period of P periods (orders 0.5 and 1: P = 2) with"
                " orders x P, alpha and beta x P^2, gamma x P, and |mu|^(1/P) per period, as a"
                " study does (model.hill_parameters)")
    return amps, orders, phases


def _shape_table(harmonics, steps_per_period: int) -> np.ndarray:
    return fourier_table(*whole_orders(harmonics), steps_per_period)


def monodromy(alpha, beta, gamma, steps_per_period: int, *, method: str = "rk5",
              harmonics=None) -> np.ndarray:
    """Monodromy matrices of the fixed-step map with ``steps_per_period`` steps, shape (n, 2, 2).

    Parameters
    ----------
    alpha, beta, gamma : array_like (broadcast to n)
        Mean stiffness, stiffness-variation scale and damping in Mathieu time [-].
    steps_per_period : int
        Steps per period 2 pi.
    method : {"rk4", "rk5"}
    harmonics : (amplitudes, orders, phases), optional
        Shape s(tau) of the stiffness variation, scaled by ``beta``; default cos tau. Orders
        whole (per period 2 pi; ValueError naming a fractional one).

    Returns
    -------
    ndarray (n, 2, 2)
        ``M[:, :, 0]`` = (p, p') at 2 pi from (1, 0), ``M[:, :, 1]`` from (0, 1); NaN where the
        map overflowed.
    """
    call = monodromy_call(alpha, beta, gamma, steps_per_period, method=method,
                          harmonics=harmonics)
    n = call["x0"].size // 2
    res = simulate(**call)
    M = np.empty((n, 2, 2))
    M[:, 0, :] = res.x_final.reshape(n, 2)
    M[:, 1, :] = res.v_final.reshape(n, 2)
    return M


def monodromy_call(alpha, beta, gamma, steps_per_period: int, *, method: str = "rk5",
                   harmonics=None) -> dict:
    """The keyword arguments of ``monodromy``'s kernel call (``simulate``): two lanes per case,
    started from (1, 0) and (0, 1), integrated over one period."""
    a, b, g = (np.ravel(x) for x in np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(gamma, float)))
    n = a.size
    S = int(steps_per_period)
    two = lambda x: np.repeat(x, 2)  # noqa: E731  lanes 2i, 2i+1 belong to case i
    return dict(h=np.full(2 * n, 2.0 * np.pi / S), method=method, damping=two(g), k_mean=two(a),
                k_scale=two(b), k_table=_shape_table(harmonics, S), x0=np.tile([1.0, 0.0], n),
                v0=np.tile([0.0, 1.0], n), n_transient=S, n_record=0, steps_per_period=S)


def largest_multiplier(M: np.ndarray) -> np.ndarray:
    """Largest |mu| of 2x2 matrices (n, 2, 2), from trace and determinant; ``inf`` for NaN input."""
    with np.errstate(invalid="ignore", over="ignore"):
        tr = M[:, 0, 0] + M[:, 1, 1]
        det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
        disc = 0.25 * tr * tr - det
        real = 0.5 * np.abs(tr) + np.sqrt(np.maximum(disc, 0.0))
        cplx = np.sqrt(np.abs(det))
    mu = np.where(disc >= 0, real, cplx)
    return np.where(np.isfinite(mu), mu, np.inf)


@dataclass(frozen=True)
class FloquetResult:
    """Converged Floquet analysis of a batch of cases (arrays of length n)."""

    multiplier: np.ndarray
    """Largest |mu| of the monodromy matrix at the finest step, per period 2 pi of tau [-]."""
    error: np.ndarray
    """Estimated absolute error of ``multiplier`` (Richardson) [-]."""
    steps_per_period: np.ndarray
    """Steps per period of the finest integration (int)."""
    converged: np.ndarray
    """``error <= atol + rtol * multiplier`` was reached before ``spp_max``."""
    monodromy: np.ndarray
    """Monodromy matrices at the finest step, shape (n, 2, 2)."""
    tol: float
    """Threshold of ``unstable``: multiplier > 1 + tol."""

    @property
    def unstable(self) -> np.ndarray:
        """The equation is unstable: largest |mu| > 1 + tol."""
        return self.multiplier > 1.0 + self.tol


UNSTABLE_TOL = 1e-6
"""A multiplier counts as > 1 above 1 + UNSTABLE_TOL: ``floquet``'s ``unstable``, the floquet
output's ``unstable`` and ``integrator_unstable`` (their ``threshold`` attribute)."""

HW0, SPP_MIN, SPP_MAX = 0.5, 16, 2**16
"""``floquet``'s defaults: the first step count resolves the stiffest frozen pole with
h |lambda| <= HW0, and lies within SPP_MIN .. SPP_MAX (``initial_steps``)."""


def initial_steps(a, b, g, harmonics) -> np.ndarray:
    """The steps per period ``floquet`` starts from with its defaults (what a study's estimate
    counts)."""
    return np.minimum(_initial_spp(a, b, g, harmonics, HW0, SPP_MIN), SPP_MAX)


def _initial_spp(a, b, g, harmonics, hw0: float, spp_min: int) -> np.ndarray:
    amps = np.atleast_1d((harmonics if harmonics is not None else MATHIEU)[0])
    kmax = np.abs(a) + np.abs(b) * np.sum(np.abs(amps))
    lam = np.sqrt(kmax) + np.abs(g)  # bound on the frozen pole magnitude
    need = np.maximum(2.0 * np.pi * lam / hw0, spp_min)
    return (2 ** np.ceil(np.log2(need))).astype(np.int64)


def floquet(alpha, beta, gamma=0.0, *, method: str = "rk5", rtol: float = 1e-9,
            atol: float = 1e-12, spp_min: int = SPP_MIN, spp_max: int = SPP_MAX, hw0: float = HW0,
            tol: float = UNSTABLE_TOL, harmonics=None) -> FloquetResult:
    """Largest Floquet multiplier of every case, the step refined until it has converged.

    Parameters
    ----------
    alpha, beta, gamma : array_like (broadcast to one shape)
        Mathieu parameters [-] (time in units of mesh period / 2 pi).
    method : {"rk4", "rk5"}
    rtol, atol : float
        Converged when the Richardson error estimate <= atol + rtol * multiplier.
    spp_min, spp_max : int
        Fewest and most steps per period.
    hw0 : float
        The first step count resolves the stiffest frozen pole with h |lambda| <= hw0.
    tol : float
        ``unstable`` threshold: multiplier > 1 + tol.
    harmonics : (amplitudes, orders, phases), optional
        Shape of the stiffness variation (default cos tau); whole orders only, per period 2 pi
        (ValueError naming a fractional one: see the module's docstring).

    Returns
    -------
    FloquetResult
        Arrays of the broadcast shape of the inputs (``monodromy``: that shape + (2, 2)).
    """
    if method not in ORDER:

        raise GearsweepError(f"method must be one of {sorted(ORDER)}, got {method!r}")
    arrs = np.broadcast_arrays(np.asarray(alpha, float), np.asarray(beta, float),
                               np.asarray(gamma, float))
    shape = arrs[0].shape
    a, b, g = (np.ravel(x) for x in arrs)
    n = a.size
    spp = _initial_spp(a, b, g, harmonics, hw0, spp_min)
    spp = np.minimum(spp, spp_max)
    mu = np.full(n, np.nan)
    err = np.full(n, np.inf)
    conv = np.zeros(n, bool)
    M = np.full((n, 2, 2), np.nan)
    prev = np.full(n, np.nan)
    active = np.ones(n, bool)
    factor = 2.0 ** ORDER[method] - 1.0
    while active.any():
        S = int(spp[active].min())
        idx = np.flatnonzero(active & (spp == S))
        Mi = monodromy(a[idx], b[idx], g[idx], S, method=method, harmonics=harmonics)
        mi = largest_multiplier(Mi)
        p = prev[idx]
        with np.errstate(invalid="ignore"):
            e = np.where(np.isnan(p), np.inf,
                         np.where(np.isinf(mi) & np.isinf(p), 0.0, np.abs(mi - p) / factor))
        e = np.where(np.isnan(e), np.inf, e)
        ok = e <= atol + rtol * np.where(np.isfinite(mi), mi, 0.0)
        ok |= np.isinf(mi) & np.isinf(p)
        M[idx], mu[idx], err[idx], conv[idx] = Mi, mi, e, ok
        prev[idx] = mi
        stop = ok | (S >= spp_max)
        active[idx[stop]] = False
        spp[idx[~stop]] = 2 * S
    return FloquetResult(
        multiplier=mu.reshape(shape),
        error=err.reshape(shape),
        steps_per_period=spp.reshape(shape),
        converged=conv.reshape(shape),
        monodromy=M.reshape(shape + (2, 2)),
        tol=tol,
    )


def paper_criterion(alpha, beta, gamma, steps_per_period: int, *, method: str = "rk5",
                    n_periods: int = 100, perturbation: float = 1e-6, threshold: float = 1e3,
                    harmonics=None) -> np.ndarray:
    """The paper's test: integrate from a small perturbation and call growth instability.

    Integrates the homogeneous equation with the fixed step 2 pi / ``steps_per_period`` for
    ``n_periods`` mesh periods from p = p' = ``perturbation`` and flags a case whose |p| exceeds
    ``threshold * perturbation`` (or overflows) at the end of any period (the kernel's divergence
    check with ``bound``).

    Parameters
    ----------
    alpha, beta, gamma : array_like
        Mathieu parameters [-].
    steps_per_period : int
        The fixed step, per mesh period.
    method : {"rk4", "rk5"}
    n_periods : int
        Mesh periods integrated.
    perturbation : float
        Initial p and p' [-] (the equation is linear: only the ratio to ``threshold`` matters).
    threshold : float
        Growth factor that counts as "without bound".
    harmonics : optional
        Shape of the stiffness variation (default cos tau); whole orders only (ValueError).

    Returns
    -------
    ndarray of bool
        True where the integration reports instability.
    """
    arrs = np.broadcast_arrays(np.asarray(alpha, float), np.asarray(beta, float),
                               np.asarray(gamma, float))
    shape = arrs[0].shape
    a, b, g = (np.ravel(x) for x in arrs)
    S = int(steps_per_period)
    res = simulate(
        np.full(a.size, 2.0 * np.pi / S),
        method=method,
        damping=g,
        k_mean=a,
        k_scale=b,
        k_table=_shape_table(harmonics, S),
        bound=threshold * perturbation,
        x0=perturbation,
        v0=perturbation,
        n_transient=S * int(n_periods),
        n_record=0,
        steps_per_period=S,
    )
    return (res.status == rk.STATUS_DIVERGED).reshape(shape)
