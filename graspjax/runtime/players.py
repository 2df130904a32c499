"""Helper processes that play some of a run's groups beside the run's own process (CPU).

On a CPU one process keeps fewer cores busy than it has: a chunk's physics step is thousands
of small kernels, mostly one after another (1.4 of 2 cores). Groups played in processes side
by side then end sooner than one after another in one process (README's command, warm, on 2
cores; results/benchmarks). `plan.share` splits the groups; each process traces or loads
only its own groups' programs, so a cold run compiles nothing twice.

A helper gets the run's experiment, its `config.json` (`meta`) and the chunks it plays; it
writes their part files into the run's folder, as the parts of a shared run do
(`outputs.RunFolder`), and prints the attempts of each call it finishes on stdout, one count a
line, for the run's progress bar. The run assembles the files once every helper is done. A
world's records do not depend on the process that plays it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

from graspjax.errors import InputError
from graspjax.provenance import SOURCES
from graspjax.runtime import tracer

MAX_DEFAULT = 4  # each process holds its own JAX client and programs: memory grows with them
# JAX settings a helper takes from the run: those of a trace worker, and the compilation cache.
SETTINGS = (*tracer.SETTINGS, "jax_compilation_cache_dir",
            "jax_persistent_cache_min_compile_time_secs")


def count(requested: int | None = None) -> int:
    """How many processes may play a run's groups: `requested` (--processes), else on a CPU
    `GRASPJAX_PROCESSES`, else one per core this process may use (at most `MAX_DEFAULT`); one
    on a GPU. --processes above one is refused on a GPU: its memory is one process's, and it
    plays one program at a time anyway (results/benchmarks)."""
    import jax

    cpu = jax.default_backend() == "cpu"
    if requested is None:
        value = os.environ.get("GRASPJAX_PROCESSES", "").strip()
        if value and not (value.isascii() and value.isdigit() and int(value) >= 1):
            raise InputError(f"GRASPJAX_PROCESSES must be a whole number >= 1, got {value!r}")
        if not cpu:  # a CPU setting: a GPU run in the same shell plays in one process
            return 1
        if value:
            return int(value)
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
        return max(1, min(cores or 1, MAX_DEFAULT))
    if requested < 1:
        raise InputError(f"--processes must be >= 1, got {requested}")
    if requested > 1 and not cpu:
        raise InputError(f"--processes {requested}: several processes play groups on a CPU "
                         f"only, and this run's device is a {jax.default_backend().upper()}")
    return requested


def cores_of(process: int, processes: int) -> set[int] | None:
    """The cores `process` of `processes` keeps to (None: no affinity here, or fewer cores than
    processes): this process's cores in contiguous blocks, one per process. Two processes sharing
    both of 2 cores played slower than each kept to one: their XLA threads contended
    (results/benchmarks)."""
    if not hasattr(os, "sched_getaffinity"):
        return None
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < processes:
        return None
    size, extra = divmod(len(cores), processes)
    first = process * size + min(process, extra)
    return set(cores[first:first + size + (process < extra)])


@contextlib.contextmanager
def kept_to(cores: set[int] | None):
    """Every thread of this process on `cores` while the block runs (threads started inside
    inherit it), then back on the cores each had. Linux sets the affinity of one thread at a
    time, so each of /proc/self/task's is set."""
    tasks = Path("/proc/self/task")
    if cores is None or not tasks.is_dir():
        yield
        return
    before, everywhere = {}, os.sched_getaffinity(0)
    for task in tasks.iterdir():
        with contextlib.suppress(OSError):  # a thread that ended meanwhile
            before[int(task.name)] = os.sched_getaffinity(int(task.name))
            os.sched_setaffinity(int(task.name), cores)
    try:
        yield
    finally:
        for task in tasks.iterdir():  # a thread started inside gets the caller's cores back
            with contextlib.suppress(OSError):
                os.sched_setaffinity(int(task.name), before.get(int(task.name), everywhere))


@dataclasses.dataclass(frozen=True)
class Assignment:
    """What a helper plays, and where it writes."""

    play: Callable  # play(job, progress): a module-level function (pickled by its name), the
    # run's `experiment.play_helper_share`: the workflow above this layer plays, this one starts
    experiment: object  # the run's `experiment.Experiment`
    out: str  # the run's folder, created by the run
    meta: dict  # the run's config.json
    process: int  # which of the run's processes it is (timings.csv; 0: the run's own)
    chunks: tuple[int, ...]  # the chunks it plays (indices in the run's plan)
    jax_settings: dict  # name -> the run's value (`SETTINGS`)


class HelperFailed(RuntimeError):
    """A helper that did not play all its chunks: the run fails with its last words."""


class Helper:
    """One helper process, started at once; `progress(attempts)` is called from a thread of its
    own as the helper reports them. It keeps to `cores` (`cores_of`; None: every core)."""

    def __init__(self, play: Callable, experiment: object, out: str, meta: dict, process: int,
                 chunks: tuple[int, ...], progress: Callable[[int], None],
                 cores: set[int] | None = None):
        import jax

        job = Assignment(play, experiment, out, meta, process, chunks,
                  {k: getattr(jax.config, k) for k in SETTINGS})
        self._stderr = tempfile.TemporaryFile()  # a file: a full pipe would stall the helper
        # Its cores are set first, before any import starts a thread.
        command = ("import os, sys; cores = [int(c) for c in sys.argv[1:]]; "
                   "cores and os.sched_setaffinity(0, cores); "
                   "from graspjax.runtime.players import main; sys.exit(main())")
        # It runs in the folder that holds this graspjax package, so that it imports this one.
        self._process = subprocess.Popen([sys.executable, "-c", command, *map(str, sorted(cores or ()))],
                                         stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=self._stderr, cwd=SOURCES.parent)
        self._process.stdin.write(pickle.dumps(job))
        self._process.stdin.close()
        self._reader = threading.Thread(target=self._follow, args=(progress,), daemon=True,
                                        name="helper progress")
        self._reader.start()

    def _follow(self, progress: Callable[[int], None]) -> None:
        for line in self._process.stdout:  # read to the end: a full pipe would stall the helper
            if line.strip().isdigit():  # anything else a library printed is not progress
                progress(int(line))

    def running(self) -> bool:
        """Whether the helper process still runs."""
        return self._process.poll() is None

    def wait(self) -> None:
        """Wait for the helper's end: `HelperFailed` unless it played every chunk."""
        self._process.wait()
        self._reader.join()
        self.check()

    def check(self) -> None:
        """`HelperFailed` if the helper has ended without playing every chunk: with its last
        line, or the signal that stopped it (the kernel's out-of-memory killer sends SIGKILL)."""
        code = self._process.poll()
        if code is not None and code < 0:
            raise HelperFailed("a helper process of the run was stopped by "
                               f"{signal.Signals(-code).name}")
        if code:
            self._stderr.seek(0)
            lines = self._stderr.read().decode(errors="replace").strip().splitlines()
            raise HelperFailed("a helper process of the run failed: "
                               f"{(lines or ['no output'])[-1]}")

    def stop(self) -> None:
        """End the helper now if it still runs (the run failed or was interrupted)."""
        if self._process.poll() is None:
            self._process.kill()
            self._process.wait()
        self._stderr.close()


def main() -> int:
    """A helper: play the job on stdin (`Assignment.play`)."""
    _end_with_the_run()
    job: Assignment = pickle.load(sys.stdin.buffer)
    import jax

    for name, value in job.jax_settings.items():
        jax.config.update(name, value)
    job.play(job, lambda attempts: print(attempts, flush=True))
    return 0


def _end_with_the_run() -> None:
    """Linux: this process gets SIGKILL when the run's process ends, so that a run killed
    outright leaves no helper writing into its folder."""
    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
