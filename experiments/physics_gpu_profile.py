"""Where the bin scene's physics spends device time, and what candidate settings buy.

    python3 experiments/physics_gpu_profile.py OUT_DIR [BATCH] [--profile] [VARIANT ...]

VARIANT: comma-separated dotted overrides (`sim.iterations=3,sim.ls_iterations=2`); `base` is
the default configuration (and is what runs when none is given). For each variant, the bin
scene (a-f, Setup 3, `bench.physics_workload`) at BATCH worlds (default 2,000: the tables'
rounds group at 1,000 trials): the drop settles first (`sim.pile_settle_time`), then

- settling world-steps/s, the median of 3 runs of 1 s of simulated time;
- how many of the contact slots hold a touching contact (dist < 0), per world: mean, 99th
  percentile and maximum (a setting that drops slots must stay above what piles use).

With `--profile`, the first variant's settling (2 segments) is also traced with
`jax.profiler`; its device time is printed by source line, function and file (MJX's
collision, constraint, solver ...). On a GPU, put `--xla_gpu_enable_command_buffer=` in
XLA_FLAGS for the attribution (and time the variants in another process, without it).
"""

import gzip
import pathlib
import statistics
import sys
import time

import jax
import numpy as np
from detect_gpu_profile import print_profile

from graspjax.bench import physics_workload
from graspjax.config import Config, override
from graspjax.privates import impl


def measure(out: pathlib.Path, batch: int, variant: str, profile: bool) -> dict:
    """Time one variant's settling; trace it when `profile`."""
    config = Config() if variant == "base" else override(Config(), variant.split(","))
    s = config.sim
    work = physics_workload("abcdef", 3, batch, config)
    idle, zero, spec = work.idle, work.zero, work.spec
    t0 = time.perf_counter()
    nothing = work.no_drops
    jax.block_until_ready(work.simulate(work.data, spec, nothing, idle, zero, zero + 1, False))
    compile_s = time.perf_counter() - t0
    data, _ = jax.block_until_ready(work.simulate(
        work.data, spec, work.drops, idle, zero, zero + s.segments(s.settle_time + s.pile_settle_time),
        False))
    second = s.segments(1.0)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        data, _ = jax.block_until_ready(work.simulate(data, spec, nothing, idle, zero, zero + second,
                                                      False))
        times.append(time.perf_counter() - t0)
    internals = impl(data)
    touching = np.sum(np.asarray(internals.contact.dist) < 0, axis=-1)
    row = {"variant": variant, "compile_s": compile_s,
           "world_steps_per_s": batch * second * s.segment_steps / statistics.median(times),
           "slots": int(np.asarray(internals.contact.dist).shape[-1]),
           "touching_mean": float(touching.mean()),
           "touching_p99": float(np.percentile(touching, 99)), "touching_max": int(touching.max())}
    print(row, flush=True)
    if profile:
        def run(d):
            return work.simulate(d, spec, nothing, idle, zero, zero + 2, False)

        hlo = work.simulate.lower(data, spec, nothing, idle, zero, zero + 2, False).compile().as_text()
        (out / "physics_hlo.txt.gz").write_bytes(gzip.compress(hlo.encode()))
        jax.block_until_ready(run(data))
        print_profile(run, (data,), hlo, out / "trace",
                      f"{variant}: 2 segments of {batch} bin-scene worlds")
    return row


def main() -> None:
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    rest = sys.argv[2:]
    batch = int(rest.pop(0)) if rest and rest[0].isdigit() else 2000
    profile = "--profile" in rest
    variants = [v for v in rest if v != "--profile"] or ["base"]
    print(f"{jax.devices()[0].device_kind}, jax {jax.__version__}", flush=True)
    rows = [measure(out, batch, v, profile=profile and i == 0) for i, v in enumerate(variants)]
    print(f"\n{'variant':<48} {'world-steps/s':>14} {'compile s':>9} {'slots':>5} "
          f"{'touching mean/p99/max':>22}")
    for r in rows:
        print(f"{r['variant']:<48} {r['world_steps_per_s']:>14,.0f} {r['compile_s']:>9.1f} "
              f"{r['slots']:>5} {r['touching_mean']:>10.1f}/{r['touching_p99']:>4.0f}/"
              f"{r['touching_max']:>3}")


if __name__ == "__main__":
    main()
