"""The jaws checked on the full-resolution image (`perception/jaws.py`), and the ranked search of
`detect_real_image`, on analytic scenes: parts whose jaws would land on their own top or on a
step, a rounded part the realistic checks accept, and a workspace where only one part can be
grasped."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import detect_one
from real_scenes import table_centre, table_with
from scipy import ndimage

from graspjax.config import Config, RealImageConfig, preset
from graspjax.imagefiles.batches import detect_batch, stack_cameras
from graspjax.perception import GraspReason
from graspjax.perception.jaws import JawRule, _joined, check_jaws, height_map
from graspjax.perception.support import SupportPlane
from graspjax.perception.virtual import view_camera, view_rotation
from graspjax.perception.window import in_view
from graspjax.synthetic import box, prism, regular_prism, rot_x, rot_y

CENTRE = table_centre()


def _table(normal, distance, found=True) -> SupportPlane:
    """The table as a support plane (camera frame), found or not."""
    return SupportPlane(found=jnp.asarray(found), reason=jnp.int32(0), normal=normal,
                        distance=distance, tilt=jnp.float32(0), inliers=jnp.int32(0),
                        fraction=jnp.float32(1))

@jax.jit
def _map(depth, camera, normal, distance, image, found=True):
    """The jaws' height map of a table image, seen along the table's normal; `found`: whether
    the table is known as the support plane."""
    turn = view_rotation(normal, jnp.array(True))
    return height_map(depth, camera, turn, view_camera(camera, turn), distance,
                      in_view(_table(normal, distance, found), turn), image.sweep_fill_px)


@jax.jit
def _check(depth, camera, normal, distance, centre, axis, width, config, image, found=True):
    """The jaws' height map of a table image seen along the table's normal (`normal` (3,) toward
    the camera, `distance` to the plane, camera frame), and `check_jaws` on one grasp (centre,
    axis (3,), camera frame)."""
    turn = view_rotation(normal, jnp.array(True))
    heights = _map(depth, camera, normal, distance, image, found)
    return check_jaws(heights, turn.T @ centre, turn.T @ axis, width, config.detect,
                      config.gripper, image)


def _jaws(solids, top, axis_world, width, config=Config(), image=RealImageConfig(), lose=None,
          tilt_deg=13.0, support=True):
    """check_jaws for a grasp at world point `top` closing along `axis_world`, the approach
    straight down onto the table; `lose`: which pixels the sensor loses, from their world points
    (H, W, 3) relative to the table's centre; the camera `tilt_deg` off vertical; `support`:
    the table known as the support plane."""
    depth, camera, workspace, rotation, eye = table_with(solids, tilt_deg=tilt_deg)
    if lose is not None:
        depth = np.where(lose(_world(depth, camera, rotation, eye)), 0.0, depth)
    depth = np.where(workspace, depth, 0.0).astype(np.float32)
    centre = rotation.T @ (np.asarray(top, float) - eye)
    axis = rotation.T @ np.asarray(axis_world, float)
    normal = rotation.T @ np.array([0.0, 0.0, 1.0])
    result = _check(depth, camera, normal.astype(np.float32), np.float32(eye[2]),
                    centre.astype(np.float32), axis.astype(np.float32), np.float32(width),
                    config, image, support)
    return jax.tree.map(np.asarray, result)


def _at(x=0.0, y=0.0, z=0.0):
    return (CENTRE[0] + x, CENTRE[1] + y, z)


X, Y = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)


def _world(depth, camera, rotation, eye):
    """World points (H, W, 3) of every pixel, relative to the table's centre."""
    v, u = np.mgrid[:depth.shape[0], :depth.shape[1]]
    rays = np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(depth)])
    return np.einsum("ij,jhw->hwi", rotation, rays * depth) + eye - [*CENTRE, 0.0]


def _table_between(x_from, x_to):
    """The table (z < 2 mm) between these world x, within 4 cm in y: a shadow, as a
    projector's sensor loses it."""
    return lambda world: ((world[..., 2] < 0.002) & (world[..., 0] > x_from)
                          & (world[..., 0] < x_to) & (np.abs(world[..., 1]) < 0.04))


BOX = box((0.04, 0.06, 0.04), _at())  # 4 x 6 x 4 cm, grasped across x (4 cm) or along y
WANTED = min(Config().detect.grasp_depth, Config().gripper.finger_length)


def test_a_box_alone_is_grasped_with_both_fingers_free_to_the_grasp_depth():
    """Across its 4 cm both footprints (4 to 5.2 cm out) stand over the table 4 cm down: the
    jaws reach the full grasp depth, touch the box's sides 4 cm apart (within a cell and a
    sample, 3 mm, each side) and land on nothing above the table; along its 6 cm the same. A 9 mm band is too
    narrow whatever the jaws find."""
    for config in (Config(), preset("realistic")):
        for axis, width in ((X, 0.04), (Y, 0.06)):
            result = _jaws([BOX], _at(z=0.04), axis, width, config)
            assert result.reason == GraspReason.FOUND and result.failed == 0
            assert abs(float(result.depth) - WANTED) < 1e-4
            assert abs(float(result.landing) - 0.04) < 0.002  # the table under the fingers
            assert abs(float(result.clearance) - (0.04 - WANTED)) < 0.002
            assert width - 0.0035 < float(result.contact_width) < width + 0.006
        assert _jaws([BOX], _at(z=0.04), X, 0.009, config).reason == GraspReason.TOO_NARROW


@pytest.mark.parametrize("gap, height, reason, reach", [
    (0.01, 0.04, GraspReason.JAWS_BLOCKED, None),  # its top under the +x finger
    (0.01, 0.02, GraspReason.FOUND, 0.02 - 0.003),  # lower: the finger goes down to it
    (0.035, 0.04, GraspReason.FOUND, WANTED)])  # beyond the finger's outer face (5.2 cm)
def test_a_neighbour_under_a_finger_holds_it_up(gap, height, reason, reach):
    """A second box `gap` beyond the first's +x face, `height` high: 1 cm away (narrower than
    the finger's room, the open finger spans 2 to 3.2 cm beyond the face) and as high, the
    finger lands on its top; 2 cm high, the finger stops on it 2 cm down, less the 3 mm
    depth clearance, deep enough; 3.5 cm away the finger passes beside it."""
    neighbour = box((0.04, 0.06, height), _at(x=0.04 + gap))
    result = _jaws([BOX, neighbour], _at(z=0.04), X, 0.04)
    assert result.reason == reason
    assert abs(float(result.landing) - (0.04 - height if gap < 0.03 else 0.04)) < 0.002
    if reach is not None:
        assert abs(float(result.depth) - reach) < 0.002


def test_a_tote_wall_beside_the_box_blocks_the_jaws_across_it_not_along_it():
    """A 1 cm thick, 12 cm high tote wall 1 cm beyond the box's +x face: across x the +x
    finger would come down on the wall; along y (parallel to the wall) both fingers are free."""
    wall = box((0.01, 0.3, 0.12), _at(x=0.035))
    across = _jaws([BOX, wall], _at(z=0.04), X, 0.04)
    assert across.reason == GraspReason.JAWS_BLOCKED
    assert across.failed & JawRule.REACH  # the finger lands on the wall's top, above the box
    assert float(across.landing) < 0.0  # the wall stands above the box's top
    along = _jaws([BOX, wall], _at(z=0.04), Y, 0.06)
    assert along.reason == GraspReason.FOUND
    assert abs(float(along.depth) - WANTED) < 1e-4


def test_a_second_part_between_the_jaws_is_what_they_close_on():
    """A 1 cm wide, 3 cm high bar 7 mm beyond the box's +x face, inside the open jaws: the
    fingers come down free (the bar ends 2.7 cm from the centre, the finger starts at 4), but
    closing 2 cm below the top they meet the bar first, past a fall to the table: refused. A
    bar of the box (against its face) is the part's own width: the jaws close on both, 5 cm."""
    apart = box((0.01, 0.06, 0.03), _at(x=0.032))
    against = box((0.01, 0.06, 0.03), _at(x=0.025))
    blocked = _jaws([BOX, apart], _at(z=0.04), X, 0.04)
    assert blocked.reason == GraspReason.JAWS_BLOCKED
    assert blocked.failed & JawRule.GAP and not blocked.failed & JawRule.REACH
    joined = _jaws([BOX, against], _at(z=0.04), X, 0.04)
    assert joined.reason == GraspReason.FOUND
    assert 0.05 - 0.0035 < float(joined.contact_width) < 0.05 + 0.006


def test_a_groove_of_the_part_itself_is_not_a_second_part():
    """A 4 x 6 x 4 cm part with a 7 mm slot 5 mm inside its +x face, open to +y and closed at -y:
    the lanes from y = -5 mm up cross the slot (a fall to the table) and rise on the part's far
    wall, which is joined to the part through the lanes below y = -5 mm: one piece, the jaws
    close on the wall (4 cm). Cut the slot through (the wall a bar of its own): refused."""
    body = box((0.025, 0.06, 0.04), _at(x=-0.0075))
    wall = box((0.008, 0.06, 0.04), _at(x=0.016))
    bridge = box((0.007, 0.025, 0.04), _at(x=0.0085, y=-0.0175))
    one_piece = _jaws([body, bridge, wall], _at(z=0.04), X, 0.04)
    assert one_piece.reason == GraspReason.FOUND and one_piece.failed == 0
    assert 0.04 - 0.0035 < float(one_piece.contact_width) < 0.04 + 0.006
    apart = _jaws([body, wall], _at(z=0.04), X, 0.04)
    assert apart.reason == GraspReason.JAWS_BLOCKED and apart.failed & JawRule.GAP


@pytest.mark.parametrize("fraction", [0.45, 0.6, 0.75])
def test_the_samples_joined_to_the_centre_are_its_four_connected_component(fraction):
    """`_joined` on random regions and on a snake that changes lanes at every turn: each side's
    samples in the components of `scipy.ndimage.label` (4-neighbours) that meet the centre,
    grown one step per loop iteration or four (`detect.unrolled_loops`)."""
    rng = np.random.default_rng(int(fraction * 100))
    regions = rng.random((40, 2, 32, 9)) < fraction  # (grasps, side, out, lane)
    snake = np.zeros((2, 32, 9), bool)  # lane 0 from the centre, then lanes 2, 4, 6, 8 from
    snake[:, :, 0] = True  # sample 1 (not seeds), joined at alternate ends by lanes 1, 3, 5, 7
    snake[:, 1:, 2::2] = True
    snake[:, 31, 1::4] = True
    snake[:, 1, 3::4] = True
    regions = np.concatenate([regions, snake[None]])
    got, unrolled = (np.asarray(jax.jit(jax.vmap(lambda r, n=n: _joined(r, n)))(jnp.asarray(regions)))
                     for n in (1, 4))
    np.testing.assert_array_equal(unrolled, got)
    for region, joined in zip(regions, got, strict=True):
        for side in range(2):
            labels, _ = ndimage.label(region[side])  # 4-connectivity
            centre = set(labels[0][labels[0] > 0])
            np.testing.assert_array_equal(joined[side], np.isin(labels, list(centre)))
    np.testing.assert_array_equal(got[-1], snake)  # one piece, reached through every lane


def test_a_hole_without_depth_under_a_finger_reads_as_the_floor_around_it():
    """The table beside the box's +x face without depth from 1 to 6 cm out (a shadow, as a
    projector's sensor loses it): the finger's cells are unseen, and read as the support (the
    floor seen around them, or the plane): the grasp passes, its unseen share stated. Without a
    support plane nothing is known there: refused, the fingers' landing unknown (-inf). (A
    dropout in a top reads as the top: `test_the_height_map_holds_the_scene_along_the_approach`.)"""
    hole = _table_between(0.03, 0.08)
    for config in (Config(), preset("realistic")):
        alone = _jaws([BOX], _at(z=0.04), X, 0.04, config, lose=hole)
        assert alone.reason == GraspReason.FOUND
        assert float(alone.unknown) > 0.1
        assert abs(float(alone.landing) - 0.04) < 0.002
        unknown = _jaws([BOX], _at(z=0.04), X, 0.04, config, lose=hole, support=False)
        assert unknown.reason == GraspReason.JAWS_BLOCKED
        assert float(unknown.landing) == -np.inf
        assert _jaws([BOX], _at(z=0.04), X, 0.04, config, support=False).reason == GraspReason.FOUND


def test_the_height_map_holds_the_scene_along_the_approach():
    """The table seen 13 and 40 degrees off vertical, turned to face it: every cell holds the
    depth along the table's normal of the highest point in it, the camera's height above the
    table less the box's where the box stands (analytic). Cells no point falls in: a 4 mm
    dropout on the box's top reads as the top, a 4 mm strip of table lost beside the box as the
    table seen beyond it (the deepest seen within `sweep_fill_px` cells), a 10 cm hole in the
    table as the support plane."""
    image = RealImageConfig()
    for tilt in (13.0, 40.0):
        cx, cy = table_centre(tilt)
        solids = [box((0.04, 0.06, 0.04), (cx, cy, 0.0))]
        depth, camera, workspace, rotation, eye = table_with(solids, tilt_deg=tilt)
        world = _world(depth, camera, rotation, eye) + [*CENTRE, 0.0] - [cx, cy, 0.0]
        dropout = (np.abs(world[..., 0]) < 0.002) & (np.abs(world[..., 1]) < 0.002)
        strip = ((world[..., 0] > 0.0205) & (world[..., 0] < 0.0245)
                 & (np.abs(world[..., 1]) < 0.02) & (world[..., 2] < 0.002))
        hole = (world[..., 0] > -0.17) & (world[..., 0] < -0.07) & (np.abs(world[..., 1]) < 0.05)
        depth = np.where(dropout | strip | hole, 0.0, depth).astype(np.float32)
        normal = (rotation.T @ np.array([0.0, 0.0, 1.0])).astype(np.float32)
        heights = jax.tree.map(np.asarray, _map(depth, camera, normal, np.float32(eye[2]), image))
        turn = np.asarray(view_rotation(normal, True))

        def at(x, y, heights=heights, turn=turn, eye=eye, rotation=rotation, cx=cx, cy=cy):
            xy = (turn.T @ rotation.T @ (np.array([cx + x, cy + y, 0.0]) - eye))[:2]
            ij = np.round(xy / heights.cell + heights.centre).astype(int)
            return heights.depth[ij[1], ij[0]], heights.seen[ij[1], ij[0]]

        top, table = eye[2] - 0.04, eye[2]
        assert abs(at(-0.01, 0.01)[0] - top) < 0.001  # the box's top
        assert abs(at(0.0, 0.08)[0] - table) < 0.001  # the table
        for (x, y), level in (((0.0, 0.0), top), ((0.0225, 0.0), table), ((-0.12, 0.0), table)):
            depth_there, seen = at(x, y)
            assert not seen and abs(depth_there - level) < 0.001, (tilt, x, y, depth_there)


def _ridged_top(length=0.12):
    """A 6 cm wide part, `length` long (y), 2 cm high, with a ridge along y: 2 cm wide on top,
    6.5 mm higher, its flanks sloping 30 degrees down to a 8.75 mm wide shoulder along each
    edge (the top falls 6.5 mm, gently, then 2 cm to the table)."""
    rise = 0.0065
    half_base = 0.01 + rise / np.tan(np.deg2rad(30.0))
    trapezoid = [(-half_base, 0.0), (half_base, 0.0), (0.01, rise), (-0.01, rise)]
    ridge = prism(trapezoid, length).moved(rot_x(np.pi / 2), _at(y=length / 2, z=0.02))
    return [box((0.06, length, 0.02), _at()), ridge]


def test_a_top_falling_gently_past_the_band_is_grasped_across_the_whole_part():
    """The ridged part (`_ridged_top`), 12 cm long: the T-beam's band (within 5 mm of the
    ridge's depth) ends on the flanks; the fingers come down beside the part, 6 cm wide, and
    close 2 cm below the ridge on its sides, within friction x that depth of the band's edge:
    a grasp of the whole part (along it the part is too long)."""
    depth, camera, workspace, rotation, eye = table_with(_ridged_top())
    r = detect_one(depth, workspace, camera, Config(),
                   RealImageConfig(contour_search=False, max_targets=1))
    assert bool(r.found)
    axis = rotation @ r.closing_axis
    assert abs(axis[0]) > 0.97  # across the part
    assert abs(float(r.ranked.contact_width[0]) - 0.06) < 0.006
    assert float(r.ranked.landing[0]) > 0.02  # its sides fall to the table


def test_a_rounded_top_is_held_where_the_jaws_touch_it():
    """A cylinder (r = 2.5 cm) lying along x: its top band is 3 cm wide, the jaws close 2 cm
    below the top on its flanks, 2 sqrt(r^2 - (r - 2 cm)^2) = 4.9 cm apart, where the side is
    steep enough for the pads (realistic checks)."""
    radius = 0.025
    cylinder = regular_prism(48, radius, 0.08).moved(rot_y(np.pi / 2),
                                                     _at(x=-0.04, z=radius))
    realistic = preset("realistic")
    result = _jaws([cylinder], _at(z=2 * radius), Y, 0.03, realistic)
    assert result.reason == GraspReason.FOUND, GraspReason(int(result.reason)).name
    assert abs(float(result.contact_width) - 2 * np.sqrt(radius**2 - 0.005**2)) < 0.004


def test_only_the_graspable_part_of_a_workspace_is_returned():
    """The highest part is 12 cm square (wider than the opening both ways), the next a flat
    10 cm plate; the third, a 3 x 5 x 3 cm box, is the one grasp: found on a later target,
    closing across its 3 cm or along its 5 cm (both fit the opening, their scores within a
    centre's offset), and ranked with the tried targets' reasons."""
    solids = [box((0.12, 0.12, 0.08), _at(x=-0.1)), box((0.1, 0.1, 0.05), _at(x=0.1, y=0.06)),
              box((0.03, 0.05, 0.03), _at(x=0.07, y=-0.08))]
    depth, camera, workspace, rotation, eye = table_with(solids)
    r = detect_one(depth, workspace, camera, Config(), RealImageConfig())
    assert bool(r.found)
    assert int(r.targets_tried) >= 2
    assert r.tried_reasons[0] == GraspReason.TOO_WIDE
    top = rotation.T @ (np.array(_at(x=0.07, y=-0.08, z=0.03)) - eye)
    assert np.linalg.norm(r.position - top) < 0.02
    assert min(abs(float(r.ranked.width[0]) - 0.03), abs(float(r.ranked.width[0]) - 0.05)) < 0.003
    assert bool(r.ranked.valid[0]) and np.isfinite(r.ranked.score[0])


def test_an_empty_table_gives_no_object_and_tries_no_target():
    """Nothing on the table: no target (NO_OBJECT), none tried, no grasp ranked, the grasp's
    numbers nan: the failure is data, whatever the search's loop ran."""
    from graspjax.codes import TargetReason

    depth, camera, workspace, _, _ = table_with([])
    r = detect_one(depth, workspace, camera, Config(), RealImageConfig())
    assert not bool(r.found)
    assert int(r.target_reason) == TargetReason.NO_OBJECT and r.reason_name == "NO_OBJECT"
    assert int(r.targets_tried) == 0 and np.all(r.tried_reasons == -1)
    assert not np.any(r.ranked.valid) and np.all(np.isnan(r.position))


def _wedge_and_box():
    """A 12 x 12 cm wedge sloping from 6.4 to 2 cm high and a 3 x 4 x 1.5 cm box."""
    profile = [(-0.06, 0.0), (0.06, 0.0), (0.06, 0.064), (-0.06, 0.02)]
    wedge = prism(profile, 0.12).moved(rot_x(np.pi / 2), _at(x=-0.05, y=0.06))
    return [wedge, box((0.03, 0.04, 0.015), _at(x=0.09, y=-0.05))]


def test_a_target_given_up_gives_up_its_object():
    """A 12 x 12 cm wedge, its top sloping 20 degrees from 6.4 cm down to 2 cm (too wide to
    grasp across either way; every band of it a strip whose jaws land on the slope below), and
    a 3 x 4 x 1.5 cm box. Its bands are the highest targets, one after another (the old rule,
    giving up a band at a time, spends three targets on them); once the first is given up, its
    whole followed surface (the wedge's top) is, so the second target is the box."""
    depth, camera, workspace, rotation, eye = table_with(_wedge_and_box())
    r = detect_one(depth, workspace, camera, Config(), RealImageConfig())
    assert bool(r.found)
    assert int(r.targets_tried) == 2
    assert r.tried_reasons[0] != GraspReason.FOUND and r.tried_reasons[1] == GraspReason.FOUND
    assert int(r.ranked.target[0]) == 1
    top = rotation.T @ (np.array(_at(x=0.09, y=-0.05, z=0.015)) - eye)
    assert np.linalg.norm(r.position - top) < 0.02
    assert np.linalg.norm(r.target_point - top) < 0.03  # the second target is on the box


def test_a_batch_gives_each_image_what_it_gets_alone():
    """vmap at the edge, where a batch runs both branches of the target loop's conds (a GPU's
    `graspjax detect` batches, a CPU's runs one image at a time): the wedge and box (its first
    target given up) and the bar between neighbours (rescued by the contour search), in one
    batch (of two, with the default settings: the program of test_bench's batch), get the
    targets, reasons and ranked grasps they get alone."""
    scenes = [table_with(_wedge_and_box()), table_with(_bar_between_neighbours())]
    camera, workspace = scenes[0][1], scenes[0][2]  # the same table view
    image = RealImageConfig()
    depths = np.stack([scene[0] for scene in scenes])
    batch = jax.tree.map(np.asarray, detect_batch(depths, workspace,
                                                  stack_cameras([camera] * len(scenes)),
                                                  Config(), image))
    alone = [detect_one(depth, workspace, camera, Config(), image) for depth in depths]
    assert int(alone[0].targets_tried) == 2 and bool(alone[1].ranked.contour[0])  # both branches
    for i, single in enumerate(alone):
        got = jax.tree.map(lambda x, i=i: x[i], batch)
        assert bool(got.found) and bool(single.found)
        assert int(got.targets_tried) == int(single.targets_tried)
        np.testing.assert_array_equal(got.tried_reasons, single.tried_reasons)
        np.testing.assert_array_equal(got.ranked.valid, single.ranked.valid)
        np.testing.assert_array_equal(got.ranked.contour, single.ranked.contour)
        valid = single.ranked.valid
        np.testing.assert_allclose(got.ranked.position[valid], single.ranked.position[valid],
                                   atol=1e-4)
        np.testing.assert_allclose(got.ranked.width[valid], single.ranked.width[valid], atol=1e-4)


@pytest.mark.parametrize("top_k", [3])
def test_ranked_grasps_are_distinct_and_best_first(top_k):
    """On one 4 x 7 x 4 cm box: several distinct grasps, scores falling, none a mirror of
    another (the same centre and axis)."""
    depth, camera, workspace, rotation, eye = table_with([box((0.04, 0.07, 0.04), _at())])
    ranked = detect_one(depth, workspace, camera, Config(), RealImageConfig(top_k=top_k)).ranked
    assert ranked.valid.sum() >= 2
    scores = ranked.score[ranked.valid]
    assert np.all(np.diff(scores) <= 1e-6)
    pos, axes = ranked.position[ranked.valid], ranked.closing_axis[ranked.valid]
    for i in range(len(pos)):
        for j in range(i):
            same = (np.linalg.norm(pos[i] - pos[j]) <= 0.01) and abs(axes[i] @ axes[j]) > 0.94
            assert not same


def _bar_between_neighbours():
    """A 4 x 14 x 5 cm bar between two 4.6 cm high neighbours 1 cm off its long sides, that
    end 4 cm past its centre."""
    return [box((0.04, 0.14, 0.05), _at()),
            *[box((0.03, 0.11, 0.046), _at(x=side * 0.045, y=-0.015)) for side in (-1, 1)]]


def test_a_blocked_bar_is_grasped_where_its_contour_is_free():
    """The bar between neighbours (`_bar_between_neighbours`): the open jaws over them, 4 mm
    below the top, have no room in the detection window. Every T-beam placement across the
    bar (at -4, 0 and +4 cm along it; along it the bar is too wide) has a pad over them. The
    contour search finds the free end: closing across the bar, both fingers (2 cm wide) past
    the neighbours' ends, the bar 4 cm wide."""
    depth, camera, workspace, rotation, eye = table_with(_bar_between_neighbours())

    def detect(image):
        return detect_one(depth, workspace, camera, Config(), image)

    tbeam_only = detect(RealImageConfig(contour_search=False, max_targets=1))  # as the ridged top
    assert tbeam_only.tried_reasons[0] == GraspReason.NO_ROOM  # the bar, highest, first
    r = detect(RealImageConfig())
    assert bool(r.found) and bool(r.ranked.contour[0])
    assert r.tried_reasons[0] == GraspReason.FOUND and int(r.ranked.target[0]) == 0
    centre = rotation @ r.position + eye - [*CENTRE, 0.0]  # world, from the bar's centre
    axis = rotation @ r.closing_axis
    assert abs(axis[0]) > 0.97  # across the bar
    assert abs(centre[0]) < 0.005 and abs(centre[2] - 0.05) < 0.003
    assert 0.04 + 0.01 - 0.0015 <= centre[1] <= 0.07  # the pads past the ends (a pixel's leeway)
    assert abs(float(r.ranked.width[0]) - 0.04) < 0.004
    # The reported detector result is the contour placement's (after the T-beam's candidates).
    # (the contour search's pairs: on the band's contour, then on the followed surface's)
    tbeams = r.grasp.candidates.valid.shape[0] - 2 * Config().baseline.antipodal_contacts
    assert int(r.grasp.index) >= tbeams and bool(r.grasp.found)
    assert np.allclose(r.rotation @ r.grasp.position, r.position, atol=1e-5)


def test_only_the_placed_grasps_are_checked_each_as_alone():
    """`check_jaws_where` (the target loop's checks, a chunk at a time): 20 grasps over a step
    and a plain block, 13 of them placed (two chunks); each placed one gets what `check_jaws`
    gives it alone (the float work may round in another order: 1e-7 m), the rest reason -1 and
    nan."""
    from graspjax.perception import jaws

    solids = [box((0.065, 0.04, 0.04), _at()), box((0.025, 0.04, 0.006), _at(z=0.04)),
              box((0.025, 0.04, 0.046), _at(x=0.09))]
    depth, camera, workspace, rotation, eye = table_with(solids, tilt_deg=13.0)
    depth = np.where(workspace, depth, 0.0).astype(np.float32)
    rng = np.random.default_rng(3)
    tops = [_at(z=0.046), _at(x=0.09, z=0.046)] * 10
    shift = rng.uniform(-0.004, 0.004, (20, 2))
    centre = np.stack([rotation.T @ (np.asarray(t) + (s[0], s[1], 0.0) - eye)
                       for t, s in zip(tops, shift, strict=True)]).astype(np.float32)
    angle = rng.uniform(-0.6, 0.6, 20)
    axis = np.stack([rotation.T @ (np.cos(a), np.sin(a), 0.0) for a in angle]).astype(np.float32)
    width = rng.uniform(0.02, 0.03, 20).astype(np.float32)
    placed = rng.random(20) < 0.65
    config, image = Config(), RealImageConfig()
    assert int(placed.sum()) > jaws._JAW_CHUNK  # two chunks
    normal = (rotation.T @ np.array([0.0, 0.0, 1.0])).astype(np.float32)
    heights = _map(depth, camera, normal, np.float32(eye[2]), image)
    turn = np.asarray(view_rotation(normal, True))
    centre, axis = centre @ turn, axis @ turn  # the view frame
    got = jax.tree.map(np.asarray, jax.jit(jaws.check_jaws_where)(
        placed, heights, centre, axis, width, config.detect, config.gripper, image))
    check = jax.jit(check_jaws)
    alone = [jax.tree.map(np.asarray, check(heights, centre[i], axis[i], width[i], config.detect,
                                            config.gripper, image))
             for i in np.flatnonzero(placed)]
    np.testing.assert_array_equal(got.reason[placed], [a.reason for a in alone])
    for field in ("depth", "clearance", "landing", "contact_width", "unknown"):
        np.testing.assert_allclose(getattr(got, field)[placed], [getattr(a, field) for a in alone],
                                   rtol=0, atol=1e-7)
        assert np.all(np.isnan(getattr(got, field)[~placed]))
    assert np.all(got.reason[~placed] == -1)
    assert {GraspReason.FOUND, GraspReason.JAWS_BLOCKED} <= set(got.reason[placed].tolist())


# --- the simulated procedure's sweep (`admit_by_jaws`, `detect.jaw_sweep`) ------------------
SWEEP_HEIGHT = 0.5  # the top-down camera's height above the table (m), as in the simulation


@jax.jit
def _swept(depth, camera, config):
    """The method's grasp on a top-down view and the same after `admit_by_jaws`."""
    from graspjax.perception.baselines import grasp_method
    from graspjax.perception.jaws import admit_by_jaws
    from graspjax.perception.support import known_support
    from graspjax.synthetic import top_down_pose

    rotation, eye = (jnp.asarray(x, jnp.float32) for x in top_down_pose(SWEEP_HEIGHT))
    grasp = grasp_method(config.method)(depth, camera, config, None)
    table = known_support(rotation, eye, jnp.array([0.0, 0.0, 1.0]), 0.0)
    return grasp, admit_by_jaws(grasp, depth, camera, table, config)


def _sweep_scene(solids, camera):
    from graspjax.synthetic import analytic_depth, top_down_pose

    rotation, eye = top_down_pose(SWEEP_HEIGHT)
    depth = analytic_depth(camera, rotation, eye, solids).astype(np.float32)
    return jax.tree.map(np.asarray, _swept(depth, camera, Config()))


def _closing(grasp, index):
    """Whether placement `index` closes along the camera's x (the world's x) rather than y."""
    return abs(grasp.candidates.axis[index][0]) > 0.9


def test_the_sweep_keeps_a_free_grasp_at_the_depth_asked(camera):
    """A box alone (5 x 3 x 4 cm): the method's grasp passes, unchanged, 2 cm deep."""
    method, swept = _sweep_scene([box((0.05, 0.03, 0.04))], camera)
    assert method.found and swept.found and swept.reason == GraspReason.FOUND
    assert swept.index == method.index
    np.testing.assert_allclose(swept.position, method.position)
    assert swept.depth == pytest.approx(Config().detect.grasp_depth)


def test_a_part_between_the_jaws_turns_the_grasp_to_the_free_axis(camera):
    """A 1 cm thick, 3 cm tall slab 1 cm beside the box's long side, inside the open jaws'
    reach across the box (4 cm from its axis) but clear of the fingers' footprints (past 4 cm):
    the depth-only checks admit closing across the box's 3 cm, the jaws would close on the
    slab too. The sweep takes the grasp across the box's 5 cm (closing along x), whose
    lanes (the 2 cm finger) pass the slab by."""
    slab = box((0.05, 0.01, 0.03), (0.0, 0.03, 0.0))
    method, swept = _sweep_scene([box((0.05, 0.03, 0.04)), slab], camera)
    admitted = np.flatnonzero(method.candidates.valid)
    across = [i for i in admitted if not _closing(method, i)]
    assert across, "the method admits closing across the 3 cm (the slab is no finger's floor)"
    assert swept.found and _closing(swept, swept.index)
    assert all(swept.candidates.reason[i] == GraspReason.JAWS_BLOCKED for i in across)


def test_blocked_on_every_axis_is_no_grasp_and_says_why(camera):
    """Slabs beside all four sides: every admitted placement's jaws close on a slab."""
    solids = [box((0.05, 0.03, 0.04)), box((0.05, 0.01, 0.03), (0.0, 0.03, 0.0)),
              box((0.05, 0.01, 0.03), (0.0, -0.03, 0.0)), box((0.01, 0.07, 0.03), (0.04, 0.0, 0.0)),
              box((0.01, 0.07, 0.03), (-0.04, 0.0, 0.0))]
    method, swept = _sweep_scene(solids, camera)
    assert method.found
    assert not swept.found and swept.reason == GraspReason.JAWS_BLOCKED and swept.index == -1
    assert np.isnan(swept.position).all()


def test_a_view_without_a_grasp_keeps_its_reason(camera):
    method, swept = _sweep_scene([], camera)
    assert not method.found and swept.reason == method.reason
