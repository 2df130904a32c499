"""How long JAX's GPU client and each device's first allocation take: one line per process.

    CUDA_VISIBLE_DEVICES=0,1,2,3 [XLA_PYTHON_CLIENT_PREALLOCATE=false] \
        python3 experiments/device_start_cost.py serial|parallel

MODE: the devices' first allocations one after another, or each in a thread of its own (as
`graspjax run` starts them: `runtime.xla.start_devices`). Results:
results/benchmarks/scaling_h200x4_stop63/start_cost.txt.
"""
import os
import sys
import threading
import time

t0 = time.perf_counter()
import jax  # noqa: E402

t1 = time.perf_counter()
devices = jax.devices()
t2 = time.perf_counter()
mode = sys.argv[1]
each = {}


def first(d):
    s = time.perf_counter()
    jax.device_put(0.0, d).block_until_ready()
    each[d.id] = round(time.perf_counter() - s, 2)


if mode == "serial":
    for d in devices:
        first(d)
else:
    threads = [threading.Thread(target=first, args=(d,)) for d in devices]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
t3 = time.perf_counter()
preallocate = os.environ.get("XLA_PYTHON_CLIENT_PREALLOCATE", "default")
print(f"{mode:8s} devices={len(devices)} prealloc={preallocate:7s} import {t1 - t0:.2f} "
      f"client {t2 - t1:.2f} first allocations {t3 - t2:.2f} {each}", flush=True)
