"""The physics step's collision: MJX's, with the narrow phase skipped where no world of the batch
needs it, and hull pairs (box-mesh, mesh-mesh) collided by `convex.convex_convex` (MJX's algorithm on pair
grids, several times faster on the CPU: MJX's contacts up to float32 rounding, which may break
MJX's ties among a pair's third and fourth contact points otherwise).

MJX runs its narrow phase on every candidate geom pair of the model in every step: in a
Setup 1 scene that is every parked object against the table and the hand, and the hand's
pairs while it waits at home. Here each of MJX's collision groups is cut into *parts* by who
owns the two geoms (the table and bin, the hand, object i; pairs of two objects form one
part), and a part runs only when, in some world of the batch, one of its pairs has bounding
spheres closer than `NEAR` (a plane: the other geom's sphere closer to its surface). The
worlds are the `jax.vmap` axis named `WORLDS`; without it each world decides alone, and
`vmap` computes both branches.

A skipped pair gets a contact that is `FAR` apart (no constraint force), which is what its
narrow phase would have given in effect: a pair whose spheres are `NEAR` apart cannot touch.
Its contact row is inactive either way, so the solver sees the same active contacts in the
same slots: a world steps bit for bit the same whatever the other worlds of its batch do,
and as under `mjx.step` up to float32 rounding, because a part's narrow phase compiles apart
from the rest of the step (tests/test_collision.py checks both).

The groups and the contact parameters are MJX's own (`collision_driver._geom_groups`,
`_contact_groups`: private, so mujoco-mjx is pinned to the minor version this was written
against); after the narrow phase, contacts are kept per condim as MJX keeps them (the
`max_contact_points` most penetrating). A model with `max_geom_pairs` (MJX's own culling)
steps with MJX's collision unchanged.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from graspjax import privates
from graspjax.privates import impl, quiet_import
from graspjax.sim.physics import convex
from graspjax.sim.physics.owners import OBJECTS, WORLDS

mjx = quiet_import("mujoco.mjx")  # mjx prints that its optional backends are missing

NEAR = 0.01  # a part runs when one of its pairs' bounding spheres are closer than this (m)
FAR = 1.0  # distance of a skipped pair's contact (m): inactive, as MJX's separated hulls give
_PLANE = int(mjx.GeomType.PLANE)
_BOX, _MESH = int(mjx.GeomType.BOX), int(mjx.GeomType.MESH)
_GRID_PAIRS = {(_BOX, _MESH), (_MESH, _MESH)}  # pair types `convex.convex_convex` collides


def narrow_phase_function(types: tuple[int, int]):
    """The collision function of a pair type: `convex.convex_convex` for hull pairs, else MJX's."""
    if tuple(map(int, types)) in _GRID_PAIRS:
        return convex.convex_convex
    return privates.COLLISION_FUNCTIONS[types]


def any_world(flag: jax.Array) -> jax.Array:
    """Whether `flag` () bool holds in some world of the batch (`WORLDS`), or in this world
    when no such axis is bound."""
    try:
        return jax.lax.psum(flag.astype(jnp.int32), WORLDS) > 0
    except NameError:  # no axis of worlds bound here
        return flag


@dataclasses.dataclass(frozen=True)
class Part:
    """Pairs of one collision group with the same owners: skipped or run together."""

    owners: tuple[int, int]  # STATIC, HAND, object index, or (OBJECTS, OBJECTS)
    index: np.ndarray  # (P,) positions of its pairs in the group, ascending
    geom: np.ndarray  # (P, 2) geom ids of its pairs


def parts(pairs: np.ndarray, geom_owner: np.ndarray) -> tuple[Part, ...]:
    """A group's pairs (P, 2) geom ids cut by owner (`geom_owner` (ngeom,): STATIC, HAND or the
    object index), in the order of their first pair."""
    owner = geom_owner[pairs]
    both_objects = (owner >= 0).all(axis=1)
    owner = np.where(both_objects[:, None], OBJECTS, np.sort(owner, axis=1))
    keys = list(dict.fromkeys(map(tuple, owner.tolist())))
    return tuple(Part(key, np.flatnonzero((owner == key).all(axis=1)),
                      pairs[(owner == key).all(axis=1)]) for key in keys)


def _near(m: mjx.Model, d: mjx.Data, types: tuple[int, int], geom: np.ndarray) -> jax.Array:
    """Whether some pair (P, 2) of a part may touch in this world: bounding spheres within
    `NEAR`, or a geom's sphere within `NEAR` of a plane's surface (MJX orders a plane first).
    A non-finite state counts as near (the narrow phase runs, as MJX's would)."""
    g1, g2 = geom[:, 0], geom[:, 1]
    centre1, centre2 = d.geom_xpos[g1], d.geom_xpos[g2]
    if types[0] == _PLANE:
        normal = d.geom_xmat[g1][:, :, 2]
        gap = jnp.sum(normal * (centre2 - centre1), -1) - m.geom_rbound[g2]
    else:
        gap = (jnp.linalg.norm(centre2 - centre1, axis=-1)
               - m.geom_rbound[g1] - m.geom_rbound[g2])
    return jnp.any(~(gap > NEAR))


def _narrow_phase(m, d, key, part: Part, func):
    """The contacts (P, ncon) of a part: MJX's collision function `func` where some world needs
    it, else `FAR` apart."""
    p, ncon = len(part.index), func.ncon

    def run():
        dist, pos, frame = func(m, d, key, jnp.asarray(part.geom))
        return dist.reshape(p, ncon), pos.reshape(p, ncon, 3), frame.reshape(p, ncon, 3, 3)

    def far():
        return (jnp.full((p, ncon), FAR, d.qpos.dtype), jnp.zeros((p, ncon, 3), d.qpos.dtype),
                jnp.broadcast_to(jnp.eye(3, dtype=d.qpos.dtype), (p, ncon, 3, 3)))

    return jax.lax.cond(any_world(_near(m, d, key.types, part.geom)), run, far)


def in_group_order(split: tuple[Part, ...], results: list) -> tuple:
    """Each part's results (a tuple of (P_i, ncon, ...) arrays) put back in their group's pair
    order and flattened pair by pair, as MJX's collision functions return a group's contacts:
    a tuple of (P * ncon, ...) arrays."""
    if len(split) == 1:
        return tuple(r.reshape((-1,) + r.shape[2:]) for r in results[0])
    order = np.argsort(np.concatenate([part.index for part in split]), kind="stable")
    return tuple(jnp.concatenate(r)[order].reshape((-1,) + r[0].shape[2:])
                 for r in zip(*results, strict=True))


def collision(m: mjx.Model, d: mjx.Data, geom_owner: np.ndarray, skip_far: bool = True
              ) -> mjx.Data:
    """`mjx.collision` with `narrow_phase_function`'s colliders (MJX's own collision when
    `max_geom_pairs` is set); when `skip_far`, each group's parts run only where some world
    needs them (`geom_owner` (ngeom,) int: STATIC, HAND or the object index of each geom),
    else every pair runs."""
    if impl(d).ncon == 0 or privates.numeric(m, "max_geom_pairs") > -1:
        return mjx.collision(m, d)
    pairs = privates.geom_groups(m)
    by_condim: dict[int, list] = {}
    for key, contact in privates.contact_groups(m, d).items():
        func = narrow_phase_function(key.types)
        group = np.array([(g1, g2) for g1, g2, _ in pairs[key]])
        if skip_far:
            split = parts(group, geom_owner)
            dist, pos, frame = in_group_order(split, [_narrow_phase(m, d, key, part, func)
                                                      for part in split])
        else:
            dist, pos, frame = func(m, d, key, jnp.asarray(group))
        if func.ncon > 1:
            contact = jax.tree.map(lambda x, r=func.ncon: jnp.repeat(x, r, axis=0), contact)
        by_condim.setdefault(key.condim, []).append(contact.replace(dist=dist, pos=pos, frame=frame))
    most = privates.numeric(m, "max_contact_points")
    kept = []
    for condim in sorted(by_condim):
        contact = jax.tree.map(lambda *x: jnp.concatenate(x), *by_condim[condim])
        if -1 < most < contact.geom.shape[0]:  # the most penetrating, as MJX keeps them
            _, idx = jax.lax.top_k(-contact.dist, k=most)
            contact = jax.tree.map(lambda x, idx=idx: x[idx], contact)
        kept.append(contact)
    contact = jax.tree.map(lambda *x: jnp.concatenate(x), *kept)
    return privates.with_impl(d, contact=contact)
