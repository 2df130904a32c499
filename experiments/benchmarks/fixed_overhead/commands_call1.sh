#!/usr/bin/env bash
# Session 40, call 1: where a warm run's time outside the chunks goes (timeline of named calls), HEAD, Tables 1+2 at 1,000 trials, one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
nvidia-smi -L; git log --oneline -1; nproc
export GRASPJAX_CACHE=/tmp/c
s=$(date +%s.%N); python3 -m graspjax.cli run --table 1,2 --trials 1000 --seed 0 --quiet --out /tmp/r/cold > $OUT/cold.log 2>&1; echo "cold $s $(date +%s.%N)" >> $OUT/total_s.txt
for i in 1 2; do
  START=$(date +%s.%N); export START
  python3 variants/timeline.py run --table 1,2 --trials 1000 --seed 0 --quiet --out /tmp/r/warm$i > $OUT/warm_tl$i.log 2>&1
  echo "warm_tl$i $START $(date +%s.%N)" >> $OUT/total_s.txt
done
python3 -X importtime -m graspjax.cli --help > /dev/null 2> $OUT/importtime_cli.txt
python3 -X importtime -c "import graspjax.experiment, graspjax.report" 2> $OUT/importtime_experiment.txt
for r in cold warm1 warm2; do echo "== $r"; cat /tmp/r/$r/timings.csv; done > $OUT/timings.txt
python3 - <<'PY'
import os
for line in open(os.environ["OUT"] + "/total_s.txt"):
    n, a, b = line.split(); print(n, round(float(b) - float(a), 1), "s")
PY
cut -d, -f1,3,7-11 $OUT/timings.txt
grep "^TL" $OUT/warm_tl1.log | awk '$4 > 0.3 || /exit|python/' | head -70
sort -t'|' -k2 -n -r $OUT/importtime_experiment.txt | head -25
