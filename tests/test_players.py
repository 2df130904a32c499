"""Helper processes of a run: how many, on which cores, and a failed one (the rows they play are
checked end to end in test_experiment.py)."""

import os
import threading

import jax
import pytest

from graspjax import experiment
from graspjax.errors import InputError
from graspjax.runtime import players


@pytest.mark.parametrize("cores, process, processes, expected", [
    ({0, 1}, 0, 2, {0}),
    ({0, 1}, 1, 2, {1}),
    ({0, 1, 2, 3}, 0, 3, {0, 1}),  # the first block takes the core left over
    ({0, 1, 2, 3}, 1, 3, {2}),
    ({0, 1, 2, 3}, 2, 3, {3}),
    ({4, 6, 9}, 1, 2, {9}),  # this process's cores, whatever their numbers
    ({0}, 0, 2, None),  # fewer cores than processes: they share them
])
def test_each_process_keeps_to_its_own_block_of_cores(monkeypatch, cores, process, processes,
                                                      expected):
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(cores))
    assert players.cores_of(process, processes) == expected


@pytest.mark.parametrize("env, requested, cores, expected", [
    ("", None, 2, 2),  # one per core
    ("", None, 16, players.MAX_DEFAULT),
    ("1", None, 16, 1),
    ("3", None, 2, 3),
    ("3", 1, 2, 1),  # --processes wins
])
def test_the_number_of_processes(monkeypatch, env, requested, cores, expected):
    monkeypatch.setenv("GRASPJAX_PROCESSES", env)
    monkeypatch.setattr(jax, "default_backend", lambda: "cpu")
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(cores)))
    assert players.count(requested) == expected


@pytest.mark.parametrize("env, requested, backend, message", [
    ("two", None, "cpu", "GRASPJAX_PROCESSES must be a whole number >= 1, got 'two'"),
    ("0", None, "cpu", "GRASPJAX_PROCESSES must be a whole number >= 1, got '0'"),
    ("", 0, "cpu", "--processes must be >= 1, got 0"),
    ("", 2, "gpu", "on a CPU only, and this run's device is a GPU"),
])
def test_a_bad_number_of_processes_is_one_line(monkeypatch, env, requested, backend, message):
    monkeypatch.setenv("GRASPJAX_PROCESSES", env)
    monkeypatch.setattr(jax, "default_backend", lambda: backend)
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        players.count(requested)


@pytest.mark.parametrize("env", ["", "3"])
def test_a_gpu_run_plays_in_one_process(monkeypatch, env):
    """GRASPJAX_PROCESSES is a CPU setting: a GPU run in the same shell plays in one process."""
    monkeypatch.setenv("GRASPJAX_PROCESSES", env)
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    assert players.count() == 1


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="Linux's per-thread affinity")
def test_every_thread_keeps_to_the_cores_inside_the_block_and_gets_its_own_back():
    everywhere = os.sched_getaffinity(0)
    one, own = {min(everywhere)}, {max(everywhere)}  # on one core, both are that core
    started = threading.Event()
    release = threading.Event()
    seen = {}

    def before_the_block():  # a thread on cores of its own, running across the block
        os.sched_setaffinity(0, own)
        started.set()
        release.wait()
        seen["after"] = os.sched_getaffinity(0)

    early = threading.Thread(target=before_the_block)
    early.start()
    started.wait()
    with players.kept_to(one):
        assert os.sched_getaffinity(0) == one
        assert os.sched_getaffinity(early.native_id) == one
        inside = threading.Thread(target=lambda: seen.update(inside=os.sched_getaffinity(0)))
        inside.start()
        inside.join()
    release.set()
    early.join()
    assert seen["inside"] == one  # a thread started inside inherits the block's cores
    assert os.sched_getaffinity(0) == everywhere
    assert seen["after"] == own  # its own cores back, not every core


def test_a_failed_helper_fails_the_run_with_its_last_words():
    """A helper that cannot play its job (here: no experiment) ends with an error: waiting for
    it raises its last line."""
    helper = players.Helper(experiment.play_helper_share, None, "/nonexistent", {}, 1, (0,),
                            lambda attempts: None, players.cores_of(1, 2))
    try:
        with pytest.raises(players.HelperFailed, match="a helper process of the run failed: "
                                                       "AttributeError: 'NoneType' object"):
            helper.wait()
    finally:
        helper.stop()
