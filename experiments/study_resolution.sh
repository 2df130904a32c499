#!/usr/bin/env bash
# Parameter study: the working resolution (paper: Kinect 640x480 downsampled).
# Tables 1 and 2 protocol (a-f in Setups 1-3, g-l in Setup 1), TRIALS per grid point, every
# point with its own seed (seed + point index). Outputs: results/studies/resolution/.
#   experiments/study_resolution.sh            # TRIALS=50 by default (the committed results: TRIALS=100 on an H100, via experiments/gpu_reference.sh); OUT=... to redirect
set -euo pipefail
trials=${TRIALS:-50}
out=${OUT:-results/studies}/resolution
python3 -m graspjax.cli sweep --table 1,2 --trials "$trials" --seed 0 --quiet \
  --grid camera.width:camera.height=80:60,160:120,320:240 --out "$out"
