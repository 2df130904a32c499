"""How soon freshly placed worlds come to rest: what settling that stops at rest could save.

    python3 experiments/settle_rest.py [BATCH] [SETUP] [OBJECTS]

BATCH worlds (default 2,000: the tables' rounds group) of SETUP (default 3) in the scene of
OBJECTS (default abcdef) are placed as a run places them (`bench.physics_workload`) and settle
one segment at a time for the first attempt's whole settling (Setup 1: drop_settle_time, 2:
group_settle_time, 3: pile_settle_time, each plus settle_time). After each segment, each
world's fastest object: linear speed (m/s) and angular speed (rad/s). Prints, per segment, the
fraction of worlds at rest under three thresholds and the slowest world's speeds. Under `vmap`
a batch's loop runs until its last world is done, so a stop at rest saves segments only once
every world of the chunk is at rest.
"""

import dataclasses
import sys

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.bench import physics_workload
from graspjax.config import Config

THRESHOLDS = ((0.01, 0.1), (0.005, 0.05), (0.002, 0.02))  # (m/s, rad/s) that count as at rest


def fastest_object(scene, data) -> tuple[np.ndarray, np.ndarray]:
    """Per world: the largest linear (m/s) and angular (rad/s) speed of any object (batch,)."""
    qvel = data.qvel
    lin = jnp.stack([jnp.linalg.norm(qvel[:, v:v + 3], axis=-1) for v in scene.object_qvel], 1)
    ang = jnp.stack([jnp.linalg.norm(qvel[:, v + 3:v + 6], axis=-1) for v in scene.object_qvel],
                    1)
    return np.asarray(lin.max(1)), np.asarray(ang.max(1))


def main() -> None:
    batch = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    setup = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    letters = sys.argv[3] if len(sys.argv) > 3 else "abcdef"
    config = Config()
    s = config.sim
    extra = {1: s.drop_settle_time, 2: s.group_settle_time, 3: s.pile_settle_time}[setup]
    segments = s.segments(extra + s.settle_time)
    work = physics_workload(letters, setup, batch, config)
    data = work.data
    print(f"{jax.devices()[0].device_kind}: {batch} worlds of Setup {setup} ({letters}), "
          f"{segments} segments of {s.segment_steps * s.timestep:.2f} s", flush=True)
    head = "  ".join(f"<{v:g} m/s,{w:g} rad/s" for v, w in THRESHOLDS)
    print(f"segment  t (s)  at rest: {head}  slowest world: m/s rad/s")
    for k in range(segments):  # one segment a call: the drops' segments count from each call
        late = work.drops.segment - k
        drops = dataclasses.replace(work.drops, segment=jnp.where(late >= 0, late, -1),
                                    push_until=work.drops.push_until - k)
        data, _ = jax.block_until_ready(
            work.simulate(data, work.spec, drops, work.idle, work.zero, work.zero + 1, False))
        lin, ang = fastest_object(work.scene, data)
        rest = "  ".join(f"{np.mean((lin < v) & (ang < w)):>{len(f'<{v:g} m/s,{w:g} rad/s')}.4f}"
                         for v, w in THRESHOLDS)
        print(f"{k + 1:>7}  {(k + 1) * s.segment_steps * s.timestep:5.1f}  {' ' * 9}{rest}  "
              f"{lin.max():.4f} {ang.max():.3f}", flush=True)


if __name__ == "__main__":
    main()
