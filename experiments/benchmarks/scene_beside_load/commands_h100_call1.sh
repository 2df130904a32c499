#!/bin/bash
# Stop 44, one H100: the scene built beside the first program's load. before = 05d91f6
# (variants/before), after = the working tree. One compilation cache for both (their XLA
# programs are the same; their stores of exported programs have other keys): before cold,
# after warm (traces its store, loads XLA's programs), then warm passes interleaved.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs GRASPJAX_CACHE=/tmp/gjc
B=$PWD/variants/before
PACKAGE=$B experiments/warm_start.sh before 1000 cold | tail -1
experiments/warm_start.sh after 1000 warm | tail -1
for i in 1 2; do
  PACKAGE=$B experiments/warm_start.sh before 1000 warm | tail -1
  experiments/warm_start.sh after 1000 warm | tail -1
done
python3 experiments/paired_rows.py runs/warm_start_before/cold1/attempts.csv runs/warm_start_after/warm1/attempts.csv > $keep/paired_h100_1000.txt 2>&1
tail -1 $keep/paired_h100_1000.txt
for n in after before; do cat runs/warm_start_$n/total_s.txt > $keep/${n}_total_s.txt
  for r in cold1 warm1 warm2 warm3; do cp runs/warm_start_$n/$r/timings.csv $keep/${n}_${r}_timings.csv 2>/dev/null; done; done
for n in before after; do for r in runs/warm_start_$n/warm*/timings.csv; do echo "$n $r first chunk at $(sed -n 2p $r | cut -d, -f10)"; done; done
ls $keep
