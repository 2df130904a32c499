"""Random object layouts of the paper's three setups (Fig. 7), for one world.

A layout is data, not a model: initial object poses plus an `active` mask
(inactive objects stay parked). Every sampler takes one PRNG key; derive it
with `layout_key(seed, setup, ...)` so that any attempt can be rebuilt from
(seed, setup, object, trial).

- Setup 1: one object, centre uniform in the workspace square, yaw uniform.
- Setup 2: all objects in a group on a jittered grid, neighbours a few
  centimetres apart (footprint circles never overlap), group rotated and
  placed at random.
- Setup 3: all objects dropped densely: centres uniform in a small disc,
  random yaw and tilt, each starting above all earlier ones, then settled, so
  they touch, lean on and overlap each other.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.config import LayoutConfig
from graspjax.geometry import axis_angle, matrix_to_quat


def layout_key(seed: int, setup: int, *indices: int) -> jax.Array:
    """The PRNG key of one layout: seed, then setup, then (object, trial) or (round,)."""
    key = jax.random.fold_in(jax.random.key(seed), setup)
    for index in indices:
        key = jax.random.fold_in(key, index)
    return key


def _yaw_quat(yaw) -> jax.Array:
    return jnp.stack([jnp.cos(yaw / 2), jnp.zeros_like(yaw), jnp.zeros_like(yaw),
                      jnp.sin(yaw / 2)], axis=-1)


def single(key: jax.Array, target: jax.Array, num_objects: int, config: LayoutConfig):
    """Setup 1: object `target` alone on the table.

    Returns positions (n, 3), quaternions (n, 4) and the active mask (n,).
    """
    k_xy, k_yaw = jax.random.split(key)
    # object centre: U(-workspace, workspace)^2
    xy = jax.random.uniform(k_xy, (2,), minval=-config.workspace, maxval=config.workspace)
    # object yaw: U(-pi, pi)
    yaw = jax.random.uniform(k_yaw, (), minval=-jnp.pi, maxval=jnp.pi)
    active = jnp.arange(num_objects) == target
    pos = jnp.zeros((num_objects, 3)).at[:, :2].set(xy).at[:, 2].set(config.drop_clearance)
    quat = jnp.broadcast_to(_yaw_quat(yaw), (num_objects, 4))
    return pos, quat, active


def grouped(key: jax.Array, radius: np.ndarray, config: LayoutConfig):
    """Setup 2: all objects in a loose group (radius: footprint radius of each object (n,))."""
    n = len(radius)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    k_perm, k_gx, k_gy, k_yaw, k_rot, k_xy = jax.random.split(key, 6)
    # cell of each object: a uniform random permutation of the grid cells
    cell = jax.random.permutation(k_perm, rows * cols)[:n]
    col, row = cell % cols, cell // cols
    r = jnp.asarray(radius, jnp.float32)
    col_r = jnp.zeros(cols).at[col].max(r)  # widest footprint in each column
    row_r = jnp.zeros(rows).at[row].max(r)
    # gaps between neighbouring columns / rows: U(gap_min, gap_max)
    gap_x = jax.random.uniform(k_gx, (cols - 1,), minval=config.gap_min, maxval=config.gap_max)
    gap_y = jax.random.uniform(k_gy, (rows - 1,), minval=config.gap_min, maxval=config.gap_max)
    x = jnp.concatenate([jnp.zeros(1), jnp.cumsum(col_r[:-1] + col_r[1:] + gap_x)])
    y = jnp.concatenate([jnp.zeros(1), jnp.cumsum(row_r[:-1] + row_r[1:] + gap_y)])
    centres = jnp.stack([x[col], y[row]], axis=-1)
    centres = centres - (centres.max(0) + centres.min(0)) / 2
    # group rotation: U(-pi, pi); group offset: U(-workspace/2, workspace/2)^2
    angle = jax.random.uniform(k_rot, (), minval=-jnp.pi, maxval=jnp.pi)
    rot = jnp.array([[jnp.cos(angle), -jnp.sin(angle)], [jnp.sin(angle), jnp.cos(angle)]])
    offset = jax.random.uniform(k_xy, (2,), minval=-config.workspace / 2,
                                maxval=config.workspace / 2)
    xy = centres @ rot.T + offset
    # object yaw: U(-pi, pi), independently per object
    yaw = jax.random.uniform(k_yaw, (n,), minval=-jnp.pi, maxval=jnp.pi)
    pos = jnp.concatenate([xy, jnp.full((n, 1), config.drop_clearance)], axis=-1)
    return pos, _yaw_quat(yaw), jnp.ones(n, bool)


def dense(key: jax.Array, points: np.ndarray, config: LayoutConfig):
    """Setup 3: all objects dropped densely (points: object vertices (n, V, 3))."""
    n = points.shape[0]
    k_r, k_phi, k_yaw, k_axis, k_tilt, k_order = jax.random.split(key, 6)
    # object centre: uniform in a disc of radius dense_radius
    r = config.dense_radius * jnp.sqrt(jax.random.uniform(k_r, (n,)))
    phi = jax.random.uniform(k_phi, (n,), minval=-jnp.pi, maxval=jnp.pi)
    xy = jnp.stack([r * jnp.cos(phi), r * jnp.sin(phi)], axis=-1)
    # object yaw: U(-pi, pi); tilt axis direction: U(-pi, pi); tilt: U(0, dense_tilt_deg)
    yaw = jax.random.uniform(k_yaw, (n,), minval=-jnp.pi, maxval=jnp.pi)
    axis_angle_xy = jax.random.uniform(k_axis, (n,), minval=-jnp.pi, maxval=jnp.pi)
    tilt = jax.random.uniform(k_tilt, (n,), maxval=jnp.deg2rad(config.dense_tilt_deg))

    def orientation(yaw_i, axis_i, tilt_i):
        axis = jnp.array([jnp.cos(axis_i), jnp.sin(axis_i), 0.0])
        return axis_angle(axis, tilt_i) @ axis_angle(jnp.array([0.0, 0.0, 1.0]), yaw_i)

    rots = jax.vmap(orientation)(yaw, axis_angle_xy, tilt)
    z_of_points = jnp.einsum("nij,nvj->nvi", rots, jnp.asarray(points, jnp.float32))[..., 2]
    lowest, height = z_of_points.min(1), z_of_points.max(1) - z_of_points.min(1)
    # drop order: a uniform random permutation; each object starts above all earlier ones
    order = jax.random.permutation(k_order, n)
    below = jnp.cumsum(height[order] + config.stack_gap) - (height[order] + config.stack_gap)
    start = jnp.zeros(n).at[order].set(below)
    z = config.drop_clearance - lowest + start
    pos = jnp.concatenate([xy, z[:, None]], axis=-1)
    return pos, jax.vmap(matrix_to_quat)(rots), jnp.ones(n, bool)
