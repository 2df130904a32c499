"""A target's detection window in a (virtual) view of a real image, and its surface there (one image).

`graspjax detect` looks at each target in a `crop_px` square window of the view, at the
detection resolution: the same camera with its principal point shifted, so nothing else
changes. The target's surface in it is found from its 3-D point as the simulated robot finds
its target in each new view (`target.follow_target`); as the targets, it faces the view within
`max_target_slope_deg`, the slope measured on the real image (a turned view repeats real
pixels and smears an object's side into a slope of connected depths).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from graspjax.camera import Camera
from graspjax.config import Config
from graspjax.perception.placements import sample_nearest
from graspjax.perception.support import SupportPlane
from graspjax.perception.target import follow_target, standing_candidates
from graspjax.perception.virtual import warp_depth_and_values


def in_view(support: SupportPlane, rotation: jax.Array) -> SupportPlane:
    """The support plane in the frame of a view turned by `rotation` (view-to-camera)."""
    return dataclasses.replace(support, normal=rotation.T @ support.normal)


def detection_window(fine: jax.Array, slope: jax.Array, fine_camera: Camera, view: Camera,
                     rotation: jax.Array, point: jax.Array, size: int
                     ) -> tuple[jax.Array, jax.Array, Camera]:
    """The `size`-square window of `view` centred on a view-frame `point` (3,): its depth (S, S),
    the tangent of its surfaces' slope against the view (S, S), from `slope` (H', W') measured
    on the real image `fine` (`target.surface_slope`), and its camera."""
    uv = view.project(point)
    origin = jnp.round(jnp.where(jnp.isfinite(uv), uv, 0.0)) - size // 2  # whole pixels
    camera = Camera(size, size, view.fx, view.fy, view.cx - origin[0], view.cy - origin[1])
    window, window_slope = warp_depth_and_values(fine, slope, fine_camera, camera, rotation,
                                                 jnp.inf)
    return window, window_slope, camera


def followed_surface(window: jax.Array, slope: jax.Array, camera: Camera, point: jax.Array,
                     support: SupportPlane, config: Config, max_slope_deg: float) -> jax.Array:
    """The target's depth-connected surface (S, S) bool in its window (`detection_window`),
    found from its view-frame `point` (3,): the pixels where the detector and the alignment
    take z_min. support: the plane in the view's frame (`in_view`)."""
    perception = config.perception
    candidate, _, _ = standing_candidates(window, camera, support,
                                          min_height=perception.min_height,
                                          tolerance=config.detect.surface_tolerance,
                                          max_slope_deg=max_slope_deg, slope=slope)
    surface, _, _ = follow_target(window, camera, candidate, point, perception.surface_step,
                                  perception.follow_distance, config.detect.unrolled_loops)
    return surface


def surface_in_view(surface: jax.Array, camera: Camera, points: jax.Array, valid: jax.Array,
                    factor: int) -> jax.Array:
    """The pixels (h, w) bool of a view of the same frame `factor` times coarser that show a
    window's `surface` (S, S) bool seen by `camera` (`detection_window`): those whose points
    (h, w, 3) (`valid` (h, w) bool) project within about half a coarse pixel of it (a coarse
    pixel on its edge shows it in part; `factor` whole, rounded down)."""
    reach = factor // 2
    if reach > 0:
        surface = jax.lax.reduce_window(surface, False, jax.lax.bitwise_or,
                                        (2 * reach + 1, 2 * reach + 1), (1, 1), "SAME")
    safe = jnp.where(valid[..., None], points, jnp.array([0.0, 0.0, 1.0], points.dtype))
    shown, _ = sample_nearest(surface, camera.project(safe), False)
    return valid & shown
