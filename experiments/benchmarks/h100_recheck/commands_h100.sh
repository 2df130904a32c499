#!/bin/bash
# Stop 46, one H100: issue 17's GPU targets measured again on main (f989624; its graspjax/ is
# a47475c's, stop 45's final code) on another host: Tables 1+2 at 1,000 trials cold, then
# warm twice (experiments/warm_start.sh), and the cold pass's rows paired with the committed
# reference run results/paper_gpu_1000 (made at 55f8bea).
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs
GRASPJAX_CACHE=/tmp/gj experiments/warm_start.sh main 1000 cold warm warm | tail -3 | tee $keep/warm_start_h100.txt
gunzip -c results/paper_gpu_1000/attempts.csv.gz > /tmp/reference.csv
python3 experiments/paired_rows.py /tmp/reference.csv runs/warm_start_main/cold1/attempts.csv > $keep/paired_reference_h100.txt 2>&1
mkdir -p timings; for r in cold1 warm1 warm2; do cp runs/warm_start_main/$r/timings.csv timings/${r}_timings.csv; done
tar -czf $keep/timings.tgz timings
grep -E "^setup|^all" $keep/paired_reference_h100.txt
