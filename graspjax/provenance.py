"""What produced a result: package versions, the code (a digest of graspjax's sources, and
the git commit and whether the checkout had changes, when it is one), the devices, the host
and the command line.

Every run's `config.json`, every plane study's and every benchmark record carry it; a run's
timings, how long its process ran before it began (`process_age`).
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import hashlib
import os
import pathlib
import platform
import shlex
import subprocess
import sys
import time
from importlib import metadata

from graspjax.version import __version__

SOURCES = pathlib.Path(__file__).resolve().parent  # the graspjax package, all of it
PACKAGES = ("graspjax", "jax", "jaxlib", "mujoco", "mujoco-mjx", "numpy", "pandas")
_COMMAND: contextvars.ContextVar[tuple[str, ...] | None] = contextvars.ContextVar(
    "graspjax_command", default=None)  # the arguments `cli.main` was given


@contextlib.contextmanager
def command(argv):
    """Record `argv` as the command a result comes from while `cli.main` runs it: a script
    that calls `main([...])` records the graspjax command it typed, not its own name."""
    token = _COMMAND.set(tuple(argv))
    try:
        yield
    finally:
        _COMMAND.reset(token)


def provenance() -> dict:
    """Versions, Python, devices (every local one, and the first one's platform, kind and the
    count), host and command line."""
    import jax

    versions = {"graspjax": __version__}  # this code's, whatever pip recorded at install
    for name in PACKAGES[1:]:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    devices = jax.local_devices()
    return {"versions": versions, "code": code_identity(), "python": platform.python_version(),
            "devices": [f"{d.platform}:{getattr(d, 'device_kind', d)}:{d.id}" for d in devices],
            "device": {"platform": devices[0].platform,
                       "kind": getattr(devices[0], "device_kind", str(devices[0])),
                       "count": len(devices)},
            "cpu": _cpu_model(),  # XLA:CPU compiles for its instruction set: CPU rows depend on it
            "host": platform.node(),
            "command": shlex.join(["graspjax", *_typed()])}


@functools.cache
def source_digest(root: pathlib.Path = SOURCES) -> str:
    """A digest (sha256 hex) of the Python sources and data files under `root` (graspjax's):
    any edit of the code that made a result changes it."""
    digest = hashlib.sha256()
    for path in sorted(p for pattern in ("*.py", "data/*") for p in root.rglob(pattern)):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


@functools.cache
def code_identity() -> dict:
    """Which code this is: `digest` (`source_digest`), and where the package lies in a git
    checkout, its `commit` and whether the checkout differs from it (`dirty`; both None
    elsewhere, or without git)."""
    commit = dirty = None
    try:
        def git(*args: str) -> str:
            return subprocess.run(["git", "-C", str(SOURCES.parent), *args], capture_output=True,
                                  text=True, timeout=10, check=True).stdout.strip()

        if pathlib.Path(git("rev-parse", "--show-toplevel")) == SOURCES.parent:
            commit = git("rev-parse", "HEAD")
            dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    except (OSError, subprocess.SubprocessError):
        pass
    return {"digest": source_digest(), "commit": commit, "dirty": dirty}


def made_by_other_code(meta: dict) -> str:
    """"" when a result's `config.json` (`meta`) was made by this code (the same source
    digest) or says nothing of its code; else a few words on the code that made it."""
    code = meta.get("code")
    if not isinstance(code, dict) or not code.get("digest"):
        return ""
    if code["digest"] == source_digest():
        return ""
    return f"made by other code ({_described(code)}; this is {_described(code_identity())})"


def _described(code: dict) -> str:
    """A `code_identity` in a few words: its commit (and changes), else its sources' digest."""
    return (f"commit {str(code['commit'])[:10]}" + (" with changes" if code.get("dirty") else "")
            if code.get("commit") else f"sources {str(code['digest'])[:10]}")


def _typed() -> tuple[str, ...]:
    """The arguments of the graspjax command being run (`command`), else this process's."""
    typed = _COMMAND.get()
    return tuple(sys.argv[1:]) if typed is None else typed


def _cpu_model() -> str:
    """The host processor's model name (Linux's /proc/cpuinfo), else what Python knows."""
    try:
        with open("/proc/cpuinfo") as info:
            for line in info:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def device_line(record: dict) -> str:
    """`device: NVIDIA H100 80GB HBM3 (gpu) x1, jax 0.11.2`: the first line of a printed
    benchmark."""
    device = record["device"]
    return (f"device: {device['kind']} ({device['platform']}) x{device['count']}, "
            f"jax {record['versions']['jax']}")


def process_age() -> float | None:
    """Seconds since this process started (Linux's /proc; None elsewhere): what the interpreter,
    the imports and the devices' start took before a run began."""
    try:
        stat = pathlib.Path("/proc/self/stat").read_text()
        ticks = int(stat.rsplit(")", 1)[1].split()[19])  # field 22, starttime, in clock ticks
        return time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None
