"""Contour tracing and straight-edge grouping against analytic shapes."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from graspjax import Camera
from graspjax.perception.contour import fit_edges, trace_contour

_trace = jax.jit(trace_contour, static_argnums=1)


SQUARE = Camera.from_fov(160, 120, 57.0)  # square pixels: metric angles equal pixel angles


def _fit(contour, camera=SQUARE, z=1.0, **kw):
    args = dict(tangent_window=3, split_angle_deg=20.0, min_edge_pixels=4, max_edges=16)
    args.update(kw)
    return jax.jit(lambda c: fit_edges(c, camera, z, **args))(contour)


def _points(contour):
    return np.asarray(contour.points)[: int(contour.length)]


def test_rectangle_is_traced_clockwise_once():
    mask = np.zeros((10, 12), bool)
    mask[2:6, 3:9] = True  # 4 rows x 6 columns
    c = _trace(jnp.asarray(mask), 64)
    pts = _points(c)
    assert bool(c.closed) and len(pts) == 2 * (6 + 4) - 4
    assert tuple(pts[0]) == (3, 2)  # first pixel in row-major order
    assert tuple(pts[1]) == (4, 2)  # then east along the top: clockwise on screen
    assert len({tuple(p) for p in pts}) == len(pts)


def test_single_pixel_and_empty_masks():
    one = np.zeros((5, 5), bool)
    one[2, 3] = True
    c = _trace(jnp.asarray(one), 16)
    assert int(c.length) == 1 and tuple(_points(c)[0]) == (3, 2)
    assert int(_trace(jnp.zeros((5, 5), bool), 16).length) == 0


def test_truncated_contour_is_flagged():
    mask = np.zeros((40, 40), bool)
    mask[5:35, 5:35] = True
    c = _trace(jnp.asarray(mask), 32)
    assert not bool(c.closed) and int(c.length) == 32


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_trace_visits_exactly_the_outer_4_boundary(seed):
    rng = np.random.default_rng(seed)
    blob = ndimage.gaussian_filter(rng.random((30, 40)), 2.5) > 0.5
    labels, n = ndimage.label(blob)
    if n == 0:
        return
    first = labels.ravel()[np.argmax(blob.ravel())]
    region = ndimage.binary_fill_holes(labels == first)
    c = _trace(jnp.asarray(region), 512)
    pts = _points(c)
    traced = np.zeros_like(region)
    traced[pts[:, 1], pts[:, 0]] = True
    boundary = region & ~ndimage.binary_erosion(np.pad(region, 1))[1:-1, 1:-1]
    assert bool(c.closed)
    np.testing.assert_array_equal(traced, boundary)
    steps = np.abs(np.diff(np.vstack([pts, pts[:1]]), axis=0)).max(axis=1)
    assert len(pts) == 1 or (steps == 1).all()  # consecutive points are 8-neighbours


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_the_steps_per_loop_iteration_change_nothing():
    """The trace and the edge walk take 1, 8 or 32 steps per loop iteration
    (`detect.unrolled_loops`: a GPU's launches): the same contour and edges, on blobs whose
    lengths are no multiple of them."""
    rng = np.random.default_rng(5)
    trace = jax.jit(trace_contour, static_argnums=(1, 2))
    lengths = []
    for _ in range(3):
        blob = ndimage.binary_fill_holes(ndimage.gaussian_filter(rng.random((30, 40)), 2.5) > 0.5)
        traces = [trace(jnp.asarray(blob), 256, steps) for steps in (1, 8, 32)]
        edges = [_fit(traces[0], steps_per_iteration=steps) for steps in (1, 8, 32)]
        for other in traces[1:]:
            for a, b in zip(jax.tree.leaves(traces[0]), jax.tree.leaves(other), strict=True):
                np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
        for other in edges[1:]:
            for a, b in zip(jax.tree.leaves(edges[0]), jax.tree.leaves(other), strict=True):
                np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
        lengths.append(int(traces[0].length))
    assert any(n % 8 for n in lengths)  # a last iteration that runs past the stop


def _polygon_mask(vertices, shape=(120, 160)):
    """Pixels whose centres lie inside a convex polygon given in pixel coordinates (u, v)."""
    v, u = np.mgrid[: shape[0], : shape[1]]
    vertices = np.asarray(vertices, float)
    sides = [(b[0] - a[0]) * (v - a[1]) - (b[1] - a[1]) * (u - a[0])
             for a, b in zip(vertices, np.roll(vertices, -1, axis=0), strict=True)]
    return np.all([s >= 0 for s in sides], 0) | np.all([s <= 0 for s in sides], 0)


@pytest.mark.parametrize("angle_deg", [0.0, 20.0, 45.0, 67.0])
def test_rotated_rectangle_gives_four_clean_edges(angle_deg):
    """Fig. 2 of the paper: the contour stays clean at 0, 20 and 45 degrees."""
    a = np.deg2rad(angle_deg)
    half = np.array([[-20, -12], [20, -12], [20, 12], [-20, 12]], float)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    corners = half @ rot.T + [80.3, 60.7]
    c = _trace(jnp.asarray(_polygon_mask(corners)), 512)
    edges = _fit(c)
    valid = np.asarray(edges.valid)
    assert valid.sum() == 4, "one straight edge per side, no jagged fragments"
    normals = np.asarray(edges.normal)[valid]
    # Outward normals are the rectangle's side normals (image coordinates: +/-rot axes).
    expected = np.vstack([rot[:, 0], -rot[:, 0], rot[:, 1], -rot[:, 1]])
    cos = normals @ expected.T
    assert (cos.max(axis=1) > np.cos(np.deg2rad(2.0))).all()
    # Edge centres lie on the true sides to within half a pixel (metric at z = 1).
    centers = np.asarray(edges.center)[valid] * SQUARE.fx  # metric at z = 1 -> pixels
    true_mid = np.vstack([rot @ [20, 0], rot @ [-20, 0], rot @ [0, 12], rot @ [0, -12]])
    true_mid += [80.3 - SQUARE.cx, 60.7 - SQUARE.cy]
    dist = np.linalg.norm(centers[:, None] - true_mid[None], axis=-1).min(axis=1)
    assert (dist < 2.0).all()


@pytest.mark.parametrize("sides", [5, 6, 8])
def test_regular_polygon_sides_are_the_longest_edges(sides):
    """Each side is one edge; digitised corners may leave short fragments, never long ones."""
    angles = 2 * np.pi * np.arange(sides) / sides + 0.3
    corners = np.column_stack([80 + 30 * np.cos(angles), 60 + 30 * np.sin(angles)])
    c = _trace(jnp.asarray(_polygon_mask(corners)), 512)
    edges = _fit(c)
    length = np.asarray(edges.length)
    order = np.argsort(-length)
    normals = np.asarray(edges.normal)[order[:sides]]
    mid = angles + np.pi / sides
    expected = np.column_stack([np.cos(mid), np.sin(mid)])
    assert ((normals @ expected.T).max(axis=1) > np.cos(np.deg2rad(3.0))).all()
    assert len({int(i) for i in (normals @ expected.T).argmax(axis=1)}) == sides
    side_length = 2 * 30 * np.sin(np.pi / sides) / SQUARE.fx
    assert (length[order[sides:]] < side_length / 3).all()


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
@pytest.mark.parametrize("shape", ["disc", "ellipse", "octagon"])
def test_edges_do_not_depend_on_the_contour_buffer_length(shape):
    """The edge walk stops at the contour's end: a longer buffer (more padding after the
    points) gives the same edges, including where the walk's last run joins its first."""
    yy, xx = np.mgrid[0:120, 0:160]
    if shape == "disc":
        mask = (xx - 80.4) ** 2 + (yy - 60.2) ** 2 <= 27.0 ** 2
    elif shape == "ellipse":
        mask = ((xx - 80.4) / 40.0) ** 2 + ((yy - 60.2) / 18.0) ** 2 <= 1.0
    else:
        angles = 2 * np.pi * np.arange(8) / 8 + 0.2
        mask = _polygon_mask(np.column_stack([80 + 35 * np.cos(angles),
                                              60 + 35 * np.sin(angles)]))
    short, long = (_trace(jnp.asarray(mask), size) for size in (400, 1600))
    assert int(short.length) == int(long.length) and bool(short.closed)
    a, b = _fit(short), _fit(long)
    for name in ("center", "direction", "normal", "length", "count", "valid"):
        np.testing.assert_array_equal(np.asarray(getattr(a, name)),
                                      np.asarray(getattr(b, name)), err_msg=name)
