"""Choosing a target on a depth image and following it from view to view (one image).

The same steps serve the simulated robot and `graspjax detect` on a real
image; what differs is an input: the workspace (a calibrated box, or a
user's region of interest) and the support plane (the calibrated table, or
one fitted to the image).

The paper's target is the nearest point z_min. A pixel may be the target
(`target_candidates`) only if it lies in the workspace (the caller
invalidates the rest) and stands at least `min_height` above the support
plane, so that on a tilted view the table's near edge is never the target.
Real images add two outlier tests:

- at least `min_target_pixels` valid pixels of its `target_window_px`
  square window (itself included) lie within the surface tolerance of its
  depth: a speck smaller than that never qualifies; and
- its surface faces the view within `max_target_slope_deg`: the normal of
  the 3-D points half the window away, on the smoother side along each
  image axis (so the pixels of an object's top next to its edge still
  qualify). A bin wall seen from the side is not a target: the detector
  could not cluster a surface there.

`best_candidate` takes the best-ranked candidate: the nearest (z_min) in a
simulated view, the highest above the fitted plane in a real image's view
that faces it (the same order within `max_tilt_deg`). `follow_target`
finds a chosen target again in the next view from its 3-D point alone and
returns its depth-connected surface, where the detector and the alignment
take z_min.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import TargetReason
from graspjax.perception.cluster import connected_surface, valid_mask
from graspjax.perception.support import SupportPlane, plane_height


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


def _normal_planes(depth: jax.Array, camera: Camera, step: int):
    """`surface_normals` as three planes (nx, ny, nz), each (H, W), not masked, and where they
    are known (H, W): computed plane by plane, with no (H, W, 3) stack to transpose and reduce."""
    valid = valid_mask(depth)
    z = jnp.where(valid, depth, 0.0)
    height, width = depth.shape
    grid = camera.pixel_grid()
    points = jnp.stack(camera.unproject_planes(grid[..., 0], grid[..., 1], z))  # (3, H, W)
    padded_p = jnp.pad(points, ((0, 0), (step, step), (step, step)))  # (3, H + 2s, W + 2s)
    padded_ok = jnp.pad(valid, step)

    def tangent(du, dv):
        sides, changes = [], []
        for sign in (1, -1):
            v0, u0 = step + sign * step * dv, step + sign * step * du
            ok = padded_ok[v0: v0 + height, u0: u0 + width]
            span = padded_p[:, v0: v0 + height, u0: u0 + width] - points
            sides.append(span)
            changes.append(jnp.where(ok, jnp.abs(span[2]), jnp.inf))
        smoother = changes[0] <= changes[1]
        return jnp.where(smoother, sides[0], sides[1]), jnp.isfinite(jnp.minimum(*changes))

    (ax, ay, az), seen_u = tangent(1, 0)
    (bx, by, bz), seen_v = tangent(0, 1)
    normal = (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)
    inverse = 1.0 / jnp.maximum(jnp.sqrt(sum(c * c for c in normal)), 1e-12)
    return tuple(c * inverse for c in normal), valid & seen_u & seen_v


def surface_normals(depth: jax.Array, camera: Camera, step: int) -> jax.Array:
    """Unit surface normals `(H, W, 3)` in the camera frame, from the 3-D points (nan: unknown).

    depth: metric depth (H, W), 0 or nan = invalid. Along each image axis the
    point `step` pixels away on the smoother side (the smaller depth change)
    spans a tangent; the normal is that of the two tangents (its sign is of
    no use: slopes take its direction only). Unknown where the depth is
    invalid, or neither side of an axis is valid.
    """
    normal, known = _normal_planes(depth, camera, step)
    return jnp.where(known[..., None], jnp.stack(normal, -1), jnp.nan)


def _slope(normal, axis) -> jax.Array:
    """Tangent of the angle between unit normals (nx, ny, nz) (...) and `axis` (3,)."""
    cos = jnp.abs(normal[0] * axis[0] + normal[1] * axis[1] + normal[2] * axis[2])
    return jnp.sqrt(jnp.maximum(1.0 - cos * cos, 0.0)) / jnp.maximum(cos, 1e-12)


def surface_slope(depth: jax.Array, camera: Camera, step: int, axis=(0.0, 0.0, 1.0)) -> jax.Array:
    """Tangent `(H, W)` of the surface's slope against a view's unit optical `axis` (3,) in the
    camera frame (`surface_normals`; default the camera's own), true anywhere in the image: a
    vertical face seen far off the axis is steep, though its depth changes by about one
    lateral pixel per pixel there; inf where unknown. From the normals' planes, without their
    (H, W, 3) stack."""
    normal, known = _normal_planes(depth, camera, step)
    return jnp.where(known, _slope(normal, axis), jnp.inf)


def target_candidates(depth: jax.Array, camera: Camera, height: jax.Array, has_plane: jax.Array,
                      *, min_height, tolerance: float, window: int = 1, min_pixels: int = 1,
                      max_slope_deg: float = 90.0, slope: jax.Array | None = None
                      ) -> tuple[jax.Array, jax.Array]:
    """Pixels that may be the target: (candidates (H, W) bool, TargetReason ()).

    depth: metric depth (H, W) of the view seen by `camera`, 0 or nan =
    invalid (pixels outside the workspace must already be invalid); height:
    (H, W) height above the support plane (m), used when `has_plane` (()
    bool). The speck test (`window`, `min_pixels`) and the slope test
    (`max_slope_deg`) are for real images' outliers; their defaults leave
    them out. `slope`: (H, W) tangents of the slope measured on the image the
    view was turned from (`surface_slope` against its axis), else from `depth` itself
    (a turned view repeats real pixels, so its own depth steps are no
    slope). Rank the candidates with `best_candidate`.
    """
    valid = valid_mask(depth)
    standing = valid & (~has_plane | (height >= min_height))
    candidate = standing
    if min_pixels > 1:
        candidate = candidate & (similar_neighbours(depth, window, tolerance) >= min_pixels)
    if max_slope_deg < 90.0:
        if slope is None:
            slope = surface_slope(depth, camera, max(1, window // 2))
        candidate = candidate & (slope <= np.tan(np.deg2rad(max_slope_deg)))
    reason = jnp.select([~jnp.any(valid), ~jnp.any(standing), ~jnp.any(candidate)],
                        [TargetReason.EMPTY_WORKSPACE, TargetReason.NO_OBJECT,
                         TargetReason.NO_SURFACE], TargetReason.FOUND).astype(jnp.int32)
    return candidate, reason


def standing_candidates(depth: jax.Array, camera: Camera, support: SupportPlane, *, min_height,
                        tolerance: float, window: int = 1, min_pixels: int = 1,
                        max_slope_deg: float = 90.0, slope: jax.Array | None = None
                        ) -> tuple[jax.Array, jax.Array, jax.Array]:
    """`target_candidates` of a view whose support plane is known (calibrated) or fitted:
    (candidates (H, W) bool, height above the support (H, W) (m; nan without one),
    TargetReason ()). depth: metric depth (H, W) of the view seen by `camera`; support: the
    plane in that view's camera frame."""
    points = camera.unproject(camera.pixel_grid(), depth)
    height = jnp.where(support.found, plane_height(points, support.normal, support.distance),
                       jnp.nan)
    candidate, reason = target_candidates(depth, camera, height, support.found,
                                          min_height=min_height, tolerance=tolerance,
                                          window=window, min_pixels=min_pixels,
                                          max_slope_deg=max_slope_deg, slope=slope)
    return candidate, height, reason


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


def follow_target(depth: jax.Array, camera: Camera, candidate: jax.Array, point: jax.Array,
                  max_step, reach, unroll: bool = False) -> tuple[jax.Array, jax.Array, jax.Array]:
    """A target chosen earlier, found again in a new view: (its surface (H, W) bool, the pixel
    it was found at (2,) int32 (u, v), found () bool).

    depth: metric depth (H, W) of the new view; candidate: (H, W) bool pixels
    that may be a target (`target_candidates`); point: (3,) the target's 3-D
    point in this view's camera frame. The target is found at the candidate
    pixel whose point lies nearest to `point`, if within `reach` (m); its
    surface is the depth-connected surface around that pixel
    (`connected_surface`, steps of at most `max_step` m), the pixels where
    the detector and the alignment take z_min. Empty when not found (the
    point is hidden or left the view). `unroll`: the fill's steps in one loop
    iteration (`detect.unrolled_loops`).
    """
    points = camera.unproject(camera.pixel_grid(), jnp.where(candidate, depth, 0.0))
    gap = jnp.where(candidate, jnp.sum((points - point) ** 2, -1), jnp.inf)
    flat = jnp.argmin(gap)
    v, u = jnp.divmod(flat, depth.shape[1])
    found = gap.reshape(-1)[flat] <= jnp.square(reach)
    pixel = jnp.stack([u, v]).astype(jnp.int32)
    surface = connected_surface(depth, candidate & found, pixel, max_step, unroll)
    return surface, pixel, found
