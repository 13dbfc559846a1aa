"""Butcher tableaux: the one home of every Runge-Kutta method's coefficients.

Each explicit method is given exactly, in fractions: the strictly lower rows of A, the weights b,
the nodes c (= row sums of A), its order and its number of stages. Everything else that is a fact
of a method is derived here from the tableau, never typed in again:

* ``stability_polynomial``: R(z) = 1 + z b^T (I - z A)^-1 1 = 1 + sum_k (b^T A^k 1) z^(k+1), exact
  (A is nilpotent, so the Neumann series stops after s terms);
* ``real_stability_interval``: the largest x with |R(-x')| <= 1 for all 0 < x' <= x (a real,
  decaying pole h lambda = -x);
* ``imaginary_stability_interval``: the largest y with |R(iy')| <= 1 for all 0 < y' <= y (an
  undamped oscillator h omega_n = y); 0 when |R(iy)| > 1 for every small y;
* ``integer_rows``: a row of A (or b) as integer numerators over one common denominator, the form
  in which the compiled kernels (``gearsweep.kernels.rk``, ``gearsweep.kernels.kink``) unroll
  their arithmetic. The kernels read their constants from here.

Methods
-------
``rk4``: the classic fourth-order method (Kutta 1901).
``rk5``: Butcher's six-stage fifth-order method (Butcher 1964; *Numerical Methods for ODEs*, 2016,
    Sec. 236), nodes on a quarter-step grid; the kernel's RK5.
``fehlberg5``: the fifth-order solution of Fehlberg's RKF4(5) pair (Fehlberg 1969), six stages.
``cashkarp5``: the fifth-order solution of the Cash-Karp RK4(5) pair (Cash & Karp 1990), six
    stages.
``dopri5``: the fifth-order solution of Dormand-Prince RK5(4)7M (Dormand & Prince 1980), seven
    stages (the seventh, FSAL stage has weight 0, so R(z) has degree 6).

The last three are fifth-order methods that a 1997 code could have called "5th-order
Runge-Kutta"; the stability analysis of the paper's Fig. 7.2 compares them
(``gearsweep.analysis.stability.artifact_map``). Only ``rk4`` and ``rk5`` are compiled into the
batch kernel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction as Fr
from functools import cache

import numpy as np

__all__ = [
    "KERNEL_METHODS",
    "TABLEAUX",
    "Tableau",
    "get",
    "imaginary_stability_interval",
    "integer_rows",
    "real_stability_interval",
    "stability_polynomial",
]


def _f(*xs) -> tuple[Fr, ...]:
    return tuple(Fr(x) for x in xs)


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge-Kutta method, exactly."""

    name: str
    """Short name (the key in ``TABLEAUX``)."""
    title: str
    """Human-readable name with its source."""
    rows: tuple[tuple[Fr, ...], ...]
    """Strictly lower rows of A: ``rows[i]`` holds a_i1 .. a_i,i-1 (``rows[0]`` is empty)."""
    b: tuple[Fr, ...]
    """Weights."""
    order: int
    """Order of accuracy."""

    @property
    def stages(self) -> int:
        return len(self.b)

    @property
    def c(self) -> tuple[Fr, ...]:
        """Nodes: the row sums of A."""
        return tuple(sum(r, Fr(0)) for r in self.rows)

    @property
    def A(self) -> tuple[tuple[Fr, ...], ...]:
        """The full s x s matrix A (zeros on and above the diagonal)."""
        s = self.stages
        return tuple(tuple(r[j] if j < len(r) else Fr(0) for j in range(s)) for r in self.rows)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A, b, c) as float64 arrays."""
        return (np.array([[float(x) for x in r] for r in self.A]),
                np.array([float(x) for x in self.b]), np.array([float(x) for x in self.c]))


TABLEAUX: dict[str, Tableau] = {t.name: t for t in (
    Tableau(
        "rk4", "classic fourth-order Runge-Kutta (Kutta 1901)",
        ((), _f("1/2"), _f(0, "1/2"), _f(0, 0, 1)),
        _f("1/6", "1/3", "1/3", "1/6"), 4),
    Tableau(
        "rk5", "Butcher's six-stage fifth-order method (Butcher 1964)",
        ((), _f("1/4"), _f("1/8", "1/8"), _f(0, "-1/2", 1), _f("3/16", 0, 0, "9/16"),
         _f("-3/7", "2/7", "12/7", "-12/7", "8/7")),
        _f("7/90", 0, "32/90", "12/90", "32/90", "7/90"), 5),
    Tableau(
        "fehlberg5", "Fehlberg RKF4(5), fifth-order weights (Fehlberg 1969)",
        ((), _f("1/4"), _f("3/32", "9/32"), _f("1932/2197", "-7200/2197", "7296/2197"),
         _f("439/216", -8, "3680/513", "-845/4104"),
         _f("-8/27", 2, "-3544/2565", "1859/4104", "-11/40")),
        _f("16/135", 0, "6656/12825", "28561/56430", "-9/50", "2/55"), 5),
    Tableau(
        "cashkarp5", "Cash-Karp RK4(5), fifth-order weights (Cash & Karp 1990)",
        ((), _f("1/5"), _f("3/40", "9/40"), _f("3/10", "-9/10", "6/5"),
         _f("-11/54", "5/2", "-70/27", "35/27"),
         _f("1631/55296", "175/512", "575/13824", "44275/110592", "253/4096")),
        _f("37/378", 0, "250/621", "125/594", 0, "512/1771"), 5),
    Tableau(
        "dopri5", "Dormand-Prince RK5(4)7M, fifth-order weights (Dormand & Prince 1980)",
        ((), _f("1/5"), _f("3/40", "9/40"), _f("44/45", "-56/15", "32/9"),
         _f("19372/6561", "-25360/2187", "64448/6561", "-212/729"),
         _f("9017/3168", "-355/33", "46732/5247", "49/176", "-5103/18656"),
         _f("35/384", 0, "500/1113", "125/192", "-2187/6784", "11/84")),
        _f("35/384", 0, "500/1113", "125/192", "-2187/6784", "11/84", 0), 5),
)}
"""Every method by name."""

KERNEL_METHODS = ("rk4", "rk5")
"""The methods compiled into the batch kernel."""

FIFTH_ORDER = ("rk5", "fehlberg5", "cashkarp5", "dopri5")
"""The fifth-order methods compared for the paper's "5th-order Runge-Kutta"."""


def get(method: str) -> Tableau:
    """The tableau of ``method``; ``KeyError`` naming the known methods otherwise."""
    try:
        return TABLEAUX[method]
    except KeyError:
        raise KeyError(f"method must be one of {sorted(TABLEAUX)}, got {method!r}") from None


@cache
def stability_polynomial(method: str) -> tuple[Fr, ...]:
    """Exact coefficients of R(z), lowest power first (``s + 1`` of them for ``s`` stages)."""
    t = get(method)
    A, s = t.A, t.stages
    vec = [Fr(1)] * s  # A^k 1, starting with k = 0
    coef = [Fr(1)]
    for _ in range(s):
        coef.append(sum((bi * vi for bi, vi in zip(t.b, vec, strict=True)), Fr(0)))
        vec = [sum((A[i][j] * vec[j] for j in range(s)), Fr(0)) for i in range(s)]
    while len(coef) > 1 and coef[-1] == 0:
        coef.pop()
    return tuple(coef)


def _first_crossing(poly: np.ndarray) -> float:
    """Smallest positive real root of ``poly`` (numpy order: highest power first) at which the
    polynomial changes sign from <= 0 to > 0; ``inf`` if none."""
    roots = np.roots(poly)
    real = np.sort(roots[(np.abs(roots.imag) < 1e-9 * np.maximum(1.0, np.abs(roots.real)))
                         & (roots.real > 1e-9)].real)
    for r in real:
        if np.polyval(poly, r * (1 + 1e-7)) > 0:
            return float(r)
    return math.inf


@cache
def real_stability_interval(method: str) -> float:
    """Largest x with |R(-x')| <= 1 for every 0 < x' <= x: the stability interval on the negative
    real axis, from the exact polynomial (the first root of R(-x)^2 - 1 past which it is > 0)."""
    c = [float(x) for x in stability_polynomial(method)]
    r_neg = np.array([ci * (-1) ** k for k, ci in enumerate(c)])  # R(-x), ascending
    sq = np.polynomial.polynomial.polymul(r_neg, r_neg)
    sq[0] -= 1.0
    return _first_crossing(sq[::-1])


@cache
def imaginary_stability_interval(method: str) -> float:
    """Largest y with |R(iy')| <= 1 for every 0 < y' <= y (undamped oscillator, y = h omega_n);
    0 when |R(iy)| exceeds 1 for every small y."""
    c = stability_polynomial(method)
    deg = len(c) - 1
    d = [Fr(0)] * (2 * deg + 1)  # |R(iy)|^2 - 1 in powers of y, exact
    for j in range(deg + 1):
        for k in range(deg + 1):
            # i^j conj(i^k) = i^(j - k): (-1)^((j - k)/2) for j - k even; for j - k odd the
            # terms (j, k) and (k, j) cancel.
            if (j - k) % 2 == 0:
                d[j + k] += c[j] * c[k] * (1 if (j - k) // 2 % 2 == 0 else -1)
    d[0] -= 1
    lead = next((x for x in d[1:] if x != 0), Fr(0))
    if lead > 0:
        return 0.0
    return _first_crossing(np.array([float(x) for x in d[::-1]]))


def integer_rows(values) -> tuple[tuple[float, ...], float]:
    """A row of fractions as (integer numerators, common denominator), both as floats, so that
    ``value_j == num_j / den`` exactly: the form of the kernels' unrolled arithmetic."""
    den = math.lcm(*(Fr(v).denominator for v in values))
    return tuple(float(Fr(v) * den) for v in values), float(den)
