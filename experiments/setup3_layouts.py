"""Setup 3's settled layouts alone (no grasping), judged against the bounds stated from the
paper's words (`graspjax/report/density.py`, `docs/simulation.md`).

    python3 experiments/setup3_layouts.py ROUNDS OUT.csv [KEY=VALUE ...]

Places and settles ROUNDS Setup 3 rounds of a-f (seed 0, rounds 0..ROUNDS-1: the same layouts a
run with `--seed 0` plays) exactly as a run does (`procedure.start_round`, `procedure.settle`),
writes one row per round (`schema.LAYOUT_COLUMNS`, `placed_spread_m`) and prints each bound's
verdict. KEY=VALUE are `--set` overrides (e.g. `layout.bin=true`).
"""

import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
from tqdm import tqdm

from graspjax.batch.rows import layout_columns
from graspjax.config import Config, override, stack_configs
from graspjax.procedure import WorldSpec, settle, start_round
from graspjax.report.density import judge
from graspjax.sim.clutter import layout_stats
from graspjax.sim.physics import WORLDS
from graspjax.sim.scene import mjx, scene_for

CHUNK = 50


def settle_chunks(rounds: int, config: Config, measure, seed: int = 0):
    """Place and settle Setup 3 rounds of a-f, rounds 0..rounds-1 of `seed`, exactly as a run
    does, CHUNK worlds per compiled call; yield (rounds (C,), `measure`'s outputs as NumPy, (C,
    ...) each) per chunk. `measure(scene, state, data)` reads one world: the round's start
    (`procedure.start_round`) and its settled `mjx.Data`."""
    scene = scene_for(tuple("abcdef"), config, True)
    n = scene.num_objects
    template = mjx.make_data(scene.mj_model)

    def one(spec):
        state = start_round(scene, template, spec, (3,))
        return measure(scene, state, settle(scene, state, spec).data)

    run = jax.jit(jax.vmap(one, axis_name=WORLDS))
    for start in tqdm(range(0, rounds, CHUNK), desc="settling", unit="chunk"):
        size = min(CHUNK, rounds - start)
        trials = np.arange(start, start + CHUNK, dtype=np.int32)  # the last chunk padded
        spec = WorldSpec(seed=np.full(CHUNK, seed, np.int32), setup=np.full(CHUNK, 3, np.int32),
                         trial=trials, order=np.tile(np.arange(n, dtype=np.int32), (CHUNK, 1)),
                         members=np.ones((CHUNK, n), bool), config=stack_configs([config] * CHUNK))
        yield trials[:size], jax.tree.map(lambda x, size=size: np.asarray(x)[:size], run(spec))


def _layout(scene, state, data):
    xy = state.drops.xy
    placed = jnp.max(jnp.linalg.norm(xy[:, None] - xy[None], axis=-1))
    return layout_stats(scene, data), placed


def settled_rounds(rounds: int, config: Config, seed: int = 0) -> pd.DataFrame:
    frames = [pd.DataFrame({"round": trials, **layout_columns(stats), "placed_spread_m": placed})
              for trials, (stats, placed) in settle_chunks(rounds, config, _layout, seed)]
    return pd.concat(frames, ignore_index=True)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    rounds, out = int(sys.argv[1]), sys.argv[2]
    config = override(Config(), sys.argv[3:])
    began = time.perf_counter()
    frame = settled_rounds(rounds, config)
    frame.to_csv(out, index=False)
    print(f"{rounds} rounds settled in {time.perf_counter() - began:.0f} s ({jax.devices()[0]}); "
          f"{' '.join(sys.argv[3:]) or 'defaults'}")
    print(f"contact (reported, not bounded): {frame.touching_fraction.mean():.3f} of objects, "
          f"{(frame.touching_fraction == 0).mean():.3f} of rounds with none")
    print(judge(frame).to_string(index=False))
