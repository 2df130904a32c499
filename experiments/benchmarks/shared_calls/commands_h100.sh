#!/bin/bash
# Stop 42 call 2, one H100: shared narrow-phase calls (working tree) against HEAD 9aa3f67 (before), Tables 1+2 at 1,000 trials.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs
B=$PWD/variants/before
experiments/warm_start.sh shared 1000 cold | tail -1
PACKAGE=$B experiments/warm_start.sh before 1000 cold | tail -1
experiments/warm_start.sh shared 1000 warm | tail -1
PACKAGE=$B experiments/warm_start.sh before 1000 warm | tail -1
experiments/warm_start.sh shared 1000 warm | tail -1
python3 experiments/paired_rows.py runs/warm_start_before/cold1/attempts.csv runs/warm_start_shared/cold1/attempts.csv > $keep/paired_h100_1000.txt 2>&1
tail -30 $keep/paired_h100_1000.txt
for n in shared before; do cat runs/warm_start_$n/total_s.txt > $keep/${n}_total_s.txt
  for r in cold1 warm1; do cp runs/warm_start_$n/$r/timings.csv $keep/${n}_${r}_timings.csv 2>/dev/null; done; done
cp runs/warm_start_shared/warm2/timings.csv $keep/shared_warm2_timings.csv
ls $keep
