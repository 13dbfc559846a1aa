"""Analysis studies (``type: analysis``): computations that are not a grid of Eq. (6) cases but
feed figures all the same (the methods' stability limits, the work-precision chart). Each has an
options model here, discriminated by ``kind``; ``gearsweep.study.analyses`` computes them into a
Dataset, so figure scripts only read results::

    type: analysis
    title: Stability limits of the fixed-step methods
    analysis:
      kind: method_stability
      zeta: [0.0, 0.1, 0.215, 0.4]

An analysis may read the results of other studies (``inputs()``: their names): they are opened
from the folder the analysis writes to (``results/<name>.nc`` in the main job, which runs the
analysis studies after the others), and each input's study text and sha256 are kept in the
result's attributes.
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import AfterValidator, BeforeValidator, Field, model_validator

from gearsweep.kernels.tableaux import KERNEL_METHODS
from gearsweep.study.quantities import (
    EACH_ONCE,
    MAX_STEPS_PER_PERIOD,
    Count,
    EachOnce,
    FieldProblems,
    Flag,
    Real,
    Speed,
    Strict,
    WholeStudy,
    speed_bound,
)

Method = Literal[KERNEL_METHODS]
BoundSpeed = Annotated[Speed, AfterValidator(speed_bound)]
"""A driving-gear speed [rpm], at most ``MAX_SPEED`` as in a scene."""


class MethodStability(Strict):
    """Largest stable h omega_n of each kernel method on the free linear oscillator
    ``p'' + 2 zeta w p' + w^2 p = 0``: from the stability polynomial on a fine grid of damping
    ratios, and measured by integration with the batch kernel (bisection on the step) at the
    ``zeta`` points."""

    kind: Literal["method_stability"]
    methods: Annotated[list[Method], EACH_ONCE] = Field(default_factory=lambda: ["rk4", "rk5"],
                                                        min_length=1)
    zeta: Annotated[list[Annotated[Real, Field(ge=0, le=10)]], EACH_ONCE] = Field(
        default_factory=lambda: [0.0, 0.02, 0.05, 0.1, 0.2, 0.215, 0.3, 0.45, 0.6, 0.8, 0.95,
                                 1.2, 1.6],
        min_length=1, description="damping ratios measured by integration [1]")
    zeta_max: Real = Field(1.6, gt=0, le=10, description="end of the polynomial's curve [1]")
    curve_points: Count = Field(321, ge=2, le=100_000)
    steps: Count = Field(4_000_000, ge=1000, le=100_000_000,
                       description="steps integrated per trial step (bisection)")



class ReadsResults(Strict):
    """An analysis that reads other studies' results (``input_fields``)."""

    def input_fields(self) -> list[tuple[str, str]]:
        """(field of the study, result name) of each result it reads, in the order read: where
        a problem of that input is said (``analyses._open_inputs``)."""
        return [(f"analysis.{name}", value) for name, value in self._reads()]

    def inputs(self) -> list[str]:
        """The names of the results it reads (``results/<name>.nc`` beside its output)."""
        return [name for _, name in self.input_fields()]


class ArtifactMap(ReadsResults):
    """The paper's instability criterion (growth 1e3-fold within 100 mesh periods at a fixed
    step) for several fifth-order Runge-Kutta tableaux over the speed x damping grid of a rig
    study (Fig. 7.2): which tableau and step reproduce the paper's figure."""

    kind: Literal["artifact_map"]
    rig: ResultName = Field(description="the rig's dynamic result (results/<name>.nc): its"
                            " resolved model and its speed and damping grids")
    methods: Annotated[list[Literal["rk5", "fehlberg5", "cashkarp5", "dopri5"]], EACH_ONCE] = Field(
        default_factory=lambda: ["rk5", "fehlberg5", "cashkarp5", "dopri5"], min_length=1)
    steps_per_period: Annotated[list[Annotated[Count, Field(ge=4, le=MAX_STEPS_PER_PERIOD)]],
                                EACH_ONCE] = Field(
        default_factory=lambda: list(range(100, 421, 20)), min_length=1)

    def _reads(self) -> list[tuple[str, str]]:
        return [("rig", self.rig)]


class WorkPrecision(Strict):
    """Error against cost of the fixed-step kernels and scipy's adaptive solvers on the whine
    and rattle scenes of ``gearsweep.analysis.precision`` against a reference solution."""

    kind: Literal["work_precision"]
    scenes: Annotated[list[Literal["whine", "rattle"]], EACH_ONCE] = Field(
        default_factory=lambda: ["whine", "rattle"], min_length=1)
    # at most MAX_SPEED as a scene's speed (1e300 rpm: an OverflowError traceback in validate)
    whine_speed: BoundSpeed = Field(6000.0, gt=0, description="speed of the whine scene [rpm]")
    rattle_speed: BoundSpeed = Field(9000.0, gt=0, description="speed of the rattle scene [rpm]")
    methods: Annotated[list[Literal["rk4", "rk5", "rk4-kink", "rk5-kink"]], EACH_ONCE] = Field(
        default_factory=lambda: ["rk4", "rk5", "rk4-kink", "rk5-kink"], min_length=1)
    steps_per_period: Annotated[list[Annotated[Count, Field(ge=8, le=MAX_STEPS_PER_PERIOD,
                                                            multiple_of=8)]], EACH_ONCE] = Field(
        default_factory=lambda: [8, 16, 32, 64, 128, 256, 512, 1024], min_length=3,
        description="multiples of 8 (the common sampling grid)")
    peers: Annotated[list[Literal["RK45", "DOP853", "LSODA"]], EACH_ONCE] = Field(
        default_factory=lambda: ["RK45", "DOP853", "LSODA"])
    rtol: Annotated[list[Annotated[Real, Field(gt=0, lt=1)]], EACH_ONCE] = Field(
        default_factory=lambda: [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10], min_length=1)
    transient_periods: Count = Field(40, ge=1, le=100_000)
    record_periods: Count = Field(20, ge=1, le=100_000)
    copies: Count = Field(64, ge=1, le=1_000_000,
                        description="identical cases per kernel call (cost = time / copies)")
    repeat: Count = Field(3, ge=1, le=100, description="timings per point; the best is kept")


def _result_name(value: object) -> object:
    """``fig08_rattle`` as written; ``fig08_rattle.nc`` is the same name (it looked for
    ``fig08_rattle.nc.nc``); a path is refused with what to write instead."""
    if not isinstance(value, str):
        return value
    name = value.removesuffix(".nc")
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
        raise ValueError("the name of a result in the folder the analysis writes to (e.g."
                         " fig08_rattle for results/fig08_rattle.nc), not a path: run the"
                         " analysis with -o in the folder that holds it")
    if len(name.encode()) > 252:  # name.nc is no file name (255 bytes): 'File name too long'
        raise ValueError(f"a name of at most 252 bytes (this one has {len(name.encode())}):"
                         " its result name.nc is a file name")
    return name


ResultName = Annotated[str, BeforeValidator(_result_name), Field(description=(
    "the name of another study's result: results/<name>.nc from studies/<name>.yaml"))]


GraphicalLine = Annotated[Real, Field(gt=0, le=100)]
"""A line of Fig. 9 as a multiple of its reference speed: above 0 (0 and below drew lines at
no or negative speed with status 0) and at most 100 (1e300 overflowed in the balance)."""


class RattleBalance(ReadsResults):
    """Harmonic balance of a continued (up and down) rattle study's scene beside its integration:
    the describing-function curves (with the mean force and without), the AFT harmonic-balance
    branch with Floquet stability, their turning points, the paper's Eq. (15) (every root on a
    grid of speeds, and the root nearest the integration at each of its speeds), the jump speeds
    of the integration and the Eq. (15) lines of the graphical solution (Fig. 9). The scene is the
    resolved model the result carries: one force harmonic, constant stiffness, backlash."""

    kind: Literal["rattle_balance"]
    result: ResultName
    harmonics: Count = Field(25, ge=1, le=200, description="AFT harmonics")
    n_time: Count = Field(1024, ge=16, le=1 << 16, description="AFT time samples per period")
    curve_top: Real = Field(3.0, gt=1, le=100,
                            description="describing-function curve up to this many b [1]")
    eq15_step: Speed = Field(50.0, gt=0, description="speed step of the Eq. (15) points [rpm]")
    graphical: tuple[GraphicalLine, GraphicalLine, GraphicalLine] = Field(
        (0.7, 0.5, 1.25), description="the three lines of Fig. 9: A at this x w_t, B at this x"
        " (w_t + w_n), C at this x w_n (w_t: the gap root appears, w_n: the linear resonance)")
    fitted: Flag = Field(False, description="the scene's force amplitude is a fit (the paper's"
                         " Fig. 8: F0 and c fitted to its jump speeds); titles and plots say"
                         " 'fitted' only then")

    def _reads(self) -> list[tuple[str, str]]:
        return [("result", self.result)]


class RattleBudget(ReadsResults):
    """The force budget of a fitted rattle scene against scenes driven by the pair's own STE:
    the fitted force, the mean force, what the pair's first STE harmonic supplies (k e_1 and
    m w^2 e_1), the force that opens the mesh of each scene and damping at each speed (linear
    response), its least value (at resonance), the speeds where m w^2 e_1 alone reaches it, and
    each scene's jumps, contact-loss span and largest response."""

    kind: Literal["rattle_budget"]
    fitted: ResultName
    scenes: Annotated[list[ResultName], EACH_ONCE] = Field(min_length=1)
    names: Annotated[list[str], EachOnce("the legends cannot tell the scenes apart")] = Field(
        min_length=1, description="a short name per scene (legends)")
    mesh: ResultName = Field(description="the pair's mesh study (its ste_harmonic gives e_1)")
    points: Count = Field(200, ge=2, le=100_000, description="speeds of the budget lines")
    at_speeds: Annotated[list[BoundSpeed], EACH_ONCE] = Field(default_factory=lambda: [7500.0, 8000.0],
                                   description="speeds where m w^2 e_1 is reported [rpm]")

    @model_validator(mode="after")
    def _names(self) -> RattleBudget:
        if len(self.names) != len(self.scenes):  # at names' line (was the analysis')
            raise FieldProblems([(("names",), (f"one name per scene: {len(self.scenes)} names for"
                                  f" the {len(self.scenes)} scenes, not {len(self.names)}"))])
        return self

    def _reads(self) -> list[tuple[str, str]]:
        return [("fitted", self.fitted), *((f"scenes[{i}]", s) for i, s in enumerate(self.scenes)),
                ("mesh", self.mesh)]


class JumpMap(ReadsResults):
    """Where a continued (up and down) sweep over design parameters rattles: per case of the
    result, the share of speeds with contact loss (either sweep) and its jump summary
    (``gearsweep.study.jumps``: jump speeds, hysteresis band)."""

    kind: Literal["jump_map"]
    result: ResultName
    loss_threshold: Real = Field(0.01, ge=0, lt=1, description="contact loss above this"
                                 " fraction of the time counts as rattle [1]")

    def _reads(self) -> list[tuple[str, str]]:
        return [("result", self.result)]


AnalysisSpec = Annotated[MethodStability | WorkPrecision | ArtifactMap | RattleBalance
                         | RattleBudget | JumpMap,
                         Field(discriminator="kind")]
"""The ``analysis:`` mapping of an analysis study."""


class AnalysisStudy(WholeStudy):
    """An analysis study: a title and one ``analysis`` (see the kinds above)."""

    type: Literal["analysis"]
    title: str = Field(min_length=1)
    description: str = ""
    analysis: AnalysisSpec
