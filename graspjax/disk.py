"""Writing to disk: files written whole (`write_atomic`), outputs checked writable before any
work, JSON values of arrays. Every problem a user can fix raises `InputError` with a one-line
message. (The stores beside the compile cache are `runtime/stores.py`.)"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path

import numpy as np

from graspjax.errors import InputError


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


def check_writable(path: str | os.PathLike | None, what: str, directory: bool = False) -> None:
    """Fail before any work if `path` (a file, or with `directory` a folder created if missing)
    cannot be written: its parent must exist and be writable. `what` names it in the message."""
    if path is None:
        return
    target = Path(path)
    if directory and target.exists() and not target.is_dir():
        raise InputError(f"{what} {path} exists and is not a directory")
    if not directory and target.is_dir():
        raise InputError(f"{what} {path} is a directory")
    parent = target.resolve() if directory and target.is_dir() else target.resolve().parent
    if not parent.is_dir():
        raise InputError(f"cannot write {path}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"cannot write {path}: directory {parent} is not writable")


def check_utf8_name(path: str | os.PathLike, what: str) -> None:
    """Refuse (`InputError`, one line) a path holding bytes the file system gave that are not
    UTF-8 (Python keeps them as lone surrogates): a name written into a UTF-8 file or table
    cannot hold them. `what` names it in the message."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        raise InputError(f"{ascii(str(path))}: {what} is not UTF-8 text (rename it)") from None


def jsonable(value):
    """Arrays, numpy scalars and nested containers as JSON values (nan and inf -> null)."""
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    array = np.asarray(value)
    if array.ndim > 0:
        return [jsonable(v) for v in array.tolist()]
    item = array.item()
    if isinstance(item, float) and not math.isfinite(item):
        return None
    return item
