"""What the plot functions do with what they are given (an outside tester's findings on a 23/61
pair): a result's variables in their own unit, a variable that is no flag, repeated calls."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402
from numpy.testing import assert_allclose  # noqa: E402

import gearsweep  # noqa: E402
from gearsweep.plot.mesh import (  # noqa: E402
    plot_backlash_stiffness,
    plot_ste,
    plot_ste_harmonics,
    plot_ste_vs_load,
)

MESH = """
type: mesh
title: plot inputs
gear: {module: 3 mm, z1: 23, z2: 61, face_width: 20 mm, pressure_angle: 20 deg, x1: 0.3,
       x2: -0.1, backlash: 0.08 mm}
sweep:
  torque: [30 N m, 120 N m, 180 N m]
positions: 60
harmonics: 4
"""


@pytest.fixture(scope="module")
def mesh():
    out = gearsweep.run(MESH)
    yield out
    plt.close("all")


def test_a_results_variables_are_drawn_in_their_unit_not_as_si(mesh):
    """``plot_ste_vs_load(ax, ds.torque, pp, h1)`` with the result's DataArrays (STE in um) drew
    the STE 1e6 times too large, 8e6 "um" (the function takes SI arrays): a DataArray with a
    ``units`` attribute is read in that unit; the same numbers in m, or as a plain SI array,
    give the same lines."""
    assert mesh["ste"].attrs["units"] == "um"
    pp = mesh["ste"].max("mesh_phase") - mesh["ste"].min("mesh_phase")
    pp.attrs["units"] = "µm"  # as a reader would write it
    h1 = mesh["ste_harmonic"].sel(harmonic=1)
    expected_pp = pp.values  # um, as drawn
    fig, ax = plt.subplots()
    plot_ste_vs_load(ax, mesh["torque"], pp, h1)
    assert_allclose(ax.lines[0].get_ydata(), expected_pp, rtol=1e-12)
    assert_allclose(ax.lines[1].get_ydata(), h1.values, rtol=1e-12)
    assert_allclose(ax.lines[0].get_xdata(), [30.0, 120.0, 180.0])
    assert ax.get_ylim()[1] < 2 * expected_pp.max()  # was 8e6
    in_m = xr.DataArray(pp.values * 1e-6, dims=pp.dims, attrs={"units": "m"})
    fig, bx = plt.subplots()
    plot_ste_vs_load(bx, mesh["torque"].values, in_m, h1.values * 1e-6)  # m, and plain SI
    assert_allclose(bx.lines[0].get_ydata(), expected_pp, rtol=1e-12)
    assert_allclose(bx.lines[1].get_ydata(), h1.values, rtol=1e-12)
    # a torque in kN m is a torque, read as such; a length for a torque is refused, by name
    fig, cx = plt.subplots()
    plot_ste_vs_load(cx, xr.DataArray([0.03, 0.12, 0.18], attrs={"units": "kN m"}), in_m, in_m)
    assert_allclose(cx.lines[0].get_xdata(), [30.0, 120.0, 180.0])
    with pytest.raises(ValueError, match=r"torque is a torque, given in 'mm': that is a length"):
        plot_ste_vs_load(cx, xr.DataArray([1.0, 2.0, 3.0], attrs={"units": "mm"}), in_m, in_m)


def test_the_other_array_taking_mesh_plots_read_a_unit_too(mesh):
    """plot_ste with arrays, plot_ste_harmonics and plot_backlash_stiffness took a result's
    variables as SI as well (um as m, kN/mm as N/m, mm as m)."""
    one = mesh.sel(torque=120.0)
    fig, ax = plt.subplots()
    plot_ste(ax, one["mesh_phase"].values, one["ste"], cycles=1)
    assert_allclose(ax.lines[0].get_ydata()[:-1], one["ste"].values, rtol=1e-12)  # um
    fig, ax = plt.subplots()
    plot_ste_harmonics(ax, {"a": one["ste_harmonic"]}, orders=3)
    heights = [p.get_height() for p in ax.patches]
    assert_allclose(heights, one["ste_harmonic"].values[1:4], rtol=1e-12)
    fig, ax = plt.subplots()
    k = xr.DataArray(400.0, attrs={"units": "kN mm-1"})  # a result's stiffness: 4e8 N/m
    b = xr.DataArray(0.4, attrs={"units": "mm"})
    plot_backlash_stiffness(ax, k, b, mean_force=xr.DataArray(3.7, attrs={"units": "kN"}))
    p, force = ax.lines[0].get_data()
    assert_allclose(p, [-0.5, -0.2, 0.2, 0.5], rtol=1e-12)  # mm
    assert_allclose(force, [-4e8 * 0.3e-3 / 1e3, 0.0, 0.0, 4e8 * 0.3e-3 / 1e3], rtol=1e-12)
    assert ax.lines[-1].get_ydata()[0] == pytest.approx(3.7)  # kN


def test_several_ste_curves_on_one_axes_have_one_single_pair_entry(mesh):
    """Three plot_ste calls (three torques) on one axes gave three "single pair" legend entries:
    one per axes, whatever the calls."""
    fig, ax = plt.subplots()
    for t in (30.0, 120.0, 180.0):
        plot_ste(ax, mesh.sel(torque=t))
    labels = [t.get_text() for t in ax.legend().get_texts()]
    assert labels == ["single pair", "T = 30 N m", "T = 120 N m", "T = 180 N m"]


def _stability_result() -> xr.Dataset:
    """A result over speed x damping as a ``floquet`` study writes it (damping in N s/mm)."""
    speed = xr.DataArray([5000.0, 10000.0, 20000.0, 40000.0], dims="speed",
                         attrs={"units": "rpm"})
    damping = xr.DataArray([0.05, 0.5, 5.0], dims="damping", attrs={"units": "N s mm-1"})
    mu = xr.DataArray(np.array([[0.5, 0.9, 1.2], [0.6, 1.1, 0.7], [0.4, 0.8, 0.95],
                                [1.05, 0.3, 0.2]]), dims=("speed", "damping"),
                      coords={"speed": speed, "damping": damping}, attrs={"units": "1"})
    ds = xr.Dataset({"floquet_multiplier": mu, "unstable": mu > 1 + 1e-6})
    ds["status"] = (mu * 2).astype(np.int8)  # 0, 1 and 2: a code, not a flag
    ds["bits"] = (mu > 1).astype(np.int64)  # integers 0 and 1: a flag
    return ds


def test_stability_map_refuses_a_variable_that_is_no_flag():
    """``plot_stability_map(ds, "floquet_multiplier")`` drew the whole map red, "(480 of 480)":
    the variable went through ``astype(bool)``. A yes/no map takes a flag (bool, or integers 0
    and 1 only); anything else is one ValueError naming it, its dtype and range, and the flags
    or a condition to give instead."""
    from gearsweep.plot.stability import plot_stability_map

    ds = _stability_result()
    with pytest.raises(ValueError, match=r"plot_stability_map draws a yes/no flag \(unstable,"
                       r" integrator_unstable.*ds.floquet_multiplier > 1.*\); 'floquet_multiplier'"
                       r" is float64 with values 0.2 to 1.2, not a flag"):
        plot_stability_map(ds, "floquet_multiplier")
    with pytest.raises(ValueError, match=r"'status' is int8 with values 0 to 2, not a flag"):
        plot_stability_map(ds, "status")
    for var, label in (("unstable", "unstable (3 of 12)"), ("bits", "bits (3 of 12)"),
                       (ds.floquet_multiplier > 1, "flagged (3 of 12)")):
        ax = plot_stability_map(ds, var).axes[0]
        assert [t.get_text() for t in ax.get_legend().get_texts()] == [label]
        image = np.asarray(ax.collections[0].get_array()).reshape(3, 4)  # (damping, speed)
        assert_allclose(image, (ds.floquet_multiplier.values > 1).T)
    plt.close("all")


def test_operating_map_reads_a_damping_coordinate_in_its_unit_and_refuses_a_non_flag():
    """plot_operating_map takes SI arrays (damping in N s/m): the result's ``ds.damping`` (N s/mm)
    given as it is was drawn 1000 times too low; it is read in its unit now. A float array is
    no flag (was drawn as 0/1 clipped)."""
    from gearsweep.plot.stability import plot_operating_map

    ds = _stability_result()
    flag = ds.unstable.transpose("damping", "speed").values
    fig, ax = plt.subplots()
    plot_operating_map(ds.speed, ds.damping, flag, ax=ax)
    rows = [x.get_text() for x in ax.get_yticklabels()]  # one row per damping, in N s/mm
    assert rows == [f"{c:g}" for c in ds.damping.values]
    fig, bx = plt.subplots()
    plot_operating_map(ds.speed.values, ds.damping.values * 1e3, flag, ax=bx)  # plain SI
    assert [x.get_text() for x in bx.get_yticklabels()] == rows
    with pytest.raises(ValueError, match=r"plot_operating_map draws a yes/no flag .* flag is"
                                         r" float64 with values 0.2 to 1.2, not a flag"):
        plot_operating_map(ds.speed.values, ds.damping.values * 1e3,
                           ds.floquet_multiplier.transpose("damping", "speed").values)
    plt.close("all")


def test_rattle_array_plots_read_a_results_units():
    """plot_fig8 and plot_rattle_map take SI arrays; a result's variables and coordinates
    (amplitude in um, backlash in mm, damping in N s/mm) given as they are were drawn as SI
    (um as m: 1e6 too large in the amplitude's mm, the damping axis 1000 times too low)."""
    from gearsweep.plot.rattle import plot_fig8, plot_rattle_map

    speed = xr.DataArray([5000.0, 6000.0, 7000.0], dims="speed", attrs={"units": "rpm"})
    up = xr.DataArray([100.0, 250.0, 40.0], dims="speed", attrs={"units": "um"})
    fig, ax = plt.subplots()
    plot_fig8(ax, speed, up, up.values * 1e-6, half_gap=xr.DataArray(0.1, attrs={"units": "mm"}))
    assert_allclose(ax.lines[0].get_ydata(), [0.1, 0.25, 0.04])  # mm
    assert_allclose(ax.lines[1].get_ydata(), [0.1, 0.25, 0.04])  # plain SI, as before
    assert ax.lines[2].get_ydata()[0] == pytest.approx(0.1)  # backlash / 2 [mm]
    damping = xr.DataArray([0.5, 5.0], dims="damping", attrs={"units": "N s mm-1"})
    torque = xr.DataArray([10.0, 20.0, 30.0], dims="torque", attrs={"units": "N m"})
    backlash = xr.DataArray([0.1, 0.2], dims="backlash", attrs={"units": "mm"})
    share = np.linspace(0, 1, 12).reshape(2, 2, 3)
    fig, axes = plt.subplots(2, 2)
    plot_rattle_map(list(axes[0]), list(axes[1]), damping, torque, backlash, share, share * 100)
    assert axes[0][0].get_ylim()[1] <= 10.0 and axes[0][0].get_ylim()[0] >= 0.1  # N s/mm
    assert [a.get_title() for a in axes[0]] == ["backlash 0.1 mm", "backlash 0.2 mm"]
    plt.close("all")


def test_rattle_map_says_what_its_grey_cells_are_and_how_many():
    """rattle_map.png explained its grey cells only as "cannot be judged, see jump_unsupported"
    (an outside reviewer): the colour bar's label says what a grey cell is (the jump cannot be
    judged) and how many of the map's cells are grey (NaN widths); scripts/fig_rattle.py's title
    says why in words."""
    from gearsweep.plot.rattle import plot_rattle_map

    share = np.linspace(0, 1, 12).reshape(2, 2, 3)
    width = share * 100
    width[0, 1, 2] = width[1, 0, 0] = width[1, 1, 1] = np.nan
    fig, axes = plt.subplots(2, 2)
    plot_rattle_map(list(axes[0]), list(axes[1]), [500.0, 5000.0], [10.0, 20.0, 30.0],
                    [1e-4, 2e-4], share, width)
    label = fig.axes[-1].get_ylabel()  # the hysteresis colour bar
    assert label.endswith("\n(grey: 3 of 12 cells, the jump cannot be judged)"), label
    fig, axes = plt.subplots(2, 2)
    plot_rattle_map(list(axes[0]), list(axes[1]), [500.0, 5000.0], [10.0, 20.0, 30.0],
                    [1e-4, 2e-4], share, share * 100)
    assert "grey" not in fig.axes[-1].get_ylabel()
    plt.close("all")


def test_ste_vs_load_says_which_line_is_which(mesh):
    """plot_ste_vs_load drew a solid and a dashed line with no legend (the tester's figure:
    two lines unexplained), and its labels ended in a space without ``label``."""
    pp = mesh["ste"].max("mesh_phase") - mesh["ste"].min("mesh_phase")
    h1 = mesh["ste_harmonic"].sel(harmonic=1)
    fig, ax = plt.subplots()
    plot_ste_vs_load(ax, mesh["torque"], pp, h1)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["peak-to-peak",
                                                                   "1st harmonic"]
    plot_ste_vs_load(ax, mesh["torque"], pp * 0.5, h1 * 0.5, label="relief")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "peak-to-peak", "1st harmonic", "peak-to-peak relief", "1st harmonic relief"]
    plt.close(fig)
