"""The inputs of a detection on real depth images: files, intrinsics, workspace, settings.

`prepare` reads and checks everything a user can get wrong (image formats and sizes,
intrinsics, workspace, depth range) before anything is computed; every problem is an
`InputError` with a one-line message. The command line parses its flags into the values
taken here (`IntrinsicsRequest`, a workspace box, a depth range).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from graspjax.camera import KINECT_FOV_X_DEG, KINECT_FOV_Y_DEG, Camera
from graspjax.config import Config, RealImageConfig, override
from graspjax.disk import check_utf8_name
from graspjax.errors import InputError
from graspjax.imagefiles.bins import bin_interior
from graspjax.imagefiles.readers import (
    load_camera_pose,
    load_intrinsics,
    load_mask,
    read_depth,
    scaled_depth,
)
from graspjax.imagefiles.resolution import (
    block_median,
    detection_factor,
    in_range,
    input_reduction,
    reduced,
)
from graspjax.perception.workspace import block_factors

DEPTH_SUFFIXES = (".npy", ".npz", ".png", ".tif", ".tiff", ".pcd", ".ply")
#: The full opening angle (degrees) along each axis that intrinsics may give the images. Depth
#: cameras for grasping see from about 20 degrees (long-range structured-light scanners) to
#: about 120 (wide time-of-flight modes), and a pinhole model holds nothing near 180; 5-150
#: leaves room for cropped images and still catches a focal length in another unit
#: (millimetres: nearly 180 degrees) or orders of magnitude off (fx 1e5 for 640 columns: 0.37
#: degrees, where the pixels' footprint would reduce the image to none).
FIELD_OF_VIEW_DEG = (5.0, 150.0)
#: The median depth (m) an image's pixels in the depth range may have: depth cameras for
#: grasping read from about 7 cm (close-range stereo) to 10-20 m at most (time-of-flight,
#: stereo), and a scene is seen from within that; 5 cm - 20 m leaves room either side and
#: still catches a wrong unit, a thousandfold off (metres in a 16-bit PNG read as millimetres:
#: 1-2 mm; a depth scale of 1e-6 for millimetres: under 1 cm), where the pixels' footprint
#: would reduce the image to none.
MEDIAN_DEPTH_M = (0.05, 20.0)


@dataclasses.dataclass(frozen=True)
class Intrinsics:
    """Where the intrinsics come from: explicit values, or each file's own K, or the default."""

    values: tuple[float, float, float, float] | None  # (fx, fy, cx, cy), None: per image
    source: str  # how the user gave them, for the records

    def describe(self, file_k: np.ndarray | None) -> str:
        """Where one image's intrinsics come from."""
        if self.values is not None:
            return self.source
        return "the file's K" if file_k is not None else "the Kinect's 57 x 43 degrees (default)"

    def camera(self, width: int, height: int, file_k: np.ndarray | None) -> Camera:
        """Full-resolution intrinsics of one `width` x `height` image with its own `file_k`."""
        if self.values is not None:
            return Camera(width, height, *map(float, self.values))
        if file_k is not None:
            return Camera(width, height, float(file_k[0, 0]), float(file_k[1, 1]),
                          float(file_k[0, 2]), float(file_k[1, 2]))
        return Camera.from_fov(width, height, KINECT_FOV_X_DEG, KINECT_FOV_Y_DEG)


@dataclasses.dataclass(frozen=True)
class IntrinsicsRequest:
    """The intrinsics as the user gave them, in at most one way (full-resolution pixels), to be
    resolved once the images' size is known. Nothing given: each file's own K, else the
    Kinect's field of view."""

    focal: tuple[float, float] | None = None  # (fx, fy) in pixels
    centre: tuple[float | None, float | None] = (None, None)  # (cx, cy); None: the image centre
    file: str | None = None  # JSON with fx, fy, cx, cy (or K), a gqcnn .intr, a 3x3 .npy/.txt
    fov_deg: tuple[float | None, float | None] | None = None  # (horizontal, vertical) degrees
    source: str = "per image"  # how they were given, for the records ({fx}, {fy}, {cx}, {cy}
    # stand for the resolved values)

    def resolve(self, width: int, height: int) -> Intrinsics:
        """The intrinsics of `width` x `height` images: finite, the focal lengths > 0."""
        intrinsics = self._resolve(width, height)
        if intrinsics.values is not None:
            fx, fy, cx, cy = intrinsics.values
            if not all(math.isfinite(v) for v in (fx, fy, cx, cy)):
                raise InputError(f"the intrinsics must be finite numbers, got fx {fx:g}, fy "
                                 f"{fy:g}, cx {cx:g}, cy {cy:g} ({intrinsics.source})")
            if fx <= 0 or fy <= 0:
                raise InputError("focal lengths must be > 0")
        return intrinsics

    def _resolve(self, width: int, height: int) -> Intrinsics:
        if self.focal is not None:
            fx, fy = self.focal
            cx = (width - 1) / 2 if self.centre[0] is None else self.centre[0]
            cy = (height - 1) / 2 if self.centre[1] is None else self.centre[1]
            return Intrinsics((fx, fy, cx, cy), self.source.format(fx=fx, fy=fy, cx=cx, cy=cy))
        if self.file is not None:
            data = load_intrinsics(self.file)
            stated = (data.get("width"), data.get("height"))
            if None not in stated and stated != (width, height):
                raise InputError(f"{self.file} is for {stated[0]:g}x{stated[1]:g} images, the "
                                 f"depth images are {width}x{height}")
            return Intrinsics((data["fx"], data["fy"], data["cx"], data["cy"]), self.file)
        if self.fov_deg is not None:
            fov_x, fov_y = self.fov_deg
            try:
                cam = Camera.from_fov(width, height, KINECT_FOV_X_DEG if fov_x is None else fov_x,
                                      fov_y if fov_y is not None or fov_x is None else None)
            except ValueError as exc:
                raise InputError(str(exc)) from None
            return Intrinsics((cam.fx, cam.fy, cam.cx, cam.cy), self.source)
        return Intrinsics(None, self.source)


@dataclasses.dataclass(frozen=True)
class Inputs:
    """Everything one detection run needs, checked. The detection works on the images
    block-medianed by `reduction` (`input_reduction`): its full resolution is `width` x
    `height`; the records give pixels in the files' own.

    Each image has its own resolutions, from its intrinsics and its median depth
    (`resolutions`): images whose resolutions differ from the first's are detected apart, in
    programs of their own (`parts`), so that no image's result depends on the others given
    with it. `reduction`, `width`, `height`, `workspace` and `image.downsample` are the first
    image's."""

    paths: tuple[Path, ...]  # the depth images, all of one size
    source_size: tuple[int, int]  # the files' columns and rows
    reduction: int  # block factor from the files to the detection's full resolution (1: none)
    width: int  # full-resolution columns (the files' // reduction)
    height: int  # full-resolution rows
    resolutions: tuple[tuple[int, int], ...]  # per image: its `reduction` and its detection
    # resolution's block factor (`resolution.detection_factor`)
    depth_scale: float  # metres per unit of a 16-bit PNG
    intrinsics: Intrinsics  # of the files
    workspace: np.ndarray  # (H, W) bool at full resolution, True where the search may look
    source_workspace: np.ndarray  # the same in the files' pixels (before the reduction)
    bins: tuple[np.ndarray, ...] | None  # with --bin: every image's bin interior within its
    # workspace (`bins.bin_interior`), bits packed along rows (H, ceil(W / 8)) uint8 at its
    # resolution; else None
    roi: tuple[int, int, int, int] | None  # (x0, y0, x1, y1) in the files' pixels
    mask: str | None  # mask file
    camera_pose: np.ndarray | None  # (4, 4) camera to world (`readers.load_camera_pose`), or None
    config: Config  # `image`: its real-image steps' settings (`Config.image`)

    @property
    def image(self) -> RealImageConfig:
        return self.config.image

    def read(self, path: Path) -> tuple[np.ndarray, Camera, str]:
        """One image at full resolution (this `Inputs`' `reduction`: a part's for its own
        images, `parts`): its depth (H, W), its camera and where its intrinsics come from."""
        return self.at_full_resolution(*read_depth(path, self.depth_scale))

    def at_full_resolution(self, depth: np.ndarray, file_k) -> tuple[np.ndarray, Camera, str]:
        """`read` of an image already read from its file (`read_depth`: depth, its K or None)."""
        camera = self.intrinsics.camera(*self.source_size, file_k)
        if self.reduction > 1:  # pixels outside the range take no part; those outside the
            # workspace stay, for the jaws' checks (`detect_real_image` masks them elsewhere)
            kept = (depth >= self.image.min_depth) & (depth <= self.image.max_depth)
            depth = block_median(np.where(kept, depth, 0.0), self.reduction)
        return depth, reduced(camera, self.reduction), self.intrinsics.describe(file_k)

    def workspace_of(self, index: int) -> np.ndarray:
        """Where the search may look in image `index` of `paths` (H, W) bool, at this
        `Inputs`' resolution (a part's for its own images, `parts`): its bin's interior with
        --bin, else the one `workspace`."""
        if self.bins is None:
            return self.workspace
        return np.unpackbits(self.bins[index], axis=-1, count=self.width).astype(bool)

    def parts(self) -> list[tuple[tuple[int, ...], Inputs]]:
        """The images by resolution, the first image's first: each part's positions among
        `paths` and its `Inputs` (its images alone, at their resolution), one compiled program
        each."""
        positions: dict[tuple[int, int], list[int]] = {}
        for i, resolution in enumerate(self.resolutions):
            positions.setdefault(resolution, []).append(i)
        return [(tuple(indices), dataclasses.replace(
            _at_resolution(self, *resolution), paths=tuple(self.paths[i] for i in indices),
            resolutions=(resolution,) * len(indices),
            bins=None if self.bins is None else tuple(self.bins[i] for i in indices)))
            for resolution, indices in positions.items()]

    def source_pixel(self, pixel) -> np.ndarray:
        """Full-resolution pixel coordinates (..., 2) (u, v), at this `Inputs`' `reduction`, in
        the files' own pixels."""
        if self.reduction == 1:
            return pixel
        return (np.asarray(pixel, np.float64) + 0.5) * self.reduction - 0.5


def split_overrides(items: Sequence[str]) -> tuple[Config, RealImageConfig]:
    """Settings by dotted name: `image.NAME=V` for `RealImageConfig`, the rest for `Config`;
    applied in order, a later item replacing an earlier one (the user's `--set` over the
    preset's)."""
    config = Config()
    for item in items:
        config = override(config, [item])
    return config, config.image


def expand_images(images: Sequence[str | Path]) -> tuple[Path, ...]:
    """The image paths, a directory standing for its depth files (`DEPTH_SUFFIXES`), sorted."""
    paths = []
    for image in images:
        path = Path(image)
        if path.is_dir():
            inside = sorted(p for p in path.iterdir()
                            if p.is_file() and p.suffix.lower() in DEPTH_SUFFIXES)
            if not inside:
                raise InputError(f"directory {path} holds no {', '.join(DEPTH_SUFFIXES)} files")
            paths += inside
        else:
            paths.append(path)
    if not paths:
        raise InputError("no depth images given")
    for path in paths:  # its name goes into the CSV and JSON records, which are UTF-8
        check_utf8_name(path, "the file name")
    return tuple(paths)


def _check_range(depth: np.ndarray, path: Path, image: RealImageConfig, depth_scale: float) -> None:
    """Refuse an image none of whose pixels lies in the depth range, or whose median depth
    there lies outside `MEDIAN_DEPTH_M` (a wrong depth scale or unit)."""
    scaled = scaled_depth(path)  # integer units of the depth scale, not metres
    kept = in_range(depth, image)
    if not kept.size:
        valid = depth[np.isfinite(depth) & (depth > 0)]
        unit = f" with depth scale {depth_scale:g}" if scaled else ""
        raise InputError(f"{path}: every pixel lies outside the depth range "
                         f"{image.min_depth:g}-{image.max_depth:g} m (its depths span "
                         f"{valid.min():.4g}-{valid.max():.4g} m{unit}; check the depth scale "
                         "or the range)")
    median = float(np.median(kept))
    low, high = MEDIAN_DEPTH_M
    if not low <= median <= high:
        hint = (f"check --depth-scale (metres per unit of the image, now {depth_scale:g})" if scaled
                else "its depth must be in metres")
        raise InputError(f"{path}: median depth {median:.3g} m (in the depth range "
                         f"{image.min_depth:g}-{image.max_depth:g} m) is implausible for a depth "
                         f"camera ({low:g}-{high:g} m): {hint}")


def _plausible_camera(source: Intrinsics, width: int, height: int, path: Path,
                     file_k: np.ndarray | None) -> Camera:
    """The full-resolution camera of the `width` x `height` image at `path` (its own K
    `file_k`, or None), refused in one line naming where its intrinsics come from when their
    field of view lies outside `FIELD_OF_VIEW_DEG`."""
    camera = source.camera(width, height, file_k)
    fov = math.degrees(camera.fov_x), math.degrees(camera.fov_y)
    low, high = FIELD_OF_VIEW_DEG
    if not all(low <= angle <= high for angle in fov):
        given = (f"{path}'s K" if source.values is None and file_k is not None
                 else source.describe(file_k))
        raise InputError(f"the intrinsics from {given} give the {width}x{height} images a "
                         f"{fov[0]:.3g} x {fov[1]:.3g} degree field of view, outside a depth "
                         f"camera's {low:g}-{high:g}: check the focal lengths (in pixels of "
                         "these images)")
    return camera


def assumed_camera(camera: Camera) -> str:
    """The one line that says images without intrinsics are taken with the Kinect's field of
    view (`camera`, at the images' size), and how to give the real ones."""
    return (f"no intrinsics given and none in the files: assuming a Kinect v1's "
            f"{KINECT_FOV_X_DEG:g} x {KINECT_FOV_Y_DEG:g} degree field of view (fx {camera.fx:.1f}, "
            f"fy {camera.fy:.1f} for {camera.width}x{camera.height}); give the camera's own with "
            "--intrinsics FILE, --K, --fx/--fy/--cx/--cy or --fov-x/--fov-y")


def _workspace_box(roi: tuple[int, int, int, int], width: int, height: int) -> np.ndarray:
    """The workspace (H, W) bool of a box of columns x0 <= u < x1 and rows y0 <= v < y1."""
    x0, y0, x1, y1 = roi
    if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
        raise InputError(f"the workspace box {x0},{y0},{x1},{y1} lies outside the "
                         f"{width}x{height} image (need 0 <= X0 < X1 <= {width}, "
                         f"0 <= Y0 < Y1 <= {height})")
    inside = np.zeros((height, width), bool)
    inside[y0:y1, x0:x1] = True
    return inside


def _workspace(roi: tuple[int, int, int, int] | None, mask: str | None, width: int,
               height: int) -> np.ndarray:
    """Where the search may look (height, width) bool, in the files' pixels: the box `roi` and
    the `mask` file, each where given; one line where they do not overlap."""
    workspace = np.ones((height, width), bool)
    if roi is not None:
        workspace &= _workspace_box(roi, width, height)
    if mask is not None:
        workspace &= load_mask(mask, (height, width))
        if not workspace.any():
            raise InputError(f"the mask {mask} and the workspace box {roi} do not overlap")
    return workspace


def _reduced_workspace(workspace: np.ndarray, reduction: int) -> np.ndarray:
    """`workspace` at the resolution the images are taken at (blocks of `reduction`): a pixel
    is in it when most of its block is; one line where nothing is left."""
    if reduction == 1:
        return workspace
    height, width = workspace.shape
    small_h, small_w = height // reduction, width // reduction
    blocks = workspace[:small_h * reduction, :small_w * reduction]
    reduced = blocks.reshape(small_h, reduction, small_w, reduction).mean(axis=(1, 3)) > 0.5
    if not reduced.any():
        raise InputError(f"the workspace is too small for the {small_w}x{small_h} "
                         f"resolution the {width}x{height} images are taken at (block "
                         f"{reduction}): give a larger --roi or mask")
    return reduced


def prepare(images: Sequence[str | Path], *, depth_scale: float = 0.001,
            intrinsics: IntrinsicsRequest = IntrinsicsRequest(),
            roi: tuple[int, int, int, int] | None = None, mask: str | None = None,
            depth_range: tuple[float, float] | None = None, downsample: int | None = None,
            overrides: Sequence[str] = (), bin: bool = False, camera_pose: str | None = None,
            warn: Callable[[str], None] = warnings.warn) -> Inputs:
    """Read and check every input; nothing is computed yet but, with `bin`, each image's bin
    interior (`bins.bin_interior`), which narrows that image's workspace: a bin found in every
    image, so that images of several bins (or of one bin that moved) each get their own, and
    an image without one stops the run before anything is written. Every image is read here
    once, to check it (its size, its intrinsics, its depth range) and find its bin.

    `camera_pose`: a file of the camera's pose (`readers.load_camera_pose`), read and checked here.

    Images without intrinsics (none given, none in the files) are taken with the Kinect's field
    of view, never silently: `warn` gets one line saying so (`assumed_camera`), once every
    input passed its checks (a mistake stays the one line of its `InputError`)."""
    paths = expand_images(images)
    if not (depth_scale > 0 and math.isfinite(depth_scale)):
        raise InputError(f"the depth scale must be > 0, got {depth_scale!r}")
    config, image = split_overrides(overrides)
    if depth_range is not None:
        image = dataclasses.replace(image, min_depth=depth_range[0], max_depth=depth_range[1])
    if downsample is not None:
        image = dataclasses.replace(image, downsample=downsample)

    first, first_k = read_depth(paths[0], depth_scale)
    height, width = first.shape
    source = intrinsics.resolve(width, height)
    source_workspace = _workspace(roi, mask, width, height)
    inputs = Inputs(paths=paths, source_size=(width, height), reduction=1, width=width,
                    height=height, resolutions=(), depth_scale=depth_scale, intrinsics=source,
                    workspace=source_workspace, source_workspace=source_workspace, bins=None,
                    roi=roi, mask=mask,
                    camera_pose=None if camera_pose is None else load_camera_pose(camera_pose),
                    config=dataclasses.replace(config, image=dataclasses.replace(
                        image, bin=image.bin or bin)))
    resolutions, interiors = [], []
    at: dict[tuple[int, int], Inputs] = {}  # each resolution's settings, made once
    for i, path in enumerate(paths):
        depth, k = (first, first_k) if i == 0 else read_depth(path, depth_scale)
        if depth.shape != (height, width):
            raise InputError(f"all images must have one size: {paths[0]} is {width}x{height}, "
                             f"{path} is {depth.shape[1]}x{depth.shape[0]}")
        if source.values is None and (k is None) != (first_k is None):
            with_k, without = (paths[0], path) if first_k is not None else (path, paths[0])
            raise InputError(f"{with_k} holds its intrinsics K but {without} does not; give "
                             "the intrinsics for all images")
        _check_range(depth, path, image, depth_scale)
        camera = _plausible_camera(source, width, height, path, k)
        try:  # the image's own resolutions, refused where they leave too few pixels
            reduction = _checked_reduction(input_reduction(depth, camera, image), width,
                                           height, image)
            resolution = reduction, detection_factor(depth, reduced(camera, reduction), image)
            if resolution not in at:
                at[resolution] = _at_resolution(inputs, *resolution)
        except InputError as error:
            raise InputError(f"{path}: {error}") from None
        if i == 0:
            inputs = at[resolution]  # the first image's resolution is the run's
        resolutions.append(resolution)
        if inputs.image.bin:
            interiors.append(np.packbits(_bin_of(at[resolution], path, depth, k), axis=-1))
    if source.values is None and first_k is None:  # once all is checked: a mistake is one line
        warn(assumed_camera(inputs.intrinsics.camera(width, height, None)))
    return dataclasses.replace(inputs, resolutions=tuple(resolutions),
                               bins=tuple(interiors) if interiors else None)


def _checked_reduction(reduction: int, width: int, height: int, image: RealImageConfig) -> int:
    """`reduction` of `width` x `height` files; one line where it leaves less than 8 x 8
    pixels (checked before a `Camera` of that size is made: it refuses one)."""
    if min(width // reduction, height // reduction) < 8:
        raise InputError(f"reducing {width}x{height} by {reduction} (to pixels of "
                         f"image.full_pixel {image.full_pixel:g} m at the median depth, at most "
                         "image.max_full_pixels) leaves less than 8x8 pixels")
    return reduction


def _at_resolution(inputs: Inputs, reduction: int, factor: int) -> Inputs:
    """`inputs` at another resolution: the files block-medianed by `reduction` (`reduction`,
    `width`, `height`, `workspace`), the detection at block `factor` of that
    (`image.downsample`); one line where either leaves too few pixels."""
    width, height = inputs.source_size
    _checked_reduction(reduction, width, height, inputs.image)
    small_w, small_h = width // reduction, height // reduction
    image = dataclasses.replace(inputs.image, downsample=factor)
    _, coarse = block_factors(small_w, image)
    if min(small_w, small_h) // coarse < 8:
        raise InputError(f"downsampling {width}x{height} by {reduction * coarse} leaves less "
                         "than 8x8 pixels")
    return dataclasses.replace(
        inputs, reduction=reduction, width=small_w, height=small_h,
        workspace=_reduced_workspace(inputs.source_workspace, reduction),
        config=dataclasses.replace(inputs.config, image=image))


def _bin_of(inputs: Inputs, path: Path, source_depth: np.ndarray, file_k) -> np.ndarray:
    """The bin's interior (H, W) bool in the image at `path` (read: `source_depth` in the
    file's pixels, its K or None), within the workspace; an `InputError` naming the image when
    it shows no bin floor."""
    depth, camera, _ = inputs.at_full_resolution(source_depth, file_k)
    image = inputs.image
    factor = block_factors(inputs.width, image)[1]  # the support resolution
    seen = np.where(inputs.workspace & np.isfinite(depth) & (depth >= image.min_depth)
                    & (depth <= image.max_depth), depth, 0.0)
    coarse = block_median(seen, factor), reduced(camera, factor)
    try:
        return bin_interior(seen, camera, inputs.workspace, image, coarse)
    except InputError as error:
        raise InputError(f"{path}: {error}") from None
