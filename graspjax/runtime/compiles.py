"""The compile scheduler: every program of a run traced (or loaded), lowered and compiled in
the background, so the devices play one program's chunks while the host still compiles others.

A program is anything with the `Compilable` shape (`batch.program.Program`). One thread lowers
the programs in turn, each once for every device (lowering is Python and holds the GIL), each
device's copy is made in a thread of its own (XLA's compiles release the GIL; with the store of
executables on, one device compiles and the others load its executable: `executables.py`), and on a
machine with cores to spare helper processes (`tracer.py`) trace the later programs into the
store of exported programs meanwhile. The caller's device threads take their next chunk with
`take_ready`: the first in their order whose program is ready.
"""

from __future__ import annotations

import concurrent.futures
import json
import os
import pickle
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from graspjax.errors import InputError
from graspjax.provenance import SOURCES
from graspjax.runtime import exported, tracer


class Compilable(Protocol):
    """What the scheduler needs of a program."""

    name: str  # what messages call it (a group's object letters)
    work: float  # its device work: with trace helpers, the heaviest traces first
    devices: Sequence  # the devices it compiles for, one copy each
    compiled: bool  # every device's copy compiled
    portable: tuple  # its exported functions, traced or loaded on first use (cached)
    worker_s: float | None  # set here: a trace helper's seconds, if one traced it

    def stored(self) -> bool:
        """Whether the store of exported programs holds it (`portable` would load)."""

    def prepare(self) -> None:
        """Build what playing needs besides the program (a scene), in a thread of its own."""

    def lower(self) -> Any:
        """Lower once for every device (holds the GIL)."""

    def compile(self, device: int, lowered: Any, lower_s: float) -> None:
        """Compile what `lower` gave for one device (releases the GIL)."""

    def trace_recipe(self) -> tuple[Callable, tuple]:
        """A module-level callable and its (picklable) arguments that build the same program
        in another process: a trace helper calls it and reads `portable`."""


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


def trace_in_worker(p: Compilable) -> float | None:
    """Trace `p` in a helper process (`tracer.py`) into the store; the helper's tracing seconds,
    or None when it found the program already stored. `WorkerFailed` (with the helper's last
    words) when it fails or hangs; `InterruptedError` when a signal stopped it (Ctrl-C reaches
    the whole process group)."""
    import jax

    build, args = p.trace_recipe()
    settings = {key: getattr(jax.config, key) for key in tracer.SETTINGS}
    job = tracer.TraceJob(build, args, str(exported.store().resolve().parent), settings)
    # The run's flags and devices, but not its memory: the helper only traces. It runs in the
    # folder that holds this graspjax package, so that it imports this one and no other.
    env = {**os.environ, "XLA_PYTHON_CLIENT_PREALLOCATE": "false"}
    command = "import sys; from graspjax.runtime.tracer import main; sys.exit(main())"
    try:
        done = subprocess.run([sys.executable, "-c", command],
                              input=pickle.dumps(job), capture_output=True, env=env,
                              cwd=SOURCES.parent, timeout=WORKER_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise WorkerFailed(f"the trace worker of {p.name} ran over {WORKER_TIMEOUT_S} s") from None
    if done.returncode < 0:
        raise InterruptedError(f"the trace worker of {p.name} was stopped by a signal")
    if done.returncode == 0:
        result = json.loads(done.stdout.decode().strip().splitlines()[-1])
        return result["seconds"] if result["traced"] else None
    last = (done.stderr.decode(errors="replace").strip().splitlines() or ["no output"])[-1]
    raise WorkerFailed(f"the trace worker of {p.name} failed: {last}")


def start_compiles(programs: list[Compilable], pool: concurrent.futures.Executor,
                    log: Callable[[str], None] = lambda m: None
                    ) -> dict[int, list[concurrent.futures.Future]]:
    """Compile every program not yet compiled, for every device, in the background; the
    futures per program id.

    One thread lowers the programs in order, each once for all devices, and hands each to
    `pool` to compile for every device (one lowering per device held the GIL some 0.5 s each,
    and staggered the devices' first chunks by as much: results/benchmarks). Lowering is
    Python and holds the GIL: lowered in parallel threads, every program would finish lowering
    only when all do; XLA's compiles release the GIL and run in parallel. With helper processes
    (`trace_workers()` at a time, `trace_in_worker`) the programs go in order of device work,
    most first (`Compilable.work`), unless that program is in the store already; at the first
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
    if todo:
        pool.submit(_Lowering(todo, futures, pool, log).run)
    return futures


def _done_into(future: concurrent.futures.Future, task: Callable, *args) -> None:
    """Run `task(*args)`; its end, or its error, goes to `future`."""
    try:
        task(*args)
        future.set_result(None)
    except BaseException as error:  # handed to the thread that waits for it
        future.set_exception(error)


class _Lowering:
    """`start_compiles`' lowering thread: the programs lowered in order, each handed to the pool
    to compile for every device; their scenes built in a thread of their own, each from its
    program's turn on (a stored program then loads beside its scene; a traced one waits for
    it); with helper processes, the programs after the first that must be traced traced by
    them."""

    def __init__(self, todo: list[Compilable], futures: dict[int, list[concurrent.futures.Future]],
                 pool: concurrent.futures.Executor, log: Callable[[str], None]):
        self.todo, self.pool, self.log = todo, pool, log
        # Its own references: the caller pops programs off the dict it gets back as it
        # reaches them, possibly before this thread does.
        self.work = [(p, futures[id(p)]) for p in todo]
        self.scenes = concurrent.futures.ThreadPoolExecutor(max_workers=1)
        self.workers = trace_workers() if exported.store() is not None else 0
        self.helpers = (concurrent.futures.ThreadPoolExecutor(max_workers=self.workers)
                        if self.workers else None)
        self.traced_elsewhere: dict[int, concurrent.futures.Future] = {}

    def take_over(self, p: Compilable) -> None:
        """The worker's program for `p`, or none: not started yet (then traced here at once), or
        failed; a program a worker traced but the store does not hold (a key that differs) is
        traced here too, and said so."""
        job = self.traced_elsewhere[id(p)]
        if job.cancel():
            return
        try:
            p.worker_s = job.result()
        except WorkerFailed as failure:
            self.log(f"{failure}; tracing it here")
            return
        if p.worker_s is not None and not p.stored():
            self.log(f"the trace worker's program of {p.name} is not in the store "
                     "under this run's key; tracing it here")

    def order(self) -> None:
        """With helpers, the program of the most device work goes first when it must be traced:
        this thread traces it itself, so its chunks wait the least. When it is in the store (a
        warm start), the plan's order stands: nothing waits for a trace, and the first chunk
        starts as soon as the first program loads (the others load while it plays)."""
        if not self.helpers or not self.work:
            return
        try:
            heaviest_stored = max(self.todo, key=lambda p: p.work).stored()
        except Exception:  # its scene failed: its own turn raises it through its futures
            return
        if not heaviest_stored:
            self.work.sort(key=lambda item: -item[0].work)

    def lower(self, i: int, p: Compilable, device_futures: list) -> None:
        """Program i traced (here or by a helper) or loaded, lowered once, and handed to the
        pool to compile for every device; an error goes to every device's future."""
        work, helpers = self.work, self.helpers
        try:
            if helpers and not self.traced_elsewhere and len(work) > i + 1 and not p.stored():
                self.traced_elsewhere.update({id(q): helpers.submit(trace_in_worker, q)
                                              for q, _ in work[i + 1:]})
                self.log(f"tracing {len(work) - i - 1} program(s) in "
                         f"{min(self.workers, len(work) - i - 1)} worker process(es)")
            if id(p) in self.traced_elsewhere:
                self.take_over(p)
            _ = p.portable  # traced or loaded once, then lowered once for every device
            start = time.perf_counter()
            lowered = p.lower()
            lower_s = time.perf_counter() - start
        except BaseException as error:  # handed to the threads that wait for it
            for future in device_futures:
                future.set_exception(error)
            return
        for device, future in enumerate(device_futures):
            self.pool.submit(_done_into, future, p.compile, device, lowered, lower_s)

    def run(self) -> None:
        try:
            self.order()
            for i, (p, program_futures) in enumerate(self.work):
                *device_futures, scene_future = program_futures
                self.scenes.submit(_done_into, scene_future, p.prepare)
                self.lower(i, p, device_futures)
        finally:
            self.scenes.shutdown(wait=False)  # the scenes submitted are still built
            if self.helpers:
                self.helpers.shutdown(wait=False, cancel_futures=True)


def first_ready(waiting: list,
                compiles: Callable[[Any], list[concurrent.futures.Future]]) -> Any | None:
    """The first of the `waiting` chunks whose program's `compiles` are all done (a failed one
    counts: playing it raises), or None while there is none."""
    return next((c for c in waiting if all(f.done() for f in compiles(c))), None)


def take_ready(waiting: list, compiles: Callable[[Any], list[concurrent.futures.Future]],
               lock: threading.Lock, stop: threading.Event) -> Any | None:
    """Remove from `waiting` and return its first chunk whose program's `compiles` are all
    done (`first_ready`), waiting for one; None once `waiting` is empty or `stop` is set.
    Several device threads take from one list, under `lock`."""
    while not stop.is_set():
        with lock:
            if not waiting:
                return None
            chunk = first_ready(waiting, compiles)
            if chunk is not None:
                waiting.remove(chunk)
                return chunk
            pending = [f for c in waiting for f in compiles(c) if not f.done()]
        concurrent.futures.wait(pending, timeout=1.0,
                                return_when=concurrent.futures.FIRST_COMPLETED)
    return None
