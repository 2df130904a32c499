#!/usr/bin/env bash
# The paper's protocol, both presets: Table 1 (objects a-f in Setups 1-3) and Table 2 (objects g-l
# in Setup 1), with the paper's numbers beside ours.
#   experiments/paper_tables.sh cpu    # 10 trials per cell (as the paper) -> results/{paper,realistic}_cpu_10
#   experiments/paper_tables.sh gpu    # 1000 trials per cell -> results/{paper,realistic}_gpu_1000
set -euo pipefail
case "${1:-cpu}" in
  cpu) trials=10; suffix=cpu_10 ;;
  gpu) trials=1000; suffix=gpu_1000 ;;
  *) echo "usage: $0 cpu|gpu" >&2; exit 2 ;;
esac
for preset in paper realistic; do
  python3 -m graspjax.cli run --table 1,2 --trials "$trials" --seed 0 --preset "$preset" --quiet \
    --overwrite --out "${OUT:-results}/${preset}_$suffix"
done
