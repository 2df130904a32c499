"""The workspace, and from a full-resolution real depth image to the working views (one image).

The workspace is where targets may be chosen: a calibrated box in the
world (`box_workspace`: the simulation's bin), or a user's region of
interest or mask on a real image.

Everything outside the workspace (an ROI or mask) and outside the depth
range `[min_depth, max_depth]` becomes invalid before anything else looks
at the image; holes up to `fill_gap_px` detection pixels wide inside a
surface are bridged, so that a dropout line does not cut a face in two or
notch its contour; the image is reduced by block median (as the paper
downsamples its Kinect) twice: to the detection resolution, and to a
coarser one for the support plane and the choice of targets.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from graspjax.camera import Camera
from graspjax.config import RealImageConfig
from graspjax.perception.cluster import valid_mask


def block_factors(width: int, config: RealImageConfig) -> tuple[int, int]:
    """Static block factors (detection, support) for images `width` pixels wide.

    Detection: `downsample` if set, else the whole factor nearest to
    `width / detect_width`; support plane and targets: the whole factor
    nearest to `width / working_width`, never finer than the detection's.
    """
    fine = config.downsample or max(1, round(width / config.detect_width))
    return fine, max(fine, round(width / config.working_width))


@functools.cache
def _sorting_network(n: int) -> tuple[tuple[int, int], ...]:
    """Compare-exchange pairs of Batcher's odd-even merge sort for `n` (a power of two) values."""
    pairs, p = [], 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return tuple(pairs)


def block_median(depth: jax.Array, factor: int) -> jax.Array:
    """Median of the valid pixels in each `factor x factor` block `(H // f, W // f)`, 0 if none.

    depth: metric depth (H, W), 0 or nan = invalid; cropped to a multiple of
    `factor`. An even count averages the two middle values (as `numpy.nanmedian`).
    The blocks are sorted by a sorting network: elementwise min/max over
    whole images, far faster than a sort per block on a CPU.
    """
    if factor == 1:
        return jnp.where(valid_mask(depth), depth, 0.0)
    h, w = depth.shape[0] // factor, depth.shape[1] // factor
    values = [depth[i: h * factor: factor, j: w * factor: factor]
              for i in range(factor) for j in range(factor)]
    count = sum(valid_mask(v).astype(jnp.int32) for v in values)
    size = 1 << (len(values) - 1).bit_length()
    values = [jnp.where(valid_mask(v), v, jnp.inf) for v in values]  # invalid sort last
    values += [jnp.full((h, w), jnp.inf, depth.dtype)] * (size - len(values))
    for a, b in _sorting_network(size):
        values[a], values[b] = jnp.minimum(values[a], values[b]), jnp.maximum(values[a], values[b])
    low_rank, high_rank = jnp.maximum(count - 1, 0) // 2, count // 2
    low = sum(jnp.where(low_rank == k, v, 0.0) for k, v in enumerate(values[: factor * factor]))
    high = sum(jnp.where(high_rank == k, v, 0.0) for k, v in enumerate(values[: factor * factor]))
    return jnp.where(count > 0, 0.5 * (low + high), 0.0)


def _order_keys(values: jax.Array) -> jax.Array:
    """uint32 keys in the order of the float32 `values` (-0 just below +0)."""
    bits = jax.lax.bitcast_convert_type(values.astype(jnp.float32), jnp.uint32)
    return jnp.where(bits >> 31 == 1, ~bits, bits | jnp.uint32(1 << 31))


def _from_order_keys(keys: jax.Array) -> jax.Array:
    """The float32 values whose `_order_keys` are `keys`."""
    bits = jnp.where(keys >> 31 == 1, keys & jnp.uint32(0x7FFFFFFF), ~keys)
    return jax.lax.bitcast_convert_type(bits, jnp.float32)


def nan_median(values: jax.Array) -> jax.Array:
    """The median `()` of the non-nan `values` (any shape, as float32), nan if there are none:
    the same number as `jnp.nanmedian`, found without sorting. Each of the two middle ranks is
    selected by 32 counting passes, one per bit of an order-preserving uint32 key, from the
    top: the largest key with at most `rank` keys below it is the key of that rank. On the
    2-core CPU a sort of a 640 x 480 image's detection view (about 19,000 depths) took 3.4 ms,
    the passes 0.35 ms, and `graspjax detect` 1.5 ms less per image (results/benchmarks)."""
    values = jnp.ravel(values).astype(jnp.float32)
    present = ~jnp.isnan(values)
    keys = jnp.where(present, _order_keys(values), jnp.uint32(0xFFFFFFFF))
    count = jnp.sum(present).astype(jnp.float32)
    q = 0.5 * (count - 1.0)  # jnp.nanmedian's linear interpolation, term by term
    low, high = jnp.floor(q), jnp.ceil(q)
    high_weight = q - low
    ranks = jnp.clip(jnp.stack([low, high]), 0, jnp.maximum(count - 1, 0)).astype(jnp.int32)

    def bit(b, found):
        trial = found | (jnp.uint32(1) << (31 - b).astype(jnp.uint32))
        below = jnp.sum(keys[None, :] < trial[:, None], axis=1)
        return jnp.where(below <= ranks, trial, found)

    found = jax.lax.fori_loop(0, 32, bit, jnp.zeros(2, jnp.uint32))
    low_value, high_value = _from_order_keys(found)
    median = low_value * (1.0 - high_weight) + high_value * high_weight
    return jnp.where(count > 0, median, jnp.nan)


def _shifted(padded: jax.Array, gap: int, du: int, dv: int, shape) -> jax.Array:
    """The image padded by `gap` on every side, read `(du, dv)` pixels away `(H, W)`."""
    v0, u0 = gap + dv, gap + du
    return padded[v0: v0 + shape[0], u0: u0 + shape[1]]


def fill_holes(depth: jax.Array, workspace: jax.Array, gap: int, tolerance: float) -> jax.Array:
    """Bridge holes inside surfaces: depth `(H, W)` with invalid workspace pixels filled.

    An invalid pixel in `workspace` (H, W) bool is filled with the mean of the
    nearest valid pixels on both sides, left-right (else up-down), when both
    lie within `gap` pixels and within `tolerance` metres of each other: a
    hole up to `gap` pixels wide along a row or a column is filled. A hole
    between an object and the table (a depth step) stays a hole.
    """
    valid = valid_mask(depth)
    if gap == 0:
        return jnp.where(valid, depth, 0.0)
    padded_z, padded_ok = jnp.pad(jnp.where(valid, depth, 0.0), gap), jnp.pad(valid, gap)
    clean = _shifted(padded_z, gap, 0, 0, depth.shape)
    valid = _shifted(padded_ok, gap, 0, 0, depth.shape)

    def nearest(du, dv):  # depth of the nearest valid pixel within `gap` steps, and whether any
        value, found = jnp.zeros_like(clean), jnp.zeros_like(valid)
        for step in range(gap, 0, -1):  # nearest last, so it wins
            z = _shifted(padded_z, gap, step * du, step * dv, depth.shape)
            ok = _shifted(padded_ok, gap, step * du, step * dv, depth.shape)
            value, found = jnp.where(ok, z, value), found | ok
        return value, found

    filled = clean
    for (du, dv) in ((0, 1), (1, 0)):  # up-down first, so left-right wins where both agree
        (a, has_a), (b, has_b) = nearest(du, dv), nearest(-du, -dv)
        bridge = ~valid & workspace & has_a & has_b & (jnp.abs(a - b) <= tolerance)
        filled = jnp.where(bridge, 0.5 * (a + b), filled)
    return filled


def box_workspace(depth: jax.Array, camera: Camera, rotation: jax.Array, position: jax.Array,
                  lower: jax.Array, upper: jax.Array) -> jax.Array:
    """Pixels `(H, W)` bool whose 3-D point lies inside a calibrated box, e.g. a bin's interior.

    depth: metric depth (H, W), 0 or nan = invalid (never inside);
    rotation: (3, 3) camera-to-world; position: (3,) camera centre; lower,
    upper: (3,) the box's corners in the world (m; +-inf leaves an axis open).
    """
    valid = valid_mask(depth)
    points = camera.unproject(camera.pixel_grid(), jnp.where(valid, depth, 0.0))
    world = jnp.stack([points[..., 0] * rotation[row, 0] + points[..., 1] * rotation[row, 1]
                       + points[..., 2] * rotation[row, 2] for row in range(3)], -1) + position
    return valid & jnp.all((world >= lower) & (world <= upper), -1)


def _blocks(image: jax.Array, camera: Camera, factor: int) -> tuple[jax.Array, Camera]:
    """Block median `(H // f, W // f)` and its camera; each block spans `factor` pixels."""
    small = block_median(image, factor)
    h, w = small.shape
    cropped = Camera(w * factor, h * factor, camera.fx, camera.fy, camera.cx, camera.cy)
    return small, cropped.scaled(w, h)  # cropping to whole blocks keeps the optics


def working_views(depth: jax.Array, workspace: jax.Array, camera: Camera, config: RealImageConfig,
                  tolerance: float) -> tuple[jax.Array, Camera, jax.Array, Camera]:
    """The detection depth and camera, then the coarser support depth and camera.

    depth: metric depth (H, W) float32 at full resolution, 0 or nan = invalid;
    workspace: (H, W) bool, True where the search may look; camera:
    intrinsics of the full image. `tolerance`: the depth band of a surface
    (m), for hole filling. Factors from `block_factors`.
    """
    fine, coarse = block_factors(depth.shape[1], config)
    inside = workspace & valid_mask(depth) & (depth >= config.min_depth) & (depth <= config.max_depth)
    # Bridging at full resolution first is the same as in detection pixels (a block is valid
    # when any of its pixels is) and far cheaper for the compiler than after the median.
    filled = fill_holes(jnp.where(inside, depth, 0.0), workspace, config.fill_gap_px * fine,
                        tolerance)
    return (*_blocks(filled, camera, fine), *_blocks(filled, camera, coarse))
