"""Benchmarks that print numbers (never asserted in tests).

Compile time is reported apart from run time; every result names the device.
"""

from __future__ import annotations

import platform
import statistics
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.config import Config
from graspjax.perception import align_tool, detect_grasp


def device_info() -> dict:
    """The JAX device and software versions, for every benchmark record."""
    device = jax.devices()[0]
    return {
        "platform": device.platform,
        "device": getattr(device, "device_kind", str(device)),
        "device_count": jax.device_count(),
        "jax": jax.__version__,
        "python": platform.python_version(),
        "host": platform.node(),
        "command": " ".join(["graspjax", *sys.argv[1:]]) if sys.argv else "",
    }


def _median_seconds(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _compile(fn, *args) -> tuple[object, float]:
    start = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile()
    return compiled, time.perf_counter() - start


def perception_benchmark(batch: int = 4096, width: int = 160, height: int = 120,
                         repeats: int = 10, unique: int = 256, seed: int = 0,
                         config: Config = Config(), progress=print) -> dict:
    """Images/s of detect_grasp + align_tool batched, and single-image latency after compile."""
    from graspjax.synthetic import random_scene

    camera = Camera.kinect(width, height)
    rng = np.random.default_rng(seed)
    progress(f"rendering {unique} random scenes at {width}x{height} ...")
    scenes = np.stack([random_scene(rng, camera) for _ in range(unique)])
    depth = jnp.asarray(scenes[np.arange(batch) % unique])
    single = jnp.asarray(scenes[0])

    def both(d):
        return (detect_grasp(d, camera, config.detect, config.gripper),
                align_tool(d, camera, config.align))

    results = {"batch": batch, "width": width, "height": height, "unique_scenes": unique,
               "repeats": repeats, **device_info()}
    for name, fn in (("detect+align", both),
                     ("detect", lambda d: detect_grasp(d, camera, config.detect, config.gripper)),
                     ("align", lambda d: align_tool(d, camera, config.align))):
        progress(f"compiling {name} (batch {batch}) ...")
        compiled, compile_s = _compile(jax.vmap(fn), depth)
        jax.block_until_ready(compiled(depth))  # warm-up
        seconds = _median_seconds(lambda c=compiled: c(depth), repeats)
        results[f"{name}_compile_s"] = compile_s
        results[f"{name}_batch_s"] = seconds
        results[f"{name}_images_per_s"] = batch / seconds
    progress("single-image latency ...")
    compiled, compile_s = _compile(both, single)
    jax.block_until_ready(compiled(single))
    results["single_compile_s"] = compile_s
    results["single_latency_ms"] = 1e3 * _median_seconds(lambda: compiled(single),
                                                          max(repeats * 5, 20))
    found = jax.vmap(lambda d: detect_grasp(d, camera, config.detect, config.gripper).found)
    results["grasp_found_fraction"] = float(jnp.mean(jax.jit(found)(jnp.asarray(scenes))))
    return results


def format_perception(r: dict) -> str:
    """A short table of a perception benchmark record."""
    lines = [
        f"device: {r['device']} ({r['platform']}), jax {r['jax']}",
        f"images {r['width']}x{r['height']}, batch {r['batch']}, "
        f"{r['unique_scenes']} distinct random scenes ({100 * r['grasp_found_fraction']:.0f}% graspable)",
        f"{'kernel':<14}{'compile s':>11}{'batch ms':>11}{'images/s':>12}",
    ]
    for name in ("detect+align", "detect", "align"):
        lines.append(f"{name:<14}{r[name + '_compile_s']:>11.1f}{1e3 * r[name + '_batch_s']:>11.1f}"
                     f"{r[name + '_images_per_s']:>12,.0f}")
    lines.append(f"single image (detect+align): {r['single_latency_ms']:.2f} ms after a "
                 f"{r['single_compile_s']:.1f} s compile")
    return "\n".join(lines)
