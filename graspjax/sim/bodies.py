"""Where one world's objects are: their poses and centres of mass, the hand's, which objects
are parked off the table. Read from the joint positions alone, so exact at any step; every
function acts on ONE world's `mjx.Data`."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from graspjax.geometry import quat_to_matrix
from graspjax.sim.scene import Scene, mjx
from graspjax.tree import pytree_dataclass


@pytree_dataclass
class Snapshot:
    """What the judge needs from one moment of one world (read from qpos alone)."""

    object_pos: jax.Array  # (n, 3) object frame origins
    object_com: jax.Array  # (n, 3) object centres of mass
    hand_pos: jax.Array  # (3,)
    hand_rot: jax.Array  # (3, 3)
    target_pos: jax.Array  # (3,) where the gripper target (mocap) is
    opening: jax.Array  # () finger 1 position = half the jaw opening (m)
    finite: jax.Array  # () bool


def snapshot(scene: Scene, data: mjx.Data) -> Snapshot:
    """Positions the judge needs, from the joint positions (exact at any step)."""
    qpos = data.qpos
    pos = jnp.stack([qpos[a:a + 3] for a in scene.object_qpos])
    rot = jax.vmap(quat_to_matrix)(jnp.stack([qpos[a + 3:a + 7] for a in scene.object_qpos]))
    h = scene.hand_qpos
    return Snapshot(
        object_pos=pos,
        object_com=pos + jnp.einsum("nij,nj->ni", rot, jnp.asarray(scene.object_com, jnp.float32)),
        hand_pos=qpos[h:h + 3],
        hand_rot=quat_to_matrix(qpos[h + 3:h + 7]),
        target_pos=data.mocap_pos[scene.hand_mocap],
        opening=qpos[scene.finger_qpos[0]],
        finite=jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel)),
    )


def parked(scene: Scene, data: mjx.Data) -> jax.Array:
    """Objects (n,) bool off the table, at their parking spots (far beyond any layout)."""
    return jnp.stack([data.qpos[a] for a in scene.object_qpos]) > scene.park_pos[0, 0] - 1.0
