"""Shared fixtures: one camera, and jitted kernels compiled once per session."""

import os

import jax
import numpy as np
import pytest

from graspjax import Camera, align_tool, detect_grasp
from graspjax.synthetic import render_depth, top_down_pose

# A persistent compilation cache makes local reruns fast (CI starts cold).
jax.config.update("jax_compilation_cache_dir",
                  os.environ.get("GRASPJAX_JAX_CACHE", os.path.expanduser("~/.cache/graspjax-jax")))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)

CAMERA_HEIGHT = 0.5  # metres above the table


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
        return render_depth(camera, rotation, eye, solids, ground=ground)

    return _render


def world_to_camera(point):
    """Camera-frame coordinates of a world point for the top-down test camera."""
    rotation, eye = top_down_pose(CAMERA_HEIGHT)
    return rotation.T @ (np.asarray(point, float) - eye)


def assert_trees_close(a, b, rtol=1e-4, atol=1e-5):
    """Integers and booleans equal exactly, floats to float32 reordering noise."""
    def check(x, y):
        x, y = np.asarray(x), np.asarray(y)
        if np.issubdtype(x.dtype, np.floating):
            np.testing.assert_allclose(x, y, rtol=rtol, atol=atol)
        else:
            np.testing.assert_array_equal(x, y)
    jax.tree.map(check, a, b)


# --- simulation: one compiled scene per object set, shared by every test ---------------------
SIM_BATCH = 6  # every physics test uses this many worlds, so each scene compiles once


@pytest.fixture(scope="session")
def basic_sim():
    """Simulator of the a-f scene (Setups 1-3), shared with the experiment runner."""
    from graspjax.sim import simulator

    return simulator(tuple("abcdef"))


@pytest.fixture(scope="session")
def industrial_sim():
    """Simulator of the g-l scene (Setup 1; objects never meet), shared likewise."""
    from graspjax.sim import simulator

    return simulator(tuple("ghijkl"), objects_collide=False)


def hull_solid(points, rotation, translation):
    """Analytic convex solid (graspjax.synthetic) of a point set, moved to a pose."""
    from scipy.spatial import ConvexHull

    from graspjax.synthetic import Solid

    eq = ConvexHull(points).equations
    return Solid(eq[:, :3], -eq[:, 3]).moved(rotation, translation)
