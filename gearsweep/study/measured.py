"""Your own STE and mesh stiffness: a scene's ``excitation: {file: ...}`` read from CSV or netCDF.

    scene:
      kind: whine
      excitation: {file: data/ste_table1.csv, harmonics: 10}   # path relative to the study file
      teeth: 48
      torque: 50 N*m
      base_radius: 56.38 mm
      ...

The file holds samples over one mesh cycle (``span: mesh_cycle``, the default) or over one
revolution of the driving gear (``span: revolution``) of the loaded static transmission error
and/or the mesh stiffness, each with its unit:

* CSV: a header line of column names with units in brackets, e.g.
  ``mesh_phase [1], ste [um], mesh_stiffness [N/mm]`` (comma, semicolon or tab separated; lines
  starting with ``#`` are comments);
* netCDF: 1-D variables over one coordinate, each with a ``units`` attribute (a ``type: mesh``
  study's result of one gear pair is such a file; over a swept ``torque``, the scene's torque is
  taken, and a torque it does not hold is refused).

A mesh study's result also holds its harmonics, integrated between the breaks of the mesh
(``k_harmonic``, ``ste_harmonic``, ``e_harmonic`` and their phases over ``harmonic``): a scene
over one mesh cycle takes those (:func:`gearsweep.gear.measured.integrated_excitation`), as the
``gear:`` scene of that pair does, not a fit of the samples, whose DFT is off by O(1/N) where k
jumps. Samples alone (CSV, other netCDF files) are fitted.

The position is ``mesh_phase`` (mesh cycles, unit ``1``) or ``angle`` / ``roll_angle`` (rotation of
the driving gear, the scene's ``teeth``, in an angle unit); the values are ``ste`` (or
``transmission_error``, a length) and ``mesh_stiffness`` (or ``stiffness``, N/m, N/mm, N/um,
kN/mm). Units are read by :mod:`gearsweep.units` (a column without a unit is refused, but
``mesh_phase``, a fraction of the mesh cycle: no unit is ``1``; a CSV column of another name, or
a netCDF variable whose name is a near miss of a value the file lacks: ``_columns``,
``_near_misses``). The fit is
:func:`gearsweep.gear.measured.measured_excitation`; this module only reads and checks the file.
"""

from __future__ import annotations

import csv
import difflib
import math
import re
import stat
import warnings
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, ValidationInfo, field_validator

from gearsweep.errors import NO_VALUE, article
from gearsweep.files import NotUtf8, user_path, utf8_text
from gearsweep.gear import GeometryWarning
from gearsweep.gear.measured import (
    FitError,
    MeasuredExcitation,
    fit_orders,
    integrated_excitation,
    measured_excitation,
    min_samples,
)
from gearsweep.model import Harmonic
from gearsweep.study.quantities import MAX_STE, STE_BEYOND, Count, Strict
from gearsweep.units import UnitParseError, to_si

POSITION = {"mesh_phase": "mesh_phase", "angle": "angle", "roll_angle": "angle"}
"""Column names of the position -> what it is (mesh cycles, or an angle of the driving gear)."""
VALUES = {"ste": ("ste", "displacement"), "transmission_error": ("ste", "displacement"),
          "mesh_stiffness": ("stiffness", "stiffness"), "stiffness": ("stiffness", "stiffness")}
"""Column names of the values -> (which, kind of quantity in ``gearsweep.units``)."""
DIMENSIONLESS = ("1", "-", "", "cycle", "cycles")


Series = tuple[np.ndarray, np.ndarray]
"""Amplitudes and phases [SI, rad] of Eq. (1) over orders 0..H (0: the mean)."""


@dataclass(frozen=True)
class Integrated:
    """A mesh study's harmonics of its mesh cycle, integrated between its breaks (SI)."""

    stiffness: Series
    """``k_harmonic`` [N/m], ``k_phase`` [rad]."""
    ste: Series
    """``ste_harmonic`` [m], ``ste_phase`` [rad]."""
    e: Series | None
    """``e_harmonic`` [m], ``e_phase`` [rad] (STE - F / k at the file's load); ``None`` in a
    result written before mesh studies stored it."""

    @property
    def harmonics(self) -> int:
        """The highest order H held."""
        return int(self.stiffness[0].size) - 1


INTEGRATED = {"stiffness": ("k_harmonic", "k_phase", "stiffness"),
              "ste": ("ste_harmonic", "ste_phase", "displacement"),
              "e": ("e_harmonic", "e_phase", "displacement")}
"""A mesh study's variables of its integrated harmonics (over ``harmonic``, 0..H): what -> (the
amplitude, the phase, the amplitude's kind in ``gearsweep.units``)."""


@dataclass(frozen=True)
class Samples:
    """A file's samples in SI: position (mesh cycles or radians), STE [m], stiffness [N/m]."""

    position: str
    """``mesh_phase`` (values in mesh cycles) or ``angle`` (radians of the driving gear)."""
    at: np.ndarray
    ste: np.ndarray | None
    stiffness: np.ndarray | None
    torque: float | None = None
    """The mean driving torque [N m] the file says its samples are at (a netCDF file's scalar
    ``torque``, as a mesh study writes it); ``None`` when it does not say."""
    base_radius: float | None = None
    """The driving gear's base radius [m] the file states (a mesh study's ``base_radius_1``)."""
    teeth: int | None = None
    """The driving gear's teeth the file states (a mesh study's 2 pi ``base_radius_1`` /
    ``base_pitch``)."""
    integrated: Integrated | None = None
    """A mesh study's integrated harmonics of k and the STE (``None``: the file has samples
    only)."""
    lines: tuple[int, ...] | None = None
    """The CSV line of each sample (``None``: a netCDF file, whose samples are said by index)."""
    stiffness_unit: tuple[str, str, float] | None = None
    """The stiffness column's name, its unit as written and N/m per that unit (``None``: no
    stiffness), to say a value in the unit written."""

    def mesh_phase(self, teeth: int) -> np.ndarray:
        return self.at if self.position == "mesh_phase" else self.at * teeth / (2.0 * math.pi)


def _factor(name: str, unit: str, kind: str, netcdf: bool = False) -> float:
    """SI per unit of a column (``um`` of an STE: 1e-6); ``netcdf``: of a netCDF variable,
    whose unit is its ``units`` attribute (the words of a CSV header told it to write one in
    its header: an outside tester)."""
    what = "variable" if netcdf else "column"
    if kind == "mesh_phase":
        if unit.strip().lower() in DIMENSIONLESS:
            return 1.0
        write = "units = '1'" if netcdf else "[1]"
        raise ValueError(f"{what} {name!r}: unit {unit!r} of a mesh phase; write {write} (mesh"
                         f" cycles) or give an 'angle' {what} in deg or rad")
    if not unit.strip():
        example = {'angle': 'deg', 'displacement': 'um'}.get(kind, 'N/mm')
        if netcdf:
            raise ValueError(f"variable {name!r} needs a 'units' attribute, e.g. units ="
                             f" '{example}'")
        raise ValueError(f"column {name!r} needs its unit in the header, e.g."
                         f" '{name} [{example}]'")
    example = {"angle": "deg or rad", "displacement": "um or m"}.get(kind, "N/mm or N/m")
    if unit.strip().lower() in DIMENSIONLESS:  # 'angle [1]' read "1 1": "a space inside a number"
        raise ValueError(f"{what} {name!r}: unit {unit!r} is no unit of {article(kind)}; write"
                         f" e.g. {example}")
    try:  # UDUNITS exponents of netCDF files (``N m-1``, ``kg m2``): units.normalise reads them
        f = to_si("1 " + unit, kind)
    except UnitParseError as exc:
        raise ValueError(f"{what} {name!r}: unit {unit!r}: {exc}") from None
    return f


def _columns(names: list[tuple[str, str]], header: int | None = None
             ) -> tuple[dict[str, int], dict[str, float], str]:
    """Which column is what: (which -> index, which -> SI factor, position kind).

    ``header``: the line of a CSV file's header, whose every column must be one of ``POSITION``
    and ``VALUES`` (a netCDF file's other variables are left alone: a mesh study's result holds
    many). A column of another name was skipped: ``te [um]`` for ``ste`` ran the scene without
    its STE (p_rms 21x lower at 20000 rpm) and validate said ok (an outside tester)."""
    index: dict[str, int] = {}
    factor: dict[str, float] = {}
    position = ""
    for i, (name, unit) in enumerate(names):
        key = name.strip().lower()
        if header is not None and key not in POSITION and key not in VALUES:
            known = [*POSITION, *VALUES]
            close = difflib.get_close_matches(key, known, n=1)
            raise ValueError(
                f"line {header}: column {i + 1} {name!r} is no column gearsweep reads"
                f" ({', '.join(known[:-1])} or {known[-1]})"
                + (f"; did you mean {close[0]!r}?" if close else ""))
        twin = "position" if key in POSITION else VALUES[key][0] if key in VALUES else None
        if twin is not None and twin in index:  # the first was taken, the second ignored
            raise ValueError(f"two {twin} columns ({names[index[twin]][0]!r} and {name!r}): keep"
                             " one")
        if key in POSITION and "position" not in index:
            position = POSITION[key]
            index["position"] = i
            factor["position"] = _factor(name, unit, "mesh_phase" if position == "mesh_phase"
                                         else "angle", header is None)
        elif key in VALUES and VALUES[key][0] not in index:
            which, kind = VALUES[key]
            index[which] = i
            factor[which] = _factor(name, unit, kind, header is None)
    found = ", ".join(repr(n) for n, _ in names) or "none"
    if "position" not in index:
        raise ValueError(f"no position column (mesh_phase [1], angle [deg] or roll_angle [deg]);"
                         f" columns: {found}")
    if "ste" not in index and "stiffness" not in index:
        raise ValueError(f"no value column (ste [um] and/or mesh_stiffness [N/mm]); columns: {found}")
    return index, factor, position


_HEADER = re.compile(r"^\s*([^\[\]()]*?)\s*(?:[\[(]\s*([^\[\]()]*?)\s*[\])])?\s*$")


def _read_csv(path: Path) -> tuple[list[tuple[str, str]], np.ndarray, list[tuple[int, list]], int]:
    """(column names and units, samples, each sample's line and cells, the header's line)."""
    try:
        text = utf8_text(path.read_bytes())
    except NotUtf8 as exc:
        raise ValueError(f"{exc} (save the file as UTF-8)") from None
    numbered = [(i, ln) for i, ln in enumerate(text.splitlines(), 1)
                if ln.strip() and not ln.lstrip().startswith("#")]
    if not numbered:
        raise ValueError("an empty CSV file (a header line with units, then samples)")
    lines = [ln for _, ln in numbered]
    try:
        dialect = csv.Sniffer().sniff(lines[0], delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    rows = list(csv.reader(lines, dialect))
    names = []
    for cell in rows[0]:
        m = _HEADER.match(cell)
        names.append((m.group(1), m.group(2) or "") if m else (cell, ""))
    values = []
    for (line, _), r in zip(numbered[1:], rows[1:], strict=True):  # each problem at its line
        if len(r) != len(names):
            raise ValueError(f"line {line} has {len(r)} value{'s' if len(r) != 1 else ''}, the"
                             f" header {len(names)} columns")
        try:
            values.append([float(c) for c in r])
        except ValueError:
            bad = next(c for c in r if not _number(c))
            raise ValueError(f"line {line}: {bad.strip()!r} is not a number") from None
    if not values:
        raise ValueError("no samples under the header line")
    rows_at = [(line, r) for (line, _), r in zip(numbered[1:], rows[1:], strict=True)]
    return names, np.array(values, dtype=float), rows_at, numbered[0][0]


def _number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _stated(ds: Any, name: str, kind: str) -> float | None:
    """A scalar variable of ``ds`` in SI (its ``units`` read as ``kind``); ``None`` where the
    file does not state it plainly (absent, not scalar, no unit)."""
    if name not in ds.variables or ds[name].ndim != 0:
        return None
    try:
        return float(ds[name].values) * to_si("1 " + str(ds[name].attrs["units"]), kind)
    except (KeyError, UnitParseError, TypeError, ValueError):
        return None


def _read_netcdf(path: Path) -> list[tuple[list[tuple[str, str]], np.ndarray, dict]]:
    """(column names and units, samples, what the file states) of each load a netCDF file
    holds: one, or one per value of a ``torque`` dimension (a mesh study's swept torque)."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        # a mesh study swept over one torque holds it as a dimension of length 1: its load
        ds = ds.squeeze([d for d, n in ds.sizes.items() if n == 1 and d in ds.coords])
        wanted = [v for v in ds.variables if str(v).lower() in VALUES]
        if wanted and "torque" in ds.dims and "torque" in ds.coords \
                and all(ds[v].dims[:1] == ("torque",) for v in wanted):
            return [_read_load(ds.isel(torque=i)) for i in range(ds.sizes["torque"])]
        return [_read_load(ds)]


def _read_load(ds: Any) -> tuple[list[tuple[str, str]], np.ndarray, dict]:
    """The samples of one load of a netCDF file (``_read_netcdf``)."""
    # the load and the pair of a mesh study, stated by scalars with units; else unstated
    stated = {"torque": _stated(ds, "torque", "torque"),
              "base_radius": _stated(ds, "base_radius_1", "length")}
    pitch = _stated(ds, "base_pitch", "length")
    if stated["base_radius"] and pitch:
        stated["teeth"] = round(2.0 * math.pi * stated["base_radius"] / pitch)
    wanted = [v for v in ds.variables if str(v).lower() in VALUES]
    _near_misses(ds, wanted)
    if not wanted:
        raise ValueError("no variable ste or mesh_stiffness (1-D over mesh_phase or angle)")
    dims = {ds[v].dims for v in wanted}
    if len(dims) != 1 or len(next(iter(dims))) != 1:
        shown = ", ".join(f"{v}{ds[v].dims}" for v in wanted)
        hint = ("; a mesh study's result of several gear pairs (variant): one pair a file,"
                " from a study with 'gear:'") if "variant" in ds.dims else ""
        raise ValueError(f"the values must be 1-D over one position coordinate: {shown}{hint}")
    (dim,) = next(iter(dims))
    names = [(str(dim), str(ds[dim].attrs.get("units", "")))] + [
        (str(v), str(ds[v].attrs.get("units", ""))) for v in wanted]
    data = np.stack([np.asarray(ds[dim].values, float)]
                    + [np.asarray(ds[v].values, float) for v in wanted], axis=1)
    stated["integrated"] = _integrated(ds)
    return names, data, stated


def _near_misses(ds: Any, wanted: list) -> None:
    """Refuse a 1-D variable (over the values' coordinate, where there are values) whose name is
    a near miss of a value the file lacks, as a CSV column of another name is (``_columns``):
    ``te`` (um) beside ``mesh_stiffness`` ran the scene without its STE and validate said ok (an
    outside tester). Only near misses: a netCDF file's other variables are left alone (a mesh
    study's result holds many, and holds both values)."""
    have = {VALUES[str(v).lower()][0] for v in wanted}
    lacking = [name for name, (which, _) in VALUES.items() if which not in have]
    if not lacking:
        return
    dims = {ds[v].dims for v in wanted}
    for v in ds.data_vars:
        if ds[v].ndim != 1 or (dims and ds[v].dims not in dims):
            continue
        close = difflib.get_close_matches(str(v).lower(), lacking, n=1)
        if close:
            which = {"ste": "STE", "stiffness": "mesh stiffness"}[VALUES[close[0]][0]]
            raise ValueError(
                f"variable {str(v)!r} is no variable gearsweep reads ({', '.join(list(VALUES)[:-1])}"
                f" or {list(VALUES)[-1]}), and the file has no {which}; did you mean {close[0]!r}?")


def _harmonic_series(ds: Any, amplitude: str, phase: str, kind: str) -> Series | None:
    """``amplitude`` (of ``kind``) and ``phase`` [rad] of ``ds`` in SI over its ``harmonic``
    0..H, or ``None`` where the file does not hold them so."""
    if amplitude not in ds.variables or phase not in ds.variables or "harmonic" not in ds.coords:
        return None
    a, p = ds[amplitude], ds[phase]
    if a.dims != ("harmonic",) or p.dims != ("harmonic",):
        return None
    order = np.asarray(ds["harmonic"].values)
    if order.size < 2 or not np.array_equal(order, np.arange(order.size)):
        return None
    try:
        fa = to_si("1 " + str(a.attrs["units"]), kind)
        fp = to_si("1 " + str(p.attrs["units"]), "angle")
    except (KeyError, UnitParseError):
        return None
    values = np.asarray(a.values, float) * fa, np.asarray(p.values, float) * fp
    return values if np.isfinite(values).all() else None


def _integrated(ds: Any) -> Integrated | None:
    """A mesh study's integrated harmonics in ``ds`` (``INTEGRATED``), or ``None`` without
    those of k and the STE."""
    got = {which: _harmonic_series(ds, *names) for which, names in INTEGRATED.items()}
    if got["stiffness"] is None or got["ste"] is None:
        return None
    return Integrated(**got)


@lru_cache(maxsize=32)
def _read(path: str, stamp: tuple[int, int]) -> tuple[Samples, ...]:
    """The samples of each load the file holds (one, but for a mesh study's swept torque)."""
    p = Path(path)
    try:
        if p.suffix.lower() in (".nc", ".nc4", ".cdf"):
            tables = [(*t, None, None) for t in _read_netcdf(p)]
        else:
            names, data, rows_at, header = _read_csv(p)
            tables = [(names, data, {}, rows_at, header)]
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read the file ({type(exc).__name__})") from None
    return tuple(_samples(*t) for t in tables)


def _samples(names: list[tuple[str, str]], data: np.ndarray, stated: dict,
             rows_at: list | None, header: int | None) -> Samples:
    """One load's samples in SI, checked (every problem one sentence, at its line of a CSV)."""
    index, factor, position = _columns(names, header)
    used = list(index.values())
    finite = np.isfinite(data[:, used])
    if not finite.all():
        row, col = (int(k) for k in np.argwhere(~finite)[0])
        if rows_at is not None:  # a CSV: the line and the cell, as for text in a sample
            line, cells = rows_at[row]
            raise ValueError(f"line {line}: {cells[used[col]].strip()!r} is not a finite"
                             " number (every sample must be one)")
        raise ValueError(f"variable {names[used[col]][0]!r}: its value at index {row} is"
                         f" {data[row, used[col]]:g}, not a finite number (every sample must"
                         " be one)")

    with np.errstate(over="ignore"):  # 1e308 N/mm is 1e311 N/m: said below, in one line
        si = {which: data[:, i] * factor[which] for which, i in index.items()}
    for which, values in si.items():
        if not np.isfinite(values).all():
            row = int(np.argwhere(~np.isfinite(values))[0][0])
            where = (f"line {rows_at[row][0]}: {rows_at[row][1][index[which]].strip()!r}"
                     if rows_at is not None else f"a sample of {names[index[which]][0]!r}")
            unit = {"ste": "m", "stiffness": "N/m"}.get(which, "rad")
            raise ValueError(f"{where} is beyond a float in SI ({unit})")
    ste = si.get("ste")
    if ste is not None and np.abs(ste).max() > MAX_STE:
        row = int(np.argmax(np.abs(ste)))
        where = (f"line {rows_at[row][0]}: {rows_at[row][1][index['ste']].strip()!r}"
                 if rows_at is not None else f"a sample of {names[index['ste']][0]!r}")
        raise ValueError(f"{where} is beyond {STE_BEYOND}")
    k_unit = ((*names[index["stiffness"]], factor["stiffness"]) if "stiffness" in index
              else None)
    lines = tuple(line for line, _ in rows_at) if rows_at is not None else None
    samples = Samples(position, si["position"], si.get("ste"), si.get("stiffness"), **stated,
                      stiffness_unit=k_unit, lines=lines)
    twins = _twin_problem(samples, *names[index["position"]], data[:, index["position"]])
    if twins:
        raise ValueError(twins)
    return samples


AGREE = 1e-2
"""How far two samples at one position (or a closing one and the first, a period apart) may
differ, as a share of their column's peak-to-peak, before they are refused as conflicting."""


def _where(s: Samples, i: int) -> str:
    return f"line {s.lines[i]}" if s.lines is not None else f"sample {i}"


def _disagree(s: Samples, i: int, j: int) -> str:
    """How samples ``i`` and ``j`` differ beyond ``AGREE`` (``""``: they agree)."""
    for which, values, unit, scale in (("ste", s.ste, "um", 1e6),
                                       ("mesh_stiffness", s.stiffness, "kN/mm", 1e-6)):
        if values is None:
            continue
        if abs(values[i] - values[j]) > AGREE * float(np.ptp(values)):
            return (f"{which} {values[i] * scale:.6g} and {values[j] * scale:.6g} {unit}")
    return ""


def _twin_problem(s: Samples, position: str, unit: str, written: np.ndarray) -> str:
    """Two samples at the same position (``written``: in the file's ``unit``) whose values
    disagree (the fit averaged them: an outside tester), or ``""``."""
    order = np.argsort(written, kind="stable")
    same = np.flatnonzero(np.diff(written[order]) == 0)
    for k in same:
        i, j = int(order[k]), int(order[k + 1])
        differ = _disagree(s, i, j)
        if differ:
            both = (f"lines {s.lines[i]} and {s.lines[j]}" if s.lines is not None
                    else f"samples {i} and {j}")
            return (f"{both}: two samples at {position} {written[i]:.10g}"
                    f"{'' if unit.strip().lower() in DIMENSIONLESS else f' {unit}'} with {differ}: keep one")
    return ""


def _closing_problem(s: Samples, phi: np.ndarray, period: float) -> str:
    """A last sample a period after the first (dropped by ``_one_period``) whose values are not
    the first's (3 um above it was dropped without a word: an outside tester), or ``""``."""
    if _one_period(phi, period).size == phi.size:
        return ""
    differ = _disagree(s, phi.size - 1, 0)
    if not differ:
        return ""
    return (f"{_where(s, phi.size - 1)}, a period after {_where(s, 0)}, repeats it with"
            f" {differ} (a period later a sample must be the same; one of them is wrong)")


class LoadNotHeld(ValueError):
    """A file of several torques (a mesh study's swept torque) holds none at the scene's."""


def read_samples(path: str | Path, torque: float | None = None) -> Samples:
    """The samples of an excitation file (cached while the file is unchanged); of a file that
    holds several torques (a mesh study's swept ``torque``), those at ``torque`` [N m] (to
    1e-3, as a file's stated load is compared with a scene's).

    Raises
    ------
    ValueError
        One sentence: the file is missing or unreadable, a column or its unit is missing or not
        of its kind, a sample is not a finite number, or the file holds several torques and
        ``torque`` is none of them (``LoadNotHeld``).
    """
    loads = _read_all(path)
    if len(loads) == 1:
        return loads[0]
    held = np.array([s.torque for s in loads], dtype=float)
    span = (f"the mesh at {held.size} torques ({np.nanmin(held):g}-{np.nanmax(held):g} N m,"
            " its 'torque')")
    if torque is None:
        raise LoadNotHeld(f"excitation.file holds {span}: give the scene's torque (or"
                         " mean_force and base_radius) to take one")
    at = [i for i, t in enumerate(held) if math.isclose(t, torque, rel_tol=1e-3)]
    if not at:
        raise LoadNotHeld(f"excitation.file holds {span}, not the scene's {torque:g} N m: an STE"
                         " holds for the load it was computed at; run the scene at one of"
                         " them, or compute the mesh at this one")
    return loads[at[0]]


def _read_all(path: str | Path) -> tuple[Samples, ...]:
    """The samples of each load of an excitation file (``_read``), the file checked first."""
    p = Path(path)
    try:
        st = p.stat()
    except OSError:
        raise ValueError(f"no such file: {p.absolute()} (a relative path is read from the study"
                         " file's folder; of a study from stdin or a dict, from the working"
                         " folder)") from None
    if not stat.S_ISREG(st.st_mode):  # a pipe was waited on, a device read without end
        raise ValueError(f"not a regular file: {p.absolute()} (a folder, a device or a pipe);"
                         " the samples are read from a CSV or netCDF file")
    return _read(str(p.resolve()), (st.st_mtime_ns, st.st_size))


def _base(info: ValidationInfo) -> Path:
    """The folder relative paths are read from: the one given (``parse_study(base=)``: a
    result's ``study_folder``), else the study file's, else the working folder."""
    context = (info.context or {}) if info is not None else {}
    if context.get("base"):
        return Path(context["base"])
    name = context.get("file")
    if name and not str(name).startswith("<"):
        return Path(name).parent
    return Path.cwd()


class ExcitationSpec(Strict):
    """``excitation:``: the scene's STE and/or mesh stiffness as samples in a file, fitted."""

    file: str = Field(min_length=1, description="CSV or netCDF file (relative to the study file;"
                      " a leading ~ is the home folder)")
    harmonics: Count = Field(10, ge=1, le=100, description="highest mesh order kept: fitted to"
                             " the samples, or of a mesh study's result its integrated harmonics"
                             " (at most the study's harmonics)")
    span: Literal["mesh_cycle", "revolution"] = Field(
        "mesh_cycle", description="the samples cover one mesh cycle or one revolution of the"
        " driving gear")

    @field_validator("file")
    @classmethod
    def _readable(cls, v: str, info: ValidationInfo) -> str:
        path = Path(user_path(v))
        if not path.is_absolute():
            path = _base(info) / path
        _read_all(path)  # every problem of the file: one ValueError sentence
        return str(path.resolve())


def excitation_problems(scene: Any, swept, swept_loads: dict | None = None
                        ) -> list[tuple[str, Any, str]]:
    """What a scene with ``excitation`` may not also give or sweep, samples that cannot give
    the harmonics asked for, and a load the file states that the scene does not run at
    (``swept_loads``: the swept torque or mean_force in SI): (field path, value or ``NO_VALUE``,
    message) for each."""
    ex: ExcitationSpec | None = getattr(scene, "excitation", None)
    if ex is None:
        return []
    span = ex.span.replace("_", " ")
    if scene.gear is not None:
        return [("scene.gear", NO_VALUE, "give either 'gear' or 'excitation', not both")]
    out: list[tuple[str, Any, str]] = []
    if scene.harmonics is not None:
        out.append(("scene.harmonics", scene.harmonics, ("the number of harmonics of a 'gear';"
                    " with a file write excitation.harmonics")))
    if scene.teeth is None:
        out.append(("scene.teeth", "(missing)", ("required with 'excitation' (N1 of the driving"
                    " gear: the mesh frequency and the mesh phase of an angle)")))
    try:
        s = read_samples(ex.file, scene_torque(scene))
    except LoadNotHeld as exc:  # a file of several torques, none the scene's
        name = next((n for n in ("torque", "mean_force") if n in swept), None)
        if name is not None:
            return [(f"sweep.{name}", NO_VALUE, f"{exc} (one study per load)")]
        name = "mean_force" if scene.torque is None and scene.mean_force is not None else "torque"
        value = getattr(scene, name)
        return out + [(f"scene.{name}", NO_VALUE if value is not None else "(missing)",
                       str(exc))]
    if s.stiffness is not None:
        out += [(f"scene.{f}", NO_VALUE, "excitation.file gives the mesh stiffness: remove it")
                for f in ("stiffness", "stiffness_harmonics") if getattr(scene, f, None)]
        if "stiffness" in swept:
            out.append(("sweep.stiffness", NO_VALUE, ("the excitation file gives the mesh"
                        " stiffness; sweep it with typed-in coefficients")))
    elif scene.stiffness is None and "stiffness" not in swept:  # (the sweep gives it)
        out.append(("scene.stiffness", "(missing)", ("required: excitation.file has no"
                    " mesh_stiffness column")))
    if s.ste is not None:
        if getattr(scene, "ste", None):
            out.append(("scene.ste", NO_VALUE, "excitation.file gives the STE: remove it"))
        out += _stated_load_problems(scene, swept_loads or {}, s.torque)
        # A measured STE holds for its load with constant stiffness too (rattle: e = STE, a
        # sweep of mean_force kept one load's STE for all: an outside tester); with k(t) e is
        # also fitted for one stiffness.
        for name in ("torque", "mean_force", "stiffness"):
            if name not in swept or (name == "stiffness"
                                     and (s.stiffness is not None or scene.kind == "rattle")):
                continue
            why = ("with k(t) the excitation e = STE - F_m / k is fitted for one load and"
                   " stiffness, and " if scene.kind != "rattle" else "")
            out.append((f"sweep.{name}", NO_VALUE, (f"{why}a measured STE holds for its load:"
                        " one study per load")))
    out += _stated_pair_problems(scene, s)
    if out:
        return out
    phi = s.mesh_phase(scene.teeth)
    period = scene.teeth if ex.span == "revolution" else 1
    width = float(np.ptp(phi))
    if width > period * (1 + 1e-9):
        what = (f"{width:.4g} mesh cycles" if s.position == "mesh_phase"
                else f"{math.degrees(width * 2 * math.pi / scene.teeth):.4g} deg")
        hint = "" if ex.span == "revolution" else "; samples over a revolution: span: revolution"
        if s.position == "mesh_phase":  # (no unit is mesh cycles: degrees were read as cycles)
            hint += ("; mesh_phase is in mesh cycles (0 to 1); an angle of the driving gear is an"
                     " 'angle [deg]' column")
        return [("scene.excitation.span", ex.span, (f"the samples of excitation.file span {what},"
                 f" more than one {span} ({period} mesh cycle{'s' if period != 1 else ''} of {scene.teeth}"
                 f" teeth){hint}"))]
    if _takes_integrated(s, ex.span == "revolution", scene.kind != "rattle",
                         scene_mean_force(scene)):
        top = s.integrated.harmonics
        if ex.harmonics > top:
            return [("scene.excitation.harmonics", ex.harmonics, (f"excitation.file holds the"
                     f" harmonics 0-{top} its mesh study integrated (k_harmonic, ste_harmonic,"
                     f" e_harmonic): ask for at most {top}, or run the mesh study with"
                     f" harmonics: {ex.harmonics}"))]
        need, n = 0, 0  # the harmonics are the file's: its samples only draw the cycle
    else:
        need = min_samples(ex.harmonics, scene.teeth, ex.span == "revolution")
        n = np.unique(np.round(_one_period(phi, period), 12)).size
    if n < need:
        return [("scene.excitation.harmonics", ex.harmonics, (f"needs at least {need} samples"
                 f" over a {span}{f' of {scene.teeth} teeth' if period > 1 else ''};"
                 f" excitation.file has {n}"))]
    closing = _closing_problem(s, phi, period)
    if closing:
        return [("scene.excitation.file", Path(ex.file).name, closing)]
    short = _short_span(s, phi, period, scene.teeth, span)
    if short:
        return [("scene.excitation.span" if ex.span == "revolution" else "scene.teeth",
                 ex.span if ex.span == "revolution" else scene.teeth, short)]
    try:
        fit = scene_measured(scene, scene_mean_force(scene))
    except FitError as exc:
        return [("scene.excitation.file", Path(ex.file).name, str(exc))]
    return [("scene.excitation.file", Path(ex.file).name, m)
            for m in _stiffness_problems(s, fit.stiffness, scene_mean_force(scene), ex.file)]


STIFFEST_MESH = 1e11
"""The largest mean mesh stiffness k0 [N/m] an excitation file may give: ISO 6336-1's c_gamma of
steel spur teeth is about 20 N/(mm um) per face width, 2e10 N/m for a face a metre wide, and the
stiffest gear material (cemented carbide, ``geometry.GEAR_MODULUS``) is 3.4 times steel: 1e11
N/m is beyond any spur mesh, and N/mm data labelled kN/mm (3e11 N/m for 300 kN/mm) is caught."""

DEFLECTION_OVER_STE = (100.0, 1000.0)
"""Warned and refused ratios of the static mesh deflection F_m / k0 to the excitation file's
largest |STE| sample: a loaded STE holds the deflection (STE = F_m / k + e), so it is of the
deflection's size (with its mean), or at least a tip relief's remainder of its variation (mean
removed, hardly less than 1 % of it); 1000 times is a unit slip of the stiffness (N/mm data
labelled N/m: 4.2 mm against 6.6 um, an outside tester)."""

STIFFNESS_UNITS = {"N/m": 1.0, "N/mm": 1e3, "kN/mm": 1e6, "kN/um": 1e9}
"""Stiffness units a slip of a factor 1000 is said in (``_stiffness_problems``)."""


def _slip(unit: str, factor: float, times: float) -> str:
    """The likely slip of a stiffness column in ``unit`` (``factor`` N/m) whose values are
    ``times`` too small (1000) or too large (1e-3)."""
    other = next((u for u, f in STIFFNESS_UNITS.items()
                  if math.isclose(f, factor * times, rel_tol=1e-9)), None)
    if other is None:
        return f"data in a unit {max(times, 1 / times):g} times {'larger' if times > 1 else 'smaller'}"
    return f"{other} data labelled {unit}"


def _stiffness_problems(s: Samples, k0: float | None, mean_force: float, file: str
                        ) -> list[str]:
    """A fitted mean stiffness no spur mesh has (``STIFFEST_MESH``), or whose static deflection
    F_m / k0 is beyond ``MAX_STE`` or ``DEFLECTION_OVER_STE`` of the file's own STE (refused;
    warned from the lower ratio): N/mm data labelled N/m ran with status 0, p_mean 4208 um (an
    outside tester)."""
    if k0 is None or s.stiffness_unit is None:
        return []
    name, unit, factor = s.stiffness_unit
    said = (f"the fitted mean of column {name!r} [{unit}] is {k0 / factor:.4g} {unit}"
            + (f" ({k0:.4g} N/m)" if factor != 1.0 else ""))
    if k0 > STIFFEST_MESH:
        return [(f"{said}, stiffer than any spur mesh (at most {STIFFEST_MESH:g} N/m: ISO 6336-1's"
                f" c_gamma is about 2e10 N/m per metre of face width for steel): a unit slip,"
                f" {_slip(unit, factor, 1e-3)}?")]
    if not mean_force > 0:
        return []
    d = mean_force / k0
    peak = float(np.max(np.abs(s.ste))) if s.ste is not None else 0.0
    ratio = d / peak if peak > 0 else 0.0
    slip = f"a unit slip, {_slip(unit, factor, 1e3)}?"
    deflects = (f"{said}: at the scene's mean mesh force {mean_force:.4g} N it gives a static"
                f" mesh deflection F_m/k0 = {d * 1e6:.4g} um")
    of_ste = f", {ratio:.3g} times the file's largest STE sample ({peak * 1e6:.4g} um), which holds it"
    if d > MAX_STE:
        return [(f"{deflects}, beyond {MAX_STE * 1e3:g} mm (teeth deflect micrometres to tens of"
                f" micrometres){of_ste if peak > 0 else ''}: {slip}")]
    if ratio > DEFLECTION_OVER_STE[1]:
        return [f"{deflects}{of_ste} (at most {DEFLECTION_OVER_STE[1]:g}): {slip}"]
    if ratio > DEFLECTION_OVER_STE[0]:
        warnings.warn(MeasuredWarning(f"{Path(file).name}: {deflects}{of_ste} (more than"
                                      f" {DEFLECTION_OVER_STE[0]:g}): {slip}"), stacklevel=2)
    return []


class MeasuredWarning(GeometryWarning):
    """An excitation file's values that run but look like a unit slip (one ``gearsweep:
    warning:`` line, as a gear pair's)."""


CLOSING_GAP = 1.5
"""The most spacings evenly spaced samples may leave between the last and the first a period
later (``_short_span``)."""


def _short_span(s: Samples, phi: np.ndarray, period: float, teeth: int, span: str) -> str:
    """Why evenly spaced samples cover less than the period, or ``""``: a closing gap of more
    than ``CLOSING_GAP`` spacings (a cycle of a 25-tooth gear written in degrees, for a scene of
    23 teeth, spans 0.92 cycle and was fitted as periodic: order 3 off by 32 %, an outside
    tester). Unevenly spaced samples are left to the fit's own test of their gaps."""
    p = np.sort(_one_period(phi, period))
    if p.size < 3:
        return ""
    step = np.diff(p)
    spacing = float(np.mean(step))
    if not spacing > 0 or np.ptp(step) > 1e-3 * spacing:
        return ""
    gap = period - float(p[-1] - p[0])
    if not gap > CLOSING_GAP * spacing:
        return ""
    covered = p.size * spacing  # the samples' own period, one spacing each
    if s.position == "mesh_phase":
        what = (f"{covered:.4g} mesh cycles, less than the {period:g} of one {span}")
        cause = ("mesh_phase in mesh cycles (0 to 1)?" if span == "mesh cycle"
                 else "the scene's teeth?")
    else:
        deg = math.degrees(covered * 2 * math.pi / teeth)
        whole = 360.0 if period != 1 else 360.0 / teeth
        what = f"{deg:.4g} deg, less than the {whole:.4g} deg of one {span}"
        if math.isclose(math.degrees(deg), whole, rel_tol=0.02):
            cause = "radians written as deg?"
        elif span == "mesh cycle":
            cause = (f"samples of a {360.0 / deg:.3g}-tooth gear's mesh cycle, not the scene's"
                     f" {teeth} teeth, or the angle's unit?")
        elif math.isclose(deg, 360.0 / teeth, rel_tol=0.02):
            cause = "samples over a mesh cycle: span: mesh_cycle?"
        else:
            cause = "the angle's unit?"
    return (f"the {p.size} evenly spaced samples of excitation.file cover {what} of"
            f" {teeth} teeth, leaving {gap / spacing:.3g} spacings between the last and the"
            f" first a period later (at most {CLOSING_GAP:g}): {cause}")


def _stated_load_problems(scene: Any, swept: dict, file_torque: float | None
                          ) -> list[tuple[str, Any, str]]:
    """The scene's loads (given or swept) against the load an excitation file states: an STE
    holds for the load it was computed at."""
    if file_torque is None:
        return []
    r1 = scene.r1
    loads: list[tuple[str, float | None]] = []
    for name in ("torque", "mean_force"):
        values = [float(v) for v in swept[name]] if name in swept else (
            [float(getattr(scene, name))] if getattr(scene, name, None) is not None else [])
        where = f"sweep.{name}" if name in swept else f"scene.{name}"
        for v in values:
            loads.append((where, v if name == "torque" else (v * r1 if r1 else None)))
    out = []
    for where, at in loads:
        if at is None:
            out.append((where, NO_VALUE, (f"excitation.file's STE is at {file_torque:g} N m (its"
                        " 'torque'): give base_radius beside mean_force, or torque, so that the"
                        " scene's load can be compared with it")))
        elif not math.isclose(at, file_torque, rel_tol=1e-3):
            out.append((where, NO_VALUE, (f"excitation.file's STE is at {file_torque:g} N m"
                        f" (its 'torque'), the scene at {at:g} N m: an STE holds for the load it"
                        " was computed at; run the scene at the file's load, or compute the mesh"
                        " at this one")))
        if out:
            break  # one line says it
    return out


def _stated_pair_problems(scene: Any, s: Samples) -> list[tuple[str, Any, str]]:
    """The scene's driving gear (teeth, base radius) against the one an excitation file states:
    its samples are that pair's, and a torque is a mesh force through its radius (found by a
    new-user test: a scene of 30 teeth, or of base radius 40 mm, ran the 48-tooth pair's file)."""
    out = []
    if s.teeth is not None and scene.teeth is not None and scene.teeth != s.teeth:
        out.append(("scene.teeth", scene.teeth, (f"the driving gear's teeth of excitation.file's"
                    f" pair ({s.teeth}, from its base_radius_1 and base_pitch)")))
    r1 = getattr(scene, "r1", None)
    if s.base_radius is not None and r1 is not None \
            and not math.isclose(r1, s.base_radius, rel_tol=1e-3):
        where = "scene.base_radius" if getattr(scene, "base_radius", None) is not None \
            else "scene.drive"
        out.append((where, NO_VALUE, (f"the driving gear's base radius of excitation.file's pair"
                    f" ({s.base_radius * 1e3:.6g} mm, its base_radius_1), the scene's"
                    f" {r1 * 1e3:.6g} mm")))
    return out


def scene_torque(scene: Any) -> float | None:
    """The scene's own mean driving torque [N m]: its ``torque``, or ``mean_force`` times the
    driving gear's base radius; ``None`` where it gives neither (a file of several torques is
    read at this one)."""
    if scene.torque is not None:
        return float(scene.torque)
    if scene.mean_force is not None and getattr(scene, "r1", None) is not None:
        return float(scene.mean_force * scene.r1)
    return None


def scene_mean_force(scene: Any) -> float:
    """The scene's own mean mesh force F_m [N] (0 when it gives no load)."""
    if scene.mean_force is not None:
        return float(scene.mean_force)
    if scene.torque is not None and scene.r1 is not None:
        return float(scene.torque / scene.r1)
    return 0.0


def typed_harmonics(items, phases: dict[float, float] | None = None) -> tuple[Harmonic, ...]:
    """Typed-in harmonics of a scene (order: position + 1 when not given). A harmonic given
    without a phase takes ``phases[order]`` (a gear pair's phase of that order), else 0."""
    out = []
    for i, h in enumerate(items):
        order = h.order if h.order is not None else i + 1
        phase = h.phase if h.phase is not None else (phases or {}).get(float(order), 0.0)
        out.append(Harmonic(h.amplitude, order, phase))
    return tuple(out)


def _one_period(phi: np.ndarray, period: float) -> np.ndarray:
    """The samples without a last one that repeats the first a period later."""
    if phi.size > 1 and abs((phi[-1] - phi[0]) - period) <= 1e-9 * period:
        return phi[:-1]
    return phi


def _takes_integrated(s: Samples, revolution: bool, time_varying: bool, mean_force: float
                      ) -> bool:
    """Whether a scene takes the file's integrated harmonics (a mesh study's result: over a
    mesh cycle, with e = STE - F / k where the scene has k(t) and a load) rather than a fit of
    its samples."""
    return (s.integrated is not None and not revolution and s.ste is not None
            and s.stiffness is not None
            and (s.integrated.e is not None or not (time_varying and mean_force)))


@lru_cache(maxsize=64)
def _fit(path: str, stamp: tuple, torque: float | None, teeth: int, harmonics: int,
         revolution: bool, time_varying: bool, mean_force: float, k_mean: float | None,
         k_harmonics: tuple[Harmonic, ...]) -> MeasuredExcitation:
    s = read_samples(path, torque)
    phi = s.mesh_phase(teeth)
    keep = _one_period(phi, teeth if revolution else 1).size
    sl = slice(0, keep)
    if _takes_integrated(s, revolution, time_varying, mean_force):
        i = s.integrated
        return integrated_excitation(phi[sl], s.ste[sl], s.stiffness[sl], i.stiffness, i.ste,
                                     i.e, harmonics, time_varying=time_varying,
                                     mean_force=mean_force)
    return measured_excitation(
        phi[sl], None if s.ste is None else s.ste[sl],
        None if s.stiffness is None else s.stiffness[sl],
        fit_orders(harmonics, teeth, revolution), time_varying=time_varying,
        mean_force=mean_force, k_mean=k_mean, k_harmonics=k_harmonics)


def scene_measured(scene: Any, mean_force: float) -> MeasuredExcitation:
    """The fit of a scene's excitation file at mean mesh force ``mean_force`` [N] (the scene's
    typed-in ``stiffness`` and ``stiffness_harmonics`` give k where the file has no stiffness).

    Raises
    ------
    FitError
        The samples cannot give the harmonics, or k <= 0 at a sample.
    """
    ex: ExcitationSpec = scene.excitation
    st = Path(ex.file).stat()
    return _fit(ex.file, (st.st_mtime_ns, st.st_size), scene_torque(scene), scene.teeth,
                ex.harmonics,
                ex.span == "revolution", scene.kind != "rattle", float(mean_force),
                scene.stiffness, typed_harmonics(getattr(scene, "stiffness_harmonics", [])))


__all__ = ["ExcitationSpec", "FitError", "Samples", "excitation_problems", "read_samples",
           "scene_mean_force", "scene_measured", "typed_harmonics"]
