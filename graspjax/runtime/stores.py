"""The stores beside JAX's compilation cache (`GRASPJAX_CACHE`): folders of results kept across
runs (exported programs, their executables, resting poses, recorded timings), switched off
with the cache and checked before anything is read from them: what the cache holds runs as
code, so it must be this user's alone (`check_cache`).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from graspjax.disk import write_atomic
from graspjax.errors import InputError


def check_cache(folder: str | os.PathLike) -> None:
    """Refuse (`InputError`, one line) a folder of the compile cache that is not this user's
    alone: what the cache holds runs as code (XLA's compiled programs; graspjax's exported
    programs are unpickled), so a file another user could put there would run as this user.
    `folder` must belong to this user and be writable by no one else; a missing one passes."""
    try:
        info = os.stat(folder)
    except FileNotFoundError:
        return
    if not stat.S_ISDIR(info.st_mode):
        raise InputError(f"the compile cache {folder} (GRASPJAX_CACHE) is not a folder: set "
                         "GRASPJAX_CACHE to a folder (0: no cache)")
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
