#!/usr/bin/env bash
# The GPU reference results, in a few long calls on the GPU machine (see ../shared/gpu/README.md:
# MuJoCo goes along as wheels; the package runs from the source tree on PYTHONPATH).
#   experiments/gpu_reference.sh bench     # perception, physics and end-to-end benchmarks
#   experiments/gpu_reference.sh tables    # Tables 1 and 2 at 1,000 trials per cell
#   experiments/gpu_reference.sh studies1  # window and threshold studies (100 trials per point)
#   experiments/gpu_reference.sh studies2  # re-orientation budget and resolution studies
#   experiments/gpu_reference.sh wall      # the wall-check ablation (300 trials per point)
# Every step writes into $OUT (a log per step; run folders and records packed into tarballs, since
# the machine returns at most 8 files) and prints a short summary last. The steps of one call
# share the persistent compilation cache.
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
gj() { python3 -m graspjax.cli "$@"; }
step() {  # step NAME COMMAND...: run, log to $out/NAME.log, show the tail and the time taken
  local name=$1 start=$SECONDS
  shift
  echo "== $name: $*"
  "$@" > "$out/$name.log" 2>&1
  local rc=$?
  tail -n 12 "$out/$name.log"
  echo "== $name: exit $rc after $((SECONDS - start)) s"
}
pack() {  # pack FOLDER: one tarball per run folder (the machine returns at most 8 files)
  tar -C "$(dirname "$1")" -czf "$out/$(basename "$1").tar.gz" "$(basename "$1")" && rm -rf "$1"
}
case "${1:-}" in
  bench)
    step perception gj bench perception --batch 4096 --repeats 10 --out "$out/perception_gpu_4096.json"
    step physics_abcdef_3 gj bench physics --objects abcdef --setup 3 --batch 8192 \
      --out "$out/physics_gpu_abcdef_setup3_8192.json"
    step physics_abcdef_1 gj bench physics --objects abcdef --setup 1 --batch 4096 \
      --out "$out/physics_gpu_abcdef_setup1_4096.json"
    step pipeline_1 gj bench pipeline --objects abcdef --setup 1 --trials 1000 \
      --out "$out/pipeline_gpu_abcdef_setup1.json"
    step pipeline_3 gj bench pipeline --objects abcdef --setup 3 --trials 1000 \
      --out "$out/pipeline_gpu_abcdef_setup3.json"
    grep -h -E "images/s|world-steps/s|attempts/s|time shares" "$out"/*.log
    mkdir -p "$out/bench_gpu" && mv "$out"/*.json "$out"/*.log "$out/bench_gpu/" && pack "$out/bench_gpu" ;;
  tables)
    step tables gj run --table 1,2 --trials 1000 --seed 0 --quiet --out "$out/paper_gpu_1000"
    cat "$out/paper_gpu_1000/timings.csv"
    pack "$out/paper_gpu_1000" ;;
  studies1)
    step window env TRIALS=100 OUT="$out" experiments/study_window.sh && pack "$out/window"
    step threshold env TRIALS=100 OUT="$out" experiments/study_threshold.sh && pack "$out/threshold" ;;
  studies2)
    step reorientations env TRIALS=100 OUT="$out" experiments/study_reorientations.sh && pack "$out/reorientations"
    step resolution env TRIALS=100 OUT="$out" experiments/study_resolution.sh && pack "$out/resolution" ;;
  wall)
    step wall env TRIALS=300 OUT="$out" experiments/study_wall.sh && pack "$out/wall" ;;
  *) echo "usage: $0 bench|tables|studies1|studies2|wall" >&2; exit 2 ;;
esac
