"""The ``floquet`` output of a study: stability of the equation and of the integrator per case.

For every case the homogeneous equation with the teeth in contact (f(p) = p, no forcing),

    m p'' + c p' + (k0 + sum_n k_n cos(n N w t + a_n)) p = 0,

is put in Mathieu time tau = N w t (``alpha = k0 / (m (N w)^2)``, ``gamma = c / (m N w)``, the
harmonics scaled by ``1 / (m (N w)^2)``; the Mathieu scene gives alpha, beta, gamma directly), and

* ``floquet_multiplier``, ``floquet_error``, ``unstable``: converged Floquet analysis
  (``gearsweep.kernels.floquet.floquet``, RK5 with step doubling);
* ``discrete_multiplier``, ``integrator_unstable``: the same monodromy matrix computed with the
  study's own method and steps_per_period; ``integrator_unstable`` where that fixed-step map has
  a multiplier > 1 and the equation does not;
* ``min_steps_per_period``: the guard rail's fewest stable steps per mesh period of the study's
  method (stability polynomial at the largest stiffness, ``gearsweep.analysis.stability``).

For the rattle and full scenes these describe the contact (linear) phase only: with backlash the
motion is piecewise linear and its stability is not a Floquet question.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gearsweep.analysis.stability import check_step
from gearsweep.kernels import BatchResult
from gearsweep.kernels.floquet import floquet, largest_multiplier, monodromy
from gearsweep.model import RPM, MathieuModel
from gearsweep.study.outputs import VarSpec

if TYPE_CHECKING:
    from gearsweep.study.runner import Plan

TOL = 1e-6
"""A multiplier counts as > 1 above 1 + TOL (converged to rtol 1e-8, far below)."""


def hill_parameters(plan: Plan, params: dict[str, np.ndarray], n: int):
    """alpha, beta, gamma [-] per case and the shared harmonics of s(tau) (or None).

    Returns
    -------
    alpha, beta, gamma : ndarray (n,)
    harmonics : (amplitudes, orders, phases) or None
        None also when a stiffness order is not an integer (then alpha is NaN).
    kmax_over_m, c_over_m, period : ndarray (n,)
        Largest stiffness / mass [1/s^2], damping / mass [1/s] and mesh period [s] of each case
        (Mathieu scene: in units of tau).
    """
    model = plan.model

    def case(name: str, default: float) -> np.ndarray:
        v = params.get(name)
        return np.full(n, float(default)) if v is None else np.asarray(v, dtype=float)

    if isinstance(model, MathieuModel):
        a, b, g = case("alpha", model.alpha), case("beta", model.beta), case("gamma", model.gamma)
        return a, b, g, None, a + np.abs(b), g, np.full(n, 2.0 * math.pi)
    omega = model.teeth * case("speed", math.nan) * RPM  # mesh angular frequency [rad/s]
    mass = case("mass", model.mass)
    k0 = case("stiffness", model.stiffness)
    c = case("damping", model.damping)
    kh = model.stiffness_harmonics
    scale = 1.0 / (mass * omega**2)
    alpha, gamma = k0 * scale, c / (mass * omega)
    harmonics = None
    beta = np.zeros(n)
    if kh:
        if any(abs(h.order - round(h.order)) > 1e-12 for h in kh):
            alpha = np.full(n, math.nan)
        else:
            harmonics = ([h.amplitude for h in kh], [round(h.order) for h in kh],
                         [h.phase for h in kh])
            beta = scale
    kmax = (k0 + sum(abs(h.amplitude) for h in kh)) / mass
    return alpha, beta, gamma, harmonics, kmax, c / mass, 2.0 * math.pi / omega


class Floquet:
    """Floquet multipliers, integrator stability and the step guard rail (DATA.md names)."""

    name = "floquet"

    def signal_samples_per_period(self, plan: Plan) -> int:
        return 0

    def variables(self, plan: Plan) -> dict[str, VarSpec]:
        return {
            "floquet_multiplier": VarSpec(attrs={"method": "rk5, steps doubled until converged",
                                                 "equation": "homogeneous, teeth in contact"}),
            "floquet_error": VarSpec(attrs={"units": "1", "long_name":
                                            "estimated error of floquet_multiplier (Richardson)"}),
            "unstable": VarSpec(dtype="bool", attrs={"threshold": f"1 + {TOL:g}"}),
            "discrete_multiplier": VarSpec(attrs={
                "units": "1", "long_name": "largest |mu| of the fixed-step map over one mesh "
                "period at the study's method and steps_per_period"}),
            "integrator_unstable": VarSpec(dtype="bool", attrs={"threshold": f"1 + {TOL:g}"}),
            "min_steps_per_period": VarSpec(attrs={
                "units": "1", "long_name": "fewest steps per mesh period for which the study's "
                "method is stable (stability polynomial at the largest stiffness)"}),
        }

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]:
        n = result.x_final.shape[0]
        a, b, g, harm, kmax, cm, period = hill_parameters(plan, params, n)
        s = plan.study.solver
        ok = np.isfinite(a)
        fl_mu = np.full(n, np.nan)
        fl_err = np.full(n, np.nan)
        disc = np.full(n, np.nan)
        if ok.any():
            fl = floquet(a[ok], b[ok], g[ok], method="rk5", rtol=1e-8, tol=TOL, harmonics=harm)
            fl_mu[ok], fl_err[ok] = fl.multiplier, fl.error
            M = monodromy(a[ok], b[ok], g[ok], s.steps_per_period, method=s.method,
                          harmonics=harm)
            disc[ok] = largest_multiplier(M)
        unstable = fl_mu > 1 + TOL
        _, limit = check_step(s.method, s.steps_per_period, period, kmax, cm)
        return {
            "floquet_multiplier": fl_mu,
            "floquet_error": fl_err,
            "unstable": unstable,
            "discrete_multiplier": disc,
            "integrator_unstable": (disc > 1 + TOL) & ~unstable & ok,
            "min_steps_per_period": np.broadcast_to(limit, (n,)).astype(float),
        }
