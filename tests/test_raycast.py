"""Simulated depth images against the independent analytic renderer (graspjax.synthetic)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SIM_BATCH, hull_solid

from graspjax.config import CameraConfig
from graspjax.geometry import axis_angle, look_down, matrix_to_quat
from graspjax.sim.objects import OBJECTS
from graspjax.sim.world import depth_image, move_hand
from graspjax.synthetic import analytic_depth, rot_z


def _poses():
    """Three objects of the a-f scene at known poses; the others parked."""
    return {0: ((0.01, 0.02, 0.0), rot_z(0.3)),  # cube
            3: ((-0.06, 0.0, 0.0), rot_z(0.1)),  # hexagonal prism
            4: ((0.07, -0.05, 0.0), rot_z(-0.7))}  # 16-gon cylinder


def _state(sim):
    n = sim.scene.num_objects
    pos, quat = np.zeros((n, 3)), np.tile([1.0, 0, 0, 0], (n, 1))
    active = np.zeros(n, bool)
    for i, (p, r) in _poses().items():
        pos[i], quat[i], active[i] = p, np.asarray(matrix_to_quat(jnp.asarray(r))), True
    batch = [np.broadcast_to(x, (SIM_BATCH, *x.shape)) for x in (pos, quat, active)]
    return sim.kinematics(sim.reset(*batch))


def _reference(camera, rotation, position):
    solids = [hull_solid(OBJECTS[sim_letter].pieces[0].points(), r, p)
              for sim_letter, (p, r) in zip("ade", _poses().values(), strict=True)]
    return analytic_depth(camera, np.asarray(rotation), np.asarray(position), solids)


@pytest.mark.parametrize("view", ["top_down", "tilted"])
def test_depth_matches_analytic_rays(basic_sim, view):
    cfg = CameraConfig()
    camera = cfg.camera()
    if view == "top_down":
        rotation, position = look_down(jnp.array([0.0, 0.0, 0.5]))
    else:  # 35 degrees off vertical, 40 cm from the scene centre
        tilt = axis_angle(jnp.array([1.0, 0.0, 0.0]), jnp.deg2rad(35.0))
        rotation = tilt @ look_down(jnp.zeros(3))[0]
        position = -0.4 * rotation[:, 2] + jnp.array([0.0, 0.0, 0.02])
    data = _state(basic_sim)
    one = jax.tree.map(lambda x: x[0], data)
    depth = np.asarray(jax.jit(depth_image, static_argnums=(0, 4, 5))(
        basic_sim.scene, one, rotation, position, camera, cfg))
    expected = _reference(camera, rotation, position)
    assert (expected > 0).all() and len(np.unique(np.round(expected, 3))) > 20
    np.testing.assert_allclose(depth, expected, atol=2e-5)


def test_gripper_is_invisible_and_range_limits_apply(basic_sim):
    cfg = CameraConfig()
    camera = cfg.camera()
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.5]))
    draw = jax.jit(jax.vmap(lambda d, c: depth_image(basic_sim.scene, d, rotation, position, camera, c),
                            in_axes=(0, None)), static_argnums=1)
    data = _state(basic_sim)
    plain = np.asarray(draw(data, cfg))
    # Put the open gripper right under the camera, in full view.
    pose = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.3]), (SIM_BATCH, 3))
    quat = jnp.broadcast_to(jnp.array([0.0, 1.0, 0.0, 0.0]), (SIM_BATCH, 4))
    move = jax.vmap(lambda d, p, q: move_hand(basic_sim.scene, d, p, q, opened=True))
    moved = basic_sim.kinematics(move(data, pose, quat))
    np.testing.assert_allclose(np.asarray(draw(moved, cfg)), plain, atol=1e-6)
    # Returns nearer than min_range or farther than max_range are invalid (0).
    limited = np.asarray(draw(data, CameraConfig(min_range=0.46, max_range=0.499)))
    inside = (plain >= 0.46) & (plain <= 0.499)
    assert inside.any() and (~inside).any()
    np.testing.assert_allclose(limited, np.where(inside, plain, 0.0), atol=1e-6)


def _cube_alone(sim):
    """The cube (a) at the origin, nothing else; one world after kinematics."""
    n = sim.scene.num_objects
    pos, quat = np.zeros((SIM_BATCH, n, 3)), np.tile([1.0, 0, 0, 0], (SIM_BATCH, n, 1))
    active = np.zeros((SIM_BATCH, n), bool)
    active[:, 0] = True
    return jax.tree.map(lambda x: x[0], sim.kinematics(sim.reset(pos, quat, active)))


KINECT = CameraConfig(sensor="kinect", noise_scale=0.0)


def test_kinect_shadow_falls_where_the_projector_cannot_see(basic_sim):
    """A 5 cm cube under the camera at 0.5 m, the projector 7.5 cm along +x: the table strip
    just left of the cube is seen by the camera but hidden from the projector (no depth);
    by similar triangles it spans x from -0.025 * 0.5 / 0.45 to (0.075 - 0.1 * 0.5 / 0.45)."""
    camera = KINECT.camera()
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.5]))
    one = _cube_alone(basic_sim)
    draw = jax.jit(depth_image, static_argnums=(0, 4, 5))
    exact = np.asarray(draw(basic_sim.scene, one, rotation, position, camera, CameraConfig()))
    kinect = np.asarray(draw(basic_sim.scene, one, rotation, position, camera, KINECT,
                             jax.random.key(0)))
    lost = (exact > 0) & (kinect == 0)
    uv = np.asarray(camera.pixel_grid())
    x = (uv[..., 0] - camera.cx) * exact / camera.fx  # world x of each pixel's point (camera x)
    y = -(uv[..., 1] - camera.cy) * exact / camera.fy
    near, far = -0.025 * 0.5 / 0.45, 0.075 - 0.1 * 0.5 / 0.45
    pixel = 0.5 / camera.fx
    predicted = (x > far - pixel) & (x < near + pixel) & (np.abs(y) < 0.025 * 0.5 / 0.45 + pixel)
    core = (x > far + pixel) & (x < near - pixel) & (np.abs(y) < 0.02)
    assert core.sum() >= 10 and lost[core].all()  # the strip's inside has no depth
    assert not (lost & ~predicted).any()  # and nothing else lost its depth
    assert kinect[(x > 0.03) & (exact > 0)].all()  # no shadow on the projector's side


def test_kinect_depth_is_quantized_in_disparity(basic_sim):
    """No noise: a table at 0.8 m reads f b / d with d the disparity rounded to 1/8 pixel."""
    camera = KINECT.camera()
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.8]))
    one = _cube_alone(basic_sim)
    depth = np.asarray(jax.jit(depth_image, static_argnums=(0, 4, 5))(
        basic_sim.scene, one, rotation, position, camera, KINECT, jax.random.key(0)))
    f = 640 / (2 * np.tan(np.deg2rad(57.0) / 2))  # native focal length (pixels)
    expected = f * 0.075 / (np.round(f * 0.075 / 0.8 * 8) / 8)
    table = np.abs(depth - 0.8) < 0.01
    assert table.sum() > 0.9 * depth.size
    np.testing.assert_allclose(depth[table], expected, rtol=1e-5)
    assert abs(expected - 0.8) <= 0.8**2 / (f * 0.075) / 16 + 1e-9  # half a disparity step


@pytest.mark.parametrize("scale", [1.0, 2.0])
def test_kinect_noise_grows_as_measured_by_nguyen_et_al(basic_sim, scale):
    """A table at 0.8 m: depth noise sigma 1.2 mm + 1.9 mm/m^2 (z - 0.4 m)^2 (times the scale),
    plus the disparity quantization's uniform error."""
    camera = KINECT.camera()
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.8]))
    one = _cube_alone(basic_sim)
    noisy = CameraConfig(sensor="kinect", noise_scale=scale)
    depth = np.asarray(jax.jit(depth_image, static_argnums=(0, 4, 5))(
        basic_sim.scene, one, rotation, position, camera, noisy, jax.random.key(1)))
    table = depth[np.abs(depth - 0.8) < 0.02]
    f = 640 / (2 * np.tan(np.deg2rad(57.0) / 2))
    step = 0.8**2 / (f * 0.075) / 8  # depth of one disparity step at 0.8 m
    sigma = scale * (0.0012 + 0.0019 * 0.4**2)
    assert table.std() == pytest.approx(np.sqrt(sigma**2 + step**2 / 12), rel=0.1)
    assert abs(table.mean() - 0.8) < 3e-4
