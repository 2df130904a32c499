"""Organised clouds, PCL's `.pcd` and the PLY range grid (`imagefiles/clouds.py`), against
files written here by hand from a known cloud and LZF streams worked out by hand."""

import numpy as np
import pytest

from graspjax.camera import Camera
from graspjax.errors import InputError
from graspjax.imagefiles.clouds import lzf_decompress, read_pcd, read_pcd_points, read_ply
from graspjax.imagefiles.readers import read_depth
from graspjax.synthetic import analytic_depth, box, rot_x, top_down_pose


def test_lzf_literal_runs_and_back_references_decoded_by_hand():
    # "abc" literal (control 2), then 6 bytes from 3 back (control (6-2) << 5, offset byte 3-1),
    # overlapping what it writes, then "X" literal (control 0)
    assert lzf_decompress(bytes([2, *b"abc", 4 << 5, 2, 0, *b"X"]), 10) == b"abcabcabcX"
    # a long copy: length field 7 plus a byte of 10 is 7 + 10 + 2 = 19 bytes from 1 back
    assert lzf_decompress(bytes([0, *b"a", 7 << 5, 10, 0]), 20) == b"a" * 20
    # a reference more than 256 back: offset (1 << 8) + 4 + 1 = 261 bytes back
    head = bytes(range(256)) + b"\x00" * 5
    stream = bytes([31, *head[:32]] + [b for k in range(32, 256, 32) for b in (31, *head[k:k + 32])]
                   + [4, *head[256:]] + [(3 - 2) << 5 | 1, 4])
    assert lzf_decompress(stream, 264) == head + head[:3]
    for bad, size, why in (([0], 1, "literal run past the end"), ([2 << 5], 4, "truncated"),
                           ([0, 1, 1 << 5, 5], 4, "outside the output"),
                           ([0, 1], 2, "decoded 1 bytes, the header says 2")):
        with pytest.raises(ValueError, match=why):
            lzf_decompress(bytes(bad), size)


def _cloud() -> tuple[Camera, np.ndarray]:
    """A box on a table seen 20 degrees off vertical, back-projected by hand through the
    camera (x = (u - cx) z / fx, y = (v - cy) z / fy), NaN where no depth: (H, W, 3)."""
    camera = Camera(40, 30, 50.0, 45.0, 19.25, 15.5)
    rotation, eye = top_down_pose(0.6)
    depth = analytic_depth(camera, rot_x(np.deg2rad(20.0)) @ rotation, eye,
                           [box((0.05, 0.09, 0.05), (0.01, 0.02, 0.0), 0.35)])
    v, u = np.indices(depth.shape)
    z = np.where(depth > 0, depth, np.nan)
    z[0, :5] = np.nan  # a few pixels the sensor missed
    xyz = np.stack([(u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z], -1)
    return camera, xyz.astype(np.float32)


def _pcd(xyz: np.ndarray, encoding: str, height: int | None = None) -> bytes:
    """`xyz` as PCL writes a Kinect cloud: a `label` field first (u4), x y z (f4), a padding
    field `_` of 3 bytes (COUNT 3), and `rgb` (f4); `binary_compressed` with an all-literal
    LZF stream (runs of at most 32 bytes, each after its control byte `length - 1`)."""
    h, w = xyz.shape[:2]
    n = h * w
    record = np.dtype([("label", "<u4"), ("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                       ("pad", "u1", (3,)), ("rgb", "<f4")])
    points = np.zeros(n, record)
    points["label"] = np.arange(n) % 7
    for k, axis in enumerate("xyz"):
        points[axis] = xyz[..., k].ravel()
    points["rgb"] = 0.5
    header = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
              "FIELDS label x y z _ rgb\nSIZE 4 4 4 4 1 4\nTYPE U F F F U F\nCOUNT 1 1 1 1 3 1\n"
              f"WIDTH {w}\nHEIGHT {h if height is None else height}\nVIEWPOINT 0 0 0 1 0 0 0\n"
              f"POINTS {n}\nDATA {encoding}\n").encode()
    if encoding == "ascii":
        lines = [" ".join([str(p["label"]), *(repr(float(p[a])) for a in "xyz"), "0 0 0 0.5"])
                 for p in points]
        return header + "\n".join(lines).encode() + b"\n"
    if encoding == "binary":
        return header + points.tobytes()
    flat = b"".join(points[name].tobytes() for name in record.names)  # field after field
    stream = b"".join(bytes([len(flat[k:k + 32]) - 1]) + flat[k:k + 32]
                      for k in range(0, len(flat), 32))
    return header + np.array([len(stream), len(flat)], "<u4").tobytes() + stream


def _each_refused_in_one_line(tmp_path, cases: dict[str, tuple[bytes, str]]) -> None:
    """Each file (name -> its bytes, the words its refusal must hold) refused by `read_depth`
    with one line."""
    for name, (data, why) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(InputError, match=why) as info:
            read_depth(tmp_path / name)
        assert "\n" not in str(info.value), name


@pytest.mark.parametrize("encoding", ["ascii", "binary", "binary_compressed"])
def test_organised_pcd_gives_the_cloud_its_depth_and_the_camera(tmp_path, encoding):
    camera, xyz = _cloud()
    (tmp_path / "c.pcd").write_bytes(_pcd(xyz, encoding))
    got = read_pcd(tmp_path / "c.pcd")
    assert got.shape == (30, 40, 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, xyz)  # NaN in the same places
    depth, k = read_depth(tmp_path / "c.pcd")
    np.testing.assert_array_equal(np.isnan(depth), np.isnan(xyz[..., 2]))
    np.testing.assert_allclose(k, [[50.0, 0, 19.25], [0, 45.0, 15.5], [0, 0, 1]], atol=2e-3)


def test_unorganised_malformed_or_foreign_pcd_is_refused_in_one_line(tmp_path):
    _, xyz = _cloud()
    cases = {
        "flat.pcd": (_pcd(xyz.reshape(1, -1, 3), "binary"), "unorganised point cloud"),
        "short.pcd": (_pcd(xyz, "binary")[:-10], "bytes of points"),
        "enc.pcd": (_pcd(xyz, "binary").replace(b"DATA binary", b"DATA lzma"), "unknown PCD DATA"),
        "noz.pcd": (_pcd(xyz, "binary").replace(b"label x y z", b"label x y w"), "no z field"),
        "head.pcd": (b"VERSION 0.7\nFIELDS x y z\n", "no PCD header ending in a DATA line"),
        "junk.pcd": (b"hello world\n", "not a PCD header line"),
        "lzf.pcd": (_pcd(xyz, "binary_compressed")[:-40] + b"\x1f" * 40, "corrupt LZF"),
        "type.pcd": (_pcd(xyz, "binary").replace(b"TYPE U F F F U F", b"TYPE U F F F U Q"),
                     "unknown TYPE Q"),
    }
    _each_refused_in_one_line(tmp_path, cases)


def test_a_folder_stands_for_its_pcd_clouds_too(tmp_path):
    from graspjax.imagefiles.inputs import expand_images

    _, xyz = _cloud()
    for name in ("b.pcd", "a.PCD"):
        (tmp_path / name).write_bytes(_pcd(xyz, "binary"))
    (tmp_path / "notes.txt").write_text("not an image")
    assert [p.name for p in expand_images([tmp_path])] == ["a.PCD", "b.pcd"]


def test_every_field_of_the_points_is_read(tmp_path):
    """`read_pcd_points` keeps the fields besides x, y, z (a segmentation's labels, colour)."""
    _, xyz = _cloud()
    (tmp_path / "c.pcd").write_bytes(_pcd(xyz, "binary_compressed"))
    points = read_pcd_points(tmp_path / "c.pcd")
    assert points.shape == (30, 40)
    np.testing.assert_array_equal(points["label"], (np.arange(1200) % 7).reshape(30, 40))
    np.testing.assert_array_equal(points["rgb"], 0.5)


def _ply(xyz: np.ndarray, form: str, grid: bool = True, info: bool = True) -> bytes:
    """`xyz` as PCL's PLY writer leaves an organised cloud: `obj_info num_cols`/`num_rows`,
    the valid points as vertices (x y z float, then a uchar `red`), an empty `face` element and
    a `range_grid` listing each pixel's vertex (none where the point is NaN); or, with
    `grid=False`, every pixel a vertex in row order."""
    h, w = xyz.shape[:2]
    flat = xyz.reshape(-1, 3)
    valid = np.isfinite(flat).all(1) if grid else np.ones(len(flat), bool)
    order = {"ascii": "<", "binary_little_endian": "<", "binary_big_endian": ">"}[form]
    head = ["ply", f"format {form} 1.0", "comment written by hand"]
    if info:
        head += ["obj_info is_mesh 0", f"obj_info num_cols {w}", f"obj_info num_rows {h}"]
    head += [f"element vertex {valid.sum()}", "property float x", "property float y",
             "property float z", "property uchar red", "element face 0"]
    if grid:
        head += [f"element range_grid {h * w}", "property list uchar int vertex_indices"]
    header = ("\n".join(head) + "\nend_header\n").encode()
    index = np.cumsum(valid) - 1
    if form == "ascii":
        lines = [" ".join([*(repr(float(v)) for v in p), "7"]) for p in flat[valid]]
        if grid:
            lines += [f"1 {i}" if ok else "0" for ok, i in zip(valid, index, strict=True)]
        return header + "\n".join(lines).encode() + b"\n"
    record = np.dtype([("x", order + "f4"), ("y", order + "f4"), ("z", order + "f4"),
                       ("red", "u1")])
    vertices = np.zeros(valid.sum(), record)
    for k, axis in enumerate("xyz"):
        vertices[axis] = flat[valid, k]
    body = vertices.tobytes()
    if grid:
        body += b"".join(b"\x01" + np.array([i], order + "i4").tobytes() if ok else b"\x00"
                         for ok, i in zip(valid, index, strict=True))
    return header + body


@pytest.mark.parametrize("form", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_a_ply_range_grid_gives_the_cloud_at_its_pixels(tmp_path, form):
    _, xyz = _cloud()
    (tmp_path / "g.ply").write_bytes(_ply(xyz, form))
    got = read_ply(tmp_path / "g.ply")
    assert got.shape == (30, 40, 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, xyz)  # NaN where the grid lists no vertex
    (tmp_path / "all.ply").write_bytes(_ply(xyz, form, grid=False))
    np.testing.assert_array_equal(read_ply(tmp_path / "all.ply"), xyz)
    depth, k = read_depth(tmp_path / "g.ply")
    np.testing.assert_allclose(k, [[50.0, 0, 19.25], [0, 45.0, 15.5], [0, 0, 1]], atol=2e-3)


def test_a_ply_with_pcl_s_camera_element_takes_its_viewport_as_the_grid(tmp_path):
    """PCL's writer with its camera: no obj_info, every pixel a vertex, and a `camera`
    element whose `viewportx`/`viewporty` are the cloud's width and height."""
    _, xyz = _cloud()
    data = _ply(xyz, "ascii", grid=False, info=False).replace(
        b"element face 0\n", b"element face 0\nelement camera 1\nproperty float focal\n"
        b"property int viewportx\nproperty int viewporty\n")
    (tmp_path / "cam.ply").write_bytes(data.rstrip(b"\n") + b"\n0 40 30\n")
    np.testing.assert_array_equal(read_ply(tmp_path / "cam.ply"), xyz)


def test_a_ply_without_its_grid_or_a_mesh_is_refused_in_one_line(tmp_path):
    _, xyz = _cloud()
    mesh = _ply(xyz, "ascii").replace(b"element face 0\n", b"element face 1\n"
                                      b"property list uchar int vertex_indices\n")
    cases = {
        "flat.ply": (_ply(xyz, "binary_little_endian", info=False), "unorganised point cloud"),
        "mesh.ply": (mesh, "'face' holds lists"),
        "short.ply": (_ply(xyz, "binary_little_endian")[:-100], "does not match its header"),
        "cut.ply": (_ply(xyz, "ascii", grid=False)[:-60], "does not match its header"),
        "count.ply": (_ply(xyz, "ascii", grid=False).replace(b"num_rows 30", b"num_rows 31"),
                      "vertices and no range_grid for a 40 x 31 grid"),
        "format.ply": (_ply(xyz, "ascii").replace(b"format ascii", b"format utf8"),
                       "unknown PLY format"),
        "type.ply": (_ply(xyz, "ascii").replace(b"property float x", b"property half x"),
                     "unreadable PLY header line"),
    }
    _each_refused_in_one_line(tmp_path, cases)
