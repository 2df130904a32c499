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
from graspjax.config import Config, SceneConfig
from graspjax.perception import align_tool, detect_grasp
from graspjax.perception.workspace import block_factors


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


def detect_benchmark(batch: int = 1024, width: int = 640, height: int = 480, repeats: int = 10,
                     unique: int = 64, seed: int = 0, config: Config = Config(),
                     scene: SceneConfig = SceneConfig(), progress=print) -> dict:
    """`graspjax detect` end to end on real-looking images (workspace, support plane, virtual
    view, detect, align): single-image latency and batched images/s, compile time apart.

    Images are `synthetic.random_real_scene` at `width` x `height` (PrimeSense-like
    intrinsics scaled to that size), the workspace leaves out the bottom 15% of the rows.
    The single image goes in as a NumPy array (the transfer is timed); the batch is on the
    device already.
    """
    from graspjax.perception.scene import detect_scene
    from graspjax.realdepth import detect_images, stack_cameras
    from graspjax.synthetic import random_real_scene

    camera = Camera(width, height, 525.0 * width / 640, 525.0 * width / 640, (width - 1) / 2,
                    (height - 1) / 2)
    rng = np.random.default_rng(seed)
    progress(f"rendering {unique} real-looking scenes at {width}x{height} ...")
    scenes = np.stack([random_real_scene(rng, camera) for _ in range(unique)])
    workspace = np.zeros((height, width), bool)
    workspace[: int(0.85 * height)] = True
    depth = jnp.asarray(scenes[np.arange(batch) % unique])
    cameras = stack_cameras([camera] * batch)
    results = {"batch": batch, "width": width, "height": height, "unique_scenes": unique,
               "repeats": repeats, "detect_width": width // block_factors(width, scene)[0],
               "support_width": width // block_factors(width, scene)[1],
               **device_info()}

    progress(f"compiling the batch of {batch} ...")
    t0 = time.perf_counter()
    jax.block_until_ready(detect_images(depth, workspace, cameras, config, scene))
    results["batch_compile_s"] = time.perf_counter() - t0
    seconds = _median_seconds(lambda: detect_images(depth, workspace, cameras, config, scene),
                              repeats)
    results["batch_s"] = seconds
    results["images_per_s"] = batch / seconds

    progress("single-image latency ...")
    single = jax.jit(detect_scene)
    t0 = time.perf_counter()
    jax.block_until_ready(single(scenes[0], workspace, camera, config, scene))
    results["single_compile_s"] = time.perf_counter() - t0
    latencies = []
    for i in range(max(repeats * 5, 20)):  # a different scene each time, NumPy in
        image = scenes[i % unique]
        start = time.perf_counter()
        jax.block_until_ready(single(image, workspace, camera, config, scene))
        latencies.append(time.perf_counter() - start)
    results["single_latency_ms"] = 1e3 * statistics.median(latencies)
    results["single_latency_p90_ms"] = 1e3 * float(np.percentile(latencies, 90))
    found = detect_images(jnp.asarray(scenes), workspace, stack_cameras([camera] * unique),
                          config, scene).found
    results["grasp_found_fraction"] = float(jnp.mean(found))
    return results


def format_detect(r: dict) -> str:
    """A short summary of a `detect_benchmark` record."""
    return (f"device: {r['device']} ({r['platform']}), jax {r['jax']}\n"
            f"real-looking images {r['width']}x{r['height']} (detection width {r['detect_width']}, "
            f"support width {r['support_width']}), "
            f"{r['unique_scenes']} distinct scenes ({100 * r['grasp_found_fraction']:.0f}% with a "
            f"grasp)\n"
            f"single image: {r['single_latency_ms']:.1f} ms median, "
            f"{r['single_latency_p90_ms']:.1f} ms p90, after a {r['single_compile_s']:.1f} s compile\n"
            f"batch of {r['batch']}: {r['images_per_s']:,.0f} images/s "
            f"({1e3 * r['batch_s']:.1f} ms per call) after a {r['batch_compile_s']:.1f} s compile")


def physics_benchmark(letters: str = "abcdef", setup: int = 3, batch: int = 1024,
                      seconds: float = 1.0, config: Config = Config(), progress=print) -> dict:
    """World-steps/s of a scene (settling and grasp execution) and depth images/s.

    Compile time is measured apart. The layout is random (seeded) for `setup`.
    """
    from graspjax.geometry import look_down
    from graspjax.sim import layout
    from graspjax.sim.scene import build_scene
    from graspjax.sim.world import GraspPose, Simulator, render

    start = time.perf_counter()
    scene = build_scene(letters, config.gripper, config.sim, objects_collide=setup != 1)
    sim = Simulator(scene)
    build_s = time.perf_counter() - start
    n = scene.num_objects
    keys = jax.vmap(lambda i: layout.layout_key(0, setup, i))(jnp.arange(batch))
    if setup == 1:
        pos, quat, active = jax.vmap(lambda k, t: layout.single(k, t, n, config.layout))(
            keys, jnp.arange(batch) % n)
    elif setup == 2:
        pos, quat, active = jax.vmap(lambda k: layout.grouped(k, scene.footprint_radius,
                                                              config.layout))(keys)
    else:
        pos, quat, active = jax.vmap(lambda k: layout.dense(k, scene.object_points,
                                                            config.layout))(keys)
    data = sim.reset(sim.empty(batch), pos, quat, active)
    seg = config.sim.segment_steps * config.sim.timestep
    progress(f"compiling the physics of {letters} (batch {batch}) ...")
    t0 = time.perf_counter()
    data = jax.block_until_ready(sim.hold_still(data, seg))
    compile_s = time.perf_counter() - t0
    data = jax.block_until_ready(sim.hold_still(data, 0.5))  # let the drop settle a little

    progress("timing settling ...")
    t0 = time.perf_counter()
    data = jax.block_until_ready(sim.hold_still(data, seconds))
    settle_s = time.perf_counter() - t0
    steps = config.sim.segments(seconds) * config.sim.segment_steps

    # A top-down grasp over each world's first active object (physics with finger contacts).
    kin = sim.kinematics(data)
    first = jnp.argmax(active, axis=1)
    centre = kin.xpos[jnp.arange(batch), jnp.asarray(scene.object_body)[first]]
    grasp = GraspPose(tcp=centre + jnp.array([0.0, 0.0, 0.01]),
                      approach=jnp.broadcast_to(jnp.array([0.0, 0.0, -1.0]), (batch, 3)),
                      closing=jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), (batch, 3)),
                      valid=jnp.ones(batch, bool))
    sim.execute(data, grasp, first)  # compile the helpers
    t0 = time.perf_counter()
    _, attempt = sim.execute(data, grasp, first)
    execute_s = time.perf_counter() - t0
    s = config.sim
    execute_steps = s.segment_steps * sum(s.segments(t) for t in (s.approach_time, s.close_time,
                                                                   s.lift_time, s.hold_time))

    camera = config.camera.camera()
    rot, eye = look_down(jnp.array([0.0, 0.0, 0.55]))
    draw = jax.jit(jax.vmap(lambda d: render(scene, d, rot, eye, camera, config.camera)))
    t0 = time.perf_counter()
    jax.block_until_ready(draw(kin))
    render_compile_s = time.perf_counter() - t0
    render_s = _median_seconds(lambda: draw(kin), 5)
    return {
        "scene": letters, "setup": setup, "batch": batch, "build_s": build_s,
        "compile_s": compile_s, "settle_world_steps_per_s": batch * steps / settle_s,
        "execute_world_steps_per_s": batch * execute_steps / execute_s,
        "execute_s": execute_s, "grasp_success_fraction": float(np.mean(attempt.outcome == 0)),
        "render_compile_s": render_compile_s, "render_images_per_s": batch / render_s,
        "render_resolution": [camera.width, camera.height],
        "ncon": int(sim.empty(1)._impl.ncon),
        **device_info(),
    }


def format_physics(r: dict) -> str:
    return (f"device: {r['device']} ({r['platform']}), jax {r['jax']}\n"
            f"scene {r['scene']}, setup {r['setup']}, batch {r['batch']} worlds, "
            f"{r['ncon']} contact slots; physics compile {r['compile_s']:.1f} s\n"
            f"settling:  {r['settle_world_steps_per_s']:>12,.0f} world-steps/s\n"
            f"execution: {r['execute_world_steps_per_s']:>12,.0f} world-steps/s "
            f"({100 * r['grasp_success_fraction']:.0f}% of blind top-down grasps lifted)\n"
            f"rendering: {r['render_images_per_s']:>12,.0f} depth images/s at "
            f"{r['render_resolution'][0]}x{r['render_resolution'][1]} "
            f"(compile {r['render_compile_s']:.1f} s)")


def pipeline_benchmark(objects: str = "abcdef", setups: tuple[int, ...] = (1,), trials: int = 100,
                       batch: int | None = None, config: Config = Config(),
                       progress=print) -> dict:
    """Grasp attempts/s end to end, and the share of time in physics, perception and rendering.

    The job runs twice with the same seed: the first run includes compilation,
    the second is timed as the steady state.
    """
    from graspjax.experiment import Job, default_batch, round_runner, run_jobs
    from graspjax.geometry import look_down
    from graspjax.sim.world import render

    job = Job(tuple(objects), tuple(setups), trials)
    size = batch or default_batch(len(job.worlds))
    progress(f"first run (compiles): {len(job.worlds)} worlds x {len(job.objects)} attempts ...")
    t0 = time.perf_counter()
    run_jobs([job], config, 0, size)
    first_s = time.perf_counter() - t0
    progress("second run (steady state) ...")
    t0 = time.perf_counter()
    rows, timings = run_jobs([job], config, 0, size)
    wall_s = time.perf_counter() - t0
    physics_s = sum(t["physics_s"] for t in timings)
    perception_s = sum(t["perception_s"] for t in timings)

    # Rendering alone, on a batch of this scene, to split it out of perception.
    runner = round_runner(job, config)
    sim, camera = runner.sim, config.camera.camera()
    rot, eye = look_down(jnp.array([0.0, 0.0, config.procedure.camera_height]))
    data = sim.kinematics(sim.empty(size))
    draw = jax.jit(jax.vmap(lambda d: render(sim.scene, d, rot, eye, camera, config.camera)))
    jax.block_until_ready(draw(data))
    per_batch = _median_seconds(lambda: draw(data), 5)
    images = (2 + config.procedure.max_reorientations) * len(job.objects)  # per world and round
    chunks = -(-len(job.worlds) // size)
    render_s = per_batch * images * chunks
    attempts = len(rows)
    return {
        "objects": objects, "setups": list(setups), "trials": trials, "batch": size,
        "attempts": attempts, "success_rate": float(np.mean([r["success"] for r in rows])),
        "first_run_s": first_s, "wall_s": wall_s, "compile_s_estimate": first_s - wall_s,
        "attempts_per_s": attempts / wall_s,
        "physics_share": physics_s / wall_s, "perception_share": perception_s / wall_s,
        "render_share": render_s / wall_s, "render_images_per_s": size / per_batch,
        **device_info(),
    }


def format_pipeline(r: dict) -> str:
    return (f"device: {r['device']} ({r['platform']}), jax {r['jax']}\n"
            f"objects {r['objects']}, setups {r['setups']}, {r['trials']} trials, batch {r['batch']}"
            f": {r['attempts']} attempts ({100 * r['success_rate']:.0f}% success)\n"
            f"first run {r['first_run_s']:.1f} s (compiles ~{r['compile_s_estimate']:.1f} s), "
            f"steady {r['wall_s']:.1f} s = {r['attempts_per_s']:,.1f} attempts/s\n"
            f"time shares: physics {100 * r['physics_share']:.0f}%, perception incl. rendering "
            f"{100 * r['perception_share']:.0f}% (rendering alone ~{100 * r['render_share']:.0f}%)")
