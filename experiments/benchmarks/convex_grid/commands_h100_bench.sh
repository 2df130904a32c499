#!/bin/bash
# Stop 45, one H100, a second call: the bin's step rate (a-f, Setup 3, 2,000 worlds, the
# rounds group's batch) before (0422a40, variants/before) and after, one process each.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name --format=csv,noheader
B=$PWD/variants/before
for i in 1 2; do
(cd $B && PYTHONPATH=/tmp/site:$B GRASPJAX_CACHE=/tmp/gjb python3 -m graspjax.cli bench physics --objects abcdef --setup 3 --batch 2000 --out $OUT/bin_2000_before_$i.json 2>&1 | tail -4)
GRASPJAX_CACHE=/tmp/gja python3 -m graspjax.cli bench physics --objects abcdef --setup 3 --batch 2000 --out $OUT/bin_2000_after_$i.json 2>&1 | tail -4
done
