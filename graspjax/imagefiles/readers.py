"""Reading depth images, intrinsics and workspace masks from disk.

Depth: `.npy` (H, W) or (H, W, 1) in metres; a 16-bit `.png` in units of
`depth_scale` metres (default millimetres); a `.tif`/`.tiff` of float32 metres or
16-bit units of `depth_scale`; `.npz` holding `depth` (metres) and optionally `K`
(3x3), the Contact-GraspNet convention, or an organised point cloud `xyz`
(H, W, 3) in the camera frame, whose intrinsics are fitted to its points; an organised PCL
`.pcd` cloud or PLY range grid (`clouds.read_pcd`, `clouds.read_ply`), read the same way.
Intrinsics: a JSON file with fx, fy, cx, cy (or a 3x3 `K`, or Open3D's
`intrinsic_matrix`), a gqcnn `.intr` (JSON with _fx, _fy, _cx, _cy, _width,
_height), a ROS `camera_info` `.yaml`/`.yml`, or a 3x3 matrix in `.npy`/`.txt`.
Every problem raises `InputError` with a one-line message.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from graspjax.errors import InputError


def _first_line(exc: Exception) -> str:
    return (str(exc).splitlines() or [type(exc).__name__])[0]


def _existing_file(path: Path, what: str) -> None:
    if not path.exists():
        raise InputError(f"no such file: {path}")
    if path.is_dir():
        raise InputError(f"{path} is a directory, not {what}")


def _colour_check(data: np.ndarray, path: Path) -> None:
    """Refuse an 8-bit image with 3 or 4 channels: a colour picture given as depth."""
    if data.ndim == 3 and data.shape[-1] in (3, 4):
        raise InputError(f"{path} is a colour image ({data.shape[1]}x{data.shape[0]}, "
                         f"{data.shape[-1]} channels, {data.dtype}), not a depth image")


def _metric_array(data: np.ndarray, path: Path) -> np.ndarray:
    _colour_check(data, path)
    if not np.issubdtype(data.dtype, np.floating):
        raise InputError(f"{path}: expected float depth in metres, got dtype {data.dtype} "
                         "(store integer depth as a 16-bit .png with --depth-scale)")
    return data.astype(np.float32)


#: Pillow's modes of a single-channel integer image: depth in units of `depth_scale`.
INTEGER_MODES = ("I;16", "I;16B", "I;16L", "I")
#: The largest pixel error (RMS) of a point cloud's fitted pinhole camera (`fit_intrinsics`): a
#: cloud computed from a depth image through a pinhole camera fits it to rounding.
MAX_FIT_RMS_PX = 0.1


def scaled_depth(path: str | os.PathLike) -> bool:
    """Whether the depth image at `path` holds integer units of `depth_scale` (a 16-bit PNG or
    TIFF), not metres."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".tif", ".tiff"):
        return suffix == ".png"
    from PIL import Image

    with Image.open(path) as image:
        return image.mode in INTEGER_MODES


def _image(path: Path, kind: str) -> tuple[np.ndarray, str]:
    """An image file's pixels and Pillow's mode; a colour image or another mode refused."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            mode = image.mode
            data = np.asarray(image)
    except Exception as exc:
        raise InputError(f"cannot read {path} as {kind}: {_first_line(exc)}") from None
    _colour_check(data, path)
    return data, mode


def fit_intrinsics(xyz: np.ndarray, name: str) -> np.ndarray:
    """The pinhole intrinsics K (3, 3) of an organised point cloud `xyz` (H, W, 3) in the camera
    frame (z forward): u = fx x / z + cx and v = fy y / z + cy fitted by least squares over
    the points with z > 0, pixel (u, v) being the point's column and row. A cloud they do not
    fit within `MAX_FIT_RMS_PX` (not organised, or not in the camera frame) is refused."""
    x, y, z = np.moveaxis(xyz.astype(np.float64), -1, 0)
    v, u = np.indices(z.shape)
    ok = np.isfinite(xyz).all(axis=-1) & (z > 0)
    k = np.eye(3)
    for axis, (ratio, pixel) in enumerate(((x / np.where(ok, z, 1), u),
                                          (y / np.where(ok, z, 1), v))):
        a, b = ratio[ok], pixel[ok].astype(np.float64)
        if a.size < 3 or np.ptp(b) == 0 or np.ptp(a) <= 0:
            raise InputError(f"{name}: too few points in distinct columns and rows to recover the "
                             "intrinsics")
        (focal, centre), *_ = np.linalg.lstsq(np.stack([a, np.ones_like(a)], -1), b, rcond=None)
        rms = float(np.sqrt(np.mean((focal * a + centre - b) ** 2)))
        if not rms <= MAX_FIT_RMS_PX:
            raise InputError(f"{name}: the points fit no pinhole camera ({'uv'[axis]} off by "
                             f"{rms:.3g} px RMS): expected an organised cloud (H, W, 3) in the "
                             "camera frame, z forward")
        k[axis, axis], k[axis, 2] = focal, centre
    return check_matrix(k, f"{name}: the intrinsics fitted to its points")


def read_depth(path: str | os.PathLike, depth_scale: float = 0.001
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """Metric depth `(H, W)` float32 and the file's own intrinsics `K` (3, 3) or None.

    `.npy` (H, W) or (H, W, 1) in metres; 16-bit `.png` times `depth_scale`
    (metres per unit); `.tif`/`.tiff` float32 (mode F) in metres or 16-bit times
    `depth_scale`; `.npz` with `depth` in metres and optionally `K`, or with an organised
    point cloud `xyz` (H, W, 3) in metres in the camera frame: depth is its z and K, unless
    the file holds one, is fitted to its points (`fit_intrinsics`); an organised `.pcd` or
    `.ply` cloud (`clouds.read_pcd`, `clouds.read_ply`) likewise. 0 and nan mark invalid
    pixels. Raises `InputError` for anything else.
    """
    path = Path(path)
    _existing_file(path, "a depth image")
    suffix = path.suffix.lower()
    matrix = None
    if suffix == ".npy":
        try:
            data = np.load(path, allow_pickle=False)
        except Exception as exc:  # corrupt or not an .npy file at all
            raise InputError(f"cannot read {path} as .npy: {_first_line(exc)}") from None
        depth = _metric_array(data, path)
    elif suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as archive:
                arrays = {k: archive[k] for k in archive.files if k in ("depth", "K", "xyz")}
                names = archive.files
        except Exception as exc:
            raise InputError(f"cannot read {path} as .npz: {_first_line(exc)}") from None
        if "depth" in arrays:
            depth = _metric_array(arrays["depth"], path)
        elif "xyz" in arrays:
            xyz = arrays["xyz"]
            if xyz.ndim != 3 or xyz.shape[-1] != 3 or not np.issubdtype(xyz.dtype, np.floating):
                raise InputError(f"{path}: expected 'xyz' an organised point cloud (H, W, 3) of "
                                 f"floats in metres, got shape {xyz.shape} ({xyz.dtype})")
            depth = xyz[..., 2].astype(np.float32)
            if "K" not in arrays:
                matrix = fit_intrinsics(xyz, f"{path}: xyz")
        else:
            raise InputError(f"{path} holds no 'depth' or 'xyz' array (it has: "
                             f"{', '.join(names) or 'none'})")
        if "K" in arrays:
            matrix = check_matrix(arrays["K"], f"{path}: K")
    elif suffix == ".png":
        data, mode = _image(path, ".png")
        if mode not in INTEGER_MODES or data.ndim != 2:
            raise InputError(f"{path}: expected a single-channel 16-bit PNG of depth, got mode "
                             f"{mode} ({data.dtype})")
        depth = data.astype(np.float32) * np.float32(depth_scale)
    elif suffix in (".tif", ".tiff"):
        data, mode = _image(path, "TIFF")
        if mode == "F" and data.ndim == 2:
            depth = data.astype(np.float32)
        elif mode in INTEGER_MODES and data.ndim == 2:
            depth = data.astype(np.float32) * np.float32(depth_scale)
        else:
            raise InputError(f"{path}: expected a single-channel TIFF of float32 metres or 16-bit "
                             f"depth, got mode {mode} ({data.dtype})")
    elif suffix in (".pcd", ".ply"):
        from graspjax.imagefiles.clouds import read_pcd, read_ply

        xyz = (read_pcd if suffix == ".pcd" else read_ply)(path)
        depth = xyz[..., 2]
        matrix = fit_intrinsics(xyz, f"{path}: its points")
    else:
        raise InputError(f"unknown depth format {suffix or '(none)'!r} for {path} "
                         "(expected .npy or .npz in metres, a 16-bit .png, a float32 or "
                         "16-bit .tif, or an organised .pcd or .ply cloud)")
    return check_depth(depth, str(path)), matrix


def check_matrix(matrix, name: str = "K") -> np.ndarray:
    """A pinhole intrinsics matrix (3, 3): positive focal lengths, no skew, last row (0, 0, 1).
    Booleans (JSON true/false, a bool array) are no numbers."""
    if any(isinstance(v, (bool, np.bool_)) for v in np.asarray(matrix, dtype=object).ravel()):
        raise InputError(f"{name}: expected numbers, got true/false")
    try:
        k = np.asarray(matrix, np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric 3x3 matrix") from None
    if k.shape != (3, 3) or not np.isfinite(k).all():
        raise InputError(f"{name}: expected a finite 3x3 matrix, got shape {k.shape}")
    if k[0, 0] <= 0 or k[1, 1] <= 0:
        raise InputError(f"{name}: focal lengths must be > 0, got {k[0, 0]:g} and {k[1, 1]:g}")
    if abs(k[0, 1]) > 1e-6 * k[0, 0] or k[1, 0] != 0 or not np.allclose(k[2], [0, 0, 1]):
        raise InputError(f"{name}: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)")
    return k


def load_intrinsics(path: str | os.PathLike) -> dict:
    """Intrinsics `{fx, fy, cx, cy}` (plus `width`, `height` when the file gives them).

    JSON (`.json`, gqcnn `.intr`) with fx, fy, cx, cy, or with a leading
    underscore (_fx, ...), or a 3x3 `K`, or Open3D's `PinholeCameraIntrinsic` (`width`,
    `height`, `intrinsic_matrix`: 9 numbers, column by column); a ROS `camera_info` `.yaml` /
    `.yml` (`camera_info_yaml`); or a 3x3 matrix in `.npy` / `.txt`. A JSON file's values
    (pixels) must be finite numbers > 0, not true or false.
    """
    path = Path(path)
    _existing_file(path, "an intrinsics file")
    suffix = path.suffix.lower()
    try:
        if suffix in (".npy", ".txt"):
            data = np.load(path, allow_pickle=False) if suffix == ".npy" else np.loadtxt(path)
            k = check_matrix(data, str(path))
            return {"fx": k[0, 0], "fy": k[1, 1], "cx": k[0, 2], "cy": k[1, 2]}
        if suffix in (".yaml", ".yml"):
            return camera_info_yaml(path.read_text(), str(path))
        data = json.loads(path.read_text())
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"cannot read intrinsics from {path}: {_first_line(exc)}") from None
    if not isinstance(data, dict):
        raise InputError(f"cannot read intrinsics from {path}: expected a JSON object")
    names = {key.lstrip("_"): key for key in data}  # as the file spells them, for messages
    data = {key.lstrip("_"): value for key, value in data.items()}
    if "fx" not in data and "intrinsic_matrix" in data:  # Open3D: column-major
        values = data["intrinsic_matrix"]
        if not (isinstance(values, list) and len(values) == 9):
            raise InputError(f"{path}: intrinsic_matrix must be a list of 9 numbers (Open3D's, "
                             "column by column)")
        k = check_matrix(np.reshape(np.array(values, dtype=object), (3, 3), order="F"),
                         f"{path}: intrinsic_matrix (column by column)")
        data.update(fx=k[0, 0], fy=k[1, 1], cx=k[0, 2], cy=k[1, 2])
        names.update({key: f"intrinsic_matrix's {key}" for key in ("fx", "fy", "cx", "cy")})
    if "fx" not in data and isinstance(data.get("K"), list):
        k = check_matrix(data["K"], f"{path}: {names['K']}")
        data.update(fx=k[0, 0], fy=k[1, 1], cx=k[0, 2], cy=k[1, 2])
        names.update({key: f"{names['K']}'s {key}" for key in ("fx", "fy", "cx", "cy")})
    missing = [key for key in ("fx", "fy", "cx", "cy") if key not in data]
    if missing:
        raise InputError(f"cannot read intrinsics from {path}: missing {', '.join(missing)}")
    out = {key: _positive(data[key], f"{path}: {names[key]}")
           for key in ("fx", "fy", "cx", "cy", "width", "height") if key in data}
    if data.get("skew", 0) not in (0, 0.0):
        raise InputError(f"{path}: skew {data['skew']!r} is not supported (expected 0)")
    return out


def _yaml_subset(text: str) -> dict[str, str | list[str]]:
    """The subset of YAML a ROS `camera_info` file uses, flattened to dotted keys
    (`camera_matrix.data`): mappings nested by indentation, scalars, flow lists `[a, b]` (over
    several lines too) and block lists (`- a`); comments and document markers skipped. Values
    stay strings. Anything else (anchors, multi-line strings) is refused by the callers' checks
    of the keys they need."""
    lines = []
    for raw in text.splitlines():
        line = raw.split(" #")[0].rstrip() if not raw.lstrip().startswith("#") else ""
        if not line.strip() or line.strip() in ("---", "..."):
            continue
        if lines and lines[-1].count("[") > lines[-1].count("]"):  # a flow list goes on
            lines[-1] += " " + line.strip()
        else:
            lines.append(line)
    flat: dict[str, str | list[str]] = {}
    stack: list[tuple[int, str]] = []  # (indent, key) of the mappings above
    for line in lines:
        indent, item = len(line) - len(line.lstrip()), line.strip()
        if item.startswith("- ") or item == "-":
            if not stack:
                raise ValueError(f"a list item outside any key: {item!r}")
            while len(stack) > 1 and stack[-1][0] > indent:
                stack.pop()
            key = ".".join(k for _, k in stack)
            listed = flat.setdefault(key, [])
            if not isinstance(listed, list):
                raise ValueError(f"{key} holds both a value and a list")
            listed.append(item[1:].strip())
            continue
        if ":" not in item:
            raise ValueError(f"expected 'key: value', got {item!r}")
        key, value = (part.strip() for part in item.split(":", 1))
        while stack and stack[-1][0] >= indent:
            stack.pop()
        stack.append((indent, key.strip("'\"")))
        if value:
            full = ".".join(k for _, k in stack)
            if value.startswith("["):
                if not value.endswith("]"):
                    raise ValueError(f"{full}: unclosed list {value!r}")
                value = [v.strip() for v in value[1:-1].split(",") if v.strip()]
            flat[full] = value
            stack.pop()
    return flat


def camera_info_yaml(text: str, name: str) -> dict:
    """Intrinsics `{fx, fy, cx, cy, width, height}` of a ROS `camera_info` YAML file (`text`;
    `name` for messages): `image_width`, `image_height` and `camera_matrix` (`rows: 3`, `cols:
    3`, `data`: 9 numbers, row by row), as ROS's camera_calibration writes it, or ROS 2's
    message fields `width`, `height` and `k` (9 numbers, row by row). Read without PyYAML
    (`_yaml_subset`). Distortion is not applied: give rectified depth images."""
    try:
        flat = _yaml_subset(text)
    except ValueError as exc:
        raise InputError(f"cannot read {name} as camera_info YAML: {exc}") from None
    if "camera_matrix.data" in flat:
        key = "camera_matrix.data"
        shape = flat.get("camera_matrix.rows", "3"), flat.get("camera_matrix.cols", "3")
        if shape != ("3", "3"):
            raise InputError(f"{name}: camera_matrix must be 3x3, got rows {shape[0]}, cols "
                             f"{shape[1]}")
        size_keys = ("image_width", "image_height")
    else:
        key = next((k for k in ("k", "K") if k in flat), None)
        if key is None:
            raise InputError(f"{name}: no camera_matrix (ROS) or k (ROS 2) in this camera_info "
                             "YAML")
        size_keys = ("width", "height")
    values = flat[key]
    try:
        if not isinstance(values, list) or len(values) != 9:
            raise ValueError
        matrix = np.array([float(v) for v in values]).reshape(3, 3)  # row by row
    except ValueError:
        raise InputError(f"{name}: {key} must be a list of 9 numbers, got {values!r}") from None
    k = check_matrix(matrix, f"{name}: {key}")
    out = {"fx": k[0, 0], "fy": k[1, 1], "cx": k[0, 2], "cy": k[1, 2]}
    for size, size_key in zip(("width", "height"), size_keys, strict=True):
        if size_key in flat:
            out[size] = _positive(flat[size_key], f"{name}: {size_key}")
    return out


def _positive(value, name: str) -> float:
    """A JSON value that must be a finite number > 0 (pixels), as a float; true and false are
    no numbers (Python would take true for 1). `name` says which key of which file."""
    number = None
    if not isinstance(value, bool):
        try:
            number = float(value)
        except (TypeError, ValueError):
            pass
    if number is None:
        raise InputError(f"{name} must be a number, got {json.dumps(value)}")
    if not (math.isfinite(number) and number > 0):
        raise InputError(f"{name} must be a finite number > 0, got {json.dumps(value)}")
    return number


def load_mask(path: str | os.PathLike, shape: tuple[int, int]) -> np.ndarray:
    """Workspace mask `(H, W)` bool from a PNG (any mode) or `.npy`: nonzero = workspace.

    shape: the depth images' (H, W); a mask of another size is refused.
    """
    path = Path(path)
    _existing_file(path, "a mask")
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            data = np.load(path, allow_pickle=False)
        elif suffix == ".png":
            from PIL import Image

            with Image.open(path) as image:
                data = np.asarray(image)
        else:
            raise InputError(f"unknown mask format {suffix or '(none)'!r} for {path} "
                             "(expected .png or .npy)")
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"cannot read mask {path}: {_first_line(exc)}") from None
    if data.ndim == 3:
        data = np.any(data != 0, axis=-1)
    if data.ndim != 2:
        raise InputError(f"mask {path}: expected a 2-D image, got shape {data.shape}")
    if data.shape != tuple(shape):
        raise InputError(f"mask {path} is {data.shape[1]}x{data.shape[0]}, the depth images are "
                         f"{shape[1]}x{shape[0]}")
    mask = np.asarray(data != 0)
    if not mask.any():
        raise InputError(f"mask {path} is empty (no nonzero pixel)")
    return mask


def check_depth(depth: np.ndarray, name: str = "depth") -> np.ndarray:
    """Validate a depth image: 2-D, at least 8x8, no negative values, some valid pixels."""
    if depth.ndim == 3 and depth.shape[-1] == 1:
        depth = depth[..., 0]
    if depth.ndim != 2:
        raise InputError(f"{name}: expected a 2-D depth image, got shape {depth.shape}")
    if min(depth.shape) < 8:
        raise InputError(f"{name}: image {depth.shape[1]}x{depth.shape[0]} is too small (min 8x8)")
    finite = depth[np.isfinite(depth)]
    if (finite < 0).any():
        raise InputError(f"{name}: {int((finite < 0).sum())} pixels have negative depth")
    if not (finite > 0).any():
        raise InputError(f"{name}: no valid depth pixels (all are 0, nan or inf)")
    return depth.astype(np.float32)


def load_camera_pose(path: str | os.PathLike) -> np.ndarray:
    """The camera's pose (4, 4): camera frame to world frame, p_world = R p_camera + t.

    A 4x4 (or 3x4) matrix in `.npy` / `.txt`; JSON: the matrix as a list of rows, or an object
    with `matrix`, or with `rotation` (3x3) and `translation` (3); or an autolab/gqcnn `.tf`
    (from and to frame names, the translation, then the rotation's three rows). The rotation
    must be a rotation (orthonormal within 1e-3, determinant +1)."""
    path = Path(path)
    _existing_file(path, "a camera pose file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".tf":
            rows = [line.split() for line in path.read_text().splitlines()[2:6]]
            numbers = np.array(rows, float)
            matrix = np.vstack([np.hstack([numbers[1:], numbers[0][:, None]]), [0, 0, 0, 1]])
        elif suffix in (".npy", ".txt"):
            matrix = np.load(path, allow_pickle=False) if suffix == ".npy" else np.loadtxt(path)
        else:
            data = json.loads(path.read_text())
            if isinstance(data, dict) and "rotation" in data:
                matrix = np.hstack([np.array(data["rotation"], float),
                                    np.array(data["translation"], float).reshape(3, 1)])
            else:
                matrix = data["matrix"] if isinstance(data, dict) else data
        matrix = np.array(matrix, float)
    except Exception as exc:
        raise InputError(f"cannot read a camera pose from {path}: {_first_line(exc)}") from None
    if matrix.shape == (3, 4):
        matrix = np.vstack([matrix, [0, 0, 0, 1]])
    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
        raise InputError(f"{path}: expected a finite 4x4 (or 3x4) camera-to-world matrix, got "
                         f"shape {matrix.shape}")
    rotation = matrix[:3, :3]
    if (not np.allclose(matrix[3], [0, 0, 0, 1]) or np.abs(rotation.T @ rotation - np.eye(3)).max() > 1e-3
            or np.linalg.det(rotation) < 0):
        raise InputError(f"{path}: the camera pose's upper-left 3x3 is not a rotation (or its "
                         "last row is not 0 0 0 1)")
    return matrix
