#!/usr/bin/env bash
# A setting against the default on the same worlds: Tables 1+2, both runs cold, in one call.
#
#   experiments/paired_setting.sh NAME TRIALS KEY=VALUE...     results in ${OUT:-runs}/paired_NAME/
#
# Runs `graspjax run --table 1,2 --trials TRIALS --seed 0` twice, each with an empty
# compilation cache of its own: `base` (the defaults), then NAME (--set KEY=VALUE ...). The same
# seed gives both the same layouts and keys, so attempts pair by (setup, object, trial,
# attempt). Prints experiments/paired_rows.py's comparison (McNemar's z per cell and setup) and
# each run's total, trace, compile and chunk seconds. A speed setting is kept only when no
# rate moves beyond chance.
set -uo pipefail
name=${1:?usage: paired_setting.sh NAME TRIALS KEY=VALUE...}
trials=${2:?usage: paired_setting.sh NAME TRIALS KEY=VALUE...}
shift 2
sets=()
for kv in "$@"; do sets+=(--set "$kv"); done
out=${OUT:-runs}/paired_$name
mkdir -p "$out"
out=$(cd "$out" && pwd)
run() {  # NAME [--set KEY=VALUE ...]
  local cache
  cache=$(mktemp -d)
  local start
  start=$(date +%s.%N)
  GRASPJAX_CACHE=$cache python3 -m graspjax.cli run --table 1,2 --trials "$trials" --seed 0 \
    --quiet --out "$out/$1" "${@:2}" > "$out/$1.log" 2>&1
  echo "$1 rc=$? total $(python3 -c "print(round($(date +%s.%N) - $start, 1))") s" \
    >> "$out/totals.txt"
  rm -rf "$cache" "$out/$1/attempts.parquet" "$out/$1"/*.png
}
run base
run "$name" "${sets[@]}"
python3 experiments/paired_rows.py "$out/base/attempts.csv" "$out/$name/attempts.csv" \
  > "$out/paired.txt" 2>&1
cat "$out/paired.txt" "$out/totals.txt"
for v in base "$name"; do
  python3 - "$out/$v/timings.csv" "$v" <<'PY'
import sys
import pandas as pd
t = pd.read_csv(sys.argv[1])
print(f"{sys.argv[2]}: trace {t['trace_s'].sum():.1f} s, compile {t['compile_s'].sum():.1f} s, "
      f"chunks {t['wall_s'].sum():.1f} s")
PY
done
