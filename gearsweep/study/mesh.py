"""Static mesh studies (``type: mesh``): STE, load sharing and mesh stiffness to netCDF.

A mesh study computes :func:`gearsweep.gear.mesh_cycles` for one gear pair (``gear``) or several
labelled variants (``gears``, a ``variant`` dim) at one torque or a swept torque (a ``torque``
dim), and writes the variables of docs/data-format.md ``ste``, ``load_share`` (dim ``pair``) and
``mesh_stiffness`` over ``mesh_phase`` and ``k_harmonic``, ``k_phase``, ``ste_harmonic``,
``ste_phase``, ``e_harmonic``, ``e_phase`` over ``harmonic`` (integrated between the breaks of
the mesh, ``gearsweep.gear.mesh.Quadrature``; a dynamic scene fed this result as its
``excitation.file`` takes these, ``gearsweep.study.measured``)::

    type: mesh
    title: STE versus load, Table 1 (consistent interpretation)
    gears:
      no relief: table1_consistent
      6 um tip relief: {preset: table1_consistent, tip_relief: {amount: 6 um, start_at: single_contact}}
    sweep:
      torque: {start: 2 N*m, stop: 150 N*m, num: 50}
    positions: 200      # per mesh cycle
    harmonics: 10

``gearsweep run STUDY.yaml`` runs it like any other study (no integration, no solver).
"""

from __future__ import annotations

import time

import numpy as np
import xarray as xr

from gearsweep.errors import LimitError
from gearsweep.gear import iso6336_stiffness, mesh_cycles
from gearsweep.study.dataset import build_dataset
from gearsweep.study.execute import LIMITS, _size
from gearsweep.study.gearscene import gear_pair, tip_reliefs, warned_once
from gearsweep.study.schema import MeshStudy, summary
from gearsweep.units import KINDS

_ATTRS = {  # name -> (kind of gearsweep.units, or a unit; long name)
    "ste": ("displacement", "static transmission error along the line of action"),
    "load_share": ("1", "share of the load on each tooth pair"),
    "mesh_stiffness": ("stiffness", "mesh stiffness (tangent, sum over loaded pairs)"),
    "k_harmonic": ("stiffness", "Fourier amplitude of mesh stiffness (0 = mean)"),
    "k_phase": ("rad", "Fourier phase of mesh stiffness, cos(2 pi n phase + k_phase)"),
    "ste_harmonic": ("displacement", "Fourier amplitude of STE (0 = mean)"),
    "ste_phase": ("rad", "Fourier phase of STE, cos(2 pi n phase + ste_phase)"),
    "e_harmonic": ("displacement", ("Fourier amplitude of STE - mean_force / mesh_stiffness,"
                                    " the excitation e(t) of a scene with k(t) (0 = mean)")),
    "e_phase": ("rad", "Fourier phase of STE - mean_force / k, cos(2 pi n phase + e_phase)"),
    "in_contact": ("1", "tooth pair slot inside the geometric path of contact"),
    "mean_force": ("N", "normal load along the line of action T / r_b1"),
    "contact_ratio": ("1", "transverse contact ratio"),
    "base_pitch": ("length", "base pitch"),
    "base_radius_1": ("length", "base radius of the driving gear"),
    "base_radius_2": ("length", "base radius of the driven gear"),
    "gear_backlash": ("length", "backlash of the gear pair along the line of action"),
    "iso_single_stiffness": ("stiffness", ("ISO 6336-1 single stiffness c' at the torque, scaled"
                             " by (F_t K_A / b / 100 N/mm)^0.25 below 100 N/mm, K_A = 1"
                             " (x E / 206 GPa)")),
    "iso_mesh_stiffness": ("stiffness", ("ISO 6336-1 mesh stiffness c_gamma at the torque, scaled"
                           " by (F_t K_A / b / 100 N/mm)^0.25 below 100 N/mm, K_A = 1"
                           " (x E / 206 GPa)")),
    "pair": ("1", "tooth pair slot: slot j is at s_start + (mesh_phase + j) base pitch"),
    "harmonic": ("1", "Fourier harmonic order in mesh orders (0 = mean)"),
    "variant": ("-", "gear pair variant (label from the study)"),
}


BYTES_PER_POINT = 200.0
"""Peak memory of a mesh study per (gear pair, torque, position) [bytes]: 140 measured (20,000
torques of the Table 1 pair at 200 positions: 835 MB peak against 274 MB for 2 torques, 26 Nov
2026), with a margin."""

BASE_BYTES = 300e6
"""Peak memory of a mesh study of one torque (the interpreter, numpy, xarray) [bytes]."""


def memory_bytes(study: MeshStudy) -> float:
    """The peak memory a mesh study will take [bytes] (``gearsweep validate`` and ``run`` refuse
    one beyond the memory limit unless told ``--yes``: a study of 1e7 torques asked numpy for
    14.9 GiB, a traceback)."""
    return BASE_BYTES + BYTES_PER_POINT * len(study.variants) * len(study.torques()) \
        * study.positions


def check_memory(study: MeshStudy, where: str, ahead: str = "run with --yes to go ahead"
                 ) -> float:
    """A mesh study's peak memory (``memory_bytes``); one line (``LimitError``, then ``ahead``:
    how to go ahead) beyond the memory limit: the CLI without ``--yes``, ``gearsweep.run``
    without ``yes=True``."""
    memory = memory_bytes(study)
    if memory > LIMITS.memory_bytes:
        raise LimitError(f"{where}: refused (memory > {_size(LIMITS.memory_bytes)}): peak memory"
                         f" about {_size(memory)} for {summary(study)}; {ahead}")
    return memory


def run_mesh_study(study: MeshStudy, text: str = "") -> xr.Dataset:
    """Compute every mesh cycle of a mesh study and return its Dataset (docs/data-format.md names).

    Returns
    -------
    xarray.Dataset
        Dims ``variant`` (with ``gears``), ``torque`` (when swept), ``mesh_phase``, ``pair``,
        ``harmonic``; SI units.
    """
    t0 = time.perf_counter()
    torques = study.torques()
    variants = study.variants
    h = study.harmonics
    per: list[dict[str, np.ndarray]] = []
    described = []
    for label, spec in variants.items():
        with warned_once():
            pair = gear_pair(spec).check()
            cycles = mesh_cycles(pair, torques, n=study.positions,
                                 tip_relief=tip_reliefs(spec, pair), harmonics=h)
        arrays = [c.as_arrays(h) for c in cycles]
        c_prime, c_gamma = iso6336_stiffness(pair, torques)  # per torque (its line load)
        rec = {k: np.stack([a[k] for a in arrays]) for k in
               ("ste", "load_share", "mesh_stiffness", "k_harmonic", "k_phase", "ste_harmonic",
                "ste_phase", "e_harmonic", "e_phase")}
        rec["mean_force"] = np.array([c.load for c in cycles])
        rec["iso_single_stiffness"], rec["iso_mesh_stiffness"] = c_prime, c_gamma
        rec["in_contact"] = cycles[0].in_contact
        rec.update(contact_ratio=pair.contact_ratio, base_pitch=pair.base_pitch,
                   base_radius_1=pair.base_radius1, base_radius_2=pair.base_radius2,
                   gear_backlash=pair.backlash_loa)
        per.append(rec)
        relief = f", tip relief {spec.tip_relief.model_dump(exclude_none=True)}" if (
            spec.tip_relief is not None) else ""
        described.append(f"{label + ': ' if label else ''}{pair.name}, z {pair.z1}/{pair.z2},"
                         f" m {pair.module * 1e3:g} mm, b {pair.face_width * 1e3:g} mm, contact"
                         f" ratio {pair.contact_ratio:.4f}{relief}")
    # Pad the pair-slot axis to the largest contact ratio among the variants.
    n_slot = max(r["load_share"].shape[-1] for r in per)
    for r in per:
        pad = n_slot - r["load_share"].shape[-1]
        if pad:
            r["load_share"] = np.pad(r["load_share"], [(0, 0), (0, 0), (0, pad)],
                                     constant_values=np.nan)
            r["in_contact"] = np.pad(r["in_contact"], [(0, 0), (0, pad)], constant_values=False)

    multi = study.gears is not None
    lead = (("variant",) if multi else ()) + (("torque",) if study.swept_torque else ())

    def stack(name: str) -> np.ndarray:
        a = np.stack([r[name] for r in per])  # (variant, torque, ...)
        if not study.swept_torque:
            a = a[:, 0]
        return a if multi else a[0]

    trailing = {"ste": ("mesh_phase",), "mesh_stiffness": ("mesh_phase",),
                "load_share": ("mesh_phase", "pair"), "k_harmonic": ("harmonic",),
                "k_phase": ("harmonic",), "ste_harmonic": ("harmonic",),
                "ste_phase": ("harmonic",), "e_harmonic": ("harmonic",),
                "e_phase": ("harmonic",), "mean_force": (), "iso_single_stiffness": (),
                "iso_mesh_stiffness": ()}
    data_vars: dict[str, tuple] = {n: ((*lead, *d), stack(n)) for n, d in trailing.items()}
    vdim = ("variant",) if multi else ()
    data_vars["in_contact"] = ((*vdim, "mesh_phase", "pair"),
                               np.stack([r["in_contact"] for r in per]) if multi
                               else per[0]["in_contact"])
    for name in ("contact_ratio", "base_pitch", "base_radius_1", "base_radius_2", "gear_backlash"):
        vals = np.array([r[name] for r in per])
        data_vars[name] = (vdim, vals if multi else vals[0])
    coords: dict[str, tuple] = {
        "mesh_phase": (("mesh_phase",), np.arange(study.positions) / study.positions),
        "pair": (("pair",), np.arange(n_slot)),
        "harmonic": (("harmonic",), np.arange(h + 1)),
        "torque": (("torque",), torques) if study.swept_torque else ((), torques[0]),
    }
    if multi:
        coords["variant"] = (("variant",), np.array(list(variants), dtype=str))
    var_attrs = {k: {"kind" if u in KINDS else "units": u, "long_name": ln}
                 for k, (u, ln) in _ATTRS.items()}  # a kind: stored in its display unit
    settings = {"scene": "mesh", "positions": study.positions, "harmonics": h,
                "gears": "; ".join(described), "cases": len(variants) * len(torques),
                "elapsed_seconds": round(time.perf_counter() - t0, 3)}
    ds = build_dataset(data_vars, coords, title=study.title, study_text=text, settings=settings,
                       var_attrs=var_attrs, source="gearsweep mesh study (gearsweep.gear)")
    return ds
