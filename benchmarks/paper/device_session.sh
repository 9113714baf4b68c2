#!/bin/bash
# One lease of a CUDA machine (16 cores, one GPU, minutes of device time), spent on what a 2-core CPU cannot do.
# Everything runs at once, each part under its own time limit, so that whatever finishes comes back:
#   - benchmarks/speed/bench_gpu.py: single fit, closed loop, profile and stacked sweep on cuda beside the cpu;
#   - Table 1's paper protocol (20,000 iterations) for reaction-diffusion on the GPU (erm, fsam's three rhos),
#     the task whose paper size needs hundreds of CPU hours;
#   - Table 1's paper protocol for the pendulum on the machine's CPU cores (erm, fsam, p-reg, science-only);
#   - per-iteration timing at paper size of the two image tasks on the GPU.
# The GPU is shared by the concurrent runs: their seconds are those of a shared GPU, not of one run alone.
#
#   OUT=/some/dir LIMIT=500 bash benchmarks/paper/device_session.sh
set -u
OUT=${OUT:-/tmp/device_session}
LIMIT=${LIMIT:-500}
WORK=$(mktemp -d)
mkdir -p "$OUT"
export PYTHONPATH=$PWD PYTHONUNBUFFERED=1 OMP_NUM_THREADS=1
{ nvidia-smi; nproc; python3 -c "import torch, sklearn, numpy; print(torch.__version__, sklearn.__version__,
numpy.__version__, torch.cuda.get_device_name(0))"; } > "$WORK/environment.txt" 2>&1
timeout "$LIMIT" python3 benchmarks/speed/bench_gpu.py --out "$WORK" > "$WORK/gpu.log" 2>&1 &
timeout "$LIMIT" python3 benchmarks/paper/table1.py --budget paper --device cuda --tasks reaction_diffusion \
    --methods erm fsam --seeds 0 --jobs 4 > "$WORK/table1_reaction_diffusion.log" 2>&1 &
timeout "$LIMIT" python3 benchmarks/paper/table1.py --budget paper --device cpu --tasks pendulum \
    --methods erm fsam p-reg science-only --seeds 0 --jobs 8 > "$WORK/table1_pendulum.log" 2>&1 &
timeout "$LIMIT" python3 benchmarks/paper/table1.py --timing --device cuda --tasks light_tunnel pendulum_images \
    > "$WORK/table1_timing.log" 2>&1 &
wait
nvidia-smi --query-gpu=name,memory.used,memory.total --format=csv >> "$WORK/environment.txt" 2>&1
cp benchmarks/results/runs/table1/*__paper__*.json "$WORK/" 2>/dev/null
[ benchmarks/results/table1_timing.md -nt "$WORK/environment.txt" ] && cp benchmarks/results/table1_timing.md "$WORK/table1_timing_cuda.md"
tar czf "$OUT/device_session.tgz" -C "$WORK" .
cp "$WORK/gpu.md" "$OUT/" 2>/dev/null
ls -la "$WORK"
tail -n 5 "$WORK"/*.log
