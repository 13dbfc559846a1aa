"""A result file's layout by arithmetic: the chunk shape of its variables (``file_chunks``, which
the writer uses) and an upper bound of its size (``output_bound``, which the estimate uses).

The bound counts what the file holds (``file_variables``): the result variables as HDF5 stores
them, uncompressed (whole chunks, the partly filled ones at the edges too, plus what a codec adds
to data it cannot compress), the coordinates (``frequency(speed, order)`` of a spectrum too), the
variables a gear scene or an excitation file adds, the attributes (the study text, the model
JSON) and HDF5's own structures: a fixed part per file (``FILE_BYTES``), a part per variable
(``VARIABLE_BYTES``) and the B-tree that indexes a chunked variable's chunks
(``btree_node_bytes``). It needs no grid of cases and no xarray: any study, 1e15 cases too, is
bounded in about a millisecond. The constants were measured by ``scripts/measure_file_overhead.py``
(docs/scale.md, "Estimate and limits"), and ``tests/test_output_bound.py`` checks the bound
against files the runner wrote.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gearsweep.gear.excitation import DEFAULT_HARMONICS
from gearsweep.gear.measured import fit_orders
from gearsweep.model import MeshModel, model_record
from gearsweep.study.outputs import status_attrs
from gearsweep.study.provenance import command_line, provenance

FILE_CHUNK_BYTES = 1 << 20
"""Uncompressed size of one chunk of a result variable in the file (at most) [bytes]."""


def file_chunks(shape: tuple[int, ...], itemsize: int, target: int | None = None
                ) -> tuple[int, ...]:
    """Chunk shape of a variable in the file: whole trailing dims, then as many rows of the
    next dim as fit in ``target`` bytes, one along the dims before (C order, so a run of
    consecutive lanes fills whole file chunks)."""
    target = target or FILE_CHUNK_BYTES
    chunks = [max(1, n) for n in shape]
    size = itemsize
    for i in range(len(shape) - 1, -1, -1):
        if size * chunks[i] <= target:
            size *= chunks[i]
            continue
        chunks[i] = max(1, target // size)
        chunks[:i] = [1] * i
        break
    return tuple(chunks)


# --------------------------------------------------------------------- HDF5's share, measured

FILE_BYTES = 12288
"""HDF5's fixed part of a result file [bytes]: superblock, root group (its links and its ~20
global attributes, in dense storage), the first global heap collection (the variables'
dimension lists) and the 2 kB metadata blocks left partly used. Measured with
``VARIABLE_BYTES`` by ``scripts/measure_file_overhead.py --files 960`` (netCDF4-python 1.7.5 with
netCDF-C 4.10.1 and HDF5 2.2.0, this machine, 26 Nov 2026) on 960 files laid out as result files
(4-37 variables, 16 kB-19 MB, study texts up to 200 kB): a least-squares fit on those under
1 MB gives 7.6 kB + 947 bytes per variable, scattered by up to 11 kB (attributes past an object
header's first block, global heap collections); with 2,048 bytes per variable every file was
within the bound for a fixed part of 5,030 bytes. The file of the runner adds a few attributes
to every variable (xarray's), hence the margin."""

VARIABLE_BYTES = 2048
"""HDF5's part of each variable [bytes], beside its data, its attribute text and its chunk
index: object header, dataspace, datatype, fill value, filter pipeline, dimension list, and its
share of the metadata blocks (fitted: 947 bytes on average; see ``FILE_BYTES``)."""

ATTRIBUTE_TEXT_BYTES = 512
"""Attribute text (names and values) per variable that the bound allows for what gearsweep's
tables give every variable [bytes]: units, long_name, comment, xarray's coordinates and
_FillValue. What an output's ``VarSpec`` adds, and ``status``'s flag attributes
(``outputs.status_attrs``), are counted on top, exactly (``file_variables``);
``tests/test_output_bound.py`` checks every variable of written files against it."""

GLOBAL_TEXT_BYTES = 512
"""Global attribute text beside the study, its title, the model JSON and ``history`` [bytes]:
Conventions, source, study_sha256, the solver settings and the timings (357-363 bytes in the
template of every study in studies/)."""

HISTORY_STAMP = len("2026-11-26T04:41:00Z: ")
"""``history``'s time stamp before ``provenance()``."""

COMMAND_BYTES = 4096
"""``history``'s command line, at most (unless this process's own is longer): counted alike
whichever command asks (``validate``, ``run --estimate``, the run itself), so that they give
one estimate."""

BTREE_FILL = 31
"""Chunks per node of a chunked variable's B-tree at least: HDF5 (netCDF-4 files use the 1.8
format) indexes the chunks with a version-1 B-tree of nodes of 2K = 64 entries (K = 32,
``istore_k``) and splits a full node into two half-full ones; 31 leaves room for the inner
nodes. Measured (``scripts/measure_file_overhead.py``): up to 2,048 one-element chunks cost at
most 66.1 (rank 1) and 98.8 (rank 3) bytes per chunk beside their data and zstd frame when
written in random order, 64.6 and 89.2 in order; ``btree_node_bytes(rank) / 31`` is 67.6 and
101.2."""

CODEC_BYTES = 16
"""What a codec adds to one chunk it cannot compress, at least [bytes]: zstd's frame header
(9 bytes on an 8-byte chunk), zlib's header and checksum. Per byte of the chunk it adds up to
``1 / CODEC_RATIO`` more."""

CODEC_RATIO = 2048
"""... on top, one byte per this many of the chunk (512 per 1 MiB chunk): zlib (level 1,
shuffle) stored 1 MiB of random bytes in 1 MiB + 326 bytes, zstd (levels 1 and -1) in 1 MiB + 34
(``scripts/measure_file_overhead.py``). (blosc_lz4 refuses such a chunk: ``--codec
blosc_lz4`` fails on incompressible data, docs/scale.md.)"""

VLEN_BYTES = 32
"""A variable-length string (the ``direction`` coordinate) beside its text [bytes]: 16 in the
variable (length and global heap id) and a 16-byte heap object header; its text is rounded up to
8 bytes."""


def btree_node_bytes(rank: int) -> int:
    """Size of one node of the chunk B-tree of a variable of ``rank`` dims [bytes] (HDF5 file
    format, version-1 B-trees: a 24-byte header, 64 child addresses of 8 bytes and 65 keys of a
    chunk size, a filter mask and ``rank + 1`` offsets of 8 bytes each): 2,096 bytes for rank 1,
    3,136 for rank 3. Every chunked variable has one even with a single chunk."""
    return 24 + 64 * 8 + 65 * (8 + 8 * (rank + 1))


@dataclass(frozen=True)
class FileVariable:
    """One variable of a result file as the bound counts it."""

    name: str
    shape: tuple[int, ...]
    itemsize: int
    """Bytes per element; for a string, its longest text in UTF-8."""
    chunked: bool = False
    """A data variable with dims (chunked, compressed); else contiguous (coordinates, scalars)."""
    string: bool = False
    text: int = ATTRIBUTE_TEXT_BYTES
    """Its attribute text (names and values) [bytes], at most."""

    def nbytes(self) -> int:
        """Bytes this variable takes in the file, at most."""
        n = math.prod(self.shape)
        if self.string:
            data = n * (VLEN_BYTES + -(-self.itemsize // 8) * 8)
        elif self.chunked and n:
            chunks = file_chunks(self.shape, self.itemsize)
            count = math.prod(-(-s // c) for s, c in zip(self.shape, chunks, strict=True))
            chunk = math.prod(chunks) * self.itemsize
            data = count * (chunk + CODEC_BYTES + -(-chunk // CODEC_RATIO)) \
                + btree_node_bytes(len(self.shape)) * (1 + -(-(count - 1) // BTREE_FILL))
        else:
            data = n * self.itemsize
        return VARIABLE_BYTES + self.text + data


def _text(attrs: dict) -> int:
    """Bytes of attribute text (names and values) of ``attrs``."""
    return sum(len(k.encode()) + (len(v.encode()) if isinstance(v, str)
                                  else np.asarray(v).nbytes) for k, v in attrs.items())


def _grid(name: str, values: np.ndarray) -> FileVariable:
    """A coordinate of ``values`` (a string one as variable-length strings)."""
    a = np.asarray(values)
    if a.dtype.kind in "OUS":
        longest = max((len(str(v).encode()) for v in a.ravel()), default=0)
        return FileVariable(name, a.shape, longest, string=True)
    return FileVariable(name, a.shape, a.dtype.itemsize)


def file_variables(plan: Any) -> list[FileVariable]:
    """Every variable of ``plan``'s result file (``resultfile.describe``) with its size and
    layout, from the plan's sizes alone."""
    continued = bool(plan.directions)
    lead = ([len(plan.directions)] if continued else []) + [len(plan.grids[d]) for d in plan.dims]
    out = []
    for name, spec in plan.specs.items():
        extra = [len(spec.extra_coords[d]) for d in spec.extra_dims]
        out.append(FileVariable(name, tuple(lead + extra), np.dtype(spec.dtype).itemsize,
                                chunked=True, text=ATTRIBUTE_TEXT_BYTES
                                + _text(spec.result_attrs())))
    out.append(FileVariable("status", tuple(lead), 1, chunked=True,
                            text=ATTRIBUTE_TEXT_BYTES + _text(status_attrs())))
    coords: dict[str, FileVariable] = {d: _grid(d, plan.grids[d]) for d in plan.dims}
    if continued:
        coords["direction"] = _grid("direction", np.array(plan.directions))
    if isinstance(plan.model, MeshModel):
        coords["mesh_frequency"] = FileVariable("mesh_frequency", (len(plan.grids["speed"]),), 8)
    for spec in plan.specs.values():
        for d, v in spec.extra_coords.items():
            coords.setdefault(d, _grid(d, v))
        for name, (_, v) in spec.aux_coords.items():
            coords.setdefault(name, _grid(name, v))
    out += coords.values()
    scene = plan.study.scene
    if getattr(scene, "gear", None) is not None:
        out += _gear_variables(plan)
    if getattr(scene, "excitation", None) is not None:
        out += _excitation_variables(plan)
    return out


def _gear_variables(plan: Any) -> list[FileVariable]:
    """``resultfile.gear_variables``: three scalars, k0 per load and k_n, e_n per load and
    harmonic (at most the scene's harmonics, or the model's)."""
    scene, model = plan.study.scene, plan.model
    harmonics = max(1, scene.harmonics or DEFAULT_HARMONICS, len(model.stiffness_harmonics),
                    len(model.ste_harmonics))
    lead = [len(plan.grids[d]) for d in ("torque", "mean_force") if d in plan.grids][:1] \
        if plan.gear_load_swept else []
    scalars = [FileVariable(n, (), 8) for n in ("gear_contact_ratio", "gear_base_radius_1",
                                                 "gear_base_radius_2")]
    return [*scalars, FileVariable("harmonic", (harmonics,), 8),
            FileVariable("gear_stiffness", tuple(lead), 8, chunked=bool(lead)),
            *(FileVariable(n, (*lead, harmonics), 8, chunked=True)
              for n in ("gear_stiffness_harmonic", "gear_ste_harmonic"))]


def _excitation_variables(plan: Any) -> list[FileVariable]:
    """``resultfile.excitation_variables``: the fit residuals (attributes name the file) and the
    fitted orders' amplitudes and phases."""
    scene = plan.study.scene
    ex = scene.excitation
    orders = len(fit_orders(ex.harmonics, scene.teeth, ex.span == "revolution"))
    named = ATTRIBUTE_TEXT_BYTES + len(str(ex.file).encode())
    return [FileVariable("excitation_fit_residual_ste", (), 8, text=named),
            FileVariable("excitation_fit_residual_stiffness", (), 8, text=named),
            FileVariable("excitation_order", (orders,), 8),
            *(FileVariable(f"excitation_{q}_{p}", (orders,), 8, chunked=True)
              for q in ("ste", "stiffness") for p in ("amplitude", "phase"))]


def global_text(plan: Any) -> int:
    """Bytes of the file's global attributes, at most: the study text, its title, the model
    JSON (with ``model_swept`` and ``excitation_sha256``) and ``history`` (its command line as
    ``COMMAND_BYTES``) counted, the rest allowed for (``GLOBAL_TEXT_BYTES``)."""
    command = len(command_line().encode())
    return (GLOBAL_TEXT_BYTES + HISTORY_STAMP + len(provenance().encode()) - command
            + max(command, COMMAND_BYTES)
            + len(plan.text.encode()) + len(plan.study.title.encode())
            + len(json.dumps(model_record(plan.model)).encode())
            + len(" ".join(plan.model_swept))
            + (64 if getattr(plan.study.scene, "excitation", None) is not None else 0))


def output_bound(plan: Any) -> int:
    """The most bytes ``plan``'s result file can take (``file_variables``, ``global_text``)."""
    return FILE_BYTES + global_text(plan) + sum(v.nbytes() for v in file_variables(plan))
