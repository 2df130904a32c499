#!/usr/bin/env bash
# Stop 38, call 2: after (+ the heaviest program traced by the run itself) cold, warm; before
# (HEAD f046e1f) cold, warm; one H100, one call.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi -L; nproc; lscpu | grep "Model name"
mkdir -p before && git archive HEAD graspjax | tar -x -C before
res=/tmp/ws
mkdir -p $res
OUT=$res GRASPJAX_CACHE=/tmp/c_after experiments/warm_start.sh after 1000 cold warm > $OUT/after.txt 2>&1
OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 cold warm > $OUT/before.txt 2>&1
python3 experiments/paired_rows.py $res/warm_start_before/cold1/attempts.csv $res/warm_start_after/cold1/attempts.csv > $OUT/paired.txt 2>&1
gzip -c $res/warm_start_after/cold1/attempts.csv > $OUT/after_cold_attempts.csv.gz
for n in after before; do sed "s/^/$n /" $res/warm_start_$n/total_s.txt; done > $OUT/total_s.txt
for r in after/cold1 after/warm1 before/cold1 before/warm1; do echo "== $r"; cat $res/warm_start_$r/timings.csv; done > $OUT/timings_all.txt
for f in after before; do tail -n 2 $OUT/$f.txt; done
cut -d, -f1,3,4,7-11 $OUT/timings_all.txt
tail -4 $OUT/paired.txt
