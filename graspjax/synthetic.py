"""Exact depth images of convex primitives by ray casting, in NumPy.

A reference that shares no code with the perception kernels: tests compare
the detector with these analytic scenes, and the perception benchmark and
examples draw random scenes from here. A solid is a convex polyhedron given
as half-spaces `normal . x <= offset` (world frame, z up); a single
half-space is a tilted ground plane.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from graspjax.camera import Camera


@dataclasses.dataclass(frozen=True)
class Solid:
    """Convex polyhedron as the intersection of half-spaces `normals @ x <= offsets`."""

    normals: np.ndarray  # (P, 3) outward unit normals, world frame
    offsets: np.ndarray  # (P,)

    def moved(self, rotation: np.ndarray, translation) -> Solid:
        """The solid rotated by `rotation` (3, 3) about the origin, then translated."""
        normals = self.normals @ np.asarray(rotation).T
        return Solid(normals, self.offsets + normals @ np.asarray(translation, float))


def rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def prism(polygon, height: float, position=(0.0, 0.0, 0.0), yaw: float = 0.0) -> Solid:
    """Upright prism over a convex counter-clockwise `polygon` (N, 2), base at `position`."""
    poly = np.asarray(polygon, float)
    edges = np.roll(poly, -1, axis=0) - poly
    side = np.stack([edges[:, 1], -edges[:, 0], np.zeros(len(poly))], axis=1)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    offsets = np.einsum("ij,ij->i", side[:, :2], poly)
    normals = np.vstack([side, [[0, 0, 1], [0, 0, -1]]])
    local = Solid(normals, np.concatenate([offsets, [height, 0.0]]))
    return local.moved(rot_z(yaw), position)


def box(size, position=(0.0, 0.0, 0.0), yaw: float = 0.0) -> Solid:
    """Box of `size` (sx, sy, sz) standing on its base centred at `position`."""
    sx, sy, sz = size
    poly = [(-sx / 2, -sy / 2), (sx / 2, -sy / 2), (sx / 2, sy / 2), (-sx / 2, sy / 2)]
    return prism(poly, sz, position, yaw)


def regular_prism(sides: int, radius: float, height: float, position=(0.0, 0.0, 0.0),
                  yaw: float = 0.0) -> Solid:
    """Prism over a regular polygon with circumradius `radius`."""
    angles = 2 * np.pi * np.arange(sides) / sides
    return prism(np.stack([radius * np.cos(angles), radius * np.sin(angles)], 1), height,
                 position, yaw)


def half_space(normal, point) -> Solid:
    """Everything below the plane through `point` with upward `normal`."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    return Solid(n[None], np.array([n @ np.asarray(point, float)]))


def top_down_pose(height: float, x: float = 0.0, y: float = 0.0):
    """Camera-to-world rotation and position looking straight down from `height`.

    Camera x = world x, camera y = world -y, camera z (optical axis) = world -z.
    """
    rotation = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])
    return rotation, np.array([x, y, height], float)


def analytic_depth(camera: Camera, rotation: np.ndarray, position, solids, ground: float | None = 0.0):
    """Depth image `(H, W)` float32 of `solids` seen from a camera pose (0 = no hit).

    rotation: camera-to-world (3, 3); position: camera centre (3,) in the world;
    ground: height of a horizontal table plane (None for none).
    """
    scene = list(solids)
    if ground is not None:
        scene.append(half_space([0, 0, 1], [0, 0, ground]))
    v, u = np.meshgrid(np.arange(camera.height), np.arange(camera.width), indexing="ij")
    rays_cam = np.stack([(u - float(camera.cx)) / float(camera.fx),
                         (v - float(camera.cy)) / float(camera.fy), np.ones(u.shape)], -1)
    rays = rays_cam @ np.asarray(rotation, float).T  # world directions, camera z = 1
    origin = np.asarray(position, float)
    depth = np.full(u.shape, np.inf)
    for solid in scene:
        denom = rays @ solid.normals.T  # (H, W, P)
        num = solid.offsets - solid.normals @ origin  # (P,)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = num / denom
        enter = np.where(denom < 0, t, -np.inf).max(-1)
        leave = np.where(denom > 0, t, np.inf).min(-1)
        parallel_out = ((denom == 0) & (num < 0)).any(-1)
        hit = (enter <= leave) & (leave > 0) & ~parallel_out & (enter > 0)
        depth = np.where(hit, np.minimum(depth, enter), depth)
    return np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)


def _random_solids(rng: np.random.Generator) -> list[Solid]:
    """1-4 random boxes and prisms around the world origin, some tilted."""
    solids = []
    for _ in range(rng.integers(1, 5)):
        # footprint radius U(1.5, 4.5) cm, height U(2, 8) cm, centre U(-8, 8) cm, yaw U(-pi, pi)
        radius, tall = rng.uniform(0.015, 0.045), rng.uniform(0.02, 0.08)
        centre, yaw = (*rng.uniform(-0.08, 0.08, 2), 0.0), rng.uniform(-np.pi, np.pi)
        if rng.random() < 0.5:
            solid = box((radius * 2, radius * rng.uniform(1.0, 2.5), tall), centre, yaw)
        else:
            solid = regular_prism(int(rng.integers(3, 9)), radius, tall, centre, yaw)
        if rng.random() < 0.3:  # tilted by U(0, 30) degrees about a random horizontal axis
            tilt = rot_z(rng.uniform(-np.pi, np.pi)) @ rot_x(rng.uniform(0, np.pi / 6))
            solid = solid.moved(np.eye(3), -np.asarray(centre)).moved(tilt, centre)
        solids.append(solid)
    return solids


def random_scene(rng: np.random.Generator, camera: Camera, height: float = 0.5) -> np.ndarray:
    """Top-down depth image of 1-4 random boxes and prisms on a table, some tilted.

    A perception workload with the variety of the experiments (single objects,
    neighbours, clutter); used by the benchmark and examples, never by tests.
    """
    rotation, eye = top_down_pose(height)
    return analytic_depth(camera, rotation, eye, _random_solids(rng))


def random_real_scene(rng: np.random.Generator, camera: Camera, height: float = 0.7) -> np.ndarray:
    """A real-looking depth image: `random_scene`'s objects seen from a tilted camera.

    The camera looks at the objects from `height` with its axis U(0, 20)
    degrees off vertical, toward a random side; a 3 x 3 x 8 cm "finger" hangs
    into the bottom of the view 0.3 m away (outside a workspace that leaves
    out the bottom 15% of the rows); 3% of the pixels drop out and 20 single
    pixels are outliers at 0.3-0.5 m. The benchmark workload of `graspjax
    detect`, never used by tests.
    """
    tilt = rng.uniform(0.0, np.deg2rad(20.0))
    down, _ = top_down_pose(0.0)
    rotation = rot_z(rng.uniform(-np.pi, np.pi)) @ down @ rot_x(tilt)
    eye = np.array([0.0, 0.0, 0.0]) - rotation[:, 2] * height / np.cos(tilt)
    finger = eye + rotation @ np.array([0.0, 0.5 * camera.height / camera.fy * 0.3, 0.3])
    solids = [*_random_solids(rng), box((0.03, 0.03, 0.08), finger - [0.0, 0.0, 0.04])]
    depth = analytic_depth(camera, rotation, eye, solids)
    depth[rng.random(depth.shape) < 0.03] = 0.0
    rows, cols = rng.integers(0, depth.shape[0], 20), rng.integers(0, depth.shape[1], 20)
    depth[rows, cols] = rng.uniform(0.3, 0.5, 20)
    return depth
