"""The compile scheduler (graspjax.runtime.compiles): the order programs lower and trace in,
failures handed to whoever waits, the next chunk the first whose program is ready."""

import concurrent.futures
import threading

import pytest

from graspjax.batch.plan import Chunk
from graspjax.errors import InputError
from graspjax.runtime import compiles, exported


class _Deferred(concurrent.futures.Executor):
    """An executor that runs nothing until told: the order of two threads, made explicit."""

    def __init__(self):
        self.calls = []

    def submit(self, fn, *args):
        self.calls.append((fn, args))
        return concurrent.futures.Future()


class _Untraceable:
    """A program whose tracing fails."""

    compiled, devices = False, ("cpu",)

    @property
    def portable(self):
        raise ValueError("cannot trace")

    def prepare(self):  # its scene builds
        pass


def test_a_program_that_fails_to_trace_fails_the_run_instead_of_hanging_it():
    """The run may take a program's futures before the lowering thread reaches it (a race that
    once hung runs): the failure still reaches the futures it waits on."""
    pool, broken = _Deferred(), _Untraceable()
    waiting = compiles.start_compiles([broken], pool).pop(id(broken))
    (lower_in_order, args), = pool.calls
    lower_in_order(*args)  # the lowering thread, after the run took its futures
    with pytest.raises(ValueError, match="cannot trace"):
        waiting[0].result(timeout=0)


@pytest.mark.parametrize("value, workers",
                         [("3", 3), (" 0 ", 0), ("two", None), ("-1", None), ("\u00b2", None)])
def test_trace_workers_come_from_the_environment(monkeypatch, value, workers):
    monkeypatch.setenv("GRASPJAX_TRACE_WORKERS", value)
    if workers is None:
        with pytest.raises(InputError, match="GRASPJAX_TRACE_WORKERS must be a whole number"):
            compiles.trace_workers()
    else:
        assert compiles.trace_workers() == workers


def test_a_device_takes_the_first_chunk_whose_program_is_ready():
    """Order among the chunks whose programs have compiled; wait when none has; a taken chunk
    leaves the list; nothing once it is empty or the run stops."""
    first, second = (concurrent.futures.Future() for _ in range(2))
    waiting = [Chunk(0, 0, ()), Chunk(1, 0, ()), Chunk(2, 1, ())]
    futures = {0: [first], 1: [second]}
    lock, stop = threading.Lock(), threading.Event()
    for delay, future in ((0.2, second), (2.0, first)):  # the second program compiles first
        threading.Timer(delay, future.set_result, [None]).start()
    assert compiles.take_ready(waiting, lambda c: futures[c.group], lock, stop).index == 2
    first = futures[0][0] = concurrent.futures.Future()
    first.set_exception(RuntimeError("failed to compile"))  # done: playing it will raise
    assert compiles.take_ready(waiting, lambda c: futures[c.group], lock, stop).index == 0
    assert [c.index for c in waiting] == [1]
    stop.set()
    assert compiles.take_ready(waiting, lambda c: futures[c.group], lock, stop) is None
    assert compiles.take_ready([], lambda c: [], lock, threading.Event()) is None


class _LoggedProgram:
    """A program that notes when the lowering thread reaches it."""

    def __init__(self, name, work, stored, reached):
        self.name, self.work = name, work
        self.compiled, self.devices, self._stored, self.reached = False, [None], stored, reached

    def stored(self):
        return self._stored

    @property
    def portable(self):
        self.reached.append(self.name)

    def prepare(self):
        self.reached.append(f"{self.name} scene")

    def lower(self):
        return None

    def compile(self, device, lowered, lower_s):
        pass


class _ThreeDevices:
    """A program of three devices that notes its lowerings and compiles (or fails to lower)."""

    name, work, compiled, devices = "three", 1, False, [None] * 3
    portable = None

    def __init__(self, lowering_fails: bool):
        self.lowering_fails, self.lowered, self.compiles = lowering_fails, [], []

    def stored(self):
        return True

    def prepare(self):
        pass

    def lower(self):
        if self.lowering_fails:
            raise ValueError("cannot lower")
        self.lowered.append(object())
        return self.lowered[-1]

    def compile(self, device, lowered, lower_s):
        self.compiles.append((device, lowered))


@pytest.mark.parametrize("lowering_fails", [False, True])
def test_a_program_is_lowered_once_and_compiled_for_each_device(lowering_fails):
    """One lowering serves every device: each device's compile gets that one lowered program;
    a failed lowering reaches every device's future."""
    p = _ThreeDevices(lowering_fails)
    with concurrent.futures.ThreadPoolExecutor(4) as pool:
        futures = compiles.start_compiles([p], pool)[id(p)]
        concurrent.futures.wait(futures, timeout=30)
    *devices, scene = futures
    if lowering_fails:
        assert all(isinstance(f.exception(), ValueError) for f in devices)
        assert p.compiles == []
    else:
        assert len(p.lowered) == 1 and all(f.exception() is None for f in devices)
        assert sorted(p.compiles, key=lambda c: c[0]) == [(d, p.lowered[0]) for d in range(3)]
    assert scene.exception() is None


@pytest.mark.parametrize("stored, order", [(False, ["heavy", "light"]),
                                           (True, ["light", "heavy"])])
def test_with_helpers_the_heaviest_program_goes_first_unless_it_is_stored(
        monkeypatch, tmp_path, stored, order):
    """A cold start traces the program of the most device work first (helpers trace the rest);
    a warm start keeps the plan's order, so that its first chunk waits for nothing but a load."""
    monkeypatch.setenv("GRASPJAX_TRACE_WORKERS", "1")
    monkeypatch.setattr(exported, "store", lambda: tmp_path)
    monkeypatch.setattr(compiles, "trace_in_worker", lambda p: None)  # traced "elsewhere": no-op
    reached = []
    programs = [_LoggedProgram("light", 1, stored, reached),
                _LoggedProgram("heavy", 10, stored, reached)]
    with concurrent.futures.ThreadPoolExecutor(4) as pool:
        futures = compiles.start_compiles(programs, pool)
        concurrent.futures.wait([f for fs in futures.values() for f in fs], timeout=30)
    assert [name for name in reached if "scene" not in name] == order
    # Every scene is built, in the same order, each from its program's turn on.
    assert [name for name in reached if "scene" in name] == [f"{name} scene" for name in order]
    assert all(reached.index(f"{name} scene") < reached.index(later)
               for i, name in enumerate(order) for later in order[i + 1:])

