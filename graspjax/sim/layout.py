"""Random object layouts of the paper's three setups (Fig. 7), for one world.

A layout is data, not a model: initial object poses plus an `active` mask
(inactive objects stay parked). Every sampler takes one PRNG key; derive it
with `layout_key(seed, setup, ...)` so that any attempt can be rebuilt from
(seed, setup, object, trial). The world's settling (`procedure/protocol.py`) then
lets the physics finish the layout.

- Setup 1: one object dropped from a uniformly random orientation, its
  lowest point `drop_height` above the table, at a random position; it
  topples onto any of its stable faces while the world settles.
- Setup 2: the objects as a group. Each rests in one of its resting poses
  (`Scene.resting`: where drops of it came to rest) with a random yaw, and
  is placed next to a random member already placed, at a face-to-face gap
  U(gap_min, gap_max) measured between footprints (the objects' outlines
  seen from above), never nearer than gap_min to any other member.
- Setup 3: the paper's "dense cluttered scenes with multiple overlapping
  objects", "positioned close to each other within minimal distance and
  sometimes even have overlapping": Setup 2's group with gaps
  U(pile_gap_min, pile_gap_max) <= 0 (default 0: each object touches the
  member placed beside); the objects are dropped one at a time in their
  placement order (`pile.Drops`), an overlapping one onto what it overlaps.
  With `layout.bin`: dropped one at a time from random orientations into the
  bin.

Footprints are convex outlines handled through their support functions on
`DIRECTIONS` fixed directions: the distance between two convex outlines is
the largest separation along any direction (here underestimated by at most
half the longest edge times sin(pi / DIRECTIONS): 0.25 mm for our objects).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.config import LayoutConfig
from graspjax.geometry import matrix_to_quat, quat_to_matrix

DIRECTIONS = 512  # directions of the footprints' support functions (0.7 degrees apart)
_CANDIDATES = 16  # Setup 2: placements tried per object (the first that keeps every gap wins)
_ANGLES = 2 * np.pi * np.arange(DIRECTIONS) / DIRECTIONS
UNIT = np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], -1).astype(np.float32)  # (K, 2)


def layout_key(seed, setup, *indices) -> jax.Array:
    """The PRNG key of one layout: seed, then setup, then (object, trial) or (round,)."""
    key = jax.random.fold_in(jax.random.key(seed), setup)
    for index in indices:
        key = jax.random.fold_in(key, index)
    return key


# ---------------------------------------------------------------------------
# Footprints


def support(points: jax.Array) -> jax.Array:
    """Support function (K,) of a footprint: points (V, 2) relative to its object's origin."""
    return jnp.max(points @ jnp.asarray(UNIT).T, axis=0)


def gap(support_a: jax.Array, xy_a: jax.Array, support_b: jax.Array, xy_b: jax.Array) -> jax.Array:
    """Distance () between two footprints (support (K,), origin (2,)); negative: they overlap."""
    flipped = jnp.roll(support_b, -DIRECTIONS // 2)  # h_b(-u_k)
    return jnp.max(jnp.asarray(UNIT) @ (xy_b - xy_a) - support_a - flipped)


def _offset_for_gap(support_a: jax.Array, support_b: jax.Array, direction: jax.Array,
                    wanted: jax.Array) -> jax.Array:
    """How far () along unit `direction` (2,) from footprint a's origin footprint b's origin
    goes so that their distance is `wanted`."""
    width = support_a + jnp.roll(support_b, -DIRECTIONS // 2)
    along = jnp.asarray(UNIT) @ direction
    return jnp.min(jnp.where(along > 1e-3, (wanted + width) / jnp.maximum(along, 1e-3), jnp.inf))


def footprints(points: jax.Array, rotations: jax.Array) -> jax.Array:
    """Support functions (n, K) of objects with vertices (n, V, 3) in rotations (n, 3, 3)."""
    xy = jnp.einsum("nij,nvj->nvi", rotations, points)[..., :2]
    return jax.vmap(support)(xy)


def gaps(supports: jax.Array, xy: jax.Array) -> jax.Array:
    """Pairwise footprint distances (n, n) of objects at origins xy (n, 2); inf on the diagonal."""
    n = supports.shape[0]
    pair = jax.vmap(lambda i: jax.vmap(lambda j: gap(supports[i], xy[i], supports[j], xy[j]))(
        jnp.arange(n)))(jnp.arange(n))
    return jnp.where(jnp.eye(n, dtype=bool), jnp.inf, pair)


# ---------------------------------------------------------------------------
# Samplers


def _random_rotation(key) -> jax.Array:
    """A uniformly random rotation (3, 3): a normalized 4-D Gaussian is a uniform quaternion."""
    q = jax.random.normal(key, (4,))
    return quat_to_matrix(q / jnp.linalg.norm(q))


def _yaw(angle) -> jax.Array:
    c, s = jnp.cos(angle), jnp.sin(angle)
    return jnp.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _lift(points: jax.Array, rotation: jax.Array, clearance) -> jax.Array:
    """Height () of an object's origin that puts its lowest point `clearance` above the table."""
    return clearance - jnp.min((points @ rotation.T)[:, 2])


def single(key: jax.Array, target, points: jax.Array, config: LayoutConfig):
    """Setup 1: object `target` alone, dropped from a random orientation.

    points: vertices (n, V, 3) of every object. Returns positions (n, 3),
    quaternions (n, 4) and the active mask (n,).
    """
    n = points.shape[0]
    k_xy, k_rot = jax.random.split(key)
    # object centre: U(-workspace, workspace)^2
    xy = jax.random.uniform(k_xy, (2,), minval=-config.workspace, maxval=config.workspace)
    # object orientation: uniform over all rotations
    rotation = _random_rotation(k_rot)
    z = _lift(points[target], rotation, config.drop_height)
    pos = jnp.broadcast_to(jnp.concatenate([xy, z[None]]), (n, 3))
    quat = jnp.broadcast_to(matrix_to_quat(rotation), (n, 4))
    return pos, quat, jnp.arange(n) == target


def grouped(key: jax.Array, resting: jax.Array, points: jax.Array, config: LayoutConfig,
            gap_min=None, gap_max=None):
    """Setups 2 and 3: every object in a resting pose, in a group with face-to-face gaps
    U(gap_min, gap_max) (default: Setup 2's `config.gap_min`, `gap_max`; Setup 3's are
    `pile_gap_min` <= 0 and `pile_gap_max`: touching or overlapping outlines).

    resting: resting rotations (n, R, 3, 3) of each object; points:
    vertices (n, V, 3). Returns positions (n, 3), quaternions (n, 4), the
    active mask (n,) and the placement order (n,) int32 (object indices).
    For one key, groups of other gaps place the same objects in the same poses,
    order and directions (a paired density sweep).
    """
    gap_min = config.gap_min if gap_min is None else gap_min
    gap_max = config.gap_max if gap_max is None else gap_max
    n, poses = resting.shape[:2]
    k_pose, k_yaw, k_order, k_place, k_offset = jax.random.split(key, 5)
    # resting pose of each object: uniform over its recorded drops; yaw: U(-pi, pi)
    which = jax.random.randint(k_pose, (n,), 0, poses)
    yaw = jax.random.uniform(k_yaw, (n,), minval=-jnp.pi, maxval=jnp.pi)
    rotations = jax.vmap(lambda r, a: _yaw(a) @ r)(resting[jnp.arange(n), which], yaw)
    # Each footprint is placed by a point well inside it (its Steiner point, the support
    # function's mean direction-weighted value), not by its object's origin, which may lie
    # near or outside its edge: a wanted overlap is then reached moving along the direction
    # (`_offset_for_gap`'s widths stay positive).
    supports = footprints(points, rotations)
    inner = 2.0 * supports @ jnp.asarray(UNIT) / DIRECTIONS  # (n, 2) from each origin
    supports = supports - inner @ jnp.asarray(UNIT).T
    # placement order: a uniform random permutation
    order = jax.random.permutation(k_order, n)
    xy = jnp.zeros((n, 2))
    placed = jnp.zeros(n, bool).at[order[0]].set(True)
    for step, k_step in zip(range(1, n), jax.random.split(k_place, max(n - 1, 1)), strict=False):
        obj = order[step]
        k_nb, k_dir, k_gap = jax.random.split(k_step, 3)
        # per candidate: a neighbour uniform among those placed, a direction U(-pi, pi) and a
        # gap U(gap_min, gap_max)
        neighbour = order[jax.random.randint(k_nb, (_CANDIDATES,), 0, step)]
        angle = jax.random.uniform(k_dir, (_CANDIDATES,), minval=-jnp.pi, maxval=jnp.pi)
        wanted = jax.random.uniform(k_gap, (_CANDIDATES,), minval=gap_min, maxval=gap_max)

        def candidate(nb, a, g, obj=obj, xy=xy, placed=placed):
            direction = jnp.stack([jnp.cos(a), jnp.sin(a)])
            spot = xy[nb] + _offset_for_gap(supports[nb], supports[obj], direction, g) * direction
            others = jax.vmap(lambda j: gap(supports[j], xy[j], supports[obj], spot))(jnp.arange(n))
            return spot, jnp.min(jnp.where(placed, others, jnp.inf))

        spots, nearest = jax.vmap(candidate)(neighbour, angle, wanted)
        ok = nearest >= gap_min - 1e-6
        best = jnp.where(jnp.any(ok), jnp.argmax(ok), jnp.argmax(nearest))
        xy = xy.at[obj].set(spots[best])
        placed = placed.at[obj].set(True)
    # the group: centred, then moved by U(-workspace/2, workspace/2)^2
    offset = jax.random.uniform(k_offset, (2,), minval=-config.workspace / 2,
                                maxval=config.workspace / 2)
    xy = xy - (jnp.max(xy, 0) + jnp.min(xy, 0)) / 2 + offset - inner  # the origins
    z = jax.vmap(_lift, in_axes=(0, 0, None))(points, rotations, config.drop_clearance)
    return (jnp.concatenate([xy, z[:, None]], -1), jax.vmap(matrix_to_quat)(rotations),
            jnp.ones(n, bool), order.astype(jnp.int32))


def in_bin(key: jax.Array, points: jax.Array, config: LayoutConfig):
    """Setup 3's bin variant: every object dropped from a random orientation into the bin
    (`bin_size`) centred at the origin, its centre uniform over the floor clear of the walls,
    one at a time in a random order (`pile.Drops`).

    points: vertices (n, V, 3). Returns positions (n, 3) (each lowest point `drop_clearance`
    above the table: the drop lifts it onto what lies there), quaternions (n, 4), the active
    mask (n,) and the drop order (n,) int32 (object indices, first dropped first).
    """
    n = points.shape[0]
    k_rot, k_xy, k_order = jax.random.split(key, 3)
    # object orientation: uniform over all rotations
    rotations = jax.vmap(_random_rotation)(jax.random.split(k_rot, n))
    rotated = jnp.einsum("nij,nvj->nvi", rotations, points)
    reach = jnp.max(jnp.linalg.norm(rotated[..., :2], axis=-1), axis=1)
    # object centre: uniform over the floor, clear of the walls
    room = jnp.maximum(config.bin_size / 2 - reach, 0.0)[:, None]
    xy = jax.random.uniform(k_xy, (n, 2), minval=-1.0, maxval=1.0) * room
    # drop order: a uniform random permutation
    order = jax.random.permutation(k_order, n).astype(jnp.int32)
    z = config.drop_clearance - rotated[..., 2].min(1)
    return (jnp.concatenate([xy, z[:, None]], -1), jax.vmap(matrix_to_quat)(rotations),
            jnp.ones(n, bool), order)
