#!/bin/bash
# README's command warm, one process (GRASPJAX_PROCESSES=1) against the default (2 on 2 cores),
# interleaved, after one pass that fills the store for the current sources
. .venv/bin/activate  # from the repository root
graspjax run --table 1,2 --trials 10 --seed 0 --out /tmp/s47/pair/fill --overwrite --quiet > /dev/null 2>&1
echo "fill: $(python3 experiments/benchmarks/processes_cpu/same_rows.py results/paper_cpu_10/attempts.csv /tmp/s47/pair/fill/attempts.csv)"
for pass in 1 2; do
  for mode in one two; do
    if [ $mode = one ]; then export GRASPJAX_PROCESSES=1; else unset GRASPJAX_PROCESSES; fi
    s=$(date +%s.%N)
    graspjax run --table 1,2 --trials 10 --seed 0 --out /tmp/s47/pair/$mode$pass --overwrite --quiet > /dev/null 2>&1
    e=$(date +%s.%N)
    echo "$mode pass $pass: $(echo "$e - $s" | bc) s, $(python3 experiments/benchmarks/processes_cpu/same_rows.py results/paper_cpu_10/attempts.csv /tmp/s47/pair/$mode$pass/attempts.csv)"
  done
done
