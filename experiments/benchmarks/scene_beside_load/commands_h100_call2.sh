#!/bin/bash
# Stop 44 call 2, the same H100 (warm machine, caches of call 1): six more warm passes, after and before alternating.
set -u
export PYTHONPATH=/tmp/site:$PWD
ls /tmp/gjc/exported | wc -l
keep=$OUT; export OUT=runs GRASPJAX_CACHE=/tmp/gjc
B=$PWD/variants/before
for i in 1 2 3; do
  experiments/warm_start.sh after 1000 warm | tail -1
  PACKAGE=$B experiments/warm_start.sh before 1000 warm | tail -1
done
for n in after before; do cat runs/warm_start_$n/total_s.txt > $keep/${n}_total_s_call2.txt; done
for n in before after; do for r in runs/warm_start_$n/warm*/timings.csv; do echo "$n $r first chunk at $(sed -n 2p $r | cut -d, -f9,10)"; done; done
