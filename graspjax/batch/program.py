"""Batch programs: a group's `start_round` and `attempt` vmapped over its worlds, one copy per
local device.

A chunk is `start_round`, then `attempt` for k = -1 (the drop settles), 0, 1, ... (one compiled
call each, all on the device), then one transfer of its records to the host. Nothing a world
does depends on the other worlds of its chunk: same seed, same batch size, same device kind
give the same records. `schedule.py` plays the chunks on the devices; records become rows in
`rows.py`; this module never builds a table.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import functools
import threading
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.dtypes import canonicalize_dtype

from graspjax.batch.plan import Group, WorldKey
from graspjax.config import Config, for_device, stack_configs
from graspjax.procedure import Record, RoundState, Views, WorldSpec, attempt, settle, start_round
from graspjax.runtime import executables, exported
from graspjax.sim.physics import WORLDS
from graspjax.sim.scene import Scene, mjx, scene_for

ATTEMPT_DONATES = (1,)  # `attempt` donates the round's state: the next call's state replaces it


class Program:
    """The compiled `start_round` and `attempt` of one group, one copy per local device.

    Every call has the one shape `batch` (worlds per device call; a chunk is one call's
    worlds, padded): XLA's floats depend on the shape it compiles for, so a world's records
    depend on its key, the device kind and `batch` alone, never on how many devices, chunks or
    other worlds a run has. Each device plays whole chunks on its own copy; worlds never
    communicate, so no SPMD partitioner is involved (XLA's crashed compiling the `shard_map` of
    this program over two H200s).
    """

    def __init__(self, group: Group, batch: int, keep_views: bool):
        self.group, self.batch, self.keep_views = group, batch, keep_views
        self.devices = jax.local_devices()
        self._start: list = [None] * len(self.devices)
        self._attempt: list = [None] * len(self.devices)
        self._compile_s = [0.0] * len(self.devices)
        self._executable = [""] * len(self.devices)  # where each device's copy came from
        self._placed: list = [None] * len(self.devices)  # `arrays` on each device (`compile`)
        self._settle = None
        self.worker_s: float | None = None  # a trace helper's seconds, if one traced it (`compiles`)
        self._scene: tuple[Scene, tuple[mjx.Model, mjx.Data]] | None = None  # `_built`
        self._building = threading.Lock()  # one build of the scene, whichever thread asks

    @property
    def name(self) -> str:
        """The group's object letters (messages)."""
        return "".join(self.group.letters)

    @property
    def work(self) -> float:
        """The group's device work (`Group.work`): the heaviest program traces first."""
        return self.group.work

    def trace_recipe(self) -> tuple[Callable, tuple]:
        """How a trace helper builds this program: the group reduced to its first world."""
        return Program, (dataclasses.replace(self.group, worlds=self.group.worlds[:1]),
                         self.batch, self.keep_views)

    @property
    def scene(self) -> Scene:
        """The group's MuJoCo scene, built on first use (`prepare`)."""
        return self._built()[0]

    @property
    def arrays(self) -> tuple[mjx.Model, mjx.Data]:
        """The scene's device arrays: its MJX model, and a fresh data for `start_round` to fill."""
        return self._built()[1]

    def prepare(self) -> None:
        """Build the scene and its device arrays, which the chunks need and a traced program's
        shapes come from; a stored program loads without them, so the lowering thread loads it
        while another thread builds them."""
        self._built()

    def _built(self) -> tuple[Scene, tuple[mjx.Model, mjx.Data]]:
        """The scene and its arrays, built once whichever thread asks first."""
        with self._building:
            if self._scene is None:
                scene = scene_for(self.group.letters, self.group.config, self.group.collide)
                self._scene = scene, (scene.model, mjx.make_data(scene.mj_model,
                                                                  device=self.devices[0]))
            return self._scene

    def _key(self) -> tuple[WorldSpec, tuple]:
        """What keys both functions in the store: one device's slice of specs (its static
        configuration in the tree) and what shapes the programs besides. Everything else they
        take (the scene's arrays, the round's state) follows from these and the package."""
        # The shapes of any batch: the group's first world, as point 0 of a one-point grid.
        example = dataclasses.replace(self.group.worlds[0], point=0)
        spec = jax.tree.map(lambda x: jax.ShapeDtypeStruct((self.batch,) + x.shape[1:],
                                                           canonicalize_dtype(x.dtype)),
                            self.spec((example,), [self.group.config]))
        group = self.group
        return spec, (group.letters, group.collide, group.attempts, self.keep_views)

    def stored(self) -> bool:
        """Whether the store holds `start_round`'s exported form (then, as a rule, `attempt`'s:
        both are saved by one trace), so that `portable` will load rather than trace."""
        spec, description = self._key()
        return exported.stored(spec, ("start_round",) + description)

    @functools.cached_property
    def portable(self) -> tuple[exported.Portable, exported.Portable]:
        """`start_round(arrays, spec)` and `attempt(model, state, spec, k)` for one device's
        slice, vmapped: loaded from the store of exported programs (without building the
        scene), or traced (the lowering thread builds them, once for all devices). The scene's
        device arrays are arguments, not constants: an exported program cannot hold them."""
        spec, description = self._key()
        stored = tuple(exported.load(spec, (name,) + description)
                       for name in ("start_round", "attempt"))
        if all(p is not None for p in stored):
            return stored
        arrays = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, canonicalize_dtype(x.dtype)),
                              self.arrays)
        keep_views = self.keep_views

        def start_fn(arrays, spec):
            scene = dataclasses.replace(self.scene, model=arrays[0])
            return jax.vmap(lambda one: start_round(scene, arrays[1], one, self.group.setups),
                            axis_name=WORLDS)(spec)

        def attempt_fn(model, state, spec, k):
            scene = dataclasses.replace(self.scene, model=model)
            one = functools.partial(attempt, scene, keep_views=keep_views,
                                    setups=self.group.setups)
            return jax.vmap(one, in_axes=(0, 0, None), axis_name=WORLDS)(state, spec, k)

        start = exported.export(start_fn, (arrays, spec), ("start_round",) + description, spec)
        attempt_ = exported.export(
            attempt_fn, (arrays[0], start.out_shapes(), spec, jax.ShapeDtypeStruct((), jnp.int32)),
            ("attempt",) + description, spec)
        return start, attempt_

    @property
    def compiled(self) -> bool:
        return all(f is not None for f in self._attempt)

    def compiled_texts(self, device: int = 0) -> list[str]:
        """The compiled HLO text of `start_round` and `attempt` on `device` (profiles:
        `bench_profile`), of those compiled so far."""
        return [f.as_text() for f in (self._start[device], self._attempt[device])
                if f is not None]

    def executable(self, device: int) -> str:
        """Where `device`'s copy came from (`runtime.executables.compile_on`): `compiled` here,
        `loaded` from the store of executables (compiled by an earlier run, another process or
        another device), or `cached` (read from JAX's compilation cache)."""
        return self._executable[device]

    @property
    def compile_s(self) -> float:
        """Seconds to lower the exported modules and compile them for one device (the slowest
        of the devices compiled so far); tracing apart (`trace_s`)."""
        return max(self._compile_s)

    def spec(self, worlds: tuple[WorldKey, ...], points: list[Config]) -> WorldSpec:
        """These worlds' batch on the host (grid point i: `points[i]`), padded with copies of the
        first world."""
        letters, n = self.group.letters, len(self.group.letters)
        padded = list(worlds) + [worlds[0]] * (self.batch - len(worlds))
        order = np.array([[letters.index(c) for c in w.objects] for w in padded], np.int32)
        members = np.zeros((self.batch, n), bool)
        np.put_along_axis(members, order, True, axis=1)
        used = sorted({w.point for w in padded})  # a chunk's points share their static values
        which = np.searchsorted(used, [w.point for w in padded])
        platform = self.devices[0].platform  # the static settings of the device it runs on
        config = jax.tree.map(lambda x: x[which], stack_configs(
            [for_device(points[i], platform) for i in used]))
        return WorldSpec(seed=np.array([w.seed for w in padded], np.int32),
                         setup=np.array([w.setup for w in padded], np.int32),
                         trial=np.array([w.trial for w in padded], np.int32),
                         order=order, members=members, config=config)

    def settle(self, worlds: tuple[WorldKey, ...], points: list[Config]) -> tuple[RoundState, WorldSpec]:
        """These worlds placed and settled (no attempt), on the first device: for studies that
        look at the layouts a run would attempt without grasping (`planes`)."""
        if self._settle is None:
            scene, template = self.scene, self.arrays[1]
            self._settle = jax.jit(jax.vmap(
                lambda spec: settle(scene, start_round(scene, template, spec, self.group.setups),
                                    spec),
                axis_name=WORLDS))
        spec = jax.device_put(self.spec(worlds, points), self.devices[0])
        return self._settle(spec), spec

    def lower(self) -> tuple[jax.stages.Lowered, jax.stages.Lowered]:
        """Lower both functions once for every device (Python: it holds the GIL); `compile`
        then compiles them for each device (`Portable.lower`)."""
        start, attempt_ = self.portable
        return start.lower(), attempt_.lower(donate_argnums=ATTEMPT_DONATES)

    @property
    def origin(self) -> str:
        """Where both functions came from: `traced` by this process, traced by a `worker`
        process of this run, or `loaded` from the store of an earlier run."""
        if not all(p.loaded for p in self.portable):
            return "traced"
        return "loaded" if self.worker_s is None else "worker"

    @property
    def trace_s(self) -> float:
        """Seconds to trace and export both functions (in the worker, if one did), or to read
        them from the store."""
        if self.origin == "worker":
            return self.worker_s
        return sum(p.seconds for p in self.portable)

    def compile(self, device: int, lowered: tuple[jax.stages.Lowered, jax.stages.Lowered],
                lower_s: float) -> None:
        """Compile the lowered functions for one device (XLA releases the GIL: devices, groups
        and the two functions compile in parallel threads), and put the scene's arrays there
        (building the scene first if no other thread has). `lower_s`: seconds the lowering
        took (tracing apart: `trace_s`)."""
        start, here = time.perf_counter(), self.devices[device]
        (start_p, attempt_p), donated = self.portable, ((), ATTEMPT_DONATES)
        with concurrent.futures.ThreadPoolExecutor(max_workers=1) as other:
            start_fn = other.submit(executables.compile_on, lowered[0], start_p.name,
                                    donated[0], here)
            attempt_fn, attempt_from = executables.compile_on(lowered[1], attempt_p.name,
                                                              donated[1], here)
            start_fn, start_from = start_fn.result()
        self._compile_s[device] = lower_s + time.perf_counter() - start
        # the costlier of the two: compiled here, else read from JAX's cache, else loaded
        self._executable[device] = next(way for way in ("compiled", "cached", "loaded")
                                        if way in (start_from, attempt_from))
        # The scene's arrays go to each device once, here, from the host, not from the first
        # device with every chunk: a first copy from device 0 to device 1 took 2 s on two H200s
        # (probably device 1's first allocation, now made at start: `xla.start_devices`;
        # results/benchmarks), and it fell into that device's first chunk.
        self._placed[device] = self.arrays if device == 0 else jax.block_until_ready(
            jax.device_put(jax.device_get(self.arrays), self.devices[device]))
        self._start[device] = start_fn
        self._attempt[device] = attempt_fn  # last: `compiled` looks at it

    def play(self, worlds: tuple[WorldKey, ...], points: list[Config], device: int,
             progress: Callable[[int], None]) -> tuple[Record, list[Record], ChunkViews | None]:
        """One chunk's round on `device`: the drop, then each attempt; the drop's record and the
        attempts' records on the host, and the views (left on the device) if kept."""
        on = functools.partial(jax.device_put, device=self.devices[device])  # numpy in: one copy
        spec, arrays = on(self.spec(worlds, points)), self._placed[device]
        state = self._start[device](arrays, spec)
        state, drop, _ = self._attempt[device](arrays[0], state, spec, on(np.int32(-1)))
        records, views = [], []
        for k in range(self.group.attempts):
            state, record, view = self._attempt[device](arrays[0], state, spec, on(np.int32(k)))
            jax.block_until_ready(record.reason)
            records.append(record)
            views.append(view)
            progress(len(worlds))
        drop, records = jax.device_get((drop, records))
        return drop, records, ChunkViews(views) if views and views[0] is not None else None


@dataclasses.dataclass(frozen=True)
class ChunkViews:
    """The views of a chunk's attempts, left on its device: at GPU batch sizes they are
    gigabytes, and only the few attempts that are saved come to the host."""

    attempts: list  # attempts[k]: `Views` of attempt k, leading axis the chunk's worlds

    def get(self, attempt: int, world: int) -> Views:
        """The views of one world's attempt (world: its index in the chunk), as numpy."""
        return jax.tree.map(lambda x: np.asarray(x[world]), self.attempts[attempt])


_PROGRAMS: dict = {}


def program(group: Group, batch: int, keep_views: bool) -> Program:
    """The shared program of a group at `batch` worlds per device call (compiled once per
    process)."""
    key = (group.letters, group.collide, group.attempts, jax.tree.structure(group.config), batch,
           keep_views, tuple(jax.local_devices()))
    if key not in _PROGRAMS:
        _PROGRAMS[key] = Program(group, batch, keep_views)
    return _PROGRAMS[key]
