"""Per-world physics: reset to a layout, move the gripper, step, render, judge a grasp.

Every function here acts on ONE world's `mjx.Data`; `Simulator` vmaps and
jits them once per scene (and per batch size), so a whole experiment compiles
the physics step exactly once: settling, approaching, closing, lifting and
holding are all the same `segment` call with different gripper targets.
"""

from __future__ import annotations

import dataclasses
import functools
from enum import IntEnum

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.config import CameraConfig, GripperConfig, SimConfig
from graspjax.geometry import frame_from_axes, matrix_to_quat
from graspjax.sim.render import render_depth
from graspjax.sim.scene import GRIPPER_HOME, Scene, build_scene, mjx

_HOME_QUAT = jnp.array([0.0, 1.0, 0.0, 0.0])  # hand z (approach) pointing down
_HELD_MARGIN = 0.01  # target centre of mass within the jaw span plus this (m)
_CLOSED = 0.001  # finger opening below this means the jaws closed on nothing (m)


class Outcome(IntEnum):
    """How one executed grasp attempt ended (carried as int32 in arrays)."""

    SUCCESS = 0  # the target was lifted by at least min_lift and is held between the fingers
    MISSED = 1  # the jaws closed on nothing
    SLIPPED = 2  # something was between the jaws but the target was not lifted and held
    COLLISION = 3  # the approach was blocked before the grasp pose was reached
    WRONG_OBJECT = 4  # another object was lifted instead of the target
    DIVERGED = 5  # the simulation state became non-finite
    NOT_EXECUTED = 6  # no grasp to execute (perception found none)


@dataclasses.dataclass(frozen=True)
class GraspPose:
    """A grasp to execute in one world (world frame)."""

    tcp: jax.Array  # (3,) point between the finger tips at the grasp
    approach: jax.Array  # (3,) unit direction from the palm to the finger tips
    closing: jax.Array  # (3,) unit closing axis, perpendicular to `approach`
    valid: jax.Array  # () bool: False means do not execute


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """What the judge needs from one moment of one world."""

    object_pos: jax.Array  # (n, 3) object frame origins
    object_com: jax.Array  # (n, 3) object centres of mass
    hand_pos: jax.Array  # (3,)
    hand_rot: jax.Array  # (3, 3)
    target_pos: jax.Array  # (3,) where the gripper target (mocap) is
    opening: jax.Array  # () finger 1 position = half the jaw opening (m)
    finite: jax.Array  # () bool


for _cls in (GraspPose, Snapshot):
    jax.tree_util.register_dataclass(
        _cls, data_fields=[f.name for f in dataclasses.fields(_cls)], meta_fields=[])


# ---------------------------------------------------------------------------
# One world


def reset(scene: Scene, data: mjx.Data, pos: jax.Array, quat: jax.Array,
          active: jax.Array) -> mjx.Data:
    """Place the active objects at (pos (n, 3), quat (n, 4)), park the rest, open the gripper at home."""
    qpos, qvel = data.qpos, jnp.zeros_like(data.qvel)
    park_quat = jnp.array([1.0, 0.0, 0.0, 0.0])
    for i in range(scene.num_objects):
        a = scene.object_qpos[i]
        qpos = qpos.at[a:a + 3].set(jnp.where(active[i], pos[i], scene.park_pos[i]))
        qpos = qpos.at[a + 3:a + 7].set(jnp.where(active[i], quat[i], park_quat))
    eq_active = data.eq_active.at[scene.park_eq].set(~active)
    data = data.replace(qpos=qpos, qvel=qvel, eq_active=eq_active, time=jnp.zeros(()))
    return move_hand(scene, data, jnp.asarray(GRIPPER_HOME, jnp.float32), _HOME_QUAT, opened=True)


def move_hand(scene: Scene, data: mjx.Data, pos: jax.Array, quat: jax.Array,
              opened: bool | jax.Array) -> mjx.Data:
    """Teleport the hand and its target to a pose, at rest; fingers fully open if `opened`."""
    h, hv = scene.hand_qpos, scene.hand_qvel
    qpos = data.qpos.at[h:h + 3].set(pos).at[h + 3:h + 7].set(quat)
    qvel = data.qvel.at[hv:hv + 6].set(0.0)
    half = scene.gripper.opening / 2
    qpos = jnp.where(opened, qpos.at[scene.finger_qpos].set(half), qpos)
    qvel = jnp.where(opened, qvel.at[scene.finger_qvel].set(0.0), qvel)
    ctrl = jnp.where(opened, jnp.full_like(data.ctrl, half), data.ctrl)
    return data.replace(qpos=qpos, qvel=qvel, ctrl=ctrl, mocap_pos=data.mocap_pos.at[0].set(pos),
                        mocap_quat=data.mocap_quat.at[0].set(quat))


def park(scene: Scene, data: mjx.Data, which: jax.Array) -> mjx.Data:
    """Take the objects flagged in `which` (n,) bool off the table, back to their parking spots."""
    qpos, qvel = data.qpos, data.qvel
    for i in range(scene.num_objects):
        a, v = scene.object_qpos[i], scene.object_qvel[i]
        pose = jnp.concatenate([jnp.asarray(scene.park_pos[i], jnp.float32),
                                jnp.array([1.0, 0.0, 0.0, 0.0])])
        qpos = qpos.at[a:a + 7].set(jnp.where(which[i], pose, qpos[a:a + 7]))
        qvel = qvel.at[v:v + 6].set(jnp.where(which[i], 0.0, qvel[v:v + 6]))
    eq_active = data.eq_active.at[scene.park_eq].set(data.eq_active[scene.park_eq] | which)
    return data.replace(qpos=qpos, qvel=qvel, eq_active=eq_active)


def segment(scene: Scene, data: mjx.Data, start: jax.Array, end: jax.Array, quat: jax.Array,
            ctrl: jax.Array) -> mjx.Data:
    """`segment_steps` physics steps; the hand target moves linearly from `start` to `end`."""
    n = scene.sim.segment_steps

    def step(d, i):
        target = start + (end - start) * (i + 1) / n
        d = d.replace(mocap_pos=d.mocap_pos.at[0].set(target),
                      mocap_quat=d.mocap_quat.at[0].set(quat), ctrl=jnp.full_like(d.ctrl, ctrl))
        return mjx.step(scene.model, d), None

    data, _ = jax.lax.scan(step, data, jnp.arange(n))
    return data


def snapshot(scene: Scene, data: mjx.Data) -> Snapshot:
    """Positions the judge needs, from a state after kinematics."""
    hand = scene.hand_body
    return Snapshot(
        object_pos=data.xpos[scene.object_body],
        object_com=data.xipos[scene.object_body],
        hand_pos=data.xpos[hand],
        hand_rot=data.xmat[hand].reshape(3, 3),
        target_pos=data.mocap_pos[0],
        opening=data.qpos[scene.finger_qpos[0]],
        finite=jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel)),
    )


def render(scene: Scene, data: mjx.Data, rotation: jax.Array, position: jax.Array,
           camera: Camera, config: CameraConfig, key: jax.Array | None = None) -> jax.Array:
    """Depth image (H, W) of this world from a camera pose (state after kinematics)."""
    return render_depth(scene.render, data.geom_xpos, data.geom_xmat, rotation, position, camera,
                        config, key)


def hand_waypoints(scene: Scene, grasp: GraspPose):
    """Hand positions (pre-grasp, grasp, lifted) and orientation for a grasp pose."""
    rot = frame_from_axes(grasp.approach, grasp.closing)
    at_grasp = grasp.tcp - scene.tcp_offset * rot[:, 2]
    pre = at_grasp - scene.sim.pregrasp_distance * rot[:, 2]
    lifted = at_grasp + jnp.array([0.0, 0.0, scene.sim.lift_height])
    home = jnp.asarray(GRIPPER_HOME, jnp.float32)
    quat = jnp.where(grasp.valid, matrix_to_quat(rot), _HOME_QUAT)
    return (jnp.where(grasp.valid, pre, home), jnp.where(grasp.valid, at_grasp, home),
            jnp.where(grasp.valid, lifted, home), quat)


def judge(scene: Scene, start: Snapshot, approached: Snapshot, closed: Snapshot, held: Snapshot,
          target: jax.Array, executed: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Outcome code and the index of the lifted object (-1 if none) of one attempt."""
    rise = held.object_pos[:, 2] - start.object_pos[:, 2]
    lifted = rise >= scene.sim.min_lift
    com_local = held.hand_rot.T @ (held.object_com[target] - held.hand_pos)
    between = (held.opening > _CLOSED) & (jnp.abs(com_local[0]) <= held.opening + _HELD_MARGIN)
    success = lifted[target] & between
    others = lifted & (jnp.arange(scene.num_objects) != target)
    blocked = jnp.linalg.norm(approached.hand_pos - approached.target_pos) > scene.sim.approach_tolerance
    something = closed.opening > _CLOSED
    finite = start.finite & approached.finite & closed.finite & held.finite
    outcome = jnp.select(
        [~finite, ~executed, success, jnp.any(others), blocked, something],
        [Outcome.DIVERGED, Outcome.NOT_EXECUTED, Outcome.SUCCESS, Outcome.WRONG_OBJECT,
         Outcome.COLLISION, Outcome.SLIPPED], Outcome.MISSED).astype(jnp.int32)
    lifted_object = jnp.where(success, target,
                              jnp.where(jnp.any(others), jnp.argmax(jnp.where(others, rise, -1)), -1))
    return outcome, lifted_object.astype(jnp.int32)


# ---------------------------------------------------------------------------
# Batches of worlds


@dataclasses.dataclass(frozen=True)
class Attempt:
    """Batched result of executing grasps: arrays with a leading world axis (numpy)."""

    outcome: np.ndarray  # (B,) int32 Outcome
    lifted_object: np.ndarray  # (B,) int32 object index, -1 if none
    rise: np.ndarray  # (B,) target rise after the hold (m)
    opening: np.ndarray  # (B,) half jaw opening after closing (m)


class Simulator:
    """Jitted, vmapped world functions of one scene; inputs and outputs have a world axis.

    Compile once per scene and batch size: keep the batch size fixed (pad).
    """

    def __init__(self, scene: Scene):
        self.scene = scene
        self._device = jax.devices()[0]
        template = mjx.make_data(scene.mj_model)
        self._template = template
        s = scene

        def batched(fn):
            """jit(vmap(fn)) with the scene bound, keeping fn's name for logs and profiles."""
            def one_world(*args):
                return fn(s, *args)
            one_world.__name__ = fn.__name__
            return jax.jit(jax.vmap(one_world))

        def kinematics(_, d):
            return mjx.kinematics(s.model, d)

        self._reset = batched(reset)
        self._segment = batched(segment)
        self._kinematics = batched(kinematics)
        self._snapshot = batched(snapshot)
        self._move_hand = batched(move_hand)
        self._park = batched(park)
        self._waypoints = batched(hand_waypoints)
        self._judge = batched(judge)

    def empty(self, batch: int) -> mjx.Data:
        """`batch` copies of the model's initial state."""
        return jax.tree.map(lambda x: jnp.broadcast_to(x, (batch, *x.shape)), self._template)

    def reset(self, data, pos, quat, active) -> mjx.Data:
        return self._reset(data, pos, quat, active)

    def _step(self, data, start, end, quat, ctrl) -> mjx.Data:
        """One segment; host-made inputs are committed to the device so that jit's cache
        key (which includes placement) never differs between calls."""
        start, end, quat, ctrl = jax.device_put((start, end, quat, ctrl), self._device)
        return self._segment(data, start, end, quat, ctrl)

    def hold_still(self, data: mjx.Data, seconds: float) -> mjx.Data:
        """Simulate with the hand held where it is and the jaws as commanded (settling)."""
        for _ in range(self.scene.sim.segments(seconds)):
            here = data.mocap_pos[:, 0]
            data = self._step(data, here, here, data.mocap_quat[:, 0], data.ctrl[:, 0])
        return data

    def kinematics(self, data: mjx.Data) -> mjx.Data:
        """Positions of every body and geom of the current state (needed before rendering)."""
        return self._kinematics(data)

    def park(self, data: mjx.Data, which) -> mjx.Data:
        return self._park(data, which)

    def go_home(self, data: mjx.Data) -> mjx.Data:
        """Teleport the gripper back to its waiting pose, jaws open."""
        batch = data.qpos.shape[0]
        home = jnp.broadcast_to(jnp.asarray(GRIPPER_HOME, jnp.float32), (batch, 3))
        return self._move_hand(data, home, jnp.broadcast_to(_HOME_QUAT, (batch, 4)),
                               jnp.ones(batch, bool))

    def _move(self, data, start, end, quat, ctrl, seconds):
        n = self.scene.sim.segments(seconds)
        for k in range(n):
            a = start + (end - start) * (k / n)
            b = start + (end - start) * ((k + 1) / n)
            data = self._step(data, a, b, quat, ctrl)
        return data

    def execute(self, data: mjx.Data, grasp: GraspPose, target) -> tuple[mjx.Data, Attempt]:
        """Approach, close, lift and hold in every world; judge each attempt.

        grasp: GraspPose with a world axis; target: (B,) index of the object to lift.
        Worlds whose grasp is not valid keep the gripper at home (NOT_EXECUTED).
        """
        sim = self.scene.sim
        batch = data.qpos.shape[0]
        pre, at_grasp, lifted, quat = self._waypoints(grasp)
        opened = jnp.full(batch, self.scene.gripper.opening / 2, dtype=jnp.float32)
        closed = jnp.zeros(batch, jnp.float32)
        data = self._move_hand(data, pre, quat, jnp.ones(batch, bool))
        start = self._snapshot(self.kinematics(data))
        data = self._move(data, pre, at_grasp, quat, opened, sim.approach_time)
        approached = self._snapshot(self.kinematics(data))
        data = self._move(data, at_grasp, at_grasp, quat, closed, sim.close_time)
        gripped = self._snapshot(self.kinematics(data))
        data = self._move(data, at_grasp, lifted, quat, closed, sim.lift_time)
        data = self._move(data, lifted, lifted, quat, closed, sim.hold_time)
        data = self.kinematics(data)
        held = self._snapshot(data)
        target = jnp.asarray(target, jnp.int32)
        outcome, lifted_object = self._judge(start, approached, gripped, held, target, grasp.valid)
        rise = jnp.take_along_axis(held.object_pos[..., 2] - start.object_pos[..., 2],
                                   target[:, None], axis=1)[:, 0]
        result = Attempt(*(np.asarray(x) for x in (outcome, lifted_object, rise, gripped.opening)))
        return data, result


@functools.lru_cache(maxsize=8)
def simulator(letters: tuple[str, ...], gripper: GripperConfig = GripperConfig(),
              sim: SimConfig = SimConfig(), objects_collide: bool = True) -> Simulator:
    """The shared `Simulator` of a scene: every caller reuses its compiled functions."""
    return Simulator(build_scene(letters, gripper, sim, objects_collide))
