#!/bin/bash
# README's command cold (empty caches): one process, then two (the default on 2 cores)
. .venv/bin/activate  # from the repository root
for mode in one two; do
  if [ $mode = one ]; then export GRASPJAX_PROCESSES=1; else unset GRASPJAX_PROCESSES; fi
  rm -rf /tmp/s47/cold_cache_$mode
  s=$(date +%s.%N)
  GRASPJAX_CACHE=/tmp/s47/cold_cache_$mode graspjax run --table 1,2 --trials 10 --seed 0 --out /tmp/s47/cold_$mode --overwrite --quiet > /dev/null 2>&1
  e=$(date +%s.%N)
  echo "cold $mode: $(echo "$e - $s" | bc) s, $(python3 experiments/benchmarks/processes_cpu/same_rows.py results/paper_cpu_10/attempts.csv /tmp/s47/cold_$mode/attempts.csv)"
done
