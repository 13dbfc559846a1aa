"""The streamed writer without xarray (``gearsweep.study.resultfile``) against xarray itself.

``ResultFile`` encodes a result as xarray does (CF fill values, booleans, ``coordinates``,
strings) with netCDF4 alone; the truth it is held to is the file xarray's ``to_netcdf`` writes of
the same result (``dataset.write_netcdf(assemble(...))``), for every study of ``studies/``: the
same dimensions, variables in the same order, each with the same dims, dtype, chunks, filters,
fill value, attributes (in order) and bytes, and the same global attributes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from gearsweep.study.dataset import assemble, write_netcdf
from gearsweep.study.plan import make_plan
from gearsweep.study.resultfile import Description, ResultFile, Var, encoded, result_layout
from gearsweep.study.schema import load_study

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ROOT / "studies"
HEAVY = {"rattle_map"}
"""Studies too large to fill with random numbers here (the 1e6 and 1e7 ones live in heavy/)."""

VARYING = ("history", "elapsed_seconds", "kernel_seconds")
"""Global attributes that differ between two writes (time stamp, timings)."""


def _studies() -> list[Path]:
    return [p for p in sorted(STUDIES.glob("*.yaml")) if p.stem not in HEAVY
            and getattr(load_study(str(p))[0], "type", None) not in ("mesh", "analysis")]


def _attr(value):
    a = np.asarray(value)
    return (a.dtype.str, a.tolist()) if a.dtype.kind != "f" else (a.dtype.str, a.tobytes())


def _anatomy(path: Path) -> dict:
    """Everything of a netCDF file that a reader can see, in order, values as bytes."""
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_maskandscale(False)
        variables = []
        for name, v in nc.variables.items():
            data = v[...]
            raw = (data.tolist() if v.dtype is str else np.ascontiguousarray(data).tobytes())
            fill = v.get_fill_value()
            variables.append((name, v.dimensions, str(v.dtype), v.chunking(), v.filters(),
                              v.endian(), None if fill is None else _attr(fill),
                              [(k, _attr(v.getncattr(k))) for k in v.ncattrs()], raw))
        return {"dimensions": [(d, len(n), n.isunlimited()) for d, n in nc.dimensions.items()],
                "variables": variables,
                "attributes": [(k, None if k in VARYING else _attr(nc.getncattr(k)))
                               for k in nc.ncattrs()]}


def _random_results(plan, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    out = {}
    for name, (shape, dtype) in result_layout(plan, plan.n_lanes).items():
        if dtype.kind == "b":
            out[name] = rng.random(shape) < 0.5
        elif dtype.kind == "f":
            a = rng.standard_normal(shape).astype(dtype)
            a.ravel()[::7] = np.nan  # the fill value among the data
            out[name] = a
        else:
            out[name] = rng.integers(0, 5, shape).astype(dtype)
    return out


@pytest.mark.parametrize("path", _studies(), ids=lambda p: p.stem)
def test_the_streamed_file_is_xarray_s_file(tmp_path, path):
    """For each study: ``ResultFile`` (chunks written out of order, as the writer thread may)
    gives the file xarray writes of ``assemble``'s Dataset of the same results."""
    study, text = load_study(str(path))
    plan = make_plan(study, text, str(path))
    results = _random_results(plan)
    ref = tmp_path / "xarray.nc"
    write_netcdf(assemble(plan, results, elapsed=1.0, kernel=0.5), ref)
    out = tmp_path / "streamed.nc"
    f = ResultFile(plan, out)
    chunks = plan.chunks(max(1, plan.n_lanes // 3))
    for a, b in reversed(chunks):
        f.write(a, b, {k: v[:, a:b] if plan.continued else v[a:b] for k, v in results.items()})
    f.close(elapsed=1.0, kernel=0.5)
    want, got = _anatomy(ref), _anatomy(out)
    assert [v[0] for v in got["variables"]] == [v[0] for v in want["variables"]]
    for w, g in zip(want["variables"], got["variables"], strict=True):
        assert g == w, w[0]
    assert got == want


def test_an_auxiliary_coordinate_on_no_variable_is_named_globally(tmp_path):
    """xarray's rule, which no study of studies/ exercises: an auxiliary coordinate whose dims
    no data variable has goes into a global ``coordinates`` attribute; one that fits a variable
    goes into that variable's, sorted by name."""
    import xarray as xr

    desc = Description({
        "p": Var(("x",), np.arange(3.0), {"units": "1"}),
        "x": Var(("x",), np.arange(3), {"units": "1"}, coord=True),
        "lonely": Var(("y",), np.arange(2.0), {"units": "1"}, coord=True),
        "b_aux": Var(("x",), np.arange(3.0), {"units": "1"}, coord=True),
        "a_aux": Var(("x",), np.arange(3.0), {"units": "1"}, coord=True),
    }, {"title": "t"})
    ds = xr.Dataset({k: xr.Variable(v.dims, v.values, v.attrs) for k, v in desc.variables.items()}
                    ).set_coords(["lonely", "b_aux", "a_aux"])
    ref = tmp_path / "ref.nc"
    ds.attrs.update(desc.attrs)
    ds.to_netcdf(ref, encoding={k: {"_FillValue": None} for k in ds.coords})
    with netCDF4.Dataset(ref) as nc:
        want = (nc.getncattr("coordinates"), nc["p"].getncattr("coordinates"))
    args = {name: attrs for name, _, attrs, _ in encoded(desc)}
    assert want == ("lonely", "a_aux b_aux") and args["p"]["coordinates"] == want[1]


def test_an_unknown_dtype_is_refused_not_guessed():
    desc = Description({"when": Var(("x",), np.array(["2026-01-01"], "datetime64[D]"), {})}, {})
    with pytest.raises(TypeError, match="when"):
        encoded(desc)


def test_gearsweep_run_imports_neither_xarray_nor_pandas(tmp_path):
    """``gearsweep run`` of a chunked study streams its file without xarray (and pandas, which it
    brings: 0.3 s of CPU beside the kernel); the file is read back by xarray as usual."""
    out = tmp_path / "r.nc"
    code = ("import sys; from gearsweep.cli import main; "
            f"code = main(['run', {str(STUDIES / 'whine_speed_sweep.yaml')!r}, '-o', {str(out)!r},"
            " '-q', '--yes']); "
            "print(code, sorted(m for m in ('xarray', 'pandas', 'dask') if m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)), check=True)
    assert r.stdout.split("\n")[-2] == "0 []", r.stdout + r.stderr
    import xarray as xr

    with xr.open_dataset(out) as ds:
        assert ds["p_pp"].attrs["units"] == "um" and ds["speed"].attrs["units"] == "rpm"
        assert json.loads(ds.attrs["model"])


@pytest.mark.parametrize(("name", "want"), [
    ("stability_rig", {"initial_displacement_um": 1.0, "initial_velocity_mm_per_s": 0.0}),
    ("rig_low_speed", {"initial_displacement_um": "static", "initial_velocity_mm_per_s": 0.0}),
    ("strutt_mathieu", {"initial_displacement": 1.0, "initial_velocity": 0.0}),
])
def test_the_solver_start_is_a_global_attribute(tmp_path, name, want):
    """The solver's start is stored with its other settings: stability_rig.yaml's verdict (the
    paper's criterion, growth by divergence_factor) hangs on its 1 um start, which was only in
    the study text (an outside tester's finding). In the display unit, named in the attribute
    (as ``elapsed_seconds``); a Mathieu scene's bare numbers under the study's names."""
    path = STUDIES / f"{name}.yaml"
    study, text = load_study(str(path))
    plan = make_plan(study, text, str(path))
    out = tmp_path / "r.nc"
    write_netcdf(assemble(plan, _random_results(plan), elapsed=1.0, kernel=0.5), out)
    with netCDF4.Dataset(out) as nc:
        got = {k: nc.getncattr(k) for k in nc.ncattrs() if k.startswith("initial_")}
    assert got == want


def test_the_harmonic_coordinate_is_what_data_format_says():
    """data-format.md said ``harmonic`` 0 is the mean for the gear scene's ``gear_*_harmonic``
    too, but a gear scene's runs 1..H (the mean is ``gear_stiffness``) while a mesh study's
    ``k_harmonic`` starts at 0, the mean (an outside tester's finding): the doc's row says each,
    and the files hold what it says."""
    import gearsweep

    row = next(line for line in (ROOT / "docs" / "data-format.md").read_text(
        encoding="utf-8").splitlines() if line.startswith("| `harmonic` |"))
    path = STUDIES / "whine_gear_table1.yaml"
    study, text = load_study(str(path))
    plan = make_plan(study, text, str(path))
    gear = assemble(plan, _random_results(plan), elapsed=1.0, kernel=0.5)
    assert gear["harmonic"].values.tolist() == list(range(1, gear.sizes["harmonic"] + 1))
    assert "gear_stiffness" in gear and gear["gear_stiffness_harmonic"].dims == ("harmonic",)
    assert f'`long_name` "{gear["harmonic"].attrs["long_name"]}"' in row
    assert "`gear_stiffness_harmonic` and `gear_ste_harmonic`" in row
    assert "run 1, ..., H with no mean" in row and "the mean stiffness is `gear_stiffness`" in row
    mesh = gearsweep.run("type: mesh\ntitle: m\ngear: table1_consistent\nsweep: {torque: [50 N m]}"
                         "\npositions: 40\nharmonics: 4\n")
    assert mesh["harmonic"].values.tolist() == [0, 1, 2, 3, 4]
    k = mesh["k_harmonic"].squeeze(drop=True)
    np.testing.assert_allclose(float(k.sel(harmonic=0)),
                               float(mesh["mesh_stiffness"].mean("mesh_phase").squeeze()), rtol=2e-2)
    assert f'`long_name` "{mesh["harmonic"].attrs["long_name"]}"' in row
    assert "run 0, 1, ..., H with 0 the mean" in row


def _documented_names() -> set[str]:
    """Names in the first cell of a table row of docs/data-format.md (``| `a`, `b` | ...``)."""
    import re

    names = set()
    for line in (ROOT / "docs" / "data-format.md").read_text(encoding="utf-8").splitlines():
        if line.startswith("| `"):
            names.update(re.findall(r"`([A-Za-z0-9_]+)`", line.split("|")[1]))
    return names


def test_every_variable_of_every_study_has_a_row_in_data_format():
    """data-format.md, the results' contract, had no row for ``impacts_per_period`` and
    ``settle_error``, which every backlash result (settle_error: every stats result) holds (an
    outside tester's finding): each data variable and coordinate of each study's result is now
    named in the first cell of a row."""
    documented = _documented_names()
    missing = {}
    for path in _studies():
        study, text = load_study(str(path))
        plan = make_plan(study, text, str(path))
        ds = assemble(plan, _random_results(plan), elapsed=1.0, kernel=0.5)
        absent = sorted(n for n in set(ds.variables) - documented  # (the doc says where the
                        if not n.startswith(("gear_", "excitation_")))  # gear_* ones are told)
        if absent:
            missing[path.stem] = absent
    assert not missing
