"""The placement of an open parallel-jaw hand on one depth image, shared by every grasp method
(`grasp.py`'s double T-beam and `baselines.py`): a method proposes where the jaws go (a centre
on the target's surface, a closing axis, a width); `check_placements` sends each proposal
through the same checks (the fingers' outer corners outside the target's surface, both finger
footprints in view, room below them to reach the grasp depth, with `detect.wall_check` the
gripped sides steep enough for the pads), and `assemble` turns the checked proposals into a
`Grasp`. A new method uses these, as `baselines.py` does.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import GraspReason, names
from graspjax.config import DetectorConfig, GripperConfig
from graspjax.perception.contour import Edges
from graspjax.perception.reasons import furthest_reason
from graspjax.tree import map_where, pytree_dataclass


@pytree_dataclass
class TBeams:
    """Every T-beam placement: edge i's centre with partner edge j, flattened to M = K*K."""

    center: jax.Array  # (M, 3) grasp centre G in the camera frame (on the surface plane)
    pixel: jax.Array  # (M, 2) G in pixel coordinates (u, v)
    axis: jax.Array  # (M, 2) closing axis in the image plane (outward normal of edge i)
    width: jax.Array  # (M,) distance c between the two antipodal edges (m)
    depth: jax.Array  # (M,) reachable finger-tip depth below the surface (m; nan: not admissible)
    reason: jax.Array  # (M,) int32 GraspReason of this placement
    valid: jax.Array  # (M,) bool, reason == FOUND


@pytree_dataclass
class Grasp:
    """Result of `detect_grasp` for one image (camera frame, metres)."""

    found: jax.Array  # () bool
    reason: jax.Array  # () int32 GraspReason
    position: jax.Array  # (3,) grasp centre G on the target surface
    closing_axis: jax.Array  # (3,) unit, perpendicular to the optical axis
    approach: jax.Array  # (3,) unit approach direction (the optical axis, +z)
    width: jax.Array  # () distance between the two antipodal edges (m)
    depth: jax.Array  # () finger-tip depth below the surface to grasp at (m)
    surface_depth: jax.Array  # () mean depth of the target surface cluster (m)
    pixel: jax.Array  # (2,) G in pixel coordinates (u, v)
    nearest: jax.Array  # (2,) int32 pixel of z_min (u, v)
    index: jax.Array  # () int32 chosen placement in `candidates`, -1 if none
    surface_pixels: jax.Array  # () int32 pixels in the surface cluster
    contour_closed: jax.Array  # () bool, False if the contour hit `max_contour`
    edges: Edges  # the straight edges (K)
    candidates: TBeams  # every placement proposed: the T-beam's K*K (a baseline's own; in
    # `detect_real_image`, with the contour search, its antipodal pairs after them)

    @property
    def reason_name(self):
        """`reason` by name (`GraspReason`): a str, or an array of str for a batch; on the host."""
        return names(GraspReason, self.reason)


def sample_nearest(image: jax.Array, uv: jax.Array, fill) -> tuple[jax.Array, jax.Array]:
    """Nearest-pixel lookup of `image` at float pixel coordinates `(..., 2)`; returns (value, inside)."""
    height, width = image.shape
    iuv = jnp.round(uv).astype(jnp.int32)
    inside = ((iuv[..., 0] >= 0) & (iuv[..., 0] < width)
              & (iuv[..., 1] >= 0) & (iuv[..., 1] < height))
    value = image[jnp.clip(iuv[..., 1], 0, height - 1), jnp.clip(iuv[..., 0], 0, width - 1)]
    return jnp.where(inside, value, fill), inside


def _beam_points(center, axis, across, lateral):
    """Points `(..., P, 2)` in the T-beam frame: `across` `(..., P)` along the closing axis and
    `lateral` `(P,)` along the edge, from `center` `(..., 2)`."""
    along = jnp.stack([-axis[..., 1], axis[..., 0]], axis=-1)
    return (center[..., None, :] + across[..., None] * axis[..., None, :]
            + jnp.asarray(lateral, jnp.float32)[:, None] * along[..., None, :])


def _finger_points(center, axis, gripper: GripperConfig, samples: int):
    """Outer corners `(..., 4, 2)` and footprint grids `(..., 2*samples^2, 2)` of both fingers."""
    inner, outer = gripper.opening / 2, gripper.opening / 2 + gripper.finger_thickness
    half_w = gripper.finger_width / 2
    corners = np.array([(side * outer, lateral) for side in (1.0, -1.0)
                        for lateral in (half_w, -half_w)], np.float32)
    a = np.linspace(inner, outer, samples)
    b = np.linspace(-half_w, half_w, samples)
    grid = np.array([(side * x, y) for side in (1.0, -1.0) for x in a for y in b], np.float32)
    return (_beam_points(center, axis, jnp.asarray(corners[:, 0]), corners[:, 1]),
            _beam_points(center, axis, jnp.asarray(grid[:, 0]), grid[:, 1]))


def _wall_points(center, axis, offset, gripper: GripperConfig, samples: int):
    """Points `(..., 2*samples, 2)` at `offset` `(...)` from `center` on both sides along `axis`,
    spread over the finger width."""
    lateral = np.tile(np.linspace(-gripper.finger_width / 2, gripper.finger_width / 2, samples), 2)
    side = jnp.asarray(np.repeat([1.0, -1.0], samples), jnp.float32)
    return _beam_points(center, axis, side * offset[..., None], lateral)


def _to_pixels(xy: jax.Array, camera: Camera, z_s: jax.Array) -> jax.Array:
    """Metric points `(..., 2)` on the surface plane at depth `z_s` -> pixels `(..., 2)`."""
    return jnp.stack([camera.fx * xy[..., 0] / z_s + camera.cx,
                      camera.fy * xy[..., 1] / z_s + camera.cy], axis=-1)


def surface_xy(camera: Camera, z_s: jax.Array) -> jax.Array:
    """Every pixel's metric position `(H, W, 2)` on the surface plane at depth `z_s`."""
    uv = camera.pixel_grid()
    return jnp.stack([(uv[..., 0] - camera.cx) * z_s / camera.fx,
                      (uv[..., 1] - camera.cy) * z_s / camera.fy], -1)


_CHECK_CHUNK = 64  # admissible placements checked per loop step on a CPU (`check_placements`)


def check_placements(depth: jax.Array, valid: jax.Array, cluster: jax.Array, z_s: jax.Array,
                      camera: Camera, g_xy: jax.Array, axis: jax.Array, c: jax.Array,
                      admissible: jax.Array, config: DetectorConfig, gripper: GripperConfig
                      ) -> tuple[jax.Array, jax.Array]:
    """Check open-hand placements on the target surface (the band `cluster` at depth `z_s`),
    for any grasp method: centres `g_xy` `(..., 2)` (metric, on the surface plane), unit
    closing axes `axis` `(..., 2)`, widths `c` `(...)` between the two contacts (m), and
    whether the method's own test passed (`admissible` `(...)`, else NO_ANTIPODAL); the same
    leading shape `(...)` for all.

    Returns each placement's `GraspReason` `(...)` (the first check it fails, in stage order)
    and the finger-tip depth it can reach below the surface `(...)` (m; nan where not
    admissible). With `config.checks_in_chunks` (a CPU's programs) only the admissible
    placements are checked, `_CHECK_CHUNK` at a time (most of a T-beam's edge pairs do not face
    each other); else all at once.
    """
    below_surface = jnp.where(valid, depth - z_s, jnp.inf)  # free depth under the top (H, W)
    edge = jnp.max(jnp.where(cluster, depth, -jnp.inf)) - z_s  # the band's edge below its mean
    n = c.size
    reason, reach = map_where(
        lambda g, a, w: _check(below_surface, edge, cluster, z_s, camera, g, a, w, config, gripper),
        admissible.reshape(-1), _CHECK_CHUNK if config.checks_in_chunks else None,
        (jnp.full(n, GraspReason.NO_ANTIPODAL, jnp.int32), jnp.full(n, jnp.nan, jnp.float32)),
        g_xy.reshape(-1, 2), axis.reshape(-1, 2), c.reshape(-1))
    return reason.reshape(c.shape), reach.reshape(c.shape)


def _check(below_surface, edge, cluster, z_s, camera: Camera, g_xy, axis, c,
           config: DetectorConfig, gripper: GripperConfig) -> tuple[jax.Array, jax.Array]:
    """`check_placements` on N admissible placements (centres, axes (N, 2), widths (N,)), given
    the free depth under the top `below_surface` (H, W) and the band's `edge` (): their reasons
    and reach (N,)."""
    wide_enough = c >= config.min_width
    fits = c <= gripper.opening - 2 * config.clearance
    corners, footprint = _finger_points(g_xy, axis, gripper, config.finger_samples)
    corner_in_cluster, corner_inside = sample_nearest(cluster, _to_pixels(corners, camera, z_s), False)
    free, foot_inside = sample_nearest(below_surface, _to_pixels(footprint, camera, z_s), jnp.inf)
    in_view = jnp.all(corner_inside, -1) & jnp.all(foot_inside, -1)
    collision = jnp.any(corner_in_cluster, -1)
    wanted = jnp.minimum(config.grasp_depth, gripper.finger_length)  # no deeper than the fingers
    reach = jnp.minimum(wanted, jnp.min(free, -1) - config.depth_clearance)
    room = reach >= config.min_grasp_depth

    # Walls (ours, `wall_check`): a closing finger touches each side at its tip depth and
    # presses along the closing axis, so the contact holds only if the side's normal lies in
    # the pads' friction cone: the side falls at least 90 deg - atan(friction) steeply, a drop
    # of 1 / friction per unit of run. So at `beyond` past each edge, where `beyond` reaches
    # the finger tips (capped at the open finger), the surface must lie `run / friction` below
    # the band's lowest point, `run` counted from the band's last pixel centre (half a pixel
    # inside the fitted edge line).
    slope = 1.0 / gripper.friction
    half_pixel = 0.5 * z_s * (jnp.abs(axis[..., 0]) / camera.fx + jnp.abs(axis[..., 1]) / camera.fy)
    beyond = jnp.clip(jnp.minimum(reach / slope, (gripper.opening - c) / 2), 0.0, None)
    wall_points = _wall_points(g_xy, axis, c / 2 + beyond, gripper, config.finger_samples)
    wall_free, _ = sample_nearest(below_surface, _to_pixels(wall_points, camera, z_s), jnp.inf)
    needed = edge + (beyond + half_pixel) * slope
    walls = jnp.logical_not(config.wall_check) | jnp.all(wall_free >= needed[..., None], -1)

    reason = jnp.select(
        [~wide_enough, ~fits, ~in_view, collision, ~room, ~walls],
        [GraspReason.TOO_NARROW, GraspReason.TOO_WIDE, GraspReason.OUT_OF_VIEW,
         GraspReason.COLLISION, GraspReason.NO_ROOM, GraspReason.NO_WALL],
        GraspReason.FOUND).astype(jnp.int32)
    return reason, reach


def assemble(found: jax.Array, overall: jax.Array, best: jax.Array, image_failed: jax.Array,
              g_flat: jax.Array, axis_flat: jax.Array, c_flat: jax.Array, reach_flat: jax.Array,
              reason_flat: jax.Array, valid_flat: jax.Array, z_s: jax.Array, n_surface,
              seed: jax.Array, camera: Camera, contour_closed: jax.Array, edges: Edges) -> Grasp:
    """A method's `Grasp` from its M placements (flat: centres `g_flat` (M, 2), axes (M, 2),
    widths, reachable depths, reasons, validity (M,)) and its choice `best`."""
    centers3 = jnp.concatenate([g_flat, jnp.full((g_flat.shape[0], 1), z_s)], -1)
    candidates = TBeams(center=centers3, pixel=_to_pixels(g_flat, camera, z_s), axis=axis_flat,
                        width=c_flat, depth=reach_flat,
                        reason=jnp.where(image_failed, overall, reason_flat),
                        valid=valid_flat & found)
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    return Grasp(
        found=found,
        reason=overall,
        position=jnp.where(found, centers3[best], nan3),
        closing_axis=jnp.where(found, jnp.append(axis_flat[best], 0.0), nan3),
        approach=jnp.array([0.0, 0.0, 1.0], jnp.float32),
        width=jnp.where(found, c_flat[best], jnp.nan),
        depth=jnp.where(found, reach_flat[best], jnp.nan),
        surface_depth=jnp.where(n_surface > 0, z_s, jnp.nan),
        pixel=jnp.where(found, _to_pixels(g_flat[best], camera, z_s), jnp.nan),
        nearest=seed,
        index=jnp.where(found, best, -1).astype(jnp.int32),
        surface_pixels=n_surface.astype(jnp.int32),
        contour_closed=contour_closed,
        edges=edges,
        candidates=candidates,
    )


def overall_reason(reason: jax.Array, image_checks: list, image_reasons: list):
    """The image's `GraspReason`: the first image-level failure, else the furthest stage any
    placement reached; and whether an image-level check failed."""
    furthest = furthest_reason(reason)
    image_failed = image_checks[0]
    for check in image_checks[1:]:
        image_failed = image_failed | check
    overall = jnp.select(image_checks, image_reasons, furthest).astype(jnp.int32)
    return overall, image_failed


def surface_centroid(camera: Camera, cluster: jax.Array, z_s: jax.Array, n_surface) -> jax.Array:
    """The surface cluster's centroid (2,), metric on the surface plane."""
    centroid_uv = (jnp.sum(camera.pixel_grid() * cluster[..., None], axis=(0, 1))
                   / jnp.maximum(n_surface, 1))
    return jnp.stack([(centroid_uv[0] - camera.cx) * z_s / camera.fx,
                      (centroid_uv[1] - camera.cy) * z_s / camera.fy])


def check_image(depth: jax.Array, camera: Camera) -> jax.Array:
    depth = jnp.asarray(depth, jnp.float32)
    if depth.shape != (camera.height, camera.width):
        raise ValueError(f"depth shape {depth.shape} does not match the camera "
                         f"({camera.height}, {camera.width})")
    return depth
