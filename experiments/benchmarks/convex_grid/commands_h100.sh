#!/bin/bash
# Stop 45, one H100: hull pairs collided on grids (sim/convex.py). before = 0422a40
# (variants/before), after = the working tree. Each has its own compilation cache (their XLA
# programs differ): both cold, then warm passes interleaved; the paired outcomes of the cold
# passes (24,000 attempts); the bin's step rate before and after; then the reference tables
# (experiments/paper_tables.sh gpu) with the after code. The call reached its 600 s limit in
# the first bin benchmark: what ran is in warm_start_h100.txt and paired_h100_1000.txt; the bin
# ran again alone (commands_h100_bench.sh); the tables were not needed (no outcome changed).
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs
B=$PWD/variants/before
GRASPJAX_CACHE=/tmp/gjb PACKAGE=$B experiments/warm_start.sh before 1000 cold | tail -1
GRASPJAX_CACHE=/tmp/gja experiments/warm_start.sh after 1000 cold | tail -1
for i in 1 2; do
  GRASPJAX_CACHE=/tmp/gjb PACKAGE=$B experiments/warm_start.sh before 1000 warm | tail -1
  GRASPJAX_CACHE=/tmp/gja experiments/warm_start.sh after 1000 warm | tail -1
done
python3 experiments/paired_rows.py runs/warm_start_before/cold1/attempts.csv runs/warm_start_after/cold1/attempts.csv > $keep/paired_h100_1000.txt 2>&1
(cd $B && GRASPJAX_CACHE=/tmp/gjb python3 -m graspjax.cli bench physics --objects abcdef --setup 3 --batch 2000 --out $keep/bin_2000_before.json 2>&1 | tail -4)
GRASPJAX_CACHE=/tmp/gja python3 -m graspjax.cli bench physics --objects abcdef --setup 3 --batch 2000 --out $keep/bin_2000_after.json 2>&1 | tail -4
for n in before after; do sed "s/^/$n /" runs/warm_start_$n/total_s.txt; done > $keep/total_s.txt
mkdir -p timings; for n in before after; do for r in cold1 warm1 warm2; do
  cp runs/warm_start_$n/$r/timings.csv timings/${n}_${r}_timings.csv; done; done
tar -czf $keep/timings.tgz timings
s=$(date +%s); GRASPJAX_CACHE=/tmp/gja OUT=tables experiments/paper_tables.sh gpu; echo "paper_tables.sh gpu: $(( $(date +%s) - s )) s"
tar -czf $keep/tables.tgz tables
cat $keep/total_s.txt; grep -E "^setup|^all" $keep/paired_h100_1000.txt
