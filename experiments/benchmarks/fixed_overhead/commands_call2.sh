#!/usr/bin/env bash
# Session 40, call 2: teardown, eager CUDA module loading, a native profile of the program loads, backend start beside imports. HEAD, Tables 1+2 at 1,000 trials, one H100.
set -uo pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl variants/py_spy-*.whl
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1 PATH=/tmp/site/bin:$PATH
nvidia-smi -L; git log --oneline -1
export GRASPJAX_CACHE=/tmp/c
s=$(date +%s.%N); python3 -m graspjax.cli run --table 1,2 --trials 1000 --seed 0 --quiet --out /tmp/r/cold > $OUT/cold.log 2>&1; echo "cold $s $(date +%s.%N)" >> $OUT/total_s.txt
tl() {  # name, then env assignments before the command
  local name=$1; shift
  START=$(date +%s.%N); export START
  env "$@" python3 variants/timeline.py run --table 1,2 --trials 1000 --seed 0 --quiet --out /tmp/r/$name > $OUT/$name.log 2>&1
  echo "$name $START $(date +%s.%N)" >> $OUT/total_s.txt
}
tl plain A=1
tl eager CUDA_MODULE_LOADING=EAGER
tl plain2 A=1
START=$(date +%s.%N); export START
py-spy record --native --threads -r 100 -f raw -o $OUT/pyspy_warm.txt -- python3 variants/timeline.py run --table 1,2 --trials 1000 --seed 0 --quiet --out /tmp/r/spy > $OUT/spy.log 2>&1
gzip -f $OUT/pyspy_warm.txt
echo "spy $START $(date +%s.%N)" >> $OUT/total_s.txt
python3 - > $OUT/backend_overlap.txt 2>&1 <<'PY'
import subprocess, sys
code = {
 "sequential": "import time,os; t0=time.time(); import jax; import graspjax.experiment; t1=time.time(); jax.devices(); t2=time.time(); import numpy as np; jax.device_put(np.zeros(3)).block_until_ready(); t3=time.time(); print(f'imports {t1-t0:.2f} devices {t2-t1:.2f} first put {t3-t2:.2f} total {t3-t0:.2f}')",
 "threaded": "import time,os,threading; t0=time.time(); import jax, numpy as np\ndef up():\n    jax.devices(); jax.device_put(np.zeros(3)).block_until_ready()\nth=threading.Thread(target=up); th.start(); import graspjax.experiment; t1=time.time(); th.join(); t2=time.time(); print(f'imports {t1-t0:.2f} join {t2-t1:.2f} total {t2-t0:.2f}')",
}
for rep in range(2):
    for name, c in code.items():
        out = subprocess.run([sys.executable, "-c", c], capture_output=True, text=True, env={**__import__('os').environ, "XLA_FLAGS": "--xla_gpu_deterministic_ops=true"})
        print(name, out.stdout.strip(), out.stderr.strip()[-300:])
PY
for r in cold plain eager plain2 spy; do echo "== $r"; cat /tmp/r/$r/timings.csv; done > $OUT/timings.txt
python3 - <<'PY'
import os
for line in open(os.environ["OUT"] + "/total_s.txt"):
    n, a, b = line.split(); print(n, round(float(b) - float(a), 1), "s")
PY
cut -d, -f1,3,7-11 $OUT/timings.txt
for r in plain eager plain2; do echo "== $r"; grep "TL_LAST\|exit\|Program.play\|write_report\|finish" $OUT/$r.log | head -12; done
cat $OUT/backend_overlap.txt
ls -la $OUT
