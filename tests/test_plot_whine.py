"""Whine figures: the plotted data are the Dataset's (checked on the artists, not on pixels)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402
from numpy.testing import assert_allclose  # noqa: E402

from gearsweep.api import run_study  # noqa: E402
from gearsweep.plot.whine import (  # noqa: E402
    driven_speed,
    lowest_in_contact,
    natural_frequency,
    plot_campbell,
    plot_order_lines,
    plot_response_by_load,
    plot_waterfall,
)
from gearsweep.study.schema import parse_study  # noqa: E402

STUDY = """
title: plot test
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  stiffness_harmonics: [{amplitude: 179 kN/mm}]
  ste: [{amplitude: 5 um, phase: 180 deg}, {amplitude: 1 um, phase: 180 deg}]
  damping: 5.5 N*s/mm
  base_radius: 56.38 mm
sweep:
  speed: {start: 2000 rpm, stop: 18000 rpm, num: 41}
  torque: [25 N*m, 50 N*m]
solver: {method: rk4, steps_per_period: 64, transient_periods: 40, record_periods: 4}
outputs: [stats, {spectrum: {max_order: 4}}]
"""


@pytest.fixture(scope="module")
def ds():
    out = run_study(parse_study(STUDY), STUDY)
    yield out
    plt.close("all")


def test_natural_frequency_and_driven_speed(ds):
    assert natural_frequency(ds) == pytest.approx(math.sqrt(1.073e9 / 0.1527) / (2 * math.pi),
                                                  rel=1e-12)
    assert_allclose(driven_speed(ds, 32), ds.speed.values * 48 / 32, rtol=1e-14)


def test_waterfall_draws_the_spectrum(ds):
    one = ds.sel(torque=50.0)
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    assert plot_waterfall(ax, one, traces=5) is fig
    lines = ax.get_lines()
    assert len(lines) == 5
    x, y, z = lines[-1].get_data_3d()
    assert_allclose(z, one.spectrum.values[-1, 1:])  # order 0 left out; the file is in um
    assert_allclose(x, one.frequency.values[-1, 1:] * 1e-3)  # kHz above 5 kHz
    assert np.all(y == 18000.0)
    assert "[µm]" in ax.get_zlabel() and "[rpm]" in ax.get_ylabel()
    flat = plt.figure().add_subplot()  # drew, then failed on 'set_zlabel' (a new-user test)
    with pytest.raises(TypeError, match="plot_waterfall draws on a 3-D axes"):
        plot_waterfall(flat, one, traces=5)
    assert not flat.get_lines()


def test_campbell_map_and_natural_frequency_curve(ds):
    one = ds.sel(torque=50.0)
    fig, ax = plt.subplots()
    f_n = natural_frequency(one)
    plot_campbell(ax, one, natural_frequency_hz=f_n, floor=1e-3, skip_mean=False)  # order 0 too
    mesh = ax.collections[0]
    assert_allclose(np.asarray(mesh.get_array()).reshape(17, 41),
                    np.clip(one.spectrum.values.T, 1e-3, None))  # um
    curve = ax.get_lines()[0]
    assert_allclose(curve.get_ydata(), f_n / one.mesh_frequency.values)
    # The circles sit where order n meets f_n: speed 60 f_n / (48 n).
    circles = [ln for ln in ax.get_lines()[1:]]
    for n, c in zip((1, 2, 3), circles, strict=True):
        assert c.get_xdata()[0] == pytest.approx(60 * f_n / (48 * n), rel=1e-9)
        assert c.get_ydata()[0] == n


def test_campbell_marks_where_order_n_meets_f_n_on_a_decreasing_speed_sweep():
    """A study may list its speeds from high to low; np.interp needs increasing abscissae, and
    with decreasing mesh frequencies it gave NaN (left/right) or nonsense, so plot_campbell
    silently dropped the circles where order n meets f_n (an outside reviewer). They sit at
    60 f_n / (48 n) whichever way the speeds run."""
    up = _spectrum_result()
    down = up.isel(speed=slice(None, None, -1))
    assert np.all(np.diff(down.speed.values) < 0)
    f_n = 2400.0  # order 1 at 3,000 rpm, order 2 at 1,500 rpm, order 3 at 1,000 rpm
    for one in (up, down):
        fig, ax = plt.subplots()
        plot_campbell(ax, one, natural_frequency_hz=f_n, orders=(1, 2, 3), floor=1e-3)
        circles = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        assert [c.get_ydata()[0] for c in circles] == [1, 2, 3]
        for n, c in zip((1, 2, 3), circles, strict=True):
            assert c.get_xdata()[0] == pytest.approx(60 * f_n / (48 * n), rel=1e-12)
        plt.close(fig)


def test_campbell_leaves_out_the_mean_and_marks_the_results_own_natural_frequency(ds):
    """plot_campbell drew no f_n curve unless ``natural_frequency_hz`` was given, though the
    result carries k0 and m_eq (its resolved model), and drew order 0, the mean of p, as the
    brightest row over the order lines (plot_waterfall leaves it out): by default now the
    result's own f_n is drawn and order 0 is left out of the colours and their scale."""
    one = ds.sel(torque=50.0)
    fig, ax = plt.subplots()
    plot_campbell(ax, one, floor=1e-3)
    mesh = ax.collections[0]
    image = np.asarray(mesh.get_array()).reshape(17, 41)
    spectrum = np.clip(one.spectrum.values.T, 1e-3, None)  # um
    assert (image[0] == 1e-3).all()  # order 0: the floor, drawn as nothing
    assert_allclose(image[1:], spectrum[1:])
    assert mesh.norm.vmax == pytest.approx(spectrum[1:].max())
    f_n = math.sqrt(1.073e9 / 0.1527) / (2 * math.pi)
    curve = ax.get_lines()[0]
    assert_allclose(curve.get_ydata(), f_n / one.mesh_frequency.values, rtol=1e-12)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        f"f_n / f_mesh, f_n = {f_n / 1e3:.2f} kHz"]
    fig, ax = plt.subplots()
    plot_campbell(ax, one, natural_frequency_hz=False)
    assert not ax.get_lines() and ax.get_legend() is None


def test_the_results_natural_frequency_where_it_sweeps_k0_or_m_eq(ds):
    """A swept k0 or m_eq (``model_swept``) is read where ``ds`` has selected it: a scalar
    ``stiffness`` or ``mass`` coordinate, or a gear scene's ``gear_stiffness`` at one load; not
    selected, there is no one f_n (no curve)."""
    from gearsweep.plot.whine import result_natural_frequency

    one = ds.sel(torque=50.0)
    assert result_natural_frequency(one) == pytest.approx(natural_frequency(one), rel=1e-15)
    swept = one.assign_attrs(model_swept="stiffness").assign_coords(
        stiffness=xr.DataArray(2000.0, attrs={"units": "kN mm-1"}))
    assert result_natural_frequency(swept) == pytest.approx(
        math.sqrt(2e9 / 0.1527) / (2 * math.pi), rel=1e-12)
    gear = one.assign_attrs(model_swept="mean_force stiffness")
    gear["gear_stiffness"] = xr.DataArray(500.0, attrs={"units": "kN mm-1"})
    assert result_natural_frequency(gear) == pytest.approx(
        math.sqrt(5e8 / 0.1527) / (2 * math.pi), rel=1e-12)
    fig, ax = plt.subplots()
    plot_campbell(ax, gear)
    assert_allclose(ax.get_lines()[0].get_ydata(),
                    math.sqrt(5e8 / 0.1527) / (2 * math.pi) / one.mesh_frequency.values)
    loads = ds.assign_attrs(model_swept="mean_force stiffness")
    loads["gear_stiffness"] = xr.DataArray([500.0, 600.0], dims="torque",
                                           attrs={"units": "kN mm-1"})
    assert result_natural_frequency(loads) is None
    fig, ax = plt.subplots()
    plot_campbell(ax, loads.sel(torque=50.0).drop_vars("gear_stiffness"))  # no k0 of the load
    assert not ax.get_lines()  # no curve rather than another load's
    plt.close("all")


def test_response_and_order_lines(ds):
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds, by="torque", variable="p_rms")
    assert_allclose(ax.get_lines()[1].get_ydata(), ds.p_rms.sel(torque=50.0).values)  # um
    fig, ax = plt.subplots()
    plot_order_lines(ax, ds.sel(torque=50.0), derivative=1, driven_teeth=32)
    line = ax.get_lines()[0]
    amp = ds.spectrum.sel(torque=50.0, order=1.0).values
    f = ds.frequency.sel(order=1.0).values
    assert_allclose(line.get_ydata(), 2 * np.pi * f * amp * 1e-3)  # um/s -> mm/s
    assert_allclose(line.get_xdata(), ds.speed.values * 48 / 32)
    assert "[mm/s]" in ax.get_ylabel()


def test_unsettled_cases_are_masked_and_counted(ds):
    """A steady-state value of a case that has not settled is not a curve point (issue 28,
    item 10): it is drawn as a gap and counted in the legend."""
    bad = ds.copy(deep=True)
    bad["status"][{"speed": 2, "torque": 1}] = 2  # not settled
    fig, ax = plt.subplots()
    plot_response_by_load(ax, bad, by="torque", variable="p_rms")
    y = ax.get_lines()[1].get_ydata()  # torque 50 N m
    assert np.isnan(y[2]) and np.isfinite(np.delete(y, 2)).all()
    assert ax.get_legend().get_title().get_text().startswith("1 of ")
    fig, ax = plt.subplots()
    plot_order_lines(ax, bad.sel(torque=50.0))
    assert np.isnan(ax.get_lines()[0].get_ydata()[2])
    assert ax.get_legend().get_title().get_text().startswith("1 of ")


THREE_DIMS = """
title: t
scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, damping: 5 N s/mm,
        backlash: 0.2 mm, mean_force: 200 N, fluctuation: [{amplitude: 300 N, order: 1}]}
sweep:
  speed: [5000 rpm, 6000 rpm]
  stiffness: [1000 kN/mm, 1073 kN/mm]
  backlash: [0.2 mm, 0.3 mm]
solver: {steps_per_period: 32, transient_periods: 10, record_periods: 4}
"""
"""A rattle result over speed x stiffness x backlash: one dim more than a figure draws."""


def test_response_vs_speed_names_the_swept_values_it_holds_fixed(tmp_path):
    """A result over speed x damping x backlash drew one backlash silently (the first): the
    title now names it; legend units are written as a study writes them (N s/mm, kN/mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import gearsweep
    from gearsweep.plot.sweep import plot_response_vs_speed

    ds = gearsweep.run(THREE_DIMS)
    fig = plot_response_vs_speed(ds, "p_pp")
    ax = fig.axes[0]
    assert ax.get_title().endswith("at backlash = 0.2 mm (select others with ds.sel)")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "stiffness = 1000 kN/mm", "stiffness = 1073 kN/mm"]


def test_response_vs_speed_counts_the_masked_cases_it_draws(tmp_path):
    """The legend's "N of M cases not settled (masked)" counted the whole result, also the
    values of the dims drawn only at their first value: a figure of 4 settled cases said
    "1 of 8 ... masked" (an outside tester's finding)."""
    import matplotlib

    matplotlib.use("Agg")
    import gearsweep
    from gearsweep.plot.sweep import plot_response_vs_speed

    ds = gearsweep.run(THREE_DIMS)
    ds["status"][:] = 0
    ds["status"][{"speed": 1, "stiffness": 0, "backlash": 1}] = 2  # not drawn (backlash 0.3 mm)
    ax = plot_response_vs_speed(ds, "p_pp").axes[0]
    assert ax.get_legend().get_title().get_text() == ""  # none of the drawn 4 is masked
    assert all(np.isfinite(line.get_ydata()).all() for line in ax.get_lines())
    ds["status"][{"speed": 1, "stiffness": 0, "backlash": 0}] = 2  # drawn
    ax = plot_response_vs_speed(ds, "p_pp").axes[0]
    assert ax.get_legend().get_title().get_text() == "1 of 4 cases not settled (masked)"


def test_spectrum_plots_say_what_they_draw_on_in_one_line(ds):
    """A spectrum over more dims than (speed, order), or an order the study did not keep, is one
    line naming the fix (were xarray's transpose error and KeyError; an API test)."""
    over_two = ds.expand_dims(copy=[1, 2]).transpose("speed", "copy", "order", ...)
    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match=r"select one value of \[.copy.*\] first"):
        plot_campbell(ax, over_two)
    top = int(ds["order"].max())
    with pytest.raises(ValueError, match=rf"order\(s\) \[{top + 1}\] are not in this spectrum"):
        plot_order_lines(ax, ds.sel(torque=50.0), orders=(1, top + 1))
    plt.close(fig)


def test_damping_legend_is_in_n_s_per_mm_from_either_unit_of_the_file():
    """A damping sweep's legend says the value the study wrote (2.5 N s/mm), whether the result
    stores damping as a study writes it (N s mm-1) or in SI (N s m-1, 2500): neither branch of
    ``value_label`` was tested (a factor of 10 in either passed every test)."""
    import xarray as xr

    import gearsweep
    from gearsweep.plot.sweep import plot_response_vs_speed, value_label

    ds = gearsweep.run(STUDY.replace("  torque: [25 N*m, 50 N*m]",
                                     "  damping: [2.5 N*s/mm, 5.5 N*s/mm]")
                       .replace("num: 41", "num: 3"))
    assert ds["damping"].attrs["units"] == "N s mm-1"
    ax = plot_response_vs_speed(ds, "p_pp", hue="damping").axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()][:2] == [
        "c = 2.5 N s/mm", "c = 5.5 N s/mm"]  # (then the grey band's: these cases part the teeth)
    si = xr.Dataset(coords={"damping": ("damping", [2500.0], {"units": "N s m-1"})})
    assert value_label(si, "damping", 2500.0) == "c = 2.5 N s/mm"


def test_the_phase_lag_behind_the_ste_passes_a_quarter_period_at_the_natural_frequency():
    """fig05_phase.png: with constant stiffness the order-n line of p answers m w^2 e_n cos(...),
    in phase with the STE, and lags it by exactly 90 degrees at w = omega_n (the receptance's
    closed form), whatever the damping; ``ste_phase_lag`` (the STE's phase taken from the
    result's model) and ``first_crossing`` find that speed to a fraction of the grid step."""
    from gearsweep.analysis.spectrum import first_crossing
    from gearsweep.plot.whine import plot_ste_phase_lags, ste_phase_lag

    text = (STUDY.replace("  stiffness_harmonics: [{amplitude: 179 kN/mm}]\n", "")
            .replace("phase: 180 deg}, {amplitude: 1 um, phase: 180 deg}",
                     "phase: 40 deg}, {amplitude: 1 um, phase: -100 deg}")
            .replace("num: 41", "num: 321").replace("  torque: [25 N*m, 50 N*m]\n", "")
            .replace("  base_radius: 56.38 mm\n", "  mean_force: 800 N\n"))
    text = text.replace("outputs: [stats, {spectrum: {max_order: 4}}]",
                        "outputs: [stats, {spectrum: {max_order: 4, phase: true}}]")
    assert "phase: true" in text
    ds = run_study(parse_study(text, "t.yaml"), text)
    f_n = math.sqrt(1073e6 / 0.1527) / (2 * math.pi)
    for n in (1, 2):
        lag = ste_phase_lag(ds, n)
        assert lag.attrs["units"] == "deg" and lag.dims == ("speed",)  # (it kept 'rad')
        cross = first_crossing(ds.speed.values, lag.values, -90.0)
        assert cross == pytest.approx(60 * f_n / (48 * n), abs=5.0)  # grid step 50 rpm
        r = n * 48 * ds.speed.values / 60 / f_n  # and the receptance's phase at every speed
        zeta = 5500 / (2 * math.sqrt(1073e6 * 0.1527))
        assert_allclose(lag.values, -np.degrees(np.arctan2(2 * zeta * r, 1 - r**2)), atol=0.05)
    fig, ax = plt.subplots()
    plot_ste_phase_lags(ax, ds, orders=(1, 2))
    assert [ln.get_label() for ln in ax.lines[:2]] == ["order 1", "order 2"]
    assert "[deg]" in ax.get_ylabel() and "[rpm]" in ax.get_xlabel()
    plt.close(fig)
    assert math.isnan(first_crossing([0.0, 1.0], [0.0, 1.0], -1.0))
    assert first_crossing([0.0, 1.0, 2.0], [0.0, -1.0, -3.0], -2.0) == 1.5


def test_order_lines_shade_the_speeds_where_contact_is_lost(ds):
    """The speeds where some case's p fell below 0 (``contact_lost``: the linear scene answers
    for a pair with no backlash there) are grey spans with one legend entry; a result with none
    gets none."""
    one = ds.sel(torque=25.0)
    lost = one.contact_lost.values
    assert lost.any() and not lost.all()  # the fixture: 5 um of STE at 25 N m parts the teeth
    fig, ax = plt.subplots()
    plot_order_lines(ax, one)
    spans = [p for p in ax.patches]
    assert [t.get_text() for t in ax.get_legend().get_texts()][0] == (
        "p < 0: teeth would part (contact_lost)")
    speed = ds.speed.values
    covered = np.zeros(speed.size, bool)
    for p in spans:
        x0, x1 = p.get_x(), p.get_x() + p.get_width()
        covered |= (speed >= x0) & (speed <= x1)  # (edges: midpoints, and the ends)
    assert np.array_equal(covered, lost)
    fig, ax = plt.subplots()
    plot_order_lines(ax, one.assign(contact_lost=one.contact_lost & False))
    assert not ax.patches


def test_waterfall_marks_the_speeds_where_contact_is_lost_on_its_floor(ds):
    """fig05_waterfall.png drew 1,922 of 2,000 speeds whose p fell below 0 (``contact_lost``)
    with nothing to say so, while README says plots over speed mark them grey and
    plot_order_lines shades them (an outside reviewer): the waterfall's floor is grey under
    those speeds, across the frequency axis, with one legend entry that counts them; a result
    with none gets no grey and no entry."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    one = ds.sel(torque=25.0)
    lost = one.contact_lost.values
    assert lost.any() and not lost.all()
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    plot_waterfall(ax, one, traces=5, natural_frequency_hz=natural_frequency(one))
    floors = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    assert len(floors) == 1
    speed = one.speed.values
    covered = np.zeros(speed.size, bool)
    for verts in np.asarray(floors[0]._faces):  # (the 3-D corners: matplotlib keeps no public
        # accessor; each strip is (x, speed, 0) around a run of lost speeds)
        assert_allclose(verts[:, 2], 0.0)  # on the floor
        assert verts[:, 0].min() <= one.frequency.values[:, 1].min() * 1e-3
        assert verts[:, 0].max() >= one.frequency.values.max() * 1e-3 * (1 - 1e-12)
        covered |= (speed >= verts[:, 1].min()) & (speed <= verts[:, 1].max())
    assert np.array_equal(covered, lost)
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts[0].startswith("f_n = ")
    assert texts[1] == (f"grey: p < 0: teeth would part (contact_lost),\n{int(lost.sum())} of"
                        f" {speed.size} speeds")
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    plot_waterfall(ax, one.assign(contact_lost=one.contact_lost & False), traces=5)
    assert not [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    assert ax.get_legend() is None
    plt.close("all")


def test_the_phase_figure_draws_every_kept_order_and_blanks_a_negligible_line(tmp_path,
                                                                              monkeypatch):
    """fig05_phase.png drew orders 1-4 only while Fig. 5's verdict reads orders 1-10: it draws
    one panel per mesh order the result keeps. A line far below the largest (here order 2, whose
    STE term is 1e-5 of order 1's: with constant stiffness each line is its own receptance times
    e_n, so order 2 is below 1e-3 of order 1 at every speed) has a phase that says nothing: it is
    left blank (``PHASE_FLOOR``), while order 1 follows the receptance's closed form."""
    import importlib.util
    import sys

    from gearsweep.plot.whine import PHASE_FLOOR, plot_ste_phase_lags

    text = (STUDY.replace("  stiffness_harmonics: [{amplitude: 179 kN/mm}]\n", "")
            .replace("ste: [{amplitude: 5 um, phase: 180 deg}, {amplitude: 1 um, phase: 180 deg}]",
                     "ste: [{amplitude: 1 um, phase: 40 deg}, {amplitude: 1e-5 um, phase: 10 deg},"
                     " {amplitude: 0.5 um}, {amplitude: 0.3 um}]")
            .replace("  torque: [25 N*m, 50 N*m]\n", "")
            .replace("  base_radius: 56.38 mm\n", "  mean_force: 800 N\n")
            .replace("{max_order: 4}", "{max_order: 4, phase: true}"))
    assert "1e-5 um" in text and "phase: true" in text
    ds = run_study(parse_study(text, "t.yaml"), text)
    assert PHASE_FLOOR == 0.01
    fig, ax = plt.subplots()
    plot_ste_phase_lags(ax, ds, orders=(1, 2))
    one, two = (ln.get_ydata() for ln in ax.lines[:2])
    assert np.isnan(two).all() and np.isfinite(one).all()
    f_n = math.sqrt(1073e6 / 0.1527) / (2 * math.pi)
    zeta = 5500 / (2 * math.sqrt(1073e6 * 0.1527))
    r = 48 * ds.speed.values / 60 / f_n
    assert_allclose(one, -np.degrees(np.arctan2(2 * zeta * r, 1 - r**2)), atol=0.05)
    plt.close(fig)

    for name in ("fig05_waterfall", "fig05_waterfall_no_ripple"):
        ds.to_netcdf(tmp_path / f"{name}.nc")
    scripts = Path(__file__).resolve().parents[1] / "scripts"
    monkeypatch.syspath_prepend(str(scripts))
    spec = importlib.util.spec_from_file_location("fig05_script", scripts / "fig05_waterfall.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "fig05_script", module)
    spec.loader.exec_module(module)
    drawn = []
    monkeypatch.setattr(module, "save", lambda f, path, **_: drawn.append(f) or path)
    module.draw_phase(tmp_path, tmp_path)
    panels = [a for a in drawn[0].axes if a.get_visible()]
    assert [a.get_title().split(":")[0] for a in panels] == ["order 1", "order 2", "order 3",
                                                             "order 4"]
    assert np.isnan(panels[1].lines[0].get_ydata()).all()  # order 2: blank
    assert all(np.isfinite(a.lines[0].get_ydata()).all() for a in panels[::2])
    plt.close(drawn[0])


def test_order_by_variant_names_each_k_and_draws_the_constant_force_closed_form(ds):
    """Fig. 6 (d), the k(t) variants its verdict rests on: each line is the order line of p
    (relative: over its value at the first speed), named by its k(t), and the grey line is a
    constant-amplitude force's receptance, which peaks at 1 / (2 zeta sqrt(1 - zeta^2)) at
    sqrt(1 - 2 zeta^2) f_n (closed form, from the study's m, k0 and c)."""
    from gearsweep.plot.whine import plot_order_by_variant

    one = ds.isel(torque=0)
    fig, ax = plt.subplots()
    plot_order_by_variant(ax, [("typed", one)], relative=True)
    labels = [ln.get_label() for ln in ax.lines]
    assert labels[0] == "typed: k0 = 1073; k1 = 179 kN/mm"
    line = one.spectrum.sel(order=1.0).values
    assert_allclose(ax.lines[0].get_ydata(), line / line[0], rtol=1e-12)
    zeta = 5500 / (2 * math.sqrt(1073e6 * 0.1527))
    f_n = math.sqrt(1073e6 / 0.1527) / (2 * math.pi)
    assert "closed form" in labels[1] and f"ζ = {zeta:.3f}" in labels[1]
    r = 48 * one.speed.values / 60 / f_n
    gain = 1 / np.sqrt((1 - r**2) ** 2 + (2 * zeta * r) ** 2)
    assert_allclose(ax.lines[1].get_ydata(), gain / gain[0], rtol=1e-9)
    peak = 60 * math.sqrt(1 - 2 * zeta**2) * f_n / 48
    assert ax.lines[2].get_xdata()[0] == pytest.approx(peak, rel=1e-9)  # the dotted mark
    assert float(np.max(gain)) <= 1 / (2 * zeta * math.sqrt(1 - zeta**2)) + 1e-12
    assert ax.get_ylabel() == "order 1 of p / its value at 2,000 rpm [-]"
    plt.close(fig)
def _lost_result(directions: bool = False) -> xr.Dataset:
    """A synthetic whine result over speed x damping (p in um, as a file stores it): damping 1's
    case at speeds 3-5 lost contact, damping 0's at speed 7; speed 4 of damping 1 is not
    settled (masked, so not marked either)."""
    speed = np.linspace(1000.0, 10000.0, 10)
    dims = ("speed", "damping")
    lost = np.zeros((10, 2), bool)
    lost[3:6, 1] = True
    lost[7, 0] = True
    status = np.zeros((10, 2), np.int8)
    status[4, 1] = 2
    p = np.linspace(1.0, 2.0, 20).reshape(10, 2)
    ds = xr.Dataset(
        {"p_rms": (dims, p, {"units": "um", "long_name": "rms of p"}),
         "p_pp": (dims, 2 * p, {"units": "um", "long_name": "peak-to-peak of p"}),
         "contact_lost": (dims, lost), "status": (dims, status)},
        coords={"speed": ("speed", speed, {"units": "rpm"}),
                "damping": ("damping", [0.55, 5.5], {"units": "N s mm-1"}),
                "mesh_frequency": ("speed", speed * 48 / 60, {"units": "Hz"})})
    if directions:
        ds = xr.concat([ds, ds], dim=xr.DataArray(["up", "down"], dims="direction"))
    return ds


CONTACT_LOST = "p < 0: teeth would part (contact_lost)"  # as the Campbell figure's grey


def _bands(ax) -> list:
    """The grey bands of contact-lost cases: lines drawn in 0.78 grey."""
    return [ln for ln in ax.get_lines() if ln.get_color() == "0.78"]


def test_response_vs_speed_marks_the_cases_that_lost_contact():
    """whine_gear_table1.png and whine_speed_sweep.png drew cases whose p fell below 0 (90 of
    400 and 1,405 of 1,800 cases ``contact_lost``) as if the teeth stayed in contact, while
    fig05_campbell.png shades such speeds grey (an outside reviewer): each line's contact-lost
    points lie on a grey band, counted in one legend entry; a masked case is not marked."""
    from gearsweep.plot.sweep import plot_response_vs_speed

    ds = _lost_result()
    ax = plot_response_vs_speed(ds, "p_rms", hue="damping").axes[0]
    bands = _bands(ax)
    assert len(bands) == 2
    marked = {tuple(np.isfinite(b.get_ydata()).nonzero()[0]) for b in bands}
    assert marked == {(7,), (3, 5)}  # speed 4 of damping 1 is masked (not settled)
    for b in bands:
        y = b.get_ydata()
        ok = np.isfinite(y)
        line = [ln for ln in ax.get_lines() if ln not in bands
                and np.allclose(ln.get_ydata()[ok], y[ok])]
        assert line  # on its own line's values (um)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[-1] == f"grey: {CONTACT_LOST},\n3 of 19 cases drawn"
    run = plot_response_vs_speed(_lost_result(directions=True), "p_pp", hue="damping").axes[0]
    assert len(_bands(run)) == 4  # both sweeps
    assert run.get_legend().get_texts()[-1].get_text().endswith("6 of 38 cases drawn")
    none = plot_response_vs_speed(ds.assign(contact_lost=ds.contact_lost & False), "p_rms",
                                  hue="damping").axes[0]
    assert not _bands(none) and "contact_lost" not in " ".join(
        t.get_text() for t in none.get_legend().get_texts())
    plain = plot_response_vs_speed(ds.drop_vars("contact_lost"), "p_rms").axes[0]
    assert not _bands(plain)
    plt.close("all")


def test_response_by_load_marks_the_cases_that_lost_contact_and_the_ratios_on_them():
    """fig06_mean_torque.png panel (b): the 12.5 N m line, the baseline of the relative panel,
    loses contact at 679 of 1,000 speeds, unmarked (an outside reviewer). Each line's
    contact-lost points lie on a grey band; in the relative panel a ratio is marked where
    either case lost contact, the baseline's too."""
    ds = _lost_result()
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds, by="damping", variable="p_rms")
    bands = _bands(ax)
    assert [tuple(np.isfinite(b.get_ydata()).nonzero()[0]) for b in bands] == [(7,), (3, 5)]
    assert_allclose(bands[1].get_ydata()[[3, 5]], ds.p_rms.values[[3, 5], 1])  # um
    assert ax.get_legend().get_texts()[-1].get_text() == (
        f"grey: {CONTACT_LOST},\n3 of 19 cases drawn")
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds, by="damping", variable="p_rms", relative=True)
    bands = _bands(ax)
    assert [tuple(np.isfinite(b.get_ydata()).nonzero()[0]) for b in bands] == [(7,), (3, 5, 7)]
    assert ax.get_legend().get_texts()[-1].get_text() == (
        f"grey: {CONTACT_LOST},\n4 of 19 ratios drawn (in the line's\ncase or the"
        " baseline's)")
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds.drop_vars("contact_lost"), by="damping")
    assert not _bands(ax)
    plt.close("all")


def _three_loads() -> xr.Dataset:
    """A synthetic Fig. 6 (b): p_rms over speed x torque (um), 12.5 N m losing contact at the
    top three speeds (and there larger than the others, as a case whose flanks part), 25 and
    50 N m keeping it; speed 1 of 25 N m not settled."""
    speed = np.linspace(1000.0, 10000.0, 6)
    torque = np.array([12.5, 25.0, 50.0])
    p = np.outer(np.ones(6), [1.0, 2.0, 4.0])
    p[3:, 0] = 8.0
    lost = np.zeros((6, 3), bool)
    lost[3:, 0] = True
    status = np.zeros((6, 3), np.int8)
    status[1, 1] = 2
    dims = ("speed", "torque")
    return xr.Dataset(
        {"p_rms": (dims, p, {"units": "um", "long_name": "rms of p"}),
         "contact_lost": (dims, lost), "status": (dims, status)},
        coords={"speed": ("speed", speed, {"units": "rpm"}),
                "torque": ("torque", torque, {"units": "N m"}),
                "mesh_frequency": ("speed", speed * 48 / 60, {"units": "Hz"})})


def test_relative_response_can_be_set_against_the_lowest_load_that_keeps_contact():
    """Fig. 6 (b): its relative panel divided by 12.5 N m, which loses contact from 7,105 rpm
    up, so its ratios (down to 0.48) compared a real pair with the linear equation's answer
    for a pair with no backlash. ``lowest_in_contact`` names the lowest load none of whose
    settled cases lost contact; ``baseline`` divides by it, and only the ratios whose own case
    lost contact are then marked."""
    ds = _three_loads()
    assert lowest_in_contact(ds, "torque") == 25.0
    keeps = ds.assign(contact_lost=ds.contact_lost & False)
    assert lowest_in_contact(keeps, "torque") == 12.5
    everywhere = ds.assign(contact_lost=ds.contact_lost | (ds.speed > 9000.0))
    assert lowest_in_contact(everywhere, "torque") is None
    # a case that lost contact but has not settled is masked, not counted against its load
    masked = ds.copy(deep=True)
    masked["contact_lost"][{"speed": 1, "torque": 1}] = True
    assert lowest_in_contact(masked, "torque") == 25.0
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds, by="torque", relative=True, baseline=25.0)
    lines = [ln for ln in ax.get_lines() if ln.get_color() != "0.78"]
    assert_allclose(lines[0].get_ydata(), [0.5, np.nan, 0.5, 4.0, 4.0, 4.0])  # (the baseline's
    assert_allclose(lines[1].get_ydata(), [1.0, np.nan, 1.0, 1.0, 1.0, 1.0])  # unsettled case:
    assert_allclose(lines[2].get_ydata(), [2.0, np.nan, 2.0, 2.0, 2.0, 2.0])  # no ratio)
    assert [tuple(np.isfinite(b.get_ydata()).nonzero()[0]) for b in _bands(ax)] == [(3, 4, 5)]
    assert ax.get_ylabel() == "p_rms / p_rms at torque = 25 N m [-]"
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds, by="torque", relative=True)  # the first load: all three marked
    assert ax.get_ylabel() == "p_rms / p_rms at torque = 12.5 N m [-]"
    assert [tuple(np.isfinite(b.get_ydata()).nonzero()[0]) for b in _bands(ax)] == [
        (3, 4, 5), (3, 4, 5), (3, 4, 5)]
    lines = [ln for ln in ax.get_lines() if ln.get_color() != "0.78"]
    assert_allclose(lines[2].get_ydata()[3:], 0.5)  # 50 / 12.5 N m where 12.5 N m parted
    plt.close("all")


def _spectrum_result() -> xr.Dataset:
    """A synthetic spectrum over (speed, order) in um, as a file stores it; the case at speed 2
    has not settled (status 2)."""
    speed = np.linspace(1000.0, 5000.0, 5)
    order = np.arange(0.0, 4.0)
    f_mesh = speed * 48 / 60
    status = np.zeros(5, np.int8)
    status[2] = 2
    return xr.Dataset(
        {"spectrum": (("speed", "order"), np.linspace(0.01, 2.0, 20).reshape(5, 4),
                      {"units": "um"}),
         "status": ("speed", status)},
        coords={"speed": ("speed", speed, {"units": "rpm"}), "order": ("order", order),
                "mesh_frequency": ("speed", f_mesh, {"units": "Hz"}),
                "frequency": (("speed", "order"), f_mesh[:, None] * order, {"units": "Hz"})})


def test_waterfall_and_campbell_leave_out_the_cases_that_did_not_settle():
    """plot_waterfall and plot_campbell drew the spectrum of a case that had not settled
    (status != 0) as a steady one, unlike every other plot function (an outside reviewer): its
    trace is empty, its column uncoloured (white), and both say how many."""
    ds = _spectrum_result()
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    plot_waterfall(ax, ds, traces=5)
    z = [ln.get_data_3d()[2] for ln in ax.get_lines()]
    assert len(z) == 5 and np.isnan(z[2]).all()
    assert all(np.isfinite(z[i]).all() for i in (0, 1, 3, 4))
    assert_allclose(z[3], ds.spectrum.values[3, 1:])
    assert [t.get_text() for t in ax.texts] == [
        "1 of 5 speeds drawn not settled (masked: no trace)"]
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    plot_waterfall(ax, ds, traces=2)  # speeds 0 and 4: none masked, nothing said
    assert not ax.texts
    fig, ax = plt.subplots()
    plot_campbell(ax, ds, natural_frequency_hz=False, floor=1e-3)
    image = np.ma.filled(ax.collections[0].get_array(), np.nan).reshape(4, 5)
    assert np.isnan(image[:, 2]).all() and np.isfinite(np.delete(image, 2, axis=1)).all()
    assert ax.collections[0].norm.vmax == pytest.approx(ds.spectrum.values[[0, 1, 3, 4], 1:].max())
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "white: 1 of 5 speeds not settled (masked)"]
    fig, ax = plt.subplots()
    plot_campbell(ax, ds.assign(status=ds.status * 0), natural_frequency_hz=False)
    assert ax.get_legend() is None
    assert np.isfinite(np.ma.filled(ax.collections[0].get_array(), np.nan)).all()
    plt.close("all")


def test_response_vs_speed_of_no_settled_case_says_so_without_an_empty_legend():
    """A result of one swept dim with no settled case called ``legend`` with nothing labelled:
    matplotlib warned "No artists with labels found to put in legend" (an outside tester's
    finding). The count of masked cases is written on the axes instead, and no legend drawn."""
    import gearsweep
    from gearsweep.plot.sweep import plot_response_vs_speed

    text = STUDY.replace("  torque: [25 N*m, 50 N*m]\n", "").replace(
        "  base_radius: 56.38 mm\n", "  base_radius: 56.38 mm\n  torque: 50 N*m\n").replace(
        "{start: 2000 rpm, stop: 18000 rpm, num: 41}", "[2000 rpm, 3000 rpm]").replace(
        "transient_periods: 40", "transient_periods: 4")
    ds = gearsweep.run(text)
    ds["status"][:] = 2  # not settled
    ax = plot_response_vs_speed(ds, "p_pp").axes[0]
    assert ax.get_legend() is None
    assert [t.get_text() for t in ax.texts] == ["2 of 2 cases not settled (masked)"]
    plt.close("all")


def _swept_three(direction: bool = False) -> xr.Dataset:
    """A whine result's shape: p_rms [um] over speed x mean_force x damping (x direction)."""
    dims = ("speed", "mean_force", "damping") + (("direction",) if direction else ())
    shape = (3, 2, 2) + ((2,) if direction else ())
    coords = {"speed": ("speed", [1000.0, 2000.0, 3000.0], {"units": "rpm"}),
              "mean_force": ("mean_force", [400.0, 833.0], {"units": "N"}),
              "damping": ("damping", [5.5, 2.0], {"units": "N s mm-1"})}
    if direction:
        coords["direction"] = ("direction", ["up", "down"])
    return xr.Dataset({"p_rms": (dims, np.arange(1.0, 1 + math.prod(shape)).reshape(shape),
                                 {"units": "um", "long_name": "rms of p"}),
                       "status": (dims, np.zeros(shape, np.int8))}, coords=coords)


def test_response_by_load_draws_another_swept_dim_at_its_first_value_and_says_so():
    """On a speed x mean_force x damping sweep, ``by="mean_force"`` drew 4 lines, "400 N" and
    "833 N" twice each, the damping named nowhere; with a continued sweep's ``direction`` it was
    a matplotlib shape error; the default ``by="torque"`` on a mean_force sweep a KeyError (an
    outside tester). Now as ``plot_response_vs_speed``: the other dim at its first value, in the
    title; each direction drawn; a ``by`` not swept one line naming those that are."""
    ds = _swept_three()
    fig, ax = plt.subplots()
    plot_response_by_load(ax, ds, by="mean_force", variable="p_rms")
    lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith(("_", "grey"))]
    assert [ln.get_label() for ln in lines] == ["mean force = 400 N", "mean force = 833 N"]
    for i, ln in enumerate(lines):
        assert_allclose(ln.get_ydata(), ds.p_rms.values[:, i, 0])  # um, at c = 5.5 N s/mm
    assert ax.get_title() == "rms of p at c = 5.5 N s/mm (select others with ds.sel)"
    fig, ax = plt.subplots()
    both = _swept_three(direction=True)
    plot_response_by_load(ax, both, by="damping", relative=True)
    lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith(("_", "grey"))]
    assert [ln.get_label() for ln in lines] == [
        "c = 5.5 N s/mm, run-up", "c = 5.5 N s/mm, run-down", "c = 2 N s/mm, run-up",
        "c = 2 N s/mm, run-down"]
    p = both.p_rms.values[:, 0]  # at 400 N
    assert_allclose(lines[3].get_ydata(), p[:, 1, 1] / p[:, 0, 1])  # down over down
    assert lines[0].get_color() == lines[1].get_color() != lines[2].get_color()
    assert "mean force = 400 N" in ax.get_title()
    with pytest.raises(ValueError, match=r"^by='torque': one of the dims 'p_rms' sweeps besides"
                                         r" speed: mean_force, damping$"):
        plot_response_by_load(ax, ds)
    plt.close("all")


def test_a_variable_alone_is_refused_naming_the_dataset_expected():
    """``plot_response_vs_speed(ds.p_rms)``, a natural notebook slip, said the result had "no
    'p_pp'"; ``plot_response_by_load(ax, ds.p_rms)`` failed inside. One line naming ``ds`` and
    the call to make (a variable alone has no ``status`` to mask the cases not settled)."""
    from gearsweep.plot.sweep import plot_response_vs_speed

    ds = _swept_three()
    with pytest.raises(ValueError, match=r"^ds: a result's Dataset, with the variable named apart"
                                         r" \(plot_response_vs_speed\(ds, 'p_rms'\)\), not a"
                                         r" DataArray \('p_rms'\)$"):
        plot_response_vs_speed(ds.p_rms)
    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match=r"^ds: .*variable='p_rms'\)\), not a DataArray"):
        plot_response_by_load(ax, ds.p_rms, by="mean_force")
    plt.close("all")


def test_a_baseline_that_is_not_one_of_the_loads_is_named_in_one_line():
    """``baseline=`` not among the values of ``by`` was a raw KeyError from ``sel`` (an outside
    tester's note); now one line naming the values there are, in the result's unit, and a value
    given to within round-off (25.000000001 for 25 N m) is that value."""
    ds = _three_loads()
    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match=r"^baseline=30\.0: one of the result's values of "
                                         r"'torque' \[N m\]: 12\.5, 25, 50$"):
        plot_response_by_load(ax, ds, by="torque", relative=True, baseline=30.0)
    plot_response_by_load(ax, ds, by="torque", relative=True, baseline=25.000000001)
    assert ax.get_ylabel() == "p_rms / p_rms at torque = 25 N m [-]"
    plt.close("all")
