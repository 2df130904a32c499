"""Surface cluster and boundary pixels against SciPy's labelling (an independent reference)."""

import jax
import jax.numpy as jnp
import numpy as np
from scipy import ndimage

from graspjax.perception.cluster import (
    boundary_pixels,
    nearest_pixel,
    surface_cluster,
    target_surface,
    valid_mask,
)

_cluster = jax.jit(surface_cluster)


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


def test_flood_fill_follows_a_serpentine_across_word_boundaries():
    # A one-pixel path that snakes through every row, crossing the 32-pixel words both ways;
    # a strip two columns away (not 4-connected to it) stays out.
    height, width = 21, 70
    path = np.zeros((height, width), bool)
    path[::2, 2:-2] = True  # full rows, joined alternately at the right and the left end
    path[1::4, -3] = True
    path[3::4, 2] = True
    strip = np.zeros_like(path)
    strip[:, 0] = True
    depth = np.where(path | strip, 0.5, 0.9).astype(np.float32)
    got = np.asarray(_cluster(jnp.asarray(depth), jnp.asarray(depth > 0), jnp.array([5, 0]),
                              0.45, 0.55))
    labels, _ = ndimage.label(path)
    assert labels[0, 5] == labels[height - 1, 5]  # one path from the first row to the last
    np.testing.assert_array_equal(got, labels == labels[0, 5])
    assert got[height - 1, 2:-2].all() and not got[:, 0].any()


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
