#!/usr/bin/env bash
# one-off device experiment (not committed): 16 vs 15 kernel threads in the 1e7 run
STEPS=none DEADLINE=60 bash scripts/device_check.sh run > /dev/null 2>&1
export PYTHONPATH=/tmp/site:$PWD NUMBA_CACHE_DIR=/tmp/numba_cache PYTHONUNBUFFERED=1
for i in 1 2 3; do
  timeout 120 python3 scripts/bench_pipeline.py --sizes 1e7 --threads 16,15 --repeats 2 >> $OUT/t.jsonl 2>&1
done
lscpu | grep -iE "thread|core|socket|model name" >> $OUT/t.jsonl
