"""Grasp point detection with the double T-beam (paper section 3.1), for one depth image.

The camera is assumed to look (nearly) perpendicular at the target surface:
the nearest valid pixel (z_min) seeds a surface cluster, its contour is
grouped into straight edges (`contour.py`), and a T-beam the size of the
opened gripper is placed at the centre S of every edge with its closing axis
along the edge's normal. A placement is a grasp when an antipodal edge lies
at a distance c that fits the opening, the four outer finger corners lie
outside the cluster, the depth under both finger footprints leaves room
to reach the grasp depth, and both gripped sides are walls steep enough for
the finger pads to hold (a depth band cut from a gentle slope is not). The
grasp centre is Eq. 1, read as G = S - (c / 2) * n (half-way between the two
antipodal edges; the paper writes it in pixels with c / 2 converted by d_p,
we work in metres on the surface plane). Among valid placements the one whose G is closest to the
cluster's centroid wins (most central, least likely to push the object);
near-ties go to the first placement.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.codes import GraspReason
from graspjax.config import DetectorConfig, GripperConfig
from graspjax.perception.cluster import nearest_pixel, target_surface, valid_mask
from graspjax.perception.contour import Contour, Edges, fit_edges, loop_steps, trace_contour
from graspjax.perception.placements import (
    Grasp,
    assemble,
    check_image,
    check_placements,
    overall_reason,
    surface_centroid,
)


def surface_contour(depth: jax.Array, config: DetectorConfig = DetectorConfig(),
                    seed_mask: jax.Array | None = None
                    ) -> tuple[jax.Array, jax.Array, jax.Array, Contour]:
    """The detector's first stage: z_min pixel `(2,)`, surface cluster `(H, W)`, its depth, contour.

    seed_mask: optional (H, W) bool, the pixels where z_min may be taken. The
    depth is 1.0 when the cluster is empty (every later result is masked).
    """
    valid = valid_mask(depth)
    seed, z_min = nearest_pixel(depth, valid if seed_mask is None else valid & seed_mask)
    cluster, z_s = target_surface(depth, valid, seed, z_min, config.surface_tolerance,
                                 config.band_step, config.unrolled_loops)
    z_s = jnp.where(jnp.any(cluster), z_s, 1.0)
    return seed, cluster, z_s, trace_contour(cluster, config.max_contour,
                                             loop_steps(config.unrolled_loops))


def detect_grasp(depth: jax.Array, camera: Camera, config: DetectorConfig = DetectorConfig(),
                 gripper: GripperConfig = GripperConfig(),
                 seed_mask: jax.Array | None = None) -> Grasp:
    """Find a parallel-jaw grasp on the surface nearest the camera (the paper's double T-beam).

    depth: metric depth (H, W) float32, 0 or nan = invalid. seed_mask:
    optional (H, W) bool restricting where the nearest point (the target) may
    be taken; the surface itself is grown over all pixels. Pure and static-
    shaped: jit it, and vmap it over a leading batch axis of `depth`.
    """
    depth = check_image(depth, camera)
    valid = valid_mask(depth)
    any_valid = jnp.any(valid if seed_mask is None else valid & seed_mask)
    seed, cluster, z_s, contour = surface_contour(depth, config, seed_mask)
    n_surface = jnp.sum(cluster)
    edges = fit_edges(contour, camera, z_s, tangent_window=config.tangent_window,
                      split_angle_deg=config.split_angle_deg,
                      min_edge_pixels=config.min_edge_pixels, max_edges=config.max_edges,
                      steps_per_iteration=loop_steps(config.unrolled_loops))

    # --- antipodal pairs: a T-beam at P points along edge i, partner edge j ---------------
    # (P = `tbeam_positions`; the paper places one, at the edge's centre S.)
    k, p = config.max_edges, config.tbeam_positions
    s_i = _tbeam_starts(edges, gripper, p).reshape(k * p, 1, 2)  # (K P, 1, 2)
    n_i = jnp.repeat(edges.normal, p, axis=0)[:, None, :]
    valid_i = jnp.repeat(edges.valid, p)
    s_j, n_j, t_j = edges.center[None], edges.normal[None], edges.direction[None]
    facing = jnp.sum(n_i * n_j, -1)  # (K P, K)
    safe = jnp.where(facing < 0, facing, -1.0)
    c = jnp.sum((s_i - s_j) * n_j, -1) / safe  # distance from S_i along -n_i to edge j's line
    hit = s_i - c[..., None] * n_i
    lateral = jnp.abs(jnp.sum((hit - s_j) * t_j, -1))
    own_edge = jnp.repeat(jnp.eye(k, dtype=bool), p, axis=0)
    pair_ok = valid_i[:, None] & edges.valid[None, :] & ~own_edge
    antipodal = (pair_ok & (facing <= -jnp.cos(jnp.deg2rad(config.antipodal_tolerance_deg)))
                 & (c > 0) & (lateral <= edges.length[None, :] / 2))

    # --- T-beam placement, Eq. 1, and its checks ------------------------------------------
    axis = jnp.broadcast_to(n_i, (k * p, k, 2))
    g_xy = s_i - 0.5 * c[..., None] * n_i  # (K P, K, 2)
    reason, reach = check_placements(depth, valid, cluster, z_s, camera, g_xy, axis, c,
                                      antipodal, config, gripper)
    ok = reason == GraspReason.FOUND

    # --- choice: the valid G closest to the cluster centroid ------------------------------
    centroid = surface_centroid(camera, cluster, z_s, n_surface)
    # Near-ties (mirror placements on a symmetric face) go to the lowest index,
    # whatever the float rounding of the batch: the first within 0.5 mm of the best.
    flat_ok = ok.reshape(-1)
    dist = jnp.where(flat_ok, jnp.linalg.norm(g_xy - centroid, axis=-1).reshape(-1), jnp.inf)
    best = jnp.argmax(dist <= jnp.min(dist) + 5e-4)
    overall, image_failed = overall_reason(
        reason, [~any_valid, n_surface < config.min_surface_pixels, jnp.sum(edges.valid) < 2],
        [GraspReason.NO_DEPTH, GraspReason.SURFACE_TOO_SMALL, GraspReason.NO_EDGES])
    found = flat_ok[best] & ~image_failed
    return assemble(found, overall, best, image_failed, g_xy.reshape(-1, 2),
                     axis.reshape(-1, 2), c.reshape(-1), jnp.clip(reach.reshape(-1), 0.0, None),
                     reason.reshape(-1), flat_ok, z_s, n_surface, seed, camera, contour.closed,
                     edges)


def _tbeam_starts(edges: Edges, gripper: GripperConfig, positions: int) -> jax.Array:
    """Where the T-beams sit on each edge `(K, P, 2)`: at its centre S (P = 1, the paper), or
    at P points spread evenly along it, a half finger width from its ends (the paper's
    Discussion, Fig. 8: the middle of an edge may be the wrong place)."""
    if positions == 1:
        return edges.center[:, None, :]
    span = jnp.clip(edges.length - gripper.finger_width, 0.0, None)  # (K,)
    fractions = (np.arange(positions, dtype=np.float32) + 0.5) / positions - 0.5  # (P,)
    offsets = jnp.where(edges.valid[:, None], span[:, None] * fractions[None, :], 0.0)
    return edges.center[:, None, :] + offsets[..., None] * edges.direction[:, None, :]
