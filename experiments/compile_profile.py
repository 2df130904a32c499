"""Where a cold compile of Tables 1 and 2 goes: lowering (Python) and XLA's compile, per program.

    python3 experiments/compile_profile.py [BATCH] [serial|parallel] [GROUPS]

BATCH: worlds per chunk (default 4096, as `graspjax run` on a GPU); GROUPS: comma-separated
indices of the run's groups (0: a-f Setup 1, 1: a-f Setups 2-3, 2: g-l; default all).
`parallel` compiles the groups in threads at once. XLA flags come from the environment
(`XLA_FLAGS=--xla_gpu_deterministic_ops=true`, as the CLI sets them); no compilation cache is
used. Results: results/benchmarks/history/physics_step.md.
"""

import concurrent.futures
import os
import sys
import time

import jax

from graspjax.batch import plan, program
from graspjax.config import Config


def profile(group: plan.Group, batch: int) -> None:
    """Lower one group's program (both functions) and compile each, timed apart."""
    p = program.program(group, batch, False)
    t0 = time.perf_counter()
    start, attempt = p.lower()
    here = (p.devices[0],)
    t1 = time.perf_counter()
    start.compile(device_assignment=here)
    t2 = time.perf_counter()
    attempt.compile(device_assignment=here)
    t3 = time.perf_counter()
    print(f"{''.join(group.letters)} collide={group.collide} attempts={group.attempts} "
          f"batch={p.batch}: lower {t1 - t0:.1f} s; compile start {t2 - t1:.1f} s, attempt "
          f"{t3 - t2:.1f} s; StableHLO {len(attempt.as_text()) / 1e6:.1f} MB", flush=True)


def main() -> None:
    batch = int(sys.argv[1]) if len(sys.argv) > 1 else 4096
    mode = sys.argv[2] if len(sys.argv) > 2 else "serial"
    groups = plan.plan([plan.table_job(1, 1000), plan.table_job(2, 1000)], [Config()], 0)
    if len(sys.argv) > 3:
        groups = [groups[int(i)] for i in sys.argv[3].split(",")]
    start = time.perf_counter()
    if mode == "serial":
        for group in groups:
            profile(group, batch)
    else:
        with concurrent.futures.ThreadPoolExecutor(len(groups)) as pool:
            list(pool.map(lambda g: profile(g, batch), groups))
    print(f"{mode}: {time.perf_counter() - start:.1f} s on {jax.devices()[0].device_kind}, "
          f"XLA_FLAGS={os.environ.get('XLA_FLAGS', '')!r}")


if __name__ == "__main__":
    main()
