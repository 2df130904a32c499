"""Where a warm start's program load goes: the exported module read, lowering, XLA's cache key,
the cache read and the executable rebuilt, per program of README's command (Tables 1 and 2).

    GRASPJAX_CACHE=<a cache README's command filled> python3 experiments/load_timing.py [BATCH]

BATCH: worlds per chunk (default: the device's, as `graspjax run`). The XLA flags are the CLI's
(`runtime.xla.with_xla_flags`), so the programs come out of the cache that run left. Last, each attempt
program's executable is serialized and rebuilt on its own (`deserialize_and_load`). Results:
results/benchmarks/history/physics_step.md (stop 39).
"""

import collections
import os
import sys
import time

from graspjax.runtime import xla

os.environ["XLA_FLAGS"] = xla.with_xla_flags(os.environ.get("XLA_FLAGS", ""))
xla.compilation_cache()

from jax._src import compilation_cache, compiler  # noqa: E402 - after the flags are set
from jax.experimental import serialize_executable  # noqa: E402

from graspjax.batch.plan import default_batch, plan, table_job  # noqa: E402
from graspjax.batch.program import program  # noqa: E402
from graspjax.config import Config  # noqa: E402

SECONDS: dict[str, float] = collections.defaultdict(float)


def timed(owner, name: str, label: str) -> None:
    """Add the seconds of every call of `owner.name` to SECONDS[label]."""
    inner = getattr(owner, name)

    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            SECONDS[label] += time.perf_counter() - start

    setattr(owner, name, wrapper)


def main(batch: int) -> None:
    timed(compiler, "_resolve_compilation_strategy", "cache_key")
    timed(compilation_cache, "decompress_executable", "decompress")
    groups = plan([table_job(1, 10), table_job(2, 10)], [Config()], 0)
    for group in groups:
        p = program(group, batch, False)
        SECONDS.clear()
        t0 = time.perf_counter()
        _ = p.portable
        t1 = time.perf_counter()
        start, attempt = p.lower()
        here = (p.devices[0],)
        t2 = time.perf_counter()
        start.compile(device_assignment=here)
        compiled = attempt.compile(device_assignment=here)
        t3 = time.perf_counter()
        print(f"{''.join(group.letters)} collide={group.collide}: read {t1 - t0:.2f} s, lower "
              f"{t2 - t1:.2f} s, compile {t3 - t2:.2f} s ({p.origin}); "
              + ", ".join(f"{k} {v:.2f} s" for k, v in SECONDS.items()), flush=True)
        blob = serialize_executable.serialize(compiled)
        t4 = time.perf_counter()
        serialize_executable.deserialize_and_load(*blob)
        print(f"  attempt executable {len(blob[0]) / 1e6:.1f} MB rebuilt in "
              f"{time.perf_counter() - t4:.2f} s", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else default_batch())
