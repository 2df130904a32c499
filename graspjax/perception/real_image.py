"""The paper's method on one real depth image: workspace, support plane, virtual view, detect, align.

1. Working views (`workspace.py`): pixels outside the workspace and the
   depth range become invalid; narrow holes inside surfaces are bridged;
   block medians give the detection resolution (`detect_width`) and a
   coarser support resolution (`working_width`).
2. Support plane (`support.py`): the table or bin floor, by RANSAC, at the
   support resolution.
3. Virtual view (`virtual.py`): when the support is tilted against the
   optical axis by more than `max_tilt_deg`, the image is re-projected into
   a camera turned to look along the plane's negative normal (the paper's
   re-alignment, done without moving), so that the paper's assumption
   holds: the camera looks perpendicular at the surface.
4. Targets (`target.py`), in that view at the support resolution: the
   pixel highest above the support that is neither a speck nor on a
   surface too steep to face the view (the nearest one when there is no
   support plane).
5. Detect (`detect_grasp`) at the detection resolution, in a `crop_px`
   square window of the virtual view centred on the target (the same camera
   with a shifted principal point, so nothing else changes), with the
   target's 3 x 3 pixels as `seed_mask`. When no grasp is found, the next
   target is the highest candidate outside the surfaces already tried, at
   most `max_targets` in all (the paper tries one: its nearest object).
   Align (`align_tool`) in the window of the last target.

The results are mapped back into the camera frame and the full-resolution
image. Written for ONE image; `jax.vmap` it over a batch (the camera may be
batched too, for images with their own intrinsics).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from graspjax.camera import Camera
from graspjax.config import Config, RealImageConfig
from graspjax.perception.align import Alignment, align_tool
from graspjax.perception.cluster import target_surface, valid_mask
from graspjax.perception.grasp import Grasp, detect_grasp
from graspjax.perception.reasons import SupportReason
from graspjax.perception.support import SupportPlane, plane_height, support_plane
from graspjax.perception.target import best_candidate, target_candidates
from graspjax.perception.virtual import view_camera, view_rotation, warp_depth
from graspjax.perception.workspace import working_views
from graspjax.tree import pytree_dataclass


@pytree_dataclass
class RealImageViews:
    """The images `detect_real_image` works on, for one input image."""

    work: jax.Array  # (h, w) support-resolution depth in the camera's own view (0 = invalid)
    work_camera: Camera  # intrinsics of `work`
    depth: jax.Array  # (h, w) the view the targets are chosen in (virtual if turned; 0 = invalid)
    camera: Camera  # intrinsics of `depth`
    height: jax.Array  # (h, w) height above the support plane in that view (m; nan: none)
    window: jax.Array  # (S, S) detection window of the reported target (0 = invalid)
    window_camera: Camera  # intrinsics of `window` (same frame as `depth`, detection resolution)


@pytree_dataclass
class RealImageDetection:
    """Result of `detect_real_image` for one image: the camera frame (m) and full-resolution pixels."""

    found: jax.Array  # () bool: a grasp was found
    support: SupportPlane  # the support plane, camera frame
    virtual: jax.Array  # () bool: the view is turned to face the support plane
    rotation: jax.Array  # (3, 3) view-to-camera rotation (identity if not virtual)
    view: Camera  # intrinsics of the reported detection window (view frame)
    target_reason: jax.Array  # () int32 TargetReason
    attempts: jax.Array  # () int32 targets tried (the reported one is the last)
    attempt_reasons: jax.Array  # (max_targets,) int32 GraspReason of each target tried, -1 after
    attempt_pixels: jax.Array  # (max_targets, 2) int32 each target's pixel in the support view
    target: jax.Array  # (2,) int32 reported target's pixel in the support view (u, v)
    target_height: jax.Array  # () target's height above the support plane (m; nan: no plane)
    target_point: jax.Array  # (3,) target point, camera frame (nan if none)
    target_pixel: jax.Array  # (2,) target in the full-resolution image (u, v)
    position: jax.Array  # (3,) grasp centre G, camera frame (nan if none)
    closing_axis: jax.Array  # (3,) unit closing axis, camera frame
    approach: jax.Array  # (3,) unit approach direction (the view's optical axis)
    pixel: jax.Array  # (2,) G in the full-resolution image (u, v)
    plane_normal: jax.Array  # (3,) re-alignment plane normal (align_tool), camera frame
    plane_point: jax.Array  # (3,) centroid of its inliers, camera frame
    grasp: Grasp  # the detector's full result on the reported target, in its window
    alignment: Alignment  # align_tool's full result on the reported target, in its window
    views: RealImageViews  # the images the steps worked on (for figures)


def _no_support() -> SupportPlane:
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    return SupportPlane(found=jnp.array(False), reason=jnp.int32(SupportReason.OFF), normal=nan3,
                        distance=jnp.float32(jnp.nan), tilt=jnp.float32(jnp.nan),
                        inliers=jnp.int32(0), fraction=jnp.float32(0.0))


def _window(fine: jax.Array, fine_camera: Camera, view: Camera, rotation: jax.Array,
            point: jax.Array, size: int) -> tuple[jax.Array, Camera, jax.Array]:
    """The `size`-square detection window of the view centred on a camera-frame `point` (3,):
    its depth (S, S), its camera, and the seed mask (S, S) of the 3 x 3 pixels at its centre."""
    uv = view.project(rotation.T @ point)
    origin = jnp.round(jnp.where(jnp.isfinite(uv), uv, 0.0)) - size // 2  # whole pixels
    camera = Camera(size, size, view.fx, view.fy, view.cx - origin[0], view.cy - origin[1])
    depth = warp_depth(fine, fine_camera, camera, rotation)
    centre = jnp.zeros((size, size), bool).at[size // 2 - 1: size // 2 + 2,
                                              size // 2 - 1: size // 2 + 2].set(True)
    return depth, camera, centre & (depth > 0)


@dataclasses.dataclass(frozen=True)
class _Targets:
    """Steps 1-4 of `detect_real_image` on one image: its views and target candidates."""

    fine: jax.Array  # (H', W') detection-resolution depth (0 = invalid)
    fine_camera: Camera  # intrinsics of `fine`
    work: jax.Array  # (h, w) support-resolution depth
    work_camera: Camera  # intrinsics of `work`
    support: SupportPlane  # the support plane, camera frame
    virtual: jax.Array  # () bool: the view is turned to face the support
    rotation: jax.Array  # (3, 3) view-to-camera rotation
    view: Camera  # intrinsics of the (virtual) view at the support resolution
    depth: jax.Array  # (h, w) depth in that view
    points: jax.Array  # (h, w, 3) its points, view frame
    height: jax.Array  # (h, w) height above the support (m; nan: no plane)
    candidate: jax.Array  # (h, w) bool target candidates
    score: jax.Array  # (h, w) their order of preference
    reason: jax.Array  # () int32 TargetReason


def _targets(depth, workspace, camera: Camera, config: Config, image: RealImageConfig) -> _Targets:
    depth = jnp.asarray(depth, jnp.float32)
    if depth.shape != (camera.height, camera.width) or workspace.shape != depth.shape:
        raise ValueError(f"depth {depth.shape} and workspace {workspace.shape} must match the "
                         f"camera ({camera.height}, {camera.width})")
    tolerance = config.detect.surface_tolerance
    fine, fine_camera, work, work_camera = working_views(depth, workspace, camera, image,
                                                         tolerance)

    # Support plane and the view (turned to face it when it is tilted).
    support = support_plane(work, work_camera, image) if image.support else _no_support()
    virtual = support.found & (support.tilt > np.deg2rad(image.max_tilt_deg))
    rotation = view_rotation(support.normal, virtual)
    view = view_camera(work_camera, rotation)
    view_depth = jnp.where(virtual, warp_depth(work, work_camera, view, rotation), work)
    points = view.unproject(view.pixel_grid(), view_depth)
    height = jnp.where(support.found,
                       plane_height(points, rotation.T @ support.normal, support.distance), jnp.nan)
    candidate, score, reason = target_candidates(
        view_depth, view, height, support.found, window=image.target_window_px,
        min_pixels=image.min_target_pixels, max_slope_deg=image.max_target_slope_deg,
        min_height=image.min_height, tolerance=tolerance)
    return _Targets(fine, fine_camera, work, work_camera, support, virtual, rotation, view,
                    view_depth, points, height, candidate, score, reason)


def detect_real_image(depth: jax.Array, workspace: jax.Array, camera: Camera,
                      config: Config = Config(), image: RealImageConfig = RealImageConfig()
                      ) -> RealImageDetection:
    """Find a grasp and a re-alignment plane on the object highest above the support.

    depth: metric depth (H, W) float32 at full resolution, 0 or nan = invalid; workspace:
    (H, W) bool, True where the search may look (pixels outside are invalid for every step);
    camera: intrinsics of the full image; image: the real-image steps' settings. Pure and
    static-shaped: jit it, vmap it over a batch.
    """
    prep = _targets(depth, workspace, camera, config, image)
    fine, fine_camera, rotation, points = prep.fine, prep.fine_camera, prep.rotation, prep.points
    view_depth, height, candidate, score = prep.depth, prep.height, prep.candidate, prep.score
    tolerance = config.detect.surface_tolerance
    fine_view = view_camera(fine_camera, rotation)

    # Targets in order of height, each outside the surfaces already tried; each detected in
    # its own window of the view at the detection resolution.
    valid = valid_mask(view_depth)

    def attempt(k, tried, reasons, pixels):
        chosen, target = best_candidate(candidate & ~tried, score)
        has_target = jnp.any(chosen)
        point = jnp.where(has_target, rotation @ points[target[1], target[0]], 0.0)
        window, window_camera, seed = _window(fine, fine_camera, fine_view, rotation, point,
                                              image.crop_px)
        seed = seed & has_target
        grasp = detect_grasp(window, window_camera, config.detect, config.gripper, seed_mask=seed)
        surface, _ = target_surface(view_depth, valid & has_target, target,
                                    view_depth[target[1], target[0]], tolerance)
        return (k + 1, tried | surface | chosen, reasons.at[k].set(grasp.reason),
                pixels.at[k].set(target), window, window_camera, seed, target, grasp)

    def more(state):
        k, tried, *_, grasp = state
        return (k < image.max_targets) & ~grasp.found & jnp.any(candidate & ~tried)

    n = image.max_targets
    first = attempt(0, jnp.zeros(candidate.shape, bool), jnp.full(n, -1, jnp.int32),
                    jnp.zeros((n, 2), jnp.int32))
    attempts, _, reasons, pixels, window, window_camera, seed, target, grasp = lax.while_loop(
        more, lambda state: attempt(*state[:4]), first)
    alignment = align_tool(window, window_camera, config.align, jax.random.key(image.seed),
                           seed_mask=seed)

    has_target = jnp.any(seed)
    target_point = jnp.where(has_target, rotation @ points[target[1], target[0]], jnp.nan)
    position = rotation @ grasp.position
    views = RealImageViews(work=prep.work, work_camera=prep.work_camera, depth=view_depth,
                           camera=prep.view, height=height, window=window,
                           window_camera=window_camera)
    return RealImageDetection(
        found=grasp.found & has_target,
        support=prep.support,
        virtual=prep.virtual,
        rotation=rotation,
        view=window_camera,
        target_reason=prep.reason,
        attempts=jnp.where(has_target, attempts, 0).astype(jnp.int32),
        attempt_reasons=jnp.where(has_target, reasons, -1),
        attempt_pixels=pixels,
        target=target,
        target_height=jnp.where(has_target, height[target[1], target[0]], jnp.nan),
        target_point=target_point,
        target_pixel=camera.project(target_point),
        position=position,
        closing_axis=rotation @ grasp.closing_axis,
        approach=rotation @ grasp.approach,
        pixel=camera.project(position),
        plane_normal=rotation @ alignment.normal,
        plane_point=rotation @ alignment.point,
        grasp=grasp,
        alignment=alignment,
        views=views,
    )


