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


def _grow4_packed(rows: jax.Array) -> jax.Array:
    """One step of 4-neighbour dilation of packed rows `(H, words)` uint32 (bits carry across
    word boundaries; nothing enters from outside the image)."""
    zero_word, zero_row = jnp.zeros_like(rows[:, :1]), jnp.zeros_like(rows[:1])
    before = jnp.concatenate([zero_word, rows[:, :-1]], 1)  # the word to the left
    after = jnp.concatenate([rows[:, 1:], zero_word], 1)  # the word to the right
    right = (rows << 1) | (before >> (_BITS - 1))  # every pixel moved one column right
    left = (rows >> 1) | (after << (_BITS - 1))
    down = jnp.concatenate([zero_row, rows[:-1]], 0)
    up = jnp.concatenate([rows[1:], zero_row], 0)
    return rows | right | left | down | up


def surface_cluster(depth: jax.Array, valid: jax.Array, seed: jax.Array, low, high,
                    steps_per_iteration: int = 8) -> jax.Array:
    """Pixels 4-connected to `seed` whose depth lies in `[low, high]`.

    depth: metric depth (H, W); valid: (H, W) bool; seed: (u, v) int32 pixel.
    Returns the cluster mask (H, W) bool, empty if the seed is outside the
    band. A flood fill by repeated masked dilation until nothing changes, on
    rows packed 32 pixels to a word (a 192-pixel row is 6 words); the loop
    tests for change every `steps_per_iteration` dilations, each its own inner
    loop step (unrolled steps fuse into one kernel that recomputes its inputs).
    """
    allowed = valid & (depth >= low) & (depth <= high)
    start = jnp.zeros(depth.shape, bool).at[seed[1], seed[0]].set(allowed[seed[1], seed[0]])
    allowed_rows = _pack_rows(allowed)

    def grow(state):
        region, _ = state
        new = lax.fori_loop(0, steps_per_iteration,
                            lambda _, rows: _grow4_packed(rows) & allowed_rows, region)
        return new, jnp.any(new != region)

    region, _ = lax.while_loop(lambda s: s[1], grow, (_pack_rows(start), jnp.array(True)))
    return _unpack_rows(region, depth.shape[1])


def target_surface(depth: jax.Array, valid: jax.Array, seed: jax.Array, z_min,
                   tolerance: float) -> tuple[jax.Array, jax.Array]:
    """The surface cluster of the nearest object and its depth.

    A first pass takes the band `[z_min, z_min + tolerance]`; its mean depth
    z_s then centres a second pass `[z_s - tolerance, z_s + tolerance]`. On a
    noise-free face seen head-on both passes agree; with sensor noise, z_min
    is an outlier and the second pass recovers the whole face. Returns the
    mask (H, W) bool and z_s (the mean depth of the final cluster).
    """
    def mean_depth(mask):
        n = jnp.sum(mask)
        return jnp.sum(jnp.where(mask, depth, 0.0)) / jnp.maximum(n, 1)

    first = surface_cluster(depth, valid, seed, z_min, z_min + tolerance)
    z_first = mean_depth(first)
    cluster = surface_cluster(depth, valid, seed, z_first - tolerance, z_first + tolerance)
    return cluster, mean_depth(cluster)


def boundary_pixels(mask: jax.Array) -> jax.Array:
    """Cluster pixels with a 4-neighbour outside the cluster or the image `(H, W)` bool."""
    padded = jnp.pad(mask, 1)
    interior = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    return mask & ~interior
