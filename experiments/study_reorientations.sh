#!/usr/bin/env bash
# Parameter study: the re-alignment budget (paper: 1).
# Table 1 protocol (objects a-f, Setups 1-3), TRIALS rounds per grid point, every
# point with its own seed (seed + point index). Outputs: results/studies/reorientations/.
#   experiments/study_reorientations.sh            # TRIALS=50 by default (the committed results: TRIALS=100 on an H100, via experiments/gpu_reference.sh); OUT=... to redirect
set -euo pipefail
trials=${TRIALS:-50}
out=${OUT:-results/studies}/reorientations
python3 -m graspjax.cli sweep --table 1 --trials "$trials" --seed 0 --quiet \
  --grid procedure.max_reorientations=0,1,2,3 --out "$out"
