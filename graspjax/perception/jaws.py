"""The jaws of one grasp on a real image, as one physical model: each finger sweeps a box down
a height map of the scene.

A real capture asks of a grasp what its jaws do on their way down. Both are read from one
height map of the scene, built once per image (`height_map`): every full-resolution point,
in the view the grasps are approached along (its +z axis; the virtual view when the support is
turned), falls into a square cell of an orthographic grid, and the cell keeps the least depth
along the approach of its points (the highest surface). The grid has the detection view's
shape and principal point, its cells that view's pixel at the workspace's median depth, so one
cell is about one detection pixel there (a turned view's real pixels fall farther apart than
its cells, by up to 1 / cos^2 of the turn along it: the cells between read by the rule
below). Shadows and holes, where no point falls, follow one rule: an unseen cell lies at the
deepest level seen within `image.sweep_fill_px` cells of it (a dropout at an edge takes the
floor beside it, a hole in a top the top around it); with none seen that near, and off the
grid, on the support plane. Without a support plane nothing is known there, and the jaws do
not go.

`check_jaws` judges one grasp on the map (centre on the top, closing axis, the band's width):

* Each finger's footprint (its width x thickness, at the open width) sweeps straight down
  along the approach: it can go as deep as the highest surface under it allows, less
  `detect.depth_clearance`, and no deeper than `min(grasp_depth, finger_length)`. Shallower
  than `min_grasp_depth`: `JAWS_BLOCKED` (a neighbour in the way, a tote's wall, the part's own
  top or shoulder under the finger).
* At that depth the jaws close. Along each lane across the pads' width, from the centre out to
  the inner face, what stands above the finger tips must be one piece with the grasped band: a
  fall below the tips (two samples seen in a row) and then a rise (a groove and something
  beyond it, a second part between the jaws) means the jaw closes on something else:
  `JAWS_BLOCKED`; unless what rises is joined to the band above the tips through the other
  lanes (a groove of the part itself, a gear's teeth). Each jaw touches where
  its lanes last stand above the tips, and there it closes on a side: within friction x the
  depth reached of the band's edge (the part falls to the tips no more gently, on average,
  than the pads' friction cone), else it comes down on a slope or a shoulder of the part. The
  distance between the touches must fit the opening less `detect.clearance` each side. Else
  `JAWS_BLOCKED`.
* With `detect.wall_check` (the realistic preset) the side falls, where the jaw touches it, at
  least 1 / friction per unit of run (its normal in the pads' cone): else `NO_WALL`.

Written for one image's map and one grasp; `jax.vmap` over grasps.
"""

from __future__ import annotations

import dataclasses
import enum

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import GraspReason
from graspjax.config import Config, DetectorConfig, GripperConfig, RealImageConfig
from graspjax.perception.cluster import valid_mask
from graspjax.perception.placements import Grasp, TBeams, sample_nearest
from graspjax.perception.reasons import furthest_reason
from graspjax.perception.support import SupportPlane
from graspjax.tree import map_where, pytree_dataclass


@pytree_dataclass
class HeightMap:
    """One image's scene along the approach (the view frame's +z), on an orthographic grid."""

    depth: jax.Array  # (N, M) least depth along the approach in each cell, unseen cells filled
    # (`height_map`'s rule); -inf: nothing known there, the jaws do not go
    seen: jax.Array  # (N, M) bool: a point fell in the cell
    cell: jax.Array  # () a cell's side (m)
    centre: jax.Array  # (2,) the cell coordinates (column, row) of the view's optical axis
    support: SupportPlane  # the support plane in the view frame (found or not)

    def cells(self, xy: jax.Array) -> jax.Array:
        """View-frame positions `(..., 2)` (m, across the approach) -> cell coordinates `(..., 2)`
        (column, row), float."""
        return xy / self.cell + self.centre

    def floor(self, xy: jax.Array) -> jax.Array:
        """The support plane's depth along the approach at view-frame positions `(..., 2)`;
        -inf where there is none (not found, or facing away from the approach)."""
        normal = self.support.normal
        facing = self.support.found & (normal[2] < -1e-3)
        depth = -(self.support.distance + xy @ normal[:2]) / jnp.minimum(normal[2], -1e-3)
        return jnp.where(facing & (depth > 0), depth, -jnp.inf)

    def lookup(self, xy: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The depth and whether it was seen at view-frame positions `(..., 2)`: `(...)` each; a
        position off the grid reads as unseen, on the support plane."""
        cells = self.cells(xy)
        depth, _ = sample_nearest(self.depth, cells, self.floor(xy))
        seen, _ = sample_nearest(self.seen, cells, False)
        return depth, seen


def height_map(depth: jax.Array, camera: Camera, rotation: jax.Array, view: Camera,
               reference: jax.Array, support: SupportPlane, fill_px: int) -> HeightMap:
    """The height map of one image along its view's approach.

    depth: metric depth (H, W) of `camera` (0 or nan: none); rotation: (3, 3) view-to-camera;
    view: the detection view's intrinsics (its shape and principal point); reference: () the
    depth along the approach where a cell is one of `view`'s pixels (the workspace's median:
    there the grid covers what the view shows); support: the support plane in the view frame;
    fill_px: the reach of the rule for unseen cells (cells). Returns `HeightMap`
    (view.height, view.width).
    """
    valid = valid_mask(depth)
    points = camera.unproject(camera.pixel_grid(), jnp.where(valid, depth, 1.0)) @ rotation
    cell = jnp.where(jnp.isfinite(reference) & (reference > 0), reference, 1.0) / view.fx
    centre = jnp.array([view.cx, view.cy], jnp.float32)
    grid = HeightMap(depth=jnp.zeros((view.height, view.width), jnp.float32),
                     seen=jnp.zeros((view.height, view.width), bool), cell=cell, centre=centre,
                     support=support)
    ij = jnp.round(grid.cells(points[..., :2])).astype(jnp.int32)
    inside = (valid & (ij[..., 0] >= 0) & (ij[..., 0] < view.width) & (ij[..., 1] >= 0)
              & (ij[..., 1] < view.height))
    flat = jnp.where(inside, ij[..., 1] * view.width + ij[..., 0], view.height * view.width)
    nearest = jnp.full(view.height * view.width, jnp.inf, jnp.float32).at[flat.ravel()].min(
        points[..., 2].ravel(), mode="drop").reshape(view.height, view.width)
    seen = jnp.isfinite(nearest)
    # Unseen: the deepest level seen within fill_px cells, else on the support plane (else
    # nothing is known: blocked).
    side = 2 * fill_px + 1
    around = jnp.where(seen, nearest, -jnp.inf)
    for window in ((side, 1), (1, side)):  # the square's maximum, one axis at a time
        around = jax.lax.reduce_window(around, -jnp.inf, jax.lax.max, window, (1, 1), "SAME")
    floor = grid.floor((view.pixel_grid() - centre) * cell)
    filled = jnp.where(seen, nearest, jnp.where(jnp.isfinite(around), around, floor))
    return dataclasses.replace(grid, depth=filled, seen=seen)


class JawRule(enum.IntFlag):
    """The rules of `check_jaws` a grasp fails (`JawCheck.failed`, a bitmask)."""

    REACH = 1  # a finger lands shallower than `detect.min_grasp_depth`
    GAP = 2  # a fall below the tips, then a rise: something else between the jaws
    WIDE = 4  # the touches do not fit the opening less the clearance
    SIDES = 8  # a jaw touches beyond friction x reach of the band's edge (a slope, a shoulder)
    WALL = 16  # with `detect.wall_check`: the side where a jaw touches is not steep enough


@pytree_dataclass
class JawCheck:
    """`check_jaws`'s verdict on one grasp (metres)."""

    reason: jax.Array  # () int32 GraspReason: FOUND, TOO_NARROW, JAWS_BLOCKED or NO_WALL (-1: not
    # checked, `check_jaws_where`; its numbers nan)
    depth: jax.Array  # () finger-tip depth below the grasp centre the jaws reach (-inf: nothing
    # known under a footprint, no support plane)
    clearance: jax.Array  # () free height below the finger tips under the footprints
    landing: jax.Array  # () depth below the centre of the highest surface under either
    # footprint, where the fingers land (-inf: nothing known there)
    contact_width: jax.Array  # () distance between the jaws where they touch the part
    unknown: jax.Array  # () share of the samples in unseen cells
    failed: jax.Array  # () int32 `JawRule` bitmask of the rules failed (0: none; -1: not checked)


def check_jaws(heights: HeightMap, center: jax.Array, axis: jax.Array, width: jax.Array,
               detect: DetectorConfig, gripper: GripperConfig, image: RealImageConfig) -> JawCheck:
    """Both fingers swept down `heights` for one grasp: centre G on the top (3,) and unit
    closing axis (3,), view frame (the approach +z; the axis's z is ignored), the gripped
    band's width (m). Pure; vmap it over grasps."""
    samples, lanes = image.jaw_samples, image.jaw_lanes
    inner = gripper.opening / 2
    outer = inner + gripper.finger_thickness
    a = axis[:2] / jnp.maximum(jnp.linalg.norm(axis[:2]), 1e-9)
    b = jnp.stack([-a[1], a[0]])
    across = jnp.asarray(np.linspace(0.0, 1.0, samples), jnp.float32) * outer  # (A,) out from G
    step = outer / (samples - 1)
    lateral = jnp.asarray(np.linspace(-0.5, 0.5, lanes), jnp.float32) * gripper.finger_width
    side = jnp.array([1.0, -1.0], jnp.float32)
    xy = (center[:2] + side[:, None, None, None] * across[None, :, None, None] * a
          + lateral[None, None, :, None] * b)  # (2, A, L, 2)
    z, seen = heights.lookup(xy)
    below = z - center[2]  # (2, A, L) depth under G of the highest surface at each sample

    # Down: each footprint's highest surface.
    foot = (across >= inner)[None, :, None]
    fall = jnp.min(jnp.where(foot, below, jnp.inf))
    wanted = jnp.minimum(detect.grasp_depth, gripper.finger_length)
    reach = jnp.minimum(wanted, fall - detect.depth_clearance)
    # Closing at the tips: above them, one piece from the centre out along every lane.
    above = below < reach  # (2, A, L)
    index = jnp.arange(samples)[None, :, None]
    last = jnp.max(jnp.where(above & ~foot, index, 0), axis=1)  # (2, L) the touch, per lane
    fallen = seen & ~above  # seen below the tips; a fall is two such samples in a row
    fall_run = fallen & jnp.concatenate([fallen[:, 1:], jnp.zeros_like(fallen[:, :1])], axis=1)
    # ... unless what the lane meets there is one piece with the band, joined to it above the
    # tips through the other lanes (a groove of the part, a gear's teeth)
    joined = _joined(above & ~foot, _JOINED_UNROLLED_STEPS if detect.unrolled_loops else 1)
    touch_joined = jnp.take_along_axis(joined, last[:, None, :], axis=1)[:, 0, :]  # (2, L)
    gap = jnp.any(jnp.any(fall_run & (index < last[:, None, :] - 1), axis=1) & ~touch_joined)
    touch = jnp.max(last, axis=1)  # (2,) each jaw touches at its outermost lane
    contact_width = jnp.sum(touch.astype(jnp.float32)) * step
    fits = contact_width <= gripper.opening - 2 * detect.clearance
    # ... on a side: within friction x the depth reached of the band's edge (on average no
    # gentler than the pads' friction cone), else the jaw comes down on a slope or shoulder.
    sides = jnp.all(touch * step <= width / 2 + gripper.friction * reach + step)
    # The wall where each jaw touches (`wall_check`): over `run` samples out and in of it the
    # pad's highest surface across its lanes falls at least 1 / friction per unit of run.
    run = 2
    profile = jnp.min(below, axis=2)  # (2, A) the highest across the pad
    out = jnp.clip(touch + run, 0, samples - 1)
    inside = jnp.clip(touch - run, 0, samples - 1)
    lower = jnp.take_along_axis(profile, out[:, None], -1)[:, 0]
    upper = jnp.take_along_axis(profile, inside[:, None], -1)[:, 0]
    steep = jnp.isinf(lower) | ((lower - upper) >= (out - inside) * step / gripper.friction)

    rules = jnp.stack([reach < detect.min_grasp_depth, gap, ~fits, ~sides,
                       detect.wall_check & ~jnp.all(steep)])
    failed = jnp.sum(rules * jnp.array([int(r) for r in JawRule], jnp.int32))
    blocked, no_wall = jnp.any(rules[:4]), rules[4]
    reason = jnp.select([width < image.min_width, blocked, no_wall],
                        [GraspReason.TOO_NARROW, GraspReason.JAWS_BLOCKED, GraspReason.NO_WALL],
                        GraspReason.FOUND).astype(jnp.int32)
    return JawCheck(reason=reason, depth=reach,
                    clearance=jnp.where(jnp.isfinite(reach), fall - reach, fall), landing=fall,
                    contact_width=contact_width, unknown=jnp.mean(~seen),
                    failed=failed.astype(jnp.int32))


def _joined(region: jax.Array, steps_per_iteration: int) -> jax.Array:
    """The samples of `region` (2, A, L) (side, out from the centre, lane) joined to the
    centre's (index 0) through 4-neighbours in `region`, each side apart; grown
    `steps_per_iteration` steps per loop iteration (steps after the last change change
    nothing)."""
    def grow(state):
        _, joined = state
        out = jnp.pad(joined[:, :-1], ((0, 0), (1, 0), (0, 0)))
        back = jnp.pad(joined[:, 1:], ((0, 0), (0, 1), (0, 0)))
        left = jnp.pad(joined[:, :, :-1], ((0, 0), (0, 0), (1, 0)))
        right = jnp.pad(joined[:, :, 1:], ((0, 0), (0, 0), (0, 1)))
        return joined, (joined | out | back | left | right) & region

    def steps(state):
        for _ in range(steps_per_iteration):
            state = grow(state)
        return state

    seeds = region & (jnp.arange(region.shape[1]) == 0)[None, :, None]
    return jax.lax.while_loop(lambda state: jnp.any(state[0] != state[1]), steps,
                              (jnp.zeros_like(region), seeds))[1]


_JAW_CHUNK = 8  # grasps checked per loop step on a CPU (`check_jaws_where`)
_JOINED_UNROLLED_STEPS = 4  # `_joined`'s steps per loop iteration with `detect.unrolled_loops`


def check_jaws_where(placed: jax.Array, heights: HeightMap, center: jax.Array, axis: jax.Array,
                     width: jax.Array, detect: DetectorConfig, gripper: GripperConfig,
                     image: RealImageConfig) -> JawCheck:
    """`check_jaws` on the grasps (view frame: centres, axes (N, 3), widths (N,)) where `placed`
    (N,) bool,
    `_JAW_CHUNK` at a time with `detect.checks_in_chunks` (a CPU's programs: a target often
    has fewer placements than are checked), else all at once; elsewhere reason -1 and nan."""
    n = placed.shape[0]
    nan = jnp.full(n, jnp.nan, jnp.float32)
    return map_where(
        jax.vmap(lambda c, a, w: check_jaws(heights, c, a, w, detect, gripper, image)),
        placed, _JAW_CHUNK if detect.checks_in_chunks else None,
        JawCheck(reason=jnp.full(n, -1, jnp.int32), depth=nan, clearance=nan, landing=nan,
                 contact_width=nan, unknown=nan, failed=jnp.full(n, -1, jnp.int32)),
        center, axis, width)


def check_placements_at(placed: jax.Array, heights: HeightMap, cands: TBeams, index: jax.Array,
                        detect: DetectorConfig, gripper: GripperConfig,
                        image: RealImageConfig) -> JawCheck:
    """`check_jaws_where` on a method's placements `cands` (view frame) at `index` (N,), where
    `placed` (N,) bool."""
    return check_jaws_where(placed, heights, cands.center[index],
                            jnp.pad(cands.axis[index], ((0, 0), (0, 1))), cands.width[index],
                            detect, gripper, image)


def grasp_score(check: JawCheck, width, centre_distance, detect, gripper, image) -> jax.Array:
    """A passing grasp's rank, each term in [0, 1]: free height below the tips (capped at 1 cm),
    width margin to the narrowest and widest allowed (capped at a quarter of the opening), less
    the distance from the part's centre in half-openings (a central grasp pushes it least)."""
    clear = jnp.minimum(check.clearance, 0.01) / 0.01
    margin = jnp.minimum(width - image.min_width,
                         gripper.opening - 2 * detect.clearance - check.contact_width)
    quarter = gripper.opening / 4
    return clear + jnp.clip(margin, 0.0, quarter) / quarter - centre_distance / (gripper.opening / 2)


def sweep_placements(grasp: Grasp, depth: jax.Array, camera: Camera, support: SupportPlane,
                     config: Config) -> tuple[jax.Array, jax.Array, JawCheck]:
    """A method's placements on one simulated view swept down the view's height map
    (`admit_by_jaws`, whose arguments these are): the `image.candidates_per_target` valid ones
    nearest the method's choice, the choice first. Returns their indices in
    `grasp.candidates` (N,), whether each was checked (N,) and their `JawCheck` (N,)."""
    cands = grasp.candidates
    image = dataclasses.replace(config.image, min_width=0.0)  # widths: the method's own check
    heights = height_map(depth, camera, jnp.eye(3, dtype=jnp.float32), camera,
                         grasp.surface_depth, support, image.sweep_fill_px)
    chosen = cands.center[jnp.maximum(grasp.index, 0), :2]
    offset = jnp.where(cands.valid, jnp.linalg.norm(cands.center[:, :2] - chosen, axis=-1),
                       jnp.inf)
    count = min(image.candidates_per_target, offset.shape[0])
    _, index = jax.lax.top_k(-offset, count)  # nearest first: the method's choice leads
    placed = cands.valid[index] & grasp.found
    return index, placed, check_placements_at(placed, heights, cands, index, config.detect,
                                              config.gripper, image)


def admit_by_jaws(grasp: Grasp, depth: jax.Array, camera: Camera, support: SupportPlane,
                  config: Config) -> Grasp:
    """The simulated procedure's use of the jaws' check (`detect.jaw_sweep`): a method's grasp
    on one view, its placements swept down the view's height map as `graspjax detect` sweeps
    them.

    depth: the view's metric depth (H, W) of `camera`, which looks along the approach (the
    view frame is the camera frame); support: the table in that frame (`known_support`). The
    map's cells are the camera's pixels at the target's surface depth. Of the method's
    admitted placements, the `image.candidates_per_target` nearest its own choice are checked
    (the choice first); the nearest that passes is the grasp, at the depth its jaws reach.
    None passing: not found, the furthest check reached (`JAWS_BLOCKED` or `NO_WALL`). The
    sweep only refuses: a view without a grasp keeps its own reason; its candidates' reasons
    and validity say what the sweep made of the placements it checked.
    """
    cands = grasp.candidates
    index, placed, jaws = sweep_placements(grasp, depth, camera, support, config)
    passed = placed & (jaws.reason == GraspReason.FOUND)
    first = jnp.argmax(passed)
    found = passed[first]
    pick = index[first]
    reason = jnp.where(found, GraspReason.FOUND,
                       jnp.where(jnp.any(placed), furthest_reason(jaws.reason, placed),
                                 grasp.reason)).astype(jnp.int32)
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    return dataclasses.replace(
        grasp, found=found, reason=reason,
        position=jnp.where(found, cands.center[pick], nan3),
        closing_axis=jnp.where(found, jnp.append(cands.axis[pick], 0.0), nan3),
        width=jnp.where(found, cands.width[pick], jnp.nan),
        depth=jnp.where(found, jaws.depth[first], jnp.nan),
        pixel=jnp.where(found, cands.pixel[pick], jnp.nan),
        index=jnp.where(found, pick, -1).astype(jnp.int32),
        candidates=dataclasses.replace(
            cands, valid=cands.valid.at[index].set(passed),
            reason=cands.reason.at[index].set(jnp.where(placed, jaws.reason, cands.reason[index]))))
