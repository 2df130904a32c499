"""How a round's scene is staged in one world before the robot looks: the bin's walls, and
Setup 3's pile built while it settles (objects dropped one at a time onto what their outlines
overlap, pushed together, let go). `world.simulate` calls `drop` and `push` before each settle
segment; `world.reset` places the walls. Every function acts on ONE world's `mjx.Data`."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.config import MAX_WALL_HEIGHT, Config
from graspjax.geometry import quat_to_matrix
from graspjax.sim.bodies import parked, snapshot
from graspjax.sim.layout import footprints, gap
from graspjax.sim.scene import WALL_PARK, WALL_SIDES, Scene, mjx
from graspjax.tree import pytree_dataclass

_OVERLAP = 0.001  # a drop lands on what its outline overlaps by more than this (m): outlines
# placed touching stay side by side when what was there settled by less than this


@pytree_dataclass
class Walls:
    """Where one world's four walls stand: around a square at the origin, or parked."""

    side: jax.Array  # () inner side of the square (m)
    height: jax.Array  # () the walls' tops above the table (m)
    present: jax.Array  # () bool: standing around the square; else parked


NO_WALLS = Walls(side=np.float32(0.0), height=np.float32(0.0), present=np.bool_(False))


def place_walls(scene: Scene, data: mjx.Data, walls: Walls) -> mjx.Data:
    """The walls (if the scene has them) around a square of inner side `walls.side` centred at
    the origin, their tops `walls.height` above the table (each wall is `MAX_WALL_HEIGHT` tall,
    the rest sunk into the table); parked unless `walls.present`."""
    if not scene.has_walls:
        return data
    offset = (walls.side + scene.wall_thickness) / 2
    xy = jnp.asarray(WALL_SIDES, jnp.float32) * offset
    z = jnp.full((len(WALL_SIDES), 1), walls.height - MAX_WALL_HEIGHT / 2)
    spot = jnp.where(walls.present, jnp.concatenate([xy, z], -1),
                     jnp.asarray(WALL_PARK, jnp.float32))
    return data.replace(mocap_pos=data.mocap_pos.at[jnp.asarray(scene.wall_mocap)].set(spot))


@pytree_dataclass
class Drops:
    """How one world's pile is built while it settles (Setup 3).

    Drops: object j appears at `xy[j]` in orientation `quat[j]` before settle segment
    `segment[j]` (-1: not dropped), its lowest point `stack_gap` above the highest point of the
    objects already there whose outlines seen from above overlap its own (by more than
    `_OVERLAP`), else `drop_clearance` above the table. Objects dropped before the same
    segment do not see each other. The push: before segment `push_until`, every dropped object
    is pushed toward `centre` with `push` times its weight, horizontally (the experimenter
    sliding the group together), the force fading to zero over the last `push_fade` segments
    (let go gently)."""

    segment: jax.Array  # (n,) int32
    xy: jax.Array  # (n, 2) where the origin appears, seen from above (m)
    quat: jax.Array  # (n, 4) the orientation it is dropped in
    centre: jax.Array  # (2,) where the push points (m)
    push: jax.Array  # () the push, a fraction of each object's weight
    push_until: jax.Array  # () int32 the settle segment the push ends before
    push_fade: jax.Array  # () int32 segments over which it fades out


def no_drops(n: int) -> Drops:
    """Nothing to drop or push (every layout but Setup 3's, and every call after the first)."""
    return Drops(segment=jnp.full(n, -1, jnp.int32), xy=jnp.zeros((n, 2), jnp.float32),
                 quat=jnp.tile(jnp.array([1.0, 0.0, 0.0, 0.0], jnp.float32), (n, 1)),
                 centre=jnp.zeros(2, jnp.float32), push=jnp.float32(0.0),
                 push_until=jnp.int32(0), push_fade=jnp.int32(1))


def push(scene: Scene, data: mjx.Data, drops: Drops, segment: jax.Array) -> mjx.Data:
    """The push of `Drops` during settle segment `segment` () int32: a horizontal force on each
    dropped object's centre of mass (`xfrc_applied`), toward `drops.centre`, fading out over
    the last `push_fade` segments before `push_until`; none after."""
    dropped = (drops.segment >= 0) & (drops.segment <= segment) & ~parked(scene, data)
    on = dropped & (segment < drops.push_until)
    away = snapshot(scene, data).object_com[:, :2] - drops.centre
    unit = away / jnp.maximum(jnp.linalg.norm(away, axis=-1, keepdims=True), 1e-3)
    weight = jnp.asarray(scene.mj_model.body_mass[scene.object_body] * -scene.mj_model.opt.gravity[2],
                         jnp.float32)
    fade = jnp.clip((drops.push_until - segment) / jnp.maximum(drops.push_fade, 1), 0.0, 1.0)
    force = jnp.where(on[:, None], -fade * drops.push * weight[:, None] * unit, 0.0)
    return data.replace(xfrc_applied=data.xfrc_applied.at[jnp.asarray(scene.object_body), :2].set(
        force, unique_indices=True))


def drop(scene: Scene, data: mjx.Data, drops: Drops, segment: jax.Array,
         config: Config) -> mjx.Data:
    """Drop the objects whose turn comes before settle segment `segment` () int32 (`Drops`)."""
    now = (drops.segment >= 0) & (drops.segment == segment)  # (n,); the execution's segments
    # count below 0
    points = jnp.asarray(scene.object_points, jnp.float32)  # (n, V, 3)
    snap = snapshot(scene, data)
    rotations = jax.vmap(quat_to_matrix)(jnp.stack([data.qpos[a + 3:a + 7]
                                                    for a in scene.object_qpos]))
    there = jnp.einsum("nij,nvj->nvi", rotations, points) + snap.object_pos[:, None]  # (n, V, 3)
    falling_rotations = jax.vmap(quat_to_matrix)(drops.quat)
    falling = jnp.einsum("nij,nvj->nvi", falling_rotations, points)
    apart = jax.vmap(lambda a, xy_a: jax.vmap(lambda b, xy_b: gap(a, xy_a, b, xy_b))(
        footprints(points, rotations), snap.object_pos[:, :2]))(
        footprints(points, falling_rotations), drops.xy)  # (n, n) outline distances
    meets = (apart < -_OVERLAP) & ~parked(scene, data)[None]
    top = jnp.max(jnp.where(meets, jnp.max(there[..., 2], 1)[None], -jnp.inf), 1)
    layout = config.layout
    floor = jnp.where(jnp.isfinite(top), top + layout.stack_gap, layout.drop_clearance)
    z = floor - jnp.min(falling[..., 2], 1)
    qpos, qvel = data.qpos, data.qvel
    for i in range(scene.num_objects):
        a, v = scene.object_qpos[i], scene.object_qvel[i]
        pose = jnp.concatenate([drops.xy[i], z[i][None], drops.quat[i]])
        qpos = qpos.at[a:a + 7].set(jnp.where(now[i], pose, qpos[a:a + 7]))
        qvel = qvel.at[v:v + 6].set(jnp.where(now[i], 0.0, qvel[v:v + 6]))
    return data.replace(qpos=qpos, qvel=qvel)
