#!/usr/bin/env bash
# The measurements that need a bigger machine than CI's (16 cores and one CUDA GPU), in one call.
#
# Issue 23 wants the pipeline and kernel figures on 16 cores (docs/scale.md, docs/benchmark.md)
# and the GPU backend's targets are still to be measured on a GPU (docs/gpu.md). A session that is
# lent the device machine (16 cores, one H100 or H200, no network) has 15 minutes of it in all,
# so everything runs from this one prepared script, step by step, most wanted first, each step
# with its own time limit inside one overall deadline, each writing its output under $OUT as soon
# as it ends (what finished comes back even if a later step runs out of time).
#
# On this machine, once (fetches the wheels the device image lacks, about 45 MB, into .whl/ and
# copies the C reference kernel into .bench/; git ignores both folders):
#
#     scripts/device_check.sh prepare [BENCH_DIR]      # BENCH_DIR: default ../shared/bench
#
# Then one call of the device tool: command `DEADLINE=470 bash scripts/device_check.sh run`, carry
# [".whl", ".bench"], timeout_s 500 (a machine's start costs 1-2 of the session's 15 minutes). Read $OUT/summary.txt first. A rehearsal on any machine
# (small sizes, the GPU steps answer "no GPU"): `SMALL=1 OUT=/tmp/dc scripts/device_check.sh run`.
#
# Steps of `run` (their files under $OUT):
#   env.txt            the wheels' install; machine, GPU, package versions, Numba's threading layer
#   kernel_cpu.jsonl   B1/B2 on 1 thread and all cores against the C reference (bench_kernel.py)
#   pipeline.jsonl     whole run / kernel-only at 1e6 and 1e7 cases on all cores (bench_pipeline.py)
#   kernel_gpu.jsonl   B1/B2 on the GPU in float64 (then float32, last), against the CPU kernel and C
#   gpu_study.txt      the 1e7-case study on the GPU: whole run against its kernel seconds
#                      (gpu_cache: the CUDA kernel compiled, then loaded from the disk cache)
#   gpu_tests.txt      the real-GPU tests of tests/test_cuda.py (PTX, every scene against the CPU)
#   workers.jsonl      --workers 1,2,4,8,16 at 1e6 cases against in-process (bench_pipeline.py);
#                      workers_1e7: 4,8,16 pinned at 1e7 cases (efficiency against 4 workers;
#                      2 workers take 40 s of the step's 150)
#   summary.txt        one line per step: exit status and seconds
set -u

mode=${1:-}
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"

if [ "$mode" = "prepare" ]; then
  bench=${2:-"$here/../shared/bench"}
  set -e
  mkdir -p .whl .bench
  cp "$bench/reference_kernel.c" "$bench/run_reference.sh" .bench/
  # The versions this repository is tested with (pyproject.toml and CI's install), CPython 3.12
  # (the device image's). Not llvmlite (60 MB, over the call's 64 MB): the image's is used.
  python3 -m pip download --no-deps --only-binary=:all: --python-version 3.12 \
    --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
    --platform manylinux_2_24_x86_64 --platform manylinux_2_17_x86_64 \
    --platform manylinux2014_x86_64 --platform manylinux1_x86_64 -d .whl -q \
    numpy==2.4.6 numba==0.68.1 numba-cuda==0.30.4 netCDF4==1.7.5.1.post1 cftime==1.6.6.1 \
    xarray==2026.9.0 pydantic==2.14.4 pydantic_core==2.50.5 annotated-types==0.8.0 \
    typing-inspection==0.4.5 Pint==0.25.3 flexcache==0.3 flexparser==0.4 platformdirs==4.14.8 \
    dask==2026.8.0 distributed==2026.8.0 partd==1.4.2 locket==1.0.0 tblib==3.2.2 zict==3.0.0 \
    tornado==6.6.1
  du -sh .whl .bench
  echo "now: the device tool's run with command 'DEADLINE=470 bash scripts/device_check.sh run'," \
       "carry ['.whl', '.bench'], timeout_s 500"
  exit 0
fi

if [ "$mode" != "run" ]; then
  echo "usage: scripts/device_check.sh prepare [BENCH_DIR] | run" >&2
  exit 2
fi

OUT=${OUT:-/tmp/device_check}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
PY=${PYTHON:-python3}
start=$(date +%s)
deadline=$((start + ${DEADLINE:-560}))
summary="$OUT/summary.txt"
rm -f "$OUT"/*.txt "$OUT"/*.jsonl

# step NAME LIMIT_S OUTFILE CMD...: runs CMD with at most LIMIT_S seconds (less if the overall
# deadline is nearer), stdout and stderr appended to $OUT/OUTFILE, one line into summary.txt.
# (The device tool brings back at most 8 files, so steps of one kind share a file.)
step() {
  local name=$1 limit=$2 file=$3
  shift 3
  case ",$STEPS," in *",$name,"*) ;; *) return ;; esac  # not asked for in this call
  local left=$((deadline - $(date +%s)))
  if [ "$left" -lt 20 ]; then
    echo "$name: skipped (deadline)" | tee -a "$summary"
    return
  fi
  [ "$limit" -gt "$left" ] && limit=$left
  local t0 rc
  t0=$(date +%s)
  timeout -k 5 "$limit" "$@" >> "$OUT/$file" 2>&1
  rc=$?
  echo "$name: exit $rc in $(($(date +%s) - t0)) s (limit $limit s) -> $file" | tee -a "$summary"
}

# The carried wheels: packages the image lacks, and numpy/numba/numba-cuda at the versions this
# repository is tested with (numba-cuda 0.30 fails to load its CUDA target under numpy 2.5).
if ls .whl/*.whl > /dev/null 2>&1; then
  "$PY" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl >> "$OUT/env.txt" 2>&1
  # byte-compiled once, in parallel: on 26 Nov 2026 (installed with --no-compile) importing the
  # libraries took 2.7 s there against 0.7 s here, inflating every whole-run figure by ~2 s
  "$PY" -m compileall -q -j 0 /tmp/site >> "$OUT/env.txt" 2>&1
  export PYTHONPATH="/tmp/site:$here${PYTHONPATH:+:$PYTHONPATH}"
  # numba 0.68 needs the image's llvmlite to be 0.50.x; else fall back to the image's numba
  if ! "$PY" -c "import numba" >> "$OUT/env.txt" 2>&1; then
    echo "carried numba does not load with the image's llvmlite: using the image's numba" \
      | tee -a "$summary"
    rm -rf /tmp/site/numba /tmp/site/numba-*.dist-info
  fi
else
  export PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}"
fi
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-/tmp/numba_cache}
[ -z "${CUDA_HOME:-}" ] && [ -d /usr/local/cuda ] && export CUDA_HOME=/usr/local/cuda

{
  date -u
  echo "nproc $(nproc)"
  env | grep -E "^(PYTHON|NUMBA|OMP|MKL)" | sort
  grep -m1 "model name" /proc/cpuinfo
  nvidia-smi -L 2>&1 | head -3
  "$PY" - <<'EOF'
import importlib, sys
print("python", sys.version.split()[0])
for name in ("numpy", "numba", "llvmlite", "numba_cuda", "xarray", "netCDF4", "pydantic", "pint",
             "dask", "distributed", "scipy", "pandas"):
    try:
        m = importlib.import_module(name)
        print(name, getattr(m, "__version__", "?"), getattr(m, "__file__", ""))
    except Exception as exc:  # noqa: BLE001 - a report, not a program
        print(name, "MISSING:", type(exc).__name__, str(exc).splitlines()[0][:120])
try:
    import numba
    import numpy as np

    @numba.njit(parallel=True)
    def f(a):
        for i in numba.prange(a.size):
            a[i] += 1.0

    f(np.zeros(64))
    print("numba threads", numba.get_num_threads(), "layer", numba.threading_layer())
except Exception as exc:  # noqa: BLE001
    print("numba parallel: FAILED", exc)
try:
    from numba import cuda
    print("numba.cuda from", cuda.__file__)
    print("cuda available", cuda.is_available())
except Exception as exc:  # noqa: BLE001
    print("numba.cuda: FAILED", exc)
EOF
} >> "$OUT/env.txt" 2>&1
echo "env: $(grep -c MISSING "$OUT/env.txt") package(s) missing -> env.txt" | tee -a "$summary"

ref=()
[ -f .bench/run_reference.sh ] && ref=(--reference --bench-dir .bench)
if [ -n "${SMALL:-}" ]; then  # rehearsal: the same steps, small
  sizes=1e4; workers=1,2; worker_size=1e4; cases=(--cases 1000); gpu_sizes=(--sizes 10000)
  study_size=1e4; scaling_cases=(--cases 2000)
else
  sizes=1e6,1e7; workers=1,2,4,8,16; worker_size=1e6; cases=(); gpu_sizes=(); study_size=1e7
  scaling_cases=(--cases 100000)
fi
threads=$(nproc)

# The steps, most wanted first. STEPS picks some. The first call of 26 Nov 2026 ran
# kernel_cpu,pipeline,kernel_gpu,gpu_study,gpu_tests,workers,kernel_gpu32; the second
# gpu_tests,kernel_gpu,gpu_study,gpu_study_none,startup,pipeline_1e7,pipeline_none,workers_pinned,
# scaling. Calls 3 to 6 (later that day; docs/data/device-2026-11-26/README.md) measured the
# rest. The default is what is still to be measured after them (docs/scale.md): the 1e7 runs on
# all cores since the saver and writer threads (d8c7046), the workers at 1e7 cases since they
# save their own chunks (3296a69, 8d40ad6) and 1e6 pinned, the start, and the GPU study. No device
# was lent to the sessions after those calls: the default is now the 1e7 runs on all cores and the
# GPU study, each with the chunk checkpoints written past the page cache (5e5767d) and, the same
# code, with GEARSWEEP_DIRECT_IO=0 (buffered, as before it), the start since the light cache loads
# (ac1544c), and the workers at 1e7 cases. Two calls on 27 Nov measured those
# (docs/data/device-2026-11-27/README.md has their commands): the 1e7 ratio on 16 cores came out at
# 1.475-1.605 in six batches, direct against buffered undecided, so the default is now those two
# steps with five runs each (REPEATS_1E7), the start beside them; first the real-GPU tests: the
# CUDA kernel's impacts count changed after the last call (9f47285, simulator only).
STEPS=${STEPS:-gpu_tests,startup,pipeline_1e7,pipeline_1e7_buffered}
REPEATS_1E7=${REPEATS_1E7:-5}
step kernel_cpu 75 kernel_cpu.jsonl "$PY" scripts/bench_kernel.py "${ref[@]}" "${cases[@]}" --rounds 3
step gpu_tests 120 gpu_tests.txt "$PY" -m pytest -q -p no:cacheprovider -p no:benchmark -n 4 \
  -k real_gpu tests/test_cuda.py
step pipeline 110 pipeline.jsonl "$PY" scripts/bench_pipeline.py --sizes "${PIPELINE_SIZES:-$sizes}" \
  --threads "$threads" --repeats "${REPEATS:-3}"
step kernel_gpu 60 kernel_gpu.jsonl "$PY" scripts/bench_kernel.py --device cuda "${ref[@]}" \
  "${gpu_sizes[@]}"
step gpu_cache 90 gpu_study.txt "$PY" scripts/bench_gpu_cache.py  # compile, then load from disk
step gpu_study 70 gpu_study.txt "$PY" scripts/bench_pipeline.py --gpu-study "$study_size" \
  --repeats 2
step gpu_study_none 45 gpu_study.txt "$PY" scripts/bench_pipeline.py --gpu-study "$study_size" \
  --repeats 2 --codec none
step startup 40 env.txt "$PY" scripts/bench_startup.py  # the start of a process, on this image
step pipeline_1e7 90 pipeline.jsonl "$PY" scripts/bench_pipeline.py --sizes "$study_size" \
  --threads "$threads" --repeats "${REPEATS_1E7:-2}"
step pipeline_1e7_buffered 90 pipeline.jsonl env GEARSWEEP_DIRECT_IO=0 "$PY" \
  scripts/bench_pipeline.py --sizes "$study_size" --threads "$threads" --repeats "${REPEATS_1E7:-2}"
step gpu_study_buffered 70 gpu_study.txt env GEARSWEEP_DIRECT_IO=0 "$PY" scripts/bench_pipeline.py \
  --gpu-study "$study_size" --repeats 2
step pipeline_none 65 pipeline.jsonl "$PY" scripts/bench_pipeline.py --sizes "$study_size" \
  --threads "$threads" --repeats 2 --codec none
step workers 80 workers.jsonl "$PY" scripts/bench_pipeline.py --sizes "$worker_size" \
  --workers "$workers" --threads "$threads" --repeats 1
step workers_pinned 100 workers.jsonl "$PY" scripts/bench_pipeline.py --sizes "$worker_size" \
  --workers "$workers" --pin --threads "$threads" --repeats 1
step workers_1e7 150 workers.jsonl "$PY" scripts/bench_pipeline.py --sizes "$study_size" \
  --workers "${WORKERS_1E7:-4,8,16}" --pin --threads "$threads" --repeats 1
step scaling 50 kernel_cpu.jsonl "$PY" scripts/bench_kernel.py "${ref[@]}" "${scaling_cases[@]}" \
  --rounds 2
step kernel_gpu32 40 kernel_gpu.jsonl "$PY" scripts/bench_kernel.py --device cuda \
  --precision float32 "${ref[@]}" "${gpu_sizes[@]}"
echo "total $(($(date +%s) - start)) s" | tee -a "$summary"
