"""Traced programs kept across processes: each batch program's exported form (`jax.export`),
keyed by everything that shapes it, so that a warm start loads it instead of tracing.

Tracing and lowering the attempt program is Python work of tens of seconds; XLA's own
persistent cache only helps after it. Every program goes through the exported form, traced
or loaded alike (`Portable.jit`), so both give XLA one and the same module: the second
process's compile is a compilation-cache hit and its rows are those of the first.

The store is `<compilation cache folder>/exported/`, switched on and off with the compilation
cache (`GRASPJAX_CACHE`, set by the CLI). A key is a digest of the program's own description
(scene, static configuration, shapes), graspjax's source files, the versions of the packages
that trace it and the device kind, so that a change to any of them traces afresh.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.metadata
import pathlib
import pickle
import re
import time
from collections.abc import Callable

import jax

from graspjax import privates
from graspjax.provenance import source_digest
from graspjax.runtime import stores

FORMAT = 1  # bump when the file layout below changes
_PACKAGES = ("jax", "jaxlib", "mujoco", "mujoco-mjx", "numpy")
KEY_SETTINGS = ("jax_enable_x64", "jax_default_matmul_precision")  # JAX settings in a key


@dataclasses.dataclass(frozen=True)
class Portable:
    """A function traced for one set of argument shapes, in portable form."""

    program: jax.export.Exported  # flat: the argument leaves in, the result leaves out
    in_tree: jax.tree_util.PyTreeDef  # the arguments' tree (a tuple of the positional ones)
    out_tree: jax.tree_util.PyTreeDef  # the result's tree
    loaded: bool  # read from the store (True) or traced by this process (False)
    seconds: float  # what tracing and exporting, or reading, took
    name: str | None = None  # its file's name in the store (None: the store is off), which
    # keys its compiled executables (`runtime.executables`)
    label: str = "call"  # what it is (its description's first item): its jitted function's
    # name, so that its compiled module is `jit_<label>` in profiles

    def in_shapes(self, sharding: jax.sharding.Sharding | None = None) -> tuple:
        """The positional arguments' shapes (placed by `sharding`, if given)."""
        return jax.tree.unflatten(self.in_tree, [
            jax.ShapeDtypeStruct(a.shape, a.dtype, sharding=sharding)
            for a in self.program.in_avals])

    def out_shapes(self):
        """The result's shapes."""
        return jax.tree.unflatten(self.out_tree, [
            jax.ShapeDtypeStruct(a.shape, a.dtype) for a in self.program.out_avals])

    def jit(self, donate_argnums: tuple[int, ...] = ()) -> Callable:
        """The function again, jitted: pytrees in and out, the exported module inside."""
        def call(*args):
            leaves, tree = jax.tree.flatten(args)
            if tree != self.in_tree:
                raise TypeError(f"arguments {tree} do not match the exported {self.in_tree}")
            return jax.tree.unflatten(self.out_tree, self.program.call(*leaves))
        call.__name__ = call.__qualname__ = self.label
        return jax.jit(call, donate_argnums=donate_argnums)

    def lower(self, donate_argnums: tuple[int, ...] = ()) -> jax.stages.Lowered:
        """`jit` lowered for the arguments' shapes on one device not chosen yet: compile it for
        any device of the module's platform with `compile(device_assignment=(device,))`, so one
        lowering (Python: it holds the GIL, ~0.5 s for a batch program) serves every device.
        With one source line per operation like the exported module: lowered with JAX's
        default, every operation inlined from the module would carry the caller's whole Python
        stack (a run's lowering thread: some 30 frames), which XLA:GPU formats again at each
        load (results/benchmarks)."""
        one_device = jax.sharding.NamedSharding(jax.sharding.AbstractMesh((1,), ("device",)),
                                                jax.sharding.PartitionSpec())
        with _one_source_line():
            return self.jit(donate_argnums).trace(*self.in_shapes(one_device)).lower(
                lowering_platforms=self.program.platforms)


def store() -> pathlib.Path | None:
    """The folder of exported programs: beside the compilation cache, None when that is off."""
    return stores.store("exported")


def export(fn: Callable, args: tuple, description: tuple, key: tuple | None = None) -> Portable:
    """`fn` (jittable) for arguments shaped like `args` (pytrees of ShapeDtypeStruct, no
    shardings): loaded from the store when a program of the same key is there, else traced,
    exported and saved. `description`: what shapes the program besides the arguments' shapes
    (scene, static configuration, modes), as values with a stable repr. `key`: the shapes that
    key the program, when the description fixes the rest of `args` (default: all of `args`),
    so that `load` finds it without them."""
    start = time.perf_counter()
    in_leaves, in_tree = jax.tree.flatten(args)
    key = args if key is None else key
    found = load(key, description)
    if found is not None and found.in_tree == in_tree:
        return found
    path = _path(description, key)
    out_tree = []

    def flat(*leaves):
        out = fn(*jax.tree.unflatten(in_tree, leaves))
        out_leaves, tree = jax.tree.flatten(out)
        out_tree.append(tree)
        return out_leaves

    with _one_source_line():
        program = jax.export.export(jax.jit(flat))(*in_leaves)
    if path is not None:
        stores.keep(path, pickle.dumps((FORMAT, in_tree, out_tree[0], program.serialize())))
    return Portable(program, in_tree, out_tree[0], False, time.perf_counter() - start,
                    None if path is None else path.stem, str(description[0]))


def load(key: tuple, description: tuple) -> Portable | None:
    """The stored program of this key (`export`'s `key` and `description`), or None: none
    stored, the store off, or an unreadable or foreign file (`export` then traces afresh and
    overwrites it). Needs no more than the key's shapes: a warm start loads its programs
    before it builds what they will be called with."""
    start = time.perf_counter()
    path = _path(description, key)
    if path is None or not path.exists():
        return None
    try:
        with path.open("rb") as f:
            fmt, in_tree, out_tree, blob = pickle.load(f)
        if fmt != FORMAT:
            return None
        return Portable(jax.export.deserialize(blob), in_tree, out_tree, True,
                        time.perf_counter() - start, path.stem, str(description[0]))
    except Exception:  # unreadable or foreign
        return None


def _one_source_line():
    """Trace or lower with one source line per operation instead of its Python traceback (up
    to 100 frames): XLA's GPU executable builds a profiler annotation from every operation's
    frames each time it is created, compiled or loaded, which was most of a warm load
    (results/benchmarks). Profiles still name each operation's line. (JAX's
    thread-local switch: private API.)"""
    return privates.include_full_tracebacks_in_locations(False)


def stored(key: tuple, description: tuple) -> bool:
    """Whether the store holds a program of this key: `export` would load it."""
    path = _path(description, key)
    return path is not None and path.exists()


def _path(description: tuple, key: tuple) -> pathlib.Path | None:
    """The program's file in the store (None when the store is off)."""
    folder = store()
    if folder is None:
        return None
    shapes = [(a.shape, str(a.dtype)) for a in jax.tree.leaves(key)]
    device = jax.local_devices()[0]
    text = repr((FORMAT, description, shapes, jax.tree.structure(key), _versions(),
                source_digest(), device.platform, device.device_kind,
                *(getattr(jax.config, name) for name in KEY_SETTINGS)))
    # Static fields' reprs may name memory addresses (MJX wraps its static numpy arrays): they
    # differ between processes. What those fields hold is fixed by the description and sources.
    text = re.sub(r" at 0x[0-9a-f]+", "", text)
    return folder / f"{hashlib.sha256(text.encode()).hexdigest()[:32]}.jaxexport"


@functools.cache
def _versions() -> tuple[str, ...]:
    """The versions of the packages that trace a program."""
    return tuple(f"{name}=={importlib.metadata.version(name)}" for name in _PACKAGES)


