"""`detect_real_image` end to end on synthetic images made to look like real captures.

Tilted table with a robot finger nearer than the table, holes and outlier
specks, a bin with walls and a rim: the grasp must land on the object, with
the geometry of the analytic scene. One image runs through
`imagefiles.batches.detect_single`, as `graspjax detect` on a CPU; several
through `detect_batch`.
"""

import jax
import numpy as np
import pytest
from conftest import assert_trees_close, detect_one
from real_scenes import HEIGHT, WIDTH, bin_scene, steep_table_scene, table_scene, with_holes_and_specks

from graspjax.codes import SupportReason, TargetReason
from graspjax.config import Config, RealImageConfig
from graspjax.imagefiles.batches import detect_batch, stack_cameras
from graspjax.perception import GraspReason

PIXEL = 0.73 / 525.0  # a detection pixel (full resolution) on the table, metres


def detect(scenes):
    """Results of `detect_batch` for scenes sharing one workspace, as NumPy, one per scene (one
    scene alone: `detect_single`, as `graspjax detect` on a CPU)."""
    if len(scenes) == 1:
        return [detect_one(scenes[0].depth, scenes[0].workspace, scenes[0].camera)]
    depth = np.stack([s.depth for s in scenes])
    result = detect_batch(depth, scenes[0].workspace, stack_cameras([s.camera for s in scenes]),
                           Config(), RealImageConfig())
    result = jax.tree.map(np.asarray, result)
    return [jax.tree.map(lambda x, i=i: x[i], result) for i in range(len(scenes))]


@pytest.fixture(scope="module")
def table():
    return table_scene()


def _angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.rad2deg(np.arccos(np.clip(abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b), 0, 1)))


def _check_grasp(r, scene, tol_px=1.5):
    """The grasp closes across one side of the target's top face, centred on it."""
    assert bool(r.found), GraspReason(int(r.grasp.reason)).name
    top = scene.to_camera(scene.top)
    assert np.linalg.norm(r.position - top) < tol_px * PIXEL
    sides = [scene.direction([np.cos(scene.yaw), np.sin(scene.yaw), 0.0]),
             scene.direction([-np.sin(scene.yaw), np.cos(scene.yaw), 0.0])]
    side = int(np.argmin([_angle_deg(r.closing_axis, s) for s in sides]))
    assert _angle_deg(r.closing_axis, sides[side]) < 4.0
    assert abs(float(r.grasp.width) - scene.size[side]) < tol_px * PIXEL
    assert _angle_deg(r.approach, -scene.up) < 0.2  # along the table's negative normal
    assert np.linalg.norm(r.pixel - scene.camera.project(top)) < 2 * tol_px  # full-res pixels


def test_tilted_table_with_a_finger_in_view(table):
    """The nearest point of the image is the finger (outside the workspace); the table's near
    edge is nearer than the box; the grasp lands on the box top, seen in the virtual view."""
    nearest = np.unravel_index(np.argmin(np.where(table.depth > 0, table.depth, 9)),
                               table.depth.shape)
    assert table.depth[nearest] < 0.35 and not table.workspace[nearest]  # the finger
    (r,) = detect([table])
    assert int(r.support.reason) == SupportReason.FOUND and bool(r.virtual)
    assert _angle_deg(r.support.normal, table.up) < 0.05
    assert np.rad2deg(float(r.support.tilt)) == pytest.approx(13.0, abs=0.05)
    assert float(r.support.distance) == pytest.approx(0.73, abs=5e-4)
    assert int(r.target_reason) == TargetReason.FOUND and int(r.targets_tried) == 1
    assert float(r.target_height) == pytest.approx(0.04, abs=1e-3)
    _check_grasp(r, table)
    np.testing.assert_allclose(r.rotation[:, 2], -table.up, atol=1e-3)


def test_holes_and_specks_change_nothing(table):
    """5% dropouts, a crack along the box top, outlier pixels and 4 x 4 specks at 0.3-0.4 m."""
    noisy = with_holes_and_specks(table)
    assert (noisy.depth[noisy.workspace] < 0.45).sum() > 50  # specks nearer than anything
    (r,) = detect([noisy])
    assert float(r.target_height) == pytest.approx(0.04, abs=2e-3)  # on the box, not a speck
    _check_grasp(r, table)


def test_bin_with_walls_and_rim():
    """The tallest box in a bin, not a wall's inner face (in the workspace) or the rim."""
    scene = bin_scene()
    inner = scene.depth[scene.workspace]
    assert inner.min() < 0.72  # wall faces 12 cm tall are in the workspace, above the 6 cm box
    (r,) = detect([scene])
    assert bool(r.virtual) and _angle_deg(r.support.normal, scene.up) < 0.05
    assert np.rad2deg(float(r.support.tilt)) == pytest.approx(8.0, abs=0.05)
    assert float(r.target_height) == pytest.approx(0.06, abs=1e-3)
    _check_grasp(r, scene)


def test_a_table_seen_44_degrees_off_vertical():
    """A tall box on a table seen 44 deg off vertical (the steepest the issue asks for): the
    view faces the table and the grasp closes across the box top, not down its near face."""
    scene = steep_table_scene()
    (r,) = detect([scene])
    assert bool(r.virtual) and np.rad2deg(float(r.support.tilt)) == pytest.approx(44.0, abs=0.1)
    assert float(r.target_height) == pytest.approx(0.15, abs=2e-3)
    _check_grasp(r, scene)


def test_a_batch_gives_the_grasps_of_single_images(table):
    """vmap at the edge: each image of a batch gets the grasp it gets alone. (Float reduction
    order differs in a batch and the virtual view samples the nearest pixel, so a pixel on a
    rounding boundary may flip: the grasp agrees within a working pixel, not to the bit.)"""
    scenes = [table, with_holes_and_specks(table, seed=1)]  # the program of test_bench's batch
    for got, alone in zip(detect(scenes), (detect([s])[0] for s in scenes), strict=True):
        assert_trees_close(got.support, alone.support, rtol=1e-4, atol=1e-5)
        assert bool(got.found) and bool(alone.found)
        assert int(got.target_reason) == int(alone.target_reason) == TargetReason.FOUND
        assert np.linalg.norm(got.position - alone.position) < PIXEL
        assert abs(float(got.grasp.width) - float(alone.grasp.width)) < PIXEL
        assert _angle_deg(got.closing_axis, alone.closing_axis) < 2.0


def test_images_given_together_are_each_detected_at_their_own_resolution(tmp_path):
    """Three 640 x 480 captures of a box on a table, each with its own K: a long lens (fx 1100:
    0.66 mm pixels, detected at block 2), a Kinect's (fx 525: 1.4 mm, block 1), the long lens
    again. Given together, each is detected at the resolution it gets alone, in a program of its
    own resolution, and comes back in the order given; before, the first image's block applied
    to all. (The programs of test_cli's block-2 image and test_bench's single image.)"""
    from real_scenes import tilted_pose

    from graspjax import Camera
    from graspjax.experiment import DetectOutputs, detect_images
    from graspjax.imagefiles.inputs import prepare
    from graspjax.synthetic import analytic_depth, box

    rotation, eye = tilted_pose(0.73, 13.0)
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    centre = (eye + axis * eye[2] / -axis[2])[:2]
    target = box((0.04, 0.06, 0.04), (*centre, 0.0), 0.4)
    paths = []
    for name, focal in (("long_a", 1100.0), ("kinect", 525.0), ("long_b", 1100.0)):
        camera = Camera(640, 480, focal, focal, 319.5, 239.5)
        paths.append(tmp_path / f"{name}.npz")
        np.savez(paths[-1], depth=analytic_depth(camera, rotation, eye, [target]),
                 K=np.array([[focal, 0, 319.5], [0, focal, 239.5], [0, 0, 1]]))
    inputs = prepare(paths)
    assert inputs.resolutions == ((1, 2), (1, 1), (1, 2)) and inputs.image.downsample == 2
    assert [indices for indices, _ in inputs.parts()] == [(0, 2), (1,)]
    together = detect_images(inputs, DetectOutputs(), quiet=True)
    alone = [detect_images(prepare([p]), DetectOutputs(), quiet=True)[0] for p in paths]
    assert [r["image"] for r in together] == [str(p) for p in paths]
    assert [r["downsample"] for r in together] == [2, 1, 2]
    for got, own in zip(together, alone, strict=True):
        assert got["found"] and got["downsample"] == own["downsample"]
        np.testing.assert_allclose(got["grasp"]["position"], own["grasp"]["position"], atol=1e-6)
        np.testing.assert_allclose(got["grasp"]["pixel"], own["grasp"]["pixel"], atol=1e-3)


def test_a_large_fine_image_is_detected_at_the_resolution_it_needs(tmp_path):
    """A 2560 x 1920 capture with a long lens (0.24 mm pixels on the table) is block-medianed
    by 4 to 640 x 480 before anything is compiled, and the grasp comes back in the file's own
    pixels and the camera frame, on the analytic box's top."""
    from real_scenes import table_scene

    from graspjax import Camera
    from graspjax.imagefiles.batches import detect_files
    from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare
    from graspjax.imagefiles.records import record
    from graspjax.synthetic import analytic_depth, box

    scene = table_scene()
    camera = Camera(2560, 1920, 3100.0, 3100.0, 1279.5, 959.5)
    target = box((*scene.size, 0.04), (*scene.top[:2], 0.0), scene.yaw)
    np.save(tmp_path / "large.npy", analytic_depth(camera, scene.rotation, scene.eye, [target]))
    inputs = prepare([tmp_path / "large.npy"], intrinsics=IntrinsicsRequest(focal=(3100, 3100)),
                     roi=(160, 80, 2400, 1600))
    assert (inputs.reduction, inputs.width, inputs.height) == (4, 640, 480)
    found, = detect_files(inputs)
    rec = record(found)
    assert rec["found"] and rec["size"] == [2560, 1920] and rec["input_reduction"] == 4
    top = scene.to_camera(scene.top)
    reduced_pixel = 0.75 * 4 / 3100.0  # metres, on the table
    assert np.linalg.norm(np.asarray(rec["grasp"]["position"]) - top) < 2 * reduced_pixel
    assert np.linalg.norm(np.asarray(rec["grasp"]["pixel"]) - camera.project(top)) < 3 * 4
    assert min(abs(rec["grasp"]["width"] - w) for w in scene.size) < 2 * reduced_pixel


def test_the_input_reduction_follows_the_pixel_footprint_and_the_pixel_count():
    from graspjax import Camera
    from graspjax.imagefiles.resolution import block_median, input_reduction, reduced

    image = RealImageConfig()  # pixels of at least 1 mm, at most 1280 x 1024 of them
    flat = np.full((480, 640), 0.73, np.float32)
    assert input_reduction(flat, Camera(640, 480, 525.0, 525.0, 319.5, 239.5), image) == 1
    big = np.full((3000, 4000), 0.7, np.float32)  # 12 Mpx, 0.23 mm pixels: the footprint rules
    assert input_reduction(big, Camera(4000, 3000, 3000.0, 3000.0, 1999.5, 1499.5), image) == 4
    wide = np.full((1920, 2560), 0.7, np.float32)  # 0.67 mm pixels: the count rules
    assert input_reduction(wide, Camera(2560, 1920, 1050.0, 1050.0, 1279.5, 959.5), image) == 2
    depth = np.array([[1, 2, 0, np.nan], [3, 4, 0, 5], [9, 9, 9, 9], [9, 9, 9, 9],
                      [7, 7, 7, 7]], np.float32)  # the fifth row fills no block
    np.testing.assert_array_equal(block_median(depth, 2), [[2.5, 5.0], [9.0, 9.0]])
    assert block_median(np.zeros((2, 2), np.float32), 2)[0, 0] == 0  # no valid pixel: none
    # A point's pixel in the reduced camera maps back to its pixel in the file.
    source = Camera(2560, 1920, 3100.0, 3050.0, 1270.3, 961.8)
    point = np.array([0.031, -0.022, 0.74])
    small = reduced(source, 4)
    assert (small.width, small.height) == (640, 480)
    back = (np.asarray(small.project(point), np.float64) + 0.5) * 4 - 0.5
    np.testing.assert_allclose(back, source.project(point), atol=1e-3)


def test_a_reduced_image_keeps_its_range_out_of_the_medians(tmp_path):
    """Pixels outside the depth range take no part in a block's median (those outside the
    workspace do: the jaws' checks see them), and a workspace too small for the reduced
    resolution is refused in one line."""
    from graspjax.errors import InputError
    from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare

    depth = np.full((1920, 2560), 0.7, np.float32)
    depth[:, :1281] = 0.2  # nearer than --range: a block straddling column 1280 keeps 0.7
    np.save(tmp_path / "d.npy", depth)
    inputs = prepare([tmp_path / "d.npy"], intrinsics=IntrinsicsRequest(focal=(3000, 3000)),
                     depth_range=(0.5, 1.0), roi=(0, 0, 2560, 1000))
    assert inputs.reduction == 4
    full, camera, _ = inputs.read(tmp_path / "d.npy")
    assert full.shape == (480, 640) and camera.fx == 750.0
    assert np.all(full[:250, 321:] == np.float32(0.7)) and np.all(full[:250, 320] == np.float32(0.7))
    assert np.all(full[:, :320] == 0)  # outside the range: no depth
    assert np.all(full[250:, 321:] == np.float32(0.7))  # outside the box: kept
    with pytest.raises(InputError, match="workspace is too small"):
        prepare([tmp_path / "d.npy"], intrinsics=IntrinsicsRequest(focal=(3000, 3000)),
                roi=(10, 10, 11, 11))


def test_a_reduction_to_less_than_8x8_pixels_is_one_line(tmp_path):
    """A reduction that leaves less than 8 x 8 pixels (10 cm pixels asked for, 0.6 m away
    through the Kinect's 57 degrees: 6 x 4 left) is an `InputError` naming the setting, not a
    `Camera` that refuses its size."""
    from graspjax.errors import InputError
    from graspjax.imagefiles.inputs import prepare

    np.save(tmp_path / "d.npy", np.full((480, 640), 0.6, np.float32))
    with pytest.raises(InputError, match=r"reducing 640x480 by 98 \(to pixels of "
                                         r"image.full_pixel 0.1 m .* less than 8x8 pixels"):
        prepare([tmp_path / "d.npy"], overrides=["image.full_pixel=0.1"])


def test_each_files_own_k_is_checked_for_a_plausible_field_of_view(tmp_path):
    """Intrinsics that give the images a field of view no depth camera has (here a K whose
    focal length is 100 times too long) are refused before anything is computed, naming the
    file whose K it is."""
    from graspjax.errors import InputError
    from graspjax.imagefiles.inputs import prepare

    depth = np.full((480, 640), 0.6, np.float32)
    k = np.array([[525.0, 0, 319.5], [0, 525.0, 239.5], [0, 0, 1]])
    np.savez(tmp_path / "a.npz", depth=depth, K=k)
    np.savez(tmp_path / "b.npz", depth=depth, K=k * [[100], [100], [1]])
    assert prepare([tmp_path / "a.npz"]).intrinsics.describe(k) == "the file's K"
    with pytest.raises(InputError, match=rf"the intrinsics from {tmp_path / 'b.npz'}'s K give "
                                         r"the 640x480 images a 0.698 x 0.524 degree field"):
        prepare([tmp_path])


def test_every_image_of_a_folder_needs_a_plausible_median_depth(tmp_path):
    """A median depth (in the depth range) no depth camera reads, here a file of kilometres
    after one of metres, is refused before anything is computed, naming that file."""
    from graspjax.errors import InputError
    from graspjax.imagefiles.inputs import prepare

    np.save(tmp_path / "a.npy", np.full((480, 640), 0.6, np.float32))
    np.save(tmp_path / "b.npy", np.full((480, 640), 0.0006, np.float32))
    with pytest.warns(UserWarning, match="no intrinsics given and none in the files"):
        assert prepare([tmp_path / "a.npy"]).reduction == 1
    with pytest.raises(InputError, match=rf"{tmp_path / 'b.npy'}: median depth 0.0006 m \(in "
                                         r"the depth range 0-10 m\) is implausible for a depth "
                                         r"camera \(0.05-20 m\): its depth must be in metres"):
        prepare([tmp_path])


SENSORS = {  # file kind, size, fx = fy, camera tilt (deg), detection factor from the intrinsics
    "png_mm_640x480_13deg": ("png", (640, 480), 525.0, 13.0, 1),
    "float_m_nan_inf_1280x720_wide_30deg": ("npy", (1280, 720), 640.0, 30.0, 1),
    "float_m_1280x1024_45deg": ("npy", (1280, 1024), 1100.0, 45.0, 2),
    "float_m_1032x772_phoxi_8deg": ("npy", (1032, 772), 1122.0, 8.0, 2),
}


@pytest.mark.parametrize("name", list(SENSORS))
def test_common_sensors_formats_sizes_and_tilts(tmp_path, name):
    """A 4 x 6 x 4 cm box on a table, rendered exactly for a sensor of each kind: a 16-bit PNG
    in millimetres; float metres with NaN, +inf and -inf dropouts (2 % each) and zeros; 640 x
    480 to 1280 x 1024; the camera tilted 8-45 degrees, 0.73 m above the table. The detection
    resolution follows the intrinsics (a pixel nearest 1.4 mm at the median depth), not the
    pixel count, and the grasp closes across a side of the box top, centred on it."""
    from PIL import Image
    from real_scenes import tilted_pose

    from graspjax import Camera
    from graspjax.imagefiles.batches import detect_files
    from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare
    from graspjax.imagefiles.records import record
    from graspjax.synthetic import analytic_depth, box

    kind, (width, height), focal, tilt, factor = SENSORS[name]
    camera = Camera(width, height, focal, focal, (width - 1) / 2, (height - 1) / 2)
    rotation, eye = tilted_pose(0.73, tilt)
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    centre = (eye + axis * eye[2] / -axis[2])[:2]  # where the optical axis meets the table
    size, yaw = (0.04, 0.06), 0.4
    depth = analytic_depth(camera, rotation, eye, [box((*size, 0.04), (*centre, 0.0), yaw)])
    rng = np.random.default_rng(0)
    if kind == "png":
        Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(tmp_path / "d.png")
        path = tmp_path / "d.png"
    else:
        lost = rng.random(depth.shape)
        depth = np.where(lost < 0.02, np.nan, depth)
        depth = np.where((lost >= 0.02) & (lost < 0.04), np.inf, depth)
        depth = np.where((lost >= 0.04) & (lost < 0.06), -np.inf, depth)
        depth = np.where((lost >= 0.06) & (lost < 0.08), 0.0, depth)
        path = tmp_path / "d.npy"
        np.save(path, depth.astype(np.float32))
    inputs = prepare([path], intrinsics=IntrinsicsRequest(focal=(focal, focal)))
    assert inputs.reduction == 1 and inputs.image.downsample == factor
    found, = detect_files(inputs)
    rec = record(found)
    assert rec["found"], rec["reason"]
    assert rec["support_plane"]["tilt_deg"] == pytest.approx(tilt, abs=0.3)
    top = rotation.T @ (np.array([*centre, 0.04]) - eye)
    pixel = factor * float(top[2]) / focal  # a detection pixel on the box top, metres
    assert np.linalg.norm(np.asarray(rec["grasp"]["position"]) - top) < 3 * pixel
    sides = [rotation.T @ np.array([np.cos(yaw), np.sin(yaw), 0.0]),
             rotation.T @ np.array([-np.sin(yaw), np.cos(yaw), 0.0])]
    cosines = [abs(float(np.dot(rec["grasp"]["closing_axis"], s))) for s in sides]
    side = int(np.argmax(cosines))
    assert cosines[side] > np.cos(np.deg2rad(5.0))
    assert abs(rec["grasp"]["width"] - size[side]) < 3 * pixel


@pytest.mark.parametrize("method", ["highest-pca", "antipodal"])
def test_the_baselines_on_a_real_looking_image(table, method):
    """`graspjax detect --method`: a baseline proposes the placements in each target's window,
    the same jaw checks and ranking follow. On the tilted table's 4 x 7 cm box, highest-pca
    closes across the box's minor axis (its 4 cm side) at the top's centre; antipodal closes
    across a pair of parallel faces (4 or 7 cm apart), on the top."""
    from graspjax.config import override

    config = override(Config(), [f"method={method}"])
    r = detect_one(table.depth, table.workspace, table.camera, config)
    assert bool(r.found), GraspReason(int(r.grasp.reason)).name
    top = table.to_camera(table.top)
    sides = [table.direction([np.cos(table.yaw), np.sin(table.yaw), 0.0]),
             table.direction([-np.sin(table.yaw), np.cos(table.yaw), 0.0])]
    angles = [_angle_deg(r.closing_axis, s) for s in sides]
    side = int(np.argmin(angles))
    assert angles[side] < 4.0
    assert abs(float(r.grasp.width) - table.size[side]) < 2 * PIXEL
    distance = np.linalg.norm(r.position - top)
    if method == "highest-pca":
        assert side == 0 and distance < 2 * PIXEL  # across the 4 cm side, at the centre
    else:
        assert abs(float(np.dot(r.position - top, table.up))) < 2 * PIXEL  # on the top face
        assert distance < max(table.size) / 2


def _tote_with_a_part_near_a_wall():
    """The bin of `bin_scene` (36 x 26 x 12 cm, 1 cm walls, 8 degrees, 0.8 m) holding a
    5 x 3 x 4 cm part 2 cm from its +y wall: depth (H, W), camera, rotation."""
    from real_scenes import HEIGHT, WIDTH, tilted_pose

    from graspjax import Camera
    from graspjax.synthetic import analytic_depth, box

    camera = Camera(WIDTH, HEIGHT, 552.5, 552.5, 319.5, 239.5)
    rotation, eye = tilted_pose(0.8, 8.0, about="y")
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    cx, cy = (eye + axis * eye[2] / -axis[2])[:2]
    length, width, height, t = 0.36, 0.26, 0.12, 0.01
    walls = [box((length + 2 * t, t, height), (cx, cy + s * (width + t) / 2, 0.0)) for s in (-1, 1)]
    walls += [box((t, width, height), (cx + s * (length + t) / 2, cy, 0.0)) for s in (-1, 1)]
    part = box((0.05, 0.03, 0.04), (cx, cy + width / 2 - 0.02 - 0.015, 0.0))
    return analytic_depth(camera, rotation, eye, walls + [part]), camera, rotation


def test_a_tote_whose_walls_lie_in_the_box(tmp_path):
    """`--bin` with a box around the whole bin: without it the best grasp is on a wall's 1 cm
    top edge (12 cm up, the highest surface); with it the workspace is the floor's hull, which
    holds no wall pixel, and the grasp is on the 6 cm box's top."""
    from graspjax.imagefiles.batches import detect_files
    from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare
    from graspjax.imagefiles.records import record

    scene = bin_scene(whole=True)
    np.save(tmp_path / "tote.npy", scene.depth)
    focal = IntrinsicsRequest(focal=(scene.camera.fx, scene.camera.fy))
    plain = prepare([tmp_path / "tote.npy"], intrinsics=focal, roi=scene.roi)
    rec = record(next(iter(detect_files(plain))))
    assert rec["found"] and rec["target"]["height"] == pytest.approx(0.12, abs=1e-3)
    assert rec["grasp"]["width"] < 0.015  # a wall's top edge
    inputs = prepare([tmp_path / "tote.npy"], intrinsics=focal, roi=scene.roi, bin=True)
    points = scene.rotation @ scene.camera.unproject(scene.camera.pixel_grid(),
                                                      scene.depth)[..., None]
    heights = np.asarray(points[..., 2, 0]) + scene.eye[2]
    floor = bin_scene().workspace & (heights < 1e-3)  # inside the inner rim's box, on the floor
    interior = inputs.workspace_of(0)
    assert (interior & floor).sum() > 0.95 * floor.sum()
    assert not (interior & (heights > 0.065)).any()  # no wall pixel
    rec = record(next(iter(detect_files(inputs))))
    assert rec["found"] and rec["workspace"]["bin"]
    top = scene.to_camera(scene.top)
    assert np.linalg.norm(np.asarray(rec["grasp"]["position"]) - top) < 3 * PIXEL
    assert min(abs(rec["grasp"]["width"] - w) for w in scene.size) < 3 * PIXEL


@pytest.mark.parametrize("batch", [1, 2])
def test_every_image_gets_its_own_bin(tmp_path, batch):
    """`--bin` over two images of the tote, the second with the bin 40 columns further right
    (the scene's planes stay planes when the image is shifted): each image's workspace is its
    own bin's interior, and each grasp is on its own image's 6 cm box (the first image's bin
    would cut the second's box off at the right and keep the left wall in). One image per call
    (a CPU's default) and both in one batch."""
    from graspjax.imagefiles.batches import detect_files
    from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare
    from graspjax.imagefiles.records import record

    scene, shift = bin_scene(whole=True), 40
    np.save(tmp_path / "a.npy", scene.depth)
    np.save(tmp_path / "b.npy", np.roll(scene.depth, shift, axis=1))
    focal = IntrinsicsRequest(focal=(scene.camera.fx, scene.camera.fy))
    inputs = prepare([tmp_path / "a.npy", tmp_path / "b.npy"], intrinsics=focal,
                     roi=(50, 10, WIDTH - 10, HEIGHT - 10), bin=True)
    first, second = inputs.workspace_of(0), inputs.workspace_of(1)
    moved = np.roll(first, shift, axis=1)
    assert (second & moved).sum() > 0.97 * max(second.sum(), moved.sum())
    assert (second != first).sum() > 0.05 * first.sum()
    records = [record(d) for d in detect_files(inputs, batch=batch)]
    pixels = [np.asarray(r["grasp"]["pixel"]) for r in records]
    assert all(r["found"] and r["workspace"]["bin"] for r in records)
    assert records[1]["workspace"]["pixels"] == int(second.sum())
    top = scene.camera.project(scene.to_camera(scene.top))
    assert np.linalg.norm(pixels[0] - top) < 3
    assert np.linalg.norm(pixels[1] - (top + np.array([shift, 0.0]))) < 3


def test_images_at_other_resolutions_keep_their_own_workspace_and_bin(tmp_path):
    """The host side of `Inputs.parts`, nothing compiled: the tote through its own lens, through
    one of three times its focal length (0.4 mm pixels: taken at half size) and its own again,
    with --bin. Each part holds its images at its resolution: its workspace and each image's bin
    at its own size, the same bin an image gets alone, and its positions in the run."""
    from graspjax.imagefiles.inputs import prepare

    scene = bin_scene(whole=True)
    c = scene.camera
    own = np.array([[c.fx, 0.0, c.cx], [0.0, c.fy, c.cy], [0.0, 0.0, 1.0]])
    long = own * np.array([[3.0], [3.0], [1.0]])  # fx, fy and the centre three times
    long[:2, 2] = own[:2, 2]
    paths = [tmp_path / f"{name}.npz" for name in ("own_a", "long", "own_b")]
    for path, k in zip(paths, (own, long, own), strict=True):
        np.savez(path, depth=scene.depth, K=k)
    box = (50, 10, WIDTH - 10, HEIGHT - 10)
    inputs = prepare(paths, roi=box, bin=True)
    assert inputs.resolutions[0] == inputs.resolutions[2] == (inputs.reduction,
                                                             inputs.image.downsample)
    assert inputs.resolutions[1][0] == 2 and inputs.reduction == 1
    (first, at_own), (second, at_long) = inputs.parts()
    assert first == (0, 2) and second == (1,) and at_long.paths == (paths[1],)
    assert at_long.workspace.shape == at_long.workspace_of(0).shape == (HEIGHT // 2, WIDTH // 2)
    assert at_own.workspace_of(1).shape == (HEIGHT, WIDTH)
    np.testing.assert_array_equal(at_own.workspace_of(0), at_own.workspace_of(1))
    alone = prepare([paths[1]], roi=box, bin=True)
    assert (alone.reduction, alone.image.downsample) == inputs.resolutions[1]
    np.testing.assert_array_equal(at_long.workspace_of(0), alone.workspace_of(0))
    interior = at_long.workspace_of(0)  # a bin found at that size, within the workspace
    assert interior.sum() > 1000 and not (interior & ~at_long.workspace).any()


def test_bin_on_an_image_without_a_floor_names_it(tmp_path):
    """`--bin` over a tote and an image of noise: the run stops in `prepare`, before anything
    is computed or written, with one line naming the image; and a third image padded into a
    batch of two keeps its own bin."""
    from graspjax.errors import InputError
    from graspjax.imagefiles.batches import detect_files
    from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare

    scene = bin_scene(whole=True)
    np.save(tmp_path / "a.npy", scene.depth)
    np.save(tmp_path / "b.npy", np.roll(scene.depth, 40, axis=1))
    noise = np.random.default_rng(0).uniform(0.5, 0.9, scene.depth.shape).astype(np.float32)
    np.save(tmp_path / "noise.npy", noise)
    focal = IntrinsicsRequest(focal=(scene.camera.fx, scene.camera.fy))
    box = (50, 10, WIDTH - 10, HEIGHT - 10)
    with pytest.raises(InputError, match=r"noise\.npy: --bin: no floor") as error:
        prepare([tmp_path / "a.npy", tmp_path / "noise.npy"], intrinsics=focal, roi=box, bin=True)
    assert "\n" not in str(error.value)
    inputs = prepare([tmp_path / "a.npy", tmp_path / "a.npy", tmp_path / "b.npy"],
                     intrinsics=focal, roi=box, bin=True)
    last = list(detect_files(inputs, batch=2))[-1]  # alone in its chunk, padded to two
    np.testing.assert_array_equal(last.workspace, inputs.workspace_of(2))
    assert not np.array_equal(last.workspace, inputs.workspace_of(0))
    top = scene.camera.project(scene.to_camera(scene.top)) + np.array([40.0, 0.0])
    assert bool(last.result.found) and np.linalg.norm(last.result.pixel - top) < 3


def test_the_jaws_see_a_bins_walls_outside_its_workspace():
    """A part 2 cm from a wall, the workspace the bin's interior (the wall outside it): the
    jaws' checks see the wall, and the grasp closes along it (a jaw across it would open into
    the wall); were the pixels outside the workspace hidden from them, the narrower grasp
    across, toward the wall, would win."""
    from graspjax.imagefiles.bins import bin_interior

    depth, camera, rotation = _tote_with_a_part_near_a_wall()
    box_ws = np.zeros(depth.shape, bool)
    box_ws[10:-10, 10:-10] = True
    from graspjax.imagefiles.resolution import block_median, reduced

    factor = round(depth.shape[1] / RealImageConfig().working_width)
    seen = np.where(box_ws, depth, 0.0)
    coarse = block_median(seen, factor), reduced(camera, factor)
    interior = bin_interior(seen, camera, box_ws, RealImageConfig(), coarse)
    axes = {}
    for hidden in (False, True):
        seen_by_jaws = np.where(interior, depth, 0.0) if hidden else depth
        r = detect_one(seen_by_jaws, interior, camera)
        assert bool(r.found)
        axes[hidden] = rotation @ r.closing_axis  # world
    assert abs(axes[False][0]) > np.cos(np.deg2rad(5.0))  # along the wall (world x)
    assert abs(axes[True][1]) > np.cos(np.deg2rad(5.0))  # toward it (world y)
