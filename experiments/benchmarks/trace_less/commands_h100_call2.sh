#!/bin/bash
# Stop 43 call 2, one H100: cold passes, before (0c39746) first, then after (working tree = ae129e3), then before again; Tables 1+2 at 1,000 trials.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs
B=$PWD/variants/before   # git archive 0c39746 graspjax | tar -x -C variants/before
PACKAGE=$B experiments/warm_start.sh before 1000 cold | tail -1
experiments/warm_start.sh after 1000 cold | tail -1
PACKAGE=$B experiments/warm_start.sh before 1000 cold | tail -1
python3 experiments/paired_rows.py runs/warm_start_before/cold1/attempts.csv runs/warm_start_after/cold1/attempts.csv > $keep/paired_h100_1000_call2.txt 2>&1
tail -1 $keep/paired_h100_1000_call2.txt
for n in after before; do cat runs/warm_start_$n/total_s.txt > $keep/${n}_total_s_call2.txt
  for r in cold1 cold2; do cp runs/warm_start_$n/$r/timings.csv $keep/${n}_${r}_timings_call2.csv 2>/dev/null; done; done
ls $keep
