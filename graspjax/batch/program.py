"""Compiled batch programs: a group's `start_round` and `attempt`, one copy per local device,
compiled in the background, and the chunks played on them.

A chunk is `start_round`, then `attempt` for k = -1 (the drop settles), 0, 1, ... (one compiled
call each, all on the device), then one transfer of its records to the host. Nothing a world
does depends on the other worlds of its chunk: same seed, same batch size, same device kind
give the same records.

The groups' programs compile in the background (one thread lowers them in turn, helper
processes trace later ones beside it where there are cores to spare, XLA compiles them in
parallel threads); the next chunk is the first in plan order whose program is ready, so the
device runs one group while the host still compiles the others.
Records become rows in `rows.py`; this module never builds a table.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import functools
import json
import os
import pickle
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.batch import exported, worker
from graspjax.batch.plan import Chunk, Group, World, chunks, padded_size
from graspjax.config import Config, stack_configs
from graspjax.io import InputError
from graspjax.procedure import Record, RoundState, Views, WorldSpec, attempt, settle, start_round
from graspjax.sim.physics import WORLDS
from graspjax.sim.scene import Scene, mjx, scene_for


class Program:
    """The compiled `start_round` and `attempt` of one group, one copy per local device.

    The batch is cut into equal slices, one per device, and each device runs the one-device
    program on its slice (dispatches are asynchronous, so the devices run together). Worlds
    never communicate, so there is nothing to partition: no SPMD partitioner is involved (XLA's
    crashed compiling the `shard_map` of this program over two H200s), and each device computes
    exactly what one device would on a batch of its slice's size.
    """

    def __init__(self, group: Group, batch: int, keep_views: bool):
        self.group, self.batch, self.keep_views = group, batch, keep_views
        self.devices = jax.local_devices()
        self.per_device = batch // len(self.devices)
        self._start: list = [None] * len(self.devices)
        self._attempt: list = [None] * len(self.devices)
        self._compile_s = [0.0] * len(self.devices)
        self._settle = None
        self._worker_s: float | None = None  # a worker process's tracing seconds, if it traced
        self._scene: tuple[Scene, tuple[mjx.Model, mjx.Data]] | None = None  # `_built`
        self._building = threading.Lock()  # one build of the scene, whichever thread asks

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
                self._scene = scene, (scene.model, mjx.make_data(scene.mj_model))
            return self._scene

    def _key(self) -> tuple[WorldSpec, tuple]:
        """What keys both functions in the store: one device's slice of specs (its static
        configuration in the tree) and what shapes the programs besides. Everything else they
        take (the scene's arrays, the round's state) follows from these and the package."""
        # The shapes of any batch: the group's first world, as point 0 of a one-point grid.
        example = dataclasses.replace(self.group.worlds[0], point=0)
        spec = jax.tree.map(lambda x: jax.ShapeDtypeStruct((self.per_device,) + x.shape[1:],
                                                           x.dtype),
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
        arrays = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), self.arrays)
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

    @property
    def compile_s(self) -> float:
        """Seconds to lower the exported modules and compile them for one device (the slowest
        of the devices); tracing apart (`trace_s`)."""
        return max(self._compile_s)

    def spec(self, worlds: tuple[World, ...], points: list[Config]) -> WorldSpec:
        """These worlds' batch on the host (grid point i: `points[i]`), padded with copies of the
        first world."""
        letters, n = self.group.letters, len(self.group.letters)
        padded = list(worlds) + [worlds[0]] * (self.batch - len(worlds))
        order = np.array([[letters.index(c) for c in w.objects] for w in padded], np.int32)
        members = np.zeros((self.batch, n), bool)
        np.put_along_axis(members, order, True, axis=1)
        used = sorted({w.point for w in padded})  # a chunk's points share their static values
        which = np.searchsorted(used, [w.point for w in padded])
        config = jax.tree.map(lambda x: x[which], stack_configs([points[i] for i in used]))
        return WorldSpec(seed=np.array([w.seed for w in padded], np.int32),
                         setup=np.array([w.setup for w in padded], np.int32),
                         trial=np.array([w.trial for w in padded], np.int32),
                         order=order, members=members, config=config)

    def settle(self, worlds: tuple[World, ...], points: list[Config]) -> tuple[RoundState, WorldSpec]:
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

    def on_device(self, spec: WorldSpec, device: int) -> WorldSpec:
        """The slice of a host batch that `device` runs, on that device."""
        m = self.per_device
        return jax.device_put(jax.tree.map(lambda x: x[device * m:(device + 1) * m], spec),
                              self.devices[device])

    def lower(self, device: int) -> tuple[jax.stages.Lowered, jax.stages.Lowered]:
        """Lower both functions for one device (Python: it holds the GIL): every device lowers
        the same exported modules (`portable`, traced or loaded first)."""
        sharding = jax.sharding.SingleDeviceSharding(self.devices[device])
        start, attempt_ = self.portable
        return start.lower(sharding), attempt_.lower(sharding, donate_argnums=(1,))

    @property
    def origin(self) -> str:
        """Where both functions came from: `traced` by this process, traced by a `worker`
        process of this run, or `loaded` from the store of an earlier run."""
        if not all(p.loaded for p in self.portable):
            return "traced"
        return "loaded" if self._worker_s is None else "worker"

    @property
    def trace_s(self) -> float:
        """Seconds to trace and export both functions (in the worker, if one did), or to read
        them from the store."""
        if self.origin == "worker":
            return self._worker_s
        return sum(p.seconds for p in self.portable)

    def compile(self, device: int, lowered: tuple[jax.stages.Lowered, jax.stages.Lowered],
                lower_s: float) -> None:
        """Compile the lowered functions for one device (XLA releases the GIL: devices, groups
        and the two functions compile in parallel threads). `lower_s`: seconds the lowering
        took (tracing apart: `trace_s`)."""
        start = time.perf_counter()
        with concurrent.futures.ThreadPoolExecutor(max_workers=1) as other:
            start_fn = other.submit(lowered[0].compile)
            attempt_fn = lowered[1].compile()
            self._start[device] = start_fn.result()
            self._attempt[device] = attempt_fn  # last: `compiled` looks at it
        self._compile_s[device] = lower_s + time.perf_counter() - start

    def play(self, worlds: tuple[World, ...], points: list[Config], progress: Callable[[int], None]
             ) -> tuple[Record, list[Record], ChunkViews | None]:
        """One round in every world: the drop, then each attempt; the drop's record and the
        attempts' records on the host, and the views (left on the devices) if kept.

        Each device's calls run in a thread of their own: a call whose physics loop is a
        `while_loop` holds its caller until the device finishes it (the host reads the loop
        condition), so calls from one thread would run the devices one after another."""
        batch = self.spec(worlds, points)
        m, lock = self.per_device, threading.Lock()

        def one_device(i: int):
            real = min(max(len(worlds) - i * m, 0), m)  # worlds of the slice that are not padding
            spec = self.on_device(batch, i)
            k_on = functools.partial(jax.device_put, device=self.devices[i])  # numpy in: one copy
            arrays = jax.device_put(self.arrays, self.devices[i])
            state = self._start[i](arrays, spec)
            state, drop, _ = self._attempt[i](arrays[0], state, spec, k_on(np.int32(-1)))
            records, views = [], []
            for k in range(self.group.attempts):
                state, record, view = self._attempt[i](arrays[0], state, spec,
                                                       k_on(np.int32(k)))
                jax.block_until_ready(record.reason)
                records.append(record)
                views.append(view)
                with lock:
                    progress(real)
            return jax.device_get((drop, records)), views

        with concurrent.futures.ThreadPoolExecutor(max_workers=len(self.devices)) as pool:
            parts = list(pool.map(one_device, range(len(self.devices))))
        joined = functools.partial(jax.tree.map, lambda *xs: np.concatenate(xs))
        drop = joined(*[p[0][0] for p in parts])
        records = [joined(*[p[0][1][k] for p in parts]) for k in range(self.group.attempts)]
        kept = parts[0][1][0] is not None
        return drop, records, ChunkViews([p[1] for p in parts], m) if kept else None


@dataclasses.dataclass(frozen=True)
class ChunkViews:
    """The views of a chunk's attempts, left on the devices: at GPU batch sizes they are
    gigabytes, and only the few attempts that are saved come to the host."""

    parts: list  # parts[device][k]: `Views` of attempt k in that device's slice of worlds
    per_device: int  # worlds per device slice

    def get(self, attempt: int, world: int) -> Views:
        """The views of one world's attempt (world: its index in the chunk), as numpy."""
        part = self.parts[world // self.per_device][attempt]
        return jax.tree.map(lambda x: np.asarray(x[world % self.per_device]), part)


_PROGRAMS: dict = {}


def program(group: Group, batch: int, keep_views: bool) -> Program:
    """The shared program of a group at a batch size (compiled once per process)."""
    size = padded_size(len(group.worlds), batch)
    key = (group.letters, group.collide, group.attempts, jax.tree.structure(group.config), size,
           keep_views, tuple(jax.local_devices()))
    if key not in _PROGRAMS:
        _PROGRAMS[key] = Program(group, size, keep_views)
    return _PROGRAMS[key]


WORKER_TIMEOUT_S = 900  # a trace worker still running after this is given up (tracing: ~1 min)


class WorkerFailed(RuntimeError):
    """A trace worker that did not hand its program over: the run traces it itself."""


def trace_workers() -> int:
    """How many helper processes may trace programs beside the run's own lowering thread:
    `GRASPJAX_TRACE_WORKERS` if set, else one per 8 CPU cores this process may use (none on a
    small machine, where they would only take cores from the compiles and the chunks)."""
    value = os.environ.get("GRASPJAX_TRACE_WORKERS", "").strip()
    if value:
        if not (value.isascii() and value.isdigit()):
            raise InputError(f"GRASPJAX_TRACE_WORKERS must be a whole number, got {value!r}")
        return int(value)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (cores or 1) // 8


def trace_in_worker(p: Program) -> float | None:
    """Trace `p` in a helper process (`worker.py`) into the store; the helper's tracing seconds,
    or None when it found the program already stored. `WorkerFailed` (with the helper's last
    words) when it fails or hangs; `InterruptedError` when a signal stopped it (Ctrl-C reaches
    the whole process group)."""
    name = "".join(p.group.letters)
    group = dataclasses.replace(p.group, worlds=p.group.worlds[:1])
    settings = {key: getattr(jax.config, key) for key in worker.SETTINGS}
    job = worker.Job(group, p.batch, p.keep_views, str(exported.store().resolve().parent),
                     settings)
    # The run's flags and devices, but not its memory: the helper only traces. It runs in the
    # folder that holds this graspjax package, so that it imports this one and no other.
    env = {**os.environ, "XLA_PYTHON_CLIENT_PREALLOCATE": "false"}
    command = "import sys; from graspjax.batch.worker import main; sys.exit(main())"
    try:
        done = subprocess.run([sys.executable, "-c", command],
                              input=pickle.dumps(job), capture_output=True, env=env,
                              cwd=exported.SOURCES.parent, timeout=WORKER_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise WorkerFailed(f"the trace worker of {name} ran over {WORKER_TIMEOUT_S} s") from None
    if done.returncode < 0:
        raise InterruptedError(f"the trace worker of {name} was stopped by a signal")
    if done.returncode == 0:
        result = json.loads(done.stdout.decode().strip().splitlines()[-1])
        return result["seconds"] if result["traced"] else None
    last = (done.stderr.decode(errors="replace").strip().splitlines() or ["no output"])[-1]
    raise WorkerFailed(f"the trace worker of {name} failed: {last}")


def _start_compiles(programs: list[Program], pool: concurrent.futures.Executor,
                    log: Callable[[str], None] = lambda m: None
                    ) -> dict[int, list[concurrent.futures.Future]]:
    """Compile every program not yet compiled, for every device, in the background; the
    futures per program id.

    One thread lowers the programs in order and hands each to `pool` to compile. Lowering is
    Python and holds the GIL: lowered in parallel threads, every program would finish lowering
    only when all do; XLA's compiles release the GIL and run in parallel. With helper processes
    (`trace_workers()` at a time, `trace_in_worker`) the programs go in order of device work,
    most first (`Group.work`), unless that program is in the store already; at the first
    program that must be traced, the programs after it go to the helpers, which trace them
    while this thread traces that one; the thread then loads theirs from the store. A helper
    starts seconds after this thread (its imports), so the group with the longest chunks waits
    the least for its program. A thread of its own builds each program's scene from its turn
    on: a stored program needs none to load, so on a warm start the first chunk waits for the
    longer of the two, not for both.
    """
    todo = list({id(p): p for p in programs if not p.compiled}.values())
    # One future per device's compile, and a last one for the scene (`Program.prepare`).
    futures = {id(p): [concurrent.futures.Future() for _ in range(len(p.devices) + 1)]
               for p in todo}

    def done_into(future, task: Callable, *args) -> None:
        """Run `task(*args)`; its end, or its error, goes to `future`."""
        try:
            task(*args)
            future.set_result(None)
        except BaseException as error:  # handed to the thread that waits for it
            future.set_exception(error)

    # The scenes are built in a thread of their own, in order, each from its program's turn
    # on: a stored program then loads beside its scene (a traced one waits for it).
    scenes = concurrent.futures.ThreadPoolExecutor(max_workers=1)

    # The lowering thread keeps its own references: the caller pops programs off the dict it
    # gets back as it reaches them, possibly before this thread does.
    work = [(p, futures[id(p)]) for p in todo]

    workers = trace_workers() if exported.store() is not None else 0
    helpers = concurrent.futures.ThreadPoolExecutor(max_workers=workers) if workers else None
    traced_elsewhere: dict[int, concurrent.futures.Future] = {}

    def take_over(p: Program) -> None:
        """The worker's program for `p`, or none: not started yet (then traced here at once), or
        failed; a program a worker traced but the store does not hold (a key that differs) is
        traced here too, and said so."""
        job = traced_elsewhere[id(p)]
        if job.cancel():
            return
        try:
            p._worker_s = job.result()
        except WorkerFailed as failure:
            log(f"{failure}; tracing it here")
            return
        if p._worker_s is not None and not p.stored():
            log(f"the trace worker's program of {''.join(p.group.letters)} is not in the store "
                "under this run's key; tracing it here")

    def order() -> None:
        """With helpers, the program of the most device work goes first when it must be traced:
        this thread traces it itself, so its chunks wait the least. When it is in the store (a
        warm start), the plan's order stands: nothing waits for a trace, and the first chunk
        starts as soon as the first program loads (the others load while it plays)."""
        if not helpers or not work:
            return
        try:
            heaviest_stored = max(todo, key=lambda p: p.group.work).stored()
        except Exception:  # its scene failed: its own turn raises it through its futures
            return
        if not heaviest_stored:
            work.sort(key=lambda item: -item[0].group.work)

    def lower_in_order() -> None:
        order()
        for i, (p, program_futures) in enumerate(work):
            *device_futures, scene_future = program_futures
            scenes.submit(done_into, scene_future, p.prepare)
            try:
                if helpers and not traced_elsewhere and len(work) > i + 1 and not p.stored():
                    traced_elsewhere.update({id(q): helpers.submit(trace_in_worker, q)
                                             for q, _ in work[i + 1:]})
                    log(f"tracing {len(work) - i - 1} program(s) in "
                        f"{min(workers, len(work) - i - 1)} worker process(es)")
                if id(p) in traced_elsewhere:
                    take_over(p)
                _ = p.portable  # traced or loaded once, then lowered for each device
            except BaseException as error:  # handed to the threads that wait for it
                for future in device_futures:
                    future.set_exception(error)
                continue
            for device, future in enumerate(device_futures):
                try:
                    start = time.perf_counter()
                    lowered = p.lower(device)
                    pool.submit(done_into, future, p.compile, device, lowered,
                                time.perf_counter() - start)
                except BaseException as error:  # likewise
                    future.set_exception(error)

    def lower_then_release() -> None:
        try:
            lower_in_order()
        finally:
            scenes.shutdown(wait=False)  # the scenes submitted are still built
            if helpers:
                helpers.shutdown(wait=False, cancel_futures=True)

    if todo:
        pool.submit(lower_then_release)
    return futures


def first_ready(waiting: list[Chunk],
                compiles: Callable[[Chunk], list[concurrent.futures.Future]]) -> Chunk | None:
    """The first of the `waiting` chunks whose program's `compiles` are all done (a failed one
    counts: playing it raises), or None while there is none."""
    return next((c for c in waiting if all(f.done() for f in compiles(c))), None)


def next_ready(waiting: list[Chunk],
               compiles: Callable[[Chunk], list[concurrent.futures.Future]]) -> Chunk:
    """`first_ready`, once there is one."""
    while (chunk := first_ready(waiting, compiles)) is None:
        concurrent.futures.wait([f for c in waiting for f in compiles(c) if not f.done()],
                                return_when=concurrent.futures.FIRST_COMPLETED)
    return chunk


@dataclasses.dataclass(frozen=True)
class ChunkResult:
    """One finished chunk, on the host: what `rows.py` turns into rows."""

    chunk: Chunk
    group: Group
    drop: Record  # the drop's record (k = -1): the settled layout's statistics; leading axis batch
    records: list[Record]  # attempt k's records (numpy, leading axis batch; padding included)
    timings: dict  # one `timings.csv` row (`schema.TIMINGS_COLUMNS`)
    views: ChunkViews | None  # every attempt's images, left on the devices (if kept)


def peak_gib(devices: list[jax.Device]) -> float | None:
    """The most memory in use at once so far in this process, in GiB, on the fullest of
    `devices` (None where the backend keeps no such count: the CPU). It tells which `--batch`
    fits a device."""
    stats = [d.memory_stats() or {} for d in devices]
    peaks = [s["peak_bytes_in_use"] for s in stats if "peak_bytes_in_use" in s]
    return round(max(peaks) / 2**30, 3) if peaks else None


def run_chunks(groups: list[Group], points: list[Config], batch: int, done: set[int] = frozenset(),
               keep_views: bool = False, progress: Callable[[int], None] = lambda n: None,
               log: Callable[[str], None] = lambda m: None, overlap: bool = True,
               process: int = 0) -> Iterator[ChunkResult]:
    """Play every chunk not in `done`; yield each as it finishes. While the caller handles a
    yielded chunk, the next one whose program is ready already plays on the devices (unless
    views are kept), so closing the generator early waits for that chunk to end.

    Programs compile in background threads; with `overlap`, a group's chunks start as soon as
    its own program is ready, while the other groups' programs still compile (the device works
    while the host compiles): the next chunk is the first in plan order whose program is ready.
    Without it, every program is compiled before the first chunk (benchmarks: run time apart
    from compile time). A chunk's timings say whether its program was traced here, traced by
    a worker process or loaded from the store of exported programs (`program`), what tracing or
    loading and compiling took (`trace_s`, `compile_s`, on a group's first chunk) and when it
    started (`started_s`, seconds since this call began: gaps are the device waiting for a
    compile), the device memory it had needed at most so far (`peak_gib`) and which of the
    run's processes played it (`process`: 0 the run's own, else a helper's, `players.py`)."""
    began = time.perf_counter()
    plan_ = chunks(groups, batch)
    todo = [c for c in plan_ if c.index not in done]
    needed = list(dict.fromkeys(c.group for c in todo))  # in the order their chunks run
    programs = {g: program(groups[g], batch, keep_views) for g in needed}
    fresh = {g for g, p in programs.items() if not p.compiled}
    tasks = 1 + sum(len(p.devices) for p in programs.values() if not p.compiled)  # + lowering
    with concurrent.futures.ThreadPoolExecutor(max_workers=tasks) as pool:
        compiling = _start_compiles(list(programs.values()), pool, log)
        if compiling:
            log(f"compiling {len(compiling)} program(s) ...")

        def ready(prog: Program) -> None:
            futures = compiling.pop(id(prog), [])
            for future in futures:
                future.result()
            if futures:
                log(f"compiled the program of {''.join(prog.group.letters)} "
                    f"({prog.group.attempts} attempt(s) per world): "
                    f"{prog.origin} in {prog.trace_s:.1f} s, "
                    f"compiled in {prog.compile_s:.1f} s")

        if not overlap:
            for prog in programs.values():
                ready(prog)

        def play(chunk: Chunk) -> ChunkResult:
            """Play one chunk on the devices (in the `device` thread) into its result; a failed
            compile of its program raises here, after the chunks before it were handed over."""
            prog = programs[chunk.group]
            ready(prog)
            start = time.perf_counter()
            drop, records, views = prog.play(chunk.worlds, points, progress)
            wall_s = time.perf_counter() - start
            real = len(chunk.worlds)
            attempts = sum(int(np.sum(np.asarray(r.aimed)[:real])) for r in records)
            first = chunk.group in fresh  # a group's first chunk carries its compile time
            fresh.discard(chunk.group)
            timings = {"chunk": chunk.index, "group": chunk.group,
                       "scene": "".join(prog.group.letters), "worlds": real,
                       "batch": prog.batch, "attempts": attempts,
                       "program": prog.origin,
                       "trace_s": round(prog.trace_s if first else 0.0, 3),
                       "compile_s": round(prog.compile_s if first else 0.0, 3),
                       "started_s": round(start - began, 3),
                       "wall_s": round(wall_s, 3),
                       "peak_gib": peak_gib(prog.devices), "process": process}
            return ChunkResult(chunk, prog.group, drop, records, timings, views)

        # One thread plays the chunks, one after another. While the caller turns a chunk into
        # rows and files, the next chunk whose program is ready already plays (not when views
        # are kept: two chunks' views would share the devices' memory).
        def compiles(chunk: Chunk) -> list[concurrent.futures.Future]:
            return compiling.get(id(programs[chunk.group]), [])

        waiting = list(todo)
        with concurrent.futures.ThreadPoolExecutor(max_workers=1) as device:
            def start(chunk: Chunk) -> concurrent.futures.Future:
                waiting.remove(chunk)
                return device.submit(play, chunk)

            playing = None
            while waiting or playing:
                if playing is None:
                    playing = start(next_ready(waiting, compiles))
                result = playing.result()
                following = None if keep_views else first_ready(waiting, compiles)
                playing = start(following) if following is not None else None
                yield result
