"""Shared fixtures: one camera, and jitted kernels compiled once per session."""

import functools
import gc
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from graspjax import Camera, align_tool, detect_grasp
from graspjax.runtime.xla import with_xla_flags
from graspjax.synthetic import analytic_depth, top_down_pose

# A persistent compilation cache makes local reruns fast (CI starts cold); the CLI in a
# subprocess shares it through GRASPJAX_CACHE.
os.environ.setdefault("GRASPJAX_CACHE", os.path.expanduser("~/.cache/graspjax-tests"))
# The suite's runs play in one process: on 2 cores a run of several groups would start a helper
# process that loads its programs again. test_experiment's helper test asks for two.
os.environ["GRASPJAX_PROCESSES"] = "1"
# The flags the CLI sets before JAX starts (`runtime.xla.set_xla_flags`), set here for the whole
# session: XLA_FLAGS is part of a compiled program's cache key, so the programs compiled in this
# process and those of a CLI subprocess share their cache entries only if both see them.
os.environ["XLA_FLAGS"] = with_xla_flags(os.environ.get("XLA_FLAGS", ""))
jax.config.update("jax_compilation_cache_dir", os.environ["GRASPJAX_CACHE"])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)

CAMERA_HEIGHT = 0.5  # metres above the table


# Modules whose tests compile a simulated scene's physics or procedure, or `graspjax detect`'s
# whole program at several image sizes (each 20 s to 2 minutes of XLA on a 2-core CPU cold):
# every test in them is `slow`. `pytest -m "not slow"` runs the rest, the perception kernels,
# files, reports and configuration, in a few minutes (README).
SLOW_MODULES = {"test_experiment", "test_image_batches", "test_bench", "test_jaws", "test_physics",
                "test_procedure", "test_collision", "test_layout_settled", "test_planes",
                "test_solver", "test_convex", "test_scatters", "test_raycast", "test_reuse"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.module.__name__.rsplit(".", 1)[-1] in SLOW_MODULES:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session", autouse=True)
def _warm_late_programs(tmp_path_factory, request):
    """`warm_cache.py` in a second process from the session's start: it compiles the programs of
    `test_experiment`'s runs and the physics programs of `test_physics` into the persistent
    caches while the first modules leave a core idle (XLA compiles mostly on one). Killed at the
    session's end if not done; not started when no slow test runs (`-m "not slow"`), which
    would not use them."""
    if not any(item.get_closest_marker("slow") for item in request.session.items):
        yield
        return
    log = tmp_path_factory.mktemp("warm") / "stderr.txt"
    with open(log, "w") as err:  # a file: a full pipe would stall it
        proc = subprocess.Popen([sys.executable, os.path.join(os.path.dirname(__file__),
                                                              "warm_cache.py")],
                                stdout=subprocess.DEVNULL, stderr=err)
    yield
    if proc.poll() is None:
        proc.kill()
        proc.wait()


def _memory_maps() -> int:
    try:
        with open("/proc/self/maps") as maps:
            return sum(1 for _ in maps)
    except OSError:  # not Linux
        return 0


@pytest.fixture(scope="module", autouse=True)
def _release_compiled_code():
    """Drop the compiled programs after a test module when they hold many memory maps.

    Each XLA:CPU executable keeps its machine code in memory maps of its own; a whole suite in
    one process otherwise reaches Linux's per-process limit (vm.max_map_count, 65530) and LLVM
    aborts while loading the next program. Released only past half the limit, as each release
    costs the session fixtures a recompile (from the persistent cache)."""
    yield
    if _memory_maps() > 30_000:
        jax.clear_caches()
        gc.collect()


@pytest.fixture(scope="session")
def camera():
    return Camera.kinect()


@pytest.fixture(scope="session")
def detect():
    """`detect_grasp` jitted once; configs are static, so each config compiles once."""
    return jax.jit(detect_grasp)


@pytest.fixture(scope="session")
def align():
    return jax.jit(align_tool)


@pytest.fixture(scope="session")
def render(camera):
    """Top-down analytic depth image of solids on a table at z = 0."""
    rotation, eye = top_down_pose(CAMERA_HEIGHT)

    def _render(solids, ground=0.0):
        return analytic_depth(camera, rotation, eye, solids, ground=ground)

    return _render


def world_to_camera(point):
    """Camera-frame coordinates of a world point for the top-down test camera."""
    rotation, eye = top_down_pose(CAMERA_HEIGHT)
    return rotation.T @ (np.asarray(point, float) - eye)


def detect_one(depth, workspace, camera, config=None, image=None):
    """`graspjax detect`'s program on a CPU (`imagefiles.batches.detect_single`: one image, not
    vmapped) on one image, its result as NumPy; `Config()` and `RealImageConfig()` by default."""
    from graspjax.config import Config, RealImageConfig
    from graspjax.imagefiles.batches import detect_single

    result = detect_single(depth, workspace, camera, Config() if config is None else config,
                           RealImageConfig() if image is None else image)
    return jax.tree.map(np.asarray, result)


def assert_trees_close(a, b, rtol=1e-4, atol=1e-5):
    """Integers and booleans equal exactly, floats to float32 reordering noise."""
    def check(x, y):
        x, y = np.asarray(x), np.asarray(y)
        if np.issubdtype(x.dtype, np.floating):
            np.testing.assert_allclose(x, y, rtol=rtol, atol=atol)
        else:
            np.testing.assert_array_equal(x, y)
    jax.tree.map(check, a, b)


# --- simulation: one compiled physics program per scene, shared by every test ---------------
SIM_BATCH = 6  # every physics test uses this many worlds, so each scene compiles once


class Worlds:
    """`SIM_BATCH` worlds of one scene: layouts, settling and grasps through `world.simulate`."""

    def __init__(self, scene):
        from graspjax.config import Config
        from graspjax.sim.physics import WORLDS
        from graspjax.sim.scene import mjx
        from graspjax.sim.world import physics_model, reset, simulate

        self.scene, config = scene, Config()
        self._start = None
        model = physics_model(scene, config)
        template = mjx.make_data(scene.mj_model)

        def one(data, grasp, target, segments, execute, take_out, drops):
            return simulate(scene, model, data, grasp, target, segments, execute, config,
                            take_out=take_out, drops=drops)

        self._reset = jax.jit(jax.vmap(lambda p, q, a, w: reset(scene, template, p, q, a, w)))
        self._kinematics = jax.jit(jax.vmap(lambda d: mjx.kinematics(scene.model, d)))
        # The physics program is compiled ahead of time, right after JAX's caches are cleared.
        # Its lowered text, and so its persistent-cache key, then does not depend on what the
        # session traced before (warm_cache.py compiles the same in a second process), and a
        # later `jax.clear_caches` (`_release_compiled_code`) cannot drop it.
        jax.clear_caches()
        n = scene.num_objects
        data = jax.eval_shape(self.reset, np.zeros((SIM_BATCH, n, 3), np.float32),
                              np.zeros((SIM_BATCH, n, 4), np.float32),
                              np.zeros((SIM_BATCH, n), bool))
        steps = jnp.zeros(SIM_BATCH, jnp.int32)
        self._play = jax.jit(jax.vmap(one, in_axes=(0, 0, 0, 0, None, 0, 0), axis_name=WORLDS)).lower(
            data, self.no_grasp(), steps, steps, jnp.array(False), jnp.zeros(SIM_BATCH, bool),
            self.no_drops()).compile()

    def reset(self, pos, quat, active, walls=None):
        """Worlds with objects at `pos` (B, n, 3), `quat` (B, n, 4), `active` (B, n); the walls
        (`pile.Walls` (side, height, present), one for every world) standing or parked."""
        from graspjax.sim.pile import NO_WALLS, Walls

        walls = NO_WALLS if walls is None else walls
        batched = Walls(*(jnp.full(SIM_BATCH, x, dtype) for x, dtype in (
            (walls.side, jnp.float32), (walls.height, jnp.float32), (walls.present, bool))))
        return self._reset(*map(jnp.asarray, (pos, quat, active)), batched)

    def settle(self, data, seconds: float, drops=None):
        """Settle every world for `seconds`, dropping `drops` (`pile.Drops`, batched; None:
        nothing) as their segments come."""
        segments = self.scene.sim.segments(seconds)
        drops = self.no_drops() if drops is None else jax.tree.map(jnp.asarray, drops)
        return self._play(data, self.no_grasp(), jnp.zeros(SIM_BATCH, jnp.int32),
                          jnp.full(SIM_BATCH, segments, jnp.int32), jnp.array(False),
                          jnp.zeros(SIM_BATCH, bool), drops)[0]

    def execute(self, data, grasp, target, take_out=None):
        """Approach, close, lift, hold, judge: (data, Execution) per world; `take_out` (B,)
        bool: the protocol takes a target that was not lifted out afterwards."""
        grasp = type(grasp)(*(jnp.asarray(x, jnp.float32) for x in (grasp.tcp, grasp.approach,
                                                                    grasp.closing)),
                            jnp.asarray(grasp.valid, bool))  # the compiled program's types
        take_out = jnp.zeros(SIM_BATCH, bool) if take_out is None else jnp.asarray(take_out, bool)
        return self._play(data, grasp, jnp.asarray(target, jnp.int32),
                          jnp.zeros(SIM_BATCH, jnp.int32), jnp.array(True), take_out,
                          self.no_drops())

    def kinematics(self, data):
        return self._kinematics(data)

    def start_rounds(self, setup: int, config=None, seed: int = 0, first: int = 0):
        """`procedure.start_round` of `SIM_BATCH` worlds of one setup (trials or rounds first,
        first + 1, ...; Setup 1: world i holds object i): their `RoundState`s, not settled."""
        from graspjax.config import Config, stack_configs
        from graspjax.procedure import WorldSpec, start_round
        from graspjax.sim.scene import mjx

        scene, config = self.scene, Config() if config is None else config
        n = scene.num_objects
        order = np.tile(np.arange(n, dtype=np.int32), (SIM_BATCH, 1))
        order[:, 0] = np.arange(SIM_BATCH) % n
        spec = WorldSpec(seed=np.full(SIM_BATCH, seed, np.int32),
                         setup=np.full(SIM_BATCH, setup, np.int32),
                         trial=np.arange(first, first + SIM_BATCH, dtype=np.int32), order=order,
                         members=np.ones((SIM_BATCH, n), bool),
                         config=stack_configs([config] * SIM_BATCH))
        if self._start is None:
            template = mjx.make_data(scene.mj_model)
            self._start = jax.jit(jax.vmap(lambda w: start_round(scene, template, w, (1, 2, 3))))
        return self._start(spec)

    def no_drops(self):
        from graspjax.sim.pile import no_drops

        return jax.vmap(lambda _: no_drops(self.scene.num_objects))(jnp.arange(SIM_BATCH))

    @staticmethod
    def no_grasp():
        from graspjax.sim import GraspPose

        nan = jnp.full((SIM_BATCH, 3), jnp.nan, jnp.float32)  # typed: weak types recompile
        return GraspPose(nan, nan, nan, jnp.zeros(SIM_BATCH, bool))


def _stepped_by(step: str):
    """The default configuration with the physics step `step` (`sim.step`)."""
    from graspjax.config import Config, override

    return override(Config(), {"sim.step": step})


def basic_scene(step: str = "graspjax"):
    """The a-f scene with object-object contacts (Setups 2, 3), stepped by `step`."""
    from graspjax.sim import scene_for

    return scene_for(tuple("abcdef"), _stepped_by(step), True)


def industrial_scene(step: str = "graspjax"):
    """The g-l scene (Setup 1; objects never meet), stepped by `step`."""
    from graspjax.sim import scene_for

    return scene_for(tuple("ghijkl"), _stepped_by(step), False)


def narrow_gripper_scene():
    """The cube (a) alone, under a gripper opening 4 cm (narrower than the cube)."""
    from graspjax.config import GripperConfig
    from graspjax.sim import build_scene

    return build_scene("a", gripper=GripperConfig(opening=0.04))


# The scenes whose `Worlds` programs `test_physics` compiles, in the order it first uses them:
# warm_cache.py compiles the same programs beside the suite.
PHYSICS_SCENES = (basic_scene, industrial_scene, narrow_gripper_scene,
                  functools.partial(basic_scene, "mjx"), functools.partial(industrial_scene, "mjx"))


@pytest.fixture(scope="session", params=["graspjax", "mjx"])
def physics_step(request):
    """Each physics test runs with graspjax's reworked step and with plain `mjx.step`."""
    return request.param


@pytest.fixture(scope="session")
def basic_sim(physics_step):
    return Worlds(basic_scene(physics_step))


@pytest.fixture(scope="session")
def industrial_sim(physics_step):
    return Worlds(industrial_scene(physics_step))


def hull_solid(points, rotation, translation):
    """Analytic convex solid (graspjax.synthetic) of a point set, moved to a pose."""
    from scipy.spatial import ConvexHull

    from graspjax.synthetic import Solid

    eq = ConvexHull(points).equations
    return Solid(eq[:, :3], -eq[:, 3]).moved(rotation, translation)
