"""Where `graspjax detect`'s batched time goes: its stages timed cumulatively on one batch.

    python3 experiments/detect_profile.py [BATCH]

Each line times everything before it plus one stage (working views; support plane; virtual
view and targets; the whole pipeline; the whole with one target instead of three), then the
detector and the alignment alone on a 192-pixel window. Images: `synthetic.random_real_scene`
at 640 x 480, as `graspjax bench detect`. Results: results/benchmarks/history/detect.md.
"""

import dataclasses
import statistics
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.bench import detect_workload
from graspjax.camera import Camera
from graspjax.config import Config, RealImageConfig
from graspjax.perception.align import align_tool
from graspjax.perception.grasp import detect_grasp
from graspjax.perception.real_image import _targets, detect_real_image
from graspjax.perception.support import support_plane
from graspjax.perception.workspace import working_views

W, H, WINDOW = 640, 480, 192
CAMERA, WORKSPACE, SCENES = detect_workload(W, H)  # graspjax bench detect's images
CONFIG, SCENE = Config(), RealImageConfig()


def views(depth):
    return working_views(depth, WORKSPACE, CAMERA, SCENE, CONFIG.detect.surface_tolerance)


def support_only(depth):
    fine, _, work, work_camera = views(depth)
    return fine.sum() + support_plane(work, work_camera, SCENE).distance


def with_targets(depth):
    found = _targets(depth, WORKSPACE, CAMERA, CONFIG, SCENE)
    return found.fine.sum() + jnp.sum(jnp.where(found.candidate, found.score, 0.0))


def timed(name: str, fn, x) -> None:
    f = jax.jit(jax.vmap(fn))
    t0 = time.perf_counter()
    jax.block_until_ready(f(x))
    compile_s = time.perf_counter() - t0
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        jax.block_until_ready(f(x))
        times.append(time.perf_counter() - t0)
    s = statistics.median(times)
    print(f"{name:<32} {1e3 * s:9.1f} ms per batch {x.shape[0] / s:10,.0f} images/s "
          f"(compile {compile_s:.1f} s)", flush=True)


def main() -> None:
    batch = int(sys.argv[1]) if len(sys.argv) > 1 else 16
    depth = jnp.asarray(SCENES[np.arange(batch) % 64])
    one_target = dataclasses.replace(SCENE, max_targets=1)
    top, left = (H - WINDOW) // 2, (W - WINDOW) // 2
    window = depth[:, top:top + WINDOW, left:left + WINDOW]
    window_camera = Camera(WINDOW, WINDOW, 525.0, 525.0, (WINDOW - 1) / 2, (WINDOW - 1) / 2)
    seed = jnp.zeros((WINDOW, WINDOW), bool).at[WINDOW // 2 - 1:WINDOW // 2 + 2,
                                                WINDOW // 2 - 1:WINDOW // 2 + 2].set(True)
    print(f"{jax.devices()[0].device_kind}, batch {batch}")
    timed("working views", lambda d: sum(v.sum() for v in views(d)[::2]), depth)
    timed("+ support plane", support_only, depth)
    timed("+ virtual view, targets", with_targets, depth)
    timed("whole pipeline", lambda d: detect_real_image(d, WORKSPACE, CAMERA, CONFIG, SCENE).position,
          depth)
    timed("whole pipeline, one target", lambda d: detect_real_image(d, WORKSPACE, CAMERA, CONFIG,
                                                                one_target).position, depth)
    timed("detector, 192-pixel window", lambda w: detect_grasp(
        w, window_camera, CONFIG.detect, CONFIG.gripper, seed_mask=seed).position, window)
    timed("alignment, 192-pixel window", lambda w: align_tool(
        w, window_camera, CONFIG.align, jax.random.key(0), seed_mask=seed).normal, window)


if __name__ == "__main__":
    main()
