#!/usr/bin/env bash
# Stop 39, call 3: HEAD as the device saw it (fcfbbc9; see README) against this tree (exported programs keep one source line per operation), Tables 1+2 at 1,000 trials, cold then warm; one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
nvidia-smi -L; git log --oneline -1
mkdir before && git archive HEAD graspjax | tar -x -C before
res=/tmp/ws; mkdir -p $res
OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 cold warm > $OUT/before.txt 2>&1
OUT=$res GRASPJAX_CACHE=/tmp/c_after experiments/warm_start.sh after 1000 cold warm > $OUT/after.txt 2>&1
for n in before after; do
  for r in cold1 warm1; do echo "== $r"; cat $res/warm_start_$n/$r/timings.csv; done > $OUT/timings_$n.txt
  cp $res/warm_start_$n/total_s.txt $OUT/total_s_$n.txt
done
python3 experiments/paired_rows.py $res/warm_start_before/cold1/attempts.csv $res/warm_start_after/cold1/attempts.csv > $OUT/paired.txt 2>&1
python3 - $res <<'PY'
import sys, pandas as pd
v = ["run_id", "chunk"]
a = pd.read_csv(f"{sys.argv[1]}/warm_start_before/cold1/attempts.csv").drop(columns=v)
b = pd.read_csv(f"{sys.argv[1]}/warm_start_after/cold1/attempts.csv").drop(columns=v)
print("after rows identical to before:", a.equals(b))
PY
tail -n 1 $OUT/paired.txt
for n in before after; do tail -n 2 $OUT/$n.txt; cut -d, -f1,3,4,7-12 $OUT/timings_$n.txt; done
