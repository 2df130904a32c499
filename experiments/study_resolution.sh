#!/usr/bin/env bash
# Parameter study: the working resolution (paper: Kinect 640x480 downsampled).
# Table 1 protocol (objects a-f, Setups 1-3), TRIALS rounds per grid point, every
# point with its own seed (seed + point index). Outputs: results/studies/resolution/.
#   experiments/study_resolution.sh            # TRIALS=50 by default; OUT=... to redirect
set -euo pipefail
trials=${TRIALS:-50}
out=${OUT:-results/studies}/resolution
python3 -m graspjax.cli sweep --table 1 --trials "$trials" --seed 0 --quiet \
  --grid camera.width:camera.height=80:60,160:120,320:240 --out "$out"
