"""Pinhole camera model (OpenCV frame: x right, y down, z forward).

Pixel `(u, v)` is (column, row); pixel centres sit at integer coordinates, so
the image spans `[-0.5, width - 0.5]` and the default principal point is the
image centre `((width - 1) / 2, (height - 1) / 2)`. Depth is the z coordinate
in the camera frame (not the ray length).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from graspjax.tree import pytree_dataclass

KINECT_FOV_X_DEG = 57.0  # Microsoft Kinect (v1) horizontal field of view, as in the paper
KINECT_FOV_Y_DEG = 43.0  # Kinect vertical field of view
KINECT_WIDTH, KINECT_HEIGHT = 640, 480  # Kinect native depth resolution


@pytree_dataclass(meta=("width", "height"))
class Camera:
    """Pinhole intrinsics; `width`/`height` are static, the focal lengths and principal point are data."""

    width: int  # image columns (static)
    height: int  # image rows (static)
    fx: float  # focal length along x (pixels)
    fy: float  # focal length along y (pixels)
    cx: float  # principal point column (pixels)
    cy: float  # principal point row (pixels)

    def __post_init__(self):
        if not (isinstance(self.width, int) and isinstance(self.height, int)):
            raise ValueError("Camera width and height must be Python ints")
        if self.width < 8 or self.height < 8:
            raise ValueError(f"camera resolution {self.width}x{self.height} is too small (min 8x8)")

    # -- construction ------------------------------------------------------
    @classmethod
    def from_fov(cls, width: int, height: int, fov_x_deg: float, fov_y_deg: float | None = None,
                 cx: float | None = None, cy: float | None = None) -> Camera:
        """Intrinsics from full opening angles; `fov_y_deg=None` means square pixels."""
        if not 0.0 < fov_x_deg < 180.0:
            raise ValueError(f"horizontal field of view must be in (0, 180) degrees, got {fov_x_deg}")
        fx = width / (2.0 * math.tan(math.radians(fov_x_deg) / 2.0))
        if fov_y_deg is None:
            fy = fx
        else:
            if not 0.0 < fov_y_deg < 180.0:
                raise ValueError(f"vertical field of view must be in (0, 180) degrees, got {fov_y_deg}")
            fy = height / (2.0 * math.tan(math.radians(fov_y_deg) / 2.0))
        return cls(int(width), int(height), fx, fy,
                   (width - 1) / 2.0 if cx is None else float(cx),
                   (height - 1) / 2.0 if cy is None else float(cy))

    @classmethod
    def kinect(cls, width: int = 160, height: int = 120) -> Camera:
        """The paper's sensor (Kinect, 57 x 43 degrees), downsampled to `width` x `height`."""
        return cls.from_fov(width, height, KINECT_FOV_X_DEG, KINECT_FOV_Y_DEG)

    def scaled(self, width: int, height: int) -> Camera:
        """The same optics sampled at another resolution (e.g. after downsampling)."""
        sx, sy = width / self.width, height / self.height
        return Camera(int(width), int(height), self.fx * sx, self.fy * sy,
                      (self.cx + 0.5) * sx - 0.5, (self.cy + 0.5) * sy - 0.5)

    # -- geometry ----------------------------------------------------------
    @property
    def fov_x(self) -> float:
        """Full horizontal opening angle (rad)."""
        return 2.0 * math.atan(self.width / (2.0 * float(self.fx)))

    @property
    def fov_y(self) -> float:
        """Full vertical opening angle (rad)."""
        return 2.0 * math.atan(self.height / (2.0 * float(self.fy)))

    def project(self, points: jax.Array) -> jax.Array:
        """Camera-frame points `(..., 3)` -> pixel coordinates `(..., 2)` as (u, v)."""
        z = points[..., 2]
        return jnp.stack([self.fx * points[..., 0] / z + self.cx,
                          self.fy * points[..., 1] / z + self.cy], axis=-1)

    def unproject(self, uv: jax.Array, depth: jax.Array) -> jax.Array:
        """Pixel coordinates `(..., 2)` and depth `(...)` -> camera-frame points `(..., 3)`."""
        return jnp.stack(self.unproject_planes(uv[..., 0], uv[..., 1], depth), axis=-1)

    def unproject_planes(self, u: jax.Array, v: jax.Array, depth: jax.Array) -> tuple:
        """`unproject` with the coordinates apart: u, v, depth `(...)` -> x, y, z `(...)` each
        (no stack: a caller that works plane by plane keeps them so)."""
        return (u - self.cx) * depth / self.fx, (v - self.cy) * depth / self.fy, depth

    def pixel_grid(self) -> jax.Array:
        """Pixel-centre coordinates `(H, W, 2)` as (u, v)."""
        v, u = jnp.meshgrid(jnp.arange(self.height, dtype=jnp.float32),
                            jnp.arange(self.width, dtype=jnp.float32), indexing="ij")
        return jnp.stack([u, v], axis=-1)

    def rays(self) -> jax.Array:
        """Per-pixel ray directions `(H, W, 3)` in the camera frame with z = 1."""
        uv = self.pixel_grid()
        return self.unproject(uv, jnp.ones(uv.shape[:-1], jnp.float32))

    def d_p(self, z, footprint: bool = True):
        """Metric size of one pixel at depth `z` (paper Eq. 2): its footprint `z / fx`, as the
        text around Eq. 2 asks ("the units of each axis must be set identical").

        As printed, Eq. 2 is `z * tan(theta/2) / res_x = z / (2 fx)`, half the footprint
        (`footprint=False`).
        """
        return z / self.fx if footprint else z / (2.0 * self.fx)


