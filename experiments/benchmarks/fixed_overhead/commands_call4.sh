#!/usr/bin/env bash
# Session 40, call 4: 0031f20 (stop 39) against the working tree (this stop: one source line when lowering, the next chunk beside the rows, plan order on a warm start, devices and compiler started beside the imports, no interpreter teardown), README-style commands through warm_start.sh, Tables 1+2 at 1,000 trials, one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
nvidia-smi -L; git log --oneline -1
mkdir -p before && git archive 0031f20 graspjax | tar -x -C before
res=/tmp/ws; mkdir -p $res
b() { OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 "$@" 2>&1 | grep "^before $1" | tail -n 1 >> $OUT/summary.txt; }
a() { OUT=$res GRASPJAX_CACHE=/tmp/c_after experiments/warm_start.sh after 1000 "$@" 2>&1 | grep "^after $1" | tail -n 1 >> $OUT/summary.txt; }
b cold; a cold; b warm; a warm; a warm; b warm
for n in before after; do for r in cold1 warm1 warm2; do echo "== $n $r"; cat $res/warm_start_$n/$r/timings.csv 2>/dev/null; done; done > $OUT/timings.txt
cat $res/warm_start_before/total_s.txt $res/warm_start_after/total_s.txt > $OUT/total_s.txt
python3 - $res <<'PY' >> $OUT/summary.txt
import sys, pandas as pd
res = sys.argv[1]
v = ["run_id", "chunk"]
a = pd.read_csv(f"{res}/warm_start_before/cold1/attempts.csv").drop(columns=v)
b = pd.read_csv(f"{res}/warm_start_after/cold1/attempts.csv").drop(columns=v)
print("after rows identical to before:", a.equals(b), len(a), len(b))
PY
cat $OUT/summary.txt
cut -d, -f1,3,7-12 $OUT/timings.txt
