"""Spectra of a scene with backlash where the flanks part: the kinks of f(p) alias (outside tester).

Where the flanks part, f(p) = p - clip(p, -b/2, b/2) has a kink, and k(t) f(p) + c p' has lines
at every order, falling only as the square of the order. Sampled at the folding rule's 16 per
mesh period, a full scene (backlash, k(t), STE, a fluctuation; 5000-12,000 rpm) had its
force_spectrum's mean 833.2 / 826.5 / 819.6 N for F_m = 833 N (the mean of m p'' over whole
periods is zero) and its order 2 at 12,000 rpm 1.8 % off scipy's. A spectrum with backlash now
samples every step by default, and validate and run warn of one written below them.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

import gearsweep
from gearsweep.analysis.reference import reference_ivp
from gearsweep.api import run_study
from gearsweep.errors import SpectrumAliasingWarning
from gearsweep.study.outputs import impact_aliasing, spectrum_aliasing
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study
from gearsweep.units import si_values

FM = 833.0  # [N]


def scene_text(*, spp: int = 128, sps: int | None = None, backlash: bool = True) -> str:
    written = f", samples_per_period: {sps}" if sps else ""
    return f"""
title: impacts
scene:
  kind: full
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  stiffness_harmonics:
    - {{amplitude: 179 kN/mm, phase: 30 deg}}
  damping: 5.5 N*s/mm
  {"backlash: 4 um" if backlash else ""}
  mean_force: {FM} N
  ste:
    - {{amplitude: 5 um, phase: 20 deg}}
  fluctuation:
    - {{amplitude: 300 N, order: 1, phase: 45 deg}}
sweep:
  speed: [5000 rpm, 9000 rpm, 12000 rpm]
solver:
  method: rk5
  steps_per_period: {spp}
  transient_periods: 20
  record_periods: 10
  initial_displacement: 3 um
  initial_velocity: 10 mm/s
outputs: [stats, {{spectrum: {{phase: true, max_order: 3{written}}}}}]
"""


def run(text: str):
    return run_study(parse_study(text), text)


def reference_lines(ds, rpm: float, orders=(0, 1, 2, 3), per_period: int = 8192):
    """|p| and |k(t) f(p) + c p'| per mesh order over the record, from scipy DOP853 (rtol 1e-12,
    the crossings as events) sampled 8192 times per period: its own aliasing is (128/8192)^2
    = 2.4e-4 of the default's."""
    model = gearsweep.result_model(ds)
    sc = model.scene(rpm)
    s = gearsweep.result_study(ds).solver
    t0, n = s.transient_periods * sc.period, s.record_periods * per_period
    sol = reference_ivp(sc, t0 + s.record_periods * sc.period, s.initial_displacement,
                        s.initial_velocity)
    phi = s.transient_periods + np.arange(1, n + 1) / per_period  # mesh phase of each sample
    p, v = sol(phi * sc.period)
    kt = model.stiffness + sum(h.amplitude * np.cos(2 * np.pi * h.order * phi + h.phase)
                               for h in model.stiffness_harmonics)
    half = model.backlash / 2
    force = kt * (p - np.clip(p, -half, half)) + model.damping * v
    out = []
    for x in (p, force):
        c = [abs(np.mean(x * np.exp(-2j * np.pi * r * phi))) * (1 if r == 0 else 2) for r in orders]
        out.append(np.array(c))
    return out


def test_default_spectrum_with_backlash_samples_every_step_and_matches_scipy():
    """The default samples every step: order 0 of p is the kernel's p_mean (over every step),
    the force's mean F_m to 6e-4 (measured 3e-7 / 3.3e-4 / 5.5e-4: the steps' own error; 1.6 %
    at 16 samples), and the lines of orders 0-3 at 12,000 rpm (where the impacts are deepest)
    scipy's to 1e-3 for the force (measured 5.5e-4 on the mean, 2.5e-4 on order 2, which was
    1.9 % off at 16 samples) and 1e-4 for p (measured 5.5e-5 on order 3, the step's error at
    128 steps; 1.9e-3 at 16 samples)."""
    ds = run(scene_text())
    assert ds.spectrum.attrs["samples_per_period"] == 128
    assert ds.contact_loss_fraction.values.max() > 0  # the flanks do part
    assert_allclose(ds.spectrum.sel(order=0.0).values, ds.p_mean.values, rtol=1e-12)
    assert_allclose(ds.force_spectrum.sel(order=0.0).values, FM, rtol=6e-4)
    p_ref, f_ref = reference_lines(ds, 12000.0)
    orders = [0.0, 1.0, 2.0, 3.0]
    case = ds.sel(speed=12000.0)
    assert_allclose(case.force_spectrum.sel(order=orders).values, f_ref, rtol=1e-3)
    assert_allclose(si_values(case.spectrum.sel(order=orders)), p_ref, rtol=1e-4)


def test_impact_aliasing_warned_and_falls_with_the_samples():
    """A written samples_per_period below the steps, with backlash: validate (the plan's line)
    and run warn of the impacts' aliasing, and the force's mean is off F_m by what the line
    says at 1024 steps: 1.8 % at 16 samples, 0.04 % at 128 (falling as samples^-2)."""
    err = {}
    for sps in (16, 128):
        text = scene_text(spp=1024, sps=sps)
        plan = make_plan(parse_study(text), text)
        assert spectrum_aliasing(plan) is None  # (the folding rule has nothing to say)
        line = impact_aliasing(plan)  # validate's line: before the run, "may"
        assert line is not None and "kinks of f(p)" in line and "samples_per_period 1024" in line
        assert "1.8 % of F_m on its mean at 16 samples, 0.04 % at 128" in line
        with pytest.warns(SpectrumAliasingWarning, match="3 of 3 case.s. part their flanks"):
            ds = gearsweep.run(parse_study(text))
        err[sps] = np.max(np.abs(ds.force_spectrum.sel(order=0.0).values / FM - 1))
    assert round(err[16] * 100, 1) == 1.8
    assert round(err[128] * 100, 2) == 0.04


def test_no_warning_after_a_run_whose_flanks_never_part():
    """Backlash without excitation (no STE, ripple or fluctuation): p settles at F_m / k0 + b/2,
    the flanks never part, and run says nothing of impacts (validate, before the run, may)."""
    text = (scene_text(spp=256, sps=16).replace("ste:", "ste_off:")
            .replace("stiffness_harmonics:", "stiffness_harmonics_off:")
            .replace("fluctuation:", "fluctuation_off:"))
    text = "\n".join(line for line in text.splitlines()
                     if not line.lstrip().startswith("- {amplitude") and "_off:" not in line)
    plan = make_plan(parse_study(text), text)
    assert impact_aliasing(plan) is not None and impact_aliasing(plan, 0) is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = run(text)
    assert ds.contact_loss_fraction.values.max() == 0


def test_without_backlash_the_default_and_its_silence_are_unchanged():
    """No backlash: the folding rule's default (16 here) and no warning at 16 samples."""
    text = scene_text(backlash=False)
    plan = make_plan(parse_study(text), text)
    assert plan.samples_per_period() == 16
    assert spectrum_aliasing(plan) is None
    text = scene_text(spp=1024, sps=16, backlash=False)
    assert spectrum_aliasing(make_plan(parse_study(text), text)) is None
    with warnings.catch_warnings(record=True) as caught:  # (p < 0: a ContactLossWarning)
        warnings.simplefilter("always")
        ds = run(text)
    assert not [w for w in caught if issubclass(w.category, SpectrumAliasingWarning)]
    # no kink: the force's mean is F_m to round-off and the steps (it was 1.8 % with backlash)
    assert_allclose(ds.force_spectrum.sel(order=0.0).values, FM, rtol=1e-9)
