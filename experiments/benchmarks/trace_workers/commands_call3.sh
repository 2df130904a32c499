#!/usr/bin/env bash
# Stop 38, call 3: the bin scene's step with the CLI's flags (deterministic ops + small-dot
# threshold) at 1,000 / 2,000 / 4,000 worlds, and a kernel profile at 2,000; one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi -L
F="--xla_gpu_deterministic_ops=true --xla_gpu_gemm_rewrite_size_threshold=300"
cd experiments
for b in 2000 4000 1000; do
  XLA_FLAGS="$F" python3 physics_gpu_profile.py /tmp/b$b $b > $OUT/bin_${b}_h100.txt 2>&1
done
XLA_FLAGS="$F --xla_gpu_enable_command_buffer=" python3 physics_gpu_profile.py /tmp/prof 2000 --profile > $OUT/profile_2000_h100.txt 2>&1
for b in 1000 2000 4000; do echo "== $b"; grep -v "^W\|^I0\|Warn" $OUT/bin_${b}_h100.txt | tail -4; done
head -60 $OUT/profile_2000_h100.txt
