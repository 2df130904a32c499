#!/usr/bin/env bash
# Start-up cost of a run: Tables 1+2, the whole command timed, pass by pass.
#
#   experiments/warm_start.sh NAME TRIALS PASS...     results in ${OUT:-runs}/warm_start_NAME/
#
# PASS is `cold` (empties the caches first) or `warm` (a new process; the caches as the last
# pass left them). The caches live in $GRASPJAX_CACHE (default: a folder of its own under
# /tmp, kept between calls so that a later call can time a warm pass). With PACKAGE=DIR the
# graspjax package in DIR is timed instead (an older checkout, for a before/after on one
# machine). Prints one line per pass: total seconds, the summed trace_s / compile_s / wall_s of
# timings.csv (an older package has no trace_s: its tracing is inside compile_s), whether the
# programs were traced (by the run or its trace workers) or loaded, and whether the rows equal the first pass's. ARGS adds options
# to every pass's `graspjax run` (for example ARGS="--batch 6000").
set -euo pipefail
name=${1:?usage: warm_start.sh NAME TRIALS PASS...}
trials=${2:?usage: warm_start.sh NAME TRIALS PASS...}
shift 2
out=${OUT:-runs}/warm_start_$name
export GRASPJAX_CACHE=${GRASPJAX_CACHE:-/tmp/graspjax_warm_start_$name}
# `python3 -m` puts the working folder first on sys.path: run from the package's folder.
package=${PACKAGE:-$PWD}
mkdir -p "$out"
out=$(cd "$out" && pwd)
for pass in "$@"; do
  if [[ $pass == cold ]]; then rm -rf "$GRASPJAX_CACHE"; fi
  mkdir -p "$GRASPJAX_CACHE"
  n=$(find "$out" -mindepth 1 -maxdepth 1 -type d -name "$pass*" | wc -l)
  run=$pass$((n + 1))
  start=$(date +%s.%N)
  (cd "$package" && python3 -m graspjax.cli run --table 1,2 --trials "$trials" --seed 0 \
    --quiet ${ARGS:-} --out "$out/$run" > "$out/$run.log" 2>&1)
  echo "$run $start $(date +%s.%N)" >> "$out/total_s.txt"
  rm -f "$out/$run/attempts.parquet" "$out/$run"/*.png
done
python3 - "$out" "$name" <<'PY'
import sys, pathlib
import pandas as pd
out, name = pathlib.Path(sys.argv[1]), sys.argv[2]
runs = [line.split() for line in (out / "total_s.txt").read_text().splitlines()]
volatile = ["run_id", "chunk"]
first = pd.read_csv(out / runs[0][0] / "attempts.csv").drop(columns=volatile)
for run, begin, end in runs:
    t = pd.read_csv(out / run / "timings.csv")
    rows = pd.read_csv(out / run / "attempts.csv").drop(columns=volatile)
    programs = ",".join(t["program"].unique()) if "program" in t else "traced"
    trace = t["trace_s"].sum() if "trace_s" in t else float("nan")
    print(f"{name} {run}: total {float(end) - float(begin):.1f} s; trace {trace:.1f} s, compile "
          f"{t['compile_s'].sum():.1f} s, chunks {t['wall_s'].sum():.1f} s; programs {programs};"
          f" rows identical to {runs[0][0]}: {rows.equals(first)}")
PY
