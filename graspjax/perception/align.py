"""End-tool alignment by plane scoring (paper section 3.2), for one depth image.

Around the point A (z_min, the paper's Fig. 4, or the centre of z_min's surface band:
`anchor`), `num_triangles` triangles (A, A + r(cos phi_k, sin phi_k),
A + r(cos phi_k+1, sin phi_k+1)) with phi_k = k * 360deg / N each define a plane. The image
becomes a point cloud in pixel units, (u, v, z / d_p) with d_p from Eq. 2 at A's depth (a
pixel's footprint, as the text asks; `pixel_scale="printed"`: the printed half of it), and a
point is an inlier of plane k (Eq. 3) when its distance to the plane is below
`distance_threshold` and it lies within `window_px` of A (the paper's words, for every plane)
or of the triangle's centroid (`window_centre`) in u, v and the converted z. The plane with
most inliers wins, among those whose view turns by at least `min_turn_deg` from the current
one; the tool then looks along its negative normal. Normals are reported in the metric camera
frame (from the triangle's back-projected corners, or a least-squares fit to the inliers when
`refit`), pointing from the surface toward the camera; the turn follows the normal in the
pixel units of Eq. 2, as the paper computes it, read as a camera-frame direction
(`turn_normal="pixel"`: with the footprint, the plane's normal near A up to perspective), or
the metric one.

Scoring only looks at a `(2 * MAX_WINDOW_PX + 3)^2` patch around each
centroid, which holds every pixel the window admits; the window itself and
the threshold are traced values (a sweep over them compiles once).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax import lax

from graspjax.camera import Camera
from graspjax.codes import AlignReason, names
from graspjax.config import MAX_WINDOW_PX, AlignConfig
from graspjax.perception.cluster import nearest_pixel, surface_cluster, valid_mask
from graspjax.tree import pytree_dataclass


@pytree_dataclass
class Alignment:
    """Result of `align_tool` for one image (camera frame, metres); N hypotheses."""

    found: jax.Array  # () bool
    reason: jax.Array  # () int32 AlignReason
    normal: jax.Array  # (3,) unit normal of the winning plane, toward the camera
    point: jax.Array  # (3,) centroid of the winning plane's inliers
    inliers: jax.Array  # () int32 inliers of the winning plane
    best: jax.Array  # () int32 index of the winning hypothesis (-1 if none)
    anchor: jax.Array  # (2,) int32 pixel A (u, v): z_min or the centre of its band (`anchor`)
    corners: jax.Array  # (N, 3, 2) int32 triangle corners in pixels (u, v)
    normals: jax.Array  # (N, 3) unit normal of every hypothesis, toward the camera
    counts: jax.Array  # (N,) int32 inliers of every hypothesis (0 if invalid)
    valid: jax.Array  # (N,) bool hypothesis corners in view, valid and not collinear
    ranking: jax.Array  # (N,) int32 hypotheses by inlier count, most first (those that turn first)

    @property
    def reason_name(self):
        """`reason` by name (`AlignReason`): a str, or an array of str for a batch; on the host."""
        return names(AlignReason, self.reason)


def _hypothesis_corners(anchor: jax.Array, config: AlignConfig, key) -> jax.Array:
    """Triangle corners `(N, 3, 2)` int32 pixels around the anchor A `(2,)`."""
    a = anchor.astype(jnp.float32)
    if config.hypotheses == "triangles":
        n = config.num_triangles
        phi = 2 * jnp.pi * jnp.arange(n + 1) / n
        ring = a + config.triangle_radius_px * jnp.stack([jnp.cos(phi), jnp.sin(phi)], -1)
        tri = jnp.stack([jnp.broadcast_to(a, (n, 2)), ring[:-1], ring[1:]], axis=1)
    else:
        if key is None:
            raise ValueError("AlignConfig.hypotheses='random' needs a PRNG key")
        # corner offsets from A: U(-window, window)^2 pixels, independently per corner
        offsets = jax.random.uniform(key, (config.num_random, 3, 2), minval=-config.window_px,
                                     maxval=config.window_px)
        tri = a + offsets
    return jnp.round(tri).astype(jnp.int32)


def _scaled_planes(corners: jax.Array, depth: jax.Array, scale) -> tuple[jax.Array, ...]:
    """Corners in pixel units `(N, 3, 3)`, unit plane normals `(N, 3)` and centroids `(N, 3)`."""
    height, width = depth.shape
    cu = jnp.clip(corners[..., 0], 0, width - 1)
    cv = jnp.clip(corners[..., 1], 0, height - 1)
    points = jnp.concatenate([corners.astype(jnp.float32), (depth[cv, cu] * scale)[..., None]], -1)
    normal = jnp.cross(points[:, 1] - points[:, 0], points[:, 2] - points[:, 0])
    norm = jnp.linalg.norm(normal, axis=-1, keepdims=True)
    return points, normal / jnp.maximum(norm, 1e-12), points.mean(axis=1), norm[:, 0]


def _eq3(u, v, zs, centre, normal, origin, config: AlignConfig):
    """Paper Eq. 3: near the triangle centroid in u, v, z and close to its plane (pixel units)."""
    w = config.window_px
    near = (jnp.abs(u - centre[0]) < w) & (jnp.abs(v - centre[1]) < w) & (jnp.abs(zs - centre[2]) < w)
    dist = jnp.abs((u - origin[0]) * normal[0] + (v - origin[1]) * normal[1]
                   + (zs - origin[2]) * normal[2])
    return near & (dist < config.distance_threshold)


def _pixel_scale(camera: Camera, z_min, config: AlignConfig):
    """1 / d_p at z_min (Eq. 2: one pixel's footprint, or the formula as printed, half of it)."""
    return 1.0 / camera.d_p(z_min, footprint=config.pixel_scale == "footprint")


def anchor_point(depth: jax.Array, allowed: jax.Array, config: AlignConfig) -> tuple[jax.Array, jax.Array]:
    """The triangles' common corner A: its pixel `(2,)` int32 (u, v) and depth (inf if none).

    depth: metric depth (H, W); allowed: (H, W) bool. `anchor="nearest"`: z_min itself (on a
    face seen head-on, sub-millimetre tilt decides: a corner of the face). `anchor="centre"`:
    the pixel nearest the centroid of z_min's surface band (4-connected, `[z_min, z_min +
    anchor_band]`); on a ridge or a narrow slope the band is a strip along the nearest edge, on
    a flat top the whole top.
    """
    seed, z_min = nearest_pixel(depth, allowed)
    if config.anchor == "nearest":
        return seed, z_min
    band = surface_cluster(depth, allowed, seed, z_min, z_min + config.anchor_band)
    height, width = depth.shape
    v, u = jnp.meshgrid(jnp.arange(height, dtype=jnp.float32), jnp.arange(width, dtype=jnp.float32),
                        indexing="ij")
    n = jnp.maximum(jnp.sum(band), 1)
    centroid_u, centroid_v = jnp.sum(u * band) / n, jnp.sum(v * band) / n
    far = jnp.where(band, (u - centroid_u) ** 2 + (v - centroid_v) ** 2, jnp.inf)
    cv, cu = jnp.divmod(jnp.argmin(far), width)
    centre = jnp.stack([cu, cv]).astype(jnp.int32)
    found = jnp.any(band)
    return (jnp.where(found, centre, seed),
            jnp.where(found, jnp.where(allowed, depth, jnp.inf)[cv, cu], z_min))


def _window_inliers(clean: jax.Array, valid: jax.Array, scale: jax.Array, centres: jax.Array,
                    normals: jax.Array, origins: jax.Array, camera: Camera, config: AlignConfig
                    ) -> tuple[jax.Array, jax.Array]:
    """Eq. 3 for N planes (pixel units: `normals` (N, 3) through `origins` (N, 3)), each on a
    static patch around its window's centre (`centres` (N, 3)): the inliers (N, S, S) and the
    patches' points (N, S, S, 3, camera frame). `clean` (H, W) is the depth with 0 where not
    `valid`; the configured window applies inside the patch of half-size `MAX_WINDOW_PX`."""
    w = MAX_WINDOW_PX
    size = 2 * w + 3
    pad = size + w + 2  # slices never clamp at the border (triangle radius <= MAX_WINDOW_PX)
    padded_z = jnp.pad(clean, pad)
    padded_ok = jnp.pad(valid, pad)
    grid = jnp.arange(size)

    def score(centre, normal, origin):
        top_left = jnp.floor(centre[:2]).astype(jnp.int32) - (w + 1)  # (u0, v0)
        z = lax.dynamic_slice(padded_z, (top_left[1] + pad, top_left[0] + pad), (size, size))
        ok = lax.dynamic_slice(padded_ok, (top_left[1] + pad, top_left[0] + pad), (size, size))
        u = (top_left[0] + grid)[None, :].astype(jnp.float32)
        v = (top_left[1] + grid)[:, None].astype(jnp.float32)
        inlier = ok & _eq3(u, v, z * scale, centre, normal, origin, config)
        pts = camera.unproject(jnp.stack(jnp.broadcast_arrays(u, v), -1), z)  # (S, S, 3)
        return inlier, pts

    return jax.vmap(score)(centres, normals, origins)


def _plane_normals(scaled: jax.Array, n_scaled: jax.Array, scale: jax.Array, camera: Camera,
                   config: AlignConfig) -> jax.Array:
    """Each hypothesis's unit normal (N, 3) facing the camera: metric, from its back-projected
    corners (`scaled` (N, 3, 3) in pixel units), or with `turn_normal="pixel"` the paper's
    (u, v, z / d_p) normal `n_scaled` read as (x, y, z)."""
    metric = camera.unproject(scaled[..., :2], scaled[..., 2] / scale)  # (N, 3, 3)
    normals = jnp.cross(metric[:, 1] - metric[:, 0], metric[:, 2] - metric[:, 0])
    normals = normals / jnp.maximum(jnp.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)
    toward_camera = jnp.sum(normals * metric[:, 0], -1) < 0
    normals = jnp.where(toward_camera[:, None], normals, -normals)
    if config.turn_normal == "pixel":  # the paper's unit: (u, v, z / d_p) read as (x, y, z)
        normals = jnp.where(n_scaled[:, 2:] < 0, n_scaled, -n_scaled)
    return normals


def align_tool(depth: jax.Array, camera: Camera, config: AlignConfig = AlignConfig(),
               key: jax.Array | None = None, seed_mask: jax.Array | None = None) -> Alignment:
    """Score candidate planes around z_min and pick the one with most inliers.

    depth: metric depth (H, W) float32, 0 or nan = invalid. key: PRNG key,
    needed only for `hypotheses="random"`. seed_mask: optional (H, W) bool,
    the pixels where z_min (the anchor A) may be taken. Pure and static-
    shaped: jit it, and vmap it over a leading batch axis of `depth` (and `key`).
    """
    depth = jnp.asarray(depth, jnp.float32)
    height, width = depth.shape
    if (height, width) != (camera.height, camera.width):
        raise ValueError(f"depth shape {depth.shape} does not match the camera "
                         f"({camera.height}, {camera.width})")
    valid = valid_mask(depth)
    clean = jnp.where(valid, depth, 0.0)
    anchor, z_anchor = anchor_point(depth, valid if seed_mask is None else valid & seed_mask, config)
    any_valid = jnp.isfinite(z_anchor)
    scale = _pixel_scale(camera, jnp.where(any_valid, z_anchor, 1.0), config)

    corners = _hypothesis_corners(anchor, config, key)  # (N, 3, 2)
    inside = ((corners[..., 0] >= 0) & (corners[..., 0] < width)
              & (corners[..., 1] >= 0) & (corners[..., 1] < height))
    corner_ok = inside & valid[jnp.clip(corners[..., 1], 0, height - 1),
                               jnp.clip(corners[..., 0], 0, width - 1)]
    scaled, n_scaled, centroid, n_norm = _scaled_planes(corners, clean, scale)
    hyp_valid = jnp.all(corner_ok, -1) & (n_norm > 1e-6) & any_valid

    at_anchor = jnp.stack([anchor[0], anchor[1], clean[anchor[1], anchor[0]] * scale])
    centres = (jnp.broadcast_to(at_anchor.astype(centroid.dtype), centroid.shape)
               if config.window_centre == "anchor" else centroid)  # A for every plane, or each centroid
    inlier, pts = _window_inliers(clean, valid, scale, centres, n_scaled, scaled[:, 0], camera,
                                  config)  # (N, S, S), (N, S, S, 3)
    counts = jnp.where(hyp_valid, jnp.sum(inlier, axis=(1, 2)), 0).astype(jnp.int32)
    sums = jnp.sum(pts * inlier[..., None], axis=(1, 2))  # (N, 3)

    normals = _plane_normals(scaled, n_scaled, scale, camera, config)

    # A view must turn by at least min_turn_deg: the optical axis is +z, normals face the camera.
    turns = normals[:, 2] >= -jnp.cos(jnp.deg2rad(config.min_turn_deg))
    strong = hyp_valid & (counts >= config.min_inliers)
    eligible = hyp_valid & (turns | ~jnp.any(strong & turns))  # none turns: keep all, to report
    ranking = jnp.argsort(-jnp.where(hyp_valid, counts + jnp.where(eligible, 1 << 24, 0), -1),
                          stable=True).astype(jnp.int32)
    best = ranking[0]
    best_count = counts[best]
    point = sums[best] / jnp.maximum(best_count, 1)
    normal = normals[best]
    if config.refit:
        # Least-squares plane through the winner's inliers: smallest principal axis.
        centred = (pts[best] - point) * inlier[best][..., None]
        cov = jnp.einsum("ijk,ijl->kl", centred, centred)
        _, vecs = jnp.linalg.eigh(cov)
        fit = vecs[:, 0]
        fit = jnp.where(jnp.dot(fit, point) < 0, fit, -fit)
        normal = jnp.where(best_count >= 3, fit, normal)

    reason = jnp.select(
        [~any_valid, ~jnp.any(hyp_valid), best_count < config.min_inliers, ~turns[best]],
        [AlignReason.NO_DEPTH, AlignReason.NO_PLANE, AlignReason.TOO_FEW_INLIERS,
         AlignReason.NO_NEW_VIEW],
        AlignReason.FOUND).astype(jnp.int32)
    found = reason == AlignReason.FOUND
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    return Alignment(
        found=found,
        reason=reason,
        normal=jnp.where(found, normal, nan3),
        point=jnp.where(found, point, nan3),
        inliers=jnp.where(hyp_valid[best], best_count, 0).astype(jnp.int32),
        best=jnp.where(found, best, -1).astype(jnp.int32),
        anchor=anchor,
        corners=corners,
        normals=jnp.where(hyp_valid[:, None], normals, jnp.nan),
        counts=counts,
        valid=hyp_valid,
        ranking=ranking,
    )


def plane_inliers(depth: jax.Array, camera: Camera, alignment: Alignment,
                  config: AlignConfig = AlignConfig()) -> jax.Array:
    """Inlier mask `(H, W)` of the winning plane over the whole image (for figures)."""
    depth = jnp.asarray(depth, jnp.float32)
    valid = valid_mask(depth)
    clean = jnp.where(valid, depth, 0.0)
    scale = _pixel_scale(camera, clean[alignment.anchor[1], alignment.anchor[0]], config)
    best = jnp.maximum(alignment.best, 0)
    points, normal, centroid, _ = _scaled_planes(alignment.corners[best][None], clean, scale)
    u_a, v_a = alignment.anchor[0], alignment.anchor[1]
    centre = (jnp.stack([u_a, v_a, clean[v_a, u_a] * scale]).astype(centroid.dtype)
              if config.window_centre == "anchor" else centroid[0])
    uv = camera.pixel_grid()
    inlier = _eq3(uv[..., 0], uv[..., 1], clean * scale, centre, normal[0], points[0, 0], config)
    return valid & inlier & (alignment.best >= 0)
