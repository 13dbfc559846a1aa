"""The Python entry: ``run(study) -> Dataset`` and ``open_result(path)``, the same path the CLI takes.

    import gearsweep
    ds = gearsweep.run("studies/whine_speed_sweep.yaml")        # a path, YAML text, a dict or a Study
    ds = gearsweep.run({"title": "...", "scene": {...}, ...}, output="out.nc")
    ds = gearsweep.open_result("results/fig08_rattle.nc")
    gearsweep.result_model(ds)                                  # the MeshModel the kernel ran
    gearsweep.result_model(ds, mean_force=833)                  # ... at a swept value (N)
    print(gearsweep.advise("studies/fig08_rattle.yaml", target=1e-4))  # steps for an accuracy

Every problem with the input raises a :class:`gearsweep.errors.GearsweepError` whose message is the
one line the command line prints; cases beyond the integrator's step limit (``solver.step_guard:
warn``) give one :class:`gearsweep.errors.StepLimitWarning`, the line it prints as a warning.
A result file carries the study text, the resolved model (every number the kernel used, SI), the
solver settings and the package version: ``result_study`` and ``result_model`` rebuild them, so a
study can be run again from its result alone.
"""

from __future__ import annotations

import dataclasses
import json
import math
import numbers
import os
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import xarray as xr
import yaml

from gearsweep.analysis.advise import Advice
from gearsweep.errors import (
    DICT_STUDY,
    NO_VALUE,
    ChunkSizeWarning,
    ResultError,
    SpectrumAliasingWarning,
    StudyError,
)
from gearsweep.files import RESULT_NAME, STUDY_SUFFIXES, study_named, user_path
from gearsweep.model import SWEEPABLE, Harmonic, MathieuModel, MeshModel, mean_mesh_force, model_from_record
from gearsweep.study.advice import DEFAULT_TARGET, study_advice
from gearsweep.study.analyses import run_analysis_study
from gearsweep.study.analysis_cost import AnalysisEstimate
from gearsweep.study.analysis_cost import check_limits as check_analysis
from gearsweep.study.analysis_cost import estimate as estimate_analysis
from gearsweep.study.analysis_specs import AnalysisStudy
from gearsweep.study.dataset import write_netcdf
from gearsweep.study.estimate import (
    before_refusing,
    capped_chunk_note,
    quick_estimate,
    small_chunk_note,
)
from gearsweep.study.estimate import chunk_cases as chunk_size
from gearsweep.study.execute import (
    WRITE_RATE,
    Estimate,
    InProcess,
    check_limits,
    contact_lost_warning,
    run_plan,
    run_to_file,
    step_limit_warning,
)
from gearsweep.study.mesh import check_memory, run_mesh_study
from gearsweep.study.outputs import impact_aliasing, parted_cases, spectrum_aliasing
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import MeshStudy, Study, load_study, parse_study, study_text
from gearsweep.study.workspace import (
    OutputLock,
    check_partial,
    check_replaces,
    output_path,
    reads_output,
)
from gearsweep.units import UnitParseError, si_values, to_display, to_si

StudyLike = str | Path | dict | Study | MeshStudy | AnalysisStudy
"""What ``run`` takes: a study file's path, its YAML text, its mapping, or a validated study."""


def load(study: StudyLike) -> tuple[Study | MeshStudy | AnalysisStudy, str]:
    """A validated study and its YAML text from any ``StudyLike``.

    Raises
    ------
    StudyError, GeometryError
        The one line the CLI prints for the same input.
    """
    return _load(study)[:2]


def _load(study: StudyLike) -> tuple[Study | MeshStudy | AnalysisStudy, str, str]:
    """``load``, and the name its errors are reported under (the file's path, ``<dict>``...)."""
    if isinstance(study, Study | MeshStudy | AnalysisStudy):
        text = getattr(study, "source_text", None)
        if text is not None and _parses_to(text, study):  # the text it was read from, with its
            return study, text, "<study>"  # units and comments (result_study's, say), if the same
        # changed in Python (``model_copy(update=...)`` validates nothing): checked as a file
        # is, and run from a text that reads back (a dump without units did not: a mass of -1
        # ran to NaN, and result_study refused the result's study, "0.1527 has no unit")
        text = study_text(study)
        return parse_study(text, "<study>", base=study._base_folder), text, "<study>"
    if isinstance(study, dict):
        try:
            text = yaml.safe_dump(_plain(study, "(study)"), sort_keys=False)
        except RecursionError:  # (a file nested as deeply is one line too: parse_study)
            raise StudyError(DICT_STUDY, "(top level)", "{...}", "values nested less deeply (or a"
                             " mapping that holds itself)") from None
        return parse_study(text, DICT_STUDY), text, DICT_STUDY
    if isinstance(study, str) and "\n" not in study.strip():  # one line, as read from a file or
        study = study.strip()  # a form ('s.yaml\n'): found by _is_file stripped, then opened
        # unstripped ("No such file"), or said "no such study file" with a newline after it
    if isinstance(study, Path) or (isinstance(study, str) and "\n" not in study and (
            study.strip().endswith(STUDY_SUFFIXES) or _is_file(study))):
        study = _user_path(study)
        return (*load_study(study), str(study))  # (a file named otherwise was read as YAML
        # text: "the file holds a single value 'studies/s.txt'"; an API test)
    if isinstance(study, str):
        if "\n" not in study.strip() and ":" not in study:  # a path, not YAML text
            raise StudyError(study.strip(), "(file)", NO_VALUE, "no such study file (YAML text"
                             " is a mapping: 'title: ...', 'scene: ...')")
        return parse_study(study, "<text>"), study, "<text>"
    raise StudyError("<study>", "(study)", type(study).__name__,
                     "a path, YAML text, a dict or a gearsweep Study")


def _user_path(path: str | Path) -> Path:
    """``files.user_path`` as a ``Path``."""
    return Path(user_path(path))


def _is_file(text: str) -> bool:
    try:
        return _user_path(text.strip()).is_file()
    except (OSError, ValueError):  # a name too long, a NUL
        return False


def _parses_to(text: str, study) -> bool:
    """Whether ``text`` validates to ``study`` (a study changed after it was read does not),
    read from the folder ``study`` was read from (its private ``_base_folder`` is compared too:
    from the working folder, a study read elsewhere was never equal to its own text)."""
    try:
        return parse_study(text, "<study>", base=study._base_folder) == study
    except StudyError:
        return False


def _plain(value, where: str):
    """``value`` with the containers and numbers a user builds a study from in Python (numpy
    scalars and arrays, tuples, ``Path``, other mappings) as YAML's plain types; anything else
    is one ``StudyError`` naming the field."""
    import numpy as np

    if isinstance(value, np.generic):  # first: np.float64 and np.str_ are a float and a str,
        return value.item()  # which PyYAML cannot represent
    if isinstance(value, str | bool | int | float) or value is None:
        return value
    if isinstance(value, np.ndarray):  # (a 0-d array's tolist() is its one value)
        return _plain(value.tolist(), where)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _plain(v, f"{where}.{k}" if where != "(study)" else str(k))
                for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    raise StudyError(DICT_STUDY, where, repr(value)[:60],
                     "a number, a string with units (e.g. '5 N m'), a list or a mapping")


def run_unchunked(study: MeshStudy | AnalysisStudy, text: str = "",
                  results: str | Path = "results") -> xr.Dataset:
    """A mesh or analysis study: computed in one piece (no chunks, no checkpoints). An analysis
    that reads other studies' results opens them from the folder ``results``."""
    if isinstance(study, MeshStudy):
        return run_mesh_study(study, text)
    return run_analysis_study(study, text, results)


def run_study(study: Study | MeshStudy | AnalysisStudy, text: str = "",
              progress: bool = False) -> xr.Dataset:
    """Run every chunk of a validated study in this process and return its Dataset in memory
    (cases beyond the step limit: one ``StepLimitWarning``, as ``run``). ``text``: the study's
    YAML for the result's ``study`` attribute; by default the text it was read from, or
    ``schema.study_text`` of it (an empty attribute made ``result_study`` say "the file holds
    nothing"; an outside tester's finding)."""
    _check_progress(progress)
    if not text:
        study, text, _ = _load(study)
    if isinstance(study, MeshStudy | AnalysisStudy):
        return run_unchunked(study, text)
    plan = make_plan(study, text)
    ds = run_plan(plan, backend=InProcess(), progress=progress)
    _warn_result(plan, ds, "<study>")
    return ds


def _warn_result(plan, ds: xr.Dataset, where: str | Path) -> None:
    """A ``StepLimitWarning`` if cases of ``ds`` are beyond the step limit, a
    ``ContactLossWarning`` if their teeth would separate (each the line the CLI prints),
    pointing at the caller of ``run`` or ``run_study``."""
    for found in (step_limit_warning(plan, ds, where), contact_lost_warning(plan, ds, where)):
        if found is not None:
            warnings.warn(found, stacklevel=3)
    impacts = impact_aliasing(plan, parted_cases(ds))  # (None where no case parted)
    if impacts is not None:
        warnings.warn(f"{where}: {impacts}", SpectrumAliasingWarning, stacklevel=3)


def estimate(study: StudyLike, *, chunk_cases: int | None = None,
             in_memory: bool = False) -> Estimate | AnalysisEstimate:
    """What running a dynamic study in this process would take, before anything runs: the
    estimate ``gearsweep run --estimate`` prints, less the start of a new process that a run in
    this one does not pay (``.start_seconds``: 0) (``.line()``: its text; ``.seconds``,
    ``.memory_bytes``, ``.output_bytes``, ``.disk_bytes``: wall time with any one-time
    compile, peak memory, the file's upper bound and the disk the run needs at its peak, the
    file with the chunks' checkpoints beside it; ``.over()``: the limits it passes).
    ``in_memory``: of ``run`` without ``output``, whose result's arrays are held in memory (the
    peak counts them; no file: ``output_bytes`` and ``disk_bytes`` 0, ``.in_memory``), the
    estimate ``run`` checks against the limits.

    An analysis study gives an ``AnalysisEstimate`` (``.line()``, ``.seconds``,
    ``.memory_bytes``, ``.over()``; its inputs read from ``results/``), the one ``gearsweep
    validate`` prints (``gearsweep.study.analysis_cost``).

    Raises
    ------
    StudyError
        For a mesh study (computed in one piece, with no estimate of its time), and as ``run``.
    """
    chunk_cases = _chunk_cases(chunk_cases)
    _check_flags(in_memory=in_memory)
    st, text, name = _load(study)
    if isinstance(st, AnalysisStudy):
        return estimate_analysis(st, "results")
    if isinstance(st, MeshStudy):
        raise StudyError(name, "type", st.type, "a dynamic or analysis study (a mesh study is"
                         " computed in one piece, with no estimate of its time)")
    plan = make_plan(st, text, name)
    est = quick_estimate(plan, chunk_size(plan, chunk_cases)[0], new_process=False)[0]
    return _held(est) if in_memory else est


def _held(est: Estimate) -> Estimate:
    """``est`` of a run whose result is held in memory: its arrays (their file's upper bound)
    on top of the peak memory, no file (no output bound, no time writing it: it stated the
    file's bound and write time of a run that writes none) and no disk (no checkpoints)."""
    write = est.output_bytes / WRITE_RATE  # off the worst case too (else every study's line
    # said a period output's worst case, the typical time less the write being below it)
    return dataclasses.replace(est, memory_bytes=est.memory_bytes + est.output_bytes,
                               seconds=est.seconds - write,
                               worst_seconds=max(0.0, est.worst_seconds - write),
                               output_bytes=0.0, disk_bytes=0.0, in_memory=True)


def _chunk_cases(chunk_cases) -> int | None:
    """``chunk_cases`` of ``run`` and ``estimate`` checked: ``None`` or a positive whole number
    (``estimate`` took 0, -5 and 2.5 without a word, and priced chunks ``run`` refuses)."""
    if chunk_cases is not None and (isinstance(chunk_cases, bool)  # np.int64 is a whole number
                                    or not isinstance(chunk_cases, numbers.Integral)
                                    or chunk_cases < 1):
        raise StudyError("<study>", "chunk_cases", repr(chunk_cases)[:60],
                         "a positive whole number of cases")
    return None if chunk_cases is None else int(chunk_cases)


def _check_flags(**flags) -> None:
    """Each of ``flags`` (a keyword argument's name: its value) checked as True or False: a
    string or a number was taken as its truth (``yes="no"`` went ahead, ``in_memory="yes"``
    was True; outside testers)."""
    for flag, value in flags.items():
        if not isinstance(value, bool):
            raise StudyError("<study>", flag, value, "True or False")


def _check_progress(progress) -> None:
    """``progress`` of ``run`` and ``run_study`` checked: ``progress="yes"`` and ``progress=5``
    showed a bar without a word (an outside tester)."""
    if not (isinstance(progress, bool) or (isinstance(progress, str) and progress == "log")):
        raise StudyError("<study>", "progress", progress, "True, False or 'log'")


def _within_limits(plan, chunk_cases: int | None, in_memory: bool, where: str) -> None:
    """``run``'s check of the CLI's limits (``LimitError`` with the estimate, as ``gearsweep run``
    without ``--yes``): a study the CLI refused, ``run`` started (a 1e9-case study raised
    MemoryError for 7.45 GiB after 0.6 s; an outside tester's finding). A result held in memory
    (no ``output``) counts its arrays in the peak memory, and has no file to limit."""
    chunk = chunk_size(plan, chunk_cases)[0]
    held = _held if in_memory else (lambda e: e)
    est = quick_estimate(plan, chunk, ask_cache=False, new_process=False)[0]  # as the CLI:
    if not held(est).over():  # Numba's cache is asked (1.3 ms a call) only where it can matter
        return
    est, _ = before_refusing(plan, quick_estimate(plan, chunk, new_process=False)[0], chunk)
    check_limits(held(est), where, ahead="pass yes=True to go ahead")


def run(study: StudyLike, *, output: str | Path | None = None, progress: bool = False,
        chunk_cases: int | None = None, yes: bool = False, overwrite: bool = False
        ) -> xr.Dataset:
    """Validate and run a study in this process; return its Dataset.

    Parameters
    ----------
    study : path, YAML text, dict or Study
        The study (see ``docs/study-reference.md`` for its fields).
    output : path, optional
        Also write the result to this netCDF file (checkpointed: a re-run after an interruption
        resumes). Without it nothing is written. An analysis study that reads other results
        opens them beside ``output`` (default: ``results/``).
    progress : bool or "log"
        Show a progress bar per chunk (stderr); ``"log"``: plain lines at most every
        ``execute.LOG_PROGRESS_SECONDS`` instead (for a log, not a terminal).
    chunk_cases : int, optional
        About this many cases per chunk (default: sized from the step count), at most about a
        tenth of the study's kernel time (``estimate.chunk_cases``, docs/scale.md).
    yes : bool
        Run a study predicted beyond the limits too (10 min, 2 GB of memory, 2 GB of output:
        ``estimate``); without it such a study raises ``LimitError`` before anything runs, as
        ``gearsweep run`` without ``--yes`` refuses it. Without ``output`` the result's arrays
        count in the memory.
    overwrite : bool
        Replace an ``output`` that holds another study's result (or a netCDF file that is not a
        gearsweep result, or a damaged one: it starts as netCDF does but cannot be read);
        without it that raises ``ResultError`` before anything runs, as ``gearsweep run``
        without ``--overwrite`` refuses it. The same study's result (the same values; comments,
        spacing and device aside) is replaced without it. A file that is not netCDF at all (a
        study, a text) is never replaced: ``ResultError``, with ``overwrite=True`` too.

    Returns
    -------
    xarray.Dataset
        In memory; the same variables, coordinates and attributes as the file the CLI writes.

    Warns
    -----
    StepLimitWarning
        Once, if cases use a step beyond the method's stability limit (``solver.step_guard:
        warn``; they are marked in ``beyond_step_limit``): the line the CLI prints, naming
        ``output`` or else the study.
    ContactLossWarning
        Once, if cases of a driven scene without backlash have p below 0 in the steady state
        (marked in ``contact_lost``): their teeth would separate, which the scene does not model.
    ChunkSizeWarning
        If ``chunk_cases`` is below one round of the kernel's blocks on all threads (mostly
        empty work), or gives chunks longer than the runner allows (about a tenth of the
        study's kernel time, 1-30 s: then cut to that, as the CLI cuts them): the notes the CLI
        prints for ``--chunk-size``.
    SpectrumAliasingWarning
        Before running, if the spectrum's ``samples_per_period`` (written in the study, or all
        the steps) folds the orders up to the natural frequency's plus the excitation's highest
        onto the kept lines: the line the CLI prints.
    """
    if output is not None and not isinstance(output, str | Path):
        raise StudyError("<study>", "output", repr(output)[:60], "a file path (str or Path)")
    if output is not None and study_named(output):  # before anything runs
        raise StudyError("<study>", "output", str(output)[:60], RESULT_NAME)
    if output is not None:
        output = output_path(_user_path(output))
    chunk_cases = _chunk_cases(chunk_cases)
    _check_flags(yes=yes, overwrite=overwrite)  # yes="no" went ahead
    _check_progress(progress)
    st, text, name = _load(study)
    if output is not None and (read := reads_output(st, output)) is not None:
        raise ResultError(f"{output}: not a place for the result: it is {read.name}, which the"
                          " study reads (the result would replace it)")
    if output is not None and not overwrite:
        check_replaces(st, output, "choose another output, or pass overwrite=True"
                                          " to replace it")
    # With an output, the run holds it as the CLI does (``OutputLock``: one run at a time; a
    # second, from Python or the shell, is refused naming the first) and refuses another
    # study's saved chunks there (``check_partial``): without them a call beside a running
    # `gearsweep run` made that run's file unreadable, and one of another study deleted its
    # chunks (an adversarial test).
    if isinstance(st, MeshStudy | AnalysisStudy):
        where = name if output is None else str(output)
        if isinstance(st, MeshStudy) and not yes:  # as the CLI refuses it without --yes
            check_memory(st, where, ahead="pass yes=True to go ahead")
        if isinstance(st, AnalysisStudy) and not yes:
            check_analysis(st, "results" if output is None else Path(output).parent, where,
                           ahead="pass yes=True to go ahead")
        if output is None:
            return run_unchunked(st, text, "results")
        with OutputLock(output):
            ds = run_unchunked(st, text, Path(output).parent)
            write_netcdf(ds, output)
        return ds
    plan = make_plan(st, text, name)
    if not yes:
        _within_limits(plan, chunk_cases, output is None, name if output is None else str(output))
    small = small_chunk_note(plan, chunk_cases)
    if small:  # the CLI's note for --chunk-size
        warnings.warn(f"{name}: chunk_cases={chunk_cases}: {small}", ChunkSizeWarning, stacklevel=2)
    asked, (chunk_cases, capped) = chunk_cases, chunk_size(plan, chunk_cases)  # as the CLI runs
    if capped and asked is not None:  # (it ran the chunks asked for, and estimated the cut ones)
        warnings.warn(f"{name}: chunk_cases={asked} gives {capped_chunk_note(plan)}; using"
                      f" {chunk_cases} cases per chunk", ChunkSizeWarning, stacklevel=2)
    aliased = spectrum_aliasing(plan)
    if aliased:  # the line the CLI prints
        warnings.warn(f"{name}: {aliased}", SpectrumAliasingWarning, stacklevel=2)
    if output is None:
        ds = run_plan(plan, backend=InProcess(), progress=progress, chunk_cases=chunk_cases)
    else:
        with OutputLock(output):
            check_partial(plan, output)
            with run_to_file(plan, output, chunk_cases=chunk_cases, progress=progress) as lazy:
                ds = lazy.load()
    _warn_result(plan, ds, name if output is None else output)
    return ds


def advise(study: StudyLike, *, target: float = DEFAULT_TARGET) -> Advice:
    """The step advisor on a dynamic study of a gear scene, before anything runs: the steps per
    mesh period its integration needs for a trajectory error of ``target`` (relative to the
    amplitude, at the lowest speed), their cost, the error of the study's own steps, and the
    warnings (a step beyond the method's stability limit, light damping, a parametric resonance
    of k(t), the step guard's map check), as ``gearsweep advise`` gives them.

    Returns
    -------
    gearsweep.analysis.advise.Advice
        ``.steps_per_period`` (advised), ``.expected_error``, ``.msteps`` (the study's cost in
        millions of steps), ``.chosen`` and ``.chosen_error`` (the steps as written),
        ``.kink_steps_per_period``, ``.warnings``; ``print(advice)``: the text `gearsweep
        advise` prints (``.report()``: without the study's name).

    Raises
    ------
    StudyError
        For a ``target`` outside (0, 1), a mesh or analysis study (nothing is integrated), a
        Mathieu scene (no accuracy model), and as ``run``: the line the CLI prints.
    """
    st, text, name = _load(study)
    return study_advice(st, text, name, target)


def open_result(path: str | Path) -> xr.Dataset:
    """Open a result file in memory; one line (``ResultError``) if it is missing or not ours."""
    if not isinstance(path, str | os.PathLike):  # (3 raised os.fspath's TypeError)
        raise ResultError(f"path: a result file's path (str or Path), not {type(path).__name__}"
                          f" {repr(path)[:40]}")
    path = _user_path(path)
    if not path.exists():
        raise ResultError(f"{path}: no such result file (run the study first)")
    if study_named(path):
        raise ResultError(f"{path}: this is a study, not a result; try `gearsweep validate {path}`"
                          " or run it")
    try:
        ds = xr.load_dataset(path)
    except (OSError, ValueError) as exc:  # one line, as ``cli.describe`` says it
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if "IO backends" in why:  # xarray: no engine recognises the file (four lines of advice)
            why = "not a netCDF file"
        raise ResultError(f"{path}: not a readable netCDF file ({why})") from None
    if "study" not in ds.attrs:
        raise ResultError(f"{path}: not a gearsweep result (no 'study' attribute)")
    return ds


def result_model(ds: xr.Dataset | str | Path, **case: float) -> MeshModel | MathieuModel:
    """The resolved model a dynamic result (a Dataset, or a result file's path) was computed
    with (every number in SI).

    A field of the model the result sweeps (``mean_force``, ``damping``, ``backlash``, ...,
    ``torque`` as the mean force; Mathieu's ``alpha``, ``beta``, ``gamma``) has one value per
    case: select it with ``case``, a coordinate value in the result's own unit as for
    ``ds.sel`` (``result_model(ds, mean_force=833, backlash=0.1)``: 833 N, 0.1 mm), or already
    selected in ``ds`` (``result_model(ds.sel(mean_force=833))``: a scalar coordinate). A swept
    field not selected is NaN, never the scene's own value, which the kernel did not run. A gear
    scene sweeping its load has k(t) and e(t) of each load: selected, they are computed again
    from the study the result carries (as the run did); else their amplitudes and phases are NaN
    (a stiffness typed beside the gear is the same at every load, and kept).
    ``speed`` is not a field of the model (each case's mesh frequency)."""
    if isinstance(ds, str | Path):
        ds = open_result(ds)
    if not isinstance(ds, xr.Dataset):  # (a DataArray said "carries no resolved model")
        raise ResultError(f"give the result's Dataset (gearsweep.run or open_result), or a result"
                          f" file's path, not a {type(ds).__name__}")
    if "model" not in ds.attrs:
        raise ResultError("this result carries no resolved model (a mesh or analysis study:"
                          " only a dynamic study's result has one; or written by an older"
                          " gearsweep)")
    model = model_from_record(json.loads(ds.attrs["model"]))
    # a swept dim that ``ds.sel``/``ds.isel`` made a scalar coordinate is selected at its value
    # (the model had the scene's value there, which the kernel did not run)
    chosen = [n for n, c in ds.coords.items() if n in SWEEPABLE and n != "speed" and c.ndim == 0]
    case = {n: float(ds[n]) for n in chosen} | case
    ds = ds.expand_dims(chosen)
    swept = [d for d in ds.dims if d in SWEEPABLE and d != "speed"]
    if "speed" in case:  # swept, but no field of the model (it said "not a swept field")
        raise ResultError("speed is not a field of the model: a case's speed sets only its mesh"
                          " frequency; " + (f"select among {', '.join(swept)}" if swept else
                                            "the model is the same at every speed:"
                                            " result_model(ds) alone gives it"))
    unknown = sorted(set(case) - set(swept))
    if unknown:
        raise ResultError(f"{', '.join(unknown)}: not a swept field of this result's model"
                          f" (swept: {', '.join(swept) or 'none'})")
    si = {}
    for name, value in case.items():
        coord = ds[name]
        if isinstance(value, str):  # '100 um': in the coordinate's own unit, as sel() takes it
            try:
                value = float(to_display(np.array([to_si(value, SWEEPABLE[name])]),
                                         SWEEPABLE[name])[0])
            except UnitParseError as exc:
                raise ResultError(f"{name}={value!r}: {exc}") from None
        elif isinstance(value, bool) or not isinstance(value, int | float | np.number):
            raise ResultError(f"{name}={value!r}: a number in the result's unit"
                              f" ({coord.attrs.get('units', '?')}) or a string with a unit")
        rtol = 1e-9  # the file's value to 9 digits (5.0 finds 4.99999999999 of a range)
        if isinstance(value, np.floating) and np.finfo(value.dtype).eps > rtol:  # np.float32(0.1)
            rtol = float(np.finfo(value.dtype).eps)  # is 0.1 to its own precision only (it said
            # "not one of the result's values; the nearest is 0.1"; an outside tester)
        at = np.flatnonzero(np.isclose(coord.values, float(value), rtol=rtol, atol=0.0))
        if at.size > 1 and isinstance(value, np.floating):
            raise ResultError(f"{name}={value!r}: {at.size} of the result's values are within"
                              f" {value.dtype}'s precision of it: give it as a float (64-bit)")
        if at.size != 1:
            near = coord.values[int(np.argmin(np.abs(coord.values - float(value))))]
            raise ResultError(f"{name}={value!r} is not one of the result's {coord.size} values"
                              f" ({coord.values.min():g} to {coord.values.max():g}"
                              f" {coord.attrs.get('units', '')}; the nearest is {near:.10g})")
        si[name] = float(si_values(coord.isel({name: int(at[0])})))
    load = {"torque", "mean_force"} & set(swept)
    scene = result_study(ds).scene if load else None  # the study is parsed only then
    if load and getattr(scene, "gear", None) is not None:  # k(t), e(t) per load
        name = next(iter(load))
        if name in si:
            torque = si[name] if name == "torque" else si[name] * model.base_radius
            at_load = make_plan(result_study(ds), ds.attrs["study"]).model_for_load(torque)
            model = dataclasses.replace(at_load, mean_force=mean_mesh_force(torque, model.base_radius))
        else:
            def unknown_load(hs: tuple[Harmonic, ...]) -> tuple[Harmonic, ...]:
                return tuple(Harmonic(math.nan, h.order, math.nan) for h in hs)

            typed_k = scene.stiffness is not None  # k(t) typed beside the gear replaces the
            model = dataclasses.replace(  # pair's: the same at every load, kept
                model, mean_force=math.nan,
                stiffness=model.stiffness if typed_k else math.nan,
                stiffness_harmonics=model.stiffness_harmonics if typed_k
                else unknown_load(model.stiffness_harmonics),
                ste_harmonics=unknown_load(model.ste_harmonics))
        si.pop(name, None)
        swept.remove(name)
    changes = {("mean_force" if d == "torque" else d): si.get(d, math.nan) for d in swept}
    if "torque" in swept and "torque" in si:
        changes["mean_force"] = mean_mesh_force(si["torque"], model.base_radius)
    return dataclasses.replace(model, **changes)


def result_study(ds: xr.Dataset | str | Path) -> Study | MeshStudy:
    """The study a result (a Dataset, or a result file's path) was computed from, validated again
    from the text it carries; ``run`` of it runs that text."""
    if isinstance(ds, str | Path):
        ds = open_result(ds)
    if not isinstance(ds, xr.Dataset) or "study" not in ds.attrs:
        raise ResultError("not a gearsweep result (no 'study' attribute): give the Dataset of"
                          " gearsweep.run or open_result, or a result file's path")
    return parse_study(ds.attrs["study"], "<result>", base=ds.attrs.get("study_folder"))


__all__ = ["advise", "estimate", "load", "open_result", "result_model", "result_study", "run", "run_study"]
