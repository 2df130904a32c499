"""Contact forces read from MJX's data, as C MuJoCo's `mj_contactForce` reads them: the
approach's collision reflex watches the force on the hand."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.privates import impl
from graspjax.sim.scene import Scene, mjx


def contact_forces(data: mjx.Data, elliptic: bool) -> jax.Array:
    """Force (C, 6) of every contact slot in its contact frame (normal, 2 tangential, torsional,
    2 rolling), as MuJoCo's `mj_contactForce` computes it; zero for slots not in the solver.

    An elliptic cone keeps one constraint row per contact dimension, the normal force first.
    A pyramidal cone keeps 2 (condim - 1) edge rows (1 row if frictionless): the normal force is
    their sum and friction i is mu_i times the difference of its two opposing edges. `elliptic`
    is the model's cone (static).
    """
    internals = impl(data)
    contact, efc_force = internals.contact, internals.efc_force
    dims, address = np.asarray(contact.dim), np.asarray(contact.efc_address)
    columns = []
    for dim in sorted(set(dims.tolist())):  # MJX groups contact slots by dimension
        slots = np.flatnonzero(dims == dim)
        start = np.maximum(address[slots], 0)
        if elliptic or dim == 1:
            rows = efc_force[start[:, None] + np.arange(dim)]  # (S, dim)
        else:
            edges = efc_force[start[:, None] + np.arange(2 * (dim - 1))]  # (S, 2 (dim - 1))
            mu = contact.friction[slots, :dim - 1]
            rows = jnp.concatenate([jnp.sum(edges, -1, keepdims=True),
                                    (edges[:, 0::2] - edges[:, 1::2]) * mu], -1)
        rows = jnp.pad(rows, ((0, 0), (0, 6 - dim)))
        columns.append((slots, jnp.where((address[slots] >= 0)[:, None], rows, 0.0)))
    if not columns:
        return jnp.zeros((0, 6), efc_force.dtype)
    slots = np.concatenate([slots for slots, _ in columns])  # every slot once: a permutation
    return jnp.concatenate([rows for _, rows in columns])[np.argsort(slots)]


def hand_contact_force(scene: Scene, data: mjx.Data) -> jax.Array:
    """Total normal force () of every contact on the hand (palm, housing, fingers) (N)."""
    contact = impl(data).contact
    on_hand = jnp.asarray(scene.gripper_geom)[contact.geom].any(-1)
    normal = contact_forces(data, scene.sim.cone == "elliptic")[:, 0]
    return jnp.sum(jnp.where(on_hand, normal, 0.0))

