#!/usr/bin/env bash
# Stop 38, call 1: Tables 1+2 at 1,000 trials, after (small-dot threshold + trace workers +
# ready-first chunks) cold then warm, then before (HEAD f046e1f) cold; one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi -L; nproc
mkdir -p before && git archive HEAD graspjax | tar -x -C before
res=$OUT
OUT=$res GRASPJAX_CACHE=/tmp/c_after experiments/warm_start.sh after 1000 cold warm > $res/after.txt 2>&1
OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 cold > $res/before.txt 2>&1
cmp -s $res/warm_start_before/cold1/attempts.csv $res/warm_start_after/cold1/attempts.csv && echo "attempts.csv identical bytes" || echo "attempts.csv differ"
python3 experiments/paired_rows.py $res/warm_start_before/cold1/attempts.csv $res/warm_start_after/cold1/attempts.csv > $res/paired.txt 2>&1
for f in after before; do tail -n 3 $res/$f.txt; done
for r in after/cold1 after/warm1 before/cold1; do echo "== $r"; cat $res/warm_start_$r/timings.csv | cut -d, -f1,3,4,7-11; done
grep -i "worker\|compiled the program" $res/warm_start_after/cold1.log | head
head -30 $res/paired.txt
