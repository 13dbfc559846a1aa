"""From a validated study to a result Dataset: plan -> chunks of cases -> kernel calls -> Dataset.

The cases of a study form a grid over its swept parameters (in the order the study lists them).
They are run in *lanes*: without continuation a lane is one case; with ``continuation`` a lane is
one sweep along ``speed`` (every other parameter fixed), run up and/or down, each speed starting
from the final state of the previous one. Lanes are independent, so a study is cut into chunks of
lanes; ``run_chunk`` computes one chunk and ``assemble`` puts the chunks together. The in-process
default runs the chunks one after another (each chunk uses every core through the kernel's
``prange``); the same chunks can be sent to dask workers.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from gearsweep.kernels import LANES, STATUS_DIVERGED
from gearsweep.kernels.cuda import kernel_for
from gearsweep.model import Harmonic, MathieuModel, MeshModel, kernel_inputs, mesh_frequency
from gearsweep.model import fluctuating_force as eq7_force
from gearsweep.study.dataset import build_dataset
from gearsweep.study.gearscene import scene_excitation
from gearsweep.study.lanes import lane_values
from gearsweep.study.outputs import OUTPUTS, VarSpec, configure
from gearsweep.study.schema import Study
from gearsweep.study.units import to_si

if TYPE_CHECKING:
    from gearsweep.study.mesh_runner import MeshStudy

STATUS_NOT_SETTLED = 2
CHUNK_STEPS = 1e9
"""Target integration steps per chunk: about 0.7 s of kernel time on this 2-core machine (plain
RK4 on a rattle scene, about 1,400 Msteps/s), long enough that the per-chunk work around the
kernel (lane values, kernel inputs, outputs: about 20 ms for 400,000 lanes; the checkpoint file
is written by a background thread) stays near 5 %, short enough
for progress and checkpoints every second or so."""
CHUNK_SIGNAL_BYTES = 64e6
"""At most this much recorded time history per chunk (outputs reduce it per chunk)."""


def build_model(study: Study) -> MeshModel | MathieuModel:
    """The scene's fixed values as a ``MeshModel`` (or ``MathieuModel``) in SI units."""
    sc = study.scene
    if sc.kind == "mathieu":
        return MathieuModel(alpha=sc.alpha, beta=sc.beta, gamma=sc.gamma)
    if sc.drive is not None:
        d = sc.drive
        mass = 1.0 / (d.base_radius_1**2 / d.inertia_1 + d.base_radius_2**2 / d.inertia_2)
    else:
        mass = sc.mass
    r1 = sc.r1
    gear = scene_excitation(sc) if getattr(sc, "gear", None) is not None else None
    if gear is not None:
        r1 = gear.base_radius_1
    mean_force = sc.mean_force if sc.mean_force is not None else 0.0
    if sc.torque is not None:
        mean_force = sc.torque / r1
    fluct = []
    for f in sc.fluctuation:
        try:
            amp = to_si(f.amplitude, "force")
        except ValueError:
            # A driving-torque amplitude: Eq. (7) with the drive's inertia, or F = T / r1
            # (the rigid-pinion limit I2 -> infinity) when only m_eq and r1 are known.
            torque = to_si(f.amplitude, "torque")
            if sc.drive is not None:
                amp = eq7_force(torque, mass, r1, sc.drive.inertia_1)
            elif r1 is not None:
                amp = torque / r1
            else:
                amp = math.nan
        fluct.append(Harmonic(amp, f.order, f.phase))

    def harmonics(items) -> tuple[Harmonic, ...]:
        return tuple(Harmonic(h.amplitude, h.order if h.order is not None else i + 1, h.phase)
                     for i, h in enumerate(items))

    if gear is not None:  # k(t), e(t) of the gear pair at the mean load (gearscene.py)
        teeth, k0, k_h, e_h = (gear.teeth, gear.stiffness, gear.stiffness_harmonics,
                               gear.no_load_te_harmonics)
        if sc.kind == "rattle":  # Eq. (13): constant k0, so e(t) is the loaded STE
            k_h, e_h = (), gear.ste_harmonics
    else:
        teeth, k0 = sc.teeth, sc.stiffness
        k_h = harmonics(getattr(sc, "stiffness_harmonics", []))
        e_h = harmonics(getattr(sc, "ste", []))
    return MeshModel(
        mass=mass,
        teeth=teeth,
        stiffness=k0,
        damping=sc.damping,
        mean_force=mean_force,
        base_radius=r1,
        backlash=getattr(sc, "backlash", 0.0),
        stiffness_harmonics=k_h,
        ste_harmonics=e_h,
        force_harmonics=tuple(fluct),
    )


@dataclass
class Plan:
    """Everything needed to run any chunk of a study, independent of where it runs."""

    study: Study
    text: str
    model: MeshModel | MathieuModel
    dims: list[str]
    """Swept dims, in the study's order (without ``direction``)."""
    grids: dict[str, np.ndarray]
    directions: list[str]
    """``["up"]``, ``["down"]``, both, or ``[]`` (no continuation)."""
    outputs: list[str]
    specs: dict[str, VarSpec] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)
    """Validated options of the outputs that take some (``outputs.configure``), by name."""
    memo: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)
    """Per-study results kept between chunks (the step guard's table); not copied by
    ``dataclasses.replace``, so a changed plan never sees another's."""

    @property
    def continued(self) -> bool:
        return bool(self.directions)

    @property
    def has_backlash(self) -> bool:
        return isinstance(self.model, MeshModel) and (self.model.backlash > 0
                                                       or "backlash" in self.grids)

    @property
    def dimensionless(self) -> bool:
        return isinstance(self.model, MathieuModel)

    @property
    def lane_dims(self) -> list[str]:
        return [d for d in self.dims if not (self.continued and d == "speed")]

    @property
    def n_lanes(self) -> int:
        return int(np.prod([len(self.grids[d]) for d in self.lane_dims], dtype=np.int64))

    @property
    def chain(self) -> int:
        """Cases per lane per direction (speeds of a continued sweep, else 1)."""
        return len(self.grids["speed"]) if self.continued else 1

    @property
    def n_cases(self) -> int:
        return self.n_lanes * self.chain * max(len(self.directions), 1)

    @property
    def steps_per_case(self) -> int:
        s = self.study.solver
        return (s.transient_periods + s.record_periods) * s.steps_per_period

    def samples_per_period(self) -> int:
        need = [OUTPUTS[o].signal_samples_per_period(self) for o in self.outputs]
        return max(need, default=0)

    def chunks(self, lanes_per_chunk: int | None = None) -> list[tuple[int, int]]:
        """Lane ranges ``[start, stop)`` of the chunks (whole sweeps inside a chunk)."""
        if lanes_per_chunk is None:
            per_lane = self.steps_per_case * self.chain * max(len(self.directions), 1)
            lanes_per_chunk = max(4 * LANES, int(CHUNK_STEPS // max(per_lane, 1)))
            # Up and down sweeps of a lane run side by side: one signal per direction.
            signal = (self.samples_per_period() * self.study.solver.record_periods * 8
                      * max(len(self.directions), 1))
            if signal:
                lanes_per_chunk = min(lanes_per_chunk,
                                      max(4 * LANES, int(CHUNK_SIGNAL_BYTES // signal)))
        n = self.n_lanes
        return [(a, min(a + lanes_per_chunk, n)) for a in range(0, n, lanes_per_chunk)]


def make_plan(study: Study, text: str = "") -> Plan:
    """Grids, dims and output specs of a study (nothing is integrated yet)."""
    dims = list(study.sweep)
    grids = {d: study.grid(d) for d in dims}
    if study.scene.kind != "mathieu" and "speed" not in grids:
        grids["speed"] = np.array([study.scene.speed])
        dims.append("speed")
    plan = Plan(study, text, build_model(study), dims, grids, list(study.continuation),
                [o.name for o in study.outputs],
                options={o.name: configure(o.name, o.options) for o in study.outputs})
    for o in plan.outputs:
        plan.specs.update(OUTPUTS[o].variables(plan))
    if study.solver.step_guard == "warn":
        plan.specs["beyond_step_limit"] = VarSpec(dtype="bool", attrs={
            "units": "1", "long_name": "step beyond the method's stability limit (results may be"
            " spoiled by the integrator)"})
    spp, sps = study.solver.steps_per_period, plan.samples_per_period()
    if sps and spp % sps:
        from gearsweep.errors import StudyError

        raise StudyError("<study>", "solver.steps_per_period", spp,
                         f"a multiple of {sps} (the samples per period the outputs need)")
    return plan


class _Clock:
    """Seconds spent in the kernel (``simulate``) by this process, summed over its threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.seconds = 0.0

    def add(self, seconds: float) -> None:
        with self._lock:
            self.seconds += seconds


KERNEL_CLOCK = _Clock()
"""Read before and after a run in this process: the difference is its time in the kernel
(``run_plan`` stores it as the Dataset's ``kernel_seconds``, beside ``elapsed_seconds``)."""


def _lanes(plan: Plan, lane0: int, lane1: int, guard: bool = False
           ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """Swept values of lanes ``[lane0, lane1)`` (C order over ``plan.lane_dims``) and, with
    ``guard``, the step guard's verdict per lane looked up in its table (``_guard_table``;
    ``None`` when there is none: then ``_integrate`` checks the lanes itself).
    """
    dims = plan.lane_dims
    table = _guard_table(plan) if guard else None
    values, flat = lane_values([plan.grids[d] for d in dims], lane0, lane1,
                               table[0] if table is not None else None)
    return dict(zip(dims, values, strict=True)), (table[2][flat] if table is not None else None)


def _lane_params(plan: Plan, lane0: int, lane1: int) -> dict[str, np.ndarray]:
    """Swept values of lanes ``[lane0, lane1)`` (C order over ``plan.lane_dims``)."""
    return _lanes(plan, lane0, lane1)[0]


STATUS_SKIPPED = 3


_GUARD_MARGIN = 2e-3


@lru_cache(maxsize=4)
def _hw_table(method: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(zeta grid, largest stable h w_n on it, largest stable h|lambda| on the negative real
    axis) of ``method``, solved once from its stability polynomial."""
    from gearsweep.analysis.stability import ray_limit, step_limit_hw

    # The limit has square-root behaviour at zeta -> 0 (RK5) and zeta -> 1+ (the fast over-damped
    # pole), and the pole's angle arccos(-zeta) has it at zeta -> 1-: below 1 a cosine grid
    # (quadratic at both ends), above 1 geometric in zeta - 1 (steps of 3.8 %).
    u = np.linspace(0.0, 1.0, 1001)
    zeta = np.unique(np.concatenate([0.5 * (1.0 - np.cos(np.pi * u)),
                                     1.0 + np.geomspace(1e-12, 1e4, 1000)]))
    # In slices: the exact solver's work arrays grow with the number of zeta values at once.
    hw = np.concatenate([np.asarray(step_limit_hw(method, zeta[i:i + 500]), float)
                         for i in range(0, len(zeta), 500)])
    return zeta, hw, float(ray_limit(method, np.pi))


def _stable_steps(method: str, k_over_m: np.ndarray, c_over_m: np.ndarray) -> np.ndarray:
    """Largest stable step h* [s] per case, a lower bound of ``analysis.stability.max_stable_step``.

    h* = (h w_n)*(zeta) / w_n with (h w_n)* tabulated once per method on a zeta grid that
    resolves its square-root ends and interpolated linearly, less a 0.2 % margin, so the guard
    does not pass a step the polynomial would reject (tested against the exact limit).
    Vectorised: a Mathieu chart has as many distinct zeta as cases.
    """
    zeta_grid, hw_grid, real_lim = _hw_table(method)
    k, c = np.broadcast_arrays(np.asarray(k_over_m, float), np.asarray(c_over_m, float))
    osc = k > 0
    wn = np.sqrt(np.where(osc, k, 1.0))
    zeta = np.clip(np.where(osc, c / (2.0 * wn), 0.0), 0.0, zeta_grid[-1])
    # Linear interpolation on this grid is second-order accurate (error < 1e-4 relative);
    # 0.2 % below it keeps the guard on the safe side of the polynomial's limit.
    hw = (1.0 - _GUARD_MARGIN) * np.interp(zeta, zeta_grid, hw_grid)
    # k <= 0: real poles -c/2 +- sqrt(c^2/4 - k); only the negative one can limit the step.
    neg = 0.5 * c + np.sqrt(np.maximum(0.25 * c * c - k, 0.0))
    with np.errstate(divide="ignore"):
        return np.where(osc, hw / wn, np.where(neg > 0, real_lim / neg, np.inf))


def _step_ok(plan: Plan, params: dict[str, np.ndarray], n: int) -> np.ndarray:
    """The guard rail: is the study's step within the method's stability limit, per case?

    Frozen-coefficient estimate at the largest stiffness of the cycle, from the method's
    stability polynomial (the rule of ``gearsweep.analysis.stability.check_step``: steps per
    period >= T / h*).
    """
    from gearsweep.study.stability_output import hill_parameters

    s = plan.study.solver
    *_, kmax, cm, period = hill_parameters(plan, params, n)
    h_star = _stable_steps(s.method, kmax, cm)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.ceil(np.asarray(period, float) / h_star)
    return np.broadcast_to(~(need > s.steps_per_period), (n,))


GUARD_PARAMS = ("alpha", "beta", "gamma", "speed", "mass", "stiffness", "damping")
"""The swept parameters ``_step_ok`` depends on (those ``hill_parameters`` reads for its
kmax/m, c/m and period)."""

_GUARD_TABLE_MAX = 1 << 20
"""Largest grid over the guard's dims that is solved once per study (else: per chunk)."""


def _guard_table(plan: Plan) -> tuple[list[int], tuple[int, ...], np.ndarray] | None:
    """The step guard solved once on the grid of the swept dims it depends on.

    Returns (positions of those dims in ``lane_dims``, their grid shape, flat ``_step_ok`` over
    that grid), or ``None`` when the grid is too large to keep (a Mathieu chart sweeping alpha,
    beta and gamma finely): then each chunk is checked on its own. A study sweeping torque and
    backlash besides speed and damping checks speeds x dampings once instead of every case.
    """
    if "guard" not in plan.memo:
        pos = [i for i, d in enumerate(plan.lane_dims) if d in GUARD_PARAMS]
        shape = tuple(len(plan.grids[plan.lane_dims[i]]) for i in pos)
        m = int(np.prod(shape, dtype=np.int64))
        table = None
        if m <= _GUARD_TABLE_MAX:
            dims = [plan.lane_dims[i] for i in pos]
            values, _ = lane_values([plan.grids[d] for d in dims], 0, m)
            params = dict(zip(dims, values, strict=True))
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                table = (pos, shape, np.array(_step_ok(plan, params, m)))
        plan.memo["guard"] = table
    return plan.memo["guard"]


def _integrate(plan: Plan, params: dict[str, np.ndarray], n: int, x0, v0,
               ok: np.ndarray | None = None) -> tuple:
    """One kernel call for ``n`` cases; returns (BatchResult, per-output arrays, status).

    ``ok``: the step guard's verdict per case if already known (else it is computed here).
    """
    guard = plan.study.solver.step_guard
    if guard == "off":
        ok = np.ones(n, bool)
    elif ok is None:
        ok = _step_ok(plan, params, n)
    if guard == "skip" and not ok.all():
        return _integrate_subset(plan, params, n, x0, v0, ok)
    res, out, status = _integrate_all(plan, params, n, x0, v0)
    if guard == "warn":
        out["beyond_step_limit"] = ~ok
    return res, out, status


def _integrate_subset(plan: Plan, params, n: int, x0, v0, ok: np.ndarray) -> tuple:
    """Integrate only the cases whose step is stable; the others get status 3 and NaN."""
    idx = np.flatnonzero(ok)
    sub = {k: np.asarray(v)[idx] for k, v in params.items()}
    sx0 = None if x0 is None else np.asarray(x0)[idx]
    sv0 = None if v0 is None else np.asarray(v0)[idx]
    res, out, status = _integrate_all(plan, sub, len(idx), sx0, sv0)
    full = {}
    for name, arr in out.items():
        fill = False if arr.dtype == bool else np.nan
        a = np.full((n, *arr.shape[1:]), fill, dtype=arr.dtype)
        a[idx] = arr
        full[name] = a
    st = np.full(n, STATUS_SKIPPED, np.int8)
    st[idx] = status
    xf = np.full(n, np.nan)
    vf = np.full(n, np.nan)
    xf[idx], vf[idx] = res.x_final, res.v_final
    rs = np.full(n, STATUS_DIVERGED, np.int8)  # a skipped lane restarts a continued sweep
    rs[idx] = res.status
    from gearsweep.kernels import BatchResult

    return BatchResult(stats={}, x_final=xf, v_final=vf, status=rs, signal=None), full, st


def _integrate_all(plan: Plan, params: dict[str, np.ndarray], n: int, x0, v0) -> tuple:
    s = plan.study.solver
    spp = s.steps_per_period
    x_init = s.initial_displacement if not plan.dimensionless or s.initial_displacement else 1.0
    kin = kernel_inputs(plan.model, params, n, spp, s.divergence_factor, x_init,
                        s.initial_velocity)
    if x0 is not None:
        kin["x0"], kin["v0"] = x0, v0
    sps = plan.samples_per_period()
    t0 = time.perf_counter()
    res = kernel_for(s.device, s.precision)(method=s.method, n_transient=s.transient_periods * spp,
                   n_record=s.record_periods * spp, steps_per_period=spp,
                   signal_stride=spp // sps if sps else 0, kink_aware=s.kink_aware, **kin)
    KERNEL_CLOCK.add(time.perf_counter() - t0)
    out: dict[str, np.ndarray] = {}
    for o in plan.outputs:
        out.update(OUTPUTS[o].compute(plan, params, res))
    status = res.status.astype(np.int8)
    unsettled = (status == 0) & ~(res.stats["settle_error"] <= s.settle_tolerance)
    status[unsettled] = STATUS_NOT_SETTLED
    return res, out, status


def run_chunk(plan: Plan, lane0: int, lane1: int) -> dict[str, np.ndarray]:
    """Compute lanes ``[lane0, lane1)``: arrays of shape (directions?, lanes, chain?, *extra)."""
    n = lane1 - lane0
    if not plan.continued:
        guard = plan.study.solver.step_guard != "off"
        params, ok = _lanes(plan, lane0, lane1, guard)
        _, out, status = _integrate(plan, params, n, None, None, ok)
        out["status"] = status
        return out
    params = _lane_params(plan, lane0, lane1)
    # Continued sweeps: the up and the down sweep of every lane advance side by side as lanes of
    # one kernel call (step k is speed k going up and speed n-1-k going down).
    speeds = plan.grids["speed"]
    ns, nd = len(speeds), len(plan.directions)
    s = plan.study.solver
    both = {name: np.tile(vals, nd) for name, vals in params.items()}
    x = np.full(n * nd, s.initial_displacement)
    v = np.full(n * nd, s.initial_velocity)
    cols: dict[str, np.ndarray] = {}
    for k in range(ns):
        idx = np.concatenate([np.full(n, k if d == "up" else ns - 1 - k) for d in plan.directions])
        res, out, status = _integrate(plan, dict(both, speed=speeds[idx]), n * nd, x, v)
        out["status"] = status
        for name, arr in out.items():
            if name not in cols:
                cols[name] = np.empty((nd, n, ns, *arr.shape[1:]), dtype=arr.dtype)
            a = arr.reshape(nd, n, *arr.shape[1:])
            for di in range(nd):
                cols[name][di, :, idx[di * n]] = a[di]
        # Carry the state; a diverged lane restarts from the initial state at the next speed.
        dead = res.status == STATUS_DIVERGED
        x = np.where(dead, s.initial_displacement, res.x_final)
        v = np.where(dead, s.initial_velocity, res.v_final)
    return cols


def result_layout(plan: Plan, lanes: int) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shape and dtype of every result array for ``lanes`` lanes, in the Dataset's order:
    (directions?, lanes, chain?, *extra)."""
    lead = ([len(plan.directions)] if plan.continued else []) + [lanes] + (
        [plan.chain] if plan.continued else [])
    out = {}
    for name, spec in plan.specs.items():
        extra = [len(spec.extra_coords[d]) for d in spec.extra_dims]
        out[name] = (tuple(lead + extra), np.dtype(spec.dtype))
    out["status"] = (tuple(lead), np.dtype(np.int8))
    return out


def empty_results(plan: Plan) -> dict[str, np.ndarray]:
    """Full-size result arrays (NaN / status 3 'skipped') that chunks are written into."""
    out = {}
    for name, (shape, dtype) in result_layout(plan, plan.n_lanes).items():
        fill = 3 if name == "status" else False if dtype.kind == "b" else np.nan
        out[name] = np.full(shape, fill, dtype=dtype)
    return out


def store_chunk(results: dict[str, np.ndarray], plan: Plan, lane0: int, lane1: int,
                chunk: dict[str, np.ndarray]) -> None:
    """Copy one chunk's arrays into the full-size result arrays."""
    for name, arr in chunk.items():
        if plan.continued:
            results[name][:, lane0:lane1] = arr
        else:
            results[name][lane0:lane1] = arr


def assemble(plan: Plan, results: dict[str, np.ndarray], elapsed: float | None = None,
             kernel: float | None = None) -> xr.Dataset:
    """Reshape the lane-ordered arrays onto the study's dims and build the Dataset (DATA.md)."""
    lane_shape = [len(plan.grids[d]) for d in plan.lane_dims]
    data_vars = {}
    for name, arr in results.items():
        spec = plan.specs.get(name, VarSpec())
        if plan.continued:
            # (direction, lanes, speed, *extra) -> (direction, *lane_dims, speed, *extra) -> dims
            a = arr.reshape([arr.shape[0], *lane_shape, arr.shape[2], *arr.shape[3:]])
            order_now = ["direction", *plan.lane_dims, "speed", *spec.extra_dims]
            target = ["direction", *plan.dims, *spec.extra_dims]
            a = np.transpose(a, [order_now.index(d) for d in target])
            dims = tuple(target)
        else:
            a = arr.reshape([*lane_shape, *arr.shape[1:]])
            dims = (*plan.dims, *spec.extra_dims)
        data_vars[name] = (dims, a)
    coords: dict[str, tuple] = {d: ((d,), plan.grids[d]) for d in plan.dims}
    if plan.continued:
        coords["direction"] = (("direction",), np.array(plan.directions))
    if isinstance(plan.model, MeshModel):
        coords["mesh_frequency"] = (("speed",), mesh_frequency(plan.grids["speed"],
                                                               plan.model.teeth))
    for spec in plan.specs.values():
        for d, v in spec.extra_coords.items():
            coords.setdefault(d, ((d,), v))
        for name, c in spec.aux_coords.items():
            coords.setdefault(name, c)
    s = plan.study.solver
    settings = {
        "scene": plan.study.scene.kind,
        "method": s.method,
        "steps_per_period": s.steps_per_period,
        "kink_aware": int(s.kink_aware),
        "transient_periods": s.transient_periods,
        "recorded_periods": s.record_periods,
        "divergence_factor": s.divergence_factor,
        "settle_tolerance": s.settle_tolerance,
        "step_guard": s.step_guard,
        "cases": plan.n_cases,
    }
    if elapsed is not None:
        settings["elapsed_seconds"] = round(elapsed, 3)
    if kernel is not None:
        settings["kernel_seconds"] = round(kernel, 3)
    var_attrs = {n: dict(sp.attrs) for n, sp in plan.specs.items()}
    ds = build_dataset(data_vars, coords, title=plan.study.title, study_text=plan.text,
                       settings=settings, var_attrs=var_attrs,
                       source=f"gearsweep study, scene {plan.study.scene.kind!r}")
    if "speed" in ds.coords and isinstance(plan.model, MeshModel):
        ds["speed"].attrs["gear"] = f"driving gear (gear 1, {plan.model.teeth} teeth)"
    return ds


def run_study(study: Study | MeshStudy, text: str = "", progress: bool = False) -> xr.Dataset:
    """Run every chunk of a study in this process and return its Dataset."""
    if getattr(study, "type", None) == "mesh":  # a static mesh study: no integration
        from gearsweep.study.mesh_runner import run_mesh_study

        return run_mesh_study(study, text)
    plan = make_plan(study, text)
    results = empty_results(plan)
    t0 = time.perf_counter()
    chunks = plan.chunks()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=plan.n_cases, unit="case", desc=study.title[:40], leave=False)
    for a, b in chunks:
        store_chunk(results, plan, a, b, run_chunk(plan, a, b))
        if bar is not None:
            bar.update((b - a) * plan.chain * max(len(plan.directions), 1))
    if bar is not None:
        bar.close()
    return assemble(plan, results, time.perf_counter() - t0)
