"""`graspjax detect` on a CPU: one image per call against batches, in one process.

    python3 experiments/detect_single_vs_batch.py [TOP_K] [ROUNDS]

Under `vmap` every `lax.cond` of `detect_real_image` runs both branches (the contour search,
a given-up target's surface); one image alone runs only the branch it takes. Each of
`graspjax bench detect`'s 64 scenes goes through `imagefiles.batches.detect_single`, through
`detect_batch` as a batch of one, and as one of a batch of 16 (the batch's time shared out),
in turn, ROUNDS times (2), top K = TOP_K (5). Prints each way's median time per image and
whether the three agree (the same grasps found; centres within 0.1 mm: a batch sums in another
order). Nothing is written.
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

BATCH = 16


def main(top_k: int = 5, rounds: int = 2) -> int:
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
    for _, call in ways.values():  # compile
        jax.block_until_ready(call(0))
    seconds = {name: [] for name in ways}
    found = {name: np.zeros(len(scenes), bool) for name in ways}
    position = {name: np.zeros((len(scenes), 3), np.float32) for name in ways}
    for _ in range(rounds):
        for i in range(len(scenes)):
            for name, (size, call) in ways.items():
                if i % size:
                    continue
                start = time.perf_counter()
                result = jax.block_until_ready(call(i))
                seconds[name] += [(time.perf_counter() - start) / size] * size
                found[name][i:i + size] = np.asarray(result.found)  # (size,) or ()
                position[name][i:i + size] = np.asarray(result.position).reshape(-1, 3)
    print(f"{jax.devices()[0].platform}, top {top_k}, {len(scenes)} scenes x {rounds}")
    for name in ways:
        print(f"  {name:20s} median {1e3 * statistics.median(seconds[name]):6.2f} ms per image")
    reference = "one image per call"
    for name in list(ways)[1:]:
        gap = np.linalg.norm(position[name] - position[reference], axis=-1)[found[reference]]
        same = np.array_equal(found[name], found[reference]) and bool(np.all(gap < 1e-4))
        print(f"  {name} finds the same grasps as one image per call: {same} "
              f"({int(found[name].sum())} found; centres at most {1e3 * gap.max():.4f} mm apart)")
    return 0


if __name__ == "__main__":
    sys.exit(main(*(int(a) for a in sys.argv[1:])))
