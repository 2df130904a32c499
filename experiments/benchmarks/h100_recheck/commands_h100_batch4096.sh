#!/bin/bash
# Stop 46, one H100, the same machine after commands_h100.sh: Tables 1+2 at 1,000 trials with
# the reference run's batch (--batch 4096, as experiments/paper_tables.sh gpu runs it), rows
# paired with results/paper_gpu_1000 (another batch changes rows statistically only:
# docs/running.md).
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
keep=$OUT; export OUT=runs
GRASPJAX_CACHE=/tmp/gj4096 ARGS="--batch 4096" experiments/warm_start.sh batch4096 1000 cold | tail -1 | tee $keep/warm_start_batch4096_h100.txt
gunzip -c results/paper_gpu_1000/attempts.csv.gz > /tmp/reference.csv
python3 experiments/paired_rows.py /tmp/reference.csv runs/warm_start_batch4096/cold1/attempts.csv > $keep/paired_reference_batch4096_h100.txt 2>&1
cp runs/warm_start_batch4096/cold1/timings.csv $keep/batch4096_cold1_timings.csv
grep -E "^setup|^all" $keep/paired_reference_batch4096_h100.txt
