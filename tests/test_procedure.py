"""The procedure's steps in one world: target selection, centring, re-alignment, reason codes."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SIM_BATCH

from graspjax.codes import ALIGN_BASE, DETECT_BASE, Outcome, Reason, Surface
from graspjax.config import Config, override
from graspjax.geometry import axis_angle, look_down
from graspjax.perception import Alignment, AlignReason, GraspReason
from graspjax.procedure import centred_pose, plane_truth, select_target, view
from graspjax.procedure.state import NO_CLUTTER, NO_PLANE
from graspjax.procedure.steps import _record, _with_error
from graspjax.sim.clutter import LayoutStats
from graspjax.sim.pile import Walls
from graspjax.sim.world import Execution, GraspPose

CONFIG = Config()
CAMERA = CONFIG.camera.camera()


def _world(sim, poses):
    """First world of a batch with objects standing on the table at (x, y, yaw), after
    kinematics: exact resting poses, no physics (the procedure's steps are under test here)."""
    n = sim.scene.num_objects
    pos, quat = np.zeros((SIM_BATCH, n, 3)), np.tile([1.0, 0, 0, 0], (SIM_BATCH, n, 1))
    active = np.zeros((SIM_BATCH, n), bool)
    for i, (x, y, yaw) in poses.items():
        pos[:, i] = (x, y, 0.0)
        quat[:, i] = (np.cos(yaw / 2), 0, 0, np.sin(yaw / 2))
        active[:, i] = True
    data = sim.kinematics(sim.reset(pos, quat, active))
    return jax.tree.map(lambda x: x[0], data)


def test_target_is_the_nearest_point_above_the_table(basic_sim):
    """Depth alone: the cylinder's top (7 cm) beats the cube (5 cm) and the block (3 cm); the
    point is credited to the cylinder (ground truth). The oracle picks among the eligible
    objects by identity instead; the protocol may stop the round."""
    # cube (5 cm tall) at x = -6 cm, cylinder (7 cm) at x = +6 cm, block (3 cm) at y = 8 cm
    data = _world(basic_sim, {0: (-0.06, 0.0, 0.0), 4: (0.06, 0.0, 0.0), 5: (0.0, 0.08, 0.3)})
    oracle = override(CONFIG, ["perception.oracle=true"])
    select = jax.jit(lambda d, e, go, c: select_target(basic_sim.scene, d, e, go, jnp.array(False),
                                                       CAMERA, c, jax.random.key(0))[:3])
    everything = jnp.array([True] * 6)
    no_cylinder = everything.at[4].set(False)
    for config in (CONFIG, oracle):
        index, aimed, point = select(data, everything, jnp.array(True), config)
        assert int(index) == 4 and bool(aimed)  # the cylinder's top is nearest to the camera
        np.testing.assert_allclose(np.asarray(point)[2], 0.07, atol=1e-3)
        assert np.linalg.norm(np.asarray(point)[:2] - [0.06, 0.0]) < 0.026
    assert int(select(data, no_cylinder, jnp.array(True), CONFIG)[0]) == 4  # depth knows no names
    assert int(select(data, no_cylinder, jnp.array(True), oracle)[0]) == 0  # the oracle does
    assert not bool(select(data, everything, jnp.array(False), CONFIG)[1])  # the round stopped
    assert not bool(select(data, jnp.zeros(6, bool), jnp.array(True), oracle)[1])


def test_in_the_bin_the_walls_are_never_the_target(basic_sim):
    """Setup 3: the bin's walls (5 cm) stand higher than a block (3 cm) inside it; the
    workspace, the bin's interior known by calibration, keeps them out."""
    from graspjax.procedure.steps import _candidates, _look, overview_pose

    n = basic_sim.scene.num_objects
    pos, quat = np.zeros((SIM_BATCH, n, 3)), np.tile([1.0, 0, 0, 0], (SIM_BATCH, n, 1))
    active = np.zeros((SIM_BATCH, n), bool)
    pos[:, 5], active[:, 5] = (0.02, 0.0, 0.0), True
    bin_walls = Walls(CONFIG.layout.bin_size, CONFIG.layout.bin_wall_height, True)
    data = jax.tree.map(lambda x: x[0], basic_sim.kinematics(basic_sim.reset(pos, quat, active,
                                                                             bin_walls)))
    rotation, position = overview_pose(CONFIG)

    @jax.jit
    def candidates(d, in_bin):
        depth, objects, _ = _look(basic_sim.scene, d, rotation, position, CAMERA, CONFIG,
                                  jax.random.key(0))
        return depth, objects, _candidates(depth, rotation, position, in_bin, CAMERA, CONFIG)

    depth, objects, inside = (np.asarray(x) for x in candidates(data, jnp.array(True)))
    walls = (objects < 0) & (depth < CONFIG.procedure.camera_height - 0.04)
    assert walls.sum() > 100 and not inside[walls].any()
    assert inside[objects == 5].mean() > 0.95 and not inside[objects < 0].any()
    everywhere = np.asarray(candidates(data, jnp.array(False))[2])
    assert everywhere[walls].all()  # without the workspace the walls' tops would qualify


def test_centring_keeps_the_height_and_aims_at_the_target():
    point = jnp.array([0.05, -0.03, 0.04])
    rotation, position = centred_pose(point, CONFIG, jax.random.key(0))
    np.testing.assert_allclose(position, [0.05, -0.03, CONFIG.procedure.camera_height])
    axis = np.asarray(rotation[:, 2])
    # The optical axis passes through the target point.
    along = np.asarray(point) - np.asarray(position)
    np.testing.assert_allclose(np.cross(axis, along), 0.0, atol=1e-7)
    # Without centring the camera stays over the workspace centre.
    still = override(CONFIG, ["procedure.centre=false"])
    np.testing.assert_allclose(centred_pose(point, still, jax.random.key(0))[1],
                               [0, 0, CONFIG.procedure.camera_height])


@pytest.mark.parametrize("tilt", [15.0, 40.0])
def test_a_tilted_centred_view_swings_about_the_target(tilt):
    """view_tilt_deg: the optical axis is that far from straight down, still through the target,
    from the same distance; the azimuth varies with the key."""
    point = np.array([0.05, -0.03, 0.04])
    config = override(CONFIG, [f"procedure.view_tilt_deg={tilt}"])
    axes = []
    for seed in range(3):
        rotation, position = (np.asarray(x) for x in centred_pose(jnp.asarray(point), config,
                                                                  jax.random.key(seed)))
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-6)
        axis = rotation[:, 2]
        assert np.degrees(np.arccos(-axis[2])) == pytest.approx(tilt, abs=1e-3)
        along = point - position
        np.testing.assert_allclose(np.cross(axis, along), 0.0, atol=1e-6)
        assert np.linalg.norm(along) == pytest.approx(CONFIG.procedure.camera_height - point[2])
        axes.append(axis)
    assert np.linalg.norm(axes[0] - axes[1]) > 1e-3
    # Not centred: the camera stays over the workspace centre and swings about the point where
    # its axis meets the target's height.
    still = override(config, ["procedure.centre=false"])
    rotation, position = (np.asarray(x) for x in centred_pose(jnp.asarray(point), still,
                                                              jax.random.key(0)))
    pivot = np.array([0.0, 0.0, point[2]])
    np.testing.assert_allclose(np.cross(rotation[:, 2], pivot - position), 0.0, atol=1e-6)
    assert np.linalg.norm(pivot - position) == pytest.approx(CONFIG.procedure.camera_height - point[2])


def test_execution_error_has_its_configured_spread():
    """2 mm per axis and 1 degree about a random axis, over 4000 draws."""
    config = override(CONFIG, ["procedure.tcp_error=0.002", "procedure.tilt_error_deg=1.0"])
    pose = GraspPose(jnp.zeros(3), jnp.array([0.0, 0.0, -1.0]), jnp.array([1.0, 0.0, 0.0]),
                     jnp.array(True))
    keys = jax.random.split(jax.random.key(0), 4000)
    reached = jax.vmap(lambda k: _with_error(pose, k, config))(keys)
    np.testing.assert_allclose(np.std(np.asarray(reached.tcp), 0), 0.002, rtol=0.06)
    tilt = np.degrees(np.arccos(np.clip(-np.asarray(reached.approach)[:, 2], -1, 1)))
    # The approach axis turns by the rotation's angle times the sine of its axis' angle to it:
    # for an isotropic axis E|sin| = pi / 4, and E|N(0, 1 deg)| = sqrt(2 / pi) deg.
    assert np.mean(tilt) == pytest.approx(np.pi / 4 * np.sqrt(2 / np.pi), rel=0.06)
    closing = np.asarray(reached.closing)
    np.testing.assert_allclose(np.sum(closing * np.asarray(reached.approach), 1), 0, atol=1e-6)
    exact = jax.vmap(lambda k: _with_error(pose, k, CONFIG))(keys[:10])
    np.testing.assert_array_equal(np.asarray(exact.tcp), 0.0)


def test_a_batch_builds_only_the_layouts_of_its_setups(basic_sim, monkeypatch):
    """`start_round` with the setups a batch plays builds only their layouts and places each
    world exactly as with all three (the others' layouts are never picked): one world per
    setup, seeds apart."""
    from graspjax.config import stack_configs
    from graspjax.procedure import WorldSpec, start_round
    from graspjax.sim import layout
    from graspjax.sim.scene import mjx

    built = []
    for name in ("single", "grouped", "in_bin"):
        sampler = getattr(layout, name)
        monkeypatch.setattr(layout, name,
                            lambda *a, _f=sampler, _n=name: built.append(_n) or _f(*a))
    samplers = {1: {"single"}, 2: {"grouped"}, 3: {"grouped", "in_bin"}}  # Setup 3: the pile or
    # the bin, per world (`layout.bin` is traced)

    scene = basic_sim.scene
    n = scene.num_objects
    spec = WorldSpec(seed=np.array([0, 1, 2], np.int32), setup=np.array([1, 2, 3], np.int32),
                     trial=np.array([4, 5, 6], np.int32),
                     order=np.tile(np.arange(n, dtype=np.int32), (3, 1)),
                     members=np.ones((3, n), bool), config=stack_configs([CONFIG] * 3))
    template = mjx.make_data(scene.mj_model)

    def placed(setups, worlds):
        built.clear()
        one = jax.tree.map(lambda x: x[worlds], spec)
        data = jax.jit(jax.vmap(lambda w: start_round(scene, template, w, setups).data))(one)
        assert set(built) == set().union(*(samplers[s] for s in setups))  # the others never
        return np.asarray(data.qpos), np.asarray(data.mocap_pos)

    every = placed((1, 2, 3), np.arange(3))
    for setups, worlds in (((1,), [0]), ((2, 3), [1, 2])):
        for ours, theirs in zip(placed(setups, np.array(worlds)), every, strict=True):
            # The same layouts, up to float32 rounding: the two programs fuse their arithmetic
            # differently on some CPUs (a last-bit difference); another setup's layout would
            # be centimetres away.
            np.testing.assert_allclose(ours, theirs[worlds], rtol=0, atol=1e-6)


NAN3 = jnp.full(3, jnp.nan)


def _reason(*, executed=False, outcome=Outcome.NOT_EXECUTED, finite=True, aimed=True,
            blocked=False, align=-1, lost=False, detect=GraspReason.NO_ROOM):
    pose = GraspPose(NAN3, NAN3, NAN3, jnp.array(executed))
    done = Execution(jnp.int32(outcome), jnp.int32(-1), jnp.float32(0), jnp.float32(0))
    stats = LayoutStats(*(jnp.int32(0),) * 4, jnp.float32(0), jnp.float32(0))
    nan = jnp.float32(jnp.nan)
    record = _record(jnp.int32(2), jnp.array(aimed), pose, done, jnp.array(finite),
                     jnp.array(blocked), jnp.int32(0), jnp.int32(detect), jnp.int32(align),
                     jnp.array(lost), NO_PLANE, jnp.int32(-1), (nan, nan), stats, NO_CLUTTER)
    return Reason(int(record.reason))


def test_one_reason_per_attempt_in_the_documented_precedence():
    assert _reason(executed=True, outcome=Outcome.SLIPPED) == Reason.SLIPPED
    assert _reason(executed=True, outcome=Outcome.SUCCESS, finite=False) == Reason.DIVERGED
    assert _reason(executed=True, outcome=Outcome.DIVERGED) == Reason.DIVERGED
    assert _reason(aimed=False, blocked=True, align=AlignReason.NO_PLANE) == Reason.NO_TARGET
    assert _reason(blocked=True, align=AlignReason.TOO_FEW_INLIERS) == Reason.ALIGN_TOO_FEW_INLIERS
    assert _reason(blocked=True, align=AlignReason.FOUND) == Reason.VIEW_UNREACHABLE
    # A view that lost its target has no anchor to re-align around either (alignment:
    # NO_DEPTH, blocked): the attempt ends as the lost target it is, whatever the budget.
    assert _reason(blocked=True, lost=True, align=AlignReason.NO_DEPTH) == Reason.TARGET_LOST
    assert _reason(lost=True) == Reason.TARGET_LOST
    assert Reason.TARGET_LOST.label == "target lost"
    assert _reason(detect=GraspReason.NO_WALL) == Reason.DETECT_NO_WALL
    # Every code has its label, and the offsets mirror the perception enums.
    assert Reason.DETECT_NO_ROOM.label == "detection: NO_ROOM"
    assert Reason.ALIGN_NO_PLANE.label == "alignment: NO_PLANE"
    assert Reason.VIEW_UNREACHABLE.label == "alignment: VIEW_UNREACHABLE"
    for g in GraspReason:
        if g != GraspReason.FOUND:
            assert Reason[f"DETECT_{g.name}"] == DETECT_BASE + g
    for a in AlignReason:
        if a != AlignReason.FOUND:
            assert Reason[f"ALIGN_{a.name}"] == ALIGN_BASE + a


def test_realigned_view_looks_along_the_negative_normal(basic_sim):
    """A wedge (c): its sloped top is the best plane; the new view faces it at the same range
    (the turn by the metric normal, ours: the paper's pixel-unit normal is tested in
    test_align.py)."""
    config = override(CONFIG, ["align.turn_normal=metric"])
    data = _world(basic_sim, {2: (0.0, 0.0, 0.0)})
    rotation, position = look_down(jnp.array([0.0, 0.0, 0.5]))
    top = jax.jit(lambda d: select_target(basic_sim.scene, d, jnp.ones(6, bool), jnp.array(True),
                                          jnp.array(False), CAMERA, CONFIG,
                                          jax.random.key(1))[2])(data)  # on the wedge's top
    v = jax.jit(lambda d: view(basic_sim.scene, d, rotation, position, jnp.int32(2), top,
                               jnp.array(False), CAMERA, config, jax.random.key(1)))(data)
    a: Alignment = v.alignment
    assert bool(a.found) and bool(v.can_realign)
    # The wedge's top rises 3 cm over 6.5 cm along +x: its upward normal, in the world.
    slope = np.arctan2(0.03, 0.065)
    expected = np.array([-np.sin(slope), 0.0, np.cos(slope)])
    normal_world = np.asarray(rotation @ a.normal)
    assert normal_world @ expected > np.cos(np.deg2rad(2.0))
    new_axis = np.asarray(v.next_rotation[:, 2])
    np.testing.assert_allclose(new_axis, -normal_world, atol=1e-5)
    point = np.asarray(rotation @ a.point + position)
    assert np.linalg.norm(np.asarray(v.next_position) - point) == pytest.approx(
        float(np.linalg.norm(a.point)), rel=1e-5)
    # The new frame is a proper rotation: orthonormal, right-handed.
    r = np.asarray(v.next_rotation)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-5)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-5)
    # Ground truth: the plane lies on the wedge, along its sloped face, and the view tilts by
    # the slope's angle.
    truth = v.truth
    assert Surface(int(truth.surface)) == Surface.TARGET and float(truth.on_target) > 0.9
    assert float(truth.normal_error_deg) < 2.0
    assert float(truth.view_tilt_deg) == pytest.approx(np.degrees(slope), abs=2.0)


def test_plane_truth_names_the_surface_and_the_nearest_face():
    """Hand-made views: a plane whose inliers lie mostly on the table, and one on the target
    tilted 10 degrees from the target's top face, seen by a view tilted 30 degrees."""
    surface = np.full((10, 10), int(Surface.TABLE))
    surface[:, 6:] = Surface.TARGET
    surface[0] = Surface.NONE
    inliers = np.zeros((10, 10), bool)
    inliers[2:8, 1:7] = True  # 30 table pixels, 6 target pixels
    yaw = np.deg2rad(25.0)
    faces = np.array([[np.cos(yaw), np.sin(yaw), 0], [-np.sin(yaw), np.cos(yaw), 0], [0, 0, 1],
                      [0, 0, -1], [0.6, 0.8, 0.0]])  # a box's faces, then another piece's
    real = np.array([True, True, True, True, False])
    tilted = np.array([np.sin(np.deg2rad(10.0)), 0.0, np.cos(np.deg2rad(10.0))])
    axis = -np.array([np.sin(np.deg2rad(30.0)), 0.0, np.cos(np.deg2rad(30.0))])
    truth = plane_truth(jnp.asarray(surface), jnp.asarray(inliers), jnp.asarray(tilted),
                        (jnp.asarray(faces), jnp.asarray(real)), jnp.array(True), jnp.asarray(axis))
    assert Surface(int(truth.surface)) == Surface.TABLE
    assert float(truth.on_target) == pytest.approx(6 / 36)
    assert float(truth.normal_error_deg) == pytest.approx(10.0, abs=1e-3)
    assert float(truth.view_tilt_deg) == pytest.approx(30.0, abs=1e-3)
    inliers[:] = False
    inliers[3:6, 6:9] = True
    truth = plane_truth(jnp.asarray(surface), jnp.asarray(inliers), jnp.asarray(faces[0]),
                        (jnp.asarray(faces), jnp.asarray(real)), jnp.array(True), jnp.asarray(axis))
    assert Surface(int(truth.surface)) == Surface.TARGET and float(truth.on_target) == 1.0
    assert float(truth.normal_error_deg) == pytest.approx(0.0, abs=0.1)
    none = plane_truth(jnp.asarray(surface), jnp.asarray(inliers), jnp.asarray(faces[0]),
                       (jnp.asarray(faces), jnp.asarray(real)), jnp.array(False), jnp.asarray(axis))
    assert Surface(int(none.surface)) == Surface.NONE and np.isnan(float(none.normal_error_deg))


def test_grasp_pose_in_the_world(basic_sim):
    """A cube seen from a tilted camera: the world grasp is the cube's top, closing across it."""
    data = _world(basic_sim, {0: (0.0, 0.0, 0.0)})
    tilt = axis_angle(jnp.array([1.0, 0.0, 0.0]), jnp.deg2rad(10.0))
    rotation = tilt @ look_down(jnp.zeros(3))[0]
    position = jnp.array([0.0, 0.0, 0.05]) - 0.45 * rotation[:, 2]
    v = jax.jit(lambda d: view(basic_sim.scene, d, rotation, position, jnp.int32(0),
                               jnp.array([0.0, 0.0, 0.05]), jnp.array(False), CAMERA, CONFIG,
                               jax.random.key(2)))(data)
    g = v.grasp_pose
    assert bool(g.valid)
    np.testing.assert_allclose(np.asarray(g.approach), np.asarray(rotation[:, 2]), atol=1e-6)
    assert abs(float(g.approach @ g.closing)) < 1e-5
    # The finger tips go grasp_depth (2 cm) below the cube's top, near its centre.
    assert np.linalg.norm(np.asarray(g.tcp)[:2]) < 0.01
    assert float(g.tcp[2]) == pytest.approx(0.05 - 0.02 * float(-g.approach[2]), abs=0.004)


@pytest.mark.parametrize("budget", [0, 1])
def test_the_search_stops_at_the_re_alignment_budget(basic_sim, budget):
    """The wedge (c) under the wall check: its top band has no wall, so the centred view fails
    and the procedure re-aligns; with budget 0 it takes that one view and no more. (With A at
    z_min, the ramp's corner, the re-aligned camera centres on the ramp's corner and finds a
    grasp there; A at the band's centre turns to the same ramp plane, but its view of the
    ramp's middle fails the wall check again; windows around each triangle, the turn by the
    metric normal.)"""
    from graspjax.procedure.steps import _search

    config = override(CONFIG, ["detect.wall_check=true", "align.anchor=nearest",
                               "align.window_centre=triangle", "align.turn_normal=metric",
                               f"procedure.max_reorientations={budget}"])
    data = _world(basic_sim, {2: (0.0, 0.0, 0.0)})
    eligible = jnp.zeros(6, bool).at[2].set(True)
    search = jax.jit(lambda d, c: _search(basic_sim.scene, d, eligible, jnp.array(True),
                                          jnp.array(False), jax.random.key(3), c, True))
    target, aimed, pose, (blocked, turns, detect_reason, *_), views = search(data, config)
    assert int(target) == 2 and bool(aimed)
    looked = np.asarray(views.looked)
    assert looked[:2].all() and looked.sum() == 2 + int(turns)  # overview, then each view taken
    assert int(turns) <= budget and not looked[2 + budget:].any()
    if budget == 0:
        assert not bool(pose.valid) and int(detect_reason) == GraspReason.NO_WALL
    else:
        assert bool(pose.valid) and int(turns) == 1


def _search_with_labels(scene, data, relabel, config):
    """`_search` (views kept) with the renderer's object label of every pixel passed through
    `relabel` (n,) int32 (a label < 0, no object, stays)."""
    from graspjax.procedure import steps

    original = steps._look

    def look(*args):
        depth, objects, table = original(*args)
        return depth, jnp.where(objects >= 0, relabel[jnp.maximum(objects, 0)], objects), table

    steps._look = look  # under this trace only
    try:
        return steps._search(scene, data, jnp.ones(scene.num_objects, bool), jnp.array(True),
                                 jnp.array(False), jax.random.key(5), config, True)
    finally:
        steps._look = original


def test_the_method_decides_on_depth_alone(basic_sim):
    """Done-when test of depth-only perception: with the labels of every rendered pixel
    permuted, merged into one object or erased, the search's decisions are bit for bit the
    same (grasp pose, re-alignments, every reason, every image, the masks where it took z_min,
    every T-beam and plane), in a top-down and in a 30-degree tilted view that re-aligns; only
    the credit and the ground-truth attribution follow the labels. The oracle reads them, so
    its decisions change: the check can fail."""
    scene = basic_sim.scene
    # The wedge (4 cm, the highest) with the block (3 cm) 2 mm beside it; under the wall check
    # the wedge's ramp holds no grasp and the search re-aligns.
    data = _world(basic_sim, {2: (0.0, 0.0, 0.0), 5: (0.0, 0.047, 0.0)})
    search = jax.jit(lambda d, r, c: _search_with_labels(scene, d, r, c))
    n = scene.num_objects
    labels = {"true": np.arange(n), "permuted": np.roll(np.arange(n), 2),
              "one object": np.zeros(n), "no object": np.full(n, -1)}

    def decisions(out):
        _, aimed, pose, progress, views = out
        blocked, turns, detect_reason, align_reason, lost, *_ = progress
        return (aimed, pose, blocked, turns, detect_reason, align_reason, lost, views.depth,
                views.seed_mask, views.looked, views.rotation, views.position, views.grasp,
                views.alignment)

    turns = []
    for tilt in (0.0, 30.0):
        config = override(CONFIG, [f"procedure.view_tilt_deg={tilt}", "detect.wall_check=true"])
        runs = {name: search(data, jnp.asarray(r, jnp.int32), config) for name, r in labels.items()}
        reference = decisions(runs["true"])
        for name, out in runs.items():
            jax.tree.map(lambda a, b, name=name: np.testing.assert_array_equal(a, b, err_msg=name),
                         decisions(out), reference)
        turns.append(int(reference[3]))
        credit = {name: int(out[0]) for name, out in runs.items()}
        assert credit["true"] == 2 and credit["permuted"] == labels["permuted"][2]
        assert credit["one object"] == 0 and credit["no object"] == -1

        oracle = override(config, ["perception.oracle=true"])
        told = decisions(search(data, jnp.asarray(labels["true"], jnp.int32), oracle))
        blind = decisions(search(data, jnp.asarray(labels["no object"], jnp.int32), oracle))
        assert bool(told[0]) and not bool(blind[0])  # the oracle sees no object without labels
        assert not np.array_equal(np.asarray(told[8]), np.asarray(blind[8]))
    assert max(turns) >= 1  # a view re-aligned: the check covers that path
