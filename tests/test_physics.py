"""Settling and grasp execution in MJX (`world.simulate`), judged by physics (CPU, small batches)."""

import copy

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from conftest import SIM_BATCH

from graspjax.codes import Outcome
from graspjax.config import Config, LayoutConfig, SimConfig, override
from graspjax.geometry import quat_to_matrix
from graspjax.sim import GraspPose
from graspjax.sim.bodies import parked

CFG = LayoutConfig()
IN_BIN = LayoutConfig(bin=True)  # Setup 3's bin variant
SIM = SimConfig()


SETTLE = {1: SIM.settle_time + SIM.drop_settle_time, 2: SIM.settle_time + SIM.group_settle_time,
          3: SIM.settle_time + SIM.pile_settle_time}  # as the procedure settles a fresh layout


def _settled(sim, setup, config=CFG):
    """`SIM_BATCH` fresh layouts of a setup settled as the procedure settles them (a pile's
    objects dropped one at a time), and which objects each layout holds (B, n)."""
    state = sim.start_rounds(setup, override(Config(), {"layout.bin": str(config.bin)}))
    active = np.asarray(state.drops.segment >= 0) | ~np.asarray(parked_batch(sim, state.data))
    return sim.settle(state.data, SETTLE[setup], state.drops), active


def parked_batch(sim, data):
    return jax.vmap(lambda d: parked(sim.scene, d))(data)


def _cpu_penetration(scene, qpos, mocap_pos):
    """Deepest penetration (m, >= 0) by CPU MuJoCo with no contact cap (independent check)."""
    model = copy.deepcopy(scene.mj_model)  # the scene's own model is shared: never mutate it
    model.numeric_data[:] = -1  # no max_contact_points: every contact
    data = mujoco.MjData(model)
    data.qpos[:], data.mocap_pos[:] = qpos, mocap_pos
    mujoco.mj_forward(model, data)
    return max([-c.dist for c in data.contact[: data.ncon]], default=0.0)


@pytest.mark.parametrize("scene_name, setup, config", [
    ("basic", 1, CFG), ("basic", 2, CFG), ("basic", 3, CFG), ("basic", 3, IN_BIN),
    ("industrial", 1, CFG)])
def test_layouts_settle_on_the_table(basic_sim, industrial_sim, scene_name, setup, config):
    """No NaN, no deep interpenetration (CPU MuJoCo, every contact), at rest, nothing in the
    table; Setup 1: on one of the object's faces; Setup 3: a heap on the table, or in the bin."""
    sim = basic_sim if scene_name == "basic" else industrial_sim
    scene = sim.scene
    data, active = _settled(sim, setup, config)
    qpos, qvel = np.asarray(data.qpos), np.asarray(data.qvel)
    assert np.isfinite(qpos).all() and np.isfinite(qvel).all()
    outside_bin = 0
    for w in range(SIM_BATCH):
        assert _cpu_penetration(scene, qpos[w], np.asarray(data.mocap_pos[w])) < 0.002
        for i in range(scene.num_objects):
            a = scene.object_qpos[i]
            rot = np.asarray(quat_to_matrix(jnp.asarray(qpos[w, a + 3:a + 7])))
            world = scene.object_points[i] @ rot.T + qpos[w, a:a + 3]
            if active[w, i]:
                assert world[:, 2].min() > -0.002  # on (not in) the table
                assert np.abs(qvel[w, scene.object_qvel[i]:scene.object_qvel[i] + 3]).max() < 0.05
                if setup == 1:  # dropped alone: it rests on a face (3 or more vertices down)
                    assert (world[:, 2] < world[:, 2].min() + 0.002).sum() >= 3
                com = rot @ scene.object_com[i] + qpos[w, a:a + 3]
                if setup == 3 and config.bin:  # in the bin (some lean on a wall's rim)
                    outside_bin += (np.abs(com[:2]) > CFG.bin_size / 2 + CFG.wall_thickness).any()
                if setup == 3 and not config.bin:  # a pile pushed together: in the overview
                    assert abs(com[0]) < 0.27 and abs(com[1]) < 0.197
            else:  # parked objects stay where they hang
                np.testing.assert_allclose(qpos[w, a:a + 3], scene.park_pos[i], atol=0.002)
    # A pile dropped into the bin one part at a time may tip a part over its 5 cm walls; it
    # rests on the table beside the bin (checked above).
    assert outside_bin <= active.sum() // 6


def _place(sim, poses):
    """Worlds with objects at given (x, y, yaw) poses: poses[w] = {object index: (x, y, yaw)}."""
    n = sim.scene.num_objects
    pos = np.zeros((SIM_BATCH, n, 3))
    quat = np.tile([1.0, 0, 0, 0], (SIM_BATCH, n, 1))
    active = np.zeros((SIM_BATCH, n), bool)
    for w, world in enumerate(poses):
        for i, (x, y, yaw) in world.items():
            pos[w, i] = (x, y, 0.001)
            quat[w, i] = (np.cos(yaw / 2), 0, 0, np.sin(yaw / 2))
            active[w, i] = True
    return sim.settle(sim.reset(pos, quat, active), 0.2)


def _grasps(rows):
    """GraspPose batch from rows of (tcp, closing axis, valid); approach straight down."""
    tcp = jnp.array([r[0] for r in rows], jnp.float32)
    closing = jnp.array([r[1] for r in rows], jnp.float32)
    return GraspPose(tcp, jnp.tile(jnp.array([0.0, 0.0, -1.0]), (len(rows), 1)), closing,
                     jnp.array([r[2] for r in rows]))


def test_the_protocol_takes_a_failed_target_out(basic_sim):
    """`take_out` (the protocol as we read the paper, `procedure.remove_failed`): after an attempt that did
    not lift its target, executed or not, the target leaves the scene, as does what was
    lifted; without `take_out` a failed target stays."""
    cube, block = 0, 5
    worlds = [{cube: (0.0, 0.0, 0.0)},  # 0: lifted
              {cube: (0.0, 0.0, 0.0)},  # 1: 20 cm beside the cube, in the air: MISSED
              {cube: (0.0, 0.0, 0.0), block: (0.1, 0.0, 0.0)},  # 2: lifts the block instead
              {cube: (0.0, 0.0, 0.0)},  # 3: no grasp (not executed)
              {cube: (0.0, 0.0, 0.0)},  # 4: as 1, without take_out
              {cube: (0.0, 0.0, 0.0)}]  # 5: as 3, without take_out
    data = _place(basic_sim, worlds)
    rows = [((0, 0, 0.03), (1, 0, 0), True), ((0.2, 0.0, 0.03), (1, 0, 0), True),
            ((0.1, 0, 0.01), (0, 1, 0), True), ((0, 0, 0.03), (1, 0, 0), False),
            ((0.2, 0.0, 0.03), (1, 0, 0), True), ((0, 0, 0.03), (1, 0, 0), False)]
    take_out = [True, True, True, True, False, False]
    after, attempt = basic_sim.execute(data, _grasps(rows), jnp.full(SIM_BATCH, cube), take_out)
    assert [Outcome(o) for o in attempt.outcome] == [
        Outcome.SUCCESS, Outcome.MISSED, Outcome.WRONG_OBJECT, Outcome.NOT_EXECUTED,
        Outcome.MISSED, Outcome.NOT_EXECUTED]
    gone = np.asarray(jax.vmap(lambda d: parked(basic_sim.scene, d))(after))  # (B, n)
    assert gone[:, cube].tolist() == [True, True, True, True, False, False]
    assert gone[2, block]  # lifted instead of the cube, it left too


def test_grasps_in_the_basic_scene(basic_sim):
    """Cube (a, 5 cm) and block (f, 7 x 4 x 3 cm) grasped top-down, 2 cm below their tops."""
    cube, block = 0, 5
    worlds = [{cube: (0.0, 0.0, 0.0)},  # 0: across the cube
              {cube: (0.02, -0.01, 0.5)},  # 1: across the cube, turned with it
              {block: (0.0, 0.0, 0.0)},  # 2: across the block's 4 cm side
              {cube: (0.0, 0.0, 0.0)},  # 3: 20 cm beside the cube, in the air
              {cube: (0.0, 0.0, 0.0), block: (0.1, 0.0, 0.0)},  # 4: grasps the block, target cube
              {cube: (0.0, 0.0, 0.0)}]  # 5: no grasp
    data = _place(basic_sim, worlds)
    rows = [((0, 0, 0.03), (1, 0, 0), True),
            ((0.02, -0.01, 0.03), (np.cos(0.5), np.sin(0.5), 0), True),
            ((0, 0, 0.01), (0, 1, 0), True),
            ((0.2, 0.0, 0.03), (1, 0, 0), True),
            ((0.1, 0, 0.01), (0, 1, 0), True),
            ((0, 0, 0.03), (1, 0, 0), False)]
    target = jnp.array([cube, cube, block, cube, cube, cube])
    after, attempt = basic_sim.execute(data, _grasps(rows), target)
    expected = [Outcome.SUCCESS, Outcome.SUCCESS, Outcome.SUCCESS, Outcome.MISSED,
                Outcome.WRONG_OBJECT, Outcome.NOT_EXECUTED]
    assert [Outcome(o) for o in attempt.outcome] == expected
    lift = basic_sim.scene.sim.lift_height
    np.testing.assert_allclose(attempt.rise[:3], lift, atol=0.01)  # lifted with the hand
    # The jaws stop on the part: half the opening is half its width (5, 5, 4 cm), less what the
    # pads sink into it at 40 N under the elliptic cone (up to 2.5 mm).
    np.testing.assert_allclose(attempt.opening[:3], [0.025, 0.025, 0.02], atol=0.003)
    assert np.asarray(attempt.lifted_object).tolist() == [cube, cube, block, -1, block, -1]
    assert np.isnan(attempt.rise[5])  # not executed
    # What was lifted left the scene (parked); the untouched cube of world 5 did not move.
    scene, qpos = basic_sim.scene, np.asarray(after.qpos)
    for w, obj in [(0, cube), (2, block), (4, block)]:
        a = scene.object_qpos[obj]
        np.testing.assert_allclose(qpos[w, a:a + 3], scene.park_pos[obj], atol=1e-6)
    a = scene.object_qpos[cube]
    np.testing.assert_allclose(qpos[5, a:a + 2], [0.0, 0.0], atol=1e-4)


def test_grasps_in_the_industrial_scene(industrial_sim):
    """Concave parts grasped at their features: knob, gear section, cup, gear teeth."""
    gear, candlestick, mill, shaft = 0, 1, 2, 4
    worlds = [{mill: (0.0, 0.0, 0.0)}, {shaft: (0.0, 0.0, 0.0)},
              {candlestick: (0.0, 0.0, 0.0)}, {gear: (0.0, 0.0, 0.0)},
              {gear: (0.0, 0.0, 0.0)}, {candlestick: (0.0, 0.0, 0.0)}]
    data = _place(industrial_sim, worlds)
    top_of_gear = 2 * 0.022 * np.cos(np.pi / 16)
    rows = [((0, 0, 0.130 - 0.010), (1, 0, 0), True),  # the pepper mill by its knob
            ((0, 0, top_of_gear - 0.015), (0, 1, 0), True),  # across the shaft's gear section
            ((0, 0, 0.122 - 0.015), (1, 0, 0), True),  # across the candlestick's cup
            ((0, 0, 0.005), (1, 0, 0), True),  # across the gear, tooth to tooth
            ((0, 0, 0.005), (np.cos(np.pi / 8), np.sin(np.pi / 8), 0), True),  # between teeth
            ((0, 0, 0.122 - 0.015), (1, 0, 0), False)]
    target = jnp.array([mill, shaft, candlestick, gear, gear, candlestick])
    _, attempt = industrial_sim.execute(data, _grasps(rows), target)
    attempt = jax.tree.map(np.asarray, attempt)
    assert [Outcome(o) for o in attempt.outcome] == [Outcome.SUCCESS] * 5 + [Outcome.NOT_EXECUTED]
    # The jaws stop at the part's width: knob, gear section and the cup's wall (flat to flat).
    flat = np.cos(np.pi / 12), np.cos(np.pi / 16)
    np.testing.assert_allclose(attempt.opening[:3], [0.011 * flat[0], 0.022 * flat[1], 0.022],
                               atol=0.003)


def test_a_world_steps_the_same_whatever_its_batch(industrial_sim):
    """The gear settling alone, in a batch of copies (every other part's pairs skipped) or
    beside worlds whose parts stand on the table and whose hand comes down to one (those
    pairs run): the same state, bit for bit."""
    gear, mill = 0, 2
    alone = _place(industrial_sim, [{gear: (0.0, 0.0, 0.3)}] * SIM_BATCH)
    beside = _place(industrial_sim, [{gear: (0.0, 0.0, 0.3)}]
                    + [{i: (0.01 * i, 0.0, 0.0)} for i in range(1, SIM_BATCH)])
    rows = [((0, 0, 0.1), (1, 0, 0), False)] * SIM_BATCH
    rows[mill] = ((0.02, 0.0, 0.12), (1, 0, 0), True)  # the pepper mill by its knob
    grasps = _grasps(rows)
    segments = jnp.full(SIM_BATCH, 3, jnp.int32)
    target = jnp.arange(SIM_BATCH) % industrial_sim.scene.num_objects
    keep = jnp.zeros(SIM_BATCH, bool)  # no object taken out
    nothing = industrial_sim.no_drops()
    after_alone, _ = industrial_sim._play(alone, _grasps([rows[0]] * SIM_BATCH), target,
                                          segments, jnp.array(True), keep, nothing)
    after_beside, attempt = industrial_sim._play(beside, grasps, target, segments, jnp.array(True),
                                                 keep, nothing)
    for state, other in ((alone, beside), (after_alone, after_beside)):
        for field in ("qpos", "qvel", "qacc"):
            np.testing.assert_array_equal(getattr(state, field)[0], getattr(other, field)[0])
    assert attempt.outcome[mill] == Outcome.SUCCESS  # the hand came down beside world 0's steps


def test_side_wider_than_the_opening_is_not_grasped():
    """A 4 cm gripper over the 5 cm cube: the fingers come down on its top and are stopped."""
    from conftest import Worlds, narrow_gripper_scene

    narrow = Worlds(narrow_gripper_scene())
    data = _place(narrow, [{0: (0.0, 0.0, 0.0)}] * SIM_BATCH)
    rows = [((0, 0, 0.03), (np.cos(a), np.sin(a), 0), True)
            for a in np.linspace(0, np.pi / 2, SIM_BATCH)]
    _, attempt = narrow.execute(data, _grasps(rows), jnp.zeros(SIM_BATCH, jnp.int32))
    attempt = jax.tree.map(np.asarray, attempt)
    assert all(Outcome(o) == Outcome.COLLISION for o in attempt.outcome)
    assert (np.abs(attempt.rise) < 0.01).all()  # the cube stays on the table


def test_a_blocked_approach_stops_as_a_collision(basic_sim):
    """The block (f, 3 cm tall) grasped across its 4 cm side, with the 7 cm cylinder (e) standing
    where the 20 cm palm comes down: the contact force stops the hand above its grasp pose."""
    block, cylinder = 5, 4
    worlds = [{block: (0.0, 0.0, 0.0), cylinder: (0.0, 0.08, 0.0)},  # 0: cylinder under the palm
              {block: (0.0, 0.0, 0.0)},  # 1: the block alone
              {block: (0.0, 0.0, 0.0), cylinder: (0.15, 0.0, 0.0)},  # 2: cylinder clear of the palm
              {block: (0.0, 0.0, 0.0), cylinder: (0.0, -0.08, 0.0)},  # 3: on the other side
              {block: (0.0, 0.0, 0.0)}, {block: (0.0, 0.0, 0.0)}]
    data = _place(basic_sim, worlds)
    rows = [((0, 0, 0.01), (0, 1, 0), True)] * SIM_BATCH
    after, attempt = basic_sim.execute(data, _grasps(rows), jnp.full(SIM_BATCH, block))
    outcomes = [Outcome(o) for o in attempt.outcome]
    assert outcomes[0] == outcomes[3] == Outcome.COLLISION
    assert outcomes[1] == outcomes[2] == Outcome.SUCCESS
    # The reflex limited the push: the cylinder is still standing where it was.
    a = basic_sim.scene.object_qpos[cylinder]
    qpos = np.asarray(after.qpos)
    for w, y in [(0, 0.08), (3, -0.08)]:
        np.testing.assert_allclose(qpos[w, a:a + 3], [0.0, y, 0.0], atol=0.01)


def test_a_pre_grasp_inside_the_table_is_refused(basic_sim):
    """A grasp 8 cm below the table top: its pre-grasp pose has the finger tips in the table, so
    the hand never goes there (COLLISION, nothing moves)."""
    cube = 0
    data = _place(basic_sim, [{cube: (0.0, 0.0, 0.0)}] * SIM_BATCH)
    rows = [((0, 0, -0.08), (1, 0, 0), True)] + [((0, 0, 0.03), (1, 0, 0), True)] * (SIM_BATCH - 1)
    after, attempt = basic_sim.execute(data, _grasps(rows), jnp.zeros(SIM_BATCH, jnp.int32))
    assert Outcome(int(attempt.outcome[0])) == Outcome.COLLISION
    assert Outcome(int(attempt.outcome[1])) == Outcome.SUCCESS
    a = basic_sim.scene.object_qpos[cube]
    # Nothing moved but the resting cube's slow sink into the table (elliptic contacts in MJX are
    # soft: about 1.5 mm over the attempt).
    np.testing.assert_allclose(np.asarray(after.qpos)[0, a:a + 3], np.asarray(data.qpos)[0, a:a + 3],
                               atol=2e-3)


def _squeezed_cube(gripper, sim, lift: float = 0.0):
    """CPU MuJoCo: the hand closed on the 5 cm cube for 1 s, then lifted by `lift` in 0.5 s and
    held for 0.3 s. Returns (model, data)."""
    from graspjax.geometry import matrix_to_quat
    from graspjax.sim.scene import CLOSED_TARGET, PALM_HALF, scene_mjcf

    model = mujoco.MjModel.from_xml_string(scene_mjcf("a", gripper, sim, False))
    data = mujoco.MjData(model)
    data.joint("obj_a").qpos[:] = (0.0, 0.0, 0.0005, 1.0, 0.0, 0.0, 0.0)
    hand_pos = np.array([0.0, 0.0, 0.03 + PALM_HALF[2] + gripper.finger_length])
    hand_quat = np.asarray(matrix_to_quat(jnp.diag(jnp.array([1.0, -1.0, -1.0]))))
    mocap = model.body("gripper_target").mocapid[0]
    data.joint("hand").qpos[:] = (*hand_pos, *hand_quat)
    data.mocap_pos[mocap] = hand_pos
    data.mocap_quat[mocap] = hand_quat
    data.joint("finger_1").qpos[:] = data.joint("finger_2").qpos[:] = gripper.opening / 2
    data.ctrl[:] = CLOSED_TARGET
    mujoco.mj_step(model, data, nstep=int(1.0 / model.opt.timestep))
    steps = int(0.5 / model.opt.timestep)
    for k in range(steps):
        data.mocap_pos[mocap] = hand_pos + np.array([0.0, 0.0, lift * (k + 1) / steps])
        mujoco.mj_step(model, data)
    mujoco.mj_step(model, data, nstep=int(0.3 / model.opt.timestep))
    mujoco.mj_forward(model, data)
    return model, data


@pytest.mark.parametrize("cone", ["elliptic", "pyramidal"])
def test_contact_forces_read_as_mujoco_reads_them(cone):
    """`world.contact_forces` on MJX data gives every contact's force as C MuJoCo's
    mj_contactForce does, for both friction cones, on a lifted cube whose pads carry its weight
    by friction; and the pads' friction balances the cube's weight (an independent check)."""
    from graspjax.config import GripperConfig
    from graspjax.privates import impl
    from graspjax.sim.contacts import contact_forces
    from graspjax.sim.scene import mjx

    model, data = _squeezed_cube(GripperConfig(), SimConfig(cone=cone), lift=0.03)
    assert data.ncon >= 4
    ours = np.asarray(contact_forces(mjx.put_data(model, data), cone == "elliptic"))
    slots = impl(mjx.put_data(model, data)).contact
    geoms, positions = np.asarray(slots.geom), np.asarray(slots.pos)
    wrench, weight_carried = np.zeros(6), np.zeros(3)
    cube = model.body("obj_a").id
    for i, contact in enumerate(data.contact[:data.ncon]):
        mujoco.mj_contactForce(model, data, i, wrench)
        same = np.flatnonzero((geoms == (contact.geom1, contact.geom2)).all(1)
                              & (np.linalg.norm(positions - contact.pos, axis=1) < 1e-6))
        assert len(same) == 1
        np.testing.assert_allclose(ours[same[0], :contact.dim], wrench[:contact.dim], rtol=1e-4,
                                   atol=1e-4)
        sign = 1.0 if model.geom_bodyid[contact.geom2] == cube else -1.0  # force on geom2's body
        weight_carried += sign * contact.frame.reshape(3, 3).T @ wrench[:3]
    assert data.joint("obj_a").qpos[2] > 0.02  # lifted off the table
    mass = model.body_subtreemass[cube]
    np.testing.assert_allclose(weight_carried, [0.0, 0.0, mass * 9.81], atol=0.02 * mass * 9.81 + 1e-3)


@pytest.mark.parametrize("force", [20.0, 40.0])
def test_the_jaws_squeeze_with_grip_force(force):
    """Closed on the 5 cm cube, each finger presses on it with grip_force: the normal contact
    forces between finger and cube, read by CPU MuJoCo's mj_contactForce."""
    from graspjax.config import GripperConfig

    gripper = GripperConfig(grip_force=force)
    model, data = _squeezed_cube(gripper, SIM)
    body = model.body("obj_a")
    finger = model.geom("finger_1").id
    cube = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body.id]
    pressed, wrench = 0.0, np.zeros(6)
    for i, contact in enumerate(data.contact[:data.ncon]):
        if {contact.geom1, contact.geom2} & {finger} and {contact.geom1, contact.geom2} & set(cube):
            mujoco.mj_contactForce(model, data, i, wrench)
            pressed += wrench[0]
    assert pressed == pytest.approx(force, rel=0.05)
    # On the cube's side: the stiff pads (0.01 s time constant) sink about 1 mm under 20-40 N.
    assert data.joint("finger_1").qpos[0] == pytest.approx(0.025, abs=0.002)


def test_c_mujoco_replays_end_as_the_physics_says(basic_sim):
    """The same states and grasps executed in C MuJoCo (sim/replay.py) give the outcomes a
    person expects, as MJX does: a cube lifted, a grasp in the air, the wrong object lifted, an
    approach stopped by the cylinder under the palm, a pre-grasp inside the table refused."""
    from graspjax.config import Config
    from graspjax.sim.replay import replay
    from graspjax.sim.world import physics_state

    cube, cylinder, block = 0, 4, 5
    worlds = [{cube: (0.0, 0.0, 0.0)}, {cube: (0.0, 0.0, 0.0)},
              {cube: (0.0, 0.0, 0.0), block: (0.1, 0.0, 0.0)},
              {block: (0.0, 0.0, 0.0), cylinder: (0.0, 0.08, 0.0)},
              {cube: (0.0, 0.0, 0.0)}, {block: (0.0, 0.0, 0.0)}]
    rows = [((0, 0, 0.03), (1, 0, 0), True), ((0.2, 0.0, 0.03), (1, 0, 0), True),
            ((0.1, 0, 0.01), (0, 1, 0), True), ((0, 0, 0.01), (0, 1, 0), True),
            ((0, 0, -0.08), (1, 0, 0), True), ((0, 0, 0.01), (0, 1, 0), True)]
    target = [cube, cube, cube, block, cube, block]
    expected = [Outcome.SUCCESS, Outcome.MISSED, Outcome.WRONG_OBJECT, Outcome.COLLISION,
                Outcome.COLLISION, Outcome.SUCCESS]
    data = _place(basic_sim, worlds)
    grasps = _grasps(rows)
    _, attempt = basic_sim.execute(data, grasps, jnp.asarray(target))
    assert [Outcome(o) for o in attempt.outcome] == expected
    for w in range(SIM_BATCH):
        state = jax.tree.map(lambda x, w=w: np.asarray(x[w]), physics_state(data))
        grasp = jax.tree.map(lambda x, w=w: np.asarray(x[w]), grasps)
        assert replay(basic_sim.scene, Config(), state, grasp, target[w]) == expected[w], w


def test_layout_stats_count_touching_and_stacked_objects():
    """Hand-placed layouts of the cube (a) and the flat block (f), their contacts from the
    physics step's collision: f resting 0.5 mm into a's top face (both touching, f stacked, no
    footprint gap), then f on the table 2 cm beside a (nothing touching, a 2 cm gap)."""
    from graspjax.sim.clutter import layout_stats
    from graspjax.sim.physics import collision
    from graspjax.sim.scene import build_scene, mjx
    from graspjax.sim.world import reset

    scene = build_scene(("a", "f"), objects_collide=True)
    model, m = scene.model, scene.mj_model
    cube, block = (np.flatnonzero(scene.geom_object == i)[0] for i in range(2))
    bottom = m.geom_pos[[cube, block], 2] - m.geom_size[[cube, block], 2]  # below each origin
    top = m.geom_pos[cube, 2] + m.geom_size[cube, 2]
    beside = m.geom_size[cube, 0] + m.geom_size[block, 0] + 0.02
    pos = np.array([[[0.0, 0.0, -bottom[0]], [0.0, 0.0, top - bottom[1] - 0.0005]],
                    [[0.0, 0.0, -bottom[0]], [beside, 0.0, -bottom[1]]]])
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (2, 2, 1))
    template = mjx.make_data(m)

    def stats(p, q):
        data = reset(scene, template, p, q, np.ones(2, bool))
        data = collision.collision(model, mjx.kinematics(model, data), scene.geom_owner,
                                   skip_far=False)
        return layout_stats(scene, data)

    got = jax.jit(jax.vmap(stats))(pos, quat)
    np.testing.assert_array_equal(got.objects, [2, 2])
    np.testing.assert_array_equal(got.touching, [2, 0])
    np.testing.assert_array_equal(got.stacked, [1, 0])
    assert float(got.gap[0]) == 0.0
    assert float(got.gap[1]) == pytest.approx(0.02, abs=1e-4)
