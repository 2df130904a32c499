"""Surface cluster and boundary pixels against SciPy's labelling (an independent reference)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import ndimage

from graspjax.perception.cluster import (
    boundary_pixels,
    connected_surface,
    nearest_pixel,
    surface_cluster,
    target_surface,
    valid_mask,
)

_cluster = jax.jit(surface_cluster, static_argnames="unroll")


def test_valid_mask_rejects_zero_nan_negative_and_inf():
    d = jnp.array([[0.5, 0.0, jnp.nan], [-1.0, jnp.inf, 0.7]])
    np.testing.assert_array_equal(np.asarray(valid_mask(d)), [[1, 0, 0], [0, 0, 1]])


def test_nearest_pixel_is_the_smallest_valid_depth():
    d = np.full((6, 8), 0.9, np.float32)
    d[4, 5] = 0.3
    d[1, 1] = 0.0  # invalid, must not win
    uv, z = nearest_pixel(jnp.asarray(d), valid_mask(jnp.asarray(d)))
    assert tuple(np.asarray(uv)) == (5, 4) and float(z) == np.float32(0.3)


def test_flood_fill_matches_connected_component_labelling():
    rng = np.random.default_rng(0)
    # Widths around the 32-pixel words the rows are packed into, and a single column.
    for height, width in [(40, 50), (40, 50), (33, 31), (20, 32), (25, 33), (30, 64), (17, 70),
                          (12, 1), (1, 40), (45, 97)]:
        for _ in range(3):
            depth = (ndimage.gaussian_filter(rng.random((height, width)), 3) * 2).astype(np.float32)
            depth[rng.random(depth.shape) < 0.02] = 0.0  # invalid pixels break connectivity
            valid = depth > 0
            seed = np.array([rng.integers(width), rng.integers(height)])
            low, high = depth[seed[1], seed[0]] - 0.05, depth[seed[1], seed[0]] + 0.05
            got = np.asarray(_cluster(jnp.asarray(depth), jnp.asarray(valid), jnp.asarray(seed),
                                      low, high))
            band = valid & (depth >= low) & (depth <= high)
            labels, _ = ndimage.label(band)  # 4-connectivity by default
            expected = labels == labels[seed[1], seed[0]] if band[seed[1], seed[0]] else 0 * band
            np.testing.assert_array_equal(got, expected)


def test_a_step_spreads_along_a_words_runs_of_links():
    """`_along_runs` against a pixel-by-pixel walk: from every region pixel along the links,
    up and down inside its 32-pixel word, as far as they go (the flood's speed rests on it; a
    flood that spread less would still end right, only later)."""
    from graspjax.perception.cluster import _along_runs

    rng = np.random.default_rng(1)
    east = rng.random((200, 32)) < 0.8  # pixel b joins b + 1 (bit 31: the next word's bit 0)
    west = np.zeros_like(east)
    west[:, 1:] = east[:, :-1]  # pixel b joins b - 1 (bit 0: the previous word's bit 31)
    west[:, 0] = rng.random(200) < 0.8
    region = rng.random((200, 32)) < 0.06
    expected = region.copy()
    for row in range(200):
        for b in np.flatnonzero(region[row]):
            up = b
            while up < 31 and east[row, up]:  # a link out of the word is the shifts' to follow
                up += 1
                expected[row, up] = True
            down = b
            while down > 0 and west[row, down]:
                down -= 1
                expected[row, down] = True

    def words(bits):
        return jnp.asarray(np.sum(bits.astype(np.uint64) << np.arange(32, dtype=np.uint64), 1)
                           .astype(np.uint32))

    got = np.asarray(_along_runs(words(region), words(east), words(west)))
    got_bits = ((got[:, None] >> np.arange(32, dtype=np.uint32)) & 1).astype(bool)
    np.testing.assert_array_equal(got_bits, expected)


@pytest.mark.parametrize("unroll", [False, True])
def test_flood_fill_follows_a_serpentine_across_word_boundaries(unroll):
    # A one-pixel path that snakes through every row, crossing the 32-pixel words both ways;
    # a strip two columns away (not 4-connected to it) stays out. Its steps unrolled into one
    # loop iteration (`detect.unrolled_loops`) or not: the same fill.
    height, width = 21, 70
    path = np.zeros((height, width), bool)
    path[::2, 2:-2] = True  # full rows, joined alternately at the right and the left end
    path[1::4, -3] = True
    path[3::4, 2] = True
    strip = np.zeros_like(path)
    strip[:, 0] = True
    depth = np.where(path | strip, 0.5, 0.9).astype(np.float32)
    got = np.asarray(_cluster(jnp.asarray(depth), jnp.asarray(depth > 0), jnp.array([5, 0]),
                              0.45, 0.55, unroll=unroll))
    labels, _ = ndimage.label(path)
    assert labels[0, 5] == labels[height - 1, 5]  # one path from the first row to the last
    np.testing.assert_array_equal(got, labels == labels[0, 5])
    assert got[height - 1, 2:-2].all() and not got[:, 0].any()


def _surface_by_search(depth, allowed, seed, step):
    """Reference: breadth-first search from `seed` (u, v) over allowed 4-neighbours whose
    depths differ by at most `step`."""
    height, width = depth.shape
    out = np.zeros_like(allowed)
    if not allowed[seed[1], seed[0]]:
        return out
    out[seed[1], seed[0]] = True
    frontier = [(seed[1], seed[0])]
    while frontier:
        v, u = frontier.pop()
        for dv, du in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            y, x = v + dv, u + du
            if (0 <= y < height and 0 <= x < width and allowed[y, x] and not out[y, x]
                    and abs(float(depth[y, x]) - float(depth[v, u])) <= step):
                out[y, x] = True
                frontier.append((y, x))
    return out


@pytest.mark.parametrize("unroll", [False, pytest.param(True, marks=pytest.mark.slow)])  # True:
# compiles programs of its own (`pytest -m "not slow"`: README)
def test_connected_surface_matches_a_breadth_first_search(unroll):
    """On random depths with steps and holes, the fill's steps unrolled into one loop
    iteration (`detect.unrolled_loops`) or not."""
    rng = np.random.default_rng(3)
    surface = jax.jit(lambda *args: connected_surface(*args, unroll=unroll))
    for height, width in [(40, 50), (33, 31), (25, 33), (17, 70), (12, 1), (1, 40)]:
        for _ in range(3):
            depth = (ndimage.gaussian_filter(rng.random((height, width)), 2) * 0.3).astype(np.float32)
            depth += np.where(rng.random(depth.shape) < 0.05, 0.05, 0.0).astype(np.float32)  # steps
            allowed = rng.random(depth.shape) > 0.03
            seed = np.array([rng.integers(width), rng.integers(height)])
            step = 0.01
            got = np.asarray(surface(jnp.asarray(depth), jnp.asarray(allowed), jnp.asarray(seed),
                                     step))
            np.testing.assert_array_equal(got, _surface_by_search(depth, allowed, seed, step))


def test_connected_surface_of_boxes_seen_from_above(camera, render):
    """From the 5 cm box's top: a 3 cm box touching it lies beyond a 2 cm step and stays out;
    a top sloped 25 degrees (a box cut by a tilted plane) is one surface, though its depth
    spans far more than a depth band."""
    from graspjax.synthetic import Solid, box

    depth = render([box((0.05, 0.05, 0.05), (-0.025, 0.0, 0.0)),
                    box((0.05, 0.05, 0.03), (0.025, 0.0, 0.0))])
    standing = depth < 0.499  # above the table
    surface = jax.jit(connected_surface)
    seed = jnp.array([camera.width // 2 - 5, camera.height // 2])
    got = np.asarray(surface(jnp.asarray(depth), jnp.asarray(standing), seed, 0.01))
    np.testing.assert_array_equal(got, standing & np.isclose(depth, 0.45, atol=1e-4))

    cube = box((0.06, 0.06, 0.08))
    up = np.array([-np.sin(np.deg2rad(25.0)), 0.0, np.cos(np.deg2rad(25.0))])
    cut = Solid(np.vstack([cube.normals, up]), np.concatenate([cube.offsets, [up @ [0, 0, 0.05]]]))
    depth = render([cut])
    top = depth < 0.47  # the sloped top: depths 0.436 to 0.464
    assert np.ptp(depth[top]) > 0.02
    got = np.asarray(surface(jnp.asarray(depth), jnp.asarray(depth < 0.499),
                             jnp.array([camera.width // 2, camera.height // 2]), 0.01))
    np.testing.assert_array_equal(got, top)


def test_boundary_is_the_complement_of_the_4_erosion():
    rng = np.random.default_rng(1)
    mask = ndimage.gaussian_filter(rng.random((30, 30)), 2) > 0.5
    expected = mask & ~ndimage.binary_erosion(np.pad(mask, 1))[1:-1, 1:-1]
    np.testing.assert_array_equal(np.asarray(boundary_pixels(jnp.asarray(mask))), expected)


def test_target_surface_recovers_a_noisy_face(camera, render):
    from graspjax.synthetic import box

    clean = render([box((0.06, 0.06, 0.05))])
    noisy = clean + np.random.default_rng(2).normal(0, 0.0015, clean.shape).astype(np.float32)
    d = jnp.asarray(noisy)
    valid = valid_mask(d)
    seed, z_min = nearest_pixel(d, valid)
    mask, z_s = jax.jit(target_surface)(d, valid, seed, z_min, 0.005)
    face = np.asarray(clean) == np.asarray(clean).min()
    # The second pass recovers essentially the whole top face, and only the face.
    assert np.asarray(mask)[face].mean() > 0.98
    assert not np.asarray(mask)[~face].any()
    assert abs(float(z_s) - 0.45) < 0.0005


def test_a_band_step_parts_a_touching_neighbour_inside_the_band(camera, render):
    """Two touching boxes whose tops differ by 3 mm lie in one 5 mm band; with `max_step`
    2 mm the band stops at the 3 mm step and keeps the seed's box alone (ours; the paper's
    band, `max_step` 0, takes both)."""
    from graspjax.synthetic import box

    depth = render([box((0.05, 0.05, 0.050), (-0.025, 0.0, 0.0)),
                    box((0.05, 0.05, 0.047), (0.025, 0.0, 0.0))])
    d = jnp.asarray(depth)
    valid = valid_mask(d)
    seed, z_min = nearest_pixel(d, valid)
    surface = jax.jit(target_surface, static_argnums=5)
    both, _ = surface(d, valid, seed, z_min, 0.005, 0.0)
    mine, z_s = surface(d, valid, seed, z_min, 0.005, 0.002)
    tops = depth < 0.49
    higher = np.isclose(depth, 0.45, atol=1e-4)
    np.testing.assert_array_equal(np.asarray(both), tops)
    np.testing.assert_array_equal(np.asarray(mine), higher)
    assert float(z_s) == pytest.approx(0.45, abs=1e-4)
