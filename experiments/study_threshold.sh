#!/usr/bin/env bash
# Parameter study: the paper's 0.3 plane distance threshold (Eq. 3).
# Table 1 protocol (objects a-f, Setups 1-3), TRIALS rounds per grid point, every
# point with its own seed (seed + point index). Outputs: results/studies/threshold/.
#   experiments/study_threshold.sh            # TRIALS=50 by default (the committed results: TRIALS=100 on an H100, via experiments/gpu_reference.sh); OUT=... to redirect
set -euo pipefail
trials=${TRIALS:-50}
out=${OUT:-results/studies}/threshold
python3 -m graspjax.cli sweep --table 1 --trials "$trials" --seed 0 --quiet \
  --grid align.distance_threshold=0.05,0.1,0.2,0.3,0.5,0.75,1.0 --out "$out"
