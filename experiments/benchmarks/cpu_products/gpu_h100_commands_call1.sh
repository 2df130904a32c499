#!/usr/bin/env bash
# Stop 39, call 1: HEAD (fcfbbc9) against this tree at --batch 8192, Tables 1+2 at 1,000 trials, cold then warm; one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
nvidia-smi -L; git log --oneline -1; python3 -c "import jax, jaxlib; print(jax.__version__, jaxlib.__version__)"
XLA_FLAGS=--xla_cpu_experimental_ynn_fusion_type= python3 -c "import jax; jax.numpy.zeros(1).block_until_ready(); print('ynn flag accepted on', jax.default_backend())" 2>&1 | tail -1
mkdir before && git archive HEAD graspjax | tar -x -C before
res=/tmp/ws; mkdir -p $res
OUT=$res GRASPJAX_CACHE=/tmp/c_before PACKAGE=$PWD/before experiments/warm_start.sh before 1000 cold warm > $OUT/before.txt 2>&1
OUT=$res GRASPJAX_CACHE=/tmp/c_after ARGS="--batch 8192" experiments/warm_start.sh after8192 1000 cold warm > $OUT/after8192.txt 2>&1
for n in before after8192; do
  gzip -c $res/warm_start_$n/cold1/attempts.csv > $OUT/${n}_cold_attempts.csv.gz
  for r in cold1 warm1; do echo "== $r"; cat $res/warm_start_$n/$r/timings.csv; done > $OUT/timings_$n.txt
  cp $res/warm_start_$n/total_s.txt $OUT/total_s_$n.txt
done
python3 experiments/paired_rows.py $res/warm_start_before/cold1/attempts.csv $res/warm_start_after8192/cold1/attempts.csv > $OUT/paired_before_after8192.txt 2>&1
grep -i "error\|memory" $res/warm_start_after8192/cold1.log | head -5
tail -n 4 $OUT/paired_before_after8192.txt
for n in before after8192; do tail -n 2 $OUT/$n.txt; cut -d, -f1,3,4,7-12 $OUT/timings_$n.txt; done
