#!/usr/bin/env bash
# Stop 38, call 4: the final code (after review) cold then warm, Tables 1+2 at 1,000 trials; one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi -L; git log --oneline -1
res=/tmp/ws; mkdir -p $res
OUT=$res GRASPJAX_CACHE=/tmp/c_final experiments/warm_start.sh final 1000 cold warm > $OUT/final.txt 2>&1
gzip -c $res/warm_start_final/cold1/attempts.csv > $OUT/final_cold_attempts.csv.gz
for r in cold1 warm1; do echo "== $r"; cat $res/warm_start_final/$r/timings.csv; done > $OUT/timings_final.txt
cp $res/warm_start_final/total_s.txt $OUT/total_s_final.txt
tail -n 2 $OUT/final.txt; cut -d, -f1,3,4,7-11 $OUT/timings_final.txt
grep -i "worker\|error" $res/warm_start_final/cold1.log | head -5
