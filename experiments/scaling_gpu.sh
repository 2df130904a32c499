#!/usr/bin/env bash
# Issue 53 on a 4-GPU host: Tables 1+2 (paper preset, seed 0) on 1, 2 and 4 GPUs of one process,
# and on 2 processes of one GPU each joined by jax.distributed; whole commands timed (`time`), rows
# compared across all of them (every column but run_id and chunk). MuJoCo goes along as wheels
# (../shared/gpu/README.md). Runs write to /tmp/scaling; $OUT gets each run's config.json,
# timings.csv and table1.md (runs.tar.gz), the wall times and the comparison (kept in
# /tmp/scaling across calls on one warm machine, copied to $OUT by each). Steps (in this order):
#   a  1 GPU at 1,000 trials cold, then warm; 4 GPUs at 1,000 (compiles devices 1-3), then at
#      4,000 trials warm
#   a2 2 GPUs at 4,000 trials warm
#   b  1 GPU at 4,000 trials warm; 2 processes x 1 GPU at 4,000 through jax.distributed;
#      the rows of every run compared (4,000-trial runs together, 1,000-trial runs together)
#   c  2 processes x 1 GPU again (their own topology's programs now cached: warm); the rows
#      compared
#   d  (stop 63) 4 GPUs at 4,000 trials cold (their first run), then warm three times: under
#      experiments/timeline.py (calls, with RunFolder.finish and the report profiled), with
#      CUDA_MODULE_LOADING=EAGER (kernels loaded with their program, not at first launch), and
#      as is
#   e  (stop 63, a 2-GPU host) 2 GPUs at 1,000 trials (their first run), then at 4,000 warm
#      twice, under experiments/timeline.py as in d, and as is
#   f  1 GPU at 1,000 trials cold, then at 4,000 warm; the rows compared
#   g  2 GPUs at 1,000 trials (their first run, or not if e ran on the machine), then at 4,000
#      warm, as fixed_2gpu_*; the rows compared
#   h  (stop 63, a 4-GPU host) 4 GPUs at 1,000 trials (their first run), then at 4,000 warm;
#      1 GPU at 1,000 trials (compiled for one device), then at 4,000 warm; the rows compared
#   i  (stop 64, a 4-GPU host) 4 GPUs at 1,000 trials (their first run; the step ends there if
#      it fails), then at 4,000 warm, with JAX's preallocation and without
#      (XLA_PYTHON_CLIENT_PREALLOCATE=true / false; the command's default is false since
#      54a6d9a, and at stop 64 (b57fc0a) the runs with preallocation set nothing), twice in turn,
#      then under experiments/timeline.py (without the interpreter's teardown, like the command)
#   j  (stop 64, the same host after i) 1 GPU at 1,000 trials (compiled for one device), then
#      at 4,000 warm with and without preallocation; the rows compared
#   k  (stop 64, a 4-GPU host) 4 GPUs at 1,000 trials (their first run; the step ends there if
#      it fails), then at 4,000 warm twice. At stop 64 (60f7fbf) each warm run was paired with
#      one under experiments/order_variant.py, g-l's Setup 1 chunks before a-f's: the order
#      `heaviest_first` gives since 91168a3
#   l  (stop 64, the same host after k) 1 GPU at 1,000 trials (compiled for one device), then
#      at 4,000 warm; the rows compared; then experiments/gil_held.py on the 4 GPUs
#   one, two: the same on a 2-GPU host: 1 GPU at 1,000 trials cold and warm and at 4,000 warm;
#      then 2 GPUs at 1,000 (their first run: XLA's cache keys hold the visible devices) and at
#      4,000 warm, and 2 processes cold (then c: warm)
# Every run's rows get a digest (attempts.csv but run_id and chunk) in $OUT/digests.txt.
# Each run's "seconds:" line (where its time went: before, start, chunks, rows, report) goes to
# $OUT/phases.txt; the last table gives every run's speed-up over the 1-GPU run of its size.
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
runs=/tmp/scaling
mkdir -p "$runs"
timed() {  # timed NAME GPUS TRIALS [EXTRA...]: one run on the GPUs listed, wall time kept;
  # RUN_ENV: assignments for its environment (e.g. CUDA_MODULE_LOADING=EAGER); with TIMELINE
  # set, it runs under experiments/timeline.py (its lines, and the profiles TIMELINE_PROFILE
  # names, in $OUT/timeline_NAME.txt)
  local name=$1 gpus=$2 trials=$3 start
  shift 3
  start=$(date +%s.%N)
  local runner=(-m graspjax.cli)
  [ -n "${TIMELINE:-}" ] && runner=(experiments/timeline.py)
  env ${RUN_ENV:-} START="$start" CUDA_VISIBLE_DEVICES=$gpus python3 "${runner[@]}" run \
    --table 1,2 --trials "$trials" \
    --seed 0 --quiet --overwrite --out "$runs/$name" "$@" > "$runs/$name.log" 2>&1
  local code=$?
  echo "$name,${gpus//,/+},$trials,$(since "$start"),$code" >> "$runs/walls.csv"
  echo "== $name (GPUs $gpus, $trials trials): exit $code, $(tail -n 1 "$runs/walls.csv")"
  echo "$name: $(grep '^seconds:' "$runs/$name.log")" >> "$runs/phases.txt"
  [ -n "${TIMELINE:-}" ] && grep -v '^[|#]' "$runs/$name.log" > "$out/timeline_$name.txt"
  digest "$name"
  keep "$name"
  return $code
}
since() {  # since START: seconds from START (date +%s.%N) to now, to 0.1 s
  python3 -c "import sys; print(round(float(sys.argv[1]) - float(sys.argv[2]), 1))" \
    "$(date +%s.%N)" "$1"
}
stop_after() {  # stop_after NAME: the failed run's last lines, then the script ends
  tail -n 5 "$runs/$1.log"
  exit 1
}
timelined() {  # timelined NAME GPUS TRIALS: `timed` under experiments/timeline.py, with the
  # device calls timed and the rows phase and the report profiled
  TIMELINE=1 TIMELINE_CALLS=jax:block_until_ready,jax:device_put \
    TIMELINE_PROFILE=graspjax.outputs:RunFolder.finish,graspjax.report:write_report timed "$@"
}
digest() {  # digest NAME: a digest of its attempts.csv but run_id and chunk, to compare runs of
  # other calls and hosts (digests.txt)
  python3 - "$runs/$1/attempts.csv" "$1" >> "$runs/digests.txt" <<'EOF'
import hashlib
import sys

import pandas as pd

rows = pd.read_csv(sys.argv[1]).drop(columns=["run_id", "chunk"])
text = rows.to_csv(index=False).encode()
print(f"{sys.argv[2]}: {len(rows)} rows, sha256 {hashlib.sha256(text).hexdigest()[:16]}")
EOF
  cp "$runs/digests.txt" "$out/"
}
keep() {  # keep NAME: its config.json, timings.csv and table1.md into $OUT/runs.tar.gz
  mkdir -p "$runs/kept/$1"
  cp "$runs/$1"/{config.json,timings.csv,table1.md} "$runs/kept/$1/" 2>/dev/null
  tar -C "$runs" -czf "$out/runs.tar.gz" kept
}
distributed() {  # distributed NAME TRIALS: 2 processes of 1 GPU each, one coordinator
  local name=$1 trials=$2 start
  start=$(date +%s.%N)
  for i in 0 1; do
    CUDA_VISIBLE_DEVICES=$i python3 -m graspjax.cli run --table 1,2 --trials "$trials" \
      --seed 0 --quiet --overwrite --out "$runs/$name" --distributed "localhost:29500,2,$i" \
      > "$runs/$name.$i.log" 2>&1 &
  done
  wait
  echo "$name,0+1,$trials,$(since "$start"),0" >> "$runs/walls.csv"
  echo "== $name (2 processes): $(tail -n 1 "$runs/walls.csv"); $(tail -n 1 "$runs/$name.1.log")"
  echo "$name: $(grep '^seconds:' "$runs/$name.0.log")" >> "$runs/phases.txt"
  digest "$name"
  keep "$name"
}
compare() {  # the rows of every run compared: 4,000-trial runs together, 1,000-trial ones too
  python3 - "$runs" > "$out/comparison.txt" <<'EOF'
import sys
from pathlib import Path

import pandas as pd

runs = Path(sys.argv[1])
for trials in (1000, 4000):
    names = sorted(p.name for p in runs.iterdir() if p.is_dir() and p.name.endswith(f"_{trials}"))
    frames = {n: pd.read_csv(runs / n / "attempts.csv").drop(columns=["run_id", "chunk"])
              for n in names if (runs / n / "attempts.csv").is_file()}
    if not frames:
        continue
    first, reference = next(iter(frames.items()))
    print(f"{trials} trials per cell: reference {first}, {len(reference)} rows, "
          f"success {reference['success'].mean():.4f}")
    for name, frame in frames.items():
        same = frame.equals(reference)
        differing = (frame != reference) & ~(frame.isna() & reference.isna()) if not same \
            and frame.shape == reference.shape else None
        rows = int(differing.any(axis=1).sum()) if differing is not None else "shape differs"
        print(f"  {name}: identical={same}, rows differing={0 if same else rows}, "
              f"success {frame['success'].mean():.4f}")
EOF
  cat "$out/comparison.txt"
}
[ -f "$runs/walls.csv" ] || echo "run,gpus,trials,wall_s,exit" > "$runs/walls.csv"
for step in "$@"; do
  case "$step" in
    a) timed cold_1gpu_1000 0 1000
       timed warm_1gpu_1000 0 1000
       timed warm_4gpu_1000 0,1,2,3 1000
       timed warm_4gpu_4000 0,1,2,3 4000
       compare ;;
    a2) timed warm_2gpu_4000 0,1 4000 ;;
    b) timed warm_1gpu_4000 0 4000
       distributed two_processes_4000 4000
       compare ;;
    c) distributed two_processes_warm_4000 4000
       compare ;;
    d) timed cold_4gpu_4000 0,1,2,3 4000
       timelined warm_4gpu_timeline_4000 0,1,2,3 4000
       RUN_ENV=CUDA_MODULE_LOADING=EAGER timed warm_4gpu_eager_4000 0,1,2,3 4000
       timed warm_4gpu_4000 0,1,2,3 4000
       compare ;;
    e) timed first_2gpu_1000 0,1 1000
       timelined warm_2gpu_timeline_4000 0,1 4000
       timed warm_2gpu_4000 0,1 4000
       compare ;;
    f) timed cold_1gpu_1000 0 1000
       timed warm_1gpu_4000 0 4000
       compare ;;
    g) timed fixed_2gpu_1000 0,1 1000  # names of their own: e's runs on the machine stay
       timed fixed_2gpu_4000 0,1 4000
       compare ;;
    h) timed first_4gpu_1000 0,1,2,3 1000
       timed warm_4gpu_4000 0,1,2,3 4000
       timed cold_1gpu_1000 0 1000
       timed warm_1gpu_4000 0 4000
       compare ;;
    i) timed first_4gpu_1000 0,1,2,3 1000 || stop_after first_4gpu_1000
       for again in "" again_; do
         RUN_ENV=XLA_PYTHON_CLIENT_PREALLOCATE=true timed "${again}warm_4gpu_4000" 0,1,2,3 4000
         RUN_ENV=XLA_PYTHON_CLIENT_PREALLOCATE=false \
           timed "${again}warm_4gpu_noprealloc_4000" 0,1,2,3 4000
       done
       TIMELINE_EXIT=1 timelined warm_4gpu_timeline_4000 0,1,2,3 4000
       compare ;;
    j) timed cold_1gpu_1000 0 1000
       RUN_ENV=XLA_PYTHON_CLIENT_PREALLOCATE=true timed warm_1gpu_4000 0 4000
       RUN_ENV=XLA_PYTHON_CLIENT_PREALLOCATE=false timed warm_1gpu_noprealloc_4000 0 4000
       compare ;;
    k) timed first_4gpu_1000 0,1,2,3 1000 || stop_after first_4gpu_1000
       timed warm_4gpu_4000 0,1,2,3 4000
       timed again_warm_4gpu_4000 0,1,2,3 4000
       compare ;;
    l) timed cold_1gpu_1000 0 1000
       timed warm_1gpu_4000 0 4000
       compare
       CUDA_VISIBLE_DEVICES=0,1,2,3 python3 experiments/gil_held.py | tee "$out/gil_held.txt" ;;
    one) timed cold_1gpu_1000 0 1000  # a 2-GPU host: 1 GPU, then 2 (own compiles), processes
         timed warm_1gpu_1000 0 1000
         timed warm_1gpu_4000 0 4000 ;;
    two) timed first_2gpu_1000 0,1 1000
         timed warm_2gpu_4000 0,1 4000
         distributed two_processes_4000 4000 ;;
  esac
done
python3 - "$runs/walls.csv" <<'EOF'
import sys

import pandas as pd

walls = pd.read_csv(sys.argv[1])
base = {t: walls[(walls.run.str.startswith("warm_1gpu")) & (walls.trials == t)].wall_s.min()
        for t in walls.trials.unique()}
walls["speedup_over_1gpu"] = [round(base[t] / w, 2) for t, w in zip(walls.trials, walls.wall_s)]
print(walls.to_string(index=False))
EOF
cp "$runs/walls.csv" "$runs/phases.txt" "$out/" 2>/dev/null
cat "$runs/phases.txt"
