"""A grasp execution replayed in C MuJoCo: the cross-check of MJX's outcomes.

`world.simulate` executes a grasp in MJX. `replay` runs the same execution from the same state
in C MuJoCo (`mujoco.mj_step`): the same model with the world's physics values
(`world.physics_model`, `world.with_parking`), the same refusal of a pre-grasp pose inside a
part (`world.hand_clear`), the same waypoints, schedule, collision reflex and judge. What
differs is the implementation: C's collision code and solver in float64, started cold (the
state carries no solver warm start), so a disagreement measures MJX against the reference
implementation (`experiments/crosscheck.py`).
"""

from __future__ import annotations

import copy

import jax.numpy as jnp
import mujoco
import numpy as np

from graspjax.config import Config
from graspjax.geometry import frame_from_axes
from graspjax.sim.bodies import parked, snapshot
from graspjax.sim.scene import CLOSED_TARGET, Scene
from graspjax.sim.world import (
    GraspPose,
    Outcome,
    PhysicsState,
    Schedule,
    hand_clear,
    hand_waypoints,
    judge,
)


def c_model(scene: Scene, config: Config, state: PhysicsState,
            iterations: int | None = None) -> mujoco.MjModel:
    """The scene's C model with this world's physics values, as `physics_model` and
    `with_parking` set them in MJX; `iterations`: the solver's and its line search's
    iterations (None: the scene's, `sim.iterations` and `sim.ls_iterations`)."""
    model = copy.copy(scene.mj_model)
    if iterations is not None:
        model.opt.iterations = model.opt.ls_iterations = iterations
    pad = np.asarray(scene.gripper_geom)
    model.geom_friction[:, 0] = np.where(pad, config.gripper.friction, config.sim.object_friction)
    force = 2 * config.gripper.grip_force
    model.actuator_forcerange[:] = [-force, force]
    floating = np.asarray(parked(scene, state), np.float64)
    model.body_gravcomp[np.asarray(scene.object_body)] = floating
    return model


def _hand_force(scene: Scene, model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Total normal force on the hand's geoms (N), read by `mj_contactForce`."""
    total, wrench = 0.0, np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        if scene.gripper_geom[contact.geom1] or scene.gripper_geom[contact.geom2]:
            mujoco.mj_contactForce(model, data, i, wrench)
            total += wrench[0]
    return total


def replay(scene: Scene, config: Config, state: PhysicsState, grasp: GraspPose,
           target: int, iterations: int | None = None) -> Outcome:
    """Execute `grasp` (numpy fields) on object `target` from `state` (numpy fields, the world
    before the attempt) in C MuJoCo, as `world.simulate` does in MJX; returns the judged outcome.
    `iterations`: C's solver iterations (None: the scene's; see `c_model`)."""
    model = c_model(scene, config, state, iterations)
    data = mujoco.MjData(model)
    for name in ("qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat"):
        getattr(data, name)[:] = np.asarray(getattr(state, name))
    mujoco.mj_forward(model, data)
    grasp = GraspPose(*(jnp.asarray(x, jnp.float32) for x in (grasp.tcp, grasp.approach,
                                                             grasp.closing)), jnp.array(True))
    waypoints, quat = (np.asarray(x, np.float64) for x in hand_waypoints(scene, grasp, config))
    rotation = np.asarray(frame_from_axes(grasp.approach, grasp.closing))
    if not bool(hand_clear(scene, data, jnp.asarray(waypoints[0]), jnp.asarray(rotation))):
        return Outcome.COLLISION

    opened = scene.gripper.opening / 2
    h, hv, m = scene.hand_qpos, scene.hand_qvel, scene.hand_mocap
    data.qpos[h:h + 3], data.qpos[h + 3:h + 7] = waypoints[0], quat  # world.move_hand
    data.qvel[hv:hv + 6] = 0.0
    data.qpos[scene.finger_qpos], data.qvel[scene.finger_qvel] = opened, 0.0
    data.ctrl[:] = opened
    data.mocap_pos[m], data.mocap_quat[m] = waypoints[0], quat
    mujoco.mj_forward(model, data)
    start = snapshot(scene, data)

    plan = Schedule.of(config)
    travel = CLOSED_TARGET - opened
    n = scene.sim.segment_steps
    tripped, stop = False, waypoints[0]
    approached = closed = start
    for i in range(plan.segments):
        a, b = waypoints[plan.start[i]], waypoints[plan.end[i]]
        seg_start, seg_end = a + (b - a) * plan.f0[i], a + (b - a) * plan.f1[i]
        jaws = opened + travel * np.array([plan.c0[i], plan.c1[i]])
        watch = i < plan.approach
        for k in range(n):
            f = (k + 1) / n
            data.mocap_pos[m] = stop if tripped else seg_start + (seg_end - seg_start) * f
            data.mocap_quat[m] = quat
            data.ctrl[:] = opened if tripped else jaws[0] + (jaws[1] - jaws[0]) * f
            mujoco.mj_step(model, data)
            if watch and not tripped and _hand_force(scene, model, data) > \
                    config.sim.approach_force_limit:
                tripped, stop = True, data.qpos[h:h + 3].copy()
        if i == plan.approach - 1:
            approached = snapshot(scene, data)
        if i == plan.closed_at:
            closed = snapshot(scene, data)
    outcome, _ = judge(scene, config, start, approached, closed, snapshot(scene, data),
                       jnp.int32(target), jnp.array(tripped))
    return Outcome(int(outcome))
