"""Following a chosen target into a new view from its 3-D point alone (`target.follow_target`)."""

import jax
import jax.numpy as jnp
import numpy as np
from conftest import CAMERA_HEIGHT, world_to_camera

from graspjax.perception.target import follow_target
from graspjax.synthetic import box

_follow = jax.jit(follow_target)


def test_a_target_is_found_again_at_its_point_and_only_its_surface(camera, render):
    """Two boxes 4 cm apart: a point on the 5 cm box's top finds that top, not the other box;
    the pixel it is found at is the point's own projection."""
    depth = render([box((0.05, 0.05, 0.05), (-0.05, 0.0, 0.0)), box((0.05, 0.05, 0.05), (0.05, 0.0, 0.0))])
    candidate = jnp.asarray(depth < CAMERA_HEIGHT - 0.01)
    point = world_to_camera([-0.05, 0.01, 0.05])
    surface, pixel, found = _follow(jnp.asarray(depth), camera, candidate, jnp.asarray(point), 0.01, 0.02)
    assert bool(found)
    np.testing.assert_allclose(np.asarray(pixel), np.asarray(camera.project(jnp.asarray(point))), atol=0.8)
    u = np.arange(camera.width)
    left = (u - camera.cx) * 0.45 / camera.fx < 0  # the left box's half of the image
    expected = (depth < 0.46) & left[None, :]
    np.testing.assert_array_equal(np.asarray(surface), expected)


def test_a_point_with_no_surface_near_it_is_lost(camera, render):
    """5 cm above the box's top, nothing lies within 2 cm: not found, nothing to take z_min on."""
    depth = render([box((0.05, 0.05, 0.05))])
    candidate = jnp.asarray(depth < CAMERA_HEIGHT - 0.01)
    point = world_to_camera([0.0, 0.0, 0.10])
    surface, _, found = _follow(jnp.asarray(depth), camera, candidate, jnp.asarray(point), 0.01, 0.02)
    assert not bool(found) and not np.asarray(surface).any()
    near = world_to_camera([0.0, 0.0, 0.065])  # 1.5 cm above it: found
    assert bool(_follow(jnp.asarray(depth), camera, candidate, jnp.asarray(near), 0.01, 0.02)[2])
