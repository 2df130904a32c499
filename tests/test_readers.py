import json

import numpy as np
import pytest
from PIL import Image

from graspjax.camera import Camera
from graspjax.disk import write_atomic
from graspjax.errors import InputError
from graspjax.imagefiles.readers import (
    check_depth,
    check_matrix,
    load_intrinsics,
    load_mask,
    read_depth,
)
from graspjax.synthetic import analytic_depth, box, rot_x, top_down_pose

K = np.array([[525.0, 0.0, 319.5], [0.0, 520.0, 239.5], [0.0, 0.0, 1.0]])


def test_npy_in_metres_and_png_in_millimetres(tmp_path):
    depth = np.full((20, 30), 0.512, np.float32)
    depth[3, 4] = 0.0
    np.save(tmp_path / "d.npy", depth)
    np.save(tmp_path / "d1.npy", depth[..., None])  # (H, W, 1), as camera tools save it
    Image.fromarray((depth * 1000).round().astype(np.uint16)).save(tmp_path / "d.png")
    for name in ("d.npy", "d1.npy"):
        got, k = read_depth(tmp_path / name)
        np.testing.assert_array_equal(got, depth)
        assert k is None
    np.testing.assert_allclose(read_depth(tmp_path / "d.png")[0], depth, atol=1e-6)


def test_png_depth_scale_and_npz_with_k(tmp_path):
    depth = np.full((20, 30), 0.7315, np.float32)
    Image.fromarray((depth * 1e4).round().astype(np.uint16)).save(tmp_path / "d.png")  # 0.1 mm
    np.testing.assert_allclose(read_depth(tmp_path / "d.png", depth_scale=1e-4)[0], depth,
                               atol=1e-7)
    np.savez(tmp_path / "c.npz", depth=depth, K=K, rgb=np.zeros((20, 30, 3), np.uint8))
    got, k = read_depth(tmp_path / "c.npz")
    np.testing.assert_array_equal(got, depth)
    np.testing.assert_array_equal(k, K)
    np.savez(tmp_path / "no_k.npz", depth=depth)
    assert read_depth(tmp_path / "no_k.npz")[1] is None


@pytest.mark.parametrize("make, match", [
    (lambda p: None, "no such file"),
    (lambda p: np.save(p / "x.npy", -np.ones((10, 10), np.float32)), "negative depth"),
    (lambda p: np.save(p / "x.npy", np.zeros((10, 10), np.float32)), "no valid depth"),
    (lambda p: np.save(p / "x.npy", np.ones((2, 10, 10), np.float32)), "2-D"),
    (lambda p: np.save(p / "x.npy", np.ones((4, 4), np.float32)), "too small"),
    (lambda p: np.save(p / "x.npy", np.ones((10, 10), np.int16)), "float depth"),
    (lambda p: np.save(p / "x.npy", np.zeros((10, 12, 3), np.uint8)), "colour image"),
    (lambda p: (p / "x.npy").write_text("not numpy"), "cannot read"),
])
def test_bad_npy_files_raise_one_line_errors(tmp_path, make, match):
    make(tmp_path)
    with pytest.raises(InputError, match=match) as info:
        read_depth(tmp_path / "x.npy")
    assert "\n" not in str(info.value)


def test_bad_png_npz_and_unknown_formats(tmp_path):
    Image.fromarray(np.zeros((10, 10), np.uint8)).save(tmp_path / "a.png")
    with pytest.raises(InputError, match="16-bit"):
        read_depth(tmp_path / "a.png")
    Image.fromarray(np.zeros((10, 12, 3), np.uint8)).save(tmp_path / "rgb.png")
    with pytest.raises(InputError, match=r"colour image \(12x10, 3 channels, uint8\)"):
        read_depth(tmp_path / "rgb.png")
    np.savez(tmp_path / "x.npz", rgb=np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(InputError, match="no 'depth' or 'xyz' array .*rgb"):
        read_depth(tmp_path / "x.npz")
    np.savez(tmp_path / "k.npz", depth=np.ones((10, 10), np.float32), K=np.eye(2))
    with pytest.raises(InputError, match="3x3"):
        read_depth(tmp_path / "k.npz")
    (tmp_path / "b.jpg").write_bytes(b"x")
    with pytest.raises(InputError, match="unknown depth format"):
        read_depth(tmp_path / "b.jpg")
    (tmp_path / "b.ply").write_bytes(b"ply")
    with pytest.raises(InputError, match=r"b\.ply: not a PLY file"):
        read_depth(tmp_path / "b.ply")


def test_tiff_float_metres_and_16_bit_scaled(tmp_path):
    """A float32 TIFF (Pillow's mode F) is metres as it stands; a 16-bit one (mode I;16) is
    units of the depth scale; a colour or 8-bit TIFF is refused in one line."""
    depth = np.full((20, 30), 0.7315, np.float32)
    depth[2, 3] = 0.0
    Image.fromarray(depth).save(tmp_path / "m.tif")
    Image.fromarray((depth * 1e4).round().astype(np.uint16)).save(tmp_path / "u.tiff")
    with Image.open(tmp_path / "m.tif") as f, Image.open(tmp_path / "u.tiff") as u:
        assert (f.mode, u.mode) == ("F", "I;16")
    got, k = read_depth(tmp_path / "m.tif")
    np.testing.assert_array_equal(got, depth)
    assert k is None
    np.testing.assert_allclose(read_depth(tmp_path / "u.tiff", depth_scale=1e-4)[0], depth,
                               atol=1e-7)
    Image.fromarray(np.zeros((10, 10), np.uint8)).save(tmp_path / "a.tif")
    with pytest.raises(InputError, match="expected a single-channel TIFF .* got mode L") as info:
        read_depth(tmp_path / "a.tif")
    assert "\n" not in str(info.value)
    Image.fromarray(np.zeros((10, 12, 3), np.uint8)).save(tmp_path / "rgb.tif")
    with pytest.raises(InputError, match="colour image"):
        read_depth(tmp_path / "rgb.tif")


def _organised_cloud(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """A box on a table seen 20 degrees off vertical (`analytic_depth`), its depth (H, W) and
    its points (H, W, 3) back-projected by hand: x = (u - cx) z / fx, y = (v - cy) z / fy; no
    depth (0) is the point (0, 0, 0), as camera drivers write it."""
    rotation, eye = top_down_pose(0.6)
    depth = analytic_depth(camera, rot_x(np.deg2rad(20.0)) @ rotation, eye,
                           [box((0.05, 0.09, 0.05), (0.01, 0.02, 0.0), 0.35)])
    v, u = np.indices(depth.shape)
    z = np.nan_to_num(depth).astype(np.float64)
    xyz = np.stack([(u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z], -1)
    return depth, xyz


def test_organised_point_cloud_npz_gives_depth_and_fitted_intrinsics(tmp_path):
    """`xyz` alone: depth is its z, K fitted to its points (fx != fy, cx != cy: a swap shows);
    a K in the file wins; points not organised (shuffled) or no cloud at all are refused."""
    camera = Camera(64, 48, 80.0, 70.0, 30.25, 25.5)
    depth, xyz = _organised_cloud(camera)
    np.savez(tmp_path / "c.npz", xyz=xyz.astype(np.float32))
    got, k = read_depth(tmp_path / "c.npz")
    np.testing.assert_allclose(got, xyz[..., 2], atol=0)
    np.testing.assert_allclose(k, [[80.0, 0, 30.25], [0, 70.0, 25.5], [0, 0, 1]], atol=1e-3)
    own = np.array([[81.0, 0, 32.0], [0, 71.0, 24.0], [0, 0, 1]])
    np.savez(tmp_path / "own.npz", xyz=xyz, K=own)
    np.testing.assert_array_equal(read_depth(tmp_path / "own.npz")[1], own)
    shuffled = np.random.default_rng(0).permutation(xyz.reshape(-1, 3)).reshape(xyz.shape)
    np.savez(tmp_path / "s.npz", xyz=shuffled)
    with pytest.raises(InputError, match="fit no pinhole camera .* expected an organised cloud"):
        read_depth(tmp_path / "s.npz")
    np.savez(tmp_path / "flat.npz", xyz=xyz.reshape(-1, 3))
    with pytest.raises(InputError, match=r"organised point cloud \(H, W, 3\).*\(3072, 3\)"):
        read_depth(tmp_path / "flat.npz")


def test_open3d_intrinsics_json_is_column_major(tmp_path):
    """Open3D writes `intrinsic_matrix` column by column: [fx, 0, 0, 0, fy, 0, cx, cy, 1]."""
    (tmp_path / "o3d.json").write_text(json.dumps({
        "width": 640, "height": 480,
        "intrinsic_matrix": [525.0, 0.0, 0.0, 0.0, 520.0, 0.0, 319.5, 239.5, 1.0]}))
    assert load_intrinsics(tmp_path / "o3d.json") == {"fx": 525.0, "fy": 520.0, "cx": 319.5,
                                                      "cy": 239.5, "width": 640, "height": 480}
    (tmp_path / "rows.json").write_text(json.dumps({  # written row by row: refused, not swapped
        "width": 640, "height": 480,
        "intrinsic_matrix": [525.0, 0.0, 319.5, 0.0, 520.0, 239.5, 0.0, 0.0, 1.0]}))
    with pytest.raises(InputError, match=r"intrinsic_matrix \(column by column\): expected"):
        load_intrinsics(tmp_path / "rows.json")
    (tmp_path / "short.json").write_text(json.dumps({"intrinsic_matrix": [525.0, 0.0]}))
    with pytest.raises(InputError, match="list of 9 numbers"):
        load_intrinsics(tmp_path / "short.json")


ROS1_YAML = """\
image_width: 640
image_height: 480
camera_name: "depth camera"  # a comment
camera_matrix:
  rows: 3
  cols: 3
  data: [525.0, 0.0, 319.5,
         0.0, 520.0, 239.5,
         0.0, 0.0, 1.0]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [0.0, 0.0, 0.0, 0.0, 0.0]
projection_matrix:
  rows: 3
  cols: 4
  data: [530.0, 0, 320.0, 0, 0, 525.0, 240.0, 0, 0, 0, 1, 0]
"""

ROS2_YAML = """\
header:
  stamp:
    sec: 0
    nanosec: 0
  frame_id: camera_depth_optical_frame
height: 480
width: 640
distortion_model: plumb_bob
d:
- 0.0
- 0.0
k:
- 525.0
- 0.0
- 319.5
- 0.0
- 520.0
- 239.5
- 0.0
- 0.0
- 1.0
r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
---
"""


@pytest.mark.parametrize("text", [ROS1_YAML, ROS2_YAML])
def test_ros_camera_info_yaml(tmp_path, text):
    """ROS's camera_matrix (row by row; the projection matrix beside it is not taken) and ROS
    2's k list give the same intrinsics and image size."""
    (tmp_path / "info.yaml").write_text(text)
    assert load_intrinsics(tmp_path / "info.yaml") == {"fx": 525.0, "fy": 520.0, "cx": 319.5,
                                                       "cy": 239.5, "width": 640, "height": 480}


@pytest.mark.parametrize("text, match", [
    ("image_width: 640\n", "no camera_matrix \\(ROS\\) or k \\(ROS 2\\)"),
    ("camera_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 2]\n", "list of 9 numbers"),
    ("camera_matrix:\n  rows: 3\n  cols: 4\n  data: [1, 2]\n", "must be 3x3, got rows 3, cols 4"),
    ("k: [525, 0, 319.5, 0, 520, 239.5, 0, 0\n", "unclosed list"),
    ("k: [525, 0, 319.5, 0, 520, 239.5, 0, 0, 1]\nwidth: wide\n", 'width must be a number'),
    ("just text\n", "expected 'key: value'"),
])
def test_bad_camera_info_yaml(tmp_path, text, match):
    (tmp_path / "info.yml").write_text(text)
    with pytest.raises(InputError, match=match) as info:
        load_intrinsics(tmp_path / "info.yml")
    assert "\n" not in str(info.value)


def test_check_depth_accepts_nan_as_invalid():
    depth = np.full((10, 10), np.nan, np.float32)
    depth[5, 5] = 1.0
    assert check_depth(depth).shape == (10, 10)


def test_intrinsics_files(tmp_path):
    expected = {"fx": 525.0, "fy": 520.0, "cx": 319.5, "cy": 239.5}
    (tmp_path / "a.json").write_text(json.dumps(expected))
    (tmp_path / "b.intr").write_text(json.dumps({"_fx": 525.0, "_fy": 520.0, "_cx": 319.5,
                                                 "_cy": 239.5, "_width": 640, "_height": 480,
                                                 "_frame": "cam"}))
    (tmp_path / "c.json").write_text(json.dumps({"K": K.tolist()}))
    np.save(tmp_path / "d.npy", K)
    np.savetxt(tmp_path / "e.txt", K)
    for name in ("a.json", "c.json", "d.npy", "e.txt"):
        assert load_intrinsics(tmp_path / name) == expected
    assert load_intrinsics(tmp_path / "b.intr") == {**expected, "width": 640, "height": 480}


@pytest.mark.parametrize("name, text, match", [
    ("x.intr", "{not json", "cannot read intrinsics"),
    ("x.json", json.dumps({"fx": 500, "fy": 500}), "missing cx, cy"),
    ("x.json", json.dumps([1, 2]), "JSON object"),
    ("x.json", json.dumps({"fx": "wide", "fy": 1, "cx": 1, "cy": 1}), "fx must be a number"),
    ("x.json", json.dumps({"fx": -5, "fy": 1, "cx": 1, "cy": 1}), "> 0"),
    ("x.txt", "1 2 3\n4 5 6", "3x3"),
])
def test_unreadable_intrinsics(tmp_path, name, text, match):
    (tmp_path / name).write_text(text)
    with pytest.raises(InputError, match=match) as info:
        load_intrinsics(tmp_path / name)
    assert "\n" not in str(info.value)


INTR = {"_fx": 525.0, "_fy": 520.0, "_cx": 319.5, "_cy": 239.5, "_width": 640, "_height": 480}


@pytest.mark.parametrize("name, values, message", [
    ("x.intr", {"_fx": True}, "_fx must be a number, got true"),
    ("x.json", {"fx": 525.0, "fy": False, "cx": 1, "cy": 1}, "fy must be a number, got false"),
    ("x.intr", {"_cy": float("nan")}, "_cy must be a finite number > 0, got NaN"),
    ("x.intr", {"_fx": float("inf")}, "_fx must be a finite number > 0, got Infinity"),
    ("x.intr", {"_cx": 0}, "_cx must be a finite number > 0, got 0"),
    ("x.intr", {"_width": True}, "_width must be a number, got true"),
    ("x.intr", {"_height": -480}, "_height must be a finite number > 0, got -480"),
    ("x.json", {"K": [[True, 0, 319.5], [0, 520, 239.5], [0, 0, 1]]},
     "K: expected numbers, got true/false"),
    ("x.json", {"K": [[525, 0, -3.0], [0, 520, 239.5], [0, 0, 1]]},
     "K's cx must be a finite number > 0, got -3.0"),
])
def test_intrinsics_files_refuse_booleans_and_non_positive_values(tmp_path, name, values, message):
    """JSON `true` is no focal length (Python's float(True) is 1), nor are NaN, infinity, 0 or
    a negative number; the one line names the file and the key as the file spells it."""
    base = INTR if name.endswith(".intr") else {}
    (tmp_path / name).write_text(json.dumps({**base, **values}))
    with pytest.raises(InputError) as info:
        load_intrinsics(tmp_path / name)
    assert str(info.value) == f"{tmp_path / name}: {message}"


def test_check_matrix_refuses_skew_and_bad_rows():
    with pytest.raises(InputError, match="no skew"):
        check_matrix([[500, 3, 320], [0, 500, 240], [0, 0, 1]])
    with pytest.raises(InputError, match="no skew"):
        check_matrix([[500, 0, 320], [0, 500, 240], [0, 1, 1]])
    with pytest.raises(InputError, match="focal lengths"):
        check_matrix([[0, 0, 320], [0, 500, 240], [0, 0, 1]])


def test_masks(tmp_path):
    mask = np.zeros((20, 30), np.uint8)
    mask[5:15, 10:25] = 255
    Image.fromarray(mask).save(tmp_path / "m.png")
    Image.fromarray(np.stack([mask] * 3, -1)).save(tmp_path / "rgb.png")
    np.save(tmp_path / "m.npy", mask > 0)
    for name in ("m.png", "rgb.png", "m.npy"):
        np.testing.assert_array_equal(load_mask(tmp_path / name, (20, 30)), mask > 0)
    with pytest.raises(InputError, match="mask .* is 30x20, the depth images are 40x20"):
        load_mask(tmp_path / "m.png", (20, 40))
    np.save(tmp_path / "empty.npy", np.zeros((20, 30)))
    with pytest.raises(InputError, match="empty"):
        load_mask(tmp_path / "empty.npy", (20, 30))
    (tmp_path / "m.jpg").write_bytes(b"x")
    with pytest.raises(InputError, match="unknown mask format"):
        load_mask(tmp_path / "m.jpg", (20, 30))


def test_write_atomic_leaves_nothing_on_failure(tmp_path):
    write_atomic(tmp_path / "a.txt", b"hello")
    assert (tmp_path / "a.txt").read_bytes() == b"hello"
    with pytest.raises(FileNotFoundError):
        write_atomic(tmp_path / "missing" / "a.txt", b"x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_camera_pose_files_give_one_camera_to_world_matrix(tmp_path):
    """A turn of 90 degrees about z and 0.6 m up, as a 3x4 .txt, a JSON of rotation and
    translation and a gqcnn .tf (translation first, then the rotation's rows): one matrix."""
    from graspjax.imagefiles.readers import load_camera_pose

    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    expected = np.eye(4)
    expected[:3, :3], expected[:3, 3] = rotation, [0.0, 0.0, 0.6]
    np.savetxt(tmp_path / "pose.txt", expected[:3])
    (tmp_path / "pose.json").write_text(json.dumps({"rotation": rotation.tolist(),
                                                    "translation": [0, 0, 0.6]}))
    (tmp_path / "pose.tf").write_text("camera\nworld\n0 0 0.6\n0 -1 0\n1 0 0\n0 0 1\n")
    for name in ("pose.txt", "pose.json", "pose.tf"):
        np.testing.assert_allclose(load_camera_pose(tmp_path / name), expected)
    mirrored = expected.copy()
    mirrored[0, :3] *= -1  # a reflection: determinant -1
    np.save(tmp_path / "mirror.npy", mirrored)
    with pytest.raises(InputError, match="is not a rotation"):
        load_camera_pose(tmp_path / "mirror.npy")
    (tmp_path / "short.json").write_text("[[1, 0], [0, 1]]")
    with pytest.raises(InputError, match="expected a finite 4x4"):
        load_camera_pose(tmp_path / "short.json")
