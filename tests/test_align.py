"""End-tool alignment against known plane normals and a direct NumPy reading of Eq. 3."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import assert_trees_close, world_to_camera

from graspjax import AlignConfig, AlignReason, align_tool
from graspjax.perception.align import plane_inliers
from graspjax.synthetic import Solid, box, half_space, rot_x, rot_y, rot_z

METRIC = AlignConfig(turn_normal="metric")  # ours: the normal in metres, checked against truth


def _camera_normal(normal_world):
    return world_to_camera(normal_world) - world_to_camera([0, 0, 0])


def _band_centre(depth, band):
    """Reference for anchor='centre': the pixel nearest the centroid of the pixels 4-connected
    to z_min within `band` of its depth (a breadth-first fill)."""
    valid = np.isfinite(depth) & (depth > 0)
    masked = np.where(valid, depth, np.inf)
    seed = np.unravel_index(np.argmin(masked), depth.shape)
    inside = valid & (masked <= masked[seed] + band)
    region, frontier = {seed}, [seed]
    while frontier:
        v, u = frontier.pop()
        for nv, nu in ((v + 1, u), (v - 1, u), (v, u + 1), (v, u - 1)):
            if (0 <= nv < depth.shape[0] and 0 <= nu < depth.shape[1] and inside[nv, nu]
                    and (nv, nu) not in region):
                region.add((nv, nu))
                frontier.append((nv, nu))
    v, u = np.array(sorted(region)).T
    nearest = np.argmin((u - u.mean()) ** 2 + (v - v.mean()) ** 2)
    return u[nearest], v[nearest]


def eq3_reference(depth, camera, config: AlignConfig):
    """Eq. 2 and 3 over the whole image, pixel by pixel, straight from the paper (the window
    around each triangle's centroid, or around A with `window_centre="anchor"`).

    Returns the inlier count of each of the 8 (N) triangles around A (z_min, or the centre of
    its surface band).
    """
    valid = np.isfinite(depth) & (depth > 0)
    masked = np.where(valid, depth, np.inf)
    v_a, u_a = np.unravel_index(np.argmin(masked), depth.shape)
    if config.anchor == "centre":
        u_a, v_a = _band_centre(depth, config.anchor_band)
    z_a = depth[v_a, u_a]
    tan_half = np.tan(camera.fov_x / 2)
    d_p = 2 * z_a * tan_half / camera.width  # a pixel's footprint at A
    if config.pixel_scale == "printed":
        d_p /= 2  # Eq. 2 as printed
    counts = []
    n = config.num_triangles
    for k in range(n):
        corners = [(u_a, v_a)]
        for phi in (2 * np.pi * k / n, 2 * np.pi * (k + 1) / n):
            corners.append((int(np.round(u_a + config.triangle_radius_px * np.cos(phi))),
                            int(np.round(v_a + config.triangle_radius_px * np.sin(phi)))))
        if not all(0 <= u < camera.width and 0 <= v < camera.height and valid[v, u]
                   for u, v in corners):
            counts.append(0)
            continue
        p = np.array([[u, v, depth[v, u] / d_p] for u, v in corners], float)
        normal = np.cross(p[1] - p[0], p[2] - p[0])
        normal /= np.linalg.norm(normal)
        centre = p[0] if config.window_centre == "anchor" else p.mean(axis=0)
        count = 0
        for v in range(camera.height):
            for u in range(camera.width):
                if not valid[v, u]:
                    continue
                q = np.array([u, v, depth[v, u] / d_p])
                d = abs(normal @ (q - p[0]))
                if d < config.distance_threshold and np.all(np.abs(q - centre)
                                                            < config.window_px):
                    count += 1
        counts.append(count)
    return np.array(counts)


@pytest.mark.parametrize("tilt_deg, azimuth_deg", [(0, 0), (10, 0), (30, 45), (50, 200),
                                                   (25, -120)])
def test_tilted_plane_normal_is_recovered(camera, align, render, tilt_deg, azimuth_deg):
    normal_world = rot_z(np.deg2rad(azimuth_deg)) @ rot_y(np.deg2rad(tilt_deg)) @ [0, 0, 1.0]
    a = align(jnp.asarray(render([half_space(normal_world, [0, 0, 0.1])], ground=None)), camera,
              METRIC)
    assert bool(a.found), AlignReason(int(a.reason))
    expected = _camera_normal(normal_world)  # toward the camera: negative z in camera frame
    np.testing.assert_allclose(np.asarray(a.normal), expected, atol=2e-3)
    assert float(a.normal[2]) < 0
    assert int(a.inliers) >= AlignConfig().min_inliers


@pytest.mark.parametrize("scale", ["footprint", "printed"])
@pytest.mark.parametrize("tilt_deg, azimuth_deg", [(10, 0), (30, 45), (50, 200)])
def test_the_paper_unit_normal_is_the_triangles_normal_in_pixel_units(camera, render, tilt_deg,
                                                                    azimuth_deg, scale):
    """turn_normal="pixel": the tool turns to the winning triangle's normal in (u, v, z / d_p),
    computed here with NumPy from the depth at its corners. With d_p a pixel's footprint it is
    the plane's normal seen through the pixel grid at A: (n_x, n_y, n_z + (x n_x + y n_y) / z)
    for A at (x, y, z) (the grid shears depth along A's ray), by hand; with Eq. 2 as printed
    (half the footprint) it is steeper than the plane."""
    normal_world = rot_z(np.deg2rad(azimuth_deg)) @ rot_y(np.deg2rad(tilt_deg)) @ [0, 0, 1.0]
    depth = render([half_space(normal_world, [0, 0, 0.1])], ground=None)
    cfg = AlignConfig(turn_normal="pixel", pixel_scale=scale)
    a = jax.jit(align_tool)(jnp.asarray(depth), camera, cfg)
    assert bool(a.found), AlignReason(int(a.reason))
    (u_a, v_a), (u_b, v_b), (u_c, v_c) = np.asarray(a.corners)[int(a.best)]
    footprint = 2 * depth[v_a, u_a] * np.tan(camera.fov_x / 2) / camera.width  # at A
    d_p = footprint if scale == "footprint" else footprint / 2
    p = np.array([[u, v, depth[v, u] / d_p] for u, v in ((u_a, v_a), (u_b, v_b), (u_c, v_c))])
    expected = np.cross(p[1] - p[0], p[2] - p[0])
    expected *= -np.sign(expected[2]) / np.linalg.norm(expected)  # toward the camera
    np.testing.assert_allclose(np.asarray(a.normal), expected, atol=1e-4)
    metric = _camera_normal(normal_world)
    tilt = np.degrees(np.arccos(-expected[2]))
    if scale == "printed":
        assert tilt > np.degrees(np.arccos(-metric[2])) + 1.0
    else:
        z = depth[v_a, u_a]
        x, y = (u_a - camera.cx) * z / camera.fx, (v_a - camera.cy) * z / camera.fy
        seen = metric + np.array([0.0, 0.0, (x * metric[0] + y * metric[1]) / z])
        seen /= np.linalg.norm(seen)
        assert np.degrees(np.arccos(np.clip(seen @ expected, -1, 1))) < 1.0


def test_the_paper_presets_d_p_is_one_pixels_footprint(camera):
    """Eq. 2 by its stated aim: at 0.5 m a Kinect pixel at 160 px across (57 deg) is
    2 * 0.5 * tan(28.5 deg) / 160 = 3.3935 mm (by hand); the printed formula gives half."""
    from graspjax.config import preset
    from graspjax.perception.align import _pixel_scale

    for name in ("paper", "realistic"):
        cfg = preset(name).align
        assert cfg.pixel_scale == "footprint"
        assert float(1 / _pixel_scale(camera, 0.5, cfg)) == pytest.approx(3.3935e-3, rel=1e-4)
    printed = AlignConfig(pixel_scale="printed")
    assert float(1 / _pixel_scale(camera, 0.5, printed)) == pytest.approx(1.69675e-3, rel=1e-4)


@pytest.mark.parametrize("scale, anchor, window", [("printed", "centre", "triangle"),
                                                   ("footprint", "centre", "triangle"),
                                                   ("footprint", "nearest", "triangle"),
                                                   ("footprint", "centre", "anchor")])
def test_inlier_counts_match_the_paper_formula(camera, render, scale, anchor, window):
    """Patch-based scoring equals Eq. 3 evaluated pixel by pixel over the image, the window
    around each triangle's centroid (ours) or around A (the paper's words)."""
    cfg = AlignConfig(pixel_scale=scale, anchor=anchor, window_centre=window)
    scene = [box((0.05, 0.07, 0.04), (0.01, 0.0, 0.0), 0.4).moved(rot_x(0.3), (0, 0, 0.02)),
             box((0.04, 0.04, 0.06), (-0.05, 0.02, 0.0), 1.0)]
    depth = render(scene)
    a = jax.jit(align_tool)(jnp.asarray(depth), camera, cfg)
    np.testing.assert_array_equal(np.asarray(a.counts), eq3_reference(depth, camera, cfg))
    assert int(a.inliers) == int(np.max(a.counts))
    mask = plane_inliers(jnp.asarray(depth), camera, a, cfg)
    assert int(mask.sum()) == int(a.inliers)


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_the_printed_scale_is_stricter_than_the_footprint_on_a_tilted_plane(camera, render):
    """Eq. 2 as printed halves d_p, doubling z in pixel units: fewer points fit the window."""
    depth = jnp.asarray(render([half_space(rot_y(0.6) @ [0, 0, 1.0], [0, 0, 0.1])], ground=None))
    paper = align_tool(depth, camera, AlignConfig(pixel_scale="printed", turn_normal="metric"))
    true = align_tool(depth, camera, AlignConfig(pixel_scale="footprint", turn_normal="metric"))
    assert int(true.inliers) > int(paper.inliers)
    np.testing.assert_allclose(np.asarray(paper.normal), np.asarray(true.normal), atol=1e-5)


def test_point_is_the_centroid_of_the_inliers(camera, render):
    depth = render([box((0.06, 0.06, 0.05), (0, 0, 0), 0.2)])
    a = align_tool(jnp.asarray(depth), camera)
    mask = np.asarray(plane_inliers(jnp.asarray(depth), camera, a))
    v, u = np.nonzero(mask)
    z = depth[v, u]
    pts = np.column_stack([(u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z])
    np.testing.assert_allclose(np.asarray(a.point), pts.mean(axis=0), atol=1e-5)
    np.testing.assert_allclose(np.asarray(a.normal), [0, 0, -1], atol=1e-5)  # the box top


def test_ranking_orders_hypotheses_by_inliers(camera, render):
    depth = render([box((0.05, 0.07, 0.04), (0.0, 0.0, 0.0), 0.4).moved(rot_x(0.5), (0, 0, 0.03))])
    a = align_tool(jnp.asarray(depth), camera)
    counts = np.asarray(a.counts)[np.asarray(a.ranking)]
    assert (np.diff(counts) <= 0).all()
    assert int(a.best) == int(a.ranking[0])


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_random_hypotheses_need_a_key_and_are_reproducible(camera, render):
    depth = jnp.asarray(render([half_space(rot_y(0.4) @ [0, 0, 1.0], [0, 0, 0.1])], ground=None))
    cfg = AlignConfig(hypotheses="random", num_random=32, turn_normal="metric")
    with pytest.raises(ValueError, match="PRNG key"):
        align_tool(depth, camera, cfg)
    key = jax.random.key(7)
    a = align_tool(depth, camera, cfg, key)
    assert_trees_close(a, align_tool(depth, camera, cfg, key))
    assert a.corners.shape == (32, 3, 2)
    np.testing.assert_allclose(np.asarray(a.normal), _camera_normal(rot_y(0.4) @ [0, 0, 1.0]),
                               atol=5e-3)


def test_refit_reduces_noise_in_the_normal(camera, render):
    """On a noisy plane the triangle normal wobbles; a least-squares refit is closer."""
    normal_world = rot_y(np.deg2rad(20)) @ [0, 0, 1.0]
    expected = _camera_normal(normal_world)
    clean = render([half_space(normal_world, [0, 0, 0.1])], ground=None)
    rng = np.random.default_rng(0)
    cfg = AlignConfig(distance_threshold=2.0, pixel_scale="footprint")
    errors = {False: [], True: []}
    for _ in range(5):
        noisy = jnp.asarray(clean + rng.normal(0, 0.0005, clean.shape).astype(np.float32))
        for refit in (False, True):
            a = align_tool(noisy, camera, AlignConfig(**{**cfg.__dict__, "refit": refit}))
            errors[refit].append(np.degrees(np.arccos(min(1.0, float(a.normal @ expected)))))
    assert np.mean(errors[True]) < np.mean(errors[False])
    assert np.mean(errors[True]) < 2.0


def test_empty_image_and_invalid_triangles(camera, align):
    a = align(jnp.zeros((120, 160)), camera)
    assert AlignReason(int(a.reason)) == AlignReason.NO_DEPTH and not bool(a.found)
    speck = np.zeros((120, 160), np.float32)
    speck[60, 80] = 0.4  # a lone pixel: every triangle corner is invalid
    a = align(jnp.asarray(speck), camera)
    assert AlignReason(int(a.reason)) == AlignReason.NO_PLANE
    assert np.isnan(np.asarray(a.normal)).all() and int(a.best) == -1


def test_vmap_equals_a_loop(camera, align, render):
    scenes = [render([half_space(rot_y(t) @ [0, 0, 1.0], [0, 0, 0.1])], ground=None)
              for t in (0.1, 0.5)]
    scenes.append(render([box((0.05, 0.05, 0.05))]))
    batched = jax.jit(jax.vmap(align_tool, in_axes=(0, None)))(jnp.asarray(np.stack(scenes)),
                                                               camera)
    for i, depth in enumerate(scenes):
        assert_trees_close(jax.tree.map(lambda x, i=i: x[i], batched),
                           align(jnp.asarray(depth), camera))
    assert_trees_close(align_tool(jnp.asarray(scenes[0]), camera),
                       align(jnp.asarray(scenes[0]), camera))


def test_min_turn_skips_the_plane_the_camera_already_faces(camera, render):
    """A box seen from above, A on its top's corner: the top faces the camera and wins; with
    min_turn_deg the winner is the best plane that turns the view at least that far, and an
    image of one flat face has none (NO_NEW_VIEW)."""
    depth = jnp.asarray(render([box((0.06, 0.06, 0.05), (0, 0, 0), 0.2)]))
    literal = align_tool(depth, camera, AlignConfig(anchor="nearest"))
    np.testing.assert_allclose(np.asarray(literal.normal), [0, 0, -1], atol=1e-5)
    turned = align_tool(depth, camera, AlignConfig(anchor="nearest", min_turn_deg=10.0))
    assert bool(turned.found)
    assert float(-turned.normal[2]) <= np.cos(np.deg2rad(10.0))  # at least 10 degrees away
    counts, normals = np.asarray(turned.counts), np.asarray(turned.normals)
    turning = np.asarray(turned.valid) & (-normals[:, 2] <= np.cos(np.deg2rad(10.0)))
    assert int(turned.inliers) == counts[turning].max()  # the strongest plane that turns
    flat = jnp.asarray(render([half_space([0, 0, 1.0], [0, 0, 0.1])], ground=None))
    none = align_tool(flat, camera, AlignConfig(min_turn_deg=10.0))
    assert AlignReason(int(none.reason)) == AlignReason.NO_NEW_VIEW and not bool(none.found)



def test_centre_anchor_on_a_flat_top_puts_every_triangle_on_the_top(camera, render):
    """A box seen from above: A is the middle of its top, and all eight planes are the top."""
    depth = render([box((0.06, 0.05, 0.05), (0.01, -0.02, 0.0), 0.3)])
    found = align_tool(jnp.asarray(depth), camera, AlignConfig(anchor="centre"))
    assert tuple(np.asarray(found.anchor)) == _band_centre(depth, 0.005)
    assert np.all(np.asarray(found.valid))
    np.testing.assert_allclose(np.asarray(found.normals), np.tile([0, 0, -1.0], (8, 1)), atol=1e-4)


def test_centre_anchor_on_a_ridge_finds_a_slope(camera, render):
    """A triangular prism lying on a side (60 degree slopes, ridge along y): A is the middle of
    the ridge and the winning plane is one slope, its normal within 2 degrees of the true one.
    z_min alone sits at the ridge's end, where some triangles hang over the table."""
    side = 0.055
    height = side * np.sqrt(3) / 2
    slopes = [np.array([s * np.sin(np.pi / 3), 0.0, np.cos(np.pi / 3)]) for s in (1, -1)]
    normals = np.array(slopes + [[0, 1.0, 0], [0, -1.0, 0], [0, 0, -1.0]])
    ridge = Solid(normals, np.array([height / 2, height / 2, 0.04, 0.04, 0.0]))
    depth = render([ridge])
    ours = AlignConfig(anchor="centre", turn_normal="metric")
    centre = align_tool(jnp.asarray(depth), camera, ours)
    assert tuple(np.asarray(centre.anchor)) == _band_centre(depth, 0.005)
    true = [_camera_normal(n) for n in slopes]
    error = min(np.degrees(np.arccos(np.clip(np.asarray(centre.normal) @ t, -1, 1))) for t in true)
    assert bool(centre.found) and error < 2.0
    nearest = align_tool(jnp.asarray(depth), camera, AlignConfig(anchor="nearest"))
    assert abs(int(nearest.anchor[1]) - int(centre.anchor[1])) > 5  # z_min: an end of the ridge
