"""Simulated depth images against the independent analytic renderer (graspjax.synthetic)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SIM_BATCH, hull_solid

from graspjax.config import CameraConfig
from graspjax.geometry import axis_angle, look_down, matrix_to_quat
from graspjax.sim.objects import OBJECTS
from graspjax.sim.world import move_hand, render
from graspjax.synthetic import render_depth, rot_z


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
    return render_depth(camera, np.asarray(rotation), np.asarray(position), solids)


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
    depth = np.asarray(jax.jit(render, static_argnums=(0, 4, 5))(
        basic_sim.scene, one, rotation, position, camera, cfg))
    expected = _reference(camera, rotation, position)
    assert (expected > 0).all() and len(np.unique(np.round(expected, 3))) > 20
    np.testing.assert_allclose(depth, expected, atol=2e-5)


def test_gripper_is_invisible_and_range_limits_apply(basic_sim):
    cfg = CameraConfig()
    camera = cfg.camera()
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.5]))
    draw = jax.jit(jax.vmap(lambda d, c: render(basic_sim.scene, d, rotation, position, camera, c),
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


def test_noise_model_grows_with_depth_squared(basic_sim):
    cfg = CameraConfig(noise_std=0.003)
    camera = cfg.camera()
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.8]))
    one = jax.tree.map(lambda x: x[0], _state(basic_sim))
    clean = np.asarray(render(basic_sim.scene, one, rotation, position, camera, CameraConfig()))
    noisy = np.asarray(render(basic_sim.scene, one, rotation, position, camera, cfg,
                              jax.random.key(0)))
    table = clean == 0.8
    residual = (noisy - clean)[table]
    assert abs(residual.mean()) < 1e-4
    assert residual.std() == pytest.approx(0.003 * 0.8**2, rel=0.05)
    exact = np.asarray(render(basic_sim.scene, one, rotation, position, camera, cfg))  # no key
    np.testing.assert_array_equal(exact, clean)
