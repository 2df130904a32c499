#!/usr/bin/env bash
# Session 40, call 3 (after's warm passes run under variants/timeline.py): HEAD (0031f20) against the working tree (lowering with one source line, the next chunk plays beside the rows, devices start beside the imports), Tables 1+2 at 1,000 trials, cold then warm, one H100; then the tree's warm pass under the timeline with and without os._exit.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
nvidia-smi -L; git log --oneline -1; git status --short | grep -v "^??" | head
mkdir -p before && git archive HEAD graspjax | tar -x -C before
res=/tmp/ws; mkdir -p $res
OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 cold > $res/before_cold.txt 2>&1
OUT=$res GRASPJAX_CACHE=/tmp/c_after experiments/warm_start.sh after 1000 cold > $res/after_cold.txt 2>&1
OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 warm > $res/before.txt 2>&1
for x in "" 1; do
  START=$(date +%s.%N); export START
  GRASPJAX_CACHE=/tmp/c_after TL_EXIT=$x python3 variants/timeline.py run --table 1,2 --trials 1000 --seed 0 --quiet --out /tmp/r/tl$x > $OUT/tl_exit$x.log 2>&1
  echo "tl_exit$x $START $(date +%s.%N)" >> $OUT/tl_total.txt
done
for n in before after; do
  for r in cold1 warm1; do echo "== $n $r"; cat $res/warm_start_$n/$r/timings.csv 2>/dev/null; done
done > $OUT/timings.txt
for x in "" 1; do echo "== after tl_exit$x"; cat /tmp/r/tl$x/timings.csv; done >> $OUT/timings.txt
python3 - $res <<'PY' > $OUT/summary.txt
import sys, os, pandas as pd
res = sys.argv[1]
v = ["run_id", "chunk"]
a = pd.read_csv(f"{res}/warm_start_before/cold1/attempts.csv").drop(columns=v)
b = pd.read_csv(f"{res}/warm_start_after/cold1/attempts.csv").drop(columns=v)
print("after rows identical to before:", a.equals(b), len(a), len(b))
for x in ["", "1"]:
    c = pd.read_csv(f"/tmp/r/tl{x}/attempts.csv").drop(columns=v)
    print(f"after warm (tl_exit{x}) rows identical to after cold:", b.equals(c))
for n in ["before", "after"]:
    for line in open(f"{res}/warm_start_{n}/total_s.txt"):
        r, s, e = line.split(); print(n, r, round(float(e) - float(s), 1), "s")
for line in open(os.environ["OUT"] + "/tl_total.txt"):
    r, s, e = line.split(); print(r, round(float(e) - float(s), 1), "s")
PY
for n in before_cold after_cold before; do echo "== $n"; cat $res/$n.txt; done > $OUT/warm_start.txt
cat $OUT/summary.txt
grep -v '^$' $OUT/warm_start.txt | tail -n 12
cut -d, -f1,3,7-12 $OUT/timings.txt
for x in "" 1; do echo "== tl_exit$x"; grep "TL_LAST\|exit\|Program.play\|write_report\|finish\|Program.compile\|backends" $OUT/tl_exit$x.log | head -20; done
