#!/bin/bash
# Stop 72, one call on an H200 host (run from the repository root there, .whl carried; see
# ../shared/gpu/README.md): `bash before_tmp/gpu.sh cpu2_stop62 cpu2_now gpu_before_5
# gpu_after_5 cpu2_now cpu2_stop62`. Made beforehand, untracked, on the dev machine:
#   before_tmp/c7a4655/: `git archive c7a4655 graspjax pyproject.toml` (stop 62's code);
#   after_tmp/perception/cluster.py: cluster.py with second_fill_from_first.patch applied.
# cpu2_*: `graspjax bench detect` on two cores of the host's CPU (taskset, JAX_PLATFORMS=cpu);
# gpu_*: the GPU batch of 1,024 with cluster.py as committed (before) and patched (after).
# A label run twice writes its JSON twice: the second run's is kept.
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl || exit 1
export PYTHONUNBUFFERED=1 JAX_COMPILATION_CACHE_DIR=/tmp/jc
lscpu | grep -E "Model name|^CPU\(s\)|Thread|Socket"
here=$PWD
for label in "$@"; do
  case $label in
    cpu2_stop62) root=$here/before_tmp/c7a4655 ;;
    cpu2_now) root=$here ;;
    gpu_before_5) root=$here; cp /tmp/cluster_head.py graspjax/perception/cluster.py ;;
    gpu_after_5) root=$here; cp after_tmp/perception/cluster.py graspjax/perception/cluster.py ;;
  esac
  [ -f /tmp/cluster_head.py ] || cp graspjax/perception/cluster.py /tmp/cluster_head.py
  echo "== $label"
  case $label in
    cpu2_*) (cd $root && PYTHONPATH=/tmp/site:$root JAX_PLATFORMS=cpu taskset -c 0,1 \
               python3 -m graspjax.cli bench detect --batch 2 --set image.top_k=5 --out $OUT/$label.json) 2>&1 | tail -3 ;;
    gpu_*) PYTHONPATH=/tmp/site:$here python3 -m graspjax.cli bench detect --width 640 --height 480 \
               --batch 1024 --set image.top_k=5 --out $OUT/$label.json 2>&1 | tail -3 ;;
  esac
done
cp /tmp/cluster_head.py graspjax/perception/cluster.py
python3 - "$OUT" <<'PY'
import json, sys, pathlib
for p in sorted(pathlib.Path(sys.argv[1]).glob("*.json")):
    r = json.loads(p.read_text())
    print(f"{p.stem:14s} single {r['single_latency_ms']:6.1f} ms  batch {r['batch']:5d}: {r['images_per_s']:8.0f} img/s  compile {r['batch_compile_s']:.0f} s")
PY
