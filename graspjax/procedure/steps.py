"""One attempt of the paper's procedure (Fig. 1) in one world, top to bottom: overview, select,
centre, detect, re-align, execute and judge, one record."""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp

from graspjax.camera import Camera
from graspjax.codes import ALIGN_BASE, DETECT_BASE, Reason
from graspjax.config import MAX_REORIENTATIONS, Config
from graspjax.geometry import axis_angle, frame_from_axes, look_down, normalize, rotation_between
from graspjax.perception import (
    Alignment,
    AlignReason,
    Grasp,
    GraspReason,
    align_tool,
    plane_inliers,
)
from graspjax.perception.baselines import grasp_method
from graspjax.perception.cluster import nearest_pixel
from graspjax.perception.jaws import admit_by_jaws
from graspjax.perception.support import known_support
from graspjax.perception.target import best_candidate, follow_target, standing_candidates
from graspjax.perception.workspace import box_workspace
from graspjax.procedure.protocol import (
    attempt_keys,
    drops_of,
    eligible_objects,
    in_bin,
    round_goes_on,
    settle_segments,
)
from graspjax.procedure.state import (
    NO_CLUTTER,
    NO_LAYOUT,
    NO_PLANE,
    PlaneTruth,
    Record,
    RoundState,
    TargetClutter,
    Views,
    WorldSpec,
)
from graspjax.procedure.truth import plane_truth, surfaces, target_faces, target_pixels, with_oracle
from graspjax.sim.clutter import LayoutStats, layout_stats, object_clutter
from graspjax.sim.raycast import render_depth_and_piece
from graspjax.sim.scene import Scene, mjx
from graspjax.sim.world import (
    Execution,
    GraspPose,
    Outcome,
    finger_clearance,
    hand_clear,
    hand_waypoints,
    physics_model,
    physics_state,
    simulate,
)
from graspjax.tree import pytree_dataclass, where_tree


@pytree_dataclass
class _View:
    """What one camera pose yields."""

    grasp: Grasp  # camera frame of this view
    alignment: Alignment  # camera frame of this view
    grasp_pose: GraspPose  # the grasp in the world frame (valid iff grasp.found)
    next_rotation: jax.Array  # (3, 3) camera-to-world rotation of the re-aligned view
    next_position: jax.Array  # (3,) camera centre of the re-aligned view
    can_realign: jax.Array  # () bool: a plane was found and its view is reachable
    truth: PlaneTruth  # the chosen plane, judged by ground truth
    depth: jax.Array  # (H, W) the image
    surface: jax.Array  # (H, W) int32 `Surface` of each pixel (ground truth)
    mask: jax.Array  # (H, W) bool the target's surface the method found (or the oracle's labels)
    lost: jax.Array  # () bool the target was not found in this view
    grasp_object: jax.Array  # () int32 object under the grasp centre (ground truth; -1: none)
    precision: jax.Array  # () share of `mask` on the target (ground truth; nan: empty)
    recall: jax.Array  # () share of the target's visible pixels in `mask` (nan: none visible)


def _look(scene: Scene, data, rotation, position, camera: Camera, config: Config, key):
    """Depth image (H, W), object index per pixel (H, W) (-1: table, bin or nothing) and whether
    each pixel shows the table (H, W) bool (rendered piece 0; the bin's walls follow it)."""
    depth, piece = render_depth_and_piece(scene.solids, data.geom_xpos, data.geom_xmat, rotation,
                                          position, camera, config.camera, key)
    objects = jnp.asarray(scene.piece_object)
    return depth, jnp.where(piece >= 0, objects[jnp.maximum(piece, 0)], -1), piece == 0


def overview_pose(config: Config):
    """The start pose: straight down over the workspace centre."""
    return look_down(jnp.array([0.0, 0.0, 1.0]) * config.procedure.camera_height)


def _table(rotation, position):
    """The table (z = 0) in the frame of a camera at a pose (rotation (3, 3), position (3,)),
    known by calibration."""
    return known_support(rotation, position, jnp.array([0.0, 0.0, 1.0]), 0.0)


def _candidates(depth: jax.Array, rotation, position, in_bin, camera: Camera, config: Config
                ) -> jax.Array:
    """Pixels (H, W) bool of a view that may be a target, from its depth (H, W) and what a
    calibrated robot knows: the camera's pose (rotation (3, 3), position (3,)), the table
    (z = 0) and the workspace (the bin's interior when `in_bin`, () bool; else the table)."""
    table = _table(rotation, position)
    inner = config.layout.bin_size / 2 - config.perception.wall_margin
    half = jnp.where(in_bin, inner, jnp.inf)
    workspace = box_workspace(depth, camera, rotation, position,
                              jnp.stack([-half, -half, -jnp.inf]), jnp.stack([half, half, jnp.inf]))
    candidate, _, _ = standing_candidates(jnp.where(workspace, depth, 0.0), camera, table,
                                          min_height=config.perception.min_height,
                                          tolerance=config.detect.surface_tolerance)
    return candidate


def select_target(scene: Scene, data, eligible: jax.Array, attempting, in_bin, camera: Camera,
                  config: Config, key):
    """Steps 1-2 (state after kinematics): the overview image and its target point, z_min among
    the candidates (`_candidates`); with `perception.oracle`, the nearest pixel of the
    `eligible` (n,) objects by the renderer's labels. Returns the object the point lies on ()
    (ground truth, -1 if none), whether a point was chosen () (never when not `attempting`),
    the point (3,) in the world, the image (H, W), its object index per pixel (H, W) and its
    candidates (H, W)."""
    rotation, position = overview_pose(config)
    depth, objects, _ = _look(scene, data, rotation, position, camera, config, key)
    candidate = _candidates(depth, rotation, position, in_bin, camera, config)
    _, pixel = best_candidate(candidate, -depth)  # z_min

    def by_labels():  # the ablation: the nearest pixel of the eligible objects, by identity
        labelled = (objects >= 0) & eligible[jnp.maximum(objects, 0)] & (depth > 0)
        return nearest_pixel(depth, labelled)[0], labelled

    (u, v), seen = with_oracle(config, (pixel, candidate), by_labels)
    aimed = jnp.any(seen) & attempting
    point_cam = camera.unproject(jnp.stack([u, v]).astype(jnp.float32), depth[v, u])
    credited = jnp.where(aimed, objects[v, u], -1).astype(jnp.int32)  # ground truth: the credit
    return credited, aimed, rotation @ point_cam + position, depth, objects, seen


_TILT_STREAM = 7  # fold_in tag of the centred view's tilt azimuth (leaves every other draw as it was)


def centred_pose(point: jax.Array, config: Config, key: jax.Array):
    """Camera moved parallel to the table so its optical axis passes through `point` (3,)
    (with `procedure.centre` off: the overview pose, unmoved). With `procedure.view_tilt_deg`
    the camera then swings by that angle about a horizontal axis of azimuth U(-pi, pi) (from
    `key`) through the point where its optical axis meets the target's height (`point` itself
    when centred): the same distance, the optical axis still through that point."""
    over = jnp.where(config.procedure.centre, point[:2], 0.0)
    rotation, position = look_down(jnp.concatenate(
        [over, jnp.full(1, config.procedure.camera_height, point.dtype)]))
    tilt = jnp.deg2rad(config.procedure.view_tilt_deg)
    azimuth = jax.random.uniform(key, (), minval=-jnp.pi, maxval=jnp.pi)
    swing = axis_angle(jnp.stack([jnp.cos(azimuth), jnp.sin(azimuth), 0.0]), tilt)
    pivot = jnp.concatenate([over, point[2:]])
    tilted = swing @ rotation, pivot + swing @ (position - pivot)
    return jax.tree.map(lambda a, b: jnp.where(tilt > 0, a, b), tilted, (rotation, position))


def view_keys(key: jax.Array) -> tuple[jax.Array, jax.Array]:
    """A view's keys: its image (the sensor's noise) and its alignment (random hypotheses)."""
    return jax.random.split(key)


def view(scene: Scene, data, rotation, position, target: jax.Array, point: jax.Array, in_bin,
         camera: Camera, config: Config, key) -> _View:
    """Look from a pose: find the target from its world `point` (3,), detect a grasp on it and
    score re-alignment planes around it. `target` () (the credited object) only judges."""
    k_render, k_align = view_keys(key)
    depth, obj, table = _look(scene, data, rotation, position, camera, config, k_render)
    surface = surfaces(obj, table, depth, target)  # ground truth: it judges, after the decisions
    candidate = _candidates(depth, rotation, position, in_bin, camera, config)
    followed, _, _ = follow_target(depth, camera, candidate, rotation.T @ (point - position),
                                   config.perception.surface_step,
                                   config.perception.follow_distance)
    mask = with_oracle(config, followed, lambda: target_pixels(surface))
    grasp = grasp_method(config.method)(depth, camera, config, mask)
    if config.detect.jaw_sweep:
        grasp = admit_by_jaws(grasp, depth, camera, _table(rotation, position), config)
    alignment = align_tool(depth, camera, config.align, k_align, seed_mask=mask)

    approach = rotation[:, 2]
    centre = rotation @ grasp.position + position
    pose = GraspPose(tcp=centre + grasp.depth * approach, approach=approach,
                     closing=rotation @ grasp.closing_axis, valid=grasp.found)

    # Re-aligned view: optical axis along the negative plane normal, at the same distance
    # from the inliers' centroid, turned from the current view by the smallest rotation.
    normal = rotation @ alignment.normal
    point_plane = rotation @ alignment.point + position
    next_rotation = rotation_between(approach, -normal) @ rotation
    next_position = point_plane + jnp.linalg.norm(alignment.point) * normal
    reachable = (next_position[2] >= config.procedure.min_view_height) & (normal[2] > 0)
    truth = plane_truth(surface, plane_inliers(depth, camera, alignment, config.align), normal,
                        target_faces(scene, data, target), alignment.found, next_rotation[:, 2])
    # Ground truth for the record: what the grasp centre and the found surface lie on.
    g = jnp.round(jnp.where(grasp.found, grasp.pixel, 0.0)).astype(jnp.int32)
    inside = (g[0] >= 0) & (g[0] < camera.width) & (g[1] >= 0) & (g[1] < camera.height)
    under = obj[jnp.clip(g[1], 0, camera.height - 1), jnp.clip(g[0], 0, camera.width - 1)]
    on_target = target_pixels(surface)  # judging the segmentation: precision and recall
    hits = jnp.sum(mask & on_target)
    return _View(grasp=grasp, alignment=alignment, grasp_pose=pose,
                 next_rotation=jnp.where(alignment.found, next_rotation, rotation),
                 next_position=jnp.where(alignment.found, next_position, position),
                 can_realign=alignment.found & reachable, truth=truth, depth=depth,
                 surface=surface, mask=mask, lost=~jnp.any(mask),
                 grasp_object=jnp.where(grasp.found & inside, under, -1).astype(jnp.int32),
                 precision=jnp.where(jnp.any(mask), hits / jnp.maximum(jnp.sum(mask), 1), jnp.nan),
                 recall=jnp.where(jnp.any(on_target), hits / jnp.maximum(jnp.sum(on_target), 1),
                                  jnp.nan))


def first_look(scene: Scene, data, eligible, attempting, in_bin, key, config: Config):
    """Steps 1-3 on a settled state (after kinematics): the credited object (), whether a
    target point was chosen (), the point (3,) (world), the centred camera pose (rotation
    (3, 3), position (3,)), the overview image (H, W) with its object index per pixel (H, W)
    and candidates (H, W), and the key of the views that follow (view r: fold_in r)."""
    k_overview, k_views = jax.random.split(key)
    camera = config.camera.camera()
    target, aimed, point, depth, objects, candidate = select_target(
        scene, data, eligible, attempting, in_bin, camera, config, k_overview)
    return (target, aimed, point, centred_pose(point, config, jax.random.fold_in(key, _TILT_STREAM)),
            (depth, objects, candidate), k_views)


class _Search(NamedTuple):
    """The search's carry from one view to the next (`_search`), of one world."""

    rotation: jax.Array  # (3, 3) the camera's next view (world)
    position: jax.Array  # (3,)
    found: jax.Array  # () bool: the last view found a grasp on the target
    blocked: jax.Array  # () bool: no grasp, and no re-alignment possible
    pose: GraspPose  # the grasp found (nan until then)
    turns: jax.Array  # () int32: re-alignments made
    detect_reason: jax.Array  # () int32 `GraspReason` of the last view
    align_reason: jax.Array  # () int32 `AlignReason` of the last re-alignment tried (-1: none)
    lost: jax.Array  # () bool: the last view saw nothing of the target
    under: jax.Array  # () int32: the object under the grasp found (-1: none)
    first: tuple[jax.Array, jax.Array]  # the first view's segmentation precision and recall


def _search(scene: Scene, data, eligible, attempting, in_bin, key, config: Config, keep_views: bool):
    """Steps 1-5 on a settled state (after kinematics): the credited object, whether a target
    point was chosen, the grasp pose, the search's record fields and, if `keep_views`, every
    image."""
    camera = config.camera.camera()
    target, aimed, point, (centre_rot, centre_pos), (depth, objects, candidate), k_views = (
        first_look(scene, data, eligible, attempting, in_bin, key, config))
    budget = config.procedure.max_reorientations  # traced; at most MAX_REORIENTATIONS + 1 views
    views_at_most = MAX_REORIENTATIONS + 1

    def searching(loop):
        """View r is taken: no grasp yet, the search not blocked, within the budget."""
        r, carry, _ = loop
        return ~carry.found & ~carry.blocked & (r <= budget) & (r < views_at_most)

    def look(loop):
        """View r of a world that still searches (a world that stopped keeps its carry)."""
        r, carry, kept = loop
        v = view(scene, data, carry.rotation, carry.position, target, point, in_bin, camera,
                 config, jax.random.fold_in(k_views, r))
        found = v.grasp.found & aimed
        may_turn = ~found & (r < budget)  # the last view never re-aligns
        move = may_turn & v.can_realign
        carry = _Search(
            rotation=jnp.where(move, v.next_rotation, carry.rotation),
            position=jnp.where(move, v.next_position, carry.position),
            found=found, blocked=may_turn & ~v.can_realign,
            pose=where_tree(found, v.grasp_pose, carry.pose),
            turns=carry.turns + move.astype(jnp.int32), detect_reason=v.grasp.reason,
            align_reason=jnp.where(may_turn, v.alignment.reason, carry.align_reason),
            lost=v.lost, under=jnp.where(found, v.grasp_object, carry.under),
            first=jax.tree.map(lambda new, old: jnp.where(r == 0, new, old),
                               (v.precision, v.recall), carry.first))
        taken = where_tree(move, v.truth, NO_PLANE)
        kept = jax.tree.map(lambda buffer, x: buffer.at[r].set(x), kept,
                            ((v, jnp.array(True)) if keep_views else None, taken))
        return r + 1, carry, kept

    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    no_pose = GraspPose(nan3, nan3, nan3, jnp.array(False))
    carry = _Search(rotation=centre_rot, position=centre_pos, found=jnp.array(False),
                    blocked=jnp.array(False), pose=no_pose, turns=jnp.int32(0),
                    detect_reason=jnp.int32(GraspReason.NO_DEPTH), align_reason=jnp.int32(-1),
                    lost=jnp.array(False), under=jnp.int32(-1),
                    first=(jnp.float32(jnp.nan), jnp.float32(jnp.nan)))
    # Views not taken keep these: no plane, and (kept views) blank images marked not looked.
    # The view's shapes cost a trace of its own, so only kept views ask for them.
    kept = None
    if keep_views:
        blank = jax.eval_shape(lambda: view(scene, data, centre_rot, centre_pos, target, point,
                                            in_bin, camera, config, k_views))
        kept = jax.tree.map(lambda x: jnp.zeros((views_at_most,) + x.shape, x.dtype),
                            (blank, jax.ShapeDtypeStruct((), bool)))
    kept = (kept, jax.tree.map(lambda x: jnp.broadcast_to(x, (views_at_most,)), NO_PLANE))
    # A masked loop: it ends when no world of a batch still searches (vmap runs it until then).
    _, carry, (per_view, taken) = jax.lax.while_loop(searching, look, (jnp.int32(0), carry, kept))
    pose = dataclasses.replace(carry.pose, valid=carry.found & aimed)
    realign = jax.tree.map(lambda x: x[:MAX_REORIENTATIONS], taken)  # the last view never turns
    views = None
    if keep_views:
        v, searched = per_view
        rotation, position = overview_pose(config)
        views = Views(depth=jnp.concatenate([depth[None], v.depth]),
                      target_mask=jnp.concatenate([((objects == target) & (target >= 0))[None],
                                                   target_pixels(v.surface)]),
                      seed_mask=jnp.concatenate([candidate[None], v.mask]),
                      rotation=jnp.concatenate([rotation[None], _view_poses(centre_rot, v.next_rotation)]),
                      position=jnp.concatenate([position[None], _view_poses(centre_pos, v.next_position)]),
                      looked=jnp.concatenate([jnp.array([True]), searched]),
                      grasp=v.grasp, alignment=v.alignment, state=physics_state(data))
    progress = (carry.blocked, carry.turns, carry.detect_reason, carry.align_reason,
                carry.lost & ~carry.found, realign, carry.under, carry.first)
    return target, aimed, pose, progress, views


def _view_poses(first: jax.Array, following: jax.Array) -> jax.Array:
    """A camera pose per view (V, ...): the centred one `first`, then each re-aligned one (the
    `following` (V, ...) pose each view chose; the last view's choice is never taken)."""
    return jnp.concatenate([first[None], following[:-1]])


def _with_error(pose: GraspPose, key, config: Config) -> GraspPose:
    """The pose the robot reaches: the planned one off by the execution error (TCP: N(0, sigma^2)
    per axis; rotation: N(0, sigma^2) about a uniformly random axis)."""
    k_tcp, k_axis, k_angle = jax.random.split(key, 3)
    p = config.procedure
    tcp = pose.tcp + p.tcp_error * jax.random.normal(k_tcp, (3,))
    axis = normalize(jax.random.normal(k_axis, (3,)))
    turn = axis_angle(axis, jnp.deg2rad(p.tilt_error_deg) * jax.random.normal(k_angle, ()))
    return GraspPose(tcp=tcp, approach=turn @ pose.approach, closing=turn @ pose.closing,
                     valid=pose.valid)


def attempt(scene: Scene, state: RoundState, spec: WorldSpec, k: jax.Array,
            keep_views: bool = False, setups: tuple[int, ...] = (1, 2, 3)
            ) -> tuple[RoundState, Record, Views | None]:
    """Call k of this world's round: k = -1 settles the freshly placed layout; k >= 0 is the
    k-th grasp attempt (steps 1-6). `k` is () int32, the same for every world of a batch.
    `setups` (static): those the batch's worlds may play; a batch of Setup 1 alone records no
    layout density (`NO_LAYOUT`: rounds.csv has rows for Setups 2 and 3 only)."""
    config = spec.config
    model = physics_model(scene, config)
    n = scene.num_objects
    eligible, attempting = eligible_objects(state, spec), round_goes_on(state, spec)
    in_the_bin = in_bin(spec)  # the workspace is the bin's interior (known by calibration)
    finite = jnp.all(jnp.isfinite(state.data.qpos))
    k_search, k_error = attempt_keys(state, k)
    searched = []  # the search's output shapes, recorded by its trace

    def search(_):
        kin = mjx.kinematics(model, state.data)
        target, aimed, pose, progress, views = _search(scene, kin, eligible, attempting,
                                                       in_the_bin, k_search, config, keep_views)
        # The pre-grasp pose must leave the open hand clear of every part, the bin and the table.
        reached = _with_error(pose, k_error, config)
        waypoints, _ = hand_waypoints(scene, reached, config)
        rotation = frame_from_axes(reached.approach, reached.closing)
        clear = hand_clear(scene, kin, waypoints[0], rotation)
        room = jnp.where(reached.valid, finger_clearance(scene, kin, waypoints[1], rotation, target),
                         jnp.nan)
        out = target, aimed, pose, reached, clear, room, progress, views
        searched.append(jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), out))
        return out

    def idle(_):
        # `lax.cond` traces the true branch first, so the search's shapes are known here and
        # the search (most of an attempt's tracing) is traced once; else they cost a trace.
        shapes = searched[-1] if searched else jax.eval_shape(search, None)
        return jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)

    target, aimed, pose, reached, clear, room, progress, views = jax.lax.cond(k >= 0, search, idle,
                                                                             None)
    blocked, turns, detect_reason, align_reason, lost, realign, under, first = progress
    realign = where_tree(k >= 0, realign, jax.tree.map(
        lambda x: jnp.broadcast_to(x, (MAX_REORIENTATIONS,)), NO_PLANE))
    aimed = aimed & (k >= 0)
    target = jnp.where(aimed, target, -1)
    valid = pose.valid & finite & aimed
    pose = dataclasses.replace(pose, valid=valid)
    # The protocol as we read the paper: the experimenter takes a failed object out before the
    # next attempt.
    take_out = aimed & (target >= 0) & config.procedure.remove_failed
    if config.procedure.round_attempts > 0:  # clutter removal leaves it
        take_out = jnp.array(False)
    data, done = simulate(scene, model, state.data, dataclasses.replace(reached, valid=valid),
                          target, settle_segments(spec, k, config), k >= 0, config,
                          reachable=clear, take_out=take_out, drops=drops_of(state, k))

    mine = (jnp.arange(n) == target) & (target >= 0)
    attempted = state.attempted | mine
    failures = jnp.where(aimed, jnp.where(done.outcome == Outcome.SUCCESS, 0,
                                          state.failures + 1), state.failures)
    lifted = (jnp.arange(n) == done.lifted_object) & (done.lifted_object >= 0)
    removed = state.removed | lifted | (mine & take_out)
    crowd = object_clutter(scene, state.data)  # as the robot found the scene (the state before)
    t = jnp.maximum(target, 0)
    clutter = where_tree(target >= 0, TargetClutter(
        touching=crowd.touching[t], resting=crowd.resting[t], covered=crowd.covered[t],
        gap=crowd.gap[t], finger_clearance=room.astype(jnp.float32)), NO_CLUTTER)
    state = RoundState(data=data, attempted=attempted, failures=failures.astype(jnp.int32),
                       removed=removed, key=state.key, drops=drops_of(state, jnp.int32(0)))
    density = layout_stats(scene, data) if {2, 3} & set(setups) else NO_LAYOUT
    return state, _record(target, aimed, pose, done, finite, blocked, turns, detect_reason,
                          align_reason, lost, realign, under, first, density, clutter), views


def _record(target, aimed, pose: GraspPose, done: Execution, finite, blocked, turns,
            detect_reason, align_reason, lost, realign: PlaneTruth, under, first,
            stats: LayoutStats, clutter: TargetClutter) -> Record:
    """The attempt's record, with its one reason (precedence: module docstring)."""
    stopped_by_alignment = blocked & (align_reason >= 0) & (align_reason != AlignReason.FOUND)
    reason = jnp.select(
        [~finite | (done.outcome == Outcome.DIVERGED), pose.valid, ~aimed, lost,
         stopped_by_alignment, blocked],
        [Reason.DIVERGED, done.outcome, Reason.NO_TARGET, Reason.TARGET_LOST,
         ALIGN_BASE + align_reason, Reason.VIEW_UNREACHABLE],
        DETECT_BASE + detect_reason).astype(jnp.int32)
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    precision, recall = first
    return Record(
        target=target.astype(jnp.int32), aimed=aimed, reason=reason, outcome=done.outcome,
        grasp_found=pose.valid, reorientations=turns, detect_reason=detect_reason,
        align_reason=align_reason, lifted_object=done.lifted_object, rise=done.rise,
        opening=done.opening, tcp=jnp.where(pose.valid, pose.tcp, nan3),
        approach=jnp.where(pose.valid, pose.approach, nan3),
        closing=jnp.where(pose.valid, pose.closing, nan3), realign=realign,
        grasp_object=jnp.where(pose.valid, under, -1).astype(jnp.int32),
        segment_precision=jnp.where(aimed, precision, jnp.nan).astype(jnp.float32),
        segment_recall=jnp.where(aimed, recall, jnp.nan).astype(jnp.float32), layout=stats,
        clutter=clutter)
