"""Benchmarks that print numbers (never asserted in tests).

Compile time is reported apart from run time; every result names the device.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.config import Config, RealImageConfig, for_device
from graspjax.perception import align_tool, detect_grasp
from graspjax.perception.support import known_support
from graspjax.perception.target import best_candidate, follow_target, standing_candidates
from graspjax.perception.workspace import block_factors
from graspjax.provenance import device_line, provenance
from graspjax.schema import BENCH_FIELDS, PERCEPTION_KERNELS, PROVENANCE_FIELDS


def median_seconds(fn, repeats: int) -> float:
    """Median wall time of `repeats` calls of `fn`, each waited for (benchmarks, experiments)."""
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
    from graspjax.synthetic import random_scene, top_down_pose

    config = for_device(config, jax.default_backend())  # the settings of the device it runs on
    camera = Camera.kinect(width, height)
    rng = np.random.default_rng(seed)
    progress(f"rendering {unique} random scenes at {width}x{height} ...")
    scenes = np.stack([random_scene(rng, camera) for _ in range(unique)])
    depth = jnp.asarray(scenes[np.arange(batch) % unique])
    single = jnp.asarray(scenes[0])

    def both(d):
        return (detect_grasp(d, camera, config.detect, config.gripper),
                align_tool(d, camera, config.align))

    def target(d):
        """A simulated view's depth-only target steps: the pixels above the calibrated table
        (`random_scene`'s camera, 0.5 m straight down), then the surface around the point of
        the nearest one, found again from that point (`target.follow_target`)."""
        rotation, position = (jnp.asarray(x, jnp.float32) for x in top_down_pose(0.5))
        table = known_support(rotation, position, jnp.array([0.0, 0.0, 1.0]), 0.0)
        candidate, _, _ = standing_candidates(d, camera, table,
                                              min_height=config.perception.min_height,
                                              tolerance=config.detect.surface_tolerance)
        _, (u, v) = best_candidate(candidate, -d)
        point = camera.unproject(jnp.stack([u, v]).astype(jnp.float32), d[v, u])
        return follow_target(d, camera, candidate, point, config.perception.surface_step,
                             config.perception.follow_distance)[0]

    def view(d):
        surface = target(d)
        return (detect_grasp(d, camera, config.detect, config.gripper, seed_mask=surface),
                align_tool(d, camera, config.align, seed_mask=surface))

    results = {"batch": batch, "width": width, "height": height, "unique_scenes": unique,
               "repeats": repeats, **provenance()}
    for name, fn in (("detect+align", both),
                     ("detect", lambda d: detect_grasp(d, camera, config.detect, config.gripper)),
                     ("align", lambda d: align_tool(d, camera, config.align)),
                     ("target", target), ("view", view)):
        progress(f"compiling {name} (batch {batch}) ...")
        compiled, compile_s = _compile(jax.vmap(fn), depth)
        jax.block_until_ready(compiled(depth))  # warm-up
        seconds = median_seconds(lambda c=compiled: c(depth), repeats)
        results[f"{name}_compile_s"] = compile_s
        results[f"{name}_batch_s"] = seconds
        results[f"{name}_images_per_s"] = batch / seconds
    progress("single-image latency ...")
    compiled, compile_s = _compile(both, single)
    jax.block_until_ready(compiled(single))
    results["single_compile_s"] = compile_s
    results["single_latency_ms"] = 1e3 * median_seconds(lambda: compiled(single),
                                                          max(repeats * 5, 20))
    found = jax.vmap(lambda d: detect_grasp(d, camera, config.detect, config.gripper).found)
    results["grasp_found_fraction"] = float(jnp.mean(jax.jit(found)(jnp.asarray(scenes))))
    return bench_record("perception", results)


def bench_record(what: str, values: dict) -> dict:
    """A benchmark's record in `schema.BENCH_FIELDS[what]`'s order, then the provenance; a
    field missing or not in the schema is a bug here, not the user's."""
    fields = (*BENCH_FIELDS[what], *PROVENANCE_FIELDS)
    if set(values) != set(fields):
        raise AssertionError(f"{what} record: {sorted(set(values) ^ set(fields))} differ from "
                             "schema.BENCH_FIELDS")
    return {name: values[name] for name in fields}


def format_perception(r: dict) -> str:
    """A short table of a perception benchmark record."""
    lines = [
        device_line(r),
        f"images {r['width']}x{r['height']}, batch {r['batch']}, "
        f"{r['unique_scenes']} distinct random scenes ({100 * r['grasp_found_fraction']:.0f}% graspable)",
        f"{'kernel':<14}{'compile s':>11}{'batch ms':>11}{'images/s':>12}",
    ]
    for name in PERCEPTION_KERNELS:
        lines.append(f"{name:<14}{r[name + '_compile_s']:>11.1f}{1e3 * r[name + '_batch_s']:>11.1f}"
                     f"{r[name + '_images_per_s']:>12,.0f}")
    lines.append(f"single image (detect+align): {r['single_latency_ms']:.2f} ms after a "
                 f"{r['single_compile_s']:.1f} s compile")
    lines.append("target: a simulated view's depth-only target steps (candidates above the table, "
                 "the followed surface); view: target, detect and align on it")
    return "\n".join(lines)


def detect_workload(width: int = 640, height: int = 480, unique: int = 64, seed: int = 0
                    ) -> tuple[Camera, np.ndarray, np.ndarray]:
    """`graspjax bench detect`'s images, for it and the experiments that profile it: the camera
    (PrimeSense-like intrinsics scaled to `width`), the workspace (H, W) bool (the bottom 15% of
    the rows left out) and `unique` `synthetic.random_real_scene` depth images (unique, H, W)."""
    from graspjax.synthetic import random_real_scene

    camera = Camera(width, height, 525.0 * width / 640, 525.0 * width / 640, (width - 1) / 2,
                    (height - 1) / 2)
    rng = np.random.default_rng(seed)
    scenes = np.stack([random_real_scene(rng, camera) for _ in range(unique)])
    workspace = np.zeros((height, width), bool)
    workspace[: int(0.85 * height)] = True
    return camera, workspace, scenes


def detect_benchmark(batch: int = 1024, width: int = 640, height: int = 480, repeats: int = 10,
                     unique: int = 64, seed: int = 0, config: Config = Config(),
                     image: RealImageConfig = RealImageConfig(), progress=print,
                     profile: str | None = None) -> dict:
    """`graspjax detect` end to end on real-looking images (workspace, support plane, virtual
    view, detect, align): single-image latency and batched images/s, compile time apart.

    Images: `detect_workload` (`synthetic.random_real_scene` at `width` x `height`). The
    single image goes in as a NumPy array (the transfer is timed); the batch is on the
    device already. `profile`: a folder where one more call plays under JAX's profiler
    (`bench_profile`), the one `graspjax detect` makes on this device (one image on a CPU, the
    batch elsewhere: `profiled_call`): its trace, `kernels.csv` (device time per compiled
    operation and the line it was traced from) and a printed summary in the record."""
    from graspjax.imagefiles.batches import default_image_batch, detect_batch, detect_single, stack_cameras

    config = for_device(config, jax.default_backend(), images=True)  # the settings of the device it runs on
    progress(f"rendering {unique} real-looking scenes at {width}x{height} ...")
    camera, workspace, scenes = detect_workload(width, height, unique, seed)
    depth = jnp.asarray(scenes[np.arange(batch) % unique])
    cameras = stack_cameras([camera] * batch)
    results = {"batch": batch, "width": width, "height": height, "unique_scenes": unique,
               "repeats": repeats, "detect_width": width // block_factors(width, image)[0],
               "support_width": width // block_factors(width, image)[1], **provenance()}

    progress(f"compiling the batch of {batch} ...")
    t0 = time.perf_counter()
    jax.block_until_ready(detect_batch(depth, workspace, cameras, config, image))
    results["batch_compile_s"] = time.perf_counter() - t0
    seconds = median_seconds(lambda: detect_batch(depth, workspace, cameras, config, image),
                              repeats)
    results["batch_s"] = seconds
    results["images_per_s"] = batch / seconds

    progress("single-image latency ...")
    single = detect_single  # graspjax detect's program on a CPU
    t0 = time.perf_counter()
    jax.block_until_ready(single(scenes[0], workspace, camera, config, image))
    results["single_compile_s"] = time.perf_counter() - t0
    latencies = []
    for i in range(max(repeats * 5, 20)):  # a different scene each time, NumPy in
        scene = scenes[i % unique]
        start = time.perf_counter()
        jax.block_until_ready(single(scene, workspace, camera, config, image))
        latencies.append(time.perf_counter() - start)
    results["single_latency_ms"] = 1e3 * statistics.median(latencies)
    results["single_latency_p90_ms"] = 1e3 * float(np.percentile(latencies, 90))
    found = detect_batch(jnp.asarray(scenes), workspace, stack_cameras([camera] * unique),
                          config, image).found
    results["grasp_found_fraction"] = float(jnp.mean(found))
    results.update(profile=None, profiled_call=None, profiled_s=None, profile_summary=None)
    if profile:
        from graspjax.bench_profile import profile_call, summary

        call, fn, args = (("single", single, (scenes[0], workspace, camera))  # as `graspjax
                          if default_image_batch() == 1  # detect` calls this device
                          else ("batch", detect_batch, (depth, workspace, cameras)))
        progress(f"one more {call} call under the profiler ...")
        traced, kernels = profile_call(fn, (*args, config, image), Path(profile))
        results.update(profile=profile, profiled_call=call, profiled_s=traced,
                       profile_summary=summary(kernels, traced))
    return bench_record("detect", results)


def format_detect(r: dict) -> str:
    """A short summary of a `detect_benchmark` record."""
    return (f"{device_line(r)}\n"
            f"real-looking images {r['width']}x{r['height']} (detection width {r['detect_width']}, "
            f"support width {r['support_width']}), "
            f"{r['unique_scenes']} distinct scenes ({100 * r['grasp_found_fraction']:.0f}% with a "
            f"grasp)\n"
            f"single image: {r['single_latency_ms']:.1f} ms median, "
            f"{r['single_latency_p90_ms']:.1f} ms p90, after a {r['single_compile_s']:.1f} s compile\n"
            f"batch of {r['batch']}: {r['images_per_s']:,.0f} images/s "
            f"({1e3 * r['batch_s']:.1f} ms per call) after a {r['batch_compile_s']:.1f} s compile"
            + (f"\none {r['profiled_call']} call profiled:\n{r['profile_summary']}\n"
               f"(kernels: {r['profile']}/kernels.csv)" if r["profile"] else ""))


@dataclasses.dataclass(frozen=True)
class PhysicsWorkload:
    """`batch` freshly placed worlds of one scene and setup, and their vmapped `world.simulate`."""

    scene: object  # sim.scene.Scene
    spec: object  # procedure.WorldSpec (batch,)
    data: object  # mjx.Data (batch,): the layouts placed, not yet settled (a pile's objects wait)
    drops: object  # pile.Drops (batch,): what the first settle drops (Setup 3's pile)
    no_drops: object  # pile.Drops (batch,): nothing (every later call)
    simulate: object  # jitted (data, spec, drops, grasp, target, segments, execute) -> (data,
    # Execution)
    idle: object  # GraspPose (batch,) that is never executed
    zero: jax.Array  # (batch,) int32 zeros


def physics_workload(letters: str, setup: int, batch: int, config: Config) -> PhysicsWorkload:
    """The worlds `graspjax bench physics` times: the per-world functions of a run
    (`procedure.start_round`, `world.simulate`) vmapped over `batch` worlds of `setup`."""
    from graspjax.config import stack_configs
    from graspjax.procedure import WorldSpec, start_round
    from graspjax.sim import pile, world
    from graspjax.sim.physics import WORLDS
    from graspjax.sim.scene import mjx, scene_for
    from graspjax.sim.world import GraspPose, physics_model

    scene = scene_for(tuple(letters), config, setup != 1)
    n = scene.num_objects
    order = np.tile(np.arange(n, dtype=np.int32), (batch, 1))
    order[:, 0] = np.arange(batch) % n  # Setup 1: world i holds object i mod n
    spec = WorldSpec(seed=np.zeros(batch, np.int32), setup=np.full(batch, setup, np.int32),
                     trial=np.arange(batch, dtype=np.int32), order=order,
                     members=np.ones((batch, n), bool), config=stack_configs([config] * batch))
    template = mjx.make_data(scene.mj_model)
    state = jax.jit(jax.vmap(lambda w: start_round(scene, template, w, (setup,))))(spec)

    def run(d, w, drops, grasp, target, segments, execute):
        return world.simulate(scene, physics_model(scene, w.config), d, grasp, target, segments,
                              execute, w.config, drops=drops)

    simulate = jax.jit(jax.vmap(run, in_axes=(0, 0, 0, 0, 0, 0, None), axis_name=WORLDS),
                       static_argnums=6)
    nan = jnp.full((batch, 3), jnp.nan)
    nothing = jax.vmap(lambda _: pile.no_drops(n))(jnp.arange(batch))
    return PhysicsWorkload(scene, spec, state.data, state.drops, nothing, simulate,
                           GraspPose(nan, nan, nan, jnp.zeros(batch, bool)),
                           jnp.zeros(batch, jnp.int32))


def physics_benchmark(letters: str = "abcdef", setup: int = 3, batch: int = 1024,
                      seconds: float = 1.0, config: Config = Config(), progress=print) -> dict:
    """World-steps/s of a scene (settling and grasp execution) and depth images/s
    (`physics_workload`); compile time apart."""
    from graspjax.geometry import look_down
    from graspjax.privates import impl
    from graspjax.sim.scene import mjx, scene_for
    from graspjax.sim.world import GraspPose, depth_image

    start = time.perf_counter()
    scene_for(tuple(letters), config, setup != 1)  # built once, shared with the workload
    build_s = time.perf_counter() - start
    work = physics_workload(letters, setup, batch, config)
    scene, spec, data, simulate, idle, zero = (work.scene, work.spec, work.data, work.simulate,
                                               work.idle, work.zero)
    nothing = work.no_drops
    s, order = config.sim, np.asarray(spec.order)
    settle = s.segments(seconds)
    progress(f"compiling the physics of {letters} (batch {batch}) ...")
    t0 = time.perf_counter()
    jax.block_until_ready(simulate(data, spec, nothing, idle, zero, zero + 1, False))
    compile_s = time.perf_counter() - t0
    # The layouts settle first, dropped as a run drops them: a pile at rest has its contacts.
    extra = {1: s.drop_settle_time, 2: s.group_settle_time, 3: s.pile_settle_time}[setup]
    drop = s.segments(s.settle_time + extra)
    data, _ = jax.block_until_ready(simulate(data, spec, work.drops, idle, zero, zero + drop, False))

    progress("timing settling ...")
    t0 = time.perf_counter()
    data, _ = jax.block_until_ready(simulate(data, spec, nothing, idle, zero, zero + settle, False))
    settle_s = time.perf_counter() - t0

    # A top-down grasp over each world's first object (physics with finger contacts).
    kin = jax.jit(jax.vmap(lambda d: mjx.kinematics(scene.model, d)))(data)
    first = jnp.asarray(order[:, 0])
    centre = kin.xpos[jnp.arange(batch), jnp.asarray(scene.object_body)[first]]
    grasp = GraspPose(tcp=centre + jnp.array([0.0, 0.0, 0.01]),
                      approach=jnp.broadcast_to(jnp.array([0.0, 0.0, -1.0]), (batch, 3)),
                      closing=jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), (batch, 3)),
                      valid=jnp.ones(batch, bool))
    jax.block_until_ready(simulate(data, spec, nothing, grasp, first, zero, True))  # compile
    t0 = time.perf_counter()
    _, done = jax.block_until_ready(simulate(data, spec, nothing, grasp, first, zero, True))
    execute_s = time.perf_counter() - t0
    execute_steps = s.segment_steps * sum(s.segments(t) for t in (s.approach_time, s.close_time,
                                                                   s.lift_time, s.hold_time))

    camera = config.camera.camera()
    rot, eye = look_down(jnp.array([0.0, 0.0, 0.55]))
    keys = jax.random.split(jax.random.key(0), batch)  # the sensor model's noise
    draw = jax.jit(jax.vmap(lambda d, k: depth_image(scene, d, rot, eye, camera, config.camera, k)))
    t0 = time.perf_counter()
    jax.block_until_ready(draw(kin, keys))
    render_compile_s = time.perf_counter() - t0
    render_s = median_seconds(lambda: draw(kin, keys), 5)
    return bench_record("physics", {
        "scene": letters, "setup": setup, "batch": batch, "build_s": build_s,
        "compile_s": compile_s,
        "settle_world_steps_per_s": batch * settle * s.segment_steps / settle_s,
        "execute_world_steps_per_s": batch * execute_steps / execute_s,
        "execute_s": execute_s,
        "grasp_success_fraction": float(np.mean(np.asarray(done.outcome) == 0)),
        "render_compile_s": render_compile_s, "render_images_per_s": batch / render_s,
        "render_resolution": [camera.width, camera.height], "sensor": config.camera.sensor,
        "ncon": int(impl(data).ncon),  # static: the same for every world
        **provenance(),
    })


def format_physics(r: dict) -> str:
    return (f"{device_line(r)}\n"
            f"scene {r['scene']}, setup {r['setup']}, batch {r['batch']} worlds, "
            f"{r['ncon']} contact slots; physics compile {r['compile_s']:.1f} s\n"
            f"settling:  {r['settle_world_steps_per_s']:>12,.0f} world-steps/s\n"
            f"execution: {r['execute_world_steps_per_s']:>12,.0f} world-steps/s "
            f"({100 * r['grasp_success_fraction']:.0f}% of blind top-down grasps lifted)\n"
            f"rendering: {r['render_images_per_s']:>12,.0f} depth images/s at "
            f"{r['render_resolution'][0]}x{r['render_resolution'][1]}, {r['sensor']} sensor "
            f"(compile {r['render_compile_s']:.1f} s)")


def pipeline_benchmark(objects: str = "abcdef", setups: tuple[int, ...] = (1,), trials: int = 100,
                       batch: int | None = None, config: Config = Config(),
                       progress=print, profile: str | None = None) -> dict:
    """Grasp attempts/s end to end (layout, settle, overview, centre, detect, re-align, execute,
    judge, rows on the host), compile time apart.

    The job's programs compile first, then every chunk runs (no overlap of compiling and
    running); the run is timed from its first chunk to its last rows. `profile`: a folder
    where the first round plays under JAX's profiler (`bench_profile.FirstRound`): its trace,
    and `kernels.csv`, the device time of each compiled operation with the source line it
    came from (the run's attempts/s then include the profiler's overhead).
    """
    import os

    from graspjax.batch.plan import Job, default_batch, plan
    from graspjax.batch.rows import RunColumns, attempt_rows
    from graspjax.batch.schedule import run_chunks

    job = Job(tuple(objects), tuple(setups), trials)
    size = batch or default_batch()
    groups = plan([job], [config], 0)
    columns = RunColumns(run_id="", points=[config], keys=[], base=config)
    progress(f"{sum(len(g.worlds) for g in groups)} worlds, up to {job.attempts(config)} attempts, "
             f"batch {size} ...")
    t0 = time.perf_counter()
    trace_s, compile_s, frames, first = 0.0, 0.0, [], None
    window = None
    if profile:
        from graspjax.bench_profile import FirstRound

        window = FirstRound(Path(profile) / "trace")
    for result in run_chunks(groups, [config], size, log=progress, overlap=False,
                             progress=window.attempted if window else lambda n: None,
                             status=window.status if window else lambda s: None):
        trace_s += result.timings["trace_s"]
        compile_s += result.timings["compile_s"]
        first = first or t0 + trace_s + compile_s
        frames.append(attempt_rows(result, columns))
    wall_s = time.perf_counter() - first
    profiled = {"profile": None, "profiled_s": None, "profile_summary": None}
    if window is not None:
        window.close()
        from graspjax.batch.program import program
        from graspjax.bench_profile import attributed, device_ops, summary

        texts = [t for g in groups for t in program(g, size, keep_views=False).compiled_texts()]
        kernels = attributed(device_ops(window.folder), texts)
        kernels.to_csv(Path(profile) / "kernels.csv", index=False)
        profiled = {"profile": str(profile), "profiled_s": window.seconds,
                    "profile_summary": summary(kernels, window.seconds)}
    attempts = sum(int((f["attempt"] >= 0).sum()) for f in frames)
    success = float(np.mean(np.concatenate([f["success"].to_numpy() for f in frames])))
    return bench_record("pipeline", {
        "objects": objects, "setups": list(setups), "trials": trials, "batch": size,
        "attempts": attempts, "success_rate": success, "trace_s": trace_s,
        "compile_s": compile_s,
        "run_s": wall_s, "attempts_per_s": attempts / wall_s,
        "deterministic": "xla_gpu_deterministic_ops=true" in os.environ.get("XLA_FLAGS", ""),
        **profiled, **provenance(),
    })


def format_pipeline(r: dict) -> str:
    return (f"{device_line(r)}, deterministic ops {'on' if r['deterministic'] else 'off'}\n"
            f"objects {r['objects']}, setups {r['setups']}, {r['trials']} trials, batch {r['batch']}"
            f": {r['attempts']} attempts ({100 * r['success_rate']:.0f}% success)\n"
            f"trace {r['trace_s']:.1f} s, compile {r['compile_s']:.1f} s, "
            f"run {r['run_s']:.1f} s = "
            f"{r['attempts_per_s']:,.1f} attempts/s"
            + (f"\n{r['profile_summary']}\n(kernels: {r['profile']}/kernels.csv)"
               if r["profile"] else ""))


def measure(what: str, *, config: Config, image: RealImageConfig, objects: str, setups: tuple[int, ...],
            trials: int, seconds: float, batch: int | None, width: int | None, height: int | None,
            repeats: int, profile: str | None = None, progress=print) -> tuple[dict, str]:
    """One benchmark (`perception`, `detect`, `physics` or `pipeline`; `bench_finish` is
    the fifth) with the device-sized defaults: its record and its printed summary."""
    gpu = jax.default_backend() == "gpu"
    if what == "perception":
        result = perception_benchmark(batch=batch or 4096, width=width or 160, height=height or 120,
                                      repeats=repeats, config=config, progress=progress)
        return result, format_perception(result)
    if what == "detect":
        result = detect_benchmark(batch=batch or (1024 if gpu else 32), width=width or 640,
                                  height=height or 480, repeats=repeats, config=config,
                                  image=image, progress=progress, profile=profile)
        return result, format_detect(result)
    if what == "pipeline":
        result = pipeline_benchmark(objects, setups, trials, batch, config, progress, profile)
        return result, format_pipeline(result)
    if what == "physics":
        result = physics_benchmark(objects, setups[0], batch or (4096 if gpu else 16), seconds,
                                   config, progress)
        return result, format_physics(result)
    raise ValueError(f"unknown benchmark {what!r}")
