"""`graspjax detect` on a CPU: one image per call against batches, in one process.

    python3 experiments/detect_single_vs_batch.py [TOP_K] [ROUNDS]

Under `vmap` every `lax.cond` of `detect_real_image` runs both branches (the contour search,
a given-up target's surface); one image alone runs only the branch it takes. Each of
`graspjax bench detect`'s 64 scenes goes through `imagefiles.batches.detect_single`, through
`detect_batch` as a batch of one, and as one of a batch of 16 (the batch's time shared out),
in turn, ROUNDS times (2), top K = TOP_K (5), with the XLA flags `graspjax detect` sets.
Prints each way's compile time (a cold cache: GRASPJAX_CACHE=0) and median time per image (a
batch of 16's share: one timing per 16 images) and
whether the three agree: the same ranked grasps valid, their centres within 0.1 mm and axes
within 0.1 degree (a batch sums in another order). Nothing is written.
"""

import dataclasses
import statistics
import sys
import time

import jax
import numpy as np

from graspjax.bench import detect_workload
from graspjax.config import Config, RealImageConfig
from graspjax.imagefiles.batches import detect_batch, detect_single, stack_cameras
from graspjax.runtime import xla

BATCH = 16


def main(top_k: int = 5, rounds: int = 2) -> int:
    xla.set_up(deterministic=True)  # before JAX starts, as the CLI
    camera, workspace, scenes = detect_workload()
    config, image = Config(), dataclasses.replace(RealImageConfig(), top_k=top_k)
    one, many = stack_cameras([camera]), stack_cameras([camera] * BATCH)
    # name: (images per call, the call on the images from i on)
    ways = {
        "one image per call": (1, lambda i: detect_single(scenes[i], workspace, camera, config,
                                                          image)),
        "a batch of one": (1, lambda i: detect_batch(scenes[i:i + 1], workspace, one, config, image)),
        f"a batch of {BATCH}": (BATCH, lambda i: detect_batch(scenes[i:i + BATCH], workspace, many,
                                                              config, image)),
    }
    compile_s = {}
    for name, (_, call) in ways.items():  # compile (and run once)
        start = time.perf_counter()
        jax.block_until_ready(call(0))
        compile_s[name] = time.perf_counter() - start
    seconds = {name: [] for name in ways}
    valid = {name: np.zeros((len(scenes), top_k), bool) for name in ways}  # ranked grasps
    position = {name: np.zeros((len(scenes), top_k, 3), np.float32) for name in ways}
    axis = {name: np.zeros((len(scenes), top_k, 3), np.float32) for name in ways}
    for _ in range(rounds):
        for i in range(len(scenes)):
            for name, (size, call) in ways.items():
                if i % size:
                    continue
                start = time.perf_counter()
                result = jax.block_until_ready(call(i))
                seconds[name] += [(time.perf_counter() - start) / size] * size
                ranked = result.ranked  # (size, K, ...) or (K, ...)
                valid[name][i:i + size] = np.asarray(ranked.valid).reshape(-1, top_k)
                position[name][i:i + size] = np.asarray(ranked.position).reshape(-1, top_k, 3)
                axis[name][i:i + size] = np.asarray(ranked.closing_axis).reshape(-1, top_k, 3)
    print(f"{jax.devices()[0].platform}, top {top_k}, {len(scenes)} scenes x {rounds}")
    for name in ways:
        print(f"  {name:20s} median {1e3 * statistics.median(seconds[name]):6.2f} ms per image "
              f"(compiled and run once in {compile_s[name]:.1f} s)")
    reference = "one image per call"
    ok = valid[reference]
    for name in list(ways)[1:]:
        gap = np.linalg.norm(position[name] - position[reference], axis=-1)[ok]
        cos = np.abs(np.sum(axis[name] * axis[reference], -1))[ok]
        turn = np.rad2deg(np.arccos(np.clip(cos, 0.0, 1.0)))
        same = (np.array_equal(valid[name], ok) and bool(np.all(gap < 1e-4))
                and bool(np.all(turn < 0.1)))
        print(f"  {name}: the same ranked grasps as one image per call: {same} ({int(ok.sum())} "
              f"valid, {int(ok[:, 0].sum())} images with a grasp; centres at most "
              f"{1e3 * gap.max(initial=0):.4f} mm, axes {turn.max(initial=0):.3f} deg apart)")
    return 0


if __name__ == "__main__":
    sys.exit(main(*(int(a) for a in sys.argv[1:])))
