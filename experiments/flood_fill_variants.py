"""The flood fill and the window warp before and after packing (issue 19's speed), in one process.

    python3 experiments/flood_fill_variants.py [BATCH]

Variants of `cluster.surface_cluster` (every flood fill of the detector, the alignment and the
real-image targets) and of the views' warp (`virtual.warp_depth_and_values`, the support view's
and every detection window's; before stop 71 the windows' warp was not swapped), swapped in by
name:

- before: bool images dilated 4 steps per loop iteration (unrolled), the warp's rotations as
  matrix products (the code before this change, kept here as the reference);
- packed: rows packed 32 pixels to a uint32 word, 8 dilations per check, each its own inner
  loop step (`fori_loop`); the warp's rotations written out per pixel (the package now);
- packed-unrolled: the same with the 8 dilations unrolled into one loop body.

For each: `graspjax detect`'s whole pipeline batched (`detect_batch`, top 1 and top 5, images/s)
and one image at a time (median latency), on `synthetic.random_real_scene` at 640 x 480 as
`graspjax bench detect`; and whether every variant gives the same grasps as `before`.
Results: results/benchmarks/history/detect.md.
"""

import statistics
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

import graspjax.perception.align as align_module
import graspjax.perception.cluster as cluster_module
import graspjax.perception.real_image as real_image_module
import graspjax.perception.virtual as virtual_module
import graspjax.perception.window as window_module
from graspjax.bench import detect_workload, median_seconds
from graspjax.config import Config, RealImageConfig
from graspjax.imagefiles.batches import detect_batch, stack_cameras
from graspjax.perception.real_image import detect_real_image

W, H = 640, 480
CAMERA, WORKSPACE, SCENES = detect_workload(W, H)  # graspjax bench detect's images


def _grow4_bool(region):
    padded = jnp.pad(region, 1)
    return (region | padded[:-2, 1:-1] | padded[2:, 1:-1] | padded[1:-1, :-2] | padded[1:-1, 2:])


def cluster_before(depth, valid, seed, low, high, steps_per_iteration=4):
    allowed = valid & (depth >= low) & (depth <= high)
    start = jnp.zeros(depth.shape, bool).at[seed[1], seed[0]].set(allowed[seed[1], seed[0]])

    def grow(state):
        region, _ = state
        new = region
        for _ in range(steps_per_iteration):
            new = _grow4_bool(new) & allowed
        return new, jnp.any(new != region)

    return lax.while_loop(lambda s: s[1], grow, (start, jnp.array(True)))[0]


def cluster_packed_unrolled(depth, valid, seed, low, high, steps_per_iteration=8):
    allowed = valid & (depth >= low) & (depth <= high)
    start = jnp.zeros(depth.shape, bool).at[seed[1], seed[0]].set(allowed[seed[1], seed[0]])
    allowed_rows = cluster_module._pack_rows(allowed)

    def grow(state):
        region, _ = state
        new = region
        for _ in range(steps_per_iteration):
            new = cluster_module._grow4_packed(new) & allowed_rows
        return new, jnp.any(new != region)

    region, _ = lax.while_loop(lambda s: s[1], grow, (cluster_module._pack_rows(start),
                                                      jnp.array(True)))
    return cluster_module._unpack_rows(region, depth.shape[1])


def warp_before(depth, camera, view, rotation):
    rays = view.rays() @ rotation.T
    forward = rays[..., 2] > 1e-6
    uv = camera.project(jnp.where(forward[..., None], rays, virtual_module._OPTICAL_AXIS))
    iuv = jnp.round(uv).astype(jnp.int32)
    inside = (forward & (iuv[..., 0] >= 0) & (iuv[..., 0] < camera.width)
              & (iuv[..., 1] >= 0) & (iuv[..., 1] < camera.height))
    iuv = jnp.stack([jnp.clip(iuv[..., 0], 0, camera.width - 1),
                     jnp.clip(iuv[..., 1], 0, camera.height - 1)], -1)
    z = depth[iuv[..., 1], iuv[..., 0]]
    ok = inside & cluster_module.valid_mask(z)
    points = camera.unproject(iuv.astype(jnp.float32), jnp.where(ok, z, 0.0))
    return jnp.where(ok, points @ rotation[:, 2], 0.0)


def warps_before(depth, values, camera, view, rotation, fill):
    return (warp_before(depth, camera, view, rotation),
            WARPS(depth, values, camera, view, rotation, fill)[1])


PACKED, WARPS = cluster_module.surface_cluster, virtual_module.warp_depth_and_values
VARIANTS = {"before": (cluster_before, warps_before), "packed": (PACKED, WARPS),
            "packed-unrolled": (cluster_packed_unrolled, WARPS)}


def use(name: str) -> None:
    fill, warps = VARIANTS[name]
    cluster_module.surface_cluster = fill  # target_surface looks it up here
    align_module.surface_cluster = fill
    real_image_module.warp_depth_and_values = warps  # the support view's warp
    window_module.warp_depth_and_values = warps  # every detection window's


def main() -> None:
    batch = int(sys.argv[1]) if len(sys.argv) > 1 else (1024 if jax.default_backend() == "gpu" else 32)
    depth = jnp.asarray(SCENES[np.arange(batch) % 64])
    cameras = stack_cameras([CAMERA] * batch)
    config = Config()
    print(f"{jax.devices()[0].device_kind}, jax {jax.__version__}, batch {batch}", flush=True)
    reference = {}
    rows = []
    for name in VARIANTS:
        use(name)
        for top in (1, 5):
            image = RealImageConfig(top_k=top)
            run = jax.jit(lambda d, c, image=image: detect_batch(d, WORKSPACE, c, config, image))
            t0 = time.perf_counter()
            result = jax.block_until_ready(run(depth, cameras))
            compile_s = time.perf_counter() - t0
            batch_s = median_seconds(lambda run=run: run(depth, cameras), 5)
            single = jax.jit(lambda d, image=image: detect_real_image(d, WORKSPACE, CAMERA,
                                                                       config, image))
            jax.block_until_ready(single(SCENES[0]))
            latency = []
            for i in range(64):
                t0 = time.perf_counter()
                jax.block_until_ready(single(SCENES[i]))
                latency.append(time.perf_counter() - t0)
            grasps = np.asarray(result.ranked.position)
            same = (np.array_equal(grasps, reference[top], equal_nan=True)
                    if top in reference else True)
            reference.setdefault(top, grasps)
            rows.append((name, top, batch / batch_s, 1e3 * statistics.median(latency),
                         compile_s, same))
            print(f"{name:<16} top {top}: {batch / batch_s:8,.0f} images/s, single "
                  f"{1e3 * statistics.median(latency):5.1f} ms, compile {compile_s:5.1f} s, "
                  f"same grasps as before: {same}", flush=True)
    print("\nvariant          top  images/s  single ms  compile s  same")
    for name, top, rate, single_ms, compile_s, same in rows:
        print(f"{name:<16} {top:>3} {rate:9,.0f} {single_ms:10.1f} {compile_s:10.1f}  {same}")


if __name__ == "__main__":
    main()
