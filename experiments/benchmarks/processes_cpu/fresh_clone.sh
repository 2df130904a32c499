#!/bin/bash
# fresh clone of main: README's install, README's command cold (empty caches) and warm, then README's tests
set -u
rm -rf /tmp/s47/fresh /tmp/s47/fresh_cache /tmp/s47/fresh_test_cache
git clone -q /work/main /tmp/s47/fresh && cd /tmp/s47/fresh && git log --oneline -1
python3 -m venv .venv && . .venv/bin/activate && python3 -m pip install -q -e ".[dev]" 2>&1 | tail -2
export GRASPJAX_CACHE=/tmp/s47/fresh_cache
for pass in cold warm; do
  s=$(date +%s.%N)
  graspjax run --table 1,2 --trials 10 --seed 0 --out runs/paper_$pass > /tmp/s47/fresh_$pass.log 2>&1
  echo "README command $pass: exit $? after $(echo "$(date +%s.%N) - $s" | bc) s, $(python3 /work/main/experiments/benchmarks/processes_cpu/same_rows.py /work/main/results/paper_cpu_10/attempts.csv runs/paper_$pass/attempts.csv)"
  cp runs/paper_$pass/timings.csv /tmp/s47/fresh_${pass}_timings.csv
done
export GRASPJAX_CACHE=/tmp/s47/fresh_test_cache
s=$(date +%s.%N)
python3 -m pytest -q > /tmp/s47/fresh_tests.log 2>&1
echo "tests: exit $? after $(echo "$(date +%s.%N) - $s" | bc) s: $(tail -1 /tmp/s47/fresh_tests.log)"
