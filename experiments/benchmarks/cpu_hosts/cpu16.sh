#!/bin/bash
# Stop 48, run on a device host with `.whl/` carried (../../../../shared/gpu/README.md), from the
# repository root, with results/ set aside (the tree sent is limited to 64 MiB) and an
# untracked devscratch/ holding copies of processes_cpu/same_rows.py and
# results/paper_cpu_10/attempts.csv (as paper_cpu_10_attempts.csv). Calls, in order:
# cpu16.sh multi:cold,warm multi_one:warm; cores.sh 0-3:230 0,1:330; eigen.sh.
# README's command on the device host's CPU (JAX_PLATFORMS=cpu): cold and warm in the default
# processes, then warm in one process; rows against results/paper_cpu_10.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl 2>&1 | tail -1
export PYTHONPATH=/tmp/site:$PWD JAX_PLATFORMS=cpu
nproc; lscpu | grep -E "Model name|^CPU\(s\)|Thread|Socket"; python3 -c "import jax, jaxlib; print(jax.__version__, jaxlib.__version__, jax.devices())"
keep=$OUT; export OUT=runs
for spec in "$@"; do
  name=${spec%%:*}; passes=${spec#*:}
  if [[ $name == *one* ]]; then export GRASPJAX_PROCESSES=1; else unset GRASPJAX_PROCESSES; fi
  GRASPJAX_CACHE=/tmp/gjc_${name%_*} timeout 560 experiments/warm_start.sh $name 10 ${passes//,/ } | tee -a $keep/cpu16_$name.txt
  for r in runs/warm_start_$name/*/; do
    b=$(basename $r); cp $r/timings.csv $keep/${name}_${b}_timings.csv 2>/dev/null
    echo "$name $b: $(python3 devscratch/same_rows.py devscratch/paper_cpu_10_attempts.csv $r/attempts.csv)" | tee -a $keep/cpu16_$name.txt
  done
done
