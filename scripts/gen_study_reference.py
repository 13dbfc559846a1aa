"""Write docs/study-reference.md from the schema: every field with its unit, default and allowed
values, every output and the variables it writes, every status code.

    python scripts/gen_study_reference.py          # rewrite docs/study-reference.md
    python scripts/gen_study_reference.py --check  # exit 1 if the file is stale (CI)

``tests/test_study_reference.py`` runs the check, so a schema change without the regenerated
reference fails the test suite.
"""

from __future__ import annotations

import argparse
import itertools
import re
import sys
import types
import typing
from pathlib import Path

import annotated_types
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from gearsweep.errors import StudyError
from gearsweep.model import SWEEPABLE
from gearsweep.study.analysis_specs import (
    AnalysisStudy,
    ArtifactMap,
    JumpMap,
    MethodStability,
    RattleBalance,
    RattleBudget,
    WorkPrecision,
)
from gearsweep.study.gearscene import PRESETS, GearSpec, TipReliefSpec
from gearsweep.study.measured import ExcitationSpec
from gearsweep.study.mesh import _ATTRS as MESH_VARIABLES
from gearsweep.study.outputs import OUTPUTS, STATUS_CODES, VarSpec
from gearsweep.study.plan import make_plan
from gearsweep.study.quantities import EachOnce
from gearsweep.study.resultfile import COORDS, VARIABLES, data_attrs, variable_attrs
from gearsweep.study.schema import (
    SCENE_PARAMETERS,
    SWEEP_GIVES,
    Drive,
    Fluctuation,
    FullScene,
    MathieuScene,
    MeshStudy,
    Range,
    RattleScene,
    Solver,
    SteHarmonic,
    StiffnessHarmonic,
    Study,
    WhineScene,
    parse_study,
)
from gearsweep.units import KINDS, QuantityKind

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "study-reference.md"

SECTIONS: list[tuple[str, type[BaseModel], str]] = [
    ("Top level of a dynamic study", Study, ""),
    ("scene, kind: whine", WhineScene, "Eq. (9): no backlash; time-varying stiffness and STE."),
    ("scene, kind: rattle", RattleScene, "Eq. (13): constant stiffness with backlash."),
    ("scene, kind: full", FullScene, "Eq. (6) with every term."),
    ("scene, kind: mathieu", MathieuScene, "Eq. (11), dimensionless."),
    ("scene.drive", Drive, "Inertias and base radii instead of `mass` (Eq. 7)."),
    ("scene.stiffness_harmonics[i]", StiffnessHarmonic, ""),
    ("scene.ste[i]", SteHarmonic, ""),
    ("scene.fluctuation[i]", Fluctuation, "A force (`300 N`) or a driving torque (`5 N m`)."),
    ("scene.gear (a preset name or a mapping)", GearSpec,
     f"Presets: {', '.join(f'`{p}`' for p in PRESETS)}."),
    ("scene.gear.tip_relief", TipReliefSpec, ""),
    ("sweep.NAME as a range", Range, ("Or a list of values, e.g. `[0.1 mm, 0.2 mm]`, each"
                                    " once, in increasing or decreasing order; or one value,"
                                    " e.g. `0.1 mm`, the same as `[0.1 mm]` (a dim of length"
                                    " 1).")),
    ("solver", Solver, ""),
    ("scene.excitation (STE and stiffness from a file)", ExcitationSpec,
     "Samples over a mesh cycle or a revolution, fitted to the Fourier series (docs/mesh.md)."),
    ("Top level of a static mesh study (type: mesh)", MeshStudy, ""),
    ("Top level of an analysis study (type: analysis)", AnalysisStudy,
     ("Computations that feed figures but are not a grid of cases; `analysis` is one of the"
      " kinds below.")),
    ("analysis, kind: method_stability", MethodStability, ""),
    ("analysis, kind: artifact_map", ArtifactMap, ""),
    ("analysis, kind: work_precision", WorkPrecision, ""),
    ("analysis, kind: rattle_balance", RattleBalance, ""),
    ("analysis, kind: rattle_budget", RattleBudget, ""),
    ("analysis, kind: jump_map", JumpMap, ""),
]


def _type_name(tp) -> str:
    if isinstance(tp, typing.ForwardRef):  # a type alias named in a string annotation
        return "the name of a result (`results/<name>.nc`)" if tp.__forward_arg__ == "ResultName" \
            else tp.__forward_arg__
    origin = typing.get_origin(tp)
    if origin is typing.Annotated:
        return _type_name(typing.get_args(tp)[0])
    if origin is typing.Literal:
        return " | ".join(f"`{a}`" for a in typing.get_args(tp))
    if origin in (typing.Union, types.UnionType):
        parts = [_type_name(a) for a in typing.get_args(tp) if a is not type(None)]
        return " or ".join(dict.fromkeys(parts))
    if origin in (list, tuple):
        return f"list of {_type_name(typing.get_args(tp)[0])}"
    if origin is dict:
        return f"mapping of {_type_name(typing.get_args(tp)[1])}"
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return "mapping (below)"
    return getattr(tp, "__name__", str(tp))


def _kind(field) -> str | None:
    for m in field.metadata:
        if isinstance(m, QuantityKind):
            return m.kind
    for a in typing.get_args(field.annotation) or (field.annotation,):
        for m in getattr(a, "__metadata__", ()):
            if isinstance(m, QuantityKind):
                return m.kind
    return None


def _bounds(field) -> str:
    out = []
    for m in field.metadata:
        for attr, sym in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            v = getattr(m, attr, None)
            if v is not None and isinstance(m, annotated_types.BaseMetadata):
                out.append(f"{sym} {v:g}" if isinstance(v, float) else f"{sym} {v}")
        if getattr(m, "min_length", None):
            what = "character(s)" if field.annotation is str else "value(s)"
            out.append(f"at least {m.min_length} {what}")
        if isinstance(m, EachOnce):
            out.append("each value once")
    return ", ".join(out)


def _default(field, kind: str | None) -> str:
    if field.default is PydanticUndefined and field.default_factory is None:
        return "**required**"
    if field.default is SWEEP_GIVES:  # (schema.given_or_swept)
        return "**required** unless swept"
    if field.default_factory is not None:
        value = field.default_factory()
        if isinstance(value, list) and value and isinstance(value[0], BaseModel):
            return "`[" + ", ".join(getattr(v, "name", "?") for v in value) + "]`"
        return "`[]`" if value == [] else "`{}`" if value == {} else "(see below)" \
            if isinstance(value, BaseModel) else f"`{value}`"
    value = field.default
    if value is None:
        return "none"
    if value == "":
        return '`""`'
    if kind and isinstance(value, float) and kind != "dimensionless":
        shown = value * (1.0 if kind == "speed" else _factor(kind))
        return f"`{shown:g} {KINDS[kind].examples[0]}`"
    return f"`{str(value).lower() if isinstance(value, bool) else value}`"


def _factor(kind: str) -> float:
    from gearsweep.units import display_factor

    return display_factor(kind)


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _fields(model: type[BaseModel]) -> list[str]:
    rows = ["| field | value | unit | default | allowed | meaning |", "|---|---|---|---|---|---|"]
    for name, f in model.model_fields.items():
        kind = _kind(f)
        if kind:
            k = KINDS[kind]
            unit = f"{k.examples[0]} ({kind})" if kind != "dimensionless" else "1"
            value = "number" if k.bare else "quantity"
        else:
            unit, value = "", _type_name(f.annotation)
        meaning = f.description or ""
        if kind:  # the unit column says it (descriptions may name the SI unit)
            meaning = re.sub(r"\s*\[[^\]]*\]$", "", meaning)
        rows.append(f"| `{name}` | {_cell(value)} | {_cell(unit)} | {_cell(_default(f, kind))} |"
                    f" {_cell(_bounds(f))} | {_cell(meaning)} |")
    return rows


SCENES = {
    "no backlash": "{kind: whine, drive: DRIVE, teeth: 20, stiffness: 1e8 N/m, speed: 1000 rpm}",
    "driven, no backlash": ("{kind: whine, drive: DRIVE, teeth: 20, stiffness: 1e8 N/m,"
                            " mean_force: 100 N, speed: 1000 rpm}"),
    "with backlash": ("{kind: rattle, drive: DRIVE, teeth: 20, stiffness: 1e8 N/m,"
                      " backlash: 0.1 mm, speed: 1000 rpm}"),
}
"""The scenes whose results the variables table is read from (each output with every combination
of its yes/no options in each): what a variable needs beyond its output's defaults is the first
scene it appears in (after the first) and the options it needs. A drive, for ``pinion``."""
DRIVE = ("{inertia_1: 1e-3 kg m^2, inertia_2: 1e-3 kg m^2, base_radius_1: 30 mm,"
         " base_radius_2: 30 mm}")
PLAN_VARIABLES = {"beyond_step_limit": "(step_guard: warn)"}
"""Variables the plan adds, not an output: the study setting that adds them."""
SCENE_NEEDS = {"transient_left": "driven"}
"""Variables whose scene the first scene they appear in misnames: ``transient_left`` needs a
driven scene, with or without backlash (``outputs.Stats.variables``), and first appears in the
driven one without."""


def output_variants(name: str) -> list[tuple[dict[str, bool], str]]:
    """(options, how they are written in ``outputs:``) of output ``name``: every combination of
    its yes/no options, fewest changed from their defaults first."""
    model = getattr(OUTPUTS[name], "options_model", None)
    flags = {} if model is None else {n: f.default for n, f in model.model_fields.items()
                                      if f.annotation is bool}
    variants = []
    for values in itertools.product((False, True), repeat=len(flags)):
        changed = {n: v for (n, d), v in zip(flags.items(), values, strict=True) if v != d}
        opts = ", ".join(f"{n}: {str(v).lower()}" for n, v in changed.items())
        written = f"{{{name}: {{{opts}}}}}" if changed else name
        variants.append((changed, written))
    return sorted(variants, key=lambda v: len(v[0]))


def output_variables(scene: str, output: str, written: str) -> dict[str, VarSpec] | None:
    """The variables ``output`` (as ``written`` in ``outputs:``) adds in ``scene`` (a key of
    ``SCENES``), and the plan's own (``PLAN_VARIABLES``); ``None`` where a study refuses it."""
    text = (f"title: t\nscene: {SCENES[scene].replace('DRIVE', DRIVE)}\n"
            f"outputs: [{written}]\n")
    try:
        return make_plan(parse_study(text), text).specs
    except StudyError:  # an option this scene does not take (pinion without force)
        return None


def _variable_rows() -> list[str]:
    rows = ["| output | variable | units | extra dims | long_name |", "|---|---|---|---|---|"]
    seen: dict[str, tuple[str, VarSpec]] = {}
    for output in OUTPUTS:
        for changed, written in output_variants(output):
            for i, scene in enumerate(SCENES):
                specs = output_variables(scene, output, written)
                for name, spec in (specs or {}).items():
                    if name in seen:
                        continue
                    if name in PLAN_VARIABLES:
                        seen[name] = (PLAN_VARIABLES[name], spec)
                        continue
                    needs = ([SCENE_NEEDS.get(name, scene)] if i else []) + [
                        f"{n}: {str(v).lower()}" for n, v in changed.items()]
                    seen[name] = (f"{output} ({', '.join(needs)})" if needs else output, spec)
    plan_rows = [n for n in seen if n in PLAN_VARIABLES]
    for name in [n for n in seen if n not in PLAN_VARIABLES] + plan_rows:
        label, spec = seen[name]
        _, attrs = variable_attrs(name, VARIABLES, spec.result_attrs())
        attrs = data_attrs(attrs)
        rows.append(f"| {label} | `{name}` | {_cell(attrs['units'])} |"
                    f" {', '.join(spec.extra_dims) or '-'} | {_cell(attrs.get('long_name', ''))} |")
    units, long_name = VARIABLES["status"]
    rows.append(f"| (always) | `status` | {units} | - | {_cell(long_name)} |")
    for name, (units, long_name) in MESH_VARIABLES.items():
        units = KINDS[units].cf if units in KINDS else units  # a kind: the unit the file holds
        rows.append(f"| (type: mesh) | `{name}` | {units} | - | {_cell(long_name)} |")
    return rows


def render() -> str:
    lines = [
        "# Study file reference",
        "",
        ("<!-- Generated by scripts/gen_study_reference.py from the schema; do not edit by hand."
        " tests/test_study_reference.py fails when this file is stale. -->"),
        "",
        "A study is a YAML file: `title`, a `scene`, what to `sweep`, the `solver` and the",
        "`outputs`. `gearsweep validate STUDY.yaml` checks it and reports every problem at once,",
        "one line each (`file.yaml:LINE: field.path: value -- message`).",
        "",
        "## Units",
        "",
        "A dimensioned value is written with its unit: `backlash: 0.1 mm`, `damping: 5.5 N s/mm`.",
        "A quantity is one number (signed, decimal or exponent form, `_` only between digits, or a",
        "product or quotient of numbers such as `200*32/48 rpm`) followed by a unit expression with",
        "no number in it but its powers (`kN/mm`, `N*s/mm`, `kg m^2`, `kN mm-1`, `1/s`); a unit",
        "with no number (`mm`), a number inside or after the unit (`3 mm 2`, `3mm/2`) and other",
        "arithmetic (`2**10 mm`, `(3) mm`, `3 rpm - 2 rpm`) are refused.",
        "A bare number in a dimensioned field is refused (`module: 3` -> `3 has no unit; write e.g.",
        "'3 mm', or '3 m' if SI was meant`), except **0** (zero in any unit) and a **shaft",
        "speed, which is read in rpm** (`speed: 3000` is 3000 rpm). A frequency given for a shaft",
        "speed is revolutions per second: `50 Hz` = 3000 rpm; `rad/s` and `deg/s` are angular",
        "rates. Non-finite values (`nan`, `inf`) are refused in every field. The result files'",
        "own spelling of a unit (UDUNITS, the `units` attribute: `kN mm-1`, `N s mm-1`, `kg m2`)",
        "is read too. An inch is `in`, a thousandth of one `thou`; an inch or foot mark (`0.004\"`,",
        "`2'`), which pint drops, and `mil`, which pint reads as an angle, are refused saying what",
        "to write.",
        "",
        "Results store swept coordinates in the *display unit* below (the numbers in the file are",
        "the numbers in the study: `ds.sel(backlash=0.1)` for `backlash: [0.1 mm, 0.2 mm]`), with",
        "the unit in their `units` attribute; dimensionless quantities have `units: \"1\"`.",
        "",
        "| kind | display unit (in files) | SI (kernel) | spellings accepted | bare number |",
        "|---|---|---|---|---|",
    ]
    for k in KINDS.values():
        lines.append(f"| {k.name} | `{k.cf}` | {k.si or '1'} | {', '.join(f'`{e}`' for e in k.examples)}"
                     f" | {'read in ' + (k.display or '1') if k.bare else 'refused (0 allowed)'} |")
    lines += ["", "## Sweepable parameters", "",
              "| parameter | kind | file unit | scenes |", "|---|---|---|---|"]
    for name, kind in SWEEPABLE.items():
        scenes = [s for s, names in SCENE_PARAMETERS.items() if name in names]
        lines.append(f"| `{name}` | {kind} | `{KINDS[kind].cf}` | {', '.join(scenes)} |")
    lines += ["", "A range `{start, stop, num}` must go from low to high (a down sweep is",
              "`continuation: [down]`). A swept parameter need not be given in the scene: the",
              "sweep gives it (a rattle scene's `backlash`; the `mass`, m_eq, with no `drive`;",
              "the `stiffness`; as the `speed`). Given in both is allowed: the sweep replaces the",
              "scene's value and `validate` says so."]
    for title, model, note in SECTIONS:
        lines += ["", f"## {title}", ""]
        if note:
            lines += [note, ""]
        lines += _fields(model)
    lines += ["", "## Outputs", "", "`outputs:` lists names, or `{name: {options}}`.", ""]
    for name, out in OUTPUTS.items():
        opts = getattr(out, "options_model", None)
        lines += [f"### {name}", "", _cell((type(out).__doc__ or "").split("\n\n")[0]), ""]
        if opts is not None:
            lines += _fields(opts)
            lines.append("")
    lines += ["## Variables each output writes", "",
              ("Every variable an output can write, read from the outputs' own declarations"
              " with every combination of their yes/no options: what a variable needs beyond"
              " the output's defaults is in brackets, an option (`spectrum (dte: true)`) or a"
              " scene (`stats (with backlash)`). Rows `(always)` are in every dynamic study's"
              " result; rows `(type: mesh)` are a mesh study's, which has no `status` (nothing"
              " is integrated)."), ""] \
        + _variable_rows()
    lines += ["", "## Coordinates", "", "| name | units | meaning |", "|---|---|---|"]
    for name, (units, long_name) in COORDS.items():
        kind = SWEEPABLE.get(name)
        shown = KINDS[kind].cf if kind else ("1" if units == "-" else units)
        lines.append(f"| `{name}` | {shown if name not in ('direction', 'method') else '(label)'}"
                     f" | {_cell(long_name)} |")
    lines += ["", "## Status codes (variable `status`)", "", "| code | meaning |", "|---|---|"]
    for code, meaning in STATUS_CODES.items():
        lines.append(f"| {code} | {_cell(meaning)} |")
    from gearsweep.errors import EXIT_HUNG_UP, EXIT_INTERRUPTED, EXIT_TERMINATED, EXIT_USAGE

    lines += ["", "## Exit codes of `gearsweep`", "", "| code | meaning |", "|---|---|",
              "| 0 | done |",
              "| 1 | a bug: a traceback (please report it with the study) |",
              (f"| {EXIT_USAGE} | refused or failed with a reason, one line per problem: input"
               " that cannot be run (nothing computed), an output that cannot be written, a full"
               " disk, no more memory, a lost dask scheduler or a failed chunk (the chunks"
               " computed so far are kept; the same command continues) |"),
              (f"| {EXIT_HUNG_UP} | terminated (SIGHUP: the terminal closed), as by SIGTERM |"),
              (f"| {EXIT_INTERRUPTED} | interrupted (Ctrl-C): the chunks computed so far are kept;"
               " the same command continues |"),
              (f"| {EXIT_TERMINATED} | terminated (SIGTERM: `kill`, a batch system's time limit):"
               " the chunks computed so far are kept; the same command continues |"), ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="exit 1 if the file is stale")
    args = p.parse_args(argv)
    text = render()
    if args.check:
        current = OUT.read_text(encoding="utf-8") if OUT.exists() else ""
        if current != text:
            print(f"{OUT.relative_to(ROOT)} is stale: run python scripts/gen_study_reference.py",
                  file=sys.stderr)
            return 1
        return 0
    OUT.write_text(text, encoding="utf-8")
    print(OUT)
    return 0


if __name__ == "__main__":
    sys.exit(main())
