#!/usr/bin/env bash
# Physics and rendering benchmark: world-steps/s of the a-f scene (Setups 1 and 3) and the
# g-l scene (Setup 1), depth images/s; compile time apart.
#   experiments/bench_physics.sh cpu     # the 2-core development machine (small batches)
#   experiments/bench_physics.sh gpu     # on the GPU machine, package on PYTHONPATH
set -euo pipefail
out=${OUT:-results/benchmarks}
run() { python3 -m graspjax.cli bench physics "$@"; }
case "${1:-cpu}" in
  cpu)
    run --objects abcdef --setup 3 --batch 16 --seconds 0.5 --out "$out/physics_cpu_abcdef_setup3.json"
    run --objects abcdef --setup 1 --batch 16 --seconds 0.5 --out "$out/physics_cpu_abcdef_setup1.json"
    run --objects ghijkl --setup 1 --batch 16 --seconds 0.5 --out "$out/physics_cpu_ghijkl_setup1.json" ;;
  gpu)
    for b in 4096 8192; do
      run --objects abcdef --setup 3 --batch "$b" --out "$out/physics_gpu_abcdef_setup3_$b.json"
    done
    run --objects abcdef --setup 1 --batch 4096 --out "$out/physics_gpu_abcdef_setup1_4096.json"
    run --objects ghijkl --setup 1 --batch 4096 --out "$out/physics_gpu_ghijkl_setup1_4096.json" ;;
  *) echo "usage: $0 cpu|gpu" >&2; exit 2 ;;
esac
