"""The real-image stages one by one: block median, hole filling, target test, support plane,
virtual view; against hand-computed arrays, NumPy references and analytic scenes."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from real_scenes import steep_table_scene, tilted_pose

from graspjax import Camera
from graspjax.codes import SupportReason, TargetReason
from graspjax.config import Config, ConfigError, RealImageConfig
from graspjax.perception.real_image import _targets
from graspjax.perception.support import plane_height, support_plane
from graspjax.perception.target import (
    best_candidate,
    similar_neighbours,
    surface_normals,
    surface_slope,
    target_candidates,
)
from graspjax.perception.virtual import (
    view_camera,
    view_rotation,
    warp_depth_and_values,
)
from graspjax.perception.window import detection_window, followed_surface, in_view, surface_in_view
from graspjax.perception.workspace import block_median, fill_holes, nan_median
from graspjax.synthetic import analytic_depth, box

WORK = Camera(320, 240, 262.5, 262.5, 159.5, 119.5)  # the PrimeSense at half resolution


@pytest.fixture(scope="module")
def support():
    return jax.jit(support_plane)


def _angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.rad2deg(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def _angle_deg_rows(vectors, b):
    """Angles (N,) between the lines of `vectors` (N, 3) and `b` (3,), degrees."""
    cos = np.abs(vectors @ b) / np.linalg.norm(vectors, axis=-1) / np.linalg.norm(b)
    return np.rad2deg(np.arccos(np.clip(cos, -1, 1)))


def _table(solids=(), tilt_deg=13.0, camera=WORK):
    """Working-resolution depth of `solids` on a table, seen from 0.73 m, tilted; and the pose."""
    rotation, eye = tilted_pose(0.73, tilt_deg)
    return analytic_depth(camera, rotation, eye, list(solids)), rotation, eye


@pytest.mark.parametrize("factor", [2, 3, 4])
def test_block_median_is_the_median_of_the_valid_pixels(factor):
    rng = np.random.default_rng(factor)
    depth = rng.uniform(0.5, 1.0, (4 * factor + 1, 6 * factor - 1)).astype(np.float32)
    depth[rng.random(depth.shape) < 0.3] = 0.0
    depth[rng.random(depth.shape) < 0.1] = np.nan
    depth[:factor, :factor] = 0.0  # a block without any valid pixel
    out = np.asarray(block_median(jnp.asarray(depth), factor))
    assert out.shape == (4, 5)  # cropped to whole blocks
    for i in range(4):
        for j in range(5):
            block = depth[i * factor:(i + 1) * factor, j * factor:(j + 1) * factor]
            valid = block[np.isfinite(block) & (block > 0)]
            assert out[i, j] == pytest.approx(np.median(valid) if valid.size else 0.0, abs=1e-7)


def test_nan_median_is_numpys_without_a_sort():
    """Bit for bit NumPy's `nanmedian` (the mean of the two middle values, in float32):
    odd and even counts, ties, signs and both zeros, nan among the values, one value; nan
    when all are nan or there are none; the same under vmap."""
    rng = np.random.default_rng(7)
    median = jax.jit(nan_median)
    cases = [np.array([0.7], np.float32), np.array([2.0, 1.0], np.float32),
             np.array([-0.0, 0.0, -1.5, 3.25], np.float32), np.full(5, 0.61, np.float32)]
    for n in (2, 3, 50, 1001, 19_200):
        values = rng.uniform(0.3, 1.5, n).astype(np.float32)
        values[rng.random(n) < 0.3] = np.nan
        cases += [values, np.round(rng.normal(size=n), 1).astype(np.float32)]
    for values in cases:
        np.testing.assert_array_equal(median(values), np.float32(np.nanmedian(values)))
    assert np.isnan(median(np.full((3, 4), np.nan, np.float32)))
    assert np.isnan(median(np.zeros(0, np.float32)))
    rows = np.stack(cases[-2:])  # (2, 19200)
    np.testing.assert_array_equal(jax.vmap(nan_median)(rows), np.nanmedian(rows, axis=1))


def test_fill_holes_bridges_holes_inside_a_surface_but_not_across_a_step():
    depth = np.full((20, 30), 0.7, np.float32)
    depth[:, 16:] = 0.6  # a 10 cm step between columns 15 and 16
    depth[5, 3:12] = 0.0  # a crack one pixel tall in the 0.7 surface
    depth[10:12, 5:7] = np.nan  # a 2 x 2 hole: each pixel is 2 pixels from valid depth on one side
    depth[:, 15:17] = 0.0  # a shadow along the step: both sides differ by 10 cm
    depth[1, 22] = 0.0  # outside the workspace
    workspace = np.ones(depth.shape, bool)
    workspace[:3] = False
    out = np.asarray(fill_holes(jnp.asarray(depth), jnp.asarray(workspace), 2, 0.005))
    np.testing.assert_allclose(out[5, 3:12], 0.7, atol=1e-6)
    np.testing.assert_allclose(out[10:12, 5:7], 0.7, atol=1e-6)
    assert np.all(out[:, 15:17] == 0.0) and out[1, 22] == 0.0
    one = np.asarray(fill_holes(jnp.asarray(depth), jnp.asarray(workspace), 1, 0.005))
    assert np.all(one[10:12, 5:7] == 0.0) and one[5, 4] == pytest.approx(0.7)  # 2 wide needs 2
    off = np.asarray(fill_holes(jnp.asarray(depth), jnp.asarray(workspace), 0, 0.005))
    np.testing.assert_array_equal(off, np.nan_to_num(depth))


def test_similar_neighbours_counts_the_window():
    depth = np.full((9, 9), 0.8, np.float32)
    depth[4, 4] = 0.3  # a one-pixel speck
    depth[8, 8] = 0.0
    count = np.asarray(similar_neighbours(jnp.asarray(depth), 5, 0.005))
    assert count[4, 4] == 1 and count[4, 3] == 24  # the speck; its neighbour sees 24 of 25
    assert count[0, 0] == 9 and count[0, 4] == 15  # the window is cut by the image border
    assert count[8, 8] == 0 and count[7, 7] == 15  # an invalid pixel counts for nothing


def test_specks_smaller_than_the_area_are_never_the_target():
    camera = Camera(40, 30, 50.0, 50.0, 19.5, 14.5)
    table = np.full((30, 40), 0.8, np.float32)
    depth = table.copy()
    depth[5, 5] = 0.5  # 1 pixel
    depth[10:12, 10:12] = 0.5  # 4 pixels
    depth[20:22, 3:7] = 0.5  # 8 pixels
    args = dict(window=5, min_pixels=9, max_slope_deg=45.0, min_height=0.01, tolerance=0.005)

    def candidates(d, has_plane=True):
        return target_candidates(jnp.asarray(d), camera, jnp.asarray(0.8 - d),
                                 jnp.asarray(has_plane), **args)

    cand, reason = candidates(depth)
    assert not np.any(cand) and int(reason) == TargetReason.NO_SURFACE
    assert int(candidates(table)[1]) == TargetReason.NO_OBJECT
    assert int(candidates(np.zeros_like(table))[1]) == TargetReason.EMPTY_WORKSPACE

    depth[20:25, 30:35] = 0.6  # a 5 x 5 top, lower than the specks: the target
    cand, reason = candidates(depth)
    score = jnp.asarray(0.8 - depth)
    assert int(reason) == TargetReason.FOUND
    assert np.array_equal(np.argwhere(np.asarray(cand)), np.argwhere(depth == 0.6))
    seed, pixel = best_candidate(cand, score)
    assert tuple(np.asarray(pixel)) == (30, 20)  # ties: the first in row-major order
    assert np.argwhere(np.asarray(seed)).tolist() == [[20, 30]]
    # Without a support plane the nearest candidate wins, and the table is a candidate too.
    cand, _ = candidates(depth, has_plane=False)
    assert np.asarray(cand)[0, 0] and tuple(np.asarray(best_candidate(cand, -depth)[1])) == (30, 20)


@pytest.mark.parametrize("slope_deg", [20.0, 60.0])
def test_surface_slope_of_an_analytic_plane(slope_deg):
    """Plane z = z0 + tan(a) y seen by the camera: at the principal point the slope is tan(a)."""
    camera = Camera(41, 31, 300.0, 300.0, 20.0, 15.0)
    v = np.arange(31, dtype=np.float64)[:, None] * np.ones((1, 41))
    z = 0.7 / (1.0 - np.tan(np.deg2rad(slope_deg)) * (v - 15.0) / 300.0)
    slope = np.asarray(surface_slope(jnp.asarray(z, jnp.float32), camera, 2))
    assert slope[15, 20] == pytest.approx(np.tan(np.deg2rad(slope_deg)), rel=0.03)
    flat = np.asarray(surface_slope(jnp.full((31, 41), 0.7), camera, 2))
    assert np.all(flat == 0.0)


@pytest.mark.parametrize("slope_deg", [0.0, 30.0])
def test_surface_slope_far_off_the_optical_axis(slope_deg):
    """A view whose rays meet the scene 40-50 deg off its axis (a view turned to face a tilted
    table): a plane z = z0 + tan(a) y has its own slope at every pixel, and a vertical face
    (y = const) is near 90 deg, though its depth changes only about one lateral pixel per pixel
    (a per-pixel depth difference would call it 45 deg)."""
    fy = 300.0
    camera = Camera(41, 31, 300.0, fy, 20.0, 15.0 - fy * np.tan(np.deg2rad(45.0)))
    v = np.arange(31, dtype=np.float64)[:, None] * np.ones((1, 41))
    ray_y = (v - camera.cy) / fy  # tan of each row's ray angle, 40-50 deg
    plane = 0.7 / (1.0 - np.tan(np.deg2rad(slope_deg)) * ray_y)
    slope = np.asarray(surface_slope(jnp.asarray(plane, jnp.float32), camera, 2))
    assert np.allclose(slope[2:-2, 2:-2], np.tan(np.deg2rad(slope_deg)), atol=0.01)
    face = 0.7 / ray_y  # every ray meets the face y = 0.7 m
    steep = np.degrees(np.arctan(np.asarray(surface_slope(jnp.asarray(face, jnp.float32), camera, 2))))
    assert np.all(steep[2:-2, 2:-2] > 85.0)


def _slope_of(normals: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Tangent of the angle between unit `normals` (..., 3) (nan: unknown) and `axis` (3,);
    inf where unknown. In float32, term by term, as the package rounds: near a zero slope the
    tangent is rounding (sqrt(2 eps), 3e-4)."""
    n, a = normals.astype(np.float32), axis.astype(np.float32)
    cos = np.abs(n[..., 0] * a[0] + n[..., 1] * a[1] + n[..., 2] * a[2])
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.sqrt(np.maximum(1.0 - cos * cos, 0.0)) / cos
    return np.where(np.isnan(slope), np.inf, slope)


def test_surface_slope_against_a_turned_axis():
    """The plane z = z0 + tan(30 deg) y against an axis turned 30 deg about x (the plane's own
    normal direction) has no slope, against one turned 30 deg the other way 60 deg; and it is
    the slope of `surface_normals` against it, unknown (inf) where the depth is."""
    camera = Camera(41, 31, 300.0, 300.0, 20.0, 15.0)
    v = np.arange(31, dtype=np.float64)[:, None] * np.ones((1, 41))
    a = np.deg2rad(30.0)
    z = 0.7 / (1.0 - np.tan(a) * (v - 15.0) / 300.0)
    z[10:13, 5:8] = 0.0
    depth = jnp.asarray(z, jnp.float32)
    inner = (slice(2, -2), slice(2, -2))
    for turn, expected in ((a, 0.0), (-a, np.tan(2 * a))):
        axis = jnp.asarray([0.0, -np.sin(turn), np.cos(turn)], jnp.float32)
        slope = np.asarray(surface_slope(depth, camera, 2, axis))
        known = np.isfinite(slope)
        assert not known[10:13, 5:8].any() and known[inner].mean() > 0.9
        assert np.allclose(slope[inner][known[inner]], expected, atol=0.02)
        reference = _slope_of(np.asarray(surface_normals(depth, camera, 2)), np.asarray(axis))
        assert np.array_equal(np.isfinite(reference), known)
        assert np.allclose(slope[known], reference[known], rtol=1e-5, atol=1e-6)


def test_surface_slope_of_a_plane_tilted_about_both_axes():
    """z = z0 + p x + q y has the normal (-p, -q, 1) everywhere: its slope against an axis with
    every component non-zero is the tangent of the angle between them (each term of the
    normal's cross product counts)."""
    camera = Camera(41, 31, 300.0, 300.0, 20.0, 15.0)
    v, u = np.mgrid[0:31, 0:41].astype(np.float64)
    p, q = np.tan(np.deg2rad(20.0)), np.tan(np.deg2rad(-25.0))
    z = 0.7 / (1.0 - p * (u - 20.0) / 300.0 - q * (v - 15.0) / 300.0)
    axis = np.array([0.3, 0.2, 0.93]) / np.linalg.norm([0.3, 0.2, 0.93])
    normal = np.array([-p, -q, 1.0]) / np.linalg.norm([-p, -q, 1.0])
    expected = np.tan(np.arccos(abs(normal @ axis)))
    slope = np.asarray(surface_slope(jnp.asarray(z, jnp.float32), camera, 2,
                                     jnp.asarray(axis, jnp.float32)))
    assert np.allclose(slope[2:-2, 2:-2], expected, rtol=1e-3)
    normals = np.asarray(surface_normals(jnp.asarray(z, jnp.float32), camera, 2))[2:-2, 2:-2]
    assert np.allclose(np.abs(normals @ normal), 1.0, atol=1e-5)


def test_support_plane_of_a_tilted_table_with_an_object(support):
    depth, rotation, eye = _table([box((0.04, 0.07, 0.04), (0.02, 0.15, 0.0), 0.3)])
    plane = support(jnp.asarray(depth), WORK)
    up = rotation.T @ [0.0, 0.0, 1.0]  # the table's normal toward the camera, camera frame
    assert int(plane.reason) == SupportReason.FOUND and bool(plane.found)
    assert _angle_deg(plane.normal, up) < 0.05
    assert float(plane.distance) == pytest.approx(0.73, abs=5e-4)
    assert np.rad2deg(float(plane.tilt)) == pytest.approx(13.0, abs=0.05)
    assert float(plane.fraction) > 0.9
    # Heights: the box top stands 4 cm above the plane.
    top = rotation.T @ (np.array([0.02, 0.15, 0.04]) - eye)
    assert float(plane_height(jnp.asarray(top), plane.normal, plane.distance)) == pytest.approx(
        0.04, abs=5e-4)


def test_support_is_the_table_even_under_a_larger_top_face(support):
    """A 3 cm slab covering most of the view: its top holds more pixels than the visible table,
    but the whole table lies behind it."""
    depth, rotation, _ = _table([box((0.6, 0.5, 0.03), (0.0, 0.17, 0.0))])
    up = rotation.T @ [0.0, 0.0, 1.0]
    slab = np.asarray(plane_height(WORK.unproject(WORK.pixel_grid(), jnp.asarray(depth)),
                                   jnp.asarray(up), 0.73)) > 0.02
    assert 0.5 < slab.mean() < 0.85  # the slab's top is the largest plane in view
    plane = support(jnp.asarray(depth), WORK)
    assert bool(plane.found) and float(plane.distance) == pytest.approx(0.73, abs=5e-4)
    assert _angle_deg(plane.normal, up) < 0.05


def _tote_view(camera_height: float, tilt_deg: float):
    """Depth of an empty 60 x 40 cm tote with 30 cm walls on a table, centred where the optical
    axis of a camera `camera_height` above the table, tilted `tilt_deg`, meets the table; and
    the table's normal toward the camera (camera frame)."""
    rotation, eye = tilted_pose(camera_height, tilt_deg)
    axis = rotation[:, 2]
    x, y, _ = eye - eye[2] / axis[2] * axis
    length, width, thick, tall = 0.60, 0.40, 0.01, 0.30
    walls = [box((length + 2 * thick, thick, tall), (x, y + side * (width + thick) / 2, 0.0))
             for side in (-1, 1)]
    walls += [box((thick, width, tall), (x + side * (length + thick) / 2, y, 0.0)) for side in (-1, 1)]
    return analytic_depth(WORK, rotation, eye, walls), rotation.T @ [0.0, 0.0, 1.0]


@pytest.mark.parametrize("tilt_deg", [50.0, 60.0])
def test_a_tote_seen_obliquely_stands_on_the_table_not_on_its_far_wall(support, tilt_deg):
    """A camera 0.6 m above the table looking 50-60 degrees down into a tote: the table (floor
    and the table beyond) is the support. A 45-degree limit would leave the table out and take
    the far wall, which faces such a camera within 45 degrees: a tilt limit guards against no
    wall; the score's penalty for pixels behind a plane does."""
    depth, up = _tote_view(0.6, tilt_deg)
    plane = support(jnp.asarray(depth), WORK)
    assert bool(plane.found) and _angle_deg(plane.normal, up) < 0.5
    assert float(plane.distance) == pytest.approx(0.6, abs=2e-3)
    limited = support(jnp.asarray(depth), WORK, RealImageConfig(max_plane_tilt_deg=45.0))
    assert bool(limited.found) and _angle_deg(limited.normal, up) > 80.0  # a wall


def test_a_camera_just_above_a_deep_totes_rim_takes_its_far_wall(support):
    """The trade-off of the 85-degree limit, recorded: 15 cm above the rim of a tote with 30 cm
    walls, looking 40 degrees down, the far wall fills most of the view with nothing seen behind
    it, and is taken as the support; a 45-degree limit found no plane there (`TOO_TILTED`)."""
    depth, up = _tote_view(0.45, 40.0)
    plane = support(jnp.asarray(depth), WORK)
    assert bool(plane.found) and _angle_deg(plane.normal, up) > 80.0  # a wall
    limited = support(jnp.asarray(depth), WORK, RealImageConfig(max_plane_tilt_deg=45.0))
    assert int(limited.reason) == SupportReason.TOO_TILTED


def test_support_plane_failures_are_reasons(support):
    assert int(support(jnp.zeros((240, 320)), WORK).reason) == SupportReason.NO_DEPTH
    # Only a plane tilted 60 degrees from the optical axis: the support under the default limit
    # (85); past a 45-degree limit not taken, and said so with its tilt.
    steep_table, _, _ = _table(tilt_deg=60.0)
    assert int(support(jnp.asarray(steep_table), WORK).reason) == SupportReason.FOUND
    steep = support(jnp.asarray(steep_table), WORK, RealImageConfig(max_plane_tilt_deg=45.0))
    assert int(steep.reason) == SupportReason.TOO_TILTED and not bool(steep.found)
    assert np.rad2deg(float(steep.tilt)) == pytest.approx(60.0, abs=0.5)
    assert np.isnan(np.asarray(steep.normal)).all()
    noise = np.random.default_rng(0).uniform(0.5, 1.0, (240, 320)).astype(np.float32)
    scattered = support(jnp.asarray(noise), WORK)
    assert int(scattered.reason) == SupportReason.TOO_FEW_INLIERS
    assert np.isnan(np.asarray(scattered.normal)).all()


def test_virtual_view_faces_the_table():
    """Re-projected into a camera looking along the table's negative normal, the table has one
    depth everywhere: the camera's distance to it."""
    depth, rotation, _ = _table([box((0.04, 0.07, 0.04), (0.02, 0.15, 0.0), 0.3)])
    up = jnp.asarray(rotation.T @ [0.0, 0.0, 1.0], jnp.float32)
    turn = view_rotation(up, jnp.asarray(True))
    np.testing.assert_allclose(np.asarray(turn)[:, 2], -np.asarray(up), atol=1e-6)
    np.testing.assert_allclose(np.asarray(turn) @ np.asarray(turn).T, np.eye(3), atol=1e-6)
    view = view_camera(WORK, turn)
    axis = np.asarray(turn).T @ [0.0, 0.0, 1.0]  # the real optical axis keeps its pixel
    np.testing.assert_allclose(np.asarray(view.project(jnp.asarray(axis))), [159.5, 119.5],
                               atol=1e-3)
    warped = np.asarray(warp_depth_and_values(jnp.asarray(depth), jnp.asarray(depth), WORK, view,
                                              turn, -1.0)[0])
    valid = warped > 0
    assert valid.mean() > 0.85
    table = np.abs(warped[valid] - 0.73) < 1e-4
    top = np.abs(warped[valid] - 0.69) < 1e-4  # the box top stands 4 cm nearer
    assert table.mean() > 0.95 and top.sum() > 100
    assert np.array_equal(np.asarray(view_rotation(up, jnp.asarray(False))), np.eye(3))


def test_normals_seen_through_a_view_that_faces_a_steep_table():
    """A table seen 44 deg off vertical: its normals, measured on the camera's own image, are
    the table's; carried into the view turned to face it, they face that view everywhere."""
    depth, rotation, _ = _table([], tilt_deg=44.0)
    up = rotation.T @ [0.0, 0.0, 1.0]
    normals = np.asarray(surface_normals(jnp.asarray(depth), WORK, 2))
    valid = np.isfinite(normals[..., 0])
    assert valid.mean() > 0.95
    assert np.all(_angle_deg_rows(normals[valid], up) < 0.5)
    turn = view_rotation(jnp.asarray(up, jnp.float32), jnp.asarray(True))
    view = view_camera(WORK, turn)
    slope = np.asarray(warp_depth_and_values(
        jnp.asarray(depth), jnp.asarray(_slope_of(normals, np.asarray(turn[:, 2])), jnp.float32),
        WORK, view, turn, jnp.inf)[1])
    seen = np.isfinite(slope)
    assert seen.mean() > 0.3
    assert np.all(slope[seen] < np.tan(np.deg2rad(0.5)))


def test_a_windows_surface_seen_in_a_view_four_times_coarser():
    """A 32-pixel square (fine pixels 40-71 of a 96-pixel window whose principal point is
    shifted 8 pixels, as `detection_window` cuts it) seen from a 32-pixel view of the same
    optics, 4 times coarser (`Camera.scaled`): coarse pixel u's centre lies on fine pixel
    4u + 1.5 of the full image, 4u - 6.5 of the window. Coarse pixels whose blocks lie inside
    the square (u 12-19) show it, those a whole coarse pixel or more outside do not (u <= 10,
    u >= 21), the edge ones within half a coarse pixel (u 11, 20) may; invalid points never."""
    full = Camera(128, 128, 100.0, 100.0, 63.5, 63.5)
    window = Camera(96, 96, 100.0, 100.0, 63.5 - 8, 63.5 - 8)
    coarse = full.scaled(32, 32)
    surface = np.zeros((96, 96), bool)
    surface[40:72, 40:72] = True
    depth = np.full((32, 32), 0.8, np.float32)
    depth[0, :] = 0.0  # no depth on the first row
    points = coarse.unproject(coarse.pixel_grid(), jnp.asarray(depth))
    shown = np.asarray(surface_in_view(jnp.asarray(surface), window, points,
                                       jnp.asarray(depth > 0), 4))
    inside = np.zeros(32, bool)
    inside[12:20] = True
    edge = np.zeros(32, bool)
    edge[[11, 20]] = True
    assert shown[np.ix_(inside, inside)].all()
    outside = ~(inside | edge)
    assert not shown[outside].any() and not shown[:, outside].any()
    assert not shown[0].any()
    none = surface_in_view(jnp.zeros((96, 96), bool), window, points, jnp.asarray(depth > 0), 4)
    assert not np.asarray(none).any()


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_a_turned_views_target_surface_stops_at_the_objects_side():
    """A 15 cm box on a table seen 44 deg off vertical: in the view turned to face the table,
    its near face becomes a slope of depths a pixel apart that a depth-connected surface
    follows down from the top; measured on the real image, the face is steep and the
    target's surface is the top alone."""
    scene = steep_table_scene()
    config, image = Config(), RealImageConfig()
    prep = _targets(scene.depth, jnp.asarray(scene.workspace), scene.camera, config, image)
    rotation = np.asarray(prep.rotation)
    top = jnp.asarray(rotation.T @ scene.to_camera(scene.top), jnp.float32)  # view frame
    window, slope, window_camera = detection_window(
        prep.fine, prep.fine_slope, prep.fine_camera, view_camera(prep.fine_camera, prep.rotation),
        prep.rotation, top, image.crop_px)
    plane = in_view(prep.support, prep.rotation)
    points = window_camera.unproject(window_camera.pixel_grid(), window)
    height = np.asarray(plane_height(points, plane.normal, plane.distance))

    def surface(max_slope_deg):
        return np.asarray(followed_surface(window, slope, window_camera, top, plane, config,
                                           max_slope_deg))

    assert height[surface(90.0)].min() < 0.12  # no slope test: down the face
    kept = surface(image.max_target_slope_deg)
    assert kept.sum() > 1000 and height[kept].min() > 0.14  # the 15 cm top


def test_the_papers_nearest_point_on_a_tilted_table_is_its_near_edge(support):
    """Why the support plane: without it, the nearest point of a tilted table (its bottom
    edge) beats a 4 cm box; with it, the box top is highest above the support."""
    depth, rotation, eye = _table([box((0.04, 0.07, 0.04), (0.02, 0.15, 0.0), 0.3)])
    depth = jnp.asarray(depth)
    plane = support(depth, WORK)
    height = plane_height(WORK.unproject(WORK.pixel_grid(), depth), plane.normal, plane.distance)
    cfg = RealImageConfig()
    args = dict(window=cfg.target_window_px, min_pixels=cfg.min_target_pixels,
                max_slope_deg=cfg.max_target_slope_deg, min_height=0.01, tolerance=0.005)
    cand, _ = target_candidates(depth, WORK, height, jnp.asarray(False), **args)
    _, nearest = best_candidate(cand, -depth)
    assert int(nearest[1]) >= 236  # the table's bottom rows (a box pixel is never that low)
    cand, _ = target_candidates(depth, WORK, height, plane.found, **args)
    _, highest = best_candidate(cand, height)
    top = WORK.project(jnp.asarray(rotation.T @ (np.array([0.02, 0.15, 0.04]) - eye)))
    assert np.linalg.norm(np.asarray(highest) - np.asarray(top)) < 14  # on the 4 x 7 cm top
    assert float(height[highest[1], highest[0]]) == pytest.approx(0.04, abs=1e-3)


@pytest.mark.parametrize("kwargs, match", [
    (dict(target_window_px=4), "target_window_px must be odd"),
    (dict(min_target_pixels=30), "min_target_pixels must be <= target_window_px"),
    (dict(min_depth=2.0, max_depth=1.0), "min_depth < max_depth"),
    (dict(crop_px=8), "RealImageConfig.crop_px"),
    (dict(max_targets=0), "RealImageConfig.max_targets"),
])
def test_scene_config_refuses_bad_values(kwargs, match):
    with pytest.raises(ConfigError, match=match) as info:
        RealImageConfig(**kwargs)
    assert "\n" not in str(info.value)


def test_known_support_is_the_table_seen_from_a_tilted_camera():
    """The calibrated table (z = 0) in the camera frame: every pixel of a rendered bare table
    lies on it (height 0), and a 4 cm box top stands 4 cm above it, whatever the tilt."""
    from graspjax.perception.support import known_support

    for tilt in (0.0, 25.0):
        rotation, eye = tilted_pose(0.6, tilt)
        plane = known_support(jnp.asarray(rotation, jnp.float32), jnp.asarray(eye, jnp.float32),
                              jnp.array([0.0, 0.0, 1.0]), 0.0)
        assert bool(plane.found)
        assert np.degrees(float(plane.tilt)) == pytest.approx(tilt, abs=1e-3)

        heights = []
        for solids in ([], [box((0.05, 0.05, 0.04))]):
            depth = jnp.asarray(analytic_depth(WORK, rotation, eye, solids))
            assert bool(jnp.all(depth > 0))
            heights.append(np.asarray(plane_height(WORK.unproject(WORK.pixel_grid(), depth),
                                                   plane.normal, plane.distance)))
        assert np.abs(heights[0]).max() < 2e-4
        assert heights[1].max() == pytest.approx(0.04, abs=2e-4)


def test_box_workspace_keeps_the_points_inside_the_box():
    """A camera 25 degrees off vertical over a bare table, an off-centre box: the pixels inside
    are those whose point, back-projected and moved to the world in float64 here, lies in it
    (pixels within 0.1 mm of a face left out of the comparison)."""
    from graspjax.perception.workspace import box_workspace

    rotation, eye = tilted_pose(0.6, 25.0)
    eye = eye + np.array([0.02, -0.03, 0.0])
    depth = analytic_depth(WORK, rotation, eye, [])
    depth[0, :5] = 0.0  # no depth: never inside
    lower, upper = np.array([-0.03, -0.10, -1.0]), np.array([0.08, 0.02, 1.0])
    inside = np.asarray(box_workspace(jnp.asarray(depth), WORK, jnp.asarray(rotation, jnp.float32),
                                      jnp.asarray(eye, jnp.float32), jnp.asarray(lower),
                                      jnp.asarray(upper)))
    v, u = np.mgrid[:WORK.height, :WORK.width]
    z = depth.astype(np.float64)
    camera_points = np.stack([(u - WORK.cx) * z / WORK.fx, (v - WORK.cy) * z / WORK.fy, z], -1)
    world = camera_points @ rotation.T + eye
    expected = (depth > 0) & np.all((world >= lower) & (world <= upper), -1)
    near_face = np.any(np.abs(world[..., :2, None] - np.stack([lower[:2], upper[:2]], -1)) < 1e-4,
                       axis=(-1, -2))
    assert 1000 < expected.sum() < expected.size // 2  # a part of the view, not all of it
    np.testing.assert_array_equal(inside[~near_face], expected[~near_face])
    assert not inside[0, :5].any()
