"""Shared fixtures: the paper's rig, the Table 1 gear pair, and small studies written on the fly.

The numbers themselves live in the package (``gearsweep.model.PAPER_RIG``,
``gearsweep.gear.table1_consistent``); tests take them from here instead of typing them again.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import yaml

from gearsweep.gear import table1_consistent
from gearsweep.kernels import simulate
from gearsweep.model import PAPER_RIG, MeshModel, kernel_inputs
from gearsweep.study.execute import InProcess
from gearsweep.study.outputs import OUTPUTS
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study

RIG = PAPER_RIG
"""The paper's rig (SI): m_eq, k0, k1, c, N1, F_m. Importable as ``from conftest import RIG``."""


@pytest.fixture
def rig() -> MeshModel:
    """The paper's rig as a MeshModel (k0 and k1, c, m_eq, F_m; no STE, no backlash)."""
    return RIG


@pytest.fixture
def rig_constant_k() -> MeshModel:
    """The rig with constant stiffness k0 (the rattle scenes' Eq. 13)."""
    return dataclasses.replace(RIG, stiffness_harmonics=())


@pytest.fixture(scope="session")
def table1_pair():
    """The Table 1 gear pair, consistent interpretation (docs/mesh.md)."""
    return table1_consistent()


RATTLE_SCENE = """\
scene:
  kind: rattle
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  damping: 100 N*s/m
  backlash: 0.2 mm
  mean_force: 200 N
  fluctuation: [{amplitude: 300 N, order: 1}]
"""
"""The ``scene:`` block of the tests' small rattle studies (YAML): the rig's m_eq, k0 and N1, a
0.2 mm backlash, light damping and a mesh-order force. Importable: ``from conftest import ...``."""

WHINE_SCENE = """\
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  stiffness_harmonics: [{amplitude: 100 kN/mm}]
  damping: 5.5 N s/mm
  mean_force: 1000 N
"""
"""The ``scene:`` block of the tests' small whine studies (YAML): the rig's m_eq, k0 and N1, one
stiffness harmonic, the paper's damping, 1000 N."""


GOOD_RATTLE = """\
title: t
scene:
  kind: rattle
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  backlash: 0.1 mm
  mean_force: 100 N
sweep:
  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}
solver: {method: rk4, steps_per_period: 32, transient_periods: 4, record_periods: 4}
"""
"""A valid rattle study (YAML) of three speeds and a short window, that the error tests change one
field of at a time."""

SMALL_WHINE = {
    "title": "small whine study (tests)",
    "scene": {"kind": "whine", "mass": f"{RIG.mass} kg", "teeth": RIG.teeth,
              "stiffness": f"{RIG.stiffness} N/m", "damping": f"{RIG.damping} N*s/m",
              "mean_force": f"{RIG.mean_force} N",
              "stiffness_harmonics": [{"amplitude": "179 kN/mm", "order": 1}],
              "ste": [{"amplitude": "5 um", "order": 1}]},
    "sweep": {"speed": {"start": "3000 rpm", "stop": "9000 rpm", "num": 7}},
    "solver": {"method": "rk4", "steps_per_period": 32, "transient_periods": 30,
               "record_periods": 10},
    "outputs": ["stats"],
}
"""A whine study of a few cases that runs in well under a second once compiled."""


@pytest.fixture
def small_whine() -> dict:
    """A fresh copy of ``SMALL_WHINE`` to change in a test."""
    return yaml.safe_load(yaml.safe_dump(SMALL_WHINE))


@pytest.fixture
def write_study(tmp_path: Path):
    """``write_study(mapping_or_text, name="study.yaml") -> Path`` of a study file in tmp_path."""

    def write(study: dict | str, name: str = "study.yaml") -> Path:
        path = tmp_path / name
        path.write_text(study if isinstance(study, str) else yaml.safe_dump(study, sort_keys=False),
                        encoding="utf-8")
        return path

    return write


class Crash(Exception):
    """What ``CrashAfter`` raises."""


class CrashAfter(InProcess):
    """In-process backend that dies after ``k`` chunks (the checkpoints of those remain)."""

    def __init__(self, k: int) -> None:
        self.k = k

    def run(self, plan, todo):
        for i, item in enumerate(super().run(plan, todo)):
            if i == self.k:
                raise Crash
            yield item


def signal_and_spectrum(text: str):
    """A study's recorded p of every case (one kernel call, all its speeds) and the spectrum
    output computed from it: (plan, kernel result, spectrum output)."""
    plan = make_plan(parse_study(text), text)
    s = plan.study.solver
    params = {"speed": plan.grids["speed"]}
    n = len(params["speed"])
    kin = kernel_inputs(plan.model, params, n, s.steps_per_period)
    res = simulate(method=s.method, n_transient=s.transient_periods * s.steps_per_period,
                   n_record=s.record_periods * s.steps_per_period,
                   steps_per_period=s.steps_per_period,
                   signal_stride=s.steps_per_period // plan.samples_per_period(), **kin)
    return plan, res, OUTPUTS["spectrum"].compute(plan, params, res)

