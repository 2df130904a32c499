"""The jaws checked on the full-resolution image (`perception/jaws.py`), and the ranked search of
`detect_real_image`, on analytic scenes: parts whose jaws would land on their own top or on a
step, a rounded part the realistic checks accept, and a workspace where only one part can be
grasped."""

import jax
import numpy as np
import pytest
from conftest import detect_one
from real_scenes import table_centre, table_with

from graspjax.config import Config, RealImageConfig, preset
from graspjax.imagefiles.batches import detect_batch, stack_cameras
from graspjax.perception import GraspReason
from graspjax.perception.jaws import check_jaws
from graspjax.synthetic import box, prism, regular_prism, rot_x, rot_y

CENTRE = table_centre()
check = jax.jit(check_jaws)


def _jaws(solids, top, axis_world, width, config=Config(), image=RealImageConfig(), lose=None,
          tilt_deg=13.0):
    """check_jaws for a grasp at world point `top` closing along `axis_world`; `lose`: which
    pixels the sensor loses, from their world points (H, W, 3) relative to the table's centre;
    the camera `tilt_deg` off vertical."""
    depth, camera, workspace, rotation, eye = table_with(solids, tilt_deg=tilt_deg)
    if lose is not None:
        depth = np.where(lose(_world(depth, camera, rotation, eye)), 0.0, depth)
    depth = np.where(workspace, depth, 0.0).astype(np.float32)
    centre = rotation.T @ (np.asarray(top, float) - eye)
    axis = rotation.T @ np.asarray(axis_world, float)
    approach = rotation.T @ np.array([0.0, 0.0, -1.0])
    result = check(depth, camera, centre.astype(np.float32), axis.astype(np.float32),
                   approach.astype(np.float32), np.float32(width), config.detect,
                   config.gripper, image)
    return jax.tree.map(np.asarray, result)


def _at(x=0.0, y=0.0, z=0.0):
    return (CENTRE[0] + x, CENTRE[1] + y, z)


X, Y = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)


def test_a_thin_rib_is_too_narrow_and_a_low_one_lands_the_jaws_on_the_part():
    """A 5 x 5 x 1.2 cm part with a rib along y on top: 9 mm wide it is narrower than
    `min_width`; 12 mm wide but 6 mm high, the jaws across it land on the part's own top (the
    rib falls less than the 8 mm shallowest grasp); along the rib they close on the part."""
    body = box((0.05, 0.05, 0.012), _at())
    narrow = [body, box((0.009, 0.05, 0.006), _at(z=0.012))]
    low = [body, box((0.012, 0.05, 0.006), _at(z=0.012))]
    assert _jaws(narrow, _at(z=0.018), X, 0.009).reason == GraspReason.TOO_NARROW
    assert _jaws(low, _at(z=0.018), X, 0.012).reason == GraspReason.JAWS_BLOCKED
    along = _jaws(low, _at(z=0.018), Y, 0.05)
    assert along.reason == GraspReason.FOUND
    # The part's own 5 cm, seen through tip-level rays of a camera tilted 13 degrees: on the
    # far side the part's top edge hides the ray's point, ~tan(15 deg) x 15 mm wider.
    assert 0.05 - 0.002 < float(along.contact_width) < 0.05 + 0.006
    assert abs(float(along.depth) - 0.015) < 0.002  # the table 18 mm down, less 3 mm


def test_jaws_beside_a_step_are_refused_and_beside_a_wall_are_not():
    """A 2.5 cm block 6 mm high on a 6.5 x 4 x 4 cm base: across x the jaws land on the step;
    the same grasp on a plain 2.5 cm wide block passes, jaws free to the 2 cm grasp depth."""
    step = [box((0.065, 0.04, 0.04), _at()), box((0.025, 0.04, 0.006), _at(z=0.04))]
    assert _jaws(step, _at(z=0.046), X, 0.025).reason == GraspReason.JAWS_BLOCKED
    plain = _jaws([box((0.025, 0.04, 0.046), _at())], _at(z=0.046), X, 0.025)
    assert plain.reason == GraspReason.FOUND
    assert abs(float(plain.depth) - 0.02) < 1e-4
    assert 0.025 - 0.002 < float(plain.contact_width) < 0.025 + 0.008  # tilt: as above
    assert float(plain.clearance) > 0.02  # the table, 46 mm below the top


def test_a_ledge_under_part_of_a_pad_holds_that_jaw_up():
    """A 4 x 6 x 4 cm part with a 2 x 1 cm ledge 6 mm below its top against its +x face, under
    half of one pad (the pad spans y -1..+1 cm; the ledge y 0..+1 cm): the jaws across x are
    refused, the fall beside the band at the worst lane is the ledge's 6 mm (under the 8 mm
    shallowest grasp); without the ledge every lane falls to the table, 4 cm down."""
    body = box((0.04, 0.06, 0.04), _at())
    ledge = box((0.02, 0.01, 0.034), _at(x=0.03, y=0.005))
    for config in (Config(), preset("realistic")):
        held = _jaws([body, ledge], _at(z=0.04), X, 0.04, config)
        assert held.reason == GraspReason.JAWS_BLOCKED
        assert abs(float(held.landing) - 0.006) < 0.0015
        free = _jaws([body], _at(z=0.04), X, 0.04, config)
        assert free.reason == GraspReason.FOUND
        assert float(free.landing) > 0.03  # the table (or a fall the camera does not see)


def test_a_top_going_on_unseen_past_the_band_is_no_landing():
    """A 6 x 3 x 4 cm part with a block level with its top against its +y face, under half of
    that pad (x 0..3 cm, y 1.5..3 cm): closing across y, the camera tilted about x, the +y
    jaw's tip-level rays near the band's edge meet the part's top, then the block's, level with
    the band: no stretch unseen, no fall: refused (the old per-sample "hidden" rule took those
    rays as a drop and passed it). The part alone: its hidden side is followed by the table,
    4 cm down: a fall, the grasp passes."""
    part = box((0.06, 0.03, 0.04), _at())
    block = box((0.03, 0.015, 0.04), _at(x=0.015, y=0.0225))
    for config in (Config(), preset("realistic")):
        held = _jaws([part, block], _at(z=0.04), Y, 0.03, config)
        assert held.reason == GraspReason.JAWS_BLOCKED
        assert abs(float(held.landing)) < 0.001  # the block's top, level with the band
        alone = _jaws([part], _at(z=0.04), Y, 0.03, config)
        assert alone.reason == GraspReason.FOUND
        assert float(alone.landing) > 0.03


def test_a_fall_hidden_behind_a_lip_is_a_landing():
    """A 6 x 4 x 4 cm part with a lip 3 mm down and 2 mm wide along both edges the jaws close
    across (y, the camera tilted about x): on the far side the rays see the band's top, the
    lip, then the table 4 cm down well beyond the reach; the side between, unseen, begins
    2 mm past the band's edge, so the jaws land beside the part (judged by the lip's 3 mm
    alone, the grasp was refused)."""
    part = box((0.06, 0.04, 0.04), _at())
    lips = [box((0.06, 0.002, 0.037), _at(y=side * 0.021)) for side in (-1, 1)]
    for config in (Config(), preset("realistic")):
        result = _jaws([part, *lips], _at(z=0.04), Y, 0.04, config)
        assert result.reason == GraspReason.FOUND
        assert float(result.landing) > 0.03


def test_a_chamfer_seen_44_degrees_off_vertical_is_no_landing():
    """A 6 x 4 x 4 cm part with a 45-degree chamfer 12 mm wide along both edges the jaws close
    across (then a step down to the table): within the reach, 5.6 mm past the edge, the side
    falls 5.6 mm, less than the 8 mm shallowest grasp, seen 13 and 44 degrees off vertical. At
    44 degrees the first sample's ray on the side facing the camera meets the chamfer 10 mm out,
    10 mm down (the chamfer nearer the edge is seen by rays inside the band, not sampled): no
    unseen stretch, so no fall (before, a drop). The part alone passes."""
    for tilt in (13.0, 44.0):
        cx, cy = table_centre(tilt)
        part = box((0.06, 0.04, 0.04), (cx, cy, 0.0))
        size = 0.017  # the chamfer's face, 12 mm wide and deep
        chamfers = [box((0.06, size, size), (0.0, 0.0, -size / 2)).moved(
            rot_x(np.pi / 4), (cx, cy + side * 0.02, 0.04 - size / np.sqrt(2))) for side in (-1, 1)]
        steps = [box((0.06, 0.012, 0.028), (cx, cy + side * 0.026, 0.0)) for side in (-1, 1)]
        for config in (Config(), preset("realistic")):
            held = _jaws([part, *chamfers, *steps], (cx, cy, 0.04), Y, 0.04, config, tilt_deg=tilt)
            assert held.reason == GraspReason.JAWS_BLOCKED
            assert float(held.landing) < config.detect.min_grasp_depth
            alone = _jaws([part], (cx, cy, 0.04), Y, 0.04, config, tilt_deg=tilt)
            assert alone.reason == GraspReason.FOUND


def test_a_top_going_on_past_a_strip_without_depth_is_no_landing():
    """The part and a block level with it as above, the block on the -y side (seen directly),
    and no depth on both tops from 1 mm inside the band's edge to 5 mm beyond it (a specular
    strip): the unseen strip lies between the band and the block's top seen level with it, so
    it is no fall: refused (taken as a drop, it passed)."""
    part = box((0.06, 0.03, 0.04), _at())
    block = box((0.03, 0.015, 0.04), _at(x=0.015, y=-0.0225))

    def strip(world):
        return (world[..., 2] > 0.035) & (world[..., 1] > -0.02) & (world[..., 1] < -0.014)

    for config in (Config(), preset("realistic")):
        held = _jaws([part, block], _at(z=0.04), Y, 0.03, config, lose=strip)
        assert held.reason == GraspReason.JAWS_BLOCKED
        assert float(held.unknown) > 0.0  # the strip is in the -y jaw's path
        assert float(held.landing) < config.detect.min_grasp_depth


def test_a_top_going_on_past_the_band_seen_44_degrees_to_the_side_is_no_landing():
    """A 3 x 6 x 4 cm part with a block level with its top against its +x face, 1.5 cm wide,
    under half of that pad (y 0..1 cm), the camera tilted 44 degrees about x, the jaws closing
    across x: the rays through the tips' level, 2 cm below the top, meet the surface ~2 cm to
    the side of the pad's lanes, past the block, on the table: an 11 mm fall (the grasp passed
    on them alone). Through the top's level they meet the block's top on the lanes: no fall
    within the reach, refused. The part alone passes."""
    cx, cy = table_centre(44.0)
    part = box((0.03, 0.06, 0.04), (cx, cy, 0.0))
    block = box((0.015, 0.01, 0.04), (cx + 0.0225, cy + 0.005, 0.0))
    for config in (Config(), preset("realistic")):
        held = _jaws([part, block], (cx, cy, 0.04), X, 0.03, config, tilt_deg=44.0)
        assert held.reason == GraspReason.JAWS_BLOCKED
        assert abs(float(held.landing)) < 0.002  # the block's top, level with the band
        alone = _jaws([part], (cx, cy, 0.04), X, 0.03, config, tilt_deg=44.0)
        assert alone.reason == GraspReason.FOUND
        assert float(alone.landing) > 0.03


def test_a_groove_then_something_beyond_it_is_what_the_jaws_close_on():
    """A 2.6 cm ridge 1 cm above a 5 cm base, and along both its sides, past a 6 mm groove, a
    6 mm rail 3 mm below the ridge's top: closing at the tips' level (2 cm down) the jaws touch
    the rails' outer faces, not the ridge: refused, though the ridge falls 1 cm into the groove
    (the landing). Without the rails they close on the base, 5 cm apart, its side falling from
    the groove's floor to the table: a grasp of the part."""
    base = box((0.05, 0.06, 0.03), _at())
    ridge = box((0.026, 0.06, 0.04), _at())
    rails = [box((0.006, 0.06, 0.037), _at(x=side * 0.022)) for side in (-1, 1)]
    for config in (Config(), preset("realistic")):
        beyond = _jaws([base, ridge, *rails], _at(z=0.04), X, 0.026, config)
        assert beyond.reason == GraspReason.JAWS_BLOCKED
        assert float(beyond.landing) >= config.detect.min_grasp_depth  # it does fall first
        assert abs(float(beyond.contact_width) - 0.05) < 0.004  # on the rails' outer faces
        plain = _jaws([base, ridge], _at(z=0.04), X, 0.026, config)
        assert plain.reason == GraspReason.FOUND
        assert abs(float(plain.contact_width) - 0.05) < 0.004


def _ridged_top(length=0.12):
    """A 6 cm wide part, `length` long (y), 2 cm high, with a ridge along y: 2 cm wide on top,
    6.5 mm higher, its flanks sloping 30 degrees down to a 8.75 mm wide shoulder along each
    edge (the top falls 6.5 mm, gently, then 2 cm to the table)."""
    rise = 0.0065
    half_base = 0.01 + rise / np.tan(np.deg2rad(30.0))
    trapezoid = [(-half_base, 0.0), (half_base, 0.0), (0.01, rise), (-0.01, rise)]
    ridge = prism(trapezoid, length).moved(rot_x(np.pi / 2), _at(y=length / 2, z=0.02))
    return [box((0.06, length, 0.02), _at()), ridge]


def test_a_top_falling_gently_past_the_band_is_grasped_on_its_followed_surface():
    """The ridged part (`_ridged_top`), 12 cm long: the T-beam's band (within 5 mm of the
    ridge's depth) ends on the flanks, 6 mm down, and the shoulders beyond fall only 6.5 mm
    within the reach (the jaws would land on them): every placement across it is refused, and
    along it the part is too long. The contour search on the target's followed surface (the
    ridge, flanks and shoulders, depth-connected) closes across the whole 6 cm."""
    depth, camera, workspace, rotation, eye = table_with(_ridged_top())

    def detect(image):
        return detect_one(depth, workspace, camera, Config(), image)

    tbeam_only = detect(RealImageConfig(contour_search=False, max_targets=1))
    assert not bool(tbeam_only.found)
    assert tbeam_only.tried_reasons[0] == GraspReason.JAWS_BLOCKED
    r = detect(RealImageConfig(max_targets=1))
    assert bool(r.found) and bool(r.ranked.contour[0])
    axis = rotation @ r.closing_axis
    assert abs(axis[0]) > 0.97  # across the part
    assert abs(float(r.ranked.width[0]) - 0.06) < 0.004
    assert float(r.ranked.landing[0]) > 0.015  # its sides fall to the table


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


def test_a_shadow_beyond_a_taller_neighbour_is_no_landing():
    """A 4 x 6 x 4 cm part with a 4 mm board 1 cm taller against its +x face, and the table
    beyond unseen for 2 cm (the board's shadow): across x the +x jaw meets the board, and what
    lies beyond it is not the part's side, so the grasp is refused (were the unseen samples a
    fall, it would pass). The same shadow beside the part alone is a fall the sensor lost: the
    grasp passes."""
    part = box((0.04, 0.06, 0.04), _at())
    board = box((0.004, 0.06, 0.05), _at(x=0.022))
    for config in (Config(), preset("realistic")):
        beside = _jaws([part, board], _at(z=0.04), X, 0.04, config,
                      lose=_table_between(0.024, 0.044))
        assert beside.reason == GraspReason.JAWS_BLOCKED
        assert float(beside.landing) < 0.0  # no fall seen before the board
        alone = _jaws([part], _at(z=0.04), X, 0.04, config, lose=_table_between(0.02, 0.04))
        assert alone.reason == GraspReason.FOUND
        assert float(alone.unknown) > 0.2  # the +x jaw's path in the shadow


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
    closing across its 3 cm, and ranked with the tried targets' reasons."""
    solids = [box((0.12, 0.12, 0.08), _at(x=-0.1)), box((0.1, 0.1, 0.05), _at(x=0.1, y=0.06)),
              box((0.03, 0.05, 0.03), _at(x=0.07, y=-0.08))]
    depth, camera, workspace, rotation, eye = table_with(solids)
    r = detect_one(depth, workspace, camera, Config(), RealImageConfig())
    assert bool(r.found)
    assert int(r.targets_tried) >= 2
    assert r.tried_reasons[0] == GraspReason.TOO_WIDE
    top = rotation.T @ (np.array(_at(x=0.07, y=-0.08, z=0.03)) - eye)
    assert np.linalg.norm(r.position - top) < 0.02
    assert abs(float(r.ranked.width[0]) - 0.03) < 0.003
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
    r = detect_one(depth, workspace, camera, Config(), RealImageConfig(max_targets=3))
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
    target given up) and the ridged part (rescued by the contour search), in one batch, get
    the targets, reasons and ranked grasps they get alone."""
    scenes = [table_with(_wedge_and_box()), table_with(_ridged_top())]
    camera, workspace = scenes[0][1], scenes[0][2]  # the same table view
    image = RealImageConfig(max_targets=3)
    depths = np.stack([scene[0] for scene in scenes])
    batch = jax.tree.map(np.asarray, detect_batch(depths, workspace, stack_cameras([camera] * 2),
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


@pytest.mark.parametrize("beside, tbeam_reason", [("neighbours", GraspReason.NO_ROOM),
                                                  ("ledges", GraspReason.JAWS_BLOCKED)])
def test_a_blocked_bar_is_grasped_where_its_contour_is_free(beside, tbeam_reason):
    """A 4 x 14 x 5 cm bar with something along both long sides that ends 4 cm past its
    centre: 4.6 cm high neighbours 1 cm off it (the open jaws over them, 4 mm below the top:
    no room in the detection window), or 1 cm wide ledges 6 mm below its top (the window's
    checks pass; at full resolution the jaws land on the ledges). Every T-beam placement
    across the bar (at -4, 0 and +4 cm along it; along it the bar is too wide) has a pad over
    them. The contour search finds the free end: closing across the bar, both fingers (2 cm
    wide) past their ends, the bar 4 cm wide."""
    bar = box((0.04, 0.14, 0.05), _at())
    if beside == "neighbours":
        sides = [box((0.03, 0.11, 0.046), _at(x=side * 0.045, y=-0.015)) for side in (-1, 1)]
    else:
        sides = [box((0.01, 0.11, 0.044), _at(x=side * 0.025, y=-0.015)) for side in (-1, 1)]
    depth, camera, workspace, rotation, eye = table_with([bar, *sides])

    def detect(image):
        return detect_one(depth, workspace, camera, Config(), image)

    tbeam_only = detect(RealImageConfig(contour_search=False))
    assert tbeam_only.tried_reasons[0] == tbeam_reason  # the bar, highest, first (with the
    # ledges a later target holds: the ledges' tops, closing across the whole 6 cm)
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
    approach = (rotation.T @ np.array([0.0, 0.0, -1.0])).astype(np.float32)
    width = rng.uniform(0.02, 0.03, 20).astype(np.float32)
    placed = rng.random(20) < 0.65
    config, image = Config(), RealImageConfig()
    assert int(placed.sum()) > jaws._JAW_CHUNK  # two chunks
    got = jax.tree.map(np.asarray, jax.jit(jaws.check_jaws_where)(
        placed, depth, camera, centre, axis, approach, width, config.detect, config.gripper, image))
    alone = [jax.tree.map(np.asarray, check(depth, camera, centre[i], axis[i], approach, width[i],
                                            config.detect, config.gripper, image))
             for i in np.flatnonzero(placed)]
    np.testing.assert_array_equal(got.reason[placed], [a.reason for a in alone])
    for field in ("depth", "clearance", "landing", "contact_width", "unknown"):
        np.testing.assert_allclose(getattr(got, field)[placed], [getattr(a, field) for a in alone],
                                   rtol=0, atol=1e-7)
        assert np.all(np.isnan(getattr(got, field)[~placed]))
    assert np.all(got.reason[~placed] == -1)
    assert {GraspReason.FOUND, GraspReason.JAWS_BLOCKED} <= set(got.reason[placed].tolist())
