"""Valid pixels, the nearest point z_min and the target's surface cluster (one image)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax import lax


def valid_mask(depth: jax.Array) -> jax.Array:
    """Pixels with a usable depth `(H, W)` bool: finite and > 0 (0 and nan mark invalid)."""
    return jnp.isfinite(depth) & (depth > 0)


def nearest_pixel(depth: jax.Array, valid: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The z_min point: its pixel `(2,)` int32 as (u, v) and its depth (inf if none is valid).

    Ties go to the first pixel in row-major order.
    """
    masked = jnp.where(valid, depth, jnp.inf)
    flat = jnp.argmin(masked)
    v, u = jnp.divmod(flat, depth.shape[1])
    return jnp.stack([u, v]).astype(jnp.int32), masked.reshape(-1)[flat]


_BITS = 32  # pixels per word of a packed row
_FLOOD_STEPS = 8  # a flood fill's steps between its tests for a change


def _pack_rows(mask: jax.Array) -> jax.Array:
    """A bool image `(H, W)` as rows of bits `(H, ceil(W / 32))` uint32: column 32 j + b is bit b
    of word j; the padding columns are 0."""
    height, width = mask.shape
    words = -(-width // _BITS)
    bits = jnp.pad(mask, ((0, 0), (0, words * _BITS - width))).reshape(height, words, _BITS)
    weights = jnp.left_shift(jnp.uint32(1), jnp.arange(_BITS, dtype=jnp.uint32))
    return jnp.sum(bits.astype(jnp.uint32) * weights, -1, dtype=jnp.uint32)


def _unpack_rows(packed: jax.Array, width: int) -> jax.Array:
    """Inverse of `_pack_rows`: `(H, words)` uint32 -> `(H, width)` bool."""
    bits = (packed[..., None] >> jnp.arange(_BITS, dtype=jnp.uint32)) & jnp.uint32(1)
    return bits.reshape(packed.shape[0], -1)[:, :width].astype(bool)


def _shifts(rows: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array]:
    """Packed rows `(H, words)` uint32 moved one pixel right, left, down and up (bits carry
    across word boundaries; nothing enters from outside the image)."""
    zero_word, zero_row = jnp.zeros_like(rows[:, :1]), jnp.zeros_like(rows[:1])
    before = jnp.concatenate([zero_word, rows[:, :-1]], 1)  # the word to the left
    after = jnp.concatenate([rows[:, 1:], zero_word], 1)  # the word to the right
    right = (rows << 1) | (before >> (_BITS - 1))
    left = (rows >> 1) | (after << (_BITS - 1))
    down = jnp.concatenate([zero_row, rows[:-1]], 0)
    up = jnp.concatenate([rows[1:], zero_row], 0)
    return right, left, down, up


def _grow4_packed(rows: jax.Array) -> jax.Array:
    """One step of 4-neighbour dilation of packed rows `(H, words)` uint32."""
    right, left, down, up = _shifts(rows)
    return rows | right | left | down | up


def _reverse_bits(words: jax.Array) -> jax.Array:
    """Each uint32 word's 32 bits in reverse order."""
    for shift, mask in ((1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF)):
        words = ((words >> shift) & jnp.uint32(mask)) | ((words & jnp.uint32(mask)) << shift)
    return (words >> 16) | (words << 16)


def _along_runs(rows: jax.Array, east: jax.Array, west: jax.Array) -> jax.Array:
    """Packed rows spread along their runs inside each word: to higher bits through `east`
    (bit b set: pixel b joins pixel b + 1) and to lower bits through `west` (pixel b joins
    b - 1). A binary addition carries a set bit through a run of ones in one step: east +
    (rows & east) clears each run of `east` from its lowest region pixel up and sets the bit
    past it, so its XOR with `east` is the run's pixels from there on; the other way is the
    same on bit-reversed words. Words still meet through the shifts of `_grow4_packed`."""
    up = (east + (rows & east)) ^ east
    back_rows, back_west = _reverse_bits(rows), _reverse_bits(west)
    down = _reverse_bits((back_west + (back_rows & back_west)) ^ back_west)
    return rows | up | down


def _flood(start: jax.Array, allowed_rows: jax.Array, grow, east: jax.Array, west: jax.Array,
           width: int, unroll: bool) -> jax.Array:
    """The region `(H, W)` bool reached from the packed `start` by repeated `grow` steps inside
    the packed `allowed_rows`, each followed by a spread along the runs of `east` and `west`
    inside each word (`_along_runs`: up to 32 pixels along a row in one step, so that a step
    is bound by rows and words, not pixels), until nothing changes (tested every
    `_FLOOD_STEPS` steps, each its own inner loop step, or with `unroll` all in one loop
    step: fewer launches on a GPU, more code to compile)."""
    def one_step(rows):
        return _along_runs(grow(rows) & allowed_rows, east, west)

    def step(state):
        region, _ = state
        new = lax.fori_loop(0, _FLOOD_STEPS, lambda _, rows: one_step(rows), region, unroll=unroll)
        return new, jnp.any(new != region)

    region, _ = lax.while_loop(lambda s: s[1], step, (start, jnp.array(True)))
    return _unpack_rows(region, width)


def _seed_rows(allowed: jax.Array, seed: jax.Array) -> jax.Array:
    """The packed seed pixel `(u, v)` if it is allowed, else nothing."""
    start = jnp.zeros(allowed.shape, bool).at[seed[1], seed[0]].set(allowed[seed[1], seed[0]])
    return _pack_rows(start)


def surface_cluster(depth: jax.Array, valid: jax.Array, seed: jax.Array, low, high,
                    unroll: bool = False) -> jax.Array:
    """Pixels 4-connected to `seed` whose depth lies in `[low, high]`.

    depth: metric depth (H, W); valid: (H, W) bool; seed: (u, v) int32 pixel.
    Returns the cluster mask (H, W) bool, empty if the seed is outside the
    band. A flood fill by repeated masked dilation on rows packed 32 pixels
    to a word (a 192-pixel row is 6 words).
    """
    allowed = valid & (depth >= low) & (depth <= high)
    rows = _pack_rows(allowed)
    return _flood(_seed_rows(allowed, seed), rows, _grow4_packed, rows & (rows >> 1),
                  rows & (rows << 1), depth.shape[1], unroll)


def connected_surface(depth: jax.Array, allowed: jax.Array, seed: jax.Array, max_step,
                      unroll: bool = False) -> jax.Array:
    """The depth-connected surface around `seed`: allowed pixels reached from it through
    4-neighbours whose depths differ by at most `max_step` (m).

    depth: metric depth (H, W); allowed: (H, W) bool; seed: (u, v) int32 pixel.
    Returns the mask (H, W) bool, empty if the seed is not allowed. Unlike a
    depth band, a surface may span any depth range as long as it has no jump:
    one object's visible faces, cut off where a depth step separates it from
    what lies behind or in front (objects that touch at equal height stay one
    surface: depth alone cannot part them).
    """
    z = jnp.where(allowed, depth, 0.0)
    east = allowed[:, :-1] & allowed[:, 1:] & (jnp.abs(z[:, 1:] - z[:, :-1]) <= max_step)
    south = allowed[:-1] & allowed[1:] & (jnp.abs(z[1:] - z[:-1]) <= max_step)
    no_col, no_row = jnp.zeros_like(allowed[:, :1]), jnp.zeros_like(allowed[:1])
    # Each direction's links at the pixel a step leaves from: to the east, west, south, north.
    links = [_pack_rows(m) for m in (jnp.concatenate([east, no_col], 1),
                                     jnp.concatenate([no_col, east], 1),
                                     jnp.concatenate([south, no_row], 0),
                                     jnp.concatenate([no_row, south], 0))]

    def grow(rows):
        right, _, _, _ = _shifts(rows & links[0])
        _, left, _, _ = _shifts(rows & links[1])
        _, _, down, _ = _shifts(rows & links[2])
        _, _, _, up = _shifts(rows & links[3])
        return rows | right | left | down | up

    return _flood(_seed_rows(allowed, seed), _pack_rows(allowed), grow, links[0], links[1],
                  depth.shape[1], unroll)


def mean_depth(depth: jax.Array, mask: jax.Array) -> jax.Array:
    """Mean of `depth` (H, W) over `mask` (H, W) bool (0 where it is empty)."""
    return jnp.sum(jnp.where(mask, depth, 0.0)) / jnp.maximum(jnp.sum(mask), 1)


def target_surface(depth: jax.Array, valid: jax.Array, seed: jax.Array, z_min,
                   tolerance: float, max_step: float = 0.0,
                   unroll: bool = False) -> tuple[jax.Array, jax.Array]:
    """The surface cluster of the nearest object and its depth.

    A first pass takes the band `[z_min, z_min + tolerance]`; its mean depth
    z_s then centres a second pass `[z_s - tolerance, z_s + tolerance]`. On a
    noise-free face seen head-on both passes agree; with sensor noise, z_min
    is an outlier and the second pass recovers the whole face. With
    `max_step` > 0 (static; ours, 0 = the paper) the band is also parted
    where 4-neighbours' depths jump by more than `max_step` (m): a touching
    neighbour whose top lies within the band, a step away, stays out. `unroll`:
    the fills' steps in one loop iteration (`detect.unrolled_loops`).
    Returns the mask (H, W) bool and z_s (the mean depth of the final cluster).
    """
    def band(low, high):
        if max_step > 0:
            return connected_surface(depth, valid & (depth >= low) & (depth <= high), seed,
                                     max_step, unroll)
        return surface_cluster(depth, valid, seed, low, high, unroll)

    first = band(z_min, z_min + tolerance)
    z_first = mean_depth(depth, first)
    cluster = band(z_first - tolerance, z_first + tolerance)
    return cluster, mean_depth(depth, cluster)


def boundary_pixels(mask: jax.Array) -> jax.Array:
    """Cluster pixels with a 4-neighbour outside the cluster or the image `(H, W)` bool."""
    padded = jnp.pad(mask, 1)
    interior = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    return mask & ~interior
