"""The resolutions a real depth image is taken at, on the host (NumPy): the full resolution the
detection needs (`input_reduction`), the detection resolution's block factor
(`detection_factor`), each from the intrinsics and the scene's median depth, and the block
medians and intrinsics of a reduced image (`block_median`, `reduced`). The device's block
median at the working resolutions is `perception.workspace.block_median`, a sorting network
over whole images; this one reduces a file once, before anything is compiled.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from graspjax.camera import Camera
from graspjax.config import RealImageConfig
from graspjax.perception.workspace import block_factors


def in_range(depth: np.ndarray, image: RealImageConfig) -> np.ndarray:
    """The image's valid depths in the depth range (n,) in metres: 0 and non-finite values
    are no depth."""
    return depth[np.isfinite(depth) & (depth > 0) & (depth >= image.min_depth)
                 & (depth <= image.max_depth)]


def pixel_footprint(depth: np.ndarray, camera: Camera, image: RealImageConfig) -> float:
    """Metres per pixel of `camera` (along its coarser axis) at the image's median valid depth
    in the depth range (`in_range`)."""
    return float(np.median(in_range(depth, image))) / min(camera.fx, camera.fy)


def input_reduction(depth: np.ndarray, camera: Camera, image: RealImageConfig) -> int:
    """The block factor that brings an image to the full resolution the detection needs: the
    largest whole factor that keeps its pixels at most `image.full_pixel` wide at the image's
    median valid depth (`pixel_footprint`), and at least what brings it to
    `image.max_full_pixels` pixels (an image coarser and smaller than that: 1)."""
    pixel = pixel_footprint(depth, camera, image)
    by_pixel = int(image.full_pixel / pixel) if pixel > 0 else 1
    by_count = math.ceil(math.sqrt(camera.width * camera.height / image.max_full_pixels))
    return max(1, by_pixel, by_count)


def detection_factor(depth: np.ndarray, camera: Camera, image: RealImageConfig) -> int:
    """The detection resolution's block factor from the full resolution (`camera`, `depth`):
    `image.downsample` if set, else the whole factor that brings its pixels nearest to
    `image.detect_pixel` at the median valid depth, by ratio (0.94 mm pixels go to 1.9 mm, not
    stay at 0.94, for 1.4 mm): chosen from the intrinsics and the scene's distance, not the
    pixel count (a wide lens's 1280 columns keep their pixels), or, with `detect_pixel` 0,
    from the width (`workspace.block_factors`)."""
    if image.downsample or not image.detect_pixel:
        return block_factors(camera.width, image)[0]
    pixel = pixel_footprint(depth, camera, image)
    if not pixel > 0:
        return 1
    ratio = image.detect_pixel / pixel
    low = max(1, math.floor(ratio))
    return low + 1 if ratio * ratio > low * (low + 1) else low  # the nearer by ratio


def block_median(depth: np.ndarray, factor: int) -> np.ndarray:
    """Depth (H, W) -> (H // factor, W // factor): each block's median of its valid pixels
    (0 where it has none); the last rows and columns that fill no block are dropped."""
    if factor == 1:
        return depth
    h, w = depth.shape[0] // factor, depth.shape[1] // factor
    blocks = depth[:h * factor, :w * factor].reshape(h, factor, w, factor).swapaxes(1, 2)
    blocks = np.where(np.isfinite(blocks) & (blocks > 0), blocks, np.nan).reshape(h, w, -1)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a block without valid pixels
        median = np.nanmedian(blocks, axis=-1)
    return np.nan_to_num(median, nan=0.0).astype(np.float32)


def reduced(camera: Camera, factor: int) -> Camera:
    """The intrinsics of an image block-medianed by `factor` (`block_median`)."""
    if factor == 1:
        return camera
    return Camera(camera.width // factor, camera.height // factor, camera.fx / factor,
                  camera.fy / factor, (camera.cx + 0.5) / factor - 0.5,
                  (camera.cy + 0.5) / factor - 0.5)
