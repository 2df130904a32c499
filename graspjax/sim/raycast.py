"""Depth images of a simulated world from any tool-camera pose, for one world.

Every renderable geom (the table and the objects' pieces, never the
gripper) is convex, so it is the intersection of half-spaces
`n . x <= d` in its own frame. Those are read from the *compiled* MuJoCo
model (box sizes, the table plane, the convex hulls of the meshes as MuJoCo
stores them), so the camera sees exactly the shapes the physics collides.
A ray from the camera centre through pixel (u, v), with direction
`(x_n, y_n, 1)` in the camera frame, enters a convex piece at the largest
entry distance and leaves at the smallest exit distance; its depth is the
entry distance itself, because the ray's z component is 1. The result is
exact for polyhedra (tested against an independent analytic renderer).

This is cheaper than `mjx.ray` (which tests every triangle of every mesh per
ray and has no cylinder case): one division per pixel, plane and piece. The
Kinect model casts a second set of rays, from its projector, for shadows.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from scipy.spatial import ConvexHull

from graspjax.camera import Camera
from graspjax.config import CameraConfig


@dataclasses.dataclass(frozen=True)
class Solids:
    """Half-space form of every rendered geom (static per model): the camera's, the hand
    clearance check's and the ground truth's one description of the solids."""

    geom_ids: np.ndarray  # (G,) geom ids
    planes: np.ndarray  # (G, P, 4) (nx, ny, nz, d) in the geom frame; padding (0, 0, 0, 1)


def _hull_planes(vertices: np.ndarray) -> np.ndarray:
    """Unique facet planes (K, 4) of a convex hull, coplanar triangles merged."""
    eq = ConvexHull(vertices).equations  # n . x + c <= 0 inside
    planes = np.column_stack([eq[:, :3], -eq[:, 3]])
    unique = []
    for p in planes:
        if not any(np.allclose(p, q, atol=1e-7) for q in unique):
            unique.append(p)
    return np.array(unique)


def solids_of(mj_model: mujoco.MjModel, geom_ids) -> Solids:
    """Half-spaces of the given geoms of a compiled model (planes, boxes and meshes)."""
    per_geom = []
    for g in geom_ids:
        kind = mj_model.geom_type[g]
        if kind == mujoco.mjtGeom.mjGEOM_PLANE:
            planes = np.array([[0.0, 0.0, 1.0, 0.0]])
        elif kind == mujoco.mjtGeom.mjGEOM_BOX:
            h = mj_model.geom_size[g]
            eye = np.eye(3)
            planes = np.array([[*(s * eye[i]), h[i]] for i in range(3) for s in (1.0, -1.0)])
        elif kind == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = mj_model.geom_dataid[g]
            start, count = mj_model.mesh_vertadr[mesh], mj_model.mesh_vertnum[mesh]
            planes = _hull_planes(mj_model.mesh_vert[start:start + count].astype(float))
        else:
            raise ValueError(f"geom {g}: only planes, boxes and convex meshes are rendered")
        per_geom.append(planes)
    most = max(len(p) for p in per_geom)
    padded = np.zeros((len(per_geom), most, 4))
    padded[:, :, 3] = 1.0  # 0 . x <= 1 holds everywhere: a no-op plane
    for i, planes in enumerate(per_geom):
        padded[i, : len(planes)] = planes
    return Solids(np.asarray(geom_ids, np.int32), padded.astype(np.float32))


def world_planes(solids: Solids, geom_xpos: jax.Array, geom_xmat: jax.Array
                 ) -> tuple[jax.Array, jax.Array]:
    """Every piece's half-spaces in the world, `normals @ x <= offsets`: normals (G, P, 3) and
    offsets (G, P), from the geoms' world poses (ngeom, 3) and (ngeom, 3, 3) or (ngeom, 9)."""
    ids = solids.geom_ids
    normals = jnp.einsum("gij,gpj->gpi", geom_xmat[ids].reshape(-1, 3, 3),
                         jnp.asarray(solids.planes[..., :3]))
    return normals, solids.planes[..., 3] + jnp.einsum("gpi,gi->gp", normals, geom_xpos[ids])


def render_depth(solids: Solids, geom_xpos: jax.Array, geom_xmat: jax.Array,
                 rotation: jax.Array, position: jax.Array, camera: Camera,
                 config: CameraConfig = CameraConfig(), key: jax.Array | None = None) -> jax.Array:
    """Metric depth `(H, W)` seen from a camera pose in one world (0 = no valid return).

    Arguments as for `render_depth_and_piece`.
    """
    return render_depth_and_piece(solids, geom_xpos, geom_xmat, rotation, position, camera,
                                  config, key)[0]


def _first_hits(normals: jax.Array, offsets: jax.Array, rays: jax.Array,
                min_t: float) -> tuple[jax.Array, jax.Array]:
    """Where rays `(H, W, 3)` from one origin first enter a convex piece: ray parameter t
    `(H, W)` (inf: none) and the piece index `(H, W)` (-1: none). Pieces are half-spaces
    `normals . x <= offsets` `(G, P, 3)`, `(G, P)` relative to the origin; entries at
    t <= min_t do not count."""

    def nearest(carry, piece):
        """Keep the nearer of the hits so far and this convex piece's entry."""
        best, seen = carry
        planes, limits, index = piece  # (P, 3), (P,), ()
        enter = jnp.full(best.shape, -jnp.inf)
        leave = jnp.full(best.shape, jnp.inf)
        outside = jnp.zeros(best.shape, bool)
        for p in range(planes.shape[0]):  # unrolled: a handful of planes per piece
            denom = rays @ planes[p]
            num = limits[p]
            t = num / jnp.where(denom == 0, 1.0, denom)
            enter = jnp.where(denom < 0, jnp.maximum(enter, t), enter)
            leave = jnp.where(denom > 0, jnp.minimum(leave, t), leave)
            outside = outside | ((denom == 0) & (num < 0))
        hit = ~outside & (enter <= leave) & (enter > min_t)
        closer = hit & (enter < best)
        return (jnp.where(closer, enter, best), jnp.where(closer, index, seen)), None

    # One piece at a time keeps memory at one image per world, whatever the piece count.
    shape = rays.shape[:2]
    (t, piece), _ = jax.lax.scan(
        nearest, (jnp.full(shape, jnp.inf), jnp.full(shape, -1, jnp.int32)),
        (normals, offsets, jnp.arange(normals.shape[0], dtype=jnp.int32)))
    return t, piece


def kinect_axial_sigma(z):
    """Axial noise sigma (m) of a Kinect v1 at depth z (m): Nguyen, Izadi and Lovell (2012),
    "Modeling Kinect Sensor Noise for Improved 3D Reconstruction and Tracking", Eq. 6."""
    return 0.0012 + 0.0019 * (z - 0.4) ** 2


def render_depth_and_piece(solids: Solids, geom_xpos: jax.Array, geom_xmat: jax.Array,
                           rotation: jax.Array, position: jax.Array, camera: Camera,
                           config: CameraConfig = CameraConfig(), key: jax.Array | None = None
                           ) -> tuple[jax.Array, jax.Array]:
    """Metric depth `(H, W)` (0 = no valid return) and the index `(H, W)` int32 of the piece
    seen at each pixel (into `solids.geom_ids`, -1 where the depth is invalid).

    geom_xpos, geom_xmat: (ngeom, 3), (ngeom, 3, 3) or (ngeom, 9) world poses of
    all geoms (MJX `Data` fields after kinematics); rotation: camera-to-world
    (3, 3); position: camera centre (3,). `config.sensor`: "ideal" gives the
    exact depth; "kinect" models a Kinect v1 (docs/simulation.md): lateral
    noise on each pixel's ray, structured-light shadows (no depth where the
    projector, `baseline` beside the camera along +x, does not see the
    point), axial noise growing with depth, and disparity quantized in
    `disparity_step`s of a native pixel. key: PRNG key of the Kinect's noise.
    """
    normal_world, offset_world = world_planes(solids, geom_xpos, geom_xmat)
    normal_cam = jnp.einsum("ij,gpi->gpj", rotation, normal_world)  # R^T n
    offset_cam = offset_world - normal_world @ position  # (G, P)

    rays = camera.rays()  # (H, W, 3), z = 1
    kinect = config.sensor == "kinect"
    if kinect:
        if key is None:
            raise ValueError("the kinect sensor model needs a PRNG key")
        k_lateral, k_axial = jax.random.split(key)
        native_fx = camera.fx * config.native_width / camera.width  # focal length of the disparity
        # lateral noise: each pixel's ray off by N(0, lateral_px^2) native pixels in u and v
        jitter = config.noise_scale * config.lateral_px / native_fx
        rays = rays.at[..., :2].add(jitter * jax.random.normal(k_lateral, rays.shape[:2] + (2,)))
    depth, piece = _first_hits(normal_cam, offset_cam, rays, 0.0)  # z = 1: t is the depth
    if kinect:
        # Shadows: the ray from the projector to the point must not enter any piece before it.
        projector = jnp.array([config.baseline, 0.0, 0.0])
        points = rays * jnp.where(jnp.isfinite(depth), depth, 0.0)[..., None]
        t, _ = _first_hits(normal_cam, offset_cam - normal_cam @ projector, points - projector,
                           1e-6)
        lit = t >= 1.0 - 1e-3
        # axial noise: N(0, sigma(z)^2), then disparity (native pixels) quantized
        depth = depth + config.noise_scale * kinect_axial_sigma(depth) * jax.random.normal(
            k_axial, depth.shape)
        disparity = native_fx * config.baseline / depth
        step = config.disparity_step
        depth = native_fx * config.baseline / (jnp.round(disparity / step) * step)
        depth = jnp.where(lit, depth, jnp.inf)
    valid = jnp.isfinite(depth) & (depth >= config.min_range) & (depth <= config.max_range)
    return jnp.where(valid, depth, 0.0).astype(jnp.float32), jnp.where(valid, piece, -1)
