"""Writing to disk: files written whole (`write_atomic`), outputs checked writable before any
work, JSON values of arrays, and the stores kept beside JAX's compilation cache (`store`,
`keep`), which hold code and so must be this user's alone (`check_cache`). Every problem a
user can fix raises `InputError` with a one-line message."""

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


def check_cache(folder: str | os.PathLike) -> None:
    """Refuse (`InputError`, one line) a folder of the compile cache that is not this user's
    alone: what the cache holds runs as code (XLA's compiled programs; graspjax's exported
    programs are unpickled), so a file another user could put there would run as this user.
    `folder` must belong to this user and be writable by no one else; a missing one passes."""
    try:
        info = os.stat(folder)
    except FileNotFoundError:
        return
    if info.st_uid != os.geteuid():
        raise InputError(f"the compile cache {folder} belongs to another user (uid "
                         f"{info.st_uid}) and what it holds runs as code: set GRASPJAX_CACHE "
                         "to a folder of your own (0: no cache)")
    if info.st_mode & 0o022:
        raise InputError(f"the compile cache {folder} is writable by other users and what it "
                         f"holds runs as code: make it yours alone (chmod -R go-w {folder}) or "
                         "set GRASPJAX_CACHE to another folder (0: no cache)")


def store(name: str) -> Path | None:
    """A folder of results kept across runs, beside JAX's compilation cache (`GRASPJAX_CACHE`)
    and switched off with it (None); both checked (`check_cache`) before anything is read
    from them."""
    import jax

    folder = jax.config.jax_compilation_cache_dir
    if not folder:
        return None
    for path in (Path(folder), Path(folder) / name):
        check_cache(path)
    return Path(folder) / name


def keep(path: Path, data: bytes) -> None:
    """Write a store's file atomically, its folder and the cache folder above it created
    private (mode 0700: `check_cache`); a store that cannot be written is skipped: it only
    saves time."""
    try:
        path.parent.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        path.parent.mkdir(mode=0o700, exist_ok=True)
        write_atomic(path, data)
    except OSError:
        pass


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
