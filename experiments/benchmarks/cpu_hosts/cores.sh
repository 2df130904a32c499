#!/bin/bash
# Stop 48, run on a device host with `.whl/` carried (../../../../shared/gpu/README.md), from the
# repository root, with results/ set aside (the tree sent is limited to 64 MiB) and an
# untracked devscratch/ holding copies of processes_cpu/same_rows.py and
# results/paper_cpu_10/attempts.csv (as paper_cpu_10_attempts.csv). Calls, in order:
# cpu16.sh multi:cold,warm multi_one:warm; cores.sh 0-3:230 0,1:330; eigen.sh.
# README's command cold on a few of the host's cores (taskset), each with an empty cache.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD JAX_PLATFORMS=cpu
keep=$OUT; export OUT=runs
for spec in "$@"; do
  cores=${spec%%:*}; limit=${spec#*:}; name=cores${cores//[,-]/_}
  GRASPJAX_CACHE=/tmp/gjc_$name timeout $limit taskset -c $cores experiments/warm_start.sh $name 10 cold | tee -a $keep/cores.txt
  cp runs/warm_start_$name/cold1/timings.csv $keep/${name}_cold1_timings.csv 2>/dev/null
  echo "$name: $(python3 devscratch/same_rows.py runs/warm_start_multi/cold1/attempts.csv runs/warm_start_$name/cold1/attempts.csv 2>&1 | tail -1)" | tee -a $keep/cores.txt
done
