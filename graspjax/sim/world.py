"""One world's physics: reset to a layout, execute a grasp, judge it, settle.

Every function here acts on ONE world's `mjx.Data` (batch with `jax.vmap`
at the edge). A grasp attempt's physics is one loop over *segments* of
`segment_steps` steps: the execution phases (approach, close, lift, hold)
follow a static waypoint schedule, then the judge decides the outcome, the
lifted object leaves the scene, the hand returns home, and the world settles
for its own number of segments. One loop means one copy of the MJX step in
the compiled program, whatever the phases.

The hand can fail as a real one does: a pre-grasp pose whose hand would be
inside a part, the bin or the table is refused; during the approach the
contact force on the hand is watched at every step and the motion stops
where it exceeds `approach_force_limit` (a collision reflex), which ends the
attempt as `COLLISION`; the jaws close by a servo ramp and squeeze with
`grip_force`, the servo's force limit.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import Outcome
from graspjax.config import CameraConfig, Config
from graspjax.geometry import frame_from_axes, matrix_to_quat
from graspjax.sim import physics
from graspjax.sim.bodies import Snapshot, parked, snapshot
from graspjax.sim.contacts import hand_contact_force
from graspjax.sim.pile import NO_WALLS, Drops, Walls, drop, place_walls, push
from graspjax.sim.raycast import render_depth, world_planes
from graspjax.sim.scene import CLOSED_TARGET, GRIPPER_HOME, Scene, mjx
from graspjax.tree import pytree_dataclass, where_tree

HOME_QUAT = np.array([0.0, 1.0, 0.0, 0.0])  # hand z (approach) pointing down
_HELD_MARGIN = 0.01  # target centre of mass within the jaw span plus this (m)
_CLOSED = 0.001  # finger opening below this means the jaws closed on nothing (m)


@pytree_dataclass
class GraspPose:
    """A grasp to execute in one world (world frame)."""

    tcp: jax.Array  # (3,) point between the finger tips at the grasp
    approach: jax.Array  # (3,) unit direction from the palm to the finger tips
    closing: jax.Array  # (3,) unit closing axis, perpendicular to `approach`
    valid: jax.Array  # () bool: False means do not execute


@pytree_dataclass
class Execution:
    """What executing (or not) one grasp did to one world."""

    outcome: jax.Array  # () int32 Outcome
    lifted_object: jax.Array  # () int32 object index, -1 if none
    rise: jax.Array  # () target rise after the hold (m)
    opening: jax.Array  # () half jaw opening after closing (m)


@pytree_dataclass
class PhysicsState:
    """One world's physics state, enough to continue it elsewhere (C MuJoCo: `sim/replay.py`)."""

    qpos: jax.Array  # (nq,)
    qvel: jax.Array  # (nv,)
    act: jax.Array  # (na,) actuator states (the jaw servo's filter)
    ctrl: jax.Array  # (nu,)
    mocap_pos: jax.Array  # (nmocap, 3) the hand's target, the bin
    mocap_quat: jax.Array  # (nmocap, 4)


def physics_state(data: mjx.Data) -> PhysicsState:
    """The state of `data` (`PhysicsState`)."""
    return PhysicsState(**{f.name: getattr(data, f.name) for f in dataclasses.fields(PhysicsState)})


def physics_model(scene: Scene, config: Config) -> mjx.Model:
    """The scene's model with this world's traced physics values (frictions, grip force)."""
    model = scene.model
    pad = jnp.asarray(scene.gripper_geom)
    friction = jnp.asarray(model.geom_friction)
    sliding = jnp.where(pad, config.gripper.friction, config.sim.object_friction)
    force = 2 * config.gripper.grip_force  # each finger presses with half the servo force
    return model.replace(geom_friction=friction.at[:, 0].set(sliding),
                         actuator_forcerange=jnp.array([[-force, force]], jnp.float32))


def with_parking(scene: Scene, model: mjx.Model, data: mjx.Data) -> mjx.Model:
    """`model` with gravity compensated for the parked objects of `data`: they float at rest."""
    gravcomp = jnp.asarray(model.body_gravcomp).at[scene.object_body].set(
        parked(scene, data).astype(jnp.float32), unique_indices=True)
    return model.replace(body_gravcomp=gravcomp)


def reset(scene: Scene, data: mjx.Data, pos: jax.Array, quat: jax.Array,
          active: jax.Array, walls: Walls = NO_WALLS) -> mjx.Data:
    """Place the active objects at (pos (n, 3), quat (n, 4)), park the rest, open the gripper at
    home; the walls (if the scene has them) as `walls` says."""
    qpos, qvel = data.qpos, jnp.zeros_like(data.qvel)
    data = place_walls(scene, data, walls)
    park_quat = jnp.array([1.0, 0.0, 0.0, 0.0])
    for i in range(scene.num_objects):
        a = scene.object_qpos[i]
        qpos = qpos.at[a:a + 3].set(jnp.where(active[i], pos[i], scene.park_pos[i]))
        qpos = qpos.at[a + 3:a + 7].set(jnp.where(active[i], quat[i], park_quat))
    data = data.replace(qpos=qpos, qvel=qvel, time=jnp.zeros(()))
    return move_hand(scene, data, jnp.asarray(GRIPPER_HOME, jnp.float32), jnp.asarray(HOME_QUAT),
                     opened=True)


def move_hand(scene: Scene, data: mjx.Data, pos: jax.Array, quat: jax.Array,
              opened: bool | jax.Array) -> mjx.Data:
    """Teleport the hand and its target to a pose, at rest; fingers fully open if `opened`."""
    h, hv = scene.hand_qpos, scene.hand_qvel
    qpos = data.qpos.at[h:h + 3].set(pos).at[h + 3:h + 7].set(quat)
    qvel = data.qvel.at[hv:hv + 6].set(0.0)
    half = scene.gripper.opening / 2
    qpos = jnp.where(opened, qpos.at[scene.finger_qpos].set(half, unique_indices=True), qpos)
    qvel = jnp.where(opened, qvel.at[scene.finger_qvel].set(0.0, unique_indices=True), qvel)
    ctrl = jnp.where(opened, jnp.full_like(data.ctrl, half), data.ctrl)
    m = scene.hand_mocap
    return data.replace(qpos=qpos, qvel=qvel, ctrl=ctrl, mocap_pos=data.mocap_pos.at[m].set(pos),
                        mocap_quat=data.mocap_quat.at[m].set(quat))


def park(scene: Scene, data: mjx.Data, which: jax.Array) -> mjx.Data:
    """Take the objects flagged in `which` (n,) bool off the table, to their parking spots, at rest
    (`with_parking` then compensates their gravity)."""
    qpos, qvel = data.qpos, data.qvel
    for i in range(scene.num_objects):
        a, v = scene.object_qpos[i], scene.object_qvel[i]
        pose = jnp.concatenate([jnp.asarray(scene.park_pos[i], jnp.float32),
                                jnp.array([1.0, 0.0, 0.0, 0.0])])
        qpos = qpos.at[a:a + 7].set(jnp.where(which[i], pose, qpos[a:a + 7]))
        qvel = qvel.at[v:v + 6].set(jnp.where(which[i], 0.0, qvel[v:v + 6]))
    return data.replace(qpos=qpos, qvel=qvel)


@pytree_dataclass
class Reflex:
    """The approach's collision reflex: whether it fired, and where the hand target stopped."""

    tripped: jax.Array  # () bool
    stop: jax.Array  # (3,) hand target where the motion stopped


def segment(scene: Scene, model: mjx.Model, data: mjx.Data, start: jax.Array, end: jax.Array,
            quat: jax.Array, ctrl: jax.Array, reflex: Reflex, watch: jax.Array,
            force_limit) -> tuple[mjx.Data, Reflex]:
    """`segment_steps` physics steps: the hand target moves linearly from `start` to `end` (3,)
    and the jaw servo's target from ctrl[0] to ctrl[1]. While `watch`, a contact force on the
    hand above `force_limit` stops the hand where it is (open jaws) for good."""
    n = scene.sim.segment_steps
    opened = scene.gripper.opening / 2

    def step(carry, i):
        d, reflex = carry
        f = (i + 1) / n
        target = jnp.where(reflex.tripped, reflex.stop, start + (end - start) * f)
        jaws = jnp.where(reflex.tripped, opened, ctrl[0] + (ctrl[1] - ctrl[0]) * f)
        m = scene.hand_mocap
        d = d.replace(mocap_pos=d.mocap_pos.at[m].set(target),
                      mocap_quat=d.mocap_quat.at[m].set(quat), ctrl=jnp.full_like(d.ctrl, jaws))
        d = physics.step(model, d, scene.geom_owner, scene.skips_far_pairs, scene.sim.step)
        trip = watch & ~reflex.tripped & (hand_contact_force(scene, d) > force_limit)
        reflex = Reflex(tripped=reflex.tripped | trip,
                        stop=jnp.where(trip, d.qpos[scene.hand_qpos:scene.hand_qpos + 3],
                                       reflex.stop))
        return (d, reflex), None

    (data, reflex), _ = jax.lax.scan(step, (data, reflex), jnp.arange(n))
    return data, reflex


def hand_clear(scene: Scene, data: mjx.Data, position: jax.Array, rotation: jax.Array,
               margin: float = 0.001) -> jax.Array:
    """Whether the open hand at a pose (position (3,), rotation (3, 3)) is out of every part,
    the bin and the table: sample points of its boxes (`Scene.hand_points`) against the
    half-spaces of every rendered piece (state after kinematics). () bool."""
    points = jnp.asarray(scene.hand_points) @ rotation.T + position  # (P, 3)
    normals, offsets = world_planes(scene.solids, data.geom_xpos, data.geom_xmat)
    depth = offsets[None] - jnp.einsum("gpi,ki->kgp", normals, points)  # inside where all > 0
    return ~jnp.any(jnp.min(depth, -1) > margin)


def finger_clearance(scene: Scene, data: mjx.Data, position: jax.Array, rotation: jax.Array,
                     target: jax.Array) -> jax.Array:
    """Free space () around the open fingers of the hand at a pose (position (3,), rotation
    (3, 3)): the least distance from a sample point of either finger (`Scene.finger_points`)
    to a part other than `target` or to a wall, each piece's distance taken as its farthest
    half-space (exact where the nearest feature is a face, less near an edge; negative
    inside). The table does not count (fingers stop above it). inf: nothing else there.
    State after kinematics; ground truth, for the record."""
    points = jnp.asarray(scene.finger_points) @ rotation.T + position  # (P, 3)
    normals, offsets = world_planes(scene.solids, data.geom_xpos, data.geom_xmat)
    outside = jnp.max(jnp.einsum("gpi,ki->kgp", normals, points) - offsets[None], -1)  # (P, G)
    owner = jnp.asarray(scene.piece_object)
    counted = (owner != target) & (jnp.arange(owner.shape[0]) > 0)  # piece 0: the table
    return jnp.min(jnp.where(counted[None], outside, jnp.inf))


def depth_image(scene: Scene, data: mjx.Data, rotation: jax.Array, position: jax.Array,
                camera: Camera, config: CameraConfig, key: jax.Array | None = None) -> jax.Array:
    """Depth image (H, W) of this world from a camera pose (state after kinematics)."""
    return render_depth(scene.solids, data.geom_xpos, data.geom_xmat, rotation, position, camera,
                        config, key)


def hand_waypoints(scene: Scene, grasp: GraspPose, config: Config):
    """Hand positions (pre-grasp, grasp, lifted, home) (4, 3) and orientation (4,) of a grasp."""
    rot = frame_from_axes(grasp.approach, grasp.closing)
    at_grasp = grasp.tcp - scene.tcp_offset * rot[:, 2]
    pre = at_grasp - config.sim.pregrasp_distance * rot[:, 2]
    lifted = at_grasp + jnp.array([0.0, 0.0, 1.0]) * config.sim.lift_height
    home = jnp.asarray(GRIPPER_HOME, jnp.float32)
    quat = jnp.where(grasp.valid, matrix_to_quat(rot), jnp.asarray(HOME_QUAT, jnp.float32))
    return jnp.stack([pre, at_grasp, lifted, home]), quat


def judge(scene: Scene, config: Config, start: Snapshot, approached: Snapshot, closed: Snapshot,
          held: Snapshot, target: jax.Array, stopped: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Outcome code and the index of the lifted object (-1 if none) of one executed attempt
    (`stopped`: the collision reflex fired during the approach)."""
    rise = held.object_pos[:, 2] - start.object_pos[:, 2]
    lifted = rise >= config.sim.min_lift
    t = jnp.maximum(target, 0)  # target -1: the attempt is credited to no object
    com_local = held.hand_rot.T @ (held.object_com[t] - held.hand_pos)
    between = (held.opening > _CLOSED) & (jnp.abs(com_local[0]) <= held.opening + _HELD_MARGIN)
    success = lifted[t] & between & (target >= 0)
    others = lifted & (jnp.arange(scene.num_objects) != target)
    lag = jnp.linalg.norm(approached.hand_pos - approached.target_pos)
    blocked = lag > config.sim.approach_tolerance
    something = closed.opening > _CLOSED
    finite = start.finite & approached.finite & closed.finite & held.finite
    outcome = jnp.select(
        [~finite, stopped, success, jnp.any(others), blocked, something],
        [Outcome.DIVERGED, Outcome.COLLISION, Outcome.SUCCESS, Outcome.WRONG_OBJECT,
         Outcome.COLLISION, Outcome.SLIPPED], Outcome.MISSED).astype(jnp.int32)
    lifted_object = jnp.where(success, target,
                              jnp.where(jnp.any(others), jnp.argmax(jnp.where(others, rise, -1)), -1))
    return outcome, lifted_object.astype(jnp.int32)


@dataclasses.dataclass(frozen=True)
class Schedule:
    """The static waypoint schedule of a grasp's execution, one row per segment.

    Waypoints are indexed as `hand_waypoints` returns them: 0 pre-grasp,
    1 grasp, 2 lifted, 3 home. Segment i moves the hand target from
    `lerp(start[i], end[i], f0[i])` to `lerp(start[i], end[i], f1[i])`, and
    the jaw servo's target from closed fraction c0[i] to c1[i] (0: open,
    1: `CLOSED_TARGET`, beyond touching, so the force limit decides the squeeze).
    """

    start: np.ndarray  # (S,) int32 waypoint the phase starts from
    end: np.ndarray  # (S,) int32 waypoint the phase goes to
    f0: np.ndarray  # (S,) float32 fraction of the phase done at the segment's start
    f1: np.ndarray  # (S,) float32 ... and at its end
    c0: np.ndarray  # (S,) float32 jaw servo target, closed fraction at the segment's start
    c1: np.ndarray  # (S,) float32 ... and at its end
    approach: int  # segments of the approach (the collision reflex watches them)
    closed_at: int  # segment after which the jaws are judged

    @property
    def segments(self) -> int:
        return len(self.start)

    @classmethod
    def of(cls, config: Config) -> Schedule:
        s = config.sim
        n = [s.segments(t) for t in (s.approach_time, s.close_time, s.lift_time, s.hold_time)]
        rows = ([(0, 1, k / n[0], (k + 1) / n[0], 0.0, 0.0) for k in range(n[0])]  # approach
                + [(1, 1, 1.0, 1.0, k / n[1], (k + 1) / n[1]) for k in range(n[1])]  # close
                + [(1, 2, k / n[2], (k + 1) / n[2], 1.0, 1.0) for k in range(n[2])]  # lift
                + [(2, 2, 1.0, 1.0, 1.0, 1.0)] * n[3])  # hold
        start, end, f0, f1, c0, c1 = (np.array(col) for col in zip(*rows, strict=True))
        return cls(start.astype(np.int32), end.astype(np.int32), f0.astype(np.float32),
                   f1.astype(np.float32), c0.astype(np.float32), c1.astype(np.float32),
                   n[0], n[0] + n[1] - 1)


def simulate(scene: Scene, model: mjx.Model, data: mjx.Data, grasp: GraspPose,
             target: jax.Array, settle_segments: jax.Array, execute: jax.Array, config: Config,
             reachable: jax.Array | bool = True, take_out: jax.Array | bool = False,
             *, drops: Drops) -> tuple[mjx.Data, Execution]:
    """Execute `grasp` on object `target` (-1: none), judge it, remove what was lifted, then
    settle.

    Execution (when `execute` and `grasp.valid`): the hand appears at the
    pre-grasp pose with open jaws, approaches (the collision reflex
    watching), closes, lifts and holds (`Schedule`); the judge then decides
    the outcome, the lifted object is parked and the hand returns home with
    open jaws. A grasp whose pre-grasp pose is not `reachable` (the hand
    would be inside something) is not executed and ends as `COLLISION`. With
    `take_out` (() bool, the protocol's hand), a target that was not lifted
    and held is taken out too, after the attempt. Then the world settles for
    `settle_segments` () int32 segments, hand at home, dropping `drops` (`Drops`;
    `pile.no_drops`: nothing) as their segments come. Worlds that do not execute only settle. `execute` is ()
    bool, the same for every world.
    """
    plan = Schedule.of(config)
    n_exec = plan.segments
    waypoints, quat = hand_waypoints(scene, grasp, config)
    refused = execute & grasp.valid & jnp.logical_not(reachable)
    executing = execute & grasp.valid & reachable
    opened = scene.gripper.opening / 2
    mine = (jnp.arange(scene.num_objects) == target) & (target >= 0) & take_out
    # Not executed: the attempt failed; its object is taken out before the world settles.
    data = where_tree(executing, move_hand(scene, data, waypoints[0], quat, opened=True),
                      park(scene, data, mine))
    start = snapshot(scene, data)
    no = Execution(outcome=jnp.where(refused, Outcome.COLLISION, Outcome.NOT_EXECUTED).astype(jnp.int32),
                   lifted_object=jnp.int32(-1), rise=jnp.float32(jnp.nan), opening=jnp.float32(jnp.nan))
    travel = CLOSED_TARGET - opened  # jaw servo target from open to closed

    def body(carry):
        i, data, reflex, approached, closed, result = carry
        data = push(scene, drop(scene, data, drops, i - n_exec, config), drops, i - n_exec)
        row = jnp.clip(i, 0, n_exec - 1)
        in_exec = i < n_exec

        def lerp(f):
            a, b = waypoints[jnp.asarray(plan.start)[row]], waypoints[jnp.asarray(plan.end)[row]]
            return jnp.where(in_exec, a + (b - a) * f, waypoints[3])

        jaws = opened + travel * jnp.stack([jnp.asarray(plan.c0)[row],
                                            jnp.asarray(plan.c1)[row]])
        data, reflex = segment(scene, with_parking(scene, model, data), data,
                               lerp(jnp.asarray(plan.f0)[row]), lerp(jnp.asarray(plan.f1)[row]),
                               jnp.where(in_exec, quat, jnp.asarray(HOME_QUAT, jnp.float32)),
                               jnp.where(in_exec, jaws, opened), reflex,
                               in_exec & (i < plan.approach), config.sim.approach_force_limit)
        now = snapshot(scene, data)
        approached = where_tree(i == plan.approach - 1, now, approached)
        closed = where_tree(i == plan.closed_at, now, closed)
        # After the hold: judge, take the lifted object out, send the hand home.
        done = i == n_exec - 1
        outcome, lifted = judge(scene, config, start, approached, closed, now, target,
                                reflex.tripped)
        t = jnp.maximum(target, 0)
        rise = jnp.where(target >= 0, now.object_pos[t, 2] - start.object_pos[t, 2], jnp.nan)
        result = where_tree(done, Execution(outcome, lifted, rise, closed.opening), result)
        gone = (((jnp.arange(scene.num_objects) == lifted) & (lifted >= 0))
                | (mine & (outcome != Outcome.SUCCESS)))
        home = move_hand(scene, park(scene, data, gone), waypoints[3],
                         jnp.asarray(HOME_QUAT, jnp.float32), opened=True)
        data = where_tree(done, home, data)
        return i + 1, data, reflex, approached, closed, result

    first = jnp.where(executing, 0, n_exec).astype(jnp.int32)
    last = n_exec + settle_segments.astype(jnp.int32)
    reflex = Reflex(tripped=jnp.array(False), stop=waypoints[0])
    carry = (first, data, reflex, start, start, no)
    _, data, _, _, _, result = jax.lax.while_loop(lambda c: c[0] < last, body, carry)
    return data, result
