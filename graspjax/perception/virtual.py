"""The paper's re-alignment done virtually: a depth image seen by a turned camera (one image).

The paper turns the tool until the camera looks along the negative normal of
a plane, then looks again. With one image, the honest way to face the
support plane is to turn the camera about its own centre: the virtual
camera sees exactly the rays the real one saw, so nothing is invented and
no occlusion changes. Each virtual pixel (u', v') is the ray
r' = ((u' - cx') / fx, (v' - cy') / fy, 1) of the virtual frame, r = R r' in
the camera frame; the real pixel nearest to r (so no depth is blended
across an object's edge) gives a point p, and the virtual depth is p's
coordinate along the virtual optical axis, p . R e_z (exact for p, which
lies within half a pixel of the virtual ray). The virtual camera keeps the
size and focal lengths; its principal point moves so that the real optical axis keeps its pixel: the
view turns about the image centre and keeps most of the image.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.camera import Camera
from graspjax.geometry import rotation_between
from graspjax.perception.cluster import valid_mask

_OPTICAL_AXIS = np.array([0.0, 0.0, 1.0], np.float32)  # numpy: no backend at import


def view_rotation(normal: jax.Array, turn: jax.Array) -> jax.Array:
    """Virtual-to-camera rotation (3, 3): its z column is `-normal` (3,) when `turn`, else identity.

    normal: unit plane normal toward the camera; the virtual camera looks
    into the plane, turned from the real one by the smallest rotation.
    """
    safe = jnp.where(turn, normal, -_OPTICAL_AXIS)
    return jnp.where(turn, rotation_between(_OPTICAL_AXIS, -safe), jnp.eye(3, dtype=jnp.float32))


def view_camera(camera: Camera, rotation: jax.Array) -> Camera:
    """Intrinsics of a view turned by `rotation`: `camera`'s size and focal lengths, with the real
    optical axis kept at (cx, cy) (the view turns about the image centre)."""
    axis = rotation.T @ _OPTICAL_AXIS  # the real optical axis in the virtual frame
    return Camera(camera.width, camera.height, camera.fx, camera.fy,
                  camera.cx - camera.fx * axis[0] / axis[2],
                  camera.cy - camera.fy * axis[1] / axis[2])


def _sources(camera: Camera, view: Camera, rotation: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The real pixel nearest to each virtual pixel's ray: (u, v) int32 (H', W', 2), clipped,
    and whether the ray meets the real image (H', W')."""
    rays = _rotate(rotation, view.rays())  # (H, W, 3) in the camera frame, virtual z = 1
    forward = rays[..., 2] > 1e-6
    uv = camera.project(jnp.where(forward[..., None], rays, _OPTICAL_AXIS))
    iuv = jnp.round(uv).astype(jnp.int32)
    inside = (forward & (iuv[..., 0] >= 0) & (iuv[..., 0] < camera.width)
              & (iuv[..., 1] >= 0) & (iuv[..., 1] < camera.height))
    return jnp.stack([jnp.clip(iuv[..., 0], 0, camera.width - 1),
                      jnp.clip(iuv[..., 1], 0, camera.height - 1)], -1), inside


def _depth_along(depth: jax.Array, camera: Camera, rotation: jax.Array, iuv: jax.Array,
                 inside: jax.Array) -> jax.Array:
    """The depth along the virtual optical axis of the real pixels `iuv` (H', W', 2) (`_sources`);
    0 where `inside` is False or the pixel is invalid."""
    z = depth[iuv[..., 1], iuv[..., 0]]
    ok = inside & valid_mask(z)
    points = camera.unproject(iuv.astype(jnp.float32), jnp.where(ok, z, 0.0))  # the real pixel's point
    axis = rotation[:, 2]  # the virtual optical axis, camera frame
    along = points[..., 0] * axis[0] + points[..., 1] * axis[1] + points[..., 2] * axis[2]
    return jnp.where(ok, along, 0.0)  # its depth along the virtual axis


def warp_depth_and_values(depth: jax.Array, values: jax.Array, camera: Camera, view: Camera,
                          rotation: jax.Array, fill) -> tuple[jax.Array, jax.Array]:
    """`depth` and `values` (H, W) of `camera`'s pixels seen by `view` turned by `rotation`:
    the depth (H', W') along the virtual optical axis (0 where the virtual ray leaves the image
    or meets an invalid pixel; `depth` 0 or nan = invalid), and each virtual pixel's real
    pixel's value (H', W') (`fill` where the ray leaves the image); the rays traced once."""
    iuv, inside = _sources(camera, view, rotation)
    return (_depth_along(depth, camera, rotation, iuv, inside),
            jnp.where(inside, values[iuv[..., 1], iuv[..., 0]], fill))


def _rotate(rotation: jax.Array, vectors: jax.Array) -> jax.Array:
    """`rotation` (3, 3) applied to `vectors` (..., 3), written out: a per-pixel product that
    fuses with its neighbours (as a matrix product, XLA on the CPU runs it as its own call at
    twice the cost of the whole warp)."""
    return jnp.stack([vectors[..., 0] * rotation[row, 0] + vectors[..., 1] * rotation[row, 1]
                      + vectors[..., 2] * rotation[row, 2] for row in range(3)], -1)
