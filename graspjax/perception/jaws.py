"""The jaws of one grasp checked on the full-resolution real image (one candidate).

The double T-beam is checked on the detection grid: its finger footprints
at the open width leave room to reach the grasp depth. A real capture asks
more of a grasp before a robot tries it, and the full-resolution image can
answer, sample by sample along each jaw's path:

* The gripped part is at least `RealImageConfig.min_width` wide (a 5 mm
  band on a ridge is not a part to grasp): `TOO_NARROW`.
* Each opened jaw's footprint (finger width x thickness, at the open width)
  is free from the top of the object down to the finger tips, and the
  gripped band has sides: within friction x the shallowest grasp depth of
  its edge the part falls at least that depth, on average steeper than the
  pads' friction cone (else the jaws land on the object's own top or on a
  shoulder of it, not beside it), in every lane across the pad's width (a
  ledge under part of a pad holds that jaw up as well); from the first
  surface out that stands above the band's top (a taller neighbour, a wall,
  a step up) nothing further out is the part's fall, seen or unseen (its
  shadow); a stretch the camera does not see (no depth, or hidden by the
  part's own top) is a fall only where the surface seen after it has fallen
  or none is. The fall is judged through the tips' level and through the
  top's, and the worse counts: a camera tilted far to the side of the pads
  sees the tips' level well beside their lanes. Closing at the
  tips' level, each jaw touches the part where it first stands higher than
  the tips, so the jaws may hold a part wider below its top, as a rounded
  one; between the band and the contact there is no gap (a fall below the
  tips, or a rise after a fall: a groove, then something beyond it; either
  way the jaw closes on something else), and the contact width fits the
  opening. Else `JAWS_BLOCKED`.
* With the wall check on (`detect.wall_check`, the realistic preset), the
  side is judged where the jaw touches it, not at the band's top edge: it
  must fall steeper than 90 deg - atan(friction) there (else `NO_WALL`).

A sample is a point at the finger tips' level (for the landing, also at the
top's); the camera ray through it meets the surface at the pixel it projects
to, and the sample's height is that surface point's distance below the grasp
centre along the approach.
Pixels without depth count as free (a real sensor loses edges; the record
says how many there were). `grasp_score` ranks the grasps that pass.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import GraspReason
from graspjax.config import DetectorConfig, GripperConfig, RealImageConfig
from graspjax.perception.cluster import valid_mask
from graspjax.perception.placements import sample_nearest
from graspjax.tree import map_where, pytree_dataclass


@pytree_dataclass
class JawCheck:
    """The full-resolution verdict on one grasp (metres)."""

    reason: jax.Array  # () int32 GraspReason: FOUND, TOO_NARROW, JAWS_BLOCKED or NO_WALL (-1: not
    # checked, `check_jaws_where`; its numbers nan)
    depth: jax.Array  # () finger-tip depth below the grasp centre the jaws can reach
    clearance: jax.Array  # () free height below the finger tips in the checked path (inf: all free)
    landing: jax.Array  # () how far the part falls beside the band, at the worst of both jaws'
    # lanes across the pad's width, the worse of the tips' and the top's level (inf: a lane's
    # fall unseen); kept if >= min_grasp_depth
    contact_width: jax.Array  # () distance between the jaws where they touch the part
    unknown: jax.Array  # () share of the path's samples without depth


def path_heights(depth: jax.Array, camera: Camera, center: jax.Array, axis: jax.Array,
                 approach: jax.Array, across: jax.Array, lateral: jax.Array,
                 level: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Depth below `center` along `approach` of the surface seen through points at `level` below
    it, `across` (A,) along the closing axis on both sides and `lateral` (L,) along the edge:
    heights (2, A, L) (inf: no depth), how far out along the closing axis the ray met the
    surface (2, A, L) (inf: no depth), and which samples had depth (2, A, L)."""
    along = jnp.cross(approach, axis)
    side = jnp.array([1.0, -1.0], jnp.float32)
    points = (center + level * approach
              + side[:, None, None, None] * across[None, :, None, None] * axis
              + lateral[None, None, :, None] * along)  # (2, A, L, 3)
    uv = jnp.round(camera.project(points))
    z, inside = sample_nearest(depth, uv, 0.0)
    seen = inside & valid_mask(z)
    surface = camera.unproject(uv, jnp.where(seen, z, 1.0)) - center
    height = jnp.sum(surface * approach, -1)
    out = side[:, None, None] * jnp.sum(surface * axis, -1)  # where the ray met it, across
    return jnp.where(seen, height, jnp.inf), jnp.where(seen, out, jnp.inf), seen


def _landing(height, out, seen, width, step, pixel, below_top: bool, detect: DetectorConfig,
             gripper: GripperConfig) -> jax.Array:
    """How far the part falls beside the band, at the worst lane of both jaws (m; inf: a lane's
    fall unseen), from one level's samples: heights, where their rays met the surface and which
    had depth (2, A, L); width: the band's; step: between samples; pixel: a pixel's size at the
    grasp (m); below_top: the samples lie below the band's top (the tips' level).

    The band has sides: the part falls at least the shallowest grasp depth within friction x
    that depth of the band's edge (on average steeper than the pads' friction cone); else the
    band tops a mound or a shoulder, and the jaws land on the part. Judged where each ray met
    the surface (a tilted ray meets it nearer or farther out than its sample). What the rays do
    not show is a stretch between two surface points seen one after the other along the lane
    (samples without depth, or rays that all meet the part's own top: the far side of a tall
    part seen by a tilted camera), wider than the samples and pixels leave on a surface seen
    throughout; it is a drop where it begins within that reach and the surface seen after it
    has fallen the shallowest grasp depth, or where nothing is seen after it. Seen again less
    deep, the top went on past the band's edge (a specular strip, or a top level with the band
    under part of a pad). Every lane across the pad's width must fall: one lane on a ledge
    holds the jaw up. From the first sample out that stands above the band's top (a taller
    neighbour, a wall or a step up) the lane no longer shows the part's side: a fall seen
    beyond it, or a stretch unseen there (the taller surface's shadow), is not a landing.
    """
    reach_out = width / 2 + detect.min_grasp_depth * gripper.friction
    unseen_gap = 2 * step + pixel  # two samples and a pixel
    farthest = jnp.maximum(width / 2, jax.lax.cummax(jnp.where(seen, out, -jnp.inf), axis=1))
    before = jnp.concatenate([jnp.full_like(farthest[:, :1], width / 2), farthest[:, :-1]],
                             axis=1)  # (2, A, L) farthest out seen before each sample (the edge)
    risen = seen & (height < -detect.surface_tolerance)
    beyond = jnp.cumsum(risen, axis=1) > 0  # (2, A, L) at or past the lane's first risen sample
    # Below the top, the first sample's ray may meet the side well out from the edge on the side
    # facing the camera, seen by rays inside the band's width that are not sampled: it ends no
    # stretch. At the top's level it meets the band's edge (or, grazing it, what lies beyond).
    first = (jnp.arange(height.shape[1]) == 0) & below_top
    unseen_drop = (seen & (out - before > unseen_gap) & (before <= reach_out)
                   & (height >= detect.min_grasp_depth) & ~first[:, None])
    fall = jnp.where(beyond, -jnp.inf, jnp.where(
        unseen_drop, jnp.inf, jnp.where(out <= reach_out, height, -jnp.inf)))  # out: inf unseen
    open_end = (~seen[:, -1] & (farthest[:, -1] <= reach_out)
                & ~jnp.any(risen, 1))  # (2, L) unseen to the lane's end
    return jnp.min(jnp.where(open_end, jnp.inf, jnp.max(fall, 1)))


def check_jaws(depth: jax.Array, camera: Camera, center: jax.Array, axis: jax.Array,
               approach: jax.Array, width: jax.Array, detect: DetectorConfig,
               gripper: GripperConfig, image: RealImageConfig) -> JawCheck:
    """Check one grasp's jaws on the full-resolution image.

    depth: metric depth (H, W) of `camera`, 0 or nan = invalid; center: grasp centre G on the
    top surface (3,), camera frame; axis: unit closing axis (3,); approach: unit approach (3,),
    into the scene; width: the gripped band's width c (m). Pure; vmap it over candidates.
    """
    samples, lanes = image.jaw_samples, image.jaw_lanes
    wanted = jnp.minimum(detect.grasp_depth, gripper.finger_length)
    outer = gripper.opening / 2 + gripper.finger_thickness
    fraction = jnp.asarray(np.linspace(0.0, 1.0, samples), jnp.float32)
    across = width / 2 + fraction * (outer - width / 2)  # (A,) band edge -> outer jaw face
    step = (outer - width / 2) / (samples - 1)
    lateral = jnp.asarray(np.linspace(-0.5, 0.5, lanes), jnp.float32) * gripper.finger_width
    height, out, seen = path_heights(depth, camera, center, axis, approach, across, lateral, wanted)
    top = jnp.min(height, -1)  # (2, A) the highest surface across the finger

    # Down: the open jaws' footprints free to below the finger tips.
    footprint = across >= gripper.opening / 2
    free = jnp.min(jnp.where(footprint, top, jnp.inf))
    reach = jnp.minimum(wanted, free - detect.depth_clearance)
    # The band has sides (`_landing`), seen through the tips' level and through the top's: at a
    # steep view the rays through the tips' level meet the surface far to the side of the
    # pad's lanes, where it may already have fallen; through the top's level they meet a top
    # that goes on near the lane.
    index = jnp.arange(samples)
    at_top = path_heights(depth, camera, center, axis, approach, across, lateral, jnp.float32(0))
    landing = jnp.minimum(
        _landing(height, out, seen, width, step, center[2] / camera.fx, True, detect, gripper),
        _landing(*at_top, width, step, center[2] / camera.fx, False, detect, gripper))
    sides = landing >= detect.min_grasp_depth
    # Closing at the tips' level: each jaw touches the part where it first stands higher than
    # the tips, with no gap between the band and the contact: no fall below the tips, and no
    # rise after a fall (a groove, then something beyond it); else it closes on something else.
    above = top < reach  # (2, A)
    last = jnp.max(jnp.where(above, index, 0), -1)  # (2,) the outermost sample above the tips
    contact_width = width + jnp.sum(last) * step
    deepest = jax.lax.cummax(jnp.where(jnp.isfinite(top), top, -jnp.inf), axis=1)
    rises = top[:, 1:] < deepest[:, :-1] - detect.surface_tolerance  # (2, A - 1)
    gap = (jnp.any((index < last[:, None]) & (top > reach + detect.surface_tolerance))
           | jnp.any((index[1:] <= last[:, None]) & rises))
    fits = contact_width <= gripper.opening - 2 * detect.clearance
    # The wall where the jaws touch (`wall_check`): over `run` samples each side of the contact
    # the side falls at least 1 / friction per unit of run (its normal in the pads' cone).
    run = 2
    outside = jnp.clip(last + run, 0, samples - 1)
    inside = jnp.clip(last - run, 0, samples - 1)
    lower = jnp.take_along_axis(top, outside[:, None], -1)[:, 0]
    upper = jnp.take_along_axis(top, inside[:, None], -1)[:, 0]
    touches = jnp.any(above, -1)  # (2,) else the side falls away inside the band's edge
    steep = ~touches | jnp.isinf(lower) | ((lower - upper) >= (outside - inside) * step
                                           / gripper.friction)

    blocked = (reach < detect.min_grasp_depth) | ~sides | gap | ~fits
    no_wall = detect.wall_check & ~jnp.all(steep)
    reason = jnp.select([width < image.min_width, blocked, no_wall],
                        [GraspReason.TOO_NARROW, GraspReason.JAWS_BLOCKED, GraspReason.NO_WALL],
                        GraspReason.FOUND).astype(jnp.int32)
    return JawCheck(reason=reason, depth=reach, clearance=free - reach, landing=landing,
                    contact_width=contact_width, unknown=jnp.mean(~seen))


_JAW_CHUNK = 8  # grasps checked per loop step on a CPU (`check_jaws_where`)


def check_jaws_where(placed: jax.Array, depth: jax.Array, camera: Camera, center: jax.Array,
                     axis: jax.Array, approach: jax.Array, width: jax.Array,
                     detect: DetectorConfig, gripper: GripperConfig, image: RealImageConfig
                     ) -> JawCheck:
    """`check_jaws` on the grasps (centres, axes (N, 3), widths (N,)) where `placed` (N,) bool,
    `_JAW_CHUNK` at a time with `detect.checks_in_chunks` (a CPU's programs: a target often
    has fewer placements than are checked), else all at once; elsewhere reason -1 and nan."""
    n = placed.shape[0]
    nan = jnp.full(n, jnp.nan, jnp.float32)
    return map_where(
        jax.vmap(lambda c, a, w: check_jaws(depth, camera, c, a, approach, w, detect, gripper, image)),
        placed, _JAW_CHUNK if detect.checks_in_chunks else None,
        JawCheck(reason=jnp.full(n, -1, jnp.int32), depth=nan, clearance=nan, landing=nan,
                 contact_width=nan, unknown=nan),
        center, axis, width)


def grasp_score(check: JawCheck, width, centre_distance, detect, gripper, image) -> jax.Array:
    """A passing grasp's rank, each term in [0, 1]: free height below the tips (capped at 1 cm),
    width margin to the narrowest and widest allowed (capped at a quarter of the opening), less
    the distance from the part's centre in half-openings (a central grasp pushes it least)."""
    clear = jnp.minimum(check.clearance, 0.01) / 0.01
    margin = jnp.minimum(width - image.min_width,
                         gripper.opening - 2 * detect.clearance - check.contact_width)
    quarter = gripper.opening / 4
    return clear + jnp.clip(margin, 0.0, quarter) / quarter - centre_distance / (gripper.opening / 2)
