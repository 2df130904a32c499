"""Synthetic depth images made to look like real captures, with analytic ground truth.

A tilted camera over a table (PrimeSense-like: 640x480, fx = 525, 13 degrees,
a robot finger nearer than the table at the bottom border) and a bin (PhoXi-
like focal length, 8 degrees, walls with a rim), rendered exactly by
`graspjax.synthetic`; holes and outlier specks are added by hand. Nothing
here shares code with the perception kernels.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from graspjax import Camera
from graspjax.synthetic import analytic_depth, box, rot_x, rot_y, top_down_pose

WIDTH, HEIGHT = 640, 480


@dataclasses.dataclass(frozen=True)
class RealScene:
    depth: np.ndarray  # (H, W) float32 metres, 0 = no return
    camera: Camera  # full-resolution intrinsics
    rotation: np.ndarray  # (3, 3) camera-to-world
    eye: np.ndarray  # (3,) camera centre, world
    workspace: np.ndarray  # (H, W) bool: the box a user would give
    roi: tuple[int, int, int, int]  # the same box as X0, Y0, X1, Y1
    top: np.ndarray  # (3,) world centre of the target's top face
    size: tuple[float, float]  # the target's footprint (along its x, along its y), metres
    yaw: float  # the target's yaw about world z

    def to_camera(self, point) -> np.ndarray:
        """Camera-frame coordinates (3,) of a world point."""
        return self.rotation.T @ (np.asarray(point, float) - self.eye)

    def direction(self, vector) -> np.ndarray:
        """Camera-frame direction (3,) of a world direction."""
        return self.rotation.T @ np.asarray(vector, float)

    @property
    def up(self) -> np.ndarray:
        """The table's normal toward the camera, in the camera frame (3,)."""
        return self.direction([0.0, 0.0, 1.0])


def tilted_pose(height: float, tilt_deg: float, about: str = "x"):
    """Camera-to-world rotation and centre `height` above the table, tilted from straight down."""
    down, _ = top_down_pose(0.0)
    turn = rot_x if about == "x" else rot_y
    return down @ turn(np.deg2rad(tilt_deg)), np.array([0.0, 0.0, height])


def _roi_mask(roi) -> np.ndarray:
    mask = np.zeros((HEIGHT, WIDTH), bool)
    mask[roi[1]:roi[3], roi[0]:roi[2]] = True
    return mask


def table_scene() -> RealScene:
    """A 4 x 7 x 4 cm box on a table seen 13 degrees off vertical from 0.73 m; a finger
    hangs into the bottom of the view 0.3 m from the camera, outside the workspace."""
    camera = Camera(WIDTH, HEIGHT, 525.0, 525.0, 319.5, 239.5)
    rotation, eye = tilted_pose(0.73, 13.0)
    size, yaw, centre = (0.04, 0.07), 0.3, (0.02, 0.15)
    target = box((*size, 0.04), (*centre, 0.0), yaw)
    finger_centre = eye + rotation @ np.array([-0.10, 0.12, 0.30])
    finger = box((0.03, 0.03, 0.08), finger_centre - [0.0, 0.0, 0.04])
    depth = analytic_depth(camera, rotation, eye, [target, finger])
    roi = (40, 20, 600, 400)
    return RealScene(depth, camera, rotation, eye, _roi_mask(roi), roi,
                     np.array([*centre, 0.04]), size, yaw)


def with_holes_and_specks(scene: RealScene, seed: int = 0) -> RealScene:
    """The scene with 5% random dropouts, a 4-pixel crack along the target's long side,
    single outlier pixels and 4 x 4 pixel specks at 0.3-0.4 m inside the workspace."""
    rng = np.random.default_rng(seed)
    depth = scene.depth.copy()
    depth[rng.random(depth.shape) < 0.05] = 0.0
    # The crack: the target's top-face centre line along its long (local y) side.
    top = scene.camera.project(scene.to_camera(scene.top))
    along = scene.camera.project(scene.to_camera(
        scene.top + 0.025 * np.array([-np.sin(scene.yaw), np.cos(scene.yaw), 0.0])))
    for t in np.linspace(-1.0, 1.0, 200):
        u, v = np.round(np.asarray(top) + t * (np.asarray(along) - np.asarray(top))).astype(int)
        depth[v - 2: v + 2, u - 2: u + 2] = np.nan
    x0, y0, x1, y1 = scene.roi
    for _ in range(40):  # single pixels
        depth[rng.integers(y0, y1), rng.integers(x0, x1)] = rng.uniform(0.3, 0.4)
    for _ in range(6):  # 4 x 4 specks
        u, v = rng.integers(x0, x1 - 4), rng.integers(y0, y1 - 4)
        depth[v: v + 4, u: u + 4] = rng.uniform(0.3, 0.4)
    return dataclasses.replace(scene, depth=depth.astype(np.float32))


def bin_scene(whole: bool = False) -> RealScene:
    """A 36 x 26 x 12 cm bin (1 cm walls) seen 8 degrees off vertical from 0.8 m, holding
    three boxes; the 6 cm tall one is the highest object. The workspace is the rectangle
    inside the projected inner rim, so it holds parts of the walls' inner faces; with `whole`,
    a box around the whole bin, walls and rims included."""
    camera = Camera(WIDTH, HEIGHT, 552.5, 552.5, 319.5, 239.5)
    rotation, eye = tilted_pose(0.8, 8.0, about="y")
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    cx, cy = (eye + axis * eye[2] / -axis[2])[:2]  # where the optical axis meets the floor
    length, width, height, t = 0.36, 0.26, 0.12, 0.01
    walls = [box((length + 2 * t, t, height), (cx, cy + s * (width + t) / 2, 0.0)) for s in (-1, 1)]
    walls += [box((t, width, height), (cx + s * (length + t) / 2, cy, 0.0)) for s in (-1, 1)]
    size, yaw, centre = (0.04, 0.06), -0.5, (cx + 0.03, cy - 0.02)
    objects = [box((*size, 0.06), (*centre, 0.0), yaw),
               box((0.05, 0.08, 0.03), (cx - 0.08, cy + 0.03, 0.0), 0.2),
               box((0.06, 0.06, 0.02), (cx + 0.12, cy + 0.06, 0.0))]
    depth = analytic_depth(camera, rotation, eye, walls + objects)
    rim = np.array([camera.project(rotation.T @ (np.array([cx + sx * length / 2,
                                                            cy + sy * width / 2, height]) - eye))
                    for sx in (-1, 1) for sy in (-1, 1)])  # (-,-), (-,+), (+,-), (+,+)
    roi = (int(np.ceil(rim[:2, 0].max())) + 2, int(np.ceil(rim[[1, 3], 1].max())) + 2,
           int(rim[2:, 0].min()) - 2, int(rim[[0, 2], 1].min()) - 2)
    if whole:
        roi = (10, 10, WIDTH - 10, HEIGHT - 10)
    return RealScene(depth, camera, rotation, eye, _roi_mask(roi), roi,
                     np.array([*centre, 0.06]), size, yaw)


def table_with(solids, roi=(40, 20, 600, 400), tilt_deg: float = 13.0):
    """`solids` on the PrimeSense-like tilted table: depth (H, W), camera, workspace (H, W),
    and the camera-to-world rotation (3, 3) and centre (3,) to check results in world terms;
    `tilt_deg` off vertical (about world x)."""
    camera = Camera(WIDTH, HEIGHT, 525.0, 525.0, 319.5, 239.5)
    rotation, eye = tilted_pose(0.73, tilt_deg)
    return (analytic_depth(camera, rotation, eye, solids), camera, _roi_mask(roi), rotation, eye)


def table_centre(tilt_deg: float = 13.0) -> np.ndarray:
    """Where the tilted table camera's optical axis meets the table (world x, y)."""
    rotation, eye = tilted_pose(0.73, tilt_deg)
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    return (eye + axis * eye[2] / -axis[2])[:2]


def steep_table_scene() -> RealScene:
    """A 4 x 6 x 15 cm box standing on a table seen 44 degrees off vertical from 0.58 m (an
    RGB-D camera on a robot's head, as the NVlabs demo frames), 4 cm nearer than where the
    optical axis meets the table: the camera sees its near face almost as much as its top."""
    camera = Camera(WIDTH, HEIGHT, 613.0, 613.0, 319.5, 239.5)
    rotation, eye = tilted_pose(0.58, 44.0)
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    cx, cy = (eye + axis * eye[2] / -axis[2])[:2]  # where the optical axis meets the table
    near = rotation @ np.array([0.0, 1.0, 0.0])  # down the image, along the table
    size, yaw = (0.04, 0.06), 0.2
    centre = np.array([cx, cy]) + 0.04 * near[:2] / np.linalg.norm(near[:2])
    depth = analytic_depth(camera, rotation, eye, [box((*size, 0.15), (*centre, 0.0), yaw)])
    roi = (20, 20, 620, 460)
    return RealScene(depth, camera, rotation, eye, _roi_mask(roi), roi,
                     np.array([*centre, 0.15]), size, yaw)
