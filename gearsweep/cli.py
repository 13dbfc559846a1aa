"""Command-line interface: ``gearsweep run | validate | advise | inspect``.

Errors that are the user's input (``GearsweepError``) print one line and exit with code 2; a
traceback is shown only with ``--debug``.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import re
import signal
import sys
import tempfile
import threading
import time
import warnings
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from gearsweep import __version__
from gearsweep.analysis.advise import ACCURACY_NOTE
from gearsweep.errors import (
    EXIT_HUNG_UP,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USAGE,
    NO_VALUE,
    STOP_SIGNALS,
    DeviceError,
    GearsweepError,
    ResultError,
    StudyError,
    article,
)
from gearsweep.files import RESULT_NAME, replace_problem, study_named, user_path
from gearsweep.gear import GeometryWarning
from gearsweep.jit import set_up_runtime_in_background
from gearsweep.kernels.cuda import kernel_for
from gearsweep.model import MeshModel
from gearsweep.study.advice import DEFAULT_TARGET, check_target, plan_advice, study_advice
from gearsweep.study.checkpoint import SUFFIX, chunk_folder, remove_checkpoints, saved_layout
from gearsweep.study.estimate import (
    CHUNK_SECONDS,
    PROGRESS_CHUNKS,
    SHORTEST_CAP_SECONDS,
    before_refusing,
    capped_chunk_note,
    chunk_cases,
    quick_estimate,
    shortest_chunk_seconds,
    small_chunk_note,
)
from gearsweep.study.execute import (
    LIMITS,
    DaskBackend,
    InProcess,
    _size,
    check_limits,
    chunks_to_run,
    contact_lost_text,
    cores,
    step_limit_text,
    stream_to_file,
)
from gearsweep.study.outputs import impact_aliasing, spectrum_aliasing
from gearsweep.study.plan import (
    cases_beyond_step_limit,
    make_plan,
    transient_residual,
)
from gearsweep.study.provenance import command
from gearsweep.study.schema import (
    is_netcdf,
    line_of,
    load_study,
    load_yaml,
    parse_study,
    read_text,
    replaced_by_sweep,
    summary,
)
from gearsweep.study.workspace import (
    BusyError,
    OutputLock,
    check_partial,
    check_replaces,
    output_path,
    reads_output,
    replaced_result,
    saved_chunks,
    writing_run,
)


def _default_output(study_path: str) -> Path:
    return Path("results") / (Path(study_path).stem + ".nc")


NAME_MAX = 237
"""The longest file name of a result [bytes]: 255, the common file systems' limit, less what the
longest name written beside it adds (``.NAME.XXXXXXXX.partial`` of the atomic writer)."""


def _check_writable(path: Path, study: str | None = None, spec=None) -> None:
    """Fail before the run, not after it, when the output cannot be written: a file is created
    and removed in its folder (what the atomic writer will do). The result replaces the file at
    ``path`` by renaming a new one over it, so ``path`` must be a regular file or nothing: not a
    folder, not a device (``-o /dev/null`` replaced the device with a file), and neither the
    study file being run nor a file it reads (``spec``, the study: its measured excitation, an
    analysis study's input results; ``workspace.reads_output``). A path through folders the
    run will make is compared as it will be then (``new/../s.yaml`` is ``s.yaml``, through links
    too)."""

    def refuse(allowed: str) -> None:
        raise StudyError(str(path), "--output", str(path), allowed)

    long = [part for part in path.parts if len(part.encode()) > 255]
    if long:  # the OS's own error came as a traceback from the checks below
        refuse(f"a path of names of at most 255 bytes ({long[0][:12]}... has"
               f" {len(long[0].encode())})")
    if len(path.name.encode()) > NAME_MAX:
        refuse(f"a file name of at most {NAME_MAX} bytes ({len(path.name.encode())}: the result"
               " is written beside it under a longer temporary name)")
    for above in [*path.parents][::-1]:  # as written: '-o study.yaml/../x.nc' cannot be made
        if above.exists() and not above.is_dir() or above.is_symlink() and not above.exists():
            refuse(f"a path in a folder ({above} is a file)")
    real = Path(os.path.realpath(path))  # as the run will reach it: links, '..', new folders
    try:
        same = study not in (None, "-") and real.exists() and Path(study).exists() \
            and os.path.samefile(real, study)
    except OSError:
        same = False
    if same:
        refuse("another path than the study file's (the result would replace it)")
    read = reads_output(spec, real) if spec is not None else None
    if read is not None:
        refuse(f"another path than {read.name}, which the study reads (the result would replace"
               " it)")
    problem = replace_problem(real)
    if problem is not None:
        refuse(problem)
    existing = real.parent  # folders still to be made are made by the run, not by this check (a
    while not existing.exists() and existing != existing.parent:  # refused run left them)
        existing = existing.parent
    try:
        fd, tmp = tempfile.mkstemp(prefix=".gearsweep-", suffix=".probe", dir=existing)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        refuse(f"a writable path ({exc.strerror or type(exc).__name__})")
    if real.exists() and not os.access(real, os.W_OK):
        refuse("a writable path (permission denied)")


def _shown(path: str) -> str:
    """The name a study is reported under: its path, or ``<stdin>`` for ``-``."""
    return "<stdin>" if path == "-" else path


def _plan(study, text: str, path: str):
    """``make_plan`` with its problems reported under the study file's name and line."""
    return make_plan(study, text, _shown(path))


def _in_file(exc: StudyError, text: str, path: str) -> StudyError:
    """A problem found after parsing (field, value, allowed; no file) at its line of the study
    file, as the schema reports its own."""
    if exc.file != "<study>" or not text:
        return exc
    raw = load_yaml(text, _shown(path))
    return StudyError.many(_shown(path), [(line_of(raw, field), field, value, allowed)
                                          for _, field, value, allowed in exc.problems])


def _summary(study, plan, est_line: str) -> str:
    """validate's one line: scene, cases, solver, outputs, and the estimate."""

    swept = replaced_by_sweep(study)
    replaced = f"; the sweep replaces {', '.join(swept)}" if swept else ""
    dims = ", ".join(f"{d}={len(plan.grids[d])}" for d in plan.dims)
    extra = f" x directions {plan.directions}" if plan.continued else ""
    speed = ""
    if "speed" in plan.grids:
        g = plan.grids["speed"]
        speed = f", speed {g.min():.6g}-{g.max():.6g} rpm" if len(g) > 1 else f", speed {g[0]:.6g} rpm"
    return (f"scene {study.scene.kind!r}, {plan.n_cases:,} cases ({dims}{extra}){speed},"
            f" {study.solver.method} at {study.solver.steps_per_period} steps/period,"
            f" outputs {', '.join(plan.outputs)}{replaced}; estimate: {est_line}")


def _check_output_arg(output: str | None, name: str) -> None:
    """``-o``'s value checked as a file path, by ``run`` and ``validate`` alike (validate took a
    folder that run refuses, and looked for an analysis' inputs beside it)."""
    if output is None:
        return
    if not output.strip():
        raise StudyError(name, "--output", output, "a file path (it is empty)")
    if output == "-":  # as the study's '-' is stdin, a user may mean stdout: it wrote ./-
        raise StudyError(name, "--output", output, "a file path (a netCDF result is not"
                         " written to stdout; write it to a file, or './-' for a file named '-')")
    try:
        folder = output.endswith(("/", os.sep)) or Path(output).is_dir()  # (Path() drops '/')
    except OSError:  # a name too long, say: said by the output's own checks, in one line
        folder = False
    if folder:
        raise StudyError(name, "--output", output, "a file path, not a folder")
    if study_named(output):
        raise StudyError(name, "--output", output, RESULT_NAME)


def cmd_validate(args: argparse.Namespace) -> int:

    study, text = load_study(args.study)
    name = _shown(args.study)
    _check_output_arg(getattr(args, "output", None), name)
    if getattr(study, "type", None) == "mesh":
        memory = _check_mesh_memory(study, name, args.yes)
        print(f"{name}: ok -- {summary(study)}, peak memory about {_size(memory)}")
        return 0
    if getattr(study, "type", None) == "analysis":
        from gearsweep.study.analyses import check_inputs, missing_inputs

        # where `run` with the same -o (or without: results/) reads them: validate looked in
        # results/ while `run -o bal.nc` read the output's folder (an outside tester)
        folder = output_path(args.output or _default_output(args.study)).parent
        try:
            check_inputs(study, folder)  # what run would refuse of them, said now
        except StudyError as exc:
            raise _in_file(exc, text, args.study) from None
        from gearsweep.study import analysis_cost

        est = (analysis_cost.estimate(study, folder) if args.yes
               else analysis_cost.check_limits(study, folder, name))
        reads = (f", its inputs read from {folder}{os.sep}"
                 if getattr(study.analysis, "inputs", list)() else "")
        print(f"{name}: ok -- analysis study {study.analysis.kind!r}{reads}; estimate:"
              f" {est.line()}")
        missing = missing_inputs(study, folder)
        if missing is not None:  # valid, but run would stop: said now, as run would say it
            for line in _in_file(missing, text, args.study).lines:
                print(f"gearsweep: note: {line}", file=sys.stderr)
        return 0
    plan = _plan(study, text, args.study)
    chunk, _ = chunk_cases(plan, None)  # the chunks `run` cuts (the default ones, without the
    # runner's cap, were 3 where `run --estimate` said 4, and another memory)
    est, _ = quick_estimate(plan, chunk)
    if not args.yes:  # validate refuses what run refuses (without --yes)
        est, _ = before_refusing(plan, est, chunk)
        check_limits(est, name)
    print(f"{name}: ok -- {_summary(study, plan, est.line())}")
    try:  # the study may be meant for another machine's GPU: said, not refused
        kernel_for(study.solver.device, study.solver.precision)
    except DeviceError as exc:
        print(f"gearsweep: note: {name}: {exc}: `gearsweep run` refuses it on this machine",
              file=sys.stderr)
    if study.solver.step_guard != "off":  # what run will warn of, said before it runs
        n = cases_beyond_step_limit(plan)
        beyond = step_limit_text(plan, n or 0, name, before=True)
        if beyond is not None:
            print(f"gearsweep: warning: {beyond}", file=sys.stderr)
        elif n is None:
            print(f"gearsweep: note: {name}: the step guard's grid is too large to check here;"
                  " run checks every case and says how many are beyond the step limit",
                  file=sys.stderr)
    if isinstance(plan.model, MeshModel):  # what the steps as written cost in accuracy
        a = plan_advice(plan, ACCURACY_NOTE, free_vibration=False)  # (the note reads the steps' error)
        if a.chosen_error is not None and a.chosen_error > ACCURACY_NOTE and not any(
                "stability limit" in w for w in a.warnings):  # (the step guard says that)
            print(f"gearsweep: note: {name}: {study.solver.steps_per_period} steps per mesh"
                  f" period: expected trajectory error up to {a.chosen_error:.0%} of the"
                  f" amplitude at the lowest speed ({study.solver.method}; the step advisor's"
                  " bound, which can overestimate far below resonance: docs/precision.md);"
                  f" `gearsweep advise {name}` gives the steps a target needs", file=sys.stderr)
    _aliasing_warning(plan, name)
    impacts = impact_aliasing(plan)  # (run says it after the cases, where flanks parted)
    if impacts is not None:
        print(f"gearsweep: warning: {name}: {impacts}", file=sys.stderr)
    fast = _pitch_line_note(plan)
    if fast is not None:
        print(f"gearsweep: note: {name}: {fast}", file=sys.stderr)
    rigid = _rigid_driven_gear_note(study)
    if rigid is not None:
        print(f"gearsweep: note: {name}: {rigid}", file=sys.stderr)
    left = transient_residual(plan)
    if left is not None:
        residual, speed, need, mu = left
        how = ("exp(Re(lambda) periods x T), lambda the slower pole of m s^2 + c s + k"
               " (Re -c / (2 m) below critical damping), at {:g} rpm, the least damped case"
               if mu is None else
               f"|mu|^periods, the fixed-step map's largest Floquet multiplier {mu:.4g} per"
               " mesh period (" + ("the step guard's map check" if plan.model.stiffness_harmonics
                                   else "the method's R(h lambda) at the poles, constant stiffness")
               + "), at {:g} rpm, the slowest to decay")
        shown = f"{residual:.{0 if residual >= 0.1 else 1}%}"
        print(f"gearsweep: note: {name}: solver.transient_periods"
              f" {study.solver.transient_periods} leave up to {shown} of the start's free"
              f" vibration ({how.format(speed)}); a beat slower than the record can pass"
              " the settle test" + (", so run flags each case left above"
                                     " solver.settle_tolerance not settled (status 2)"
                                     if plan.driven else "") + f": {need} transient periods leave"
              f" {study.solver.settle_tolerance:.0%}", file=sys.stderr)
    return 0


_ADDRESS = re.compile(r"(?:tcp://)?(?:\[[0-9a-fA-F:.]+\]|[^\s:/\[\]]+):(\d{1,5})")
"""A dask scheduler's address: ``[tcp://]HOST:PORT`` (TLS needs a security context the command
line does not take: ``tls://`` ended in a TypeError traceback)."""


def _backend(args: argparse.Namespace):

    if args.scheduler:
        m = _ADDRESS.fullmatch(args.scheduler.strip())
        if not m or not 0 < int(m.group(1)) < 65536:  # before dask, whose client raised
            raise StudyError(_shown(args.study), "--scheduler", args.scheduler,  # in a thread
                             "a scheduler's address, tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786)")
        return DaskBackend(scheduler=args.scheduler.strip())
    if args.workers:
        return DaskBackend(workers=args.workers)
    return InProcess()


_STOP = threading.Event()
"""Set by the first SIGINT of ``gearsweep run``: stop after the chunks being computed."""


_COMPUTING = threading.Event()
"""Set while ``gearsweep run`` computes its chunks (a Ctrl-C before stops before the first)."""


_left: int | None = None
"""The chunks ``gearsweep run`` has still to compute, the one computing included (``_stoppable``);
``None`` before the first begins (the kernel loading, or compiling on a cold cache)."""

_drains = False
"""Whether the running backend waits for its chunks in flight on a stop and says how many
(``DaskBackend.stop``, ``stopping``): then its line is printed when it knows them."""


def _stop_line(n: int = 1) -> str:
    """What the first Ctrl-C does, in words (``_stoppable``), ``n`` chunks being computed: a
    one-chunk run stopped in its compile was told "stopping after the chunk being computed",
    then ran to its end and wrote its file, exit 0; with several workers it said "the chunk
    being computed" and dropped the others in flight (outside testers). ``n`` 0 (a cluster's
    stop that found no chunk begun) is said so: it was told "the chunk being computed, which
    is kept" (a reviewer)."""
    if _left is None:
        return "stopping before the first chunk begins"
    if n == 0:
        return "stopping now: no chunk is being computed"
    n = max(1, min(_left, n))
    chunks = "chunk" if n == 1 else f"{n} chunks"
    if _left <= n:
        return f"finishing the last {chunks} and writing the file"
    return (f"stopping after the {chunks} being computed, which {'is' if n == 1 else 'are'}"
            " kept")


def _say_stopping(n: int = 1) -> None:
    again = " (Ctrl-C again to stop at once)" if n or _left is None else ""
    print(f"gearsweep: {_stop_line(n)}{again}", file=sys.stderr)


def _on_sigint(signum, frame) -> None:
    if _STOP.is_set():  # a second Ctrl-C: stop now (the chunks saved so far are kept)
        raise KeyboardInterrupt
    _STOP.set()
    if _COMPUTING.is_set() and not (_drains and _left is not None):  # (a chunk may last up
        _say_stopping()  # to CHUNK_SECONDS)


_signalled: int | None = None
"""The signal that stopped ``gearsweep run`` at once (``_on_sigterm``), its exit code's
(``_exit_code``); ``None``: a Ctrl-C of the chunked run's own."""


def _on_sigterm(signum, frame) -> None:
    """SIGTERM (``kill``, ``docker stop``, a batch system's time limit, each followed by SIGKILL
    after a grace period), or SIGHUP (the terminal closed): stop now, as a second Ctrl-C does,
    once the main thread is back from its current range of the kernel. The chunks already
    computed are saved first: under the default action they died with the process while
    waiting for the saver thread (up to two chunks, each up to ``CHUNK_SECONDS`` of computing).
    A mesh or analysis study (computed in one piece) takes Ctrl-C too this way."""
    global _signalled
    _signalled = signum
    _STOP.set()
    raise KeyboardInterrupt


def _stopped_how() -> str:
    """How the run was stopped, in its line: ``interrupted``, ``terminated (SIGTERM)``, ..."""
    if _signalled in (None, signal.SIGINT):
        return "interrupted"
    return f"terminated ({signal.Signals(_signalled).name})"


def _exit_code() -> int:
    """The exit code of a run stopped by ``_signalled`` (128 + the signal, as a shell says)."""
    codes = {signal.SIGINT: EXIT_INTERRUPTED, signal.SIGTERM: EXIT_TERMINATED}
    if hasattr(signal, "SIGHUP"):  # (not on Windows)
        codes[signal.SIGHUP] = EXIT_HUNG_UP
    return codes.get(_signalled, EXIT_INTERRUPTED)


@contextlib.contextmanager
def _stop_handlers(on_sigint):
    """``on_sigint`` for SIGINT and ``_on_sigterm`` for SIGTERM and SIGHUP while the block runs
    (in the main thread; elsewhere none can be set), and the unraisable hook of a stop
    (``_quiet_once_stopping``); a signal ignored when the run began stays ignored (``nohup``, a
    background job of a shell without job control: the terminal's Ctrl-C or hang-up stopped
    it)."""
    previous, unraisable = {}, sys.unraisablehook
    try:
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                if signal.getsignal(signum) != signal.SIG_IGN:
                    handler = on_sigint if signum == signal.SIGINT else _on_sigterm
                    previous[signum] = signal.signal(signum, handler)
            sys.unraisablehook = _quiet_once_stopping(unraisable)
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        sys.unraisablehook = unraisable


def _stoppable(backend):
    """``backend`` whose ``run`` stops cleanly between chunks once ``_STOP`` is set: every chunk
    computed so far, those that were computing when the stop came included (on a dask cluster
    every one begun: ``DaskBackend.stop``), is saved by the caller before the stop (raised as
    ``KeyboardInterrupt``); a stop during the last chunks lets the run finish and write its
    file; a stop before the first chunk (while the kernel loaded or compiled) stops before it.
    (The chunk that finished after the stop was dropped: a single-chunk continued sweep ran to
    its end and kept nothing; an adversarial test.) Keeps ``_left`` and ``_drains``, which
    the Ctrl-C's line tells from."""
    base = type(backend)
    drains = isinstance(backend, DaskBackend)  # it waits for its chunks in flight itself

    class Stoppable(base):
        def run(self, plan, todo, *args):
            global _left, _drains
            if _STOP.is_set():  # no chunk has begun
                raise KeyboardInterrupt
            last = len(todo) - 1
            _left = len(todo)
            if drains:
                self.stop, self.stopping, _drains = _STOP.is_set, _say_stopping, True
            yielded = 0
            for i, item in enumerate(base.run(self, plan, todo, *args)):
                yield item
                yielded += 1
                _left = last - i
                if _STOP.is_set() and i < last and not drains:
                    raise KeyboardInterrupt
            if _STOP.is_set() and yielded < len(todo):  # a cluster's stop, its chunks begun
                raise KeyboardInterrupt

    backend.__class__ = Stoppable
    return backend


def _check_device(study, text: str, args: argparse.Namespace) -> None:
    """The study's device must be there: else one line naming where the device was asked for,
    ``--device`` or the study's ``solver.device`` (file:line), with the advice for that place."""
    try:
        kernel_for(study.solver.device, study.solver.precision)
    except DeviceError as exc:
        reason = str(exc).removeprefix(f"device {study.solver.device}: ")
        if args.device:
            raise DeviceError(f"--device {args.device}: "
                              + reason.replace("use device: ", "use --device ")) from None
        name = _shown(args.study)
        line = line_of(load_yaml(text, name), "solver.device") if text else None
        raise StudyError(name, "solver.device", study.solver.device, reason, line) from None


def _check_mesh_memory(study, name: str, yes: bool) -> float:
    """A mesh study's peak memory; one line (``LimitError``) beyond the limit unless ``yes``."""
    from gearsweep.study.mesh import check_memory, memory_bytes

    return memory_bytes(study) if yes else check_memory(study, name)


def cmd_run(args: argparse.Namespace) -> int:
    set_up_runtime_in_background()  # beside reading the study and planning (LLVM, no GIL)
    text, shown = read_text(args.study)
    try:  # --device replaces solver.device before the study's device checks
        study = parse_study(text, shown, device=args.device)
    except StudyError:
        if args.device is None:
            raise
        study = parse_study(text, shown)  # valid as written: the flag is refused below, by name
    name = _shown(args.study)
    if args.study == "-" and not args.output:
        raise StudyError(name, "--output", NO_VALUE, "a study read from stdin needs -o OUT.nc")
    _check_output_arg(args.output, name)
    out = output_path(args.output if args.output else _default_output(args.study))
    if not args.estimate:
        _check_writable(out, args.study, study)
        if not args.overwrite:
            check_replaces(study, out, "choose another -o, or pass --overwrite to replace it")
    if getattr(study, "type", None) in ("mesh", "analysis"):  # computed in one piece, no chunks

        unused = [o for o, v in (("--workers", args.workers), ("--chunk-size", args.chunk_size),
                                 ("--scheduler", args.scheduler), ("--device", args.device)) if v]
        if unused and not args.quiet:
            print(f"gearsweep: note: {name}: {article(study.type)} study is computed in one piece,"
                  f" in this process: {', '.join(unused)} do{'es' if len(unused) == 1 else ''}"
                  " not apply", file=sys.stderr)
        if study.type == "mesh" and not args.estimate:
            _check_mesh_memory(study, name, args.yes)
        if study.type == "analysis":  # what it will take, said (--estimate) or refused
            from gearsweep.study import analysis_cost
            from gearsweep.study.analyses import check_inputs

            if args.estimate:  # what validate and run refuse of its inputs, refused here too
                try:  # (an n_time too small for its harmonics was estimated, exit 0)
                    check_inputs(study, out.parent)
                except StudyError as exc:
                    raise _in_file(exc, text, args.study) from None
                print(f"{name}: analysis study {study.analysis.kind!r}, computed in one piece:"
                      f" {analysis_cost.estimate(study, out.parent).line()}")
                return 0
            if not args.yes:
                analysis_cost.check_limits(study, out.parent, name)
        elif args.estimate:  # a mesh study: its memory, as validate says it (no time model)
            from gearsweep.study.mesh import memory_bytes

            print(f"{name}: a mesh study, computed in one piece: peak memory about"
                  f" {_size(memory_bytes(study))} (its time is not estimated)")
            return 0
        from gearsweep.api import run_unchunked
        from gearsweep.study.dataset import write_netcdf

        t0 = time.perf_counter()
        # Nothing to save: every stop signal stops at once (``_on_sigterm``); one that comes
        # while xarray writes the file is taken once the file is closed, which is then removed
        # (``write_netcdf``). Without handlers, a Ctrl-C in the write hung for ever, and SIGTERM
        # left the lock files and the partial file (an outside tester).
        written = False
        try:
            with _stop_handlers(_on_sigterm), OutputLock(out):
                try:
                    ds = run_unchunked(study, text, out.parent)
                except StudyError as exc:
                    raise _in_file(exc, text, args.study) from None
                write_netcdf(ds, out, codec=args.codec)
                written = True
        except KeyboardInterrupt:
            if not written:  # (else the result is in place: a stop as the lock was let go)
                raise Interrupted(f"{_stopped_how()}: nothing written ({article(study.type)}"
                                  " study is computed in one piece: run the same command to"
                                  " compute it)") from None
        finally:
            _STOP.clear()
        for key in sorted(k for k in ds.attrs if k.endswith("_note")):  # (what is NaN, why)
            print(f"gearsweep: note: {name}: {ds.attrs[key]}", file=sys.stderr)
        if not args.quiet:
            print(f"{out}: {study.type} study in {time.perf_counter() - t0:.2f} s")
        return 0
    if args.device:  # --device overrides the study's solver.device
        study = study.model_copy(update={"solver": study.solver.model_copy(
            update={"device": args.device})})
    plan = _plan(study, text, args.study)
    if args.chunk_size is not None and (isinstance(args.chunk_size, str) or args.chunk_size < 1):
        raise StudyError(name, "--chunk-size", args.chunk_size, "a positive whole number of cases"
                         f" up to 1e{MAX_DIGITS} (100000, or 1e5)")
    if args.workers is not None and (isinstance(args.workers, str) or args.workers < 1):
        raise StudyError(name, "--workers", args.workers, "a positive whole number of workers")
    if args.workers is not None and args.workers > cores():  # each a process of the machine
        raise StudyError(name, "--workers", args.workers, (  # (10000 would start them all)
            f"at most this machine's {cores()} cores (a local worker is a process with its share"
            " of them; several machines: --scheduler)"))
    # An existing cluster is asked for its workers once, on connecting: the chunks are cut and
    # the estimate stated for them (chunked and priced for this machine, 6 chunks where its 4
    # workers wanted 8 or more, one of them idle; an outside tester).
    with contextlib.ExitStack() as connected:
        cluster = connected.enter_context(_backend(args)) if args.scheduler else None
        return _run_chunked(args, study, text, plan, out, name, cluster)


def _run_chunked(args: argparse.Namespace, study, text: str, plan, out: Path, name: str,
                 cluster: DaskBackend | None) -> int:
    """``gearsweep run`` of a study computed in chunks (``cluster``: the existing dask cluster
    of ``--scheduler``, connected)."""
    global _left, _drains
    workers = cluster.n_workers if cluster is not None else args.workers
    threads = cluster.threads if cluster is not None else cores() if args.workers else None
    # Chunks of at most about 30 s (progress, and a kill loses at most one chunk).
    chunk, capped = chunk_cases(plan, args.chunk_size, threads=threads, workers=workers)
    saved = saved_layout(out, plan.study_key, plan.n_lanes)
    if saved:  # a resumed run keeps its chunks: estimate with them, say so if asked for others
        asked_chunk = chunk
        chunk, capped = max(b - a for a, b in saved) * plan.cases_per_lane, False
        asked = [f for f, v in (("--chunk-size", args.chunk_size), ("--workers", args.workers))
                 if v is not None]
        if asked and chunks_to_run(plan, None, asked_chunk) == [tuple(c) for c in saved]:
            asked = []  # they give the saved chunks: nothing to say (said on every resume)
        if asked and not args.quiet:
            print(f"gearsweep: note: {out}: resuming in the interrupted run's {len(saved)} chunks;"
                  f" the chunks of {' and '.join(asked)} apply to a fresh run", file=sys.stderr)
    small = None if saved else small_chunk_note(plan, args.chunk_size, threads, workers)
    if small and not args.quiet:
        print(f"gearsweep: note: {name}: --chunk-size {args.chunk_size}: {small}", file=sys.stderr)
    if capped and args.chunk_size is not None and not args.quiet:
        print(f"gearsweep: note: {name}: --chunk-size {args.chunk_size} gives"
              f" {capped_chunk_note(plan, threads)}; using {chunk} cases per chunk", file=sys.stderr)
    # From arithmetic: no grid of cases, no compilation (any size answers at once). Whether the
    # kernel is compiled already (Numba's cache asked: 7-8 ms the first time in a process, of
    # which the warm-up, which asks too, then repeats most: 2-4 ms net, medians 43.9 against
    # 40.0 ms with the warm-up, 26 Nov 2026) is asked only where the answer can change what the
    # run says or does: with every specialisation counted as compiled on the spot, a study
    # that is neither shown its estimate (--estimate, or over SHOW_ESTIMATE_SECONDS) nor
    # refused by the limits, is not.
    est, _ = quick_estimate(plan, chunk, threads=threads, ask_cache=False, workers=workers)
    if args.estimate or est.seconds > SHOW_ESTIMATE_SECONDS or (not args.yes and est.over()):
        est, _ = quick_estimate(plan, chunk, threads=threads, workers=workers)
    if args.estimate:  # also for a GPU study on a machine without one: planning a GPU run
        print(f"{name}: {est.line()}")
        if saved:
            done, total = saved_chunks(plan, out, chunk)
            saying = (f"all {total} chunks already saved in {chunk_folder(out)}: a run writes"
                      " the result from them" if done == total else  # (nothing to compute)
                      f"{done} of {total} chunks already saved in {chunk_folder(out)}: a run"
                      " computes only the others")
            print(f"{name}: {saying} (the estimate is for them all)")
        try:  # what the run would be refused for (it said nothing of it; an outside test)
            check_partial(plan, out)
        except BusyError as exc:
            print(f"{name}: note: a run to this output would be refused: {exc}")
        held = None if args.overwrite else replaced_result(study, out)
        if held is not None:  # (it said nothing of this refusal either; an outside tester)
            print(f"{name}: note: a run to this output would be refused: {out} holds {held};"
                  " choose another -o, or pass --overwrite to replace it")
        _long_sweep_note(plan, args)
        return 0
    _check_device(study, text, args)  # no GPU: one line, exit 2, now
    if not args.yes:
        est, _ = before_refusing(plan, est, chunk, threads, workers)
        check_limits(est, name)
    _long_sweep_note(plan, args)
    _aliasing_warning(plan, name)  # (as validate: a spectrum that folds its lines, said first)
    progress = False if args.quiet else (True if sys.stderr.isatty() else "log")  # a log: lines
    # The handlers are ours from before the backend starts until it is closed (a local cluster
    # takes 0.5-1 s to close: a signal then, with Python's handlers back, ended in a bare
    # "interrupted" or SIGTERM's default action, the lock files left; an adversarial test). A
    # signal while a local cluster starts is held until its workers are up, then handled here
    # (``execute._starting_workers``; SIGTERM then ended the run without a word), and the run
    # stops before its first chunk.
    written = None
    try:
        with _stop_handlers(_on_sigint), OutputLock(out), (
                contextlib.nullcontext(cluster) if cluster is not None
                else _backend(args)) as backend:
            check_partial(plan, out)
            if not args.quiet and est.seconds > SHOW_ESTIMATE_SECONDS:
                print(f"{name}: {est.line()}", file=sys.stderr)
            saved, total = saved_chunks(plan, out, chunk)
            if saved and not args.quiet:  # (all of them: after a full disk, say)
                print(f"{out}: all {total} chunks already saved in {out}.chunks, writing the"
                      " result" if saved == total else f"{out}: resuming: {saved} of {total}"
                      f" chunks already saved in {out}.chunks, computing the others",
                      file=sys.stderr)
            t0 = time.perf_counter()
            if _STOP.is_set():  # a Ctrl-C before the first chunk
                raise KeyboardInterrupt
            _left = None
            _COMPUTING.set()
            written = stream_to_file(plan, out, backend=_stoppable(backend),
                                     chunk_cases=chunk, progress=progress, codec=args.codec)
    except (KeyboardInterrupt, SystemError) as exc:
        if written is None:  # (else the result is in place: a stop while the backend closed)
            if not (_STOP.is_set() or isinstance(exc, KeyboardInterrupt)):
                raise
            raise Interrupted(_interrupted_line(plan, out, chunk)) from None
    finally:
        _STOP.clear()
        _COMPUTING.clear()
        _left, _drains = None, False
    # Counted as the chunks were written: the file is not opened again to report them.
    for line in (step_limit_text(plan, written.beyond, out),
                 contact_lost_text(plan, written.contact_lost, out)):
        if line is not None:  # the text gearsweep.run warns, as one line
            print(f"gearsweep: warning: {line}", file=sys.stderr)
    impacts = impact_aliasing(plan, written.parted)  # (None where no case parted)
    if impacts is not None:  # the line gearsweep.run warns
        print(f"gearsweep: warning: {out}: {impacts}", file=sys.stderr)
    if not args.quiet:
        # The file's elapsed_seconds is the chunk phase; the wall time adds the one-time
        # loading (or compiling) of the kernel and the writing of the file: say both. A
        # resumed run says what it used of the earlier runs: the file's elapsed_seconds is
        # their chunk phases and this run's together (a resumed run said "1600000 cases in
        # 55 s" of 96 chunks, then gave this run's 0.8 s as the file's elapsed_seconds).
        w = written
        if w.earlier_chunks:
            runs = "an earlier run" if w.earlier_runs == 1 else f"{w.earlier_runs} earlier runs"
            resumed = (f" (resumed: {w.earlier_chunks} of {w.chunks} chunks from {runs},"
                       f" {w.chunks - w.earlier_chunks} computed now)")
            phase = (f"computing the chunks: {w.run_elapsed:.2f} s now,"
                     f" {_seconds(w.elapsed)} over the {w.earlier_runs + 1} runs, the file's"
                     " elapsed_seconds")
        else:
            resumed, phase = "", f"computing the chunks: {w.elapsed:.2f} s, the file's elapsed_seconds"
        print(f"{out}: {w.cases} cases{resumed} in {time.perf_counter() - t0:.2f} s ({phase})"
              + (f"; {w.flagged} flagged in 'status' (see its 'codes' attribute)"
                 if w.flagged else ""))
    return 0


def _seconds(s: float) -> str:
    """``1.23 s``, or where a total is unknown (NaN: an earlier run kept no record of its
    time) ``unknown (an earlier run kept no record)``."""
    return f"{s:.2f} s" if math.isfinite(s) else "unknown (an earlier run kept no record)"


SHOW_ESTIMATE_SECONDS = 30.0
"""``gearsweep run`` prints its estimate before a study estimated to last longer than this [s]."""


def _quiet_once_stopping(default):
    """``sys.unraisablehook`` that says nothing once a stop is asked: the stop, raised in the
    main thread wherever it is, may land in a callback or a destructor (llvmlite's object cache
    while a kernel loads), where Python prints "Exception ignored in ..." with a traceback
    beside the run's one line (an adversarial test, 1 in 20-40 SIGTERMs during the start)."""
    def hook(unraisable) -> None:
        if not _STOP.is_set():
            default(unraisable)
    return hook


def _interrupted_line(plan, out: Path, chunk: int | None) -> str:
    """What an interrupted run says; a chunk folder left with no chunk in it is removed."""
    done, total = saved_chunks(plan, out, chunk)
    how = _stopped_how()
    if done == 0 and not any(chunk_folder(out).glob(f"*/*{SUFFIX}")):
        remove_checkpoints(out)  # (it held the manifest only)
        return f"{how} before the first chunk was saved: nothing to continue from"
    return f"{how}: {done} of {total} chunks saved in {out}.chunks; run the same command to continue"


class Interrupted(Exception):
    """A run stopped by Ctrl-C (SIGINT): one line, exit 130; by SIGTERM: exit 143."""


def _long_sweep_note(plan, args: argparse.Namespace) -> None:
    """One line when a continued sweep alone lasts beyond the chunk target: it is never split."""
    floor_s = shortest_chunk_seconds(plan)
    if plan.continued and floor_s > CHUNK_SECONDS and not args.quiet:
        print(f"gearsweep: note: one continued sweep ({plan.chain:,} speeds) takes about"
              f" {floor_s:.0f} s and is never split (its state carries from speed to speed): a"
              " chunk lasts at least that long and a kill loses up to that much; split the speed"
              " range into several studies for shorter chunks", file=sys.stderr)


def describe(path: str | Path) -> str:
    """A plain-words summary of a result file."""
    import xarray as xr

    path = Path(path)
    try:
        path.stat()  # xarray's engines each warned they "fail while guessing" a name too long
    except OSError as exc:
        folder = chunk_folder(path)
        try:
            saved = len(list(folder.glob(f"*/chunk_*{SUFFIX}"))) if folder.is_dir() else 0
        except OSError:  # the folder's name is too long too, say
            saved = 0
        pid = writing_run(path)
        if pid is not None:  # a run going on (was "an interrupted run saved ...")
            raise ResultError(f"{path}: no result file there yet: a run (PID {pid}) is writing"
                              f" it now: {saved} chunk{'s' if saved != 1 else ''} saved so far"
                              f" in {folder}; inspect it once that run has finished") from None
        if saved:  # an interrupted run's output: say where its work is (was "no result file")
            raise ResultError(f"{path}: no result file there yet: an interrupted run saved"
                              f" {saved} chunk{'s' if saved != 1 else ''} in {folder}; run the"
                              " same command (gearsweep run STUDY -o"
                              f" {path}) to compute the others and write it") from None
        raise ResultError(f"{path}: no result file there ({exc.strerror or type(exc).__name__})"
                          ) from None
    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if "IO backends" in why:  # xarray: no engine recognises the file
            why = "not a netCDF file"
        raise ResultError(f"{path}: cannot open as a netCDF result ({why})") from None
    with ds:
        if "study" not in ds.attrs:  # as open_result: said "(no title) scene ?", exit 0
            raise ResultError(f"{path}: a netCDF file, not a gearsweep result (no 'study'"
                              " attribute); xarray.open_dataset or ncdump -h shows what it holds")
        lines = [f"{path}: {ds.attrs.get('title', '(no title)')}"]
        scene = str(ds.attrs.get("scene", "?"))
        if scene == "mesh":
            lines.append(f"  static mesh study, {ds.attrs.get('positions', '?')} positions per"
                         " mesh cycle")
        elif scene.startswith("analysis"):  # no solver of its own: its inputs say which
            inputs = [k.removeprefix("input_") for k in ds.attrs if k.startswith("input_")
                      and k not in ("input_cases", "input_elapsed_seconds")]
            lines.append(f"  {scene.replace(': ', ' study ')}"
                         + (f", reading {', '.join(inputs)}" if inputs else ""))
        else:
            lines.append(f"  scene {ds.attrs.get('scene', '?')}, {ds.attrs.get('method', '?')} at "
                         f"{ds.attrs.get('steps_per_period', '?')} steps per mesh period, "
                         f"{ds.attrs.get('transient_periods', '?')} transient + "
                         f"{ds.attrs.get('record_periods', ds.attrs.get('recorded_periods', '?'))}"
                         " recorded periods"
                         + (f", on {ds.attrs['device']}"
                            + (f" ({ds.attrs['device_name']})" if "device_name" in ds.attrs
                               else "")
                            + f" in {ds.attrs.get('precision', '?')}"
                            if "device" in ds.attrs else ""))
        history = str(ds.attrs.get("history", "?")).splitlines() or ["?"]
        lines.append("  history: " + "\n           ".join(history))  # a line per run
        resumed = _resumed_line(ds.attrs)
        if resumed:
            lines.append(f"  {resumed}")
        lines.append("  dimensions:")
        damaged: list[str] = []  # variables whose data cannot be read (the header can)
        for d in ds.dims:
            c = ds[d] if d in ds.coords else None
            if c is not None and _read(c, damaged) is None:
                lines.append(f"    {d:<14} {c.size:>6} values, damaged: cannot be read")
            elif c is not None and c.size and c.dtype.kind in "fi":
                units = c.attrs.get("units", "")  # '1': dimensionless, no unit to print
                lines.append(f"    {d:<14} {c.size:>6} values from {float(c.min()):.6g} to "
                             f"{float(c.max()):.6g}" + (f" {units}" if units not in ("", "1")
                                                        else ""))
            elif c is not None:
                lines.append(f"    {d:<14} {c.size:>6} values: {', '.join(map(str, c.values[:6]))}")
            else:
                lines.append(f"    {d:<14} {ds.sizes[d]:>6}")
        lines.append("  variables:")
        width = max([26, *(len(str(n)) for n in ds.data_vars)])  # long names kept aligned
        uw = max([6, *(len(str(v.attrs.get("units", ""))) for v in ds.data_vars.values())])
        for name, v in ds.data_vars.items():
            rng = ""
            if v.dtype.kind in "fb" and v.size and _read(v, damaged) is None:
                rng = "  damaged: cannot be read"
            elif v.dtype.kind == "f" and v.size:
                vals = v.values
                finite = vals[vals == vals]
                if finite.size:
                    rng = f"  [{finite.min() + 0.0:.4g} .. {finite.max() + 0.0:.4g}]"  # no -0
            elif v.dtype.kind == "b" and v.size:  # a flag: how many cases it marks (a
                rng = f"  [true for {int(v.values.sum()):,} of {v.size:,}]"  # 0.7 m p_rms of
                # a step beyond the limit stood beside 'status: 300 x code 0' with no count)
            lines.append(f"    {name:<{width}} {v.attrs.get('units', ''):<{uw}} ({', '.join(v.dims)})"
                         f" {v.attrs.get('long_name', '')}{rng}")
        if "status" in ds and _read(ds["status"], damaged) is not None:
            st = ds["status"].values
            counts = {int(k): int((st == k).sum()) for k in sorted(set(st.ravel().tolist()))}
            lines.append("  status: " + ", ".join(f"{n} x code {k}" for k, n in counts.items())
                         + f"  ({ds['status'].attrs.get('codes', '')})")
    if damaged:  # the rest described, then one line naming what cannot be read
        names = ", ".join(dict.fromkeys(damaged))
        raise DamagedResult("\n".join(lines), f"{path}: damaged: the data of {names} cannot be"
                            " read (the file was changed or cut after it was written); run its"
                            " study again")
    return "\n".join(lines)


class DamagedResult(ResultError):
    """A result whose header can be read but not the data of some variables: ``text``, what
    ``describe`` could say of it (those variables marked damaged)."""

    def __init__(self, text: str, message: str) -> None:
        super().__init__(message)
        self.text = text


def _read(v, damaged: list[str]):
    """The values of the variable ``v`` (loaded once, kept by xarray), or ``None`` where its
    data cannot be read (a damaged file: ``NetCDF: HDF error``), its name then added to
    ``damaged``. What the HDF5 filters print of it on the process's stderr (``zstd: Data
    corruption detected``) is not shown: the line that names the variable says it."""
    try:
        with _c_stderr_to_devnull():
            return v.values
    except (RuntimeError, OSError, ValueError):
        damaged.append(str(v.name))
        return None


@contextlib.contextmanager
def _c_stderr_to_devnull():
    """File descriptor 2 sent to the null device while the block runs (the C libraries' own
    messages), Python's ``sys.stderr`` flushed first."""
    with contextlib.suppress(OSError, ValueError):
        sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no stderr to redirect
        yield
        return
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 2)
        finally:
            os.close(null)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _resumed_line(attrs) -> str | None:
    """What a resumed result says of its runs (``resultfile.run_attrs``), ``None`` for a result
    made in one run: ``resumed: 10 of 14 chunks from an earlier run; chunk phase 2.10 s over
    the 2 runs (elapsed_seconds), 0.82 s in the last``."""
    if "run_chunks" not in attrs:
        return None
    chunks = np.atleast_1d(attrs["run_chunks"]).astype(int)
    each = np.atleast_1d(attrs.get("run_elapsed_seconds", [np.nan])).astype(float)
    n = len(chunks)
    runs = "an earlier run" if n == 2 else f"{n - 1} earlier runs"
    total = float(attrs.get("elapsed_seconds", np.nan))
    return (f"resumed: {chunks[:-1].sum()} of {chunks.sum()} chunks from {runs}; chunk phase"
            f" {_seconds(total)} over the {n} runs (elapsed_seconds), {_seconds(each[-1])} in"
            " the last")


def _looks_like_study(path: Path) -> bool:
    """A text file that starts like a study (not a netCDF file, which starts with its magic)."""
    if is_netcdf(path):
        return False
    try:
        with open(path, "rb") as fh:
            text = fh.read(4096).decode("utf-8", "replace")
    except OSError:
        return False
    return any(line.split(":")[0].strip() in ("title", "scene", "type", "sweep")
               for line in text.splitlines() if ":" in line)


def _aliasing_warning(plan, name: str) -> None:
    """Print validate's and run's warning of a spectrum whose samples fold the orders where the
    response has weight onto its kept lines (``outputs.spectrum_aliasing``), if there is one."""
    text = spectrum_aliasing(plan)
    if text is not None:
        print(f"gearsweep: warning: {name}: {text}", file=sys.stderr)


def _rigid_driven_gear_note(study) -> str | None:
    """The note on a torque fluctuation beside a typed mass (no ``scene.drive``): its force is
    F = T / r1, the limit of a driven gear much heavier than the driving one, which a typed m_eq
    of two finite inertias contradicts; Eq. (7) with the drive's inertias gives m_eq r1 T / I1,
    less by the factor m_eq r1^2 / I1 (an outside tester's pair: 274.65 N against 191.28 N, with
    nothing said)."""
    sc = study.scene
    if getattr(sc, "drive", None) is not None or getattr(sc, "r1", None) is None:
        return None
    torques = [i for i, f in enumerate(getattr(sc, "fluctuation", [])) if f.is_torque]
    if not torques:
        return None
    i = torques[0]
    return (f"scene.fluctuation[{i}]: a torque amplitude beside a typed mass is the force"
            f" T / r1 (r1 = {sc.r1 * 1e3:.4g} mm), the limit of a driven gear much heavier than"
            " the driving one; with scene.drive's inertias instead of the mass it is Eq. (7)'s"
            " m_eq r1 T / I1, less by m_eq r1^2 / I1 (a force amplitude in N is taken as written)")


PITCH_LINE_NOTE = 200.0
"""A driving gear's base-circle speed [m/s] above which ``validate`` notes the speed: spur gears
run at up to about 100 m/s; far beyond is likely a unit mistaken (a mesh frequency written in
Hz, which the speed reads as shaft revolutions per second: an outside tester's 190-3450 Hz became
11,400-207,000 rpm, 750 m/s, with no word)."""


def _pitch_line_note(plan) -> str | None:
    """The note on a study whose fastest case moves the driving gear's base circle faster than
    ``PITCH_LINE_NOTE`` (``None`` below it, or where no base radius is known)."""
    r1 = getattr(plan.model, "base_radius", None)
    if not isinstance(plan.model, MeshModel) or not r1:
        return None
    rpm = float(np.max(plan.grids["speed"])) if "speed" in plan.grids else None
    if rpm is None:
        return None
    v = rpm * 2 * math.pi / 60 * r1
    if v <= PITCH_LINE_NOTE:
        return None
    return (f"{rpm:,.0f} rpm of the driving gear moves its base circle (r1 = {r1 * 1e3:.4g} mm) at"
            f" {v:,.0f} m/s, beyond any spur gear (up to about 100 m/s): the speed is the shaft's"
            " (a speed in Hz is revolutions per second, 50 Hz = 3000 rpm; the mesh frequency is"
            " teeth x that)")


def cmd_advise(args: argparse.Namespace) -> int:
    """Steps per mesh period for a target accuracy, its cost, and stability warnings
    (``study.advice.study_advice``, which ``gearsweep.advise`` returns)."""

    name = _shown(args.study)
    check_target(args.target, name, "--target")  # before the study is read, as it was
    study, text = load_study(args.study)
    print(study_advice(study, text, name, args.target, field="--target"))
    return 0


def cmd_inspect(args: argparse.Namespace) -> int:
    path = Path(args.result)
    if study_named(path) or _looks_like_study(path):
        raise ResultError(f"{path}: a study file, not a result: check it with 'gearsweep validate"
                          f" {path}', run it with 'gearsweep run {path}', then inspect the .nc it"
                          " writes")
    try:
        text = describe(args.result)
    except DamagedResult as exc:  # what can be read is said, then the error's one line
        print(exc.text)
        raise
    print(text)
    return 0


MAX_DIGITS = 18
"""``--chunk-size`` is at most ``10**MAX_DIGITS`` cases (far beyond any study: a chunk holds
at most a study's cases; ``1e999999999`` as a whole number took minutes to make)."""


def _whole_number(text: str) -> int | str:
    """A command line's whole number, written as ``100000`` or ``1e5`` (the help itself writes
    '1e9 steps'; argparse's ``int`` refused ``1e5``); anything else, ``1.5e0`` say, as written:
    the command refuses it in one line naming the flag."""
    try:
        value = Decimal(text.strip())
    except InvalidOperation:
        return text
    if not value.is_finite() or value != value.to_integral_value() or value > 10 ** MAX_DIGITS:
        return text
    return int(value)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="gearsweep",
        description="Batch parameter studies of spur gear dynamics: validate a study (YAML), run it"
                    " to a netCDF result, advise on its step, inspect a result.")
    p.add_argument("--version", action="version", version=f"gearsweep {__version__}")
    p.add_argument("--debug", action="store_true",
                   help="show tracebacks (accepted anywhere on the command line)")
    sub = p.add_subparsers(dest="command", required=True)  # every path: type=user_path ('~')
    r = sub.add_parser("run", help="run a study and write its netCDF result")
    r.add_argument("study", type=user_path, help="study file (- reads stdin)")
    r.add_argument("-o", "--output", type=user_path, help="result file (default results/STUDY.nc)")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress, no summary")
    where = r.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help="run the chunks on this existing dask.distributed cluster")
    where.add_argument("--workers", type=_whole_number, metavar="N",
                       help="run the chunks on a local dask cluster of N worker processes")
    r.add_argument("--estimate", action="store_true",
                   help="print the estimated time, memory and output size; do not run")
    r.add_argument("--yes", action="store_true",
                   help=f"run even if the estimate is beyond the limits ({LIMITS.seconds / 60:g}"
                        f" min, {LIMITS.memory_bytes / 1e9:g} GB of memory,"
                        f" {LIMITS.output_bytes / 1e9:g} GB of output)")
    r.add_argument("--device", choices=("cpu", "cuda", "auto"),
                   help="where the kernel runs (overrides solver.device; docs/gpu.md)")
    r.add_argument("--chunk-size", type=_whole_number, metavar="CASES",
                   help="about this many cases per chunk (100000 or 1e5; checkpoint and progress unit;"
                        " default about 1e9 steps, 3 chunks per worker with --workers, 4e9 steps"
                        f" on a GPU; at most about 1/{PROGRESS_CHUNKS} of the study's kernel time,"
                        f" {SHORTEST_CAP_SECONDS:g}-{CHUNK_SECONDS:g} s at the stated rate, for"
                        " progress and what an interruption loses; a quarter of the first and of"
                        " the last chunk is split off where it still fills the cores twice: 20,000"
                        " cases in chunks of 1000 are 22 chunks on 2 cores; a resumed run keeps"
                        " its first run's chunks)")
    r.add_argument("--overwrite", action="store_true",
                   help="replace an existing output that holds another study's result, a"
                        " netCDF file that is not a gearsweep result, or a damaged one (it"
                        " starts as netCDF does but cannot be read: cut short, say); the same"
                        " study's result is replaced without it. A file that is not netCDF at"
                        " all (a study, a text) is never replaced: remove it first")
    r.add_argument("--codec", choices=("zstd", "zlib", "none"),
                   help="compression of the result (default zstd, fastest to write; zlib for"
                        " readers whose HDF5 lacks the zstd filter, docs/data-format.md)")
    r.set_defaults(func=cmd_run)
    v = sub.add_parser("validate", help="check a study file without running it")
    v.add_argument("study", type=user_path, help="study file (- reads stdin)")
    v.add_argument("--yes", action="store_true",
                   help="accept a study beyond the limits (as run --yes would run it)")
    v.add_argument("-o", "--output", type=user_path,
                   help="the result file run -o would write (default"
                   " results/STUDY.nc): an analysis study's inputs are checked in its folder")
    v.set_defaults(func=cmd_validate)
    a = sub.add_parser("advise", help="steps per period for a target accuracy, cost, warnings")
    a.add_argument("study", type=user_path, help="study file (- reads stdin)")
    a.add_argument("--target", type=float, default=DEFAULT_TARGET,
                   help="trajectory error relative to the amplitude (default"
                   f" {DEFAULT_TARGET:.0e}; the report also gives the error the study's own"
                   " steps per period reach)".replace("e-0", "e-"))
    a.set_defaults(func=cmd_advise)
    i = sub.add_parser("inspect", help="describe a result file in words")
    i.add_argument("result", type=user_path, help="a result file (.nc) written by gearsweep run")
    i.set_defaults(func=cmd_inspect)
    return p


def main(argv: list[str] | None = None) -> int:
    if argv is None:
        return _main(list(sys.argv[1:]))
    with command(["gearsweep", *argv]):  # the result's history names this command
        return _main(list(argv))


def _main(argv: list[str]) -> int:
    global _signalled
    _signalled = None  # (a stop of an earlier command in this process is not this one's)
    debug = "--debug" in argv  # accepted anywhere on the command line
    argv = [a for a in argv if a != "--debug"]
    parser = build_parser()
    args = parser.parse_args(argv)
    args.debug = debug
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _geometry_lines(warnings.showwarning)
            return args.func(args)
    except GearsweepError as exc:
        if debug:
            raise
        for line in getattr(exc, "lines", None) or str(exc).splitlines() or [""]:
            print(f"gearsweep: error: {line}", file=sys.stderr)
        return EXIT_USAGE
    except MemoryError as exc:  # a study larger than this machine (a mesh study of 1e7 torques
        if debug:  # asked numpy for 14.9 GiB: a traceback)
            raise
        why = str(exc).splitlines()[0] if str(exc) else "no more memory"
        print(f"gearsweep: error: {_shown(getattr(args, 'study', None) or args.command)}: out of"
              f" memory ({why}): make the study smaller, or run it where there is more memory"
              " (chunks already saved are kept)", file=sys.stderr)
        return EXIT_USAGE
    except Interrupted as exc:
        code, _signalled = _exit_code(), None
        with contextlib.suppress(OSError):  # (a terminal hung up: its line goes nowhere)
            print(f"gearsweep: {exc}", file=sys.stderr)
        return code
    except KeyboardInterrupt:
        if debug:
            raise
        print("gearsweep: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `gearsweep inspect r.nc | head`: the reader left; say nothing
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, as a shell reports it


def _geometry_lines(shown):
    """Python's ``showwarning`` ``shown``, but a ``GeometryWarning`` (a study's nearly pointed
    teeth, at its field's line) as one ``gearsweep: warning:`` line (it showed a source line),
    once (``run`` validates the study twice)."""
    said: set[str] = set()

    def show(message, category, *where, **kw) -> None:
        if issubclass(category, GeometryWarning):
            if str(message) not in said:
                said.add(str(message))
                print(f"gearsweep: warning: {message}", file=sys.stderr)
        else:
            shown(message, category, *where, **kw)

    return show


def entry() -> None:
    """The ``gearsweep`` command: ``main``, then exit without Python's teardown.

    Freeing every module of numpy, xarray, Numba and LLVM at exit took 0.33 s after the work was
    done (an 8-case study: 1.47 s from start to exit, 1.11 s with this), longer than the study's
    own computing. Everything the run leaves behind is already closed when ``main`` returns (the
    result file, the lock, the checkpoint folder); the exit handlers (``atexit``: logging, file
    locks, finalizers, a dask cluster's shutdown) and the output streams are run and flushed here
    as Python would, and only the freeing of memory is left to the operating system. Under a
    profiler or a tracer the exit is Python's own (``python -m cProfile -m gearsweep.cli`` writes
    its profile after ``main`` returns)."""
    import atexit

    code = main()
    if sys.getprofile() is not None or sys.gettrace() is not None:
        sys.exit(code)  # under a profiler or a tracer (coverage, a debugger): let them finish
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a reader that left, a terminal gone, a stream closed
            pass
    atexit._run_exitfuncs()
    os._exit(code)


if __name__ == "__main__":
    entry()
