"""What a figure script writes into its titles and labels follows from the result it draws: run
on a small result, then on the same result changed, the words change with it (an outside
reviewer found verdicts typed into titles, true or not of the data beside them)."""

from __future__ import annotations

import re
import runpy
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402
from numpy.testing import assert_allclose  # noqa: E402

import gearsweep  # noqa: E402
import gearsweep.plot.common as common  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def small_rig(name: str = "rig_low_speed") -> str:
    """studies/<name>.yaml (the rig, or its profile-shift reading), small: 5 stiffness
    harmonics, 3 speeds, orders 0-4."""
    text = (ROOT / "studies" / f"{name}.yaml").read_text(encoding="utf-8")
    small = (text.replace("harmonics: 60", "harmonics: 5").replace("num: 121", "num: 3")
             .replace("steps_per_period: 2048", "steps_per_period: 512")
             .replace("max_order: 64, samples_per_period: 512",
                      "max_order: 4, samples_per_period: 128"))
    assert small.count("harmonics: 5") == 1 and "num: 3" in small and "max_order: 4" in small
    return small


@pytest.fixture(scope="module")
def rig(tmp_path_factory) -> xr.Dataset:
    folder = tmp_path_factory.mktemp("rig")
    gearsweep.run(small_rig(), output=folder / "rig_low_speed.nc")
    return xr.load_dataset(folder / "rig_low_speed.nc")


@pytest.fixture(scope="module")
def shift(tmp_path_factory) -> xr.Dataset:
    """The same, with the profile-shift reading of Table 1 (8.9 N m), which Fig. 11 draws beside
    the consistent reading's ratios."""
    folder = tmp_path_factory.mktemp("shift")
    gearsweep.run(small_rig("rig_low_speed_profile_shift"),
                  output=folder / "rig_low_speed_profile_shift.nc")
    return xr.load_dataset(folder / "rig_low_speed_profile_shift.nc")


def draw(script: str, results: Path, tmp_path: Path, monkeypatch,
         *extra: str) -> dict[str, plt.Figure]:
    """Run ``scripts/<script>`` on ``results`` (``extra``: more arguments); the figures it
    saves, by file name, open."""
    saved = {}

    def keep(fig, path, dpi=130):
        saved[Path(path).name] = fig
        return Path(path)

    monkeypatch.setattr(common, "save", keep)
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    monkeypatch.setattr(sys, "argv", [script, "--results", str(results), "--figures",
                                      str(tmp_path / "figures"), *extra])
    runpy.run_path(str(ROOT / "scripts" / script), run_name="__main__")
    return saved


def rig_figures(ds: xr.Dataset, shift: xr.Dataset, tmp_path: Path,
                monkeypatch) -> dict[str, plt.Figure]:
    results = tmp_path / "results"
    results.mkdir(exist_ok=True)
    ds.to_netcdf(results / "rig_low_speed.nc")
    shift.to_netcdf(results / "rig_low_speed_profile_shift.nc")
    return draw("fig11_low_speed.py", results, tmp_path, monkeypatch)


def test_fig12_says_theta2_in_urad_as_the_axis_value_over_r2_in_metres(rig, shift, tmp_path,
                                                                       monkeypatch, capsys):
    """The y label said "θ2 rms [µrad] = this / 37.6 mm": 0.143 / 37.6 = 0.0038, not the
    3.8 µrad it is (µm / m = µrad)."""
    ax = rig_figures(rig, shift, tmp_path, monkeypatch)["fig12_rig_rms.png"].axes[0]
    r2 = gearsweep.result_study(rig).scene.drive.base_radius_2
    assert f"(θ2 rms [µrad] = this [µm] / r2 [m], r2 = {r2:.4f} m)" in ax.get_ylabel()
    plt.close("all")


def test_fig12_and_fig11_verdicts_follow_the_curves_they_draw(rig, shift, tmp_path, monkeypatch,
                                                              capsys):
    """"the curves coincide" (Fig. 12, per load) and "they change with speed, not with load"
    (Fig. 11, ratios of order lines) were typed: now the spread between the loads is read
    from the result, and a result whose loads differ says so."""
    figs = rig_figures(rig, shift, tmp_path, monkeypatch)
    per_load = figs["fig12_rig_rms.png"].axes[1].get_title()
    ratios = figs["fig11_low_speed.png"].axes[2].get_title()
    assert "(they coincide: response proportional to load)" in per_load
    assert re.search(r"differ by at most \de-\d+ of their mean", per_load), per_load
    assert re.search(r"differ by at most \de-\d+ of their mean", ratios), ratios
    plt.close("all")
    changed = rig.copy(deep=True)
    changed["pinion_rms"].loc[{"torque": 2.0}] *= 1.1  # no longer proportional to the load
    changed["pinion_spectrum"].loc[{"torque": 2.0, "order": 2.0}] *= 1.2
    figs = rig_figures(changed, shift, tmp_path, monkeypatch)
    per_load = figs["fig12_rig_rms.png"].axes[1].get_title()
    ratios = figs["fig11_low_speed.png"].axes[2].get_title()
    assert "coincide" not in per_load and "differ by at most 0.1 of their mean" in per_load
    assert "differ by at most 0.2 of their mean" in ratios
    plt.close("all")


def test_fig11_gives_the_order_lines_change_to_a_tenth_of_a_percent(rig, shift, tmp_path,
                                                                    monkeypatch, capsys):
    """The change of orders 1-3 from 200 to 800 rpm was printed with ``+.0%``: order 1's
    -0.89 % read "-1%", where docs/REPRODUCTION.md says "less than 1 %"."""
    title = rig_figures(rig, shift, tmp_path, monkeypatch)["fig11_low_speed.png"].axes[1].get_title()
    changes = re.search(r" 1: (\S+), 2: (\S+), 3: (\S+)$", title)
    assert changes, title
    x = rig["pinion_spectrum"].sel(torque=8.9, damping=5.5)
    for n, text in zip((1, 2, 3), changes.groups(), strict=True):
        line = x.sel(order=float(n)).values
        assert text == f"{line[-1] / line[0] - 1:+.1%}"
    plt.close("all")


@pytest.mark.filterwarnings("ignore::gearsweep.errors.ContactLossWarning")  # (the study's own)
def test_fig05_order_sources_shows_every_order_line_it_names(tmp_path, monkeypatch, capsys):
    """Panel (b), the STE off, named orders 8-10 in its legend while their peaks (5.8e-5 to
    4.6e-6 um) lay under its fixed lower limit of 1e-4 um: the limit now goes down to the decade
    under the smallest peak drawn."""
    results = tmp_path / "results"
    for name in ("fig05_waterfall", "fig05_waterfall_no_ste", "fig05_waterfall_no_ripple"):
        text = (ROOT / "studies" / f"{name}.yaml").read_text(encoding="utf-8")
        assert text.count("num: 2000") == 1
        gearsweep.run(text.replace("num: 2000", "num: 25"), output=results / f"{name}.nc")
    fig = draw("fig05_waterfall.py", results, tmp_path, monkeypatch)["fig05_order_sources.png"]
    for ax in fig.axes:
        low, high = ax.get_ylim()
        lines = [ln for ln in ax.get_lines() if ln.get_label().startswith("order ")]
        assert len(lines) == 10
        for ln in lines:
            assert low <= np.nanmax(ln.get_ydata()) <= high, (ax.get_title(loc="left"), ln.get_label())
    plt.close("all")


def small(name: str, *swaps: tuple[str, str]) -> str:
    """studies/<name>.yaml with each (old, new) of ``swaps`` replaced once."""
    text = (ROOT / "studies" / f"{name}.yaml").read_text(encoding="utf-8")
    for old, new in swaps:
        assert text.count(old) == 1, (name, old)
        text = text.replace(old, new)
    return text


@pytest.mark.filterwarnings("ignore::gearsweep.errors.StepLimitWarning")  # (the study's own)
def test_fig7_2_methods_title_counts_the_floquet_unstable_cases(tmp_path, monkeypatch, capsys):
    """The title said "(Floquet: stable everywhere)", typed: now it counts the converged
    Floquet multipliers above 1 in the rig result the map is drawn on, and says another thing
    when one is."""
    results = tmp_path / "results"
    dampings = ("damping: [0 N*s/m, 10 N*s/m, 100 N*s/m, 500 N*s/m, 1 N*s/mm, 2 N*s/mm,"
                " 5.5 N*s/mm, 10 N*s/mm]")
    steps = ("steps_per_period: [100, 120, 140, 160, 180, 200, 220, 240, 260, 280, 300, 320,"
             " 340, 360, 380, 400, 420]")
    gearsweep.run(small("stability_rig", ("num: 96", "num: 3"),
                        (dampings, "damping: [0 N*s/m, 5.5 N*s/mm]")),
                  output=results / "stability_rig.nc")
    gearsweep.run(small("stability_artifact_map",
                        ("methods: [rk5, fehlberg5, cashkarp5, dopri5]", "methods: [rk5]"),
                        (steps, "steps_per_period: [100, 200]")),
                  output=results / "stability_artifact_map.nc")
    rig = xr.load_dataset(results / "stability_rig.nc")
    assert not rig.unstable.any()

    def title() -> str:
        fig = draw("fig_stability.py", results, tmp_path, monkeypatch, "--only", "methods")
        return fig["fig7_2_methods.png"].get_suptitle()

    assert "the equation is stable at all 6 cases of the grid (Floquet" in title()
    plt.close("all")
    rig["unstable"][{"speed": 1, "damping": 0}] = True
    rig.to_netcdf(results / "stability_rig.nc")
    said = title()
    assert "the equation is unstable at 1 of 6 cases of the grid (Floquet" in said
    assert "stable at all" not in said and "artifact" not in said
    plt.close("all")


def test_whine_gear_table1_title_says_where_its_unsettled_cases_lie(tmp_path, monkeypatch,
                                                                     capsys):
    """The title explained its masked cases as "the parametric tongue near twice f_n and its
    slow edges", typed: now it gives, per damping, the mesh frequencies of the cases not
    settled over f_n, read from the result (and nothing where every case settled); where they
    span twice f_n, that they lie mostly in the principal parametric tongue, which
    docs/REPRODUCTION.md checks (the result holds no Floquet multiplier to count them by)."""
    results = tmp_path / "results"
    gearsweep.run(small("whine_gear_table1", ("num: 400", "num: 4"),
                        ("record_periods: 50", "record_periods: 8")),
                  output=results / "whine_gear_table1.nc")
    ds = xr.load_dataset(results / "whine_gear_table1.nc")
    assert not (ds.status != 0).any()

    def title() -> str:
        fig = draw("fig_whine_gear_table1.py", results, tmp_path, monkeypatch)
        return fig["whine_gear_table1.png"].axes[0].get_title()

    said = title()
    assert said.endswith("0 of 8 cases not settled, masked"), said
    plt.close("all")
    ds["status"][{"speed": 2, "damping": 1}] = 2
    ds["status"][{"speed": 3, "damping": 1}] = 2
    ds.to_netcdf(results / "whine_gear_table1.nc")
    f_n = np.sqrt(gearsweep.result_model(ds).stiffness / 0.1527) / (2 * np.pi)
    lo, hi = ds.mesh_frequency.values[2:4] / f_n
    assert lo < 2.0 < hi  # they span twice f_n: the title points to the tongue's check
    assert title().endswith(f"2 of 8 cases not settled, masked (2 at c = 5.5 N s/mm, mesh"
                            f" frequency {lo:.2f}-{hi:.2f} f_n)\nnot settled: most in the"
                            " principal parametric tongue (docs/REPRODUCTION.md)")
    plt.close("all")
    ds["status"][{"speed": 2, "damping": 1}] = 0  # speed 3 alone: not near twice f_n
    ds.to_netcdf(results / "whine_gear_table1.nc")
    assert title().endswith(f"1 of 8 cases not settled, masked (1 at c = 5.5 N s/mm, mesh"
                            f" frequency {hi:.2f}-{hi:.2f} f_n)")
    plt.close("all")


def test_fig11_draws_the_profile_shift_reading_beside_the_consistent_one(rig, shift, tmp_path,
                                                                        monkeypatch, capsys):
    """docs/REPRODUCTION.md quotes order 2 / order 1 for both readings of Table 1 (0.55-0.57 and
    0.20-0.23), but no figure drew rig_low_speed_profile_shift: now Fig. 11's ratio panel draws
    its order 2 / 1 and 3 / 1, labelled, and its title gives their ranges, read from the result
    (a changed result changes them)."""
    def panel(profile_shift):
        return rig_figures(rig, profile_shift, tmp_path, monkeypatch)["fig11_low_speed.png"].axes[2]

    c0 = float(rig.damping[0])
    x = shift.pinion_spectrum.sel(damping=c0)
    ax = panel(shift)
    for n in (2, 3):
        drawn = [ln for ln in ax.get_lines()
                 if ln.get_label() == f"order {n} / order 1, profile-shift reading, T1 = 8.9 N m"]
        assert len(drawn) == 1
        assert_allclose(drawn[0].get_ydata(), x.sel(order=float(n)) / x.sel(order=1.0))
    r = x.sel(order=2.0) / x.sel(order=1.0)
    assert (f"profile-shift reading (dash-dot, 8.9 N m): 2 / 1: {float(r.min()):.3f}-"
            f"{float(r.max()):.3f}") in ax.get_title()
    plt.close("all")
    changed = shift.copy(deep=True)
    changed["pinion_spectrum"].loc[{"order": 2.0}] *= 2.0
    assert (f"2 / 1: {2 * float(r.min()):.3f}-{2 * float(r.max()):.3f}"
            in panel(changed).get_title())
    plt.close("all")
