"""`graspjax detect`: the perception kernels on real depth images from disk.

`prepare` reads and checks everything a user can get wrong (image formats
and sizes, intrinsics, workspace, depth range; `check_output` the output
paths) before any work is done; `run` pushes the images through
`detect_scene`, batched with `jax.vmap` in chunks of one compiled size, and
returns one JSON record per image; `csv_bytes` makes the results table, and
`figure` the debug figure of one image. The CLI (`graspjax detect`) writes
them atomically. User mistakes raise `InputError` with a one-line message.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import time
import typing
from collections.abc import Callable, Sequence
from pathlib import Path

import jax
import numpy as np

from graspjax.camera import KINECT_FOV_X_DEG, KINECT_FOV_Y_DEG, Camera
from graspjax.config import Config, SceneConfig, override
from graspjax.io import InputError, check_matrix, load_intrinsics, load_mask, read_depth
from graspjax.perception import AlignReason, GraspReason
from graspjax.perception.reasons import SupportReason, TargetReason
from graspjax.perception.scene import detect_scene, scene_views
from graspjax.perception.workspace import block_factors

#: `detect_scene` over a batch: depth (B, H, W), workspace (H, W), a `Camera` whose fx, fy, cx,
#: cy are (B,) arrays (`stack_cameras`), `Config`, `SceneConfig`. One compile per batch size,
#: image size and configuration.
detect_images = jax.jit(jax.vmap(detect_scene, in_axes=(0, None, 0, None, None)))
_views = jax.jit(scene_views)


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
class Inputs:
    """Everything one `graspjax detect` run needs, checked."""

    paths: tuple[Path, ...]  # the depth images, all of one size
    width: int  # their columns
    height: int  # their rows
    depth_scale: float  # metres per unit of a 16-bit PNG
    intrinsics: Intrinsics
    workspace: np.ndarray  # (H, W) bool, True where the search may look
    roi: tuple[int, int, int, int] | None  # (x0, y0, x1, y1) full-resolution pixels
    mask: str | None  # mask file
    config: Config
    scene: SceneConfig


# ---------------------------------------------------------------------------
# Parsing and checking


def _settings_type():
    """`Config`'s sections plus `scene`, so that `--set` names and suggestions cover both."""
    hints = typing.get_type_hints(Config)
    fields = [(f.name, hints[f.name], dataclasses.field(default=getattr(Config(), f.name)))
              for f in dataclasses.fields(Config)]
    fields.append(("scene", SceneConfig, dataclasses.field(default=SceneConfig())))
    return dataclasses.make_dataclass("DetectSettings", fields, frozen=True)


_Settings = _settings_type()


def split_overrides(items: Sequence[str]) -> tuple[Config, SceneConfig]:
    """`--set` values by dotted name: `scene.NAME=V` for `SceneConfig`, the rest for `Config`."""
    settings = override(_Settings(), items)
    config = Config(**{f.name: getattr(settings, f.name) for f in dataclasses.fields(Config)})
    return config, settings.scene


def _numbers(text: str, count: int, name: str) -> list[float]:
    parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise InputError(f"{name} takes {count} comma-separated numbers, got {text!r}")
    return values


def parse_roi(text: str, width: int, height: int) -> tuple[int, int, int, int]:
    """`X0,Y0,X1,Y1` (columns X0 <= u < X1, rows Y0 <= v < Y1), inside a `width` x `height` image."""
    values = _numbers(text, 4, "--roi")
    if any(v != int(v) for v in values):
        raise InputError(f"--roi takes whole pixels, got {text!r}")
    x0, y0, x1, y1 = map(int, values)
    if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
        raise InputError(f"--roi {text} lies outside the {width}x{height} image "
                         f"(need 0 <= X0 < X1 <= {width}, 0 <= Y0 < Y1 <= {height})")
    return x0, y0, x1, y1


def parse_range(text: str) -> tuple[float, float]:
    """`MIN,MAX` in metres, 0 <= MIN < MAX."""
    lo, hi = _numbers(text, 2, "--range")
    if not 0 <= lo < hi:
        raise InputError(f"--range needs 0 <= MIN < MAX (metres), got {text!r}")
    return lo, hi


def intrinsics_from(fx=None, fy=None, cx=None, cy=None, k=None, intrinsics=None, fov_x=None,
                    fov_y=None, size: tuple[int, int] | None = None) -> Intrinsics:
    """The one way the user gave intrinsics (full-resolution pixels); two ways at once is an error.

    size: (width, height) of the images, checked against an intrinsics file that states it.
    """
    given = {"--fx/--fy/--cx/--cy": any(v is not None for v in (fx, fy, cx, cy)),
             "--K": k is not None, "--intrinsics": intrinsics is not None,
             "--fov-x/--fov-y": fov_x is not None or fov_y is not None}
    chosen = [name for name, used in given.items() if used]
    if len(chosen) > 1:
        raise InputError(f"give the intrinsics one way, not {' and '.join(chosen)}")
    width, height = size
    if given["--fx/--fy/--cx/--cy"]:
        if fx is None:
            raise InputError("--fy, --cx and --cy need --fx")
        fy = fx if fy is None else fy
        if fx <= 0 or fy <= 0:
            raise InputError("focal lengths must be > 0")
        values = (fx, fy, (width - 1) / 2 if cx is None else cx, (height - 1) / 2 if cy is None else cy)
        return Intrinsics(values, f"--fx {fx:g} --fy {fy:g} --cx {values[2]:g} --cy {values[3]:g}")
    if given["--K"]:
        m = check_matrix(np.reshape(_numbers(k, 9, "--K"), (3, 3)), "--K")
        return Intrinsics((m[0, 0], m[1, 1], m[0, 2], m[1, 2]), "--K")
    if given["--intrinsics"]:
        data = load_intrinsics(intrinsics)
        stated = (data.get("width"), data.get("height"))
        if None not in stated and stated != (width, height):
            raise InputError(f"{intrinsics} is for {stated[0]:g}x{stated[1]:g} images, the depth "
                             f"images are {width}x{height}")
        return Intrinsics((data["fx"], data["fy"], data["cx"], data["cy"]), str(intrinsics))
    if given["--fov-x/--fov-y"]:
        try:
            cam = Camera.from_fov(width, height, KINECT_FOV_X_DEG if fov_x is None else fov_x,
                                  fov_y if fov_y is not None or fov_x is None else None)
        except ValueError as exc:
            raise InputError(str(exc)) from None
        return Intrinsics((cam.fx, cam.fy, cam.cx, cam.cy), "--fov-x/--fov-y")
    return Intrinsics(None, "per image")


DEPTH_SUFFIXES = (".npy", ".npz", ".png")


def expand_images(images: Sequence[str | Path]) -> tuple[Path, ...]:
    """The image paths, a directory standing for its depth files (.npy, .npz, .png), sorted."""
    paths = []
    for image in images:
        path = Path(image)
        if path.is_dir():
            inside = sorted(p for p in path.iterdir()
                            if p.is_file() and p.suffix.lower() in DEPTH_SUFFIXES)
            if not inside:
                raise InputError(f"directory {path} holds no .npy, .npz or .png files")
            paths += inside
        else:
            paths.append(path)
    if not paths:
        raise InputError("no depth images given")
    return tuple(paths)


def _check_range(depth: np.ndarray, path: Path, scene: SceneConfig, depth_scale: float) -> None:
    """Refuse an image none of whose pixels lies in the depth range (a wrong depth scale)."""
    valid = depth[np.isfinite(depth) & (depth > 0)]
    if not ((valid >= scene.min_depth) & (valid <= scene.max_depth)).any():
        unit = f" with --depth-scale {depth_scale:g}" if path.suffix.lower() == ".png" else ""
        raise InputError(f"{path}: every pixel lies outside the depth range "
                         f"{scene.min_depth:g}-{scene.max_depth:g} m (its depths span "
                         f"{valid.min():.4g}-{valid.max():.4g} m{unit}; check the depth scale "
                         "or --range)")


def prepare(images: Sequence[str | Path], *, depth_scale: float = 0.001, intrinsics: dict | None = None,
            roi: str | None = None, mask: str | None = None, depth_range: str | None = None,
            downsample: int | None = None, overrides: Sequence[str] = ()) -> Inputs:
    """Read and check every input; nothing is computed or written yet.

    intrinsics: keyword arguments of `intrinsics_from` (fx, fy, cx, cy, k,
    intrinsics, fov_x, fov_y). Every image is read once here, to check it.
    """
    paths = expand_images(images)
    if not (depth_scale > 0 and math.isfinite(depth_scale)):
        raise InputError(f"--depth-scale must be > 0, got {depth_scale!r}")
    config, scene = split_overrides(overrides)
    if depth_range is not None:
        lo, hi = parse_range(depth_range)
        scene = dataclasses.replace(scene, min_depth=lo, max_depth=hi)
    if downsample is not None:
        if downsample < 1:
            raise InputError(f"--downsample must be >= 1, got {downsample}")
        scene = dataclasses.replace(scene, downsample=downsample)

    first, first_k = read_depth(paths[0], depth_scale)
    height, width = first.shape
    fine, coarse = block_factors(width, scene)
    if min(width, height) // coarse < 8:
        raise InputError(f"downsampling {width}x{height} by {coarse} leaves less than 8x8 pixels")
    source = intrinsics_from(**(intrinsics or {}), size=(width, height))
    workspace = np.ones((height, width), bool)
    box = parse_roi(roi, width, height) if roi is not None else None
    if box is not None:
        inside = np.zeros_like(workspace)
        inside[box[1]:box[3], box[0]:box[2]] = True
        workspace &= inside
    if mask is not None:
        workspace &= load_mask(mask, (height, width))
        if not workspace.any():
            raise InputError(f"--mask {mask} and --roi {roi} do not overlap")
    for i, path in enumerate(paths):
        depth, k = (first, first_k) if i == 0 else read_depth(path, depth_scale)
        if depth.shape != (height, width):
            raise InputError(f"all images must have one size: {paths[0]} is {width}x{height}, "
                             f"{path} is {depth.shape[1]}x{depth.shape[0]}")
        if source.values is None and (k is None) != (first_k is None):
            with_k, without = (paths[0], path) if first_k is not None else (path, paths[0])
            raise InputError(f"{with_k} holds its intrinsics K but {without} does not; give "
                             "--intrinsics (or --fx ...) for all images")
        _check_range(depth, path, scene, depth_scale)
    return Inputs(paths=paths, width=width, height=height, depth_scale=depth_scale,
                  intrinsics=source, workspace=workspace, roi=box, mask=mask, config=config,
                  scene=scene)


# ---------------------------------------------------------------------------
# Running


def stack_cameras(cameras: Sequence[Camera]) -> Camera:
    """One `Camera` (fx, fy, cx, cy of shape (B,)) from B cameras of one size, for `detect_images`."""
    c0 = cameras[0]
    return Camera(c0.width, c0.height, *(np.array([getattr(c, f) for c in cameras], np.float32)
                                         for f in ("fx", "fy", "cx", "cy")))


def record(path: Path, r, camera: Camera, source: str, inputs: Inputs, load_s: float,
           compute_s: float) -> dict:
    """The JSON record of one image from its (single, NumPy) `SceneDetection` `r`."""
    g, a, s = r.grasp, r.alignment, r.support
    target_ok = int(r.target_reason) == TargetReason.FOUND
    reason = (GraspReason(int(g.reason)).name if target_ok
              else TargetReason(int(r.target_reason)).name)
    fine, coarse = block_factors(inputs.width, inputs.scene)
    return {
        "image": str(path),
        "found": bool(r.found),
        "reason": reason,
        "size": [inputs.width, inputs.height],
        "working_resolution": [inputs.width // fine, inputs.height // fine],
        "downsample": fine,
        "support_resolution": [inputs.width // coarse, inputs.height // coarse],
        "window": inputs.scene.crop_px,
        "camera": {"fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy,
                   "source": source},
        "workspace": {"roi": list(inputs.roi) if inputs.roi else None, "mask": inputs.mask,
                      "range": [inputs.scene.min_depth, inputs.scene.max_depth],
                      "pixels": int(inputs.workspace.sum())},
        "support_plane": {"found": bool(s.found), "reason": SupportReason(int(s.reason)).name,
                          "normal": s.normal, "distance": s.distance,
                          "tilt_deg": np.rad2deg(s.tilt), "inliers": int(s.inliers),
                          "inlier_fraction": s.fraction},
        "view": "virtual" if bool(r.virtual) else "camera",
        "view_rotation": r.rotation,
        "window_camera": {"fx": r.view.fx, "fy": r.view.fy, "cx": r.view.cx, "cy": r.view.cy},
        "target": {"reason": TargetReason(int(r.target_reason)).name,
                   "attempts": int(r.attempts),
                   "attempt_reasons": [GraspReason(int(x)).name for x in r.attempt_reasons if x >= 0],
                   "pixel": r.target_pixel, "point": r.target_point, "height": r.target_height},
        "grasp": {"found": bool(r.found), "reason": GraspReason(int(g.reason)).name,
                  "position": r.position, "closing_axis": r.closing_axis,
                  "approach": r.approach, "width": g.width, "depth": g.depth,
                  "surface_depth": g.surface_depth, "pixel": r.pixel,
                  "surface_pixels": int(g.surface_pixels),
                  "valid_candidates": int(g.candidates.valid.sum())},
        "alignment": {"found": bool(a.found), "reason": AlignReason(int(a.reason)).name,
                      "normal": r.plane_normal, "point": r.plane_point,
                      "inliers": int(a.inliers), "counts": a.counts},
        "timing": {"load_ms": 1e3 * load_s, "compute_ms": 1e3 * compute_s},
    }


def run(inputs: Inputs, batch: int = 16, progress: Callable[[int], None] = lambda n: None,
        log: Callable[[str], None] = lambda m: None,
        each: Callable[[int, np.ndarray, Camera, object], None] | None = None) -> list[dict]:
    """Records of every image, in order, computed `batch` images per compiled call.

    progress(n): n more images done. each(i, depth, camera, result): called
    per image with its full-resolution depth and its (NumPy) `SceneDetection`.
    """
    batch = max(1, min(batch, len(inputs.paths)))
    workspace = inputs.workspace
    args = (inputs.config, inputs.scene)
    records, compiled = [], False
    for start in range(0, len(inputs.paths), batch):
        chunk = inputs.paths[start:start + batch]
        depths, cameras, sources, loads = [], [], [], []
        for path in chunk:
            t0 = time.perf_counter()
            depth, file_k = read_depth(path, inputs.depth_scale)
            depths.append(depth)
            cameras.append(inputs.intrinsics.camera(inputs.width, inputs.height, file_k))
            sources.append(inputs.intrinsics.describe(file_k))
            loads.append(time.perf_counter() - t0)
        pad = batch - len(chunk)  # one compiled size: repeat the last image
        stacked = np.stack(depths + [depths[-1]] * pad)
        camera = stack_cameras(cameras + [cameras[-1]] * pad)
        if not compiled:
            t0 = time.perf_counter()
            jax.block_until_ready(detect_images(stacked, workspace, camera, *args))
            log(f"compiled and ran the first {batch} image(s) in {time.perf_counter() - t0:.1f} s")
            compiled = True
        t0 = time.perf_counter()
        result = jax.tree.map(np.asarray, detect_images(stacked, workspace, camera, *args))
        per_image = (time.perf_counter() - t0) / batch
        for i, path in enumerate(chunk):
            single = jax.tree.map(lambda x, i=i: x[i], result)
            records.append(record(path, single, cameras[i], sources[i], inputs, loads[i],
                                  per_image))
            if each is not None:
                each(start + i, depths[i], cameras[i], single)
        progress(len(chunk))
    return records


def figure(inputs: Inputs, depth: np.ndarray, camera: Camera, result, title: str) -> bytes:
    """PNG bytes of the debug figure of one image (`graspjax.viz.scene_figure`)."""
    from graspjax.viz import scene_figure

    views = _views(depth, inputs.workspace, camera, inputs.config, inputs.scene)
    return scene_figure(depth, inputs.workspace, camera, views, result, inputs.config,
                        inputs.scene, title=title)


def figure_names(paths: Sequence[Path]) -> list[str]:
    """Distinct PNG names for the images: their stems, prefixed by parent folders where needed."""
    parts = [p.resolve().with_suffix("").parts for p in paths]
    for depth in range(1, max(len(q) for q in parts) + 1):
        names = ["_".join(q[-depth:]) for q in parts]
        if len(set(names)) == len(names):
            return [n + ".png" for n in names]
    return [f"{i:05d}_{p.stem}.png" for i, p in enumerate(paths)]


# ---------------------------------------------------------------------------
# Output


CSV_COLUMNS = [
    "image", "found", "reason", "x", "y", "z", "axis_x", "axis_y", "axis_z", "approach_x",
    "approach_y", "approach_z", "width", "grasp_depth", "u", "v", "target_u", "target_v",
    "target_height", "attempts", "view", "support", "support_nx", "support_ny", "support_nz",
    "support_distance", "support_tilt_deg", "support_inlier_fraction", "alignment",
    "align_nx", "align_ny", "align_nz", "load_ms", "compute_ms",
]


def csv_row(rec: dict) -> list:
    """One CSV row (`CSV_COLUMNS`) of a record."""
    g, s, t, a = rec["grasp"], rec["support_plane"], rec["target"], rec["alignment"]
    return [rec["image"], rec["found"], rec["reason"], *g["position"], *g["closing_axis"],
            *g["approach"], g["width"], g["depth"], *g["pixel"], *t["pixel"], t["height"],
            t["attempts"], rec["view"], s["reason"], *s["normal"], s["distance"], s["tilt_deg"],
            s["inlier_fraction"], a["reason"], *a["normal"], rec["timing"]["load_ms"],
            rec["timing"]["compute_ms"]]


def csv_bytes(records: Sequence[dict]) -> bytes:
    """The results table: one row per image, nan as an empty cell."""
    import pandas as pd

    frame = pd.DataFrame([csv_row(r) for r in records], columns=CSV_COLUMNS)
    return frame.to_csv(index=False, float_format="%.6g").encode()


def check_output(path: str | None, what: str, directory: bool = False) -> None:
    """Fail before any work if `path` cannot be written (its parent must exist and be writable)."""
    if path is None:
        return
    target = Path(path)
    if directory and target.exists() and not target.is_dir():
        raise InputError(f"{what} {path} exists and is not a directory")
    if not directory and target.is_dir():
        raise InputError(f"{what} {path} is a directory")
    parent = target.resolve().parent if not (directory and target.is_dir()) else target.resolve()
    if not parent.is_dir():
        raise InputError(f"cannot write {path}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"cannot write {path}: directory {parent} is not writable")
