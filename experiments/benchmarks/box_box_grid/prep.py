"""Worlds mid-grasp for step timings: `python step_pair.py LETTERS SETUP OBJECT BATCH` execs this.
BATCH worlds of the scene settle, then the hand is lowered over object OBJECT and closes for one
segment; the state is pickled in /tmp and reused by later calls (a state, not a result)."""
import os
import pickle
import sys

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.config import Config, stack_configs
from graspjax.procedure import WorldSpec, start_round
from graspjax.sim.collision import WORLDS
from graspjax.sim.scene import mjx, scene_for
from graspjax.sim.world import (
    CLOSED_TARGET,
    GraspPose,
    Reflex,
    hand_waypoints,
    move_hand,
    physics_model,
    play,
    segment,
    with_parking,
)

letters, setup, obj, batch = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
config = Config()
scene = scene_for(tuple(letters), config, setup != 1)
n = scene.num_objects
order = np.tile(np.arange(n, dtype=np.int32), (batch, 1)); order[:, 0] = obj
spec = WorldSpec(seed=np.zeros(batch, np.int32), setup=np.full(batch, setup, np.int32),
                 trial=np.arange(batch, dtype=np.int32), order=order,
                 members=np.ones((batch, n), bool), config=stack_configs([config] * batch))
cache = f"/tmp/prep_{letters}_{setup}_{obj}_{batch}.pkl"
template = mjx.make_data(scene.mj_model)
data = jax.jit(jax.vmap(lambda w: start_round(scene, template, w, (setup,)).data))(spec)
if os.path.exists(cache):
    leaves = pickle.load(open(cache, "rb"))
    data = jax.tree.unflatten(jax.tree.structure(data), [jnp.asarray(x) for x in leaves])
else:
    def settle_and_grip(d, w):
        model = physics_model(scene, w.config)
        zero3 = jnp.zeros(3)
        d, _ = play(scene, model, d, GraspPose(zero3, zero3, zero3, jnp.array(False)), jnp.int32(0),
                    jnp.int32(12), jnp.array(False), w.config)
        kin = mjx.kinematics(scene.model, d)
        centre = kin.xpos[jnp.asarray(scene.object_body)[w.order[0]]]
        g = GraspPose(centre + jnp.array([0, 0, 0.01]), jnp.array([0., 0, -1]), jnp.array([1., 0, 0]), jnp.array(True))
        wp, quat = hand_waypoints(scene, g, w.config)
        opened = scene.gripper.opening / 2
        d = move_hand(scene, d, wp[1], quat, opened=True)
        m = with_parking(scene, model, d)
        d, _ = segment(scene, m, d, wp[1], wp[1], quat, jnp.array([opened, CLOSED_TARGET]),
                       Reflex(jnp.array(False), wp[1]), jnp.array(False), 20.0)
        return d
    data = jax.block_until_ready(jax.jit(jax.vmap(settle_and_grip, axis_name=WORLDS))(data, spec))
    pickle.dump([np.asarray(x) for x in jax.tree.leaves(data)], open(cache, "wb"))
