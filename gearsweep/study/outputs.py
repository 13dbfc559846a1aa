"""What a study can ask for (``outputs:`` in the YAML): the extension point of the runner.

An ``Output`` declares the variables it adds (their extra dims and coordinates) and computes them
for a batch of cases from the kernel's ``BatchResult`` (and the cases' parameters). New scenes add
an ``Output`` here (e.g. spectra, Floquet multipliers); the runner, chunking and the Dataset
builder need no change.

``signal_samples_per_period`` > 0 asks the runner to record p at that many samples per mesh period
over the recorded window (``steps_per_period`` must be a multiple of it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from gearsweep.kernels import BatchResult

if TYPE_CHECKING:
    from gearsweep.study.runner import Plan


@dataclass(frozen=True)
class VarSpec:
    """A variable an output adds: extra trailing dims with their coordinates, and attributes."""

    extra_dims: tuple[str, ...] = ()
    extra_coords: dict[str, np.ndarray] = field(default_factory=dict)
    dtype: str = "float64"
    attrs: dict = field(default_factory=dict)


class Output(Protocol):
    name: str

    def signal_samples_per_period(self, plan: Plan) -> int: ...

    def variables(self, plan: Plan) -> dict[str, VarSpec]: ...

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]: ...


class Stats:
    """Steady-state statistics of p (DATA.md): rms, peak-to-peak, extremes, mean, contact."""

    name = "stats"

    def signal_samples_per_period(self, plan: Plan) -> int:
        return 0

    def variables(self, plan: Plan) -> dict[str, VarSpec]:
        names = ["p_rms", "p_pp", "p_max", "p_min", "p_mean", "settle_error"]
        if plan.has_backlash:
            names += ["contact_loss_fraction", "backside_contact_fraction", "impacts_per_period"]
        unit = {"units": "1"} if plan.dimensionless else {}
        return {n: VarSpec(attrs=unit if n.startswith("p_") else {}) for n in names}

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]:
        s = result.stats
        out = {k: s[k] for k in ("p_rms", "p_max", "p_min", "p_mean", "settle_error")}
        out["p_pp"] = s["p_max"] - s["p_min"]
        if plan.has_backlash:
            for k in ("contact_loss_fraction", "backside_contact_fraction", "impacts_per_period"):
                out[k] = s[k]
        return out


OUTPUTS: dict[str, Output] = {"stats": Stats()}
"""Registered outputs by name."""

from gearsweep.study.stability_output import Floquet  # noqa: E402 -- needs VarSpec above

OUTPUTS["floquet"] = Floquet()
