#!/bin/bash
# Stop 43 call 1, one H100: the working tree (e98c95f: the search traced once, start_round building only its setups' layouts) against 0c39746 (before), Tables 1+2 at 1,000 trials.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs
B=$PWD/variants/before   # git archive 0c39746 graspjax | tar -x -C variants/before
experiments/warm_start.sh after 1000 cold | tail -1
PACKAGE=$B experiments/warm_start.sh before 1000 cold | tail -1
experiments/warm_start.sh after 1000 warm | tail -1
PACKAGE=$B experiments/warm_start.sh before 1000 warm | tail -1
experiments/warm_start.sh after 1000 warm | tail -1
python3 experiments/paired_rows.py runs/warm_start_before/cold1/attempts.csv runs/warm_start_after/cold1/attempts.csv > $keep/paired_h100_1000.txt 2>&1
tail -5 $keep/paired_h100_1000.txt
for n in after before; do cat runs/warm_start_$n/total_s.txt > $keep/${n}_total_s.txt
  for r in cold1 warm1; do cp runs/warm_start_$n/$r/timings.csv $keep/${n}_${r}_timings.csv 2>/dev/null; done; done
ls $keep
