"""Measure what HDF5 adds to a result file beside its data and attribute text, for the output
bound of the estimate (``gearsweep.study.filelayout``).

    python scripts/measure_file_overhead.py [--files 80] [--seed 0]

Writes netCDF-4 files with netCDF4-python laid out as gearsweep's result files are (contiguous
coordinates, chunked zstd data variables with ``_FillValue``, scalars, a 2-D auxiliary
coordinate, about 20 global attributes with a study text) with random sizes, attributes and
incompressible data, and prints:

* the fixed part per file and the part per variable (``FILE_BYTES``, ``VARIABLE_BYTES``): a
  least-squares fit of size - data - attribute text - chunk index = FILE + VARIABLE * variables,
  with the largest residual added to FILE so that every file is within the bound;
* the bytes per chunk of the chunk B-tree (one-element chunks, in order and in random order)
  beside ``btree_node_bytes(rank) / BTREE_FILL``;
* what zstd and zlib add to 1 MiB of random bytes (``CODEC_BYTES``, ``CODEC_RATIO``).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import netCDF4
import numpy as np

from gearsweep.study.filelayout import (
    BTREE_FILL,
    FILE_BYTES,
    VARIABLE_BYTES,
    FileVariable,
    btree_node_bytes,
    file_chunks,
)
from gearsweep.study.resultfile import ZSTD_LEVEL


def _size(path: Path, build) -> int:
    ds = netCDF4.Dataset(path, "w", format="NETCDF4")
    try:
        build(ds)
    finally:
        ds.close()
    size = path.stat().st_size
    path.unlink()
    return size


def _text(attrs: dict) -> int:
    return sum(len(k) + (len(v.encode()) if isinstance(v, str) else np.asarray(v).nbytes)
               for k, v in attrs.items())


def _padding(v: FileVariable) -> int:
    """Bytes of the partly filled chunks at the edges beyond the data: the bound counts whole
    chunks (stored so without a codec), a codec packs their fill values into almost nothing."""
    if not v.chunked or not v.shape:
        return 0
    chunks = file_chunks(v.shape, v.itemsize)
    whole = np.prod([-(-s // c) * c for s, c in zip(v.shape, chunks, strict=True)])
    return int(whole - np.prod(v.shape)) * v.itemsize


def _noise(rng, shape, dtype) -> np.ndarray:
    """Incompressible values of ``shape`` (random bytes)."""
    n = int(np.prod(shape)) * np.dtype(dtype).itemsize
    return rng.integers(0, 256, n, dtype=np.uint8).view(dtype).reshape(shape)


def _attrs(rng, count: int) -> dict:
    return {f"attr_{i}": "x" * int(rng.integers(1, 180)) for i in range(count)}


def result_like(rng, path: Path) -> dict:
    """Write one random result-like file; return its size and what the bound counts."""
    ndims = int(rng.integers(1, 4))
    sizes = [int(rng.choice([1, 3, 7, 50, 600, 2000])) for _ in range(ndims)]
    dims = [f"d{i}" for i in range(ndims)]
    nvars = int(rng.integers(1, 30))
    big = rng.random() < 0.3  # some files with variables of several 1 MiB chunks
    counted: list[FileVariable] = []
    gtext = 0

    def build(ds):
        nonlocal gtext
        for d, n in zip(dims, sizes, strict=True):
            ds.createDimension(d, n)
            v = ds.createVariable(d, "f8", (d,))
            attrs = {"units": "rpm", "long_name": "a coordinate " + "y" * int(rng.integers(0, 40))}
            v.setncatts(attrs)
            v[:] = np.arange(n, dtype=float)
            counted.append(FileVariable(d, (n,), 8, text=_text(attrs)))
        ds.createDimension("order", 5)
        v = ds.createVariable("order", "f8", ("order",))
        v[:] = np.arange(5.0)
        counted.append(FileVariable("order", (5,), 8, text=0))
        aux = ds.createVariable("frequency", "f8", (dims[0], "order"))
        aux.setncatts({"units": "Hz", "long_name": "spectrum frequency"})
        aux[:] = np.ones((sizes[0], 5))
        counted.append(FileVariable("frequency", (sizes[0], 5), 8, text=_text(aux.__dict__)))
        for i in range(nvars):
            rank = int(rng.integers(1, min(ndims, 3) + 1))
            vd = list(dims[:rank]) + (["order"] if rng.random() < 0.2 else [])
            shape = [sizes[dims.index(d)] if d in dims else 5 for d in vd]
            if np.prod(shape) > 300_000:  # a few MB at most
                vd, shape = vd[-1:], shape[-1:]
            if big and i == 0:
                ds.createDimension("long", int(rng.integers(2, 6)) * (1 << 17) + 17)
                vd, shape = ["long"], [len(ds.dimensions["long"])]
            dtype = "i1" if rng.random() < 0.2 else "f8"
            itemsize = np.dtype(dtype).itemsize
            chunks = file_chunks(tuple(shape), itemsize)
            fill = {"fill_value": np.int8(-1) if dtype == "i1" else np.nan}
            v = ds.createVariable(f"v{i}", dtype, vd, compression="zstd", complevel=ZSTD_LEVEL,
                                  chunksizes=chunks, **fill)
            attrs = _attrs(rng, int(rng.integers(1, 7)))
            v.setncatts(attrs)
            v[...] = _noise(rng, shape, dtype)
            counted.append(FileVariable(f"v{i}", tuple(shape), itemsize, chunked=True,
                                        text=_text(attrs) + len("_FillValue") + itemsize))
        for i in range(int(rng.integers(0, 4))):
            v = ds.createVariable(f"s{i}", "f8", ())
            attrs = _attrs(rng, 3)
            v.setncatts(attrs)
            v.assignValue(1.5)
            counted.append(FileVariable(f"s{i}", (), 8, text=_text(attrs) + len("_FillValue") + 8))
        g = {f"setting_{i}": "z" * int(rng.integers(1, 30)) for i in range(16)}
        g["study"] = "s" * int(rng.choice([200, 2000, 20000, 200000]) * rng.random()) + "s"
        g["model"] = json.dumps({"k": list(range(int(rng.integers(10, 300))))})
        g["history"] = "h" * int(rng.integers(50, 400))
        ds.setncatts(g)
        gtext = _text(g)

    size = _size(path, build)
    fixed = sum(v.nbytes() - VARIABLE_BYTES - _padding(v) for v in counted) + gtext
    return {"size": size, "variables": len(counted), "counted": fixed}


def btree(rng, path: Path, m: int, rank: int, shuffled: bool) -> float:
    """Bytes per chunk beyond the first of a variable of ``m`` one-element chunks, less its
    data and zstd frames (9 bytes on 8)."""

    def build(n):
        def b(ds):
            shape = [n] + [1] * (rank - 1)
            names = [f"x{i}" for i in range(rank)]
            for d, k in zip(names, shape, strict=True):
                ds.createDimension(d, k)
            v = ds.createVariable("v", "f8", names, compression="zstd", complevel=ZSTD_LEVEL,
                                  chunksizes=(1,) * rank)
            data = _noise(rng, (n,), "f8")
            for i in (rng.permutation(n) if shuffled else range(n)):
                v[(int(i),) + (0,) * (rank - 1)] = data[i]
        return b

    one = _size(path, build(1))
    return (_size(path, build(m)) - one) / (m - 1) - 17


def codec(rng, path: Path, name: str) -> int:
    """Size of a file of one 1 MiB chunk of random bytes written with codec ``name``."""
    n = 1 << 17
    kw = {"zstd": {"compression": "zstd", "complevel": ZSTD_LEVEL},
          "zlib": {"zlib": True, "complevel": 1, "shuffle": True}, "none": {}}[name]

    def b(ds):
        ds.createDimension("x", n)
        ds.createVariable("v", "f8", ("x",), chunksizes=(n,), **kw)[:] = _noise(rng, (n,), "f8")

    return _size(path, b)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", type=int, default=80)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"netCDF4 {netCDF4.__version__}, netCDF-C {netCDF4.__netcdf4libversion__},"
          f" HDF5 {netCDF4.__hdf5libversion__}")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.nc"
        rows = [result_like(rng, path) for _ in range(args.files)]
        x = np.array([r["variables"] for r in rows], float)
        y = np.array([r["size"] - r["counted"] for r in rows], float)
        small = np.array([r["size"] < 1e6 for r in rows])  # the bound's allowances for codec
        slope, intercept = np.polyfit(x[small], y[small], 1)  # and chunk index weigh on big ones
        worst = float(np.max(y[small] - (intercept + slope * x[small])))
        print(f"{len(rows)} files of {int(x.min())}-{int(x.max())} variables,"
              f" {min(r['size'] for r in rows):,}-{max(r['size'] for r in rows):,} bytes."
              f" HDF5's part, files under 1 MB: {intercept:.0f} + {slope:.0f} per variable"
              f" (largest residual {worst:.0f}); with VARIABLE_BYTES = {VARIABLE_BYTES} every"
              f" file is within the bound for FILE_BYTES >= {np.max(y - VARIABLE_BYTES * x):.0f}"
              f" (FILE_BYTES = {FILE_BYTES})")
        for rank in (1, 3):
            for shuffled in (False, True):
                per = max(btree(rng, path, m, rank, shuffled) for m in (128, 512, 2048))
                print(f"chunk B-tree, rank {rank}, {'random order' if shuffled else 'in order'}:"
                      f" at most {per:.1f} bytes per chunk; btree_node_bytes / BTREE_FILL ="
                      f" {btree_node_bytes(rank) / BTREE_FILL:.1f}")
        plain = codec(rng, path, "none")
        for name in ("zstd", "zlib"):
            print(f"{name} on 1 MiB of random bytes: {codec(rng, path, name) - plain:+d} bytes")


if __name__ == "__main__":
    main()
