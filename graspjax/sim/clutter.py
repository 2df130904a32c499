"""How crowded one world's objects are: contacts, objects resting on others, outline gaps seen
from above (the clutter columns of `attempts.csv` and `rounds.csv`). Every function acts on ONE
world's `mjx.Data`, the state after a step (its contacts)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from graspjax.geometry import quat_to_matrix
from graspjax.privates import impl
from graspjax.sim.bodies import parked, snapshot
from graspjax.sim.layout import footprints, gaps
from graspjax.sim.scene import Scene, mjx
from graspjax.tree import pytree_dataclass

NEAR = 0.002  # an object is near another when their outlines seen from above are this close (m)


@pytree_dataclass
class LayoutStats:
    """How dense one world's layout is (Setups 2, 3; `rounds.csv`)."""

    objects: jax.Array  # () int32 objects on the table
    touching: jax.Array  # () int32 of them in contact with another object
    near: jax.Array  # () int32 of them whose outline seen from above lies within `NEAR` of another's
    stacked: jax.Array  # () int32 of them resting on another object
    gap: jax.Array  # () median over objects of the nearest footprint-to-footprint distance (m)
    spread: jax.Array  # () largest distance between two objects' origins, seen from above (m)


@pytree_dataclass
class Clutter:
    """How crowded each object of one world is (state after a step); (n,) each."""

    present: jax.Array  # bool on the table (not parked)
    touching: jax.Array  # bool in contact with another object
    resting: jax.Array  # bool resting on another object (a contact with a mostly vertical
    # normal, this one's centre of mass the higher)
    covered: jax.Array  # bool another object rests on it
    gap: jax.Array  # nearest outline-to-outline distance seen from above to another object on
    # the table (m; negative: their outlines overlap; inf: none)


def object_clutter(scene: Scene, data: mjx.Data) -> Clutter:
    """Contacts and footprint gaps of every object (state after a step, for its contacts)."""
    n = scene.num_objects
    present = ~parked(scene, data)
    contact = impl(data).contact
    owner = jnp.asarray(scene.geom_object)[contact.geom]  # (C, 2)
    real = (contact.dist < 1e-3) & (owner[:, 0] >= 0) & (owner[:, 1] >= 0) & (
        owner[:, 0] != owner[:, 1])
    pairs = jnp.zeros((n, n), bool).at[owner[:, 0], owner[:, 1]].max(real)
    pairs = pairs | pairs.T
    snap = snapshot(scene, data)
    vertical = real & (jnp.abs(contact.frame[:, 0, 2]) > 0.7)
    higher = snap.object_com[owner[:, 0], 2] > snap.object_com[owner[:, 1], 2]
    upper, lower = jnp.where(higher, owner[:, 0], owner[:, 1]), jnp.where(higher, owner[:, 1], owner[:, 0])
    resting = jnp.zeros(n, bool).at[upper].max(vertical)
    covered = jnp.zeros(n, bool).at[lower].max(vertical)
    rotations = jax.vmap(quat_to_matrix)(
        jnp.stack([data.qpos[a + 3:a + 7] for a in scene.object_qpos]))
    apart = gaps(footprints(jnp.asarray(scene.object_points), rotations), snap.object_pos[:, :2])
    apart = jnp.where(present[:, None] & present[None], apart, jnp.inf)
    return Clutter(present=present, touching=present & jnp.any(pairs, 1), resting=present & resting,
                   covered=present & covered, gap=jnp.where(present, jnp.min(apart, 1), jnp.inf))


def layout_stats(scene: Scene, data: mjx.Data) -> LayoutStats:
    """How dense the objects on the table are (state after a step: `object_clutter`)."""
    each = object_clutter(scene, data)
    present = each.present
    nearest = jnp.clip(each.gap, 0.0, None)
    xy = snapshot(scene, data).object_pos[:, :2]
    distance = jnp.linalg.norm(xy[:, None] - xy[None], axis=-1)
    spread = jnp.max(jnp.where(present[:, None] & present[None], distance, 0.0))
    return LayoutStats(objects=jnp.sum(present).astype(jnp.int32),
                       touching=jnp.sum(each.touching).astype(jnp.int32),
                       near=jnp.sum(present & (nearest <= NEAR)).astype(jnp.int32),
                       stacked=jnp.sum(each.resting).astype(jnp.int32),
                       gap=jnp.nanmedian(jnp.where(present & jnp.isfinite(nearest), nearest, jnp.nan)),
                       spread=spread)
