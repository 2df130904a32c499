#!/usr/bin/env bash
# Perception benchmark: images/s of detect_grasp + align_tool, compile time apart.
# CPU (the 2-core development machine):
#   experiments/bench_perception.sh cpu
# GPU (from the repository root on the GPU machine, package on PYTHONPATH):
#   experiments/bench_perception.sh gpu
set -euo pipefail
out=results/benchmarks
case "${1:-cpu}" in
  cpu) python3 -m graspjax.cli bench perception --batch 256 --repeats 5 --out "$out/perception_cpu.json" ;;
  gpu) for batch in 4096 16384; do
         python3 -m graspjax.cli bench perception --batch "$batch" --repeats 10 \
           --out "${OUT:-$out}/perception_gpu_$batch.json"
       done ;;
  *) echo "usage: $0 cpu|gpu" >&2; exit 2 ;;
esac
