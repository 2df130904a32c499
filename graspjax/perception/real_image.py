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
   full-resolution image (`jaws.py`: width, the jaws' paths, the wall
   where the jaws touch), scored (`jaws.grasp_score`) and pooled. The next target is
   the highest candidate outside the surfaces already tried, until `top_k`
   distinct grasps passed or `max_targets` were tried (the paper tries one:
   its nearest object). When none of a target's T-beam placements passes, with
   `image.contour_search` `per` antipodal pairs (`antipodal_grasp`) spread along its
   band's contour, and `per` along its followed surface's (a top that slopes past the
   band's depth), are checked the same way, the best `per` kept, before it is given up
   (clutter); a target given up gives up its followed surface in the window, not only its
   band (the next target is another object, not a lower band of the same dome).
   The best `top_k` are returned, best first. Align (`align_tool`) in the
   window of the best grasp's target (the last target when none passed).

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
from graspjax.codes import GraspReason, TargetReason, names
from graspjax.config import Config, RealImageConfig, replace_unchecked
from graspjax.perception.align import Alignment, align_tool
from graspjax.perception.baselines import antipodal_grasp, evenly_spread, grasp_method
from graspjax.perception.cluster import target_surface, valid_mask
from graspjax.perception.jaws import check_jaws_where, grasp_score
from graspjax.perception.placements import Grasp
from graspjax.perception.ranking import distinct_best
from graspjax.perception.reasons import further_reason, furthest_reason
from graspjax.perception.support import SupportPlane, no_support, support_plane
from graspjax.perception.target import best_candidate, standing_candidates, surface_slope
from graspjax.perception.virtual import view_camera, view_rotation, warp_depth_and_values
from graspjax.perception.window import detection_window, followed_surface, in_view, surface_in_view
from graspjax.perception.workspace import working_views
from graspjax.tree import concat_trees, pytree_dataclass, where_tree


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
    attempt: jax.Array  # (K,) int32 the target it stands on (its attempt), -1 if none
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
    attempts: jax.Array  # () int32 targets tried (the reported one is the best grasp's, else the last)
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
    ranked: RankedGrasps  # the best `top_k` grasps (the first is the one above)
    views: RealImageViews  # the images the steps worked on (for figures)

    # Reasons by name (the int codes above stay for the arrays); one image, on the host.
    @property
    def target_reason_name(self) -> str:
        """`target_reason` by name (`TargetReason`)."""
        return names(TargetReason, self.target_reason)

    @property
    def attempt_reason_names(self) -> list[str]:
        """The `GraspReason` name of each target tried, in order."""
        return [names(GraspReason, x) for x in np.asarray(self.attempt_reasons) if x >= 0]

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
    fine, fine_camera, rotation, points = prep.fine, prep.fine_camera, prep.rotation, prep.points
    view_depth, height, candidate, score = prep.depth, prep.height, prep.candidate, prep.score
    tolerance = config.detect.surface_tolerance
    fine_view = view_camera(fine_camera, rotation)
    support = in_view(prep.support, rotation)
    # The window's own checks; the wall is judged at full resolution where the jaws touch.
    window_config = replace_unchecked(config, detect=replace_unchecked(
        config.detect, tbeam_positions=image.tbeam_positions, wall_check=jnp.zeros((), bool)))
    in_range = valid_mask(depth) & (depth >= image.min_depth) & (depth <= image.max_depth)
    full = jnp.where(in_range, jnp.asarray(depth, jnp.float32), 0.0)  # in the workspace or not
    approach = rotation[:, 2]  # the view's optical axis, camera frame
    n, per = image.max_targets, image.candidates_per_target
    factor = fine.shape[1] // view_depth.shape[1]  # detection pixels per support pixel

    # Targets in order of height, each outside the surfaces already tried; each detected in
    # its own window of the view at the detection resolution, its most central placements
    # checked on the full-resolution image, until `top_k` distinct grasps pass.
    valid = valid_mask(view_depth)

    contour_search = image.contour_search and config.method == "paper"

    def checked(cands, found, centre, k, first, by_contour):
        """`per` valid placements of `cands` (a `TBeams`) checked at full resolution (the method's
        nearest the part's `centre` (3,), the contour search's spread along the contour): target
        k's pool entries, each (per, ...), indexed in its candidates from `first`."""
        offset = jnp.linalg.norm(cands.center[:, :2] - centre[:2], axis=-1)
        if by_contour:
            index, real = evenly_spread(cands.valid, per)
        else:
            count = min(per, cands.valid.shape[0])  # a baseline may propose fewer placements
            _, index = lax.top_k(-jnp.where(cands.valid, offset, jnp.inf), count)
            index, real = jnp.pad(index, (0, per - count)), jnp.arange(per) < count
        placed = cands.valid[index] & found & real
        position = cands.center[index] @ rotation.T
        axis = jnp.pad(cands.axis[index], ((0, 0), (0, 1))) @ rotation.T
        jaws = check_jaws_where(placed, full, camera, position, axis, approach,
                                cands.width[index], config.detect, config.gripper, image)
        passed = placed & (jaws.reason == GraspReason.FOUND)
        rank = jnp.where(passed, grasp_score(jaws, cands.width[index], offset[index],
                                             config.detect, config.gripper, image), -jnp.inf)
        return dict(passed=passed, placed=placed, score=rank,
                    attempt=jnp.full(per, k, jnp.int32), index=(index + first).astype(jnp.int32),
                    contour=jnp.full(per, by_contour), position=position, axis=axis,
                    width=cands.width[index], distance=offset[index], jaws=jaws)

    def outcome(placements, window_reason):
        """A target's `GraspReason` from its checked placements: FOUND if one passed, else the
        furthest stage the placed ones reached at full resolution, else the window's reason."""
        placed, jaws = placements["placed"], placements["jaws"]
        failed = jnp.where(jnp.any(placed), furthest_reason(jaws.reason, placed), window_reason)
        return jnp.where(jnp.any(placements["passed"]), GraspReason.FOUND, failed).astype(jnp.int32)

    def examine(k, tried):
        """Target k: the surfaces tried after it, its checked placements (`per` each), its own
        results, its detector result, and its window, the window's camera and its followed
        surface there (where the tool is aligned if it is the best target)."""
        chosen, target = best_candidate(candidate & ~tried, score)
        has_target = jnp.any(chosen)
        point = jnp.where(has_target, points[target[1], target[0]], 0.0)  # view frame
        window, slope, window_camera = detection_window(fine, prep.fine_slope, fine_camera,
                                                        fine_view, rotation, point, image.crop_px)
        seed = followed_surface(window, slope, window_camera, point, support, config,
                                image.max_target_slope_deg)
        grasp = grasp_method(config.method)(window, window_camera, window_config,
                                            seed & has_target)
        surface, _ = target_surface(view_depth, valid & has_target, target,
                                    view_depth[target[1], target[0]], tolerance)
        centre = jnp.sum(points * surface[..., None], (0, 1)) / jnp.maximum(jnp.sum(surface), 1)

        # Its most central valid placements checked at full resolution; if none passes, with
        # `image.contour_search` its contour's antipodal pairs too (the further reason wins).
        placements = checked(grasp.candidates, grasp.found & has_target, centre, k, 0, False)
        reason = outcome(placements, grasp.reason)
        if contour_search:
            def search():
                # Pairs on the band's contour and on the followed surface's (a top sloping past
                # the band's depth: the part's outline); `per` of each checked, the `per` best
                # distinct kept (the two propose the same pairs where the band is the surface).
                first = grasp.candidates.valid.shape[0]
                searches = [antipodal_grasp(window, window_camera, window_config.detect,
                                            config.gripper, config.baseline, seed & has_target,
                                            surface=outline)
                            for outline in (None, seed & has_target)]
                both = concat_trees(*[
                    checked(pairs.candidates, pairs.found & has_target, centre, k,
                            first + i * pairs.candidates.valid.shape[0], True)
                    for i, pairs in enumerate(searches)])
                reason = outcome(both, further_reason(*[pairs.reason for pairs in searches]))
                best, distinct = distinct_best(both["passed"], both["score"], both["position"],
                                         both["axis"], per, image.duplicate_distance)
                kept = jax.tree.map(lambda x: x[jnp.clip(best, 0)], both)
                kept.update(passed=distinct, score=jnp.where(distinct, kept["score"], -jnp.inf))
                candidates = concat_trees(*[pairs.candidates for pairs in searches])
                return candidates, kept, reason

            def skipped():  # no placement, every one refused
                pairs, searched, _ = jax.tree.map(jnp.zeros_like, jax.eval_shape(search))
                no = jnp.int32(GraspReason.NO_ANTIPODAL)
                return (dataclasses.replace(pairs, reason=jnp.full_like(pairs.reason, no)),
                        {**searched, "score": jnp.full(per, -jnp.inf)}, no)

            pairs, searched, searched_reason = lax.cond(
                ~jnp.any(placements["passed"]) & has_target, search, skipped)
            rescued = jnp.any(searched["passed"])
            placements = where_tree(rescued, searched, placements)
            reason = further_reason(reason, searched_reason)  # skipped: NO_ANTIPODAL
            grasp = dataclasses.replace(grasp, candidates=concat_trees(grasp.candidates, pairs))
        placements.pop("placed")
        own = dict(reasons=reason, pixels=target, points=point, has_target=has_target)
        # A target given up gives up its object: its followed surface in the window (with the
        # contour search, the outline it paired across), not only its band, is tried.
        given_up = lax.cond(has_target & ~jnp.any(placements["passed"]),
                            lambda: surface_in_view(seed, window_camera, points, valid, factor),
                            lambda: jnp.zeros_like(valid))
        return (tried | surface | chosen | given_up, placements, own, grasp,
                (window, window_camera, seed & has_target))

    # The loop carries the targets' small results (a batch's loop selects its whole carry at
    # every step) and one target's detector result, window and followed surface: the best
    # grasp's so far (the last target's while none passed), where the tool is aligned.
    def attempt(k, tried, pool, best):
        tried, placements, own, grasp, target_window = examine(k, tried)
        pool = dict(pool)
        for key, value in placements.items():
            pool[key] = jax.tree.map(
                lambda whole, part: lax.dynamic_update_slice_in_dim(whole, part, k * per, 0),
                pool[key], value)
        for key, value in own.items():
            pool[key] = pool[key].at[k].set(value)
        best_score, best_k, best_result = best
        own_score = jnp.max(placements["score"])
        better = (own_score > best_score) | (best_score == -jnp.inf)  # ties keep the first
        best = (jnp.where(better, own_score, best_score), jnp.where(better, k, best_k),
                where_tree(better, (grasp, target_window), best_result))
        return k + 1, tried, pool, best

    def distinct(pool):
        return distinct_best(pool["passed"], pool["score"], pool["position"], pool["axis"],
                       image.top_k, image.duplicate_distance)

    def more(state):
        k, tried, pool, _ = state
        return ((k < n) & jnp.any(candidate & ~tried)
                & (jnp.sum(distinct(pool)[1]) < image.top_k))

    nothing_tried = jnp.zeros(candidate.shape, bool)
    _, placements, own, grasp0, window0 = jax.eval_shape(examine, 0, nothing_tried)
    pool = {key: jax.tree.map(lambda x: jnp.zeros((n * per, *x.shape[1:]), x.dtype), value)
            for key, value in placements.items()}
    pool.update({key: jnp.zeros((n, *x.shape), x.dtype) for key, x in own.items()})
    pool["score"] = jnp.full(n * per, -jnp.inf, jnp.float32)
    pool["reasons"] = jnp.full(n, -1, jnp.int32)
    best = (jnp.float32(-jnp.inf), jnp.int32(0),
            jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), (grasp0, window0)))
    attempts, _, pool, (_, best, (best_grasp, (window, window_camera, seed))) = lax.while_loop(
        more, lambda state: attempt(*state), attempt(0, nothing_tried, pool, best))
    chosen, ranked_ok = distinct(pool)
    pick = jnp.clip(chosen, 0)
    alignment = align_tool(window, window_camera, config.align, jax.random.key(image.seed),
                           seed_mask=seed)

    def ranked(x, fill):
        x = x[pick]
        return jnp.where(ranked_ok.reshape(-1, *[1] * (x.ndim - 1)), x, fill)

    jaws = pool["jaws"]
    position = ranked(pool["position"], jnp.nan)
    top = RankedGrasps(
        valid=ranked_ok, score=ranked(pool["score"], jnp.nan),
        attempt=ranked(pool["attempt"], -1), index=ranked(pool["index"], -1),
        contour=ranked(pool["contour"], False),
        position=position, closing_axis=ranked(pool["axis"], jnp.nan),
        pixel=camera.project(position), width=ranked(pool["width"], jnp.nan),
        contact_width=ranked(jaws.contact_width, jnp.nan), depth=ranked(jaws.depth, jnp.nan),
        clearance=ranked(jaws.clearance, jnp.nan), landing=ranked(jaws.landing, jnp.nan),
        unknown=ranked(jaws.unknown, jnp.nan),
        centre_distance=ranked(pool["distance"], jnp.nan))
    grasp = _as_chosen(best_grasp, top, pool["reasons"][best])

    target = pool["pixels"][best]
    has_target = pool["has_target"][best]
    found = ranked_ok[0] & has_target
    target_point = jnp.where(has_target, rotation @ pool["points"][best], jnp.nan)
    views = RealImageViews(work=prep.work, work_camera=prep.work_camera, depth=view_depth,
                           camera=prep.view, height=height, window=window,
                           window_camera=window_camera)
    return RealImageDetection(
        found=found,
        support=prep.support,
        virtual=prep.virtual,
        rotation=rotation,
        view=window_camera,
        target_reason=prep.reason,
        attempts=jnp.where(jnp.any(candidate), attempts, 0).astype(jnp.int32),
        attempt_reasons=jnp.where(jnp.any(candidate) & (jnp.arange(n) < attempts),
                                  pool["reasons"], -1),
        attempt_pixels=pool["pixels"],
        target=target,
        target_height=jnp.where(has_target, height[target[1], target[0]], jnp.nan),
        target_point=target_point,
        target_pixel=camera.project(target_point),
        position=top.position[0],
        closing_axis=top.closing_axis[0],
        approach=approach,
        pixel=top.pixel[0],
        plane_normal=rotation @ alignment.normal,
        plane_point=rotation @ alignment.point,
        grasp=grasp,
        alignment=alignment,
        ranked=top,
        views=views,
    )


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
