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


def _grow4(region: jax.Array) -> jax.Array:
    """One step of 4-neighbour dilation of a bool image `(H, W)`."""
    padded = jnp.pad(region, 1)
    return (region | padded[:-2, 1:-1] | padded[2:, 1:-1]
            | padded[1:-1, :-2] | padded[1:-1, 2:])


def surface_cluster(depth: jax.Array, valid: jax.Array, seed: jax.Array, low, high,
                    steps_per_iteration: int = 4) -> jax.Array:
    """Pixels 4-connected to `seed` whose depth lies in `[low, high]`.

    depth: metric depth (H, W); valid: (H, W) bool; seed: (u, v) int32 pixel.
    Returns the cluster mask (H, W) bool, empty if the seed is outside the
    band. A flood fill by repeated masked dilation until nothing changes.
    """
    allowed = valid & (depth >= low) & (depth <= high)
    start = jnp.zeros(depth.shape, bool).at[seed[1], seed[0]].set(allowed[seed[1], seed[0]])

    def grow(state):
        region, _ = state
        new = region
        for _ in range(steps_per_iteration):
            new = _grow4(new) & allowed
        return new, jnp.any(new != region)

    region, _ = lax.while_loop(lambda s: s[1], grow, (start, jnp.array(True)))
    return region


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
