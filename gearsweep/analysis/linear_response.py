"""Steady-state periodic response of the linear mesh equation with time-varying stiffness.

Eq. (9) of the paper (no backlash) is linear with periodic coefficients (a Hill equation with a
periodic right-hand side):

    m p'' + c p' + k(t) p = F(t),
    k(t) = k0 + sum_n k_n cos(n W t + a_n),   F(t) = F0 + sum_n F_n cos(n W t + b_n)

with W the mesh angular frequency and whole orders n. Its periodic solution (it exists and is
unique when the homogeneous equation is asymptotically stable; where that equation is
parametrically unstable, ``periodic_response`` warns, ``UnstableEquationWarning``, for the periodic
solution is then not the steady state) is found by harmonic balance:
writing ``p = sum_{|j| <= J} P_j exp(i j W t)`` turns the equation into the linear system

    (k0 - m (j W)^2 + i c j W) P_j + sum_{n != 0} K_n P_{j-n} = F_j,   |j| <= J,

which is banded and whose solution converges geometrically in ``J`` (the coefficients are
smooth). Unlike time stepping, it has no step-size error: it is the independent reference the
spectra of the batch integrator are tested against. For the STE excitation of Eq. (9),
``-m e''(t)`` gives ``F_n = m (n W)^2 e_n`` with the phase of ``e_n``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from gearsweep.errors import UnstableEquationWarning
from gearsweep.kernels.floquet import floquet

__all__ = ["periodic_response", "ste_force"]


def _two_sided(mean: float, amplitudes: Sequence[float], orders: Sequence[int],
               phases: Sequence[float], size: int, name: str) -> np.ndarray:
    """Exponential Fourier coefficients C_j, j = -size..size, of mean + sum a cos(n theta + ph);
    ``name`` is the argument that gave ``orders`` (for the error)."""
    c = np.zeros(2 * size + 1, dtype=complex)
    c[size] += mean
    for a, order, ph in zip(amplitudes, orders, phases, strict=True):
        if not (float(order).is_integer() and 1 <= order <= size):
            raise ValueError(f"{name}: order {order} is not allowed: orders must be whole"
                             f" numbers 1..{size} (the truncation `harmonics`; the response is"
                             " periodic in the mesh period, fractional orders are not supported)")
        n = int(order)
        c[size + n] += 0.5 * a * np.exp(1j * ph)
        c[size - n] += 0.5 * a * np.exp(-1j * ph)
    return c


def _same_lengths(func: str, *named: tuple[str, int | None]) -> None:
    """ValueError naming the arguments of ``func`` and their lengths unless all the given
    (``None``: not given) lengths agree: one order (and phase) per amplitude. Mismatched ones
    raised numpy's broadcast message or zip()'s, naming no argument."""
    given = [(name, n) for name, n in named if n is not None]
    if len({n for _, n in given}) > 1:
        names = [name for name, _ in given]
        lengths = ", ".join(f"{name} {n}" for name, n in given)
        raise ValueError(f"{func}: {', '.join(names[:-1])} and {names[-1]} must have the same"
                         f" length (one order{' and phase' if len(names) > 2 else ''} per"
                         f" amplitude); got {lengths}")


def _length(values) -> int | None:
    """len of a sequence argument (``None`` for ``None``; a 0-d value counts as 1)."""
    if values is None:
        return None
    return 1 if np.ndim(values) == 0 else len(values)


def ste_force(mass: float, omega: np.ndarray, amplitudes: Sequence[float],
              orders: Sequence[int]) -> np.ndarray:
    """Amplitudes of the STE force ``-m e''`` of Eq. (9): ``m (n W)^2 e_n`` [N].

    Parameters
    ----------
    mass : float
        Equivalent mass m_eq [kg].
    omega : ndarray (s,)
        Mesh angular frequency W [rad/s].
    amplitudes, orders :
        STE harmonics e_n [m] and their integer mesh orders n [-].

    Returns
    -------
    ndarray (s, len(amplitudes)) [N]
    """
    _same_lengths("ste_force", ("amplitudes", _length(amplitudes)), ("orders", _length(orders)))
    w = np.asarray(omega, dtype=float)[:, None]
    n = np.asarray(orders, dtype=float)[None, :]
    return mass * (n * w) ** 2 * np.asarray(amplitudes, dtype=float)[None, :]


def periodic_response(
    mass: float,
    damping: float,
    stiffness: float,
    omega: np.ndarray,
    *,
    k_amplitudes: Sequence[float] = (),
    k_orders: Sequence[int] = (),
    k_phases: Sequence[float] | None = None,
    mean_force: float = 0.0,
    f_amplitudes: np.ndarray | Sequence[float] = (),
    f_orders: Sequence[int] = (),
    f_phases: Sequence[float] | None = None,
    harmonics: int = 40,
) -> np.ndarray:
    """Single-sided Fourier coefficients of the periodic response by harmonic balance.

    Parameters
    ----------
    mass : float
        m [kg].
    damping : float
        c [N s/m].
    stiffness : float
        Mean stiffness k0 [N/m].
    omega : ndarray (s,)
        Mesh angular frequencies W [rad/s], one response per value.
    k_amplitudes, k_orders, k_phases :
        Stiffness harmonics k_n [N/m], whole orders n (1..``harmonics``; a fractional or out
        of range one is refused, ValueError naming it), phases a_n [rad] (default 0); of one
        length (else ValueError naming them and their lengths).
    mean_force : float
        F0 [N].
    f_amplitudes : array_like (m,) or (s, m)
        Force harmonics F_n [N], the same for every W or one row per W (e.g. ``ste_force``).
    f_orders, f_phases :
        Their whole orders (as ``k_orders``) and phases b_n [rad] (default 0), one per
        amplitude (per column of a 2-D ``f_amplitudes``; else ValueError as ``k_orders``).
    harmonics : int
        Truncation J [-]; the response is returned for orders 0..J.

    Returns
    -------
    ndarray complex (s, J + 1)
        ``c_j`` with ``p(t) = sum_j Re(c_j exp(i j W t))`` [m]: ``|c_j|`` is the amplitude of
        mesh order j, ``c_0`` the mean.

    Warns
    -----
    UnstableEquationWarning
        Where the homogeneous equation is parametrically unstable (its converged largest Floquet
        multiplier, ``kernels.floquet.floquet``, above 1 + ``UNSTABLE_TOL``): the solution
        returned there is periodic but not the steady state.
    """
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    J = int(harmonics)
    fa = np.asarray(f_amplitudes, dtype=float)
    if fa.ndim > 2:
        raise ValueError(f"periodic_response: f_amplitudes has {fa.ndim} dimensions (shape"
                         f" {fa.shape}); allowed: (m,) or (s, m), s the {w.size} values of omega")
    if fa.ndim == 2 and fa.shape[0] not in (1, w.size):
        raise ValueError(f"periodic_response: f_amplitudes has {fa.shape[0]} rows and omega"
                         f" {w.size} values; allowed: one row per value of omega, or a 1-D array")
    _same_lengths("periodic_response", ("k_amplitudes", _length(k_amplitudes)),
                  ("k_orders", _length(k_orders)), ("k_phases", _length(k_phases)))
    _same_lengths("periodic_response",  # (a scalar F_n is every order's, as numpy broadcasts)
                  ("f_amplitudes" if fa.ndim < 2 else "f_amplitudes' columns",
                   int(fa.shape[-1]) if fa.ndim else None),
                  ("f_orders", _length(f_orders)), ("f_phases", _length(f_phases)))
    k_phases = np.zeros(len(k_orders)) if k_phases is None else k_phases
    f_phases = np.zeros(len(f_orders)) if f_phases is None else f_phases
    kc = _two_sided(0.0, k_amplitudes, k_orders, k_phases, J, "k_orders")
    fa = np.broadcast_to(fa, (w.size, len(f_orders)))
    j = np.arange(-J, J + 1)
    # Convolution matrix of the stiffness harmonics: A[r, s] = K_{j_r - j_s}.
    diff = j[:, None] - j[None, :]
    conv = np.where(np.abs(diff) <= J, kc[np.clip(diff + J, 0, 2 * J)], 0.0)
    a = np.broadcast_to(conv, (w.size, 2 * J + 1, 2 * J + 1)).copy()
    diag = stiffness - mass * (j[None, :] * w[:, None]) ** 2 + 1j * damping * j[None, :] * w[:, None]
    idx = np.arange(2 * J + 1)
    a[:, idx, idx] += diag
    rhs = np.stack([_two_sided(mean_force, fa[i], f_orders, f_phases, J, "f_orders")
                    for i in range(w.size)])
    p = np.linalg.solve(a, rhs[..., None])[..., 0]
    out = p[:, J:].copy()
    out[:, 1:] *= 2.0  # single-sided: c_j = 2 P_j for j > 0 (P_{-j} = conj(P_j))
    if np.any(np.asarray(k_amplitudes, dtype=float) != 0.0):
        _warn_if_unstable(mass, damping, stiffness, w, (k_amplitudes, k_orders, k_phases))
    return out


def _warn_if_unstable(mass: float, damping: float, stiffness: float, w: np.ndarray,
                      harmonics) -> None:
    """``UnstableEquationWarning`` naming the mesh frequencies where the homogeneous equation's
    converged largest Floquet multiplier (``kernels.floquet.floquet``, per mesh period, in the
    Mathieu time W t) is unstable."""
    scale = 1.0 / (mass * w**2)
    fl = floquet(stiffness * scale, scale, damping / (mass * w), harmonics=harmonics)
    bad = np.flatnonzero(fl.unstable)
    if bad.size:
        worst = bad[np.argmax(fl.multiplier[bad])]
        warnings.warn(
            f"periodic_response: the homogeneous equation is parametrically unstable at"
            f" {bad.size} of {w.size} mesh frequencies (largest Floquet multiplier per mesh"
            f" period {fl.multiplier[worst]:.4g} at {w[worst] / (2.0 * np.pi):.6g} Hz): the"
            " periodic solution returned there is not the steady state (any perturbation of it"
            " grows)", UnstableEquationWarning, stacklevel=3)
