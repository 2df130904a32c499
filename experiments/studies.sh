#!/usr/bin/env bash
# Parameter studies under the realistic preset (Kinect sensor, wall check, execution error),
# Table 1 protocol (objects a-f, Setups 1-3), one factor at a time around the preset.
#   experiments/studies.sh NAME|traced|all   # NAME: window threshold reorientations friction noise
#                                            #       execution centring resolution; traced: all but
#                                            #       resolution (they share compiled programs)
# Every study has 600 rounds in all (100 per point for six points, 150 for four, ...): the same
# numbers of worlds, so every study of a traced value runs the same compiled programs.
# Outputs: ${OUT:-results/studies}/NAME/. Every grid point has its own seed (seed + point index).
set -euo pipefail
out=${OUT:-results/studies}
study() {  # study NAME POINTS --grid ...: Table 1 protocol
  local name=$1 points=$2
  shift 2
  python3 -m graspjax.cli sweep --table 1 --preset realistic --trials $((600 / points)) --seed 0 \
    --quiet --overwrite "$@" --out "$out/$name"
}
run() {
  case "$1" in
    window) study window 6 --grid align.window_px=5,10,15,20,25,30 ;;
    threshold) study threshold 6 --grid align.distance_threshold=0.05,0.1,0.2,0.3,0.5,1.0 ;;
    reorientations) study reorientations 4 --grid procedure.max_reorientations=0,1,2,3 ;;
    friction) study friction 5 --grid gripper.friction=0.3,0.5,0.7,0.9,1.0 ;;
    noise) study noise 4 --grid camera.noise_scale=0,0.5,1,2 ;;
    execution) study execution 4 \
      --grid procedure.tcp_error:procedure.tilt_error_deg=0:0,0.001:0.5,0.002:1,0.004:2 ;;
    centring) study centring 2 --grid procedure.centre=true,false ;;
    resolution)  # a static value: each resolution compiles its own programs, so Setup 1 alone
      python3 -m graspjax.cli sweep --setup 1 --objects abcdef --preset realistic --trials 200 \
        --seed 0 --quiet --overwrite --grid camera.width:camera.height=80:60,160:120,320:240 \
        --out "$out/resolution" ;;
    *) echo "unknown study $1" >&2; exit 2 ;;
  esac
}
traced=(window threshold reorientations friction noise execution centring)
case "${1:-}" in
  traced) for name in "${traced[@]}"; do run "$name"; done ;;
  all) for name in "${traced[@]}" resolution; do run "$name"; done ;;
  *) run "${1:?usage: $0 NAME|traced|all}" ;;
esac
