"""Reading depth images from disk: `.npy` in metres or 16-bit `.png` in millimetres."""

from __future__ import annotations

import os
import tempfile
import warnings
from pathlib import Path

import numpy as np


class InputError(Exception):
    """A user-supplied file or value is unusable (the message is one line)."""


def load_depth(path: str | os.PathLike) -> np.ndarray:
    """Metric depth `(H, W)` float32 from `.npy` (metres) or 16-bit `.png` (millimetres).

    0 and nan mark invalid pixels. Raises `InputError` for anything else.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"no such file: {path}")
    if path.is_dir():
        raise InputError(f"{path} is a directory, not a depth image")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            data = np.load(path, allow_pickle=False)
        except Exception as exc:  # corrupt or not an .npy file at all
            raise InputError(f"cannot read {path} as .npy: {exc}".splitlines()[0]) from None
        if not np.issubdtype(data.dtype, np.floating):
            raise InputError(f"{path}: expected float depth in metres, got dtype {data.dtype} "
                             "(store millimetres as a 16-bit .png)")
        depth = data.astype(np.float32)
    elif suffix == ".png":
        from PIL import Image

        try:
            with Image.open(path) as image:
                mode = image.mode
                data = np.asarray(image)
        except Exception as exc:
            raise InputError(f"cannot read {path} as .png: {exc}".splitlines()[0]) from None
        if mode not in ("I;16", "I;16B", "I;16L", "I") or data.ndim != 2:
            raise InputError(f"{path}: expected a single-channel 16-bit PNG in millimetres, "
                             f"got mode {mode}")
        depth = data.astype(np.float32) / 1000.0
    else:
        raise InputError(f"unknown depth format {suffix or '(none)'!r} for {path} "
                         "(expected .npy in metres or 16-bit .png in millimetres)")
    return check_depth(depth, str(path))


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


def downsample(depth: np.ndarray, factor: int) -> np.ndarray:
    """Block median of the valid pixels in `factor x factor` blocks (0 where none is valid).

    The image is cropped to a multiple of `factor`; use `Camera.scaled` for the
    matching intrinsics.
    """
    if factor == 1:
        return depth
    h, w = (depth.shape[0] // factor) * factor, (depth.shape[1] // factor) * factor
    blocks = depth[:h, :w].reshape(h // factor, factor, w // factor, factor).swapaxes(1, 2)
    blocks = np.where(np.isfinite(blocks) & (blocks > 0), blocks, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-invalid blocks are expected
        out = np.nanmedian(blocks.reshape(h // factor, w // factor, -1), axis=-1)
    return np.nan_to_num(out, nan=0.0).astype(np.float32)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_FILE_MODE = 0o666 & ~_umask()  # what open() would give a new file


def write_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write a file in one step (temp file + rename): never leaves a half-written file."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.chmod(tmp, _FILE_MODE)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
