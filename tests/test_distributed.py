"""One run over several processes on JAX's distributed runtime: joining it, and a process that
never comes. (A whole run over two processes: tests/test_experiment.py.)"""

import os
import socket
import subprocess
import sys


def _free_port() -> int:
    with socket.socket() as probe:  # a free port for JAX's coordinator (the test's, not ours)
        probe.bind(("localhost", 0))
        return probe.getsockname()[1]


def _python(*codes: str, timeout: float) -> list[tuple[int, str, str]]:
    """Each of `codes` in a new CPU-only Python process at once (JAX's distributed runtime is
    per process): (exit status, stdout, stderr) of each; all are killed after `timeout`."""
    procs = [subprocess.Popen([sys.executable, "-c", code], text=True,
                              env={**os.environ, "JAX_PLATFORMS": "cpu"},
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE) for code in codes]
    try:
        said = [proc.communicate(timeout=timeout) for proc in procs]
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    return [(proc.returncode, *out) for proc, out in zip(procs, said, strict=True)]


def test_the_run_s_processes_join_and_know_their_index():
    address = f"localhost:{_free_port()}"
    done = _python(*(f"from graspjax.runtime import distributed as d; "
                     f"d.initialize(({address!r}, 2, {i})); print(d.process()); "
                     "d.barrier('test'); d.shutdown()" for i in range(2)), timeout=120)
    for i, (code, out, err) in enumerate(done):
        assert code == 0, err[-2000:]
        assert out.strip() == f"({i}, 2)"


def test_a_process_that_never_joins_is_named_in_one_line_and_nothing_is_written(tmp_path):
    """Process 0 of 2 started alone: after the join timeout (3 s here, 5 minutes by default) one
    line naming process 1, exit 2, no folder; not JAX's native abort with a stack trace."""
    address, out = f"localhost:{_free_port()}", tmp_path / "run"
    argv = ["graspjax", "run", "--setup", "1", "--distributed", f"{address},2,0", "--out", str(out)]
    [(code, _, err)] = _python("import sys; from graspjax.runtime import distributed; "
                               f"distributed.JOIN_TIMEOUT_S = 3; sys.argv = {argv!r}; "
                               "from graspjax.cli import entry; entry()", timeout=60)
    assert code == 2, err[-2000:]
    assert err == (f"graspjax: error: --distributed {address},2,0: process 1 did not join the run "
                   f"at {address} within 3 s: start every process I of the run with --distributed "
                   f"{address},2,I, or check the address (process 0 serves it)\n")
    assert not out.exists()
