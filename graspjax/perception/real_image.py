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
   surface too steep to face the view, its slope measured on the real
   image (the nearest one when there is no support plane).
5. Detect (`detect_grasp`, or the baseline `config.method` names:
   `baselines.grasp_method`) at the detection resolution, in a `crop_px`
   square window of the virtual view centred on the target (`window.py`),
   with the target's depth-connected surface in the window as `seed_mask`,
   found from its 3-D point as the simulated robot finds its target in each
   new view, and `tbeam_positions` T-beams per edge. Its
   `candidates_per_target` most central placements are checked on the
   jaws' height map of the whole image, built once from its full-resolution
   points (`jaws.py`: width, each finger swept down, the jaws closing on
   the part alone, the wall where they touch), scored (`jaws.grasp_score`) and pooled. The next target is
   the highest candidate outside the surfaces already tried, until `top_k`
   distinct grasps passed or `max_targets` were tried (the paper tries one:
   its nearest object). When none of a target's T-beam placements passes, with
   `image.contour_search` `per` antipodal pairs (`antipodal_grasp`) spread along its
   band's contour, and `per` along its followed surface's (a top that slopes past the
   band's depth), are checked the same way, the best `per` kept, before it is given up
   (clutter); a target given up gives up its followed surface in the window, not only its
   band (the next target is another object, not a lower band of the same dome).
   The best `top_k` are returned, best first (the loop: `target_loop.py`). Align
   (`align_tool`) in the window of the best grasp's target (the last target when none passed).

The results are mapped back into the camera frame and the full-resolution
image. Written for ONE image; `jax.vmap` it over a batch (the camera may be
batched too, for images with their own intrinsics).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import GraspReason, TargetReason, names
from graspjax.config import Config, RealImageConfig, replace_unchecked
from graspjax.perception.align import Alignment, align_tool
from graspjax.perception.cluster import valid_mask
from graspjax.perception.jaws import height_map
from graspjax.perception.placements import Grasp
from graspjax.perception.support import SupportPlane, no_support, support_plane
from graspjax.perception.target import standing_candidates, surface_slope
from graspjax.perception.target_loop import Placements, TargetSearch
from graspjax.perception.virtual import view_camera, view_rotation, warp_depth_and_values
from graspjax.perception.window import in_view
from graspjax.perception.workspace import nan_median, working_views
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
class RankedGrasps:
    """The best `top_k` grasps of one image that passed every check, best first (camera frame)."""

    valid: jax.Array  # (K,) bool: a grasp in this rank
    score: jax.Array  # (K,) clearance + width margin - distance from the centre (`grasp_score`)
    target: jax.Array  # (K,) int32 the target it stands on (its index among those tried), -1 if none
    index: jax.Array  # (K,) int32 its placement in that target's `Grasp.candidates`, -1 if none
    contour: jax.Array  # (K,) bool: placed by the contour search (the method's were all blocked)
    position: jax.Array  # (K, 3) grasp centre G on the top surface (nan if none)
    closing_axis: jax.Array  # (K, 3) unit closing axis
    pixel: jax.Array  # (K, 2) G in the full-resolution image (u, v)
    width: jax.Array  # (K,) width of the gripped band (m)
    contact_width: jax.Array  # (K,) distance between the jaws where they touch the part (m)
    depth: jax.Array  # (K,) finger-tip depth below G the jaws reach (m)
    clearance: jax.Array  # (K,) free height below the finger tips in the jaws' paths (m; inf: all)
    landing: jax.Array  # (K,) the part's fall beside the band at the jaws' worst lane (m; inf: unseen)
    unknown: jax.Array  # (K,) share of the jaws' path samples without depth
    centre_distance: jax.Array  # (K,) distance of G from the part's centre across the view (m)


@pytree_dataclass
class RealImageDetection:
    """Result of `detect_real_image` for one image: the camera frame (m) and full-resolution pixels."""

    found: jax.Array  # () bool: a grasp was found
    support: SupportPlane  # the support plane, camera frame
    virtual: jax.Array  # () bool: the view is turned to face the support plane
    rotation: jax.Array  # (3, 3) view-to-camera rotation (identity if not virtual)
    view: Camera  # intrinsics of the reported detection window (view frame)
    target_reason: jax.Array  # () int32 TargetReason
    targets_tried: jax.Array  # () int32 (the reported target is the best grasp's, else the last)
    tried_reasons: jax.Array  # (max_targets,) int32 GraspReason of each target tried, -1 after
    tried_pixels: jax.Array  # (max_targets, 2) int32 each target's pixel in the support view
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
    ranked: RankedGrasps  # the best `top_k` grasps (the first is the one above)
    views: RealImageViews  # the images the steps worked on (for figures)

    # Reasons by name (the int codes above stay for the arrays); one image, on the host.
    @property
    def target_reason_name(self) -> str:
        """`target_reason` by name (`TargetReason`)."""
        return names(TargetReason, self.target_reason)

    @property
    def tried_reason_names(self) -> list[str]:
        """The `GraspReason` name of each target tried, in order."""
        return [names(GraspReason, x) for x in np.asarray(self.tried_reasons) if x >= 0]

    @property
    def reason_name(self) -> str:
        """The image's one reason: the grasp's (`GraspReason`) when a target was found, else
        the target's (`TargetReason`)."""
        if int(self.target_reason) == TargetReason.FOUND:
            return self.grasp.reason_name
        return self.target_reason_name


@dataclasses.dataclass(frozen=True)
class _Targets:
    """Steps 1-4 of `detect_real_image` on one image: its views and target candidates."""

    fine: jax.Array  # (H', W') detection-resolution depth (0 = invalid)
    fine_camera: Camera  # intrinsics of `fine`
    fine_slope: jax.Array  # (H', W') its surfaces' slope against the view (tangent; inf: unknown)
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
    support = support_plane(work, work_camera, image) if image.support else no_support()
    virtual = support.found & (support.tilt > np.deg2rad(image.max_tilt_deg))
    rotation = view_rotation(support.normal, virtual)
    view = view_camera(work_camera, rotation)
    step = max(1, image.target_window_px // 2)  # the slope's span (support pixels)
    # Slopes measured on the real image, against the view's axis: a turned view repeats real
    # pixels, so its own depth steps are no slope.
    axis = rotation[:, 2]
    warped, slope = warp_depth_and_values(work, surface_slope(work, work_camera, step, axis),
                                          work_camera, view, rotation, jnp.inf)
    view_depth = jnp.where(virtual, warped, work)
    points = view.unproject(view.pixel_grid(), view_depth)
    candidate, height, reason = standing_candidates(
        view_depth, view, in_view(support, rotation), window=image.target_window_px,
        min_pixels=image.min_target_pixels, max_slope_deg=image.max_target_slope_deg,
        min_height=config.perception.min_height, tolerance=tolerance, slope=slope)
    fine_slope = surface_slope(fine, fine_camera, step * (fine.shape[1] // work.shape[1]), axis)
    score = jnp.where(support.found, height, -view_depth)  # highest above it; else z_min
    return _Targets(fine, fine_camera, fine_slope, work, work_camera, support, virtual,
                    rotation, view, view_depth, points, height, candidate, score, reason)


def detect_real_image(depth: jax.Array, workspace: jax.Array, camera: Camera,
                      config: Config = Config(), image: RealImageConfig = RealImageConfig()
                      ) -> RealImageDetection:
    """Find the best grasps, and a re-alignment plane, on the objects highest above the support.

    depth: metric depth (H, W) float32 at full resolution, 0 or nan = invalid; workspace:
    (H, W) bool, where the search may look (the jaws' checks see every pixel in the range);
    camera: intrinsics of the full image; image: the real-image steps' settings. Pure and
    static-shaped: jit it, vmap it over a batch.
    """
    prep = _targets(depth, workspace, camera, config, image)
    rotation = prep.rotation
    in_range = valid_mask(depth) & (depth >= image.min_depth) & (depth <= image.max_depth)
    fine_view = view_camera(prep.fine_camera, rotation)
    support = in_view(prep.support, rotation)
    valid = valid_mask(prep.depth)
    heights = height_map(jnp.where(in_range, jnp.asarray(depth, jnp.float32), 0.0), camera,
                         rotation, fine_view, nan_median(jnp.where(valid, prep.depth, jnp.nan)),
                         support, image.sweep_fill_px)  # the jaws see outside the workspace
    search = TargetSearch(
        config=config, image=image, heights=heights,
        fine=prep.fine, fine_slope=prep.fine_slope, fine_camera=prep.fine_camera,
        fine_view=fine_view, rotation=rotation, support=support, depth=prep.depth,
        valid=valid, points=prep.points, candidate=prep.candidate,
        score=prep.score,
        # The window's own checks; the wall is judged on the jaws' height map where they touch.
        window_config=replace_unchecked(config, detect=replace_unchecked(
            config.detect, tbeam_positions=image.tbeam_positions,
            wall_check=jnp.zeros((), bool))))
    loop = search.run()
    pool, best = loop.pool, loop.best
    window = best.window
    alignment = align_tool(window.depth, window.camera, config.align,
                           jax.random.key(image.seed), seed_mask=window.seed)
    top = _ranked(pool.placements, *search.distinct(pool), camera)
    tried = jax.tree.map(lambda x: x[best.k], pool.tried)
    target_point = jnp.where(tried.found, rotation @ tried.point, jnp.nan)
    any_candidate = jnp.any(prep.candidate)
    n = image.max_targets
    return RealImageDetection(
        found=top.valid[0] & tried.found,
        support=prep.support,
        virtual=prep.virtual,
        rotation=rotation,
        view=window.camera,
        target_reason=prep.reason,
        targets_tried=jnp.where(any_candidate, loop.k, 0).astype(jnp.int32),
        tried_reasons=jnp.where(any_candidate & (jnp.arange(n) < loop.k), pool.tried.reason,
                                  -1),
        tried_pixels=pool.tried.pixel,
        target=tried.pixel,
        target_height=jnp.where(tried.found, prep.height[tried.pixel[1], tried.pixel[0]],
                                jnp.nan),
        target_point=target_point,
        target_pixel=camera.project(target_point),
        position=top.position[0],
        closing_axis=top.closing_axis[0],
        approach=rotation[:, 2],  # the view's optical axis, camera frame
        pixel=top.pixel[0],
        plane_normal=rotation @ alignment.normal,
        plane_point=rotation @ alignment.point,
        grasp=_as_chosen(best.grasp, top, tried.reason),
        alignment=alignment,
        ranked=top,
        views=RealImageViews(work=prep.work, work_camera=prep.work_camera, depth=prep.depth,
                             camera=prep.view, height=prep.height, window=window.depth,
                             window_camera=window.camera),
    )


def _ranked(pool: Placements, chosen: jax.Array, ok: jax.Array, camera: Camera) -> RankedGrasps:
    """The pool's placements `chosen` (K,) where `ok` (K,), best first (`TargetSearch.distinct`)."""
    pick = jnp.clip(chosen, 0)

    def ranked(x, fill):
        x = x[pick]
        return jnp.where(ok.reshape(-1, *[1] * (x.ndim - 1)), x, fill)

    jaws = pool.jaws
    position = ranked(pool.position, jnp.nan)
    return RankedGrasps(
        valid=ok, score=ranked(pool.score, jnp.nan),
        target=ranked(pool.target, -1), index=ranked(pool.index, -1),
        contour=ranked(pool.contour, False),
        position=position, closing_axis=ranked(pool.axis, jnp.nan),
        pixel=camera.project(position), width=ranked(pool.width, jnp.nan),
        contact_width=ranked(jaws.contact_width, jnp.nan), depth=ranked(jaws.depth, jnp.nan),
        clearance=ranked(jaws.clearance, jnp.nan), landing=ranked(jaws.landing, jnp.nan),
        unknown=ranked(jaws.unknown, jnp.nan),
        centre_distance=ranked(pool.distance, jnp.nan))


def _as_chosen(grasp: Grasp, top: RankedGrasps, reason: jax.Array) -> Grasp:
    """The detector's result on the best grasp's target (its window frame) with the best grasp
    as its choice, for figures and records."""
    index = top.index[0]
    ok = top.valid[0]
    cands = grasp.candidates
    i = jnp.clip(index, 0)
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    return dataclasses.replace(
        grasp, found=ok, reason=jnp.where(ok, GraspReason.FOUND, reason).astype(jnp.int32),
        position=jnp.where(ok, cands.center[i], nan3),
        closing_axis=jnp.where(ok, jnp.append(cands.axis[i], 0.0), nan3),
        width=jnp.where(ok, cands.width[i], jnp.nan),
        depth=jnp.where(ok, top.depth[0], jnp.nan),
        pixel=jnp.where(ok, cands.pixel[i], jnp.nan),
        index=jnp.where(ok, index, -1).astype(jnp.int32))
