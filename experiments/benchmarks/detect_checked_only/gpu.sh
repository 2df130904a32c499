#!/bin/bash
# Stop 73, one call on one H200 (run from the repository root there, .whl carried; see
# ../shared/gpu/README.md): `bash experiments/benchmarks/detect_checked_only/gpu.sh before_5
# after_5 after_1 before_1` (ba5ab90, the loop on every backend: gpu_loops/), then `... after_5
# before_5 after_1` (the loop on a CPU only, `tree.cpu_chunk`: gpu/). Made beforehand, untracked,
# on the dev machine:
#   before_tmp/366cb6f/: `git archive 366cb6f graspjax pyproject.toml` (stop 72's last code,
#   every placement and every jaw check computed). after_*: the working tree (only the
#   admissible placements and the placed grasps' jaws checked).
# Each label: `graspjax bench detect` batch 1,024 at 640 x 480, top 5 or top 1.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl || exit 1
export PYTHONUNBUFFERED=1 JAX_COMPILATION_CACHE_DIR=/tmp/jc
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
here=$PWD
for label in "$@"; do
  case $label in
    before_*) root=$here/before_tmp/366cb6f ;;
    after_*) root=$here ;;
  esac
  echo "== $label"
  (cd $root && PYTHONPATH=/tmp/site:$root python3 -m graspjax.cli bench detect --width 640 \
     --height 480 --batch 1024 --set image.top_k=${label##*_} --out $OUT/$label.json) 2>&1 | tail -3
done
python3 - "$OUT" <<'PY'
import json, sys, pathlib
for p in sorted(pathlib.Path(sys.argv[1]).glob("*.json")):
    r = json.loads(p.read_text())
    print(f"{p.stem:10s} single {r['single_latency_ms']:6.1f} ms  batch {r['batch']:5d}: "
          f"{r['images_per_s']:8.0f} img/s  compile {r['batch_compile_s']:.0f} s")
PY
