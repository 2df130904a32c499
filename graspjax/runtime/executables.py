"""Compiled programs kept across devices and processes: each batch program's executable for one
kind of device, compiled once and loaded onto every device that plays it.

JAX's persistent compilation cache keys an executable by the device it was compiled for on the
CPU and by the whole topology on GPUs, so the second device of a run, a process of a
`--distributed` run or a run with another device count compiled afresh what an earlier run had
compiled (75-85 s a process on an H100, results/benchmarks). This store keys an executable by
its exported program alone (`exported.Portable.name`: the program, graspjax's sources, the
package versions, the device kind), the donated arguments, the platform's version and XLA's
flags; it is compiled by the first thread or process that needs it and loaded, serialized, by
every other (`privates.load_executable`). An executable JAX itself read from its cache is not
kept: on the CPU such a copy serializes without its code; the next device or process that
misses JAX's cache compiles it and keeps it.

The store is `<compilation cache folder>/executables/`, switched on and off with the
compilation cache (`GRASPJAX_CACHE`, set by the CLI); a file that does not load is compiled
again and replaced.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pathlib
import threading

import jax

from graspjax import privates
from graspjax.runtime import stores

FORMAT = 1  # bump when the file layout changes
# XLA flags that do not change what a single-device program compiles to (as in JAX's cache key)
_FLAGS_APART = ("--xla_force_host_platform_device_count",)
_locks: dict[str, threading.Lock] = {}  # one compile per executable in this process
_locks_lock = threading.Lock()
_CACHE_HIT = "/jax/compilation_cache/cache_hits"  # JAX's event, in the compiling thread
_hits = threading.local()  # this thread's count of JAX compilation-cache hits


@functools.cache
def _count_cache_hits() -> None:
    """Count JAX's compilation-cache hits per thread (once per process): an executable JAX
    read from its cache is not serialized again, since on the CPU such a copy lacks its
    functions' code ("Function ... not found" when called)."""
    def listener(event: str, **kwargs) -> None:
        if event == _CACHE_HIT:
            _hits.count = getattr(_hits, "count", 0) + 1

    jax.monitoring.register_event_listener(listener)


def compile_on(lowered: jax.stages.Lowered, name: str | None, donate: tuple[int, ...],
               device: jax.Device) -> tuple[jax.stages.Compiled, str]:
    """`lowered` (a program lowered for one device not chosen yet, `exported.Portable.lower`)
    compiled for `device`, and where it came from: `compiled` here (and kept), `loaded` from
    the store, or `cached`, read from JAX's compilation cache (not kept: `_count_cache_hits`).
    `name`: the exported program's name in its store (None: not kept); `donate`: the arguments
    it donates (its lowering's). Threads that ask for one executable at once compile it once:
    the others wait and load it."""
    _count_cache_hits()
    path = _path(name, donate, device)
    found = None if path is None else _load(path, lowered, device)  # devices load side by side
    if found is not None:
        return found, "loaded"
    with _locks_lock:
        lock = _locks.setdefault(str(path), threading.Lock())
    with lock:  # one compiles; the others wait, then load what it kept
        found = None if path is None else _load(path, lowered, device)
        if found is not None:
            return found, "loaded"
        _hits.count = 0
        compiled = lowered.compile(device_assignment=(device,))
        if _hits.count:
            return compiled, "cached"
        if path is not None:
            try:
                from jax.experimental.serialize_executable import serialize

                stores.keep(path, FORMAT.to_bytes(4, "little") + serialize(compiled)[0])
            except (ValueError, NotImplementedError):  # an executable XLA cannot serialize
                pass
        return compiled, "compiled"


def _load(path: pathlib.Path, lowered: jax.stages.Lowered, device: jax.Device
          ) -> jax.stages.Compiled | None:
    """The stored executable loaded onto `device`, or None (none stored, or one that does not
    load: compiled again and replaced)."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    if int.from_bytes(data[:4], "little") != FORMAT:
        return None
    try:
        return privates.load_executable(data[4:], lowered.in_tree, lowered.out_tree, device)
    except Exception:  # unreadable, foreign, or from another XLA
        return None


def store() -> pathlib.Path | None:
    """The folder of executables: beside the compilation cache, None when that is off."""
    return stores.store("executables")


def _path(name: str | None, donate: tuple[int, ...], device: jax.Device) -> pathlib.Path | None:
    folder = store()
    if folder is None or name is None:
        return None
    flags = sorted(f for f in os.environ.get("XLA_FLAGS", "").split()
                   if f.split("=")[0] not in _FLAGS_APART)
    text = repr((FORMAT, name, tuple(donate), device.platform, device.device_kind,
                 device.client.platform_version, jax.__version__, flags))
    return folder / f"{hashlib.sha256(text.encode()).hexdigest()[:32]}.xla"
