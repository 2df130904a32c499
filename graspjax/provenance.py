"""What produced a result: package versions, the devices, the host and the command line.

Every run's `config.json`, every plane study's and every benchmark record carry it.
"""

from __future__ import annotations

import contextlib
import contextvars
import platform
import shlex
import sys
from importlib import metadata

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

    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    devices = jax.local_devices()
    return {"versions": versions, "python": platform.python_version(),
            "devices": [f"{d.platform}:{getattr(d, 'device_kind', d)}:{d.id}" for d in devices],
            "device": {"platform": devices[0].platform,
                       "kind": getattr(devices[0], "device_kind", str(devices[0])),
                       "count": len(devices)},
            "cpu": _cpu_model(),  # XLA:CPU compiles for its instruction set: CPU rows depend on it
            "host": platform.node(),
            "command": shlex.join(["graspjax", *_typed()])}


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
