"""The target point on a real depth image: highest above the support, never a speck (one image).

The paper's target is the nearest point z_min. On a real image the nearest
point is often an outlier pixel or a speck of a few, and on a tilted table
it is the table's near edge. Here a pixel may be the target only if

- it stands at least `min_height` above the support plane (when one was
  found);
- at least `min_target_pixels` valid pixels of its `target_window_px`
  square window (itself included) lie within the surface tolerance of its
  depth: a speck smaller than that never qualifies; and
- its surface faces the view within `max_target_slope_deg`: the depth
  changes by at most tan(slope) times the lateral distance over half the
  window, on the smoother side along each image axis (so the pixels of an
  object's top next to its edge still qualify). A bin wall seen from the
  side is not a target: the detector could not cluster a surface there;

and the target is the qualifying pixel highest above the plane (the nearest
one when there is no plane).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.perception.cluster import valid_mask
from graspjax.perception.reasons import TargetReason


def similar_neighbours(depth: jax.Array, window: int, tolerance: float) -> jax.Array:
    """Count `(H, W)` int32 of valid pixels in each pixel's `window` square within `tolerance` of it.

    depth: metric depth (H, W), 0 or nan = invalid; the pixel itself counts
    when valid; invalid pixels get 0.
    """
    valid = valid_mask(depth)
    clean = jnp.where(valid, depth, 0.0)
    r = window // 2
    height, width = depth.shape
    padded_z, padded_ok = jnp.pad(clean, r), jnp.pad(valid, r)
    count = jnp.zeros(depth.shape, jnp.int32)
    for dv in range(window):
        for du in range(window):
            z = padded_z[dv: dv + height, du: du + width]
            ok = padded_ok[dv: dv + height, du: du + width]
            count += (ok & (jnp.abs(z - clean) <= tolerance)).astype(jnp.int32)
    return jnp.where(valid, count, 0)


def surface_slope(depth: jax.Array, camera: Camera, step: int) -> jax.Array:
    """Tangent `(H, W)` of the surface's slope against the view, from depth differences.

    depth: metric depth (H, W), 0 or nan = invalid. Along each image axis the
    depth difference to the pixel `step` away on the smoother side, over the
    lateral distance `step` pixels span at that depth; inf where neither side
    is valid.
    """
    valid = valid_mask(depth)
    clean = jnp.where(valid, depth, 0.0)
    height, width = depth.shape
    padded_z, padded_ok = jnp.pad(clean, step), jnp.pad(valid, step)

    def gradient(du, dv, focal):
        sides = []
        for sign in (1, -1):
            v0, u0 = step + sign * step * dv, step + sign * step * du
            z = padded_z[v0: v0 + height, u0: u0 + width]
            ok = padded_ok[v0: v0 + height, u0: u0 + width]
            sides.append(jnp.where(ok, jnp.abs(z - clean), jnp.inf))
        return jnp.minimum(*sides) * focal / (step * jnp.maximum(clean, 1e-6))

    slope = jnp.hypot(gradient(1, 0, camera.fx), gradient(0, 1, camera.fy))
    return jnp.where(valid, slope, jnp.inf)


def target_candidates(depth: jax.Array, camera: Camera, height: jax.Array, has_plane: jax.Array,
                      *, window: int, min_pixels: int, max_slope_deg: float, min_height: float,
                      tolerance: float) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Pixels that may be the target: (candidates (H, W) bool, score (H, W), TargetReason ()).

    depth: metric depth (H, W) of the view seen by `camera`, 0 or nan =
    invalid; height: (H, W) height above the support plane (m), used when
    `has_plane` (() bool). The score ranks candidates: the height, or minus
    the depth without a plane.
    """
    valid = valid_mask(depth)
    score = jnp.where(has_plane, height, -depth)  # without a plane: the nearest point
    standing = valid & (~has_plane | (height >= min_height))
    solid = similar_neighbours(depth, window, tolerance) >= min_pixels
    facing = surface_slope(depth, camera, max(1, window // 2)) <= np.tan(np.deg2rad(max_slope_deg))
    candidate = standing & solid & facing
    reason = jnp.select([~jnp.any(valid), ~jnp.any(standing), ~jnp.any(candidate)],
                        [TargetReason.EMPTY_WORKSPACE, TargetReason.NO_OBJECT,
                         TargetReason.NO_SURFACE], TargetReason.FOUND).astype(jnp.int32)
    return candidate, score, reason


def best_candidate(candidate: jax.Array, score: jax.Array, tie: float = 5e-4
                   ) -> tuple[jax.Array, jax.Array]:
    """The candidate with the highest score: (seed mask (H, W) bool, pixel (2,) int32 (u, v)).

    Scores within `tie` (m) of the best are ties and the first in row-major
    order wins, so that a flat top gives the same pixel whatever the float
    rounding (batched or single). The seed mask holds that pixel alone (empty
    when there is no candidate); give it to `detect_grasp` and `align_tool`
    as `seed_mask`.
    """
    masked = jnp.where(candidate, score, -jnp.inf)
    flat = jnp.argmax((masked >= jnp.max(masked) - tie).reshape(-1) & candidate.reshape(-1))
    v, u = jnp.divmod(flat, candidate.shape[1])
    seed = jnp.zeros(candidate.shape, bool).at[v, u].set(candidate.reshape(-1)[flat])
    return seed, jnp.stack([u, v]).astype(jnp.int32)
