"""The support plane (table or bin floor) of a depth image, for one image.

A simulated robot knows its table by calibration (`known_support`); a real
image's support is fitted (`support_plane`). The paper assumes a camera
looking perpendicular at a table with nothing but objects nearer than it.
A real camera is tilted, so the table's near edge is nearer than the
objects on it. The plane the objects stand on is found here, so that
"nearest object" can mean "highest above the support" and the view can be
turned to face it (`perception/virtual.py`).

RANSAC: `plane_hypotheses` triangles of valid pixels drawn at random (one
fixed key, so the same image always gives the same plane), each oriented
toward the camera and scored as its inliers (closer than `plane_threshold`)
minus the pixels *behind* it (farther from the camera by more than the
threshold). Objects stand on their support, so nothing lies behind it,
while the top face of a large object has the whole table behind it.
Hypotheses tilted more than `max_plane_tilt_deg` (85) from the optical axis, seen nearly
edge-on, are not candidates; when none is found, and the best of every hypothesis is such a
plane holding `min_plane_fraction` of the pixels, the reason says so (`TOO_TILTED`, with its
tilt): a camera looking at its table more obliquely than the limit. The limit is no guard
against walls: a wall can face a tilted camera at any angle (a tote's far wall is nearly
head-on to a camera looking 50 degrees down), so a limit that keeps a tilted table out lets
such a wall in. The score keeps walls out: the table beyond a wall lies behind it. A wall
that holds more of the view than the floor, with nothing seen behind it (a camera just above
a deep tote's rim), is taken, where a 45-degree limit found no plane at all
(`tests/test_real_image_steps.py`). The best plane is refit by least squares to the
pixels within half the threshold of it, `plane_refits` times (the half keeps out the feet of
walls and objects, which pull on a plane). Everything works on a regular grid of about
`plane_pixels` pixels of the image (every n-th row and column).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from graspjax.camera import Camera
from graspjax.codes import SupportReason, names
from graspjax.config import RealImageConfig
from graspjax.perception.cluster import valid_mask
from graspjax.tree import pytree_dataclass


@pytree_dataclass
class SupportPlane:
    """Result of `support_plane` for one image: the plane `normal . p + distance = 0`."""

    found: jax.Array  # () bool
    reason: jax.Array  # () int32 SupportReason
    normal: jax.Array  # (3,) unit normal in the camera frame, pointing toward the camera
    distance: jax.Array  # () distance from the camera centre to the plane (m)
    tilt: jax.Array  # () angle between the normal and the optical axis (rad); TOO_TILTED: the
    # tilted plane's, that was not taken
    inliers: jax.Array  # () int32 grid pixels within `plane_threshold` of the best plane (found or not)
    fraction: jax.Array  # () inliers / valid grid pixels

    @property
    def reason_name(self):
        """`reason` by name (`SupportReason`): a str, or an array of str for a batch; on the host."""
        return names(SupportReason, self.reason)


def no_support() -> SupportPlane:
    """The result when the support plane is not looked for (`RealImageConfig.support` off)."""
    nan3 = jnp.full(3, jnp.nan, jnp.float32)
    return SupportPlane(found=jnp.array(False), reason=jnp.int32(SupportReason.OFF), normal=nan3,
                        distance=jnp.float32(jnp.nan), tilt=jnp.float32(jnp.nan),
                        inliers=jnp.int32(0), fraction=jnp.float32(0.0))


def plane_height(points: jax.Array, normal: jax.Array, distance) -> jax.Array:
    """Signed height `(...)` of camera-frame points `(..., 3)` above the plane (toward the camera)."""
    return (points[..., 0] * normal[0] + points[..., 1] * normal[1] + points[..., 2] * normal[2]
            + distance)


def known_support(rotation: jax.Array, position: jax.Array, normal: jax.Array, offset
                  ) -> SupportPlane:
    """The support plane known by calibration, in the camera frame of a camera at a known pose.

    rotation: (3, 3) camera-to-world; position: (3,) camera centre; the plane
    is `normal . x = offset` in the world, `normal` (3,) unit, pointing to
    the side the objects stand on (the table z = 0: normal (0, 0, 1), offset
    0). The same plane `support_plane` fits to a real image.
    """
    normal_cam = rotation.T @ normal
    distance = jnp.dot(normal, position) - offset
    return SupportPlane(found=jnp.array(True), reason=jnp.int32(SupportReason.FOUND),
                        normal=normal_cam, distance=distance,
                        tilt=_tilt(normal_cam),
                        inliers=jnp.int32(0), fraction=jnp.float32(1.0))


def _tilt(normal: jax.Array) -> jax.Array:
    """Angle (rad) between a plane's unit normal (3,), pointing toward the camera, and the
    optical axis."""
    return jnp.arccos(jnp.clip(-normal[2], -1.0, 1.0))


def _least_squares(points: jax.Array, weight: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Plane `(normal (3,), distance ())` through points `(N, 3)` weighted by `weight` `(N,)`."""
    total = jnp.maximum(jnp.sum(weight), 1.0)
    centre = jnp.sum(points * weight[:, None], 0) / total
    centred = (points - centre) * weight[:, None]
    _, vectors = jnp.linalg.eigh(centred.T @ (points - centre))
    normal = vectors[:, 0]
    normal = jnp.where(jnp.dot(normal, centre) < 0, normal, -normal)  # toward the camera
    return normal, -jnp.dot(normal, centre)


def support_plane(depth: jax.Array, camera: Camera, config: RealImageConfig = RealImageConfig()
                  ) -> SupportPlane:
    """The dominant plane with nothing behind it, facing the camera within `max_plane_tilt_deg`.

    depth: metric depth (H, W) float32, 0 or nan = invalid (pixels outside
    the workspace must already be invalid). Pure and static-shaped: jit it,
    vmap it over a leading batch axis of `depth`.
    """
    valid = valid_mask(depth)
    grid = camera.unproject(camera.pixel_grid(), jnp.where(valid, depth, 0.0))  # (H, W, 3)
    stride = max(1, math.ceil(math.sqrt(valid.size / config.plane_pixels)))
    points, ok = grid[::stride, ::stride].reshape(-1, 3), valid[::stride, ::stride].reshape(-1)
    n_valid = jnp.sum(ok)

    # Three valid pixels per hypothesis: invert the running count of valid pixels.
    k = config.plane_hypotheses
    draws = jax.random.uniform(jax.random.key(config.seed), (k, 3)) * n_valid
    index = jnp.minimum(jnp.searchsorted(jnp.cumsum(ok), draws, side="right"), ok.size - 1)
    corners = points[index]  # (K, 3, 3)
    cross = jnp.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = jnp.linalg.norm(cross, axis=-1)
    normals = cross / jnp.maximum(area, 1e-12)[:, None]
    normals = jnp.where(jnp.sum(normals * corners[:, 0], -1, keepdims=True) < 0, normals, -normals)
    distances = -jnp.sum(normals * corners[:, 0], -1)
    cos_max = jnp.cos(jnp.deg2rad(config.max_plane_tilt_deg))
    shaped = (area > 1e-6) & (n_valid >= 3)
    usable = shaped & (-normals[:, 2] >= cos_max)

    # Scores: inliers minus pixels behind the plane (K, N), summed as they are made (one fused
    # reduction: a matrix product of depth 3 would write all K x N heights first).
    signed = plane_height(points[None], normals.T[:, :, None], distances[:, None])
    thr = config.plane_threshold
    votes = (jnp.abs(signed) < thr).astype(jnp.int32) - (signed < -thr).astype(jnp.int32)
    score = jnp.sum(jnp.where(ok, votes, 0), -1)
    best = jnp.argmax(jnp.where(usable, score, jnp.iinfo(jnp.int32).min))
    normal, distance = normals[best], distances[best]
    for _ in range(config.plane_refits):  # within half the threshold: the points nearest the plane
        inlier = ok & (jnp.abs(plane_height(points, normal, distance)) < thr / 2)
        normal, distance = _least_squares(points, inlier.astype(jnp.float32))
    any_usable = jnp.any(usable)
    inliers = jnp.sum(ok & (jnp.abs(plane_height(points, normal, distance)) < thr))
    inliers = jnp.where(any_usable, inliers, 0)
    fraction = inliers / jnp.maximum(n_valid, 1)

    # Where none is found: would a plane tilted past the limit have held enough? (Said, never
    # used: the camera then sees its table more obliquely than `max_plane_tilt_deg` allows.)
    steep = jnp.argmax(jnp.where(shaped, score, jnp.iinfo(jnp.int32).min))
    steep_fraction = (jnp.sum(ok & (jnp.abs(plane_height(points, normals[steep], distances[steep]))
                                     < thr)) / jnp.maximum(n_valid, 1))
    steep_tilt = _tilt(normals[steep])
    too_tilted = ((steep_fraction >= config.min_plane_fraction) & (-normals[steep, 2] < cos_max)
                  & jnp.any(shaped))

    failed = ~any_usable | (fraction < config.min_plane_fraction)
    reason = jnp.select(
        [n_valid < 3, failed & too_tilted, ~any_usable, fraction < config.min_plane_fraction],
        [SupportReason.NO_DEPTH, SupportReason.TOO_TILTED, SupportReason.NO_PLANE,
         SupportReason.TOO_FEW_INLIERS],
        SupportReason.FOUND).astype(jnp.int32)
    found = reason == SupportReason.FOUND
    tilted = reason == SupportReason.TOO_TILTED
    return SupportPlane(
        found=found,
        reason=reason,
        normal=jnp.where(found, normal, jnp.nan),
        distance=jnp.where(found, distance, jnp.nan),
        tilt=jnp.where(found, _tilt(normal),
                       jnp.where(tilted, steep_tilt, jnp.nan)),
        inliers=inliers.astype(jnp.int32),
        fraction=fraction.astype(jnp.float32),
    )
