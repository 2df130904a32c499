#!/usr/bin/env bash
# The re-alignment diagnosis and the friction cone's cost on the GPU machine (one call each step;
# MuJoCo goes along as wheels, see ../shared/gpu/README.md). Every step writes into $OUT.
#   experiments/realign_gpu.sh paper      # Tables 1+2 at 300 trials, paper preset, paired sweep of
#                                         #   align.min_turn_deg = 0 (the paper read literally), 10
#   experiments/realign_gpu.sh realistic  # the same, realistic preset
#   experiments/realign_gpu.sh cone       # the bin scene's physics, elliptic vs pyramidal, batch 2000
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
gj() { python3 -m graspjax.cli "$@"; }
case "${1:-}" in
  paper|realistic)
    start=$SECONDS
    gj sweep --table 1,2 --trials 300 --seed 0 --preset "$1" --paired --quiet \
      --grid align.min_turn_deg=0,10 --out "$out/turn_$1" > "$out/turn_$1.log" 2>&1
    echo "== $1: exit $? after $((SECONDS - start)) s"; tail -n 3 "$out/turn_$1.log"
    tar -C "$out" -czf "$out/turn_$1.tar.gz" "turn_$1" && rm -rf "${out:?}/turn_$1" ;;
  cone)
    for cone in elliptic pyramidal; do
      gj bench physics --objects abcdef --setup 3 --batch 2000 --set sim.cone=$cone \
        --out "$out/physics_gpu_h100_bin_2000_$cone.json" | tail -n 4
    done ;;
  *) echo "usage: $0 paper|realistic|cone" >&2; exit 2 ;;
esac
