#!/usr/bin/env bash
# The GPU figures of the SPH step (docs/gpu.md), on a machine with an NVIDIA GPU, in one command:
#
#   bash benchmarks/gpu_measure.sh [OUT] [PART]
#
# PART = bench     `erosim info`; the CPU/GPU agreement check (benchmarks/gpu_agreement.py); the device
#                  benchmark at 10^6 and 10^7 fluid particles; the CPU benchmark at the same sizes (the
#                  ratio: same machine, same call; 40 and 10 timed steps after 20 untimed ones)
#        validate  `erosim validate martin-moyce --device cuda` and `hydrostatic --device cuda`
#        all       both (default)
# Each part takes a few minutes (Numba compiles the CPU and GPU kernels on a fresh machine first).
# OUT (default gpu-results) receives one JSON file per figure and measure.log (every command, its
# exit status, wall time and the tail of its error output); run folders go to $RUNS (default
# /tmp/erosim-gpu-runs). PYTHON picks the interpreter (default python3); it needs numba-cuda
# (`pip install 'erosim[cuda]'`). WHEELS=DIR first installs wheels from DIR (no index, into
# /tmp/erosim-site) for a machine without network: benchmarks/gpu_wheels.sh DIR fetches erosim's
# dependencies that a CUDA Python image usually lacks.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-gpu-results}
PART=${2:-all}
PY=${PYTHON:-python3}
RUNS=${RUNS:-/tmp/erosim-gpu-runs}
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}"
export PYTHONUNBUFFERED=1
if [ -n "${WHEELS:-}" ]; then
    $PY -m pip install -q --no-index --no-deps --no-compile --upgrade --target /tmp/erosim-site "$WHEELS"/*.whl || exit 1
    export PYTHONPATH="$PYTHONPATH:/tmp/erosim-site"
fi
mkdir -p "$OUT" "$RUNS"
LOG="$OUT/measure.log"

erosim() { $PY -c 'import sys; from erosim.cli import main; sys.argv[0] = "erosim"; main()' "$@"; }

# step NAME COMMAND...: run it, its standard output to OUT/NAME.json, the rest to the log
step() {
    local name=$1
    shift
    echo "== $name: $*" | tee -a "$LOG"
    local t0=$SECONDS
    "$@" >"$OUT/$name.json" 2>"$RUNS/$name.err"
    local rc=$?
    echo "   exit $rc after $((SECONDS - t0)) s" | tee -a "$LOG"
    tail -c 1500 "$OUT/$name.json" | tee -a "$LOG"
    echo | tee -a "$LOG"
    if [ $rc -ne 0 ]; then tail -n 15 "$RUNS/$name.err" | tee -a "$LOG"; fi
}

{
    date -u
    nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.max.sm --format=csv 2>&1
    $PY -c 'import numba, numpy; print("numba", numba.__version__, "numpy", numpy.__version__)'
    $PY -c 'from numba import cuda; print("numba.cuda:", getattr(cuda, "implementation", "Built-in"))'
    nproc
} 2>&1 | tee -a "$LOG"

if [ "$PART" = all ] || [ "$PART" = bench ]; then
    step info erosim info
    step agreement $PY benchmarks/gpu_agreement.py --particles 20000 --steps 100
    step bench_cuda_1e6 erosim bench sph --device cuda --particles 1000000 --json
    step bench_cuda_1e7 erosim bench sph --device cuda --particles 10000000 --json
    step bench_cpu_1e6 erosim bench sph --device cpu --particles 1000000 --steps 40 --json
    step bench_cpu_1e7 erosim bench sph --device cpu --particles 10000000 --steps 10 --json
    $PY - "$OUT" <<'EOF' 2>&1 | tee -a "$LOG"
import json, sys
from pathlib import Path
out = Path(sys.argv[1])
for n in ("1e6", "1e7"):
    try:
        gpu = json.loads((out / f"bench_cuda_{n}.json").read_text())
        cpu = json.loads((out / f"bench_cpu_{n}.json").read_text())
        g, c = gpu["particle_steps_per_s"], cpu["particle_steps_per_s"]
        print(f"GPU/CPU particle-steps/s at {n}: {g:.4g} / {c:.4g} = {g / c:.1f}x (CPU threads: {cpu['threads']})")
    except (OSError, ValueError, KeyError) as exc:
        print(f"no ratio at {n}: {exc}")
EOF
fi

if [ "$PART" = all ] || [ "$PART" = validate ]; then
    rm -rf "$RUNS/martin-moyce-cuda" "$RUNS/hydrostatic-cuda"
    step martin_moyce_cuda erosim --quiet validate martin-moyce --device cuda --json --out "$RUNS/martin-moyce-cuda"
    step hydrostatic_cuda erosim --quiet validate hydrostatic --device cuda --json --out "$RUNS/hydrostatic-cuda"
fi
