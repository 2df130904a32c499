#!/usr/bin/env bash
# Ablation of our one addition to the paper's detector: the wall check (detect.min_wall_angle_deg;
# 0 = the paper's checks alone, 45 = the default, the friction cone of the finger pads).
# Tables 1 and 2 protocol, TRIALS per grid point, every point with its own seed (seed + point
# index). Outputs: results/studies/wall/.
#   experiments/study_wall.sh            # TRIALS=50 by default (the committed results: TRIALS=300 on an H100, via experiments/gpu_reference.sh); OUT=... to redirect
set -euo pipefail
trials=${TRIALS:-50}
out=${OUT:-results/studies}/wall
python3 -m graspjax.cli sweep --table 1,2 --trials "$trials" --seed 0 --quiet \
  --grid detect.min_wall_angle_deg=0,45 --out "$out"
