"""Save `graspjax detect`'s ranked grasps on 64 benchmark images, to compare two versions.

    python3 experiments/detect_same_grasps.py OUT.npz        # run once per version
    python3 experiments/detect_same_grasps.py A.npz B.npz    # compare

Images: `bench.detect_workload` (640 x 480, seed 0, as `graspjax bench detect`),
`detect_batch` with the default settings and `image.top_k=5`. Saves the ranked positions,
their validity and each image's target pixel; comparing prints how many images agree.
Run each version from its own folder (`python3 -c` and scripts put their folder first on
`sys.path`; the printed package path says which ran).
"""

import sys

import numpy as np


def save(path: str) -> None:
    import jax
    import jax.numpy as jnp

    import graspjax
    from graspjax.bench import detect_workload
    from graspjax.config import Config, RealImageConfig
    from graspjax.imagefiles.batches import detect_batch, stack_cameras

    camera, workspace, scenes = detect_workload()
    result = jax.jit(lambda d, c: detect_batch(d, workspace, c, Config(),
                                               RealImageConfig(top_k=5)))(
        jnp.asarray(scenes), stack_cameras([camera] * 64))
    np.savez(path, position=np.asarray(result.ranked.position),
             valid=np.asarray(result.ranked.valid), target=np.asarray(result.target))
    print(f"{graspjax.__file__}: saved {path}")


def compare(first: str, second: str) -> None:
    a, b = np.load(first), np.load(second)
    valid = (a["valid"] == b["valid"]).all(axis=1)
    identical = np.array([np.array_equal(x, y, equal_nan=True)
                          for x, y in zip(a["position"], b["position"], strict=True)])
    target = (a["target"] == b["target"]).all(axis=1)
    print(f"{len(valid)} images, top 5: same validity {valid.sum()}, bit-identical positions "
          f"{identical.sum()}, same target {target.sum()}")


if __name__ == "__main__":
    if len(sys.argv) == 2:
        save(sys.argv[1])
    else:
        compare(sys.argv[1], sys.argv[2])
