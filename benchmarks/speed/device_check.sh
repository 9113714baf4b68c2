#!/bin/bash
# A short second lease, after device_session.sh found the stacked engine and the light tunnel's model failing on
# cuda: the CUDA tests, bench_gpu.py at 100 iterations, and per-iteration timing at paper size on the GPU of the
# three tasks whose paper size a CPU cannot train (run side by side: the GPU is shared, timings are upper bounds).
#
#   OUT=/some/dir LIMIT=190 bash benchmarks/speed/device_check.sh
set -u
OUT=${OUT:-/tmp/device_check}
LIMIT=${LIMIT:-190}
WORK=$(mktemp -d)
mkdir -p "$OUT"
export PYTHONPATH=$PWD PYTHONUNBUFFERED=1 OMP_NUM_THREADS=1
timeout "$LIMIT" python3 -m pytest -q -p no:cacheprovider tests/test_cuda.py tests/test_device.py > "$WORK/pytest.log" 2>&1 &
timeout "$LIMIT" python3 benchmarks/speed/bench_gpu.py --iters 100 --out "$WORK" > "$WORK/gpu.log" 2>&1 &
timeout "$LIMIT" python3 benchmarks/paper/table1.py --timing --device cuda \
    --tasks reaction_diffusion light_tunnel pendulum_images > "$WORK/table1_timing.log" 2>&1 &
wait
tar czf "$OUT/device_check.tgz" -C "$WORK" .
cp "$WORK/gpu.md" "$OUT/" 2>/dev/null
tail -n 3 "$WORK/pytest.log"; grep "^|" "$WORK/table1_timing.log"
