#!/bin/bash
# Stop 47, one H100: the reference tables results/{paper,realistic}_gpu_1000 regenerated with the
# current code (experiments/paper_tables.sh gpu, empty compilation cache), each preset's rows
# paired with the files they replace (made at 55f8bea). Run from the repository root with the
# replaced attempts.csv.gz files copied to old_ref/{paper,realistic}_attempts.csv.gz and results/
# moved aside (the tree that travels is limited to 64 MiB).
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD GRASPJAX_CACHE=/tmp/gj
nvidia-smi --query-gpu=name --format=csv,noheader
start=$SECONDS
OUT=$OUT bash experiments/paper_tables.sh gpu > $OUT/tables.log 2>&1
echo "paper_tables.sh gpu: exit $? after $((SECONDS - start)) s" | tee $OUT/total_s.txt
for p in paper realistic; do
  gunzip -c old_ref/${p}_attempts.csv.gz > /tmp/old_$p.csv
  python3 experiments/paired_rows.py /tmp/old_$p.csv $OUT/${p}_gpu_1000/attempts.csv > $OUT/paired_${p}.txt 2>&1
  rm -f $OUT/${p}_gpu_1000/attempts.parquet
done
tar -C $OUT -czf $OUT/tables.tar.gz paper_gpu_1000 realistic_gpu_1000 && rm -rf $OUT/paper_gpu_1000 $OUT/realistic_gpu_1000
tail -3 $OUT/tables.log
for p in paper realistic; do echo "== $p"; grep -E "^setup|^all" $OUT/paired_$p.txt; done
