"""The chunks of a run played on every local device (`runtime.devices`): which chunk a device
takes next, and each finished chunk's result on the host.

The groups' programs (`program.py`) compile in the background (`runtime/compiles.py`); the next
chunk is the first in plan order whose program is ready, so the device runs one group while
the host still compiles the others.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import threading
import time
from collections.abc import Callable, Iterator

import jax
import numpy as np

from graspjax.batch.plan import Chunk, Group, chunks
from graspjax.batch.program import ChunkViews, Program, program
from graspjax.config import Config
from graspjax.procedure import Record
from graspjax.runtime.compiles import start_compiles
from graspjax.runtime.devices import play_on_devices
from graspjax.sim.objects import OBJECTS


@dataclasses.dataclass(frozen=True)
class ChunkResult:
    """One finished chunk, on the host: what `rows.py` turns into rows."""

    chunk: Chunk
    group: Group
    drop: Record  # the drop's record (k = -1): the settled layout's statistics; leading axis batch
    records: list[Record]  # attempt k's records (numpy, leading axis batch; padding included)
    timings: dict  # one `timings.csv` row (`schema.TIMINGS_COLUMNS`)
    views: ChunkViews | None  # every attempt's images, left on the devices (if kept)


def peak_gib(device: jax.Device) -> float | None:
    """The most memory in use at once so far in this process on `device`, in GiB (None where
    the backend keeps no such count: the CPU). It tells which `--batch` fits a device."""
    peak = (device.memory_stats() or {}).get("peak_bytes_in_use")
    return None if peak is None else round(peak / 2**30, 3)


def heaviest_first(todo: list[Chunk], groups: list[Group]) -> list[Chunk]:
    """The chunks in the order devices take them: the groups of the most device work per world
    first (a round of six objects before a drop of one); among equals, the group whose objects
    have more convex pieces, since MJX's collision work grows with them (g-l's Setup 1 chunks
    took 3.2-4.3 s on one H200, a-f's 2.2-2.8 s: results/benchmarks, stop 64), so that the last
    chunks of a run on several devices are the short ones; plan order otherwise."""
    def cost(chunk: Chunk) -> tuple[float, int]:
        group = groups[chunk.group]
        pieces = sum(len(OBJECTS[letter].pieces) for letter in group.letters)
        return -group.work / len(group.worlds), -pieces

    return sorted(todo, key=cost)


def run_chunks(groups: list[Group], points: list[Config], batch: int, done: set[int] = frozenset(),
               keep_views: bool = False, progress: Callable[[int], None] = lambda n: None,
               log: Callable[[str], None] = lambda m: None, overlap: bool = True,
               process: int = 0,
               status: Callable[[str], None] = lambda s: None) -> Iterator[ChunkResult]:
    """Play every chunk not in `done`; yield each as it finishes.

    Every local device plays whole chunks in a thread of its own: the first chunk in
    `heaviest_first` order whose program's copy on that device is ready, then the next, so no
    device waits while there is work (nor for another device's copy). While the caller
    handles a yielded chunk the devices play on (unless views are kept: then a device starts
    its next chunk only once the caller has handled its last, whose views it holds); closing
    the generator early waits for the chunks playing to end.

    Programs compile in background threads (`runtime.compiles`); with `overlap`, a group's
    chunks start as soon as its own program is ready on their device, while other programs
    (and other devices' copies) still compile: the devices work while the host compiles.
    Without it, every program is compiled for every device before the first chunk
    (benchmarks: run time apart from compile time). A chunk's timings say where its
    program came from (`program`: traced here, by a worker process, or loaded from the store),
    what tracing or loading and compiling took (`trace_s`, `compile_s`, on a group's first
    chunk), when it started (`started_s`, seconds since this call began: gaps are a device
    waiting for a compile), the memory its device had needed at most so far (`peak_gib`), and
    which device and which of the run's processes played it (`device`, `process`: 0 the run's
    own, else a helper's, `runtime.players`). `status(text)`, for the progress bar: the programs
    still traced or compiled ("compiling abcdef (Setup 2, 3), ghijkl (Setup 1)"; "": none)."""
    began = time.perf_counter()
    todo = [c for c in chunks(groups, batch) if c.index not in done]
    needed = list(dict.fromkeys(c.group for c in todo))
    programs = {g: program(groups[g], batch, keep_views) for g in needed}
    fresh = {g for g, p in programs.items() if not p.compiled}  # before any compile starts
    devices = jax.local_devices()
    tasks = 1 + sum(len(p.devices) for p in programs.values() if not p.compiled)  # + lowering
    with concurrent.futures.ThreadPoolExecutor(max_workers=tasks) as pool:
        compiling = start_compiles(list(programs.values()), pool, log)
        if compiling:
            log(f"compiling {len(compiling)} program(s) ...")
        players = _Players(programs, fresh, compiling, points, began, process, progress, log,
                           status)
        if not overlap:
            for prog in programs.values():
                for device in range(len(devices)):
                    players.ready(prog, device)
        yield from play_on_devices(
            heaviest_first(todo, groups), len(devices),
            lambda chunk, device: players.copy_of(programs[chunk.group], device), players.play,
            players.lock, one_at_a_time=keep_views)


class _Players:
    """What `run_chunks`'s device threads share: the programs and their compiles, and how a
    device plays one chunk into its result. `lock` guards the logged and fresh programs, the
    compiles still pending and the progress."""

    def __init__(self, programs: dict[int, Program], fresh: set[int], compiling: dict,
                 points: list[Config], began: float, process: int,
                 progress: Callable[[int], None], log: Callable[[str], None],
                 status: Callable[[str], None]):
        self.programs, self.compiling, self.points = programs, compiling, points
        self.began, self.process, self.progress, self.log, self.status = (began, process,
                                                                          progress, log, status)
        self.lock = threading.Lock()
        self.fresh = fresh  # groups whose first chunk carries the compile time
        self.logged: set[int] = set()
        self.pending = {id(p): f"{p.name} (Setup {', '.join(map(str, p.group.setups))})"
                        for p in programs.values() if id(p) in compiling}
        self.tell()

    def tell(self) -> None:
        """The programs still compiling, for the progress bar."""
        self.status(f"compiling {', '.join(self.pending.values())}" if self.pending else "")

    def copy_of(self, prog: Program, device: int) -> list[concurrent.futures.Future]:
        """What `device` waits for to play `prog`: its own copy's compile and the scene (the
        last future); not the other devices' copies."""
        futures = self.compiling.get(id(prog), [])
        return [futures[device], futures[-1]] if futures else []

    def ready(self, prog: Program, device: int) -> None:
        """Wait for `device`'s copy of `prog` (a failed compile raises here)."""
        for future in self.copy_of(prog, device):
            future.result()
        with self.lock:
            if id(prog) in self.compiling and id(prog) not in self.logged:
                self.logged.add(id(prog))
                self.log(f"compiled the program of {prog.name} "
                         f"({prog.group.attempts} attempt(s) per world): "
                         f"{prog.origin} in {prog.trace_s:.1f} s, "
                         f"compiled in {prog.compile_s:.1f} s")
                self.pending.pop(id(prog), None)
                self.tell()

    def counted(self, attempts: int) -> None:
        with self.lock:
            self.progress(attempts)

    def play(self, chunk: Chunk, device: int) -> ChunkResult:
        """Play one chunk on `device` into its result; a failed compile of its program raises
        here."""
        prog = self.programs[chunk.group]
        self.ready(prog, device)
        start = time.perf_counter()
        drop, records, views = prog.play(chunk.worlds, self.points, device, self.counted)
        wall_s = time.perf_counter() - start
        real = len(chunk.worlds)
        attempts = sum(int(np.sum(np.asarray(r.aimed)[:real])) for r in records)
        with self.lock:
            first = chunk.group in self.fresh  # a group's first chunk carries its compile time
            self.fresh.discard(chunk.group)
        timings = {"chunk": chunk.index, "group": chunk.group,
                   "scene": prog.name, "worlds": real,
                   "batch": prog.batch, "attempts": attempts,
                   "program": prog.origin,
                   "executable": prog.executable(device),
                   "trace_s": round(prog.trace_s if first else 0.0, 3),
                   "compile_s": round(prog.compile_s if first else 0.0, 3),
                   "started_s": round(start - self.began, 3),
                   "wall_s": round(wall_s, 3),
                   "peak_gib": peak_gib(prog.devices[device]), "device": device,
                   "process": self.process}
        return ChunkResult(chunk, prog.group, drop, records, timings, views)
