"""When each step of one `graspjax` command runs, and in which thread: a timeline of the calls
that make up a run's fixed cost (imports, device start, scene builds, program loads, chunks,
rows, files, report, teardown).

    START=$(date +%s.%N) python3 experiments/timeline.py run --table 1,2 --trials 1000 --seed 0 ...

The arguments are `graspjax`'s. Every call of the functions in CALLS is timed (seconds since
START, the shell's clock when it launched Python: the interpreter's own start counts); calls
of 0.05 s or more are printed to stderr at exit as `TL begin end seconds thread name`, then
`TL_LAST_ATEXIT` when the last exit handler runs (the rest of the wall time is the
interpreter's teardown). TIMELINE_CALLS adds targets (`module:Qualified.name`, comma-separated,
e.g. `jax:block_until_ready`); TIMELINE_PROFILE names targets among them whose calls are also
profiled (cProfile), printed at exit, 30 lines each by cumulative time: one profile at a
time (Python 3.12's profiler is per process), a call that starts while another is profiled is
only timed. The graspjax modules are imported before the command runs, so the imports are timed
apart (`graspjax run` itself starts the devices beside them). With TIMELINE_EXIT=1 the
process ends at that point without the teardown. Results:
results/benchmarks/history/physics_step.md (stop 40), scaling_h200x2_stop63/ (stop 63).
"""

import atexit
import cProfile
import functools
import importlib
import io
import os
import pstats
import sys
import threading
import time

START = float(os.environ.get("START", time.time()))
EVENTS: list[tuple[str, float, float, str]] = []
PROFILED = [t for t in os.environ.get("TIMELINE_PROFILE", "").split(",") if t]
PROFILES: dict[str, list[cProfile.Profile]] = {}
PROFILING = threading.Lock()  # held while a call is profiled
CALLS = [
    "graspjax.experiment:run",
    "graspjax.batch.program:Program.portable",
    "graspjax.batch.program:Program.scene",
    "graspjax.batch.program:Program.arrays",
    "graspjax.batch.program:Program.lower",
    "graspjax.batch.program:Program.compile",
    "graspjax.batch.program:Program.play",
    "graspjax.runtime.compiles:trace_in_worker",
    "graspjax.batch.rows:attempt_rows",
    "graspjax.batch.rows:round_rows",
    "graspjax.outputs:RunFolder.add",
    "graspjax.outputs:RunFolder.finish",
    "graspjax.report:write_report",
    "graspjax.sim.scene:mjx.put_model",
    "jax._src.xla_bridge:backends",
    "jax._src.compiler:compile_or_get_cached",
    "jax._src.compilation_cache:get_executable_and_time",
]


def since_start() -> float:
    return time.time() - START


@atexit.register  # registered first, so it runs after every other exit handler (JAX's too)
def _last_handler() -> None:
    print(f"TL_LAST_ATEXIT {since_start():.2f}", file=sys.stderr, flush=True)
    if os.environ.get("TIMELINE_EXIT"):
        os._exit(0)


def timed(name: str, fn, profiled: bool = False):
    """`fn`, noting each call's begin and end in EVENTS (and profiling it, with `profiled`,
    unless another call is being profiled)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        begin = since_start()
        try:
            if profiled and PROFILING.acquire(blocking=False):
                try:
                    profile = cProfile.Profile()
                    PROFILES.setdefault(name, []).append(profile)
                    return profile.runcall(fn, *args, **kwargs)
                finally:
                    PROFILING.release()
            return fn(*args, **kwargs)
        finally:
            EVENTS.append((name, begin, since_start(), threading.current_thread().name))
    return wrapper


def wrap(target: str) -> None:
    """Time `module:Qualified.name` (a function, method, property or cached property) in place."""
    module, _, qualified = target.partition(":")
    *path, name = qualified.split(".")
    owner = importlib.import_module(module)
    for part in path:
        owner = getattr(owner, part)
    inner = owner.__dict__[name]
    profiled = target in PROFILED
    if isinstance(inner, property):
        setattr(owner, name, property(timed(qualified, inner.fget, profiled)))
    elif isinstance(inner, functools.cached_property):
        cached = functools.cached_property(timed(qualified, inner.func, profiled))
        cached.__set_name__(owner, name)
        setattr(owner, name, cached)
    else:
        setattr(owner, name, timed(qualified, inner, profiled))


def imported(module: str):
    begin = since_start()
    loaded = importlib.import_module(module)
    EVENTS.append((f"import {module}", begin, since_start(), "MainThread"))
    return loaded


@atexit.register
def _show() -> None:
    for name, begin, end, thread in sorted(EVENTS, key=lambda e: e[1]):
        if end - begin >= 0.05:
            print(f"TL {begin:8.2f} {end:8.2f} {end - begin:7.2f}  {thread[:24]:24s} {name}",
                  file=sys.stderr)
    for name, profiles in PROFILES.items():
        text = io.StringIO()
        pstats.Stats(*profiles, stream=text).sort_stats("cumulative").print_stats(30)
        print(f"PROFILE {name} ({len(profiles)} call(s))\n{text.getvalue()}", file=sys.stderr)
    print(f"TL {since_start():8.2f} exit", file=sys.stderr)


if __name__ == "__main__":
    for module in ("jax", "graspjax.cli", "graspjax.experiment", "graspjax.report"):
        imported(module)
    extra = [t for t in os.environ.get("TIMELINE_CALLS", "").split(",") if t]
    for target in dict.fromkeys(CALLS + extra + PROFILED):
        wrap(target)
    # names the modules imported before they were wrapped
    experiment = sys.modules["graspjax.experiment"]
    program = sys.modules["graspjax.batch.program"]
    rows = sys.modules["graspjax.batch.rows"]
    experiment.run_chunks = program.run_chunks
    experiment.attempt_rows, experiment.round_rows = rows.attempt_rows, rows.round_rows
    sys.exit(sys.modules["graspjax.cli"].main(sys.argv[1:]))
