#!/bin/bash
# Stop 48, run on a device host with `.whl/` carried (../../../../shared/gpu/README.md), from the
# repository root, with results/ set aside (the tree sent is limited to 64 MiB) and an
# untracked devscratch/ holding copies of processes_cpu/same_rows.py and
# results/paper_cpu_10/attempts.csv (as paper_cpu_10_attempts.csv). Calls, in order:
# cpu16.sh multi:cold,warm multi_one:warm; cores.sh 0-3:230 0,1:330; eigen.sh.
# README's command cold with XLA's Eigen single-threaded, on all 16 cores and on 4 (taskset):
# do the rows still depend on the core count?
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD JAX_PLATFORMS=cpu XLA_FLAGS=--xla_cpu_multi_thread_eigen=false
keep=$OUT; export OUT=runs
GRASPJAX_CACHE=/tmp/gjc_e16 timeout 200 experiments/warm_start.sh eigen16 10 cold | tee -a $keep/eigen.txt
GRASPJAX_CACHE=/tmp/gjc_e4 timeout 260 taskset -c 0-3 experiments/warm_start.sh eigen4 10 cold | tee -a $keep/eigen.txt
for a in multi cores0_3 eigen16; do for b in eigen16 eigen4; do [ $a = $b ] && continue
  echo "$a vs $b: $(python3 devscratch/same_rows.py runs/warm_start_$a/cold1/attempts.csv runs/warm_start_$b/cold1/attempts.csv 2>&1 | tr '\n' ' ')" | tee -a $keep/eigen.txt; done; done
for n in eigen16 eigen4; do cp runs/warm_start_$n/cold1/timings.csv $keep/${n}_cold1_timings.csv; grep -o "xla_flags[^,]*" runs/warm_start_$n/cold1/config.json; done
