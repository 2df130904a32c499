"""Grasp methods a user would try instead of the paper's double T-beam, for one depth image.

Both start where the T-beam starts, on the target's surface band (the pixels connected to
z_min within `surface_tolerance` of its depth, `target_surface`), and end where it ends: the
open hand's placement goes through the same checks (`placements.check_placements`: fingers
outside the band, in view, room to reach the grasp depth, the optional wall check), and the
result is a `Grasp` with its placements as candidates. What differs is how a placement is
proposed:

- `highest_pca_grasp`: the common heuristic, and the PCA-based alignment of the paper's
  reference [17]: one top-down grasp at the band's centre, closing across its principal axis
  (the minor axis of the band's pixels in the image), as wide as the band is along it.
- `antipodal_grasp`: in the spirit of Dex-Net's antipodal sampler and GPD's candidates:
  contacts sampled on the band's boundary, each with its normal from the band's image
  gradient; from each, a walk straight across the band finds the second contact; a pair is
  antipodal when the line between the contacts lies in both contacts' friction cones. The most
  antipodal pair that passes the checks wins (near-ties: the one nearest the band's centroid).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from graspjax.camera import Camera
from graspjax.codes import GraspReason
from graspjax.config import BaselineConfig, DetectorConfig, GripperConfig
from graspjax.perception.cluster import (
    boundary_pixels,
    mean_depth,
    nearest_pixel,
    target_surface,
    valid_mask,
)
from graspjax.perception.contour import Edges
from graspjax.perception.grasp import detect_grasp
from graspjax.perception.placements import (
    Grasp,
    assemble,
    check_image,
    check_placements,
    overall_reason,
    surface_centroid,
    surface_xy,
)


def _band(depth: jax.Array, config: DetectorConfig, seed_mask: jax.Array | None,
          surface: jax.Array | None = None):
    """The target's surface band, as the T-beam finds it (or `surface` (H, W) bool, given):
    valid pixels (H, W), any valid seed (), the z_min pixel (2,), the band (H, W), its mean
    depth () and its pixel count ()."""
    valid = valid_mask(depth)
    any_valid = jnp.any(valid if seed_mask is None else valid & seed_mask)
    seed, z_min = nearest_pixel(depth, valid if seed_mask is None else valid & seed_mask)
    if surface is None:
        cluster, z_s = target_surface(depth, valid, seed, z_min, config.surface_tolerance,
                                      config.band_step, config.unrolled_loops)
    else:
        cluster = valid & surface
        z_s = mean_depth(depth, cluster)
    z_s = jnp.where(jnp.any(cluster), z_s, 1.0)
    return valid, any_valid, seed, cluster, z_s, jnp.sum(cluster)


def _pixel_size(camera: Camera, z_s: jax.Array) -> jax.Array:
    """Metres per pixel on the band (the mean of the two focal lengths)."""
    return z_s * 0.5 * (1.0 / camera.fx + 1.0 / camera.fy)


def _no_edges() -> Edges:
    """The straight edges a baseline does not fit: one invalid entry."""
    zero2 = jnp.zeros((1, 2), jnp.float32)
    return Edges(center=zero2, direction=zero2, normal=zero2, length=jnp.zeros(1, jnp.float32),
                 count=jnp.zeros(1, jnp.int32), valid=jnp.zeros(1, bool))


def highest_pca_grasp(depth: jax.Array, camera: Camera, config: DetectorConfig = DetectorConfig(),
                      gripper: GripperConfig = GripperConfig(),
                      seed_mask: jax.Array | None = None) -> Grasp:
    """One top-down grasp at the nearest (highest) surface band, closing across its principal
    axis. depth: metric depth (H, W); seed_mask: as for `detect_grasp`. One candidate."""
    depth = check_image(depth, camera)
    valid, any_valid, seed, cluster, z_s, n_surface = _band(depth, config, seed_mask)
    xy = surface_xy(camera, z_s)  # (H, W, 2)
    weight = cluster.astype(jnp.float32)[..., None]
    centroid = surface_centroid(camera, cluster, z_s, n_surface)
    offset = (xy - centroid) * weight
    covariance = jnp.einsum("hwi,hwj->ij", offset, offset) / jnp.maximum(n_surface, 1)
    _, vectors = jnp.linalg.eigh(covariance)  # ascending eigenvalues
    axis = vectors[:, 0]  # the minor axis: closing across the principal one
    axis = axis * jnp.where(axis[0] < 0, -1.0, 1.0)  # one sign for one placement
    along = jnp.sum((xy - centroid) * axis, -1)  # (H, W)
    low = jnp.min(jnp.where(cluster, along, jnp.inf))
    high = jnp.max(jnp.where(cluster, along, -jnp.inf))
    # The band's width: between its outermost pixel centres, plus one pixel (each centre lies
    # up to a pixel inside the true edge; half on average on either side).
    c = jnp.where(n_surface > 0, high - low + _pixel_size(camera, z_s), 0.0)
    g_xy = centroid + 0.5 * (low + high) * axis
    reason, reach = check_placements(depth, valid, cluster, z_s, camera, g_xy[None], axis[None],
                                      c[None], jnp.ones(1, bool), config, gripper)
    ok = reason == GraspReason.FOUND
    overall, image_failed = overall_reason(
        reason, [~any_valid, n_surface < config.min_surface_pixels],
        [GraspReason.NO_DEPTH, GraspReason.SURFACE_TOO_SMALL])
    found = ok[0] & ~image_failed
    return assemble(found, overall, jnp.int32(0), image_failed, g_xy[None], axis[None],
                     c[None], jnp.clip(reach, 0.0, None), reason, ok, z_s, n_surface, seed,
                     camera, jnp.array(True), _no_edges())


def _smoothed(image: jax.Array) -> jax.Array:
    """A separable binomial (1 4 6 4 1) / 16 blur of an (H, W) image, edges replicated."""
    kernel = jnp.asarray([1.0, 4.0, 6.0, 4.0, 1.0], jnp.float32) / 16.0
    padded = jnp.pad(image, 2, mode="edge")
    rows = sum(kernel[i] * padded[:, i:i + image.shape[1]] for i in range(5))
    return sum(kernel[i] * rows[i:i + image.shape[0]] for i in range(5))


def _outward_normals(cluster: jax.Array, camera: Camera, z_s: jax.Array) -> jax.Array:
    """Unit outward normals (H, W, 2) of the band's boundary on the surface plane (metric),
    from the gradient of the smoothed band: it points inward, across the boundary."""
    smooth = jnp.pad(_smoothed(cluster.astype(jnp.float32)), 1, mode="edge")
    du = (smooth[1:-1, 2:] - smooth[1:-1, :-2]) / 2  # per pixel
    dv = (smooth[2:, 1:-1] - smooth[:-2, 1:-1]) / 2
    gradient = jnp.stack([du * camera.fx / z_s, dv * camera.fy / z_s], -1)  # per metre
    norm = jnp.linalg.norm(gradient, axis=-1, keepdims=True)
    return jnp.where(norm > 0, -gradient / jnp.maximum(norm, 1e-12), 0.0)


def evenly_spread(flags: jax.Array, count: int) -> tuple[jax.Array, jax.Array]:
    """`count` of the True entries of `flags` (M,) bool, spread evenly through it (every one,
    in order, when there are fewer): their indices `(count,)` int32 and which are real
    `(count,)` bool (the slots past the number of True entries are not)."""
    running = jnp.cumsum(flags.astype(jnp.int32))  # True entries up to each one
    n = running[-1]
    slot = jnp.arange(count)
    wanted = jnp.where(n >= count, (slot * n) // count, jnp.minimum(slot, jnp.maximum(n - 1, 0)))
    index = jnp.where(n > 0, jnp.searchsorted(running, wanted + 1, side="left"), 0)
    return index.astype(jnp.int32), slot < n


def _spread(mask: jax.Array, count: int) -> tuple[jax.Array, jax.Array]:
    """Up to `count` pixels of `mask` (H, W), spread evenly through its raster order
    (`evenly_spread`): their (u, v) `(count, 2)` int32 and which are real `(count,)` bool."""
    pick, real = evenly_spread(mask.reshape(-1), count)
    return jnp.stack([pick % mask.shape[1], pick // mask.shape[1]], -1).astype(jnp.int32), real


def antipodal_grasp(depth: jax.Array, camera: Camera, config: DetectorConfig = DetectorConfig(),
                    gripper: GripperConfig = GripperConfig(),
                    baseline: BaselineConfig = BaselineConfig(),
                    seed_mask: jax.Array | None = None, surface: jax.Array | None = None) -> Grasp:
    """Antipodal contact pairs on the nearest surface band's boundary (module docstring).
    depth: metric depth (H, W); seed_mask: as for `detect_grasp`; surface: optional (H, W)
    bool, the target's surface to pair contacts on instead of the band. M =
    `antipodal_contacts` candidates."""
    depth = check_image(depth, camera)
    valid, any_valid, seed, cluster, z_s, n_surface = _band(depth, config, seed_mask, surface)
    height, width = cluster.shape
    xy = surface_xy(camera, z_s)
    normals = _outward_normals(cluster, camera, z_s)
    first, real = _spread(boundary_pixels(cluster), baseline.antipodal_contacts)  # (M, 2)
    n_p = normals[first[:, 1], first[:, 0]]  # (M, 2) outward at the first contact
    p_xy = xy[first[:, 1], first[:, 0]]

    # Walk inward along -n_p one pixel at a time; the second contact is the last band pixel
    # before the walk first leaves the band.
    pixel = _pixel_size(camera, z_s)
    steps = jnp.arange(1, baseline.antipodal_steps + 1, dtype=jnp.float32) * pixel  # (S,)
    walk = p_xy[:, None, :] - steps[None, :, None] * n_p[:, None, :]  # (M, S, 2)
    uv = jnp.round(jnp.stack([walk[..., 0] * camera.fx / z_s + camera.cx,
                              walk[..., 1] * camera.fy / z_s + camera.cy], -1)).astype(jnp.int32)
    inside_image = ((uv[..., 0] >= 0) & (uv[..., 0] < width) & (uv[..., 1] >= 0)
                    & (uv[..., 1] < height))
    on_band = inside_image & cluster[jnp.clip(uv[..., 1], 0, height - 1),
                                     jnp.clip(uv[..., 0], 0, width - 1)]
    exits = ~on_band
    leaves = jnp.any(exits, -1)  # the walk leaves the band within its steps
    last = jnp.maximum(jnp.argmax(exits, -1) - 1, 0)  # the last step on the band
    second = jnp.where((jnp.argmax(exits, -1) > 0)[:, None],
                       uv[jnp.arange(uv.shape[0]), last], first)  # (M, 2)
    n_q = normals[second[:, 1], second[:, 0]]
    q_xy = xy[second[:, 1], second[:, 0]]

    line = q_xy - p_xy
    span = jnp.linalg.norm(line, axis=-1)  # between the contacts' pixel centres
    axis = line / jnp.maximum(span, 1e-9)[:, None]  # closing axis, from p to q
    c = jnp.where(span > 0, span + pixel, 0.0)  # the band's width between the contacts
    cone = jnp.cos(jnp.deg2rad(baseline.antipodal_cone_deg))
    cos_p = jnp.sum(axis * -n_p, -1)  # the line enters the band at p
    cos_q = jnp.sum(axis * n_q, -1)  # and leaves it at q
    antipodal = real & leaves & (span > 0) & (cos_p >= cone) & (cos_q >= cone)
    g_xy = 0.5 * (p_xy + q_xy)
    reason, reach = check_placements(depth, valid, cluster, z_s, camera, g_xy, axis, c,
                                      antipodal, config, gripper)
    ok = reason == GraspReason.FOUND

    # The most antipodal pair wins; near-ties go to the one nearest the band's centroid.
    worst = jnp.rad2deg(jnp.arccos(jnp.clip(jnp.minimum(cos_p, cos_q), -1.0, 1.0)))
    worst = jnp.where(ok, worst, jnp.inf)
    tied = worst <= jnp.min(worst) + baseline.antipodal_tie_deg
    centroid = surface_centroid(camera, cluster, z_s, n_surface)
    distance = jnp.where(tied & ok, jnp.linalg.norm(g_xy - centroid, axis=-1), jnp.inf)
    best = jnp.argmin(distance)
    overall, image_failed = overall_reason(
        reason, [~any_valid, n_surface < config.min_surface_pixels],
        [GraspReason.NO_DEPTH, GraspReason.SURFACE_TOO_SMALL])
    found = ok[best] & ~image_failed
    return assemble(found, overall, best, image_failed, g_xy, axis, c,
                     jnp.clip(reach, 0.0, None), reason, ok, z_s, n_surface, seed, camera,
                     jnp.array(True), _no_edges())


def grasp_method(name: str):
    """The detector of a method (`Config.method`) as `f(depth, camera, config, seed_mask)`."""
    if name == "paper":
        return lambda depth, camera, config, seed_mask: detect_grasp(
            depth, camera, config.detect, config.gripper, seed_mask=seed_mask)
    if name == "highest-pca":
        return lambda depth, camera, config, seed_mask: highest_pca_grasp(
            depth, camera, config.detect, config.gripper, seed_mask=seed_mask)
    if name == "antipodal":
        return lambda depth, camera, config, seed_mask: antipodal_grasp(
            depth, camera, config.detect, config.gripper, config.baseline, seed_mask=seed_mask)
    raise ValueError(f"unknown grasp method {name!r}")
