#!/usr/bin/env bash
# Issue 18's GPU measurement, prepared as one command for a session that is lent an accelerator:
# `bench_montecarlo.py` (Chen 2022 M1, jaxatt's default `monte_carlo` call against the hand scan,
# NumPy and SciPy, every row checked) at batches up to 10^6, in float32 and then float64.
#
# Run it from the repository root, on the machine with the GPU:
#
#     bash benchmarks/gpu_run.sh
#
# It needs no install: jaxatt is imported from src/ (PYTHONPATH) with the JAX, equinox, diffrax,
# optax and SciPy the machine already has. Each precision writes, under $OUT (default
# benchmarks/results): montecarlo_gpu_<dtype>.json (with the device name and kind, the library
# versions and every check) and montecarlo_gpu_<dtype>.log (what the script printed).
# environment.txt records nvidia-smi, the Python and the JAX devices.
#
# Settings (environment variables, with their defaults): BATCHES="1000 10000 100000 1000000",
# HORIZON=2 (seconds simulated: 2000 RK4 steps at dt = 1e-3 s, issue 18's own horizon),
# PER_RUN=240 (seconds allowed to each precision's run before it is stopped, so that one slow
# compile cannot spend the whole lease), PYTHON=python3. The SciPy baseline integrates one
# trajectory on the host (its rate does not depend on the GPU); Basilisk is skipped.
#
# Every absolute time in benchmarks/README.md up to now is a CPU time. Record these figures
# with the device name from the JSON, and compare ratios only within one run.
set -uo pipefail
SCRIPT="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"
cd "$(dirname "$SCRIPT")/.."

OUT="${OUT:-benchmarks/results}"
BATCHES="${BATCHES:-1000 10000 100000 1000000}"
HORIZON="${HORIZON:-2}"
PER_RUN="${PER_RUN:-240}"
PYTHON="${PYTHON:-python3}"
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
if [ -n "${DRY_RUN:-}" ]; then
    # Print each precision's bench_montecarlo.py arguments, run nothing (the suite parses them:
    # tests/test_benchmark_scripts.py).
    for dtype in float32 float64; do
        echo "--batches $BATCHES --horizon $HORIZON --dtype $dtype --no-basilisk" \
            "--scipy-samples 1 --repeat 3 --max-seconds 10 --out $OUT/montecarlo_gpu_$dtype.json"
    done
    exit 0
fi
mkdir -p "$OUT"

{
    date -u
    nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv || echo "no nvidia-smi"
    "$PYTHON" -c 'import sys, jax; print(sys.version); print("jax", jax.__version__, jax.devices())'
} 2>&1 | tee "$OUT/environment.txt"

status=0
for dtype in float32 float64; do
    # shellcheck disable=SC2046  # the arguments are words without spaces
    timeout "$PER_RUN" "$PYTHON" benchmarks/bench_montecarlo.py $(DRY_RUN=1 bash "$SCRIPT" | grep -- "--dtype $dtype") \
        2>&1 | tee "$OUT/montecarlo_gpu_$dtype.log"
    rc=${PIPESTATUS[0]}
    echo "bench_montecarlo.py --dtype $dtype: exit $rc" | tee -a "$OUT/environment.txt"
    [ "$rc" -eq 0 ] || status=$rc
done
exit "$status"
