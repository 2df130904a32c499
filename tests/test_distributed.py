"""One run over several processes on JAX's distributed runtime: joining it, and a process that
never comes. (A whole run over two processes: tests/test_experiment.py.)"""

import os
import socket
import subprocess
import sys

import pytest

from graspjax.cli import main


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


@pytest.mark.slow  # starts Python processes that import JAX (`pytest -m "not slow"`: README)
def test_the_run_s_processes_join_and_know_their_index():
    address = f"localhost:{_free_port()}"
    done = _python(*(f"from graspjax.runtime import distributed as d; "
                     f"d.initialize(({address!r}, 2, {i})); print(d.process()); "
                     "d.barrier('test'); d.shutdown()" for i in range(2)), timeout=120)
    for i, (code, out, err) in enumerate(done):
        assert code == 0, err[-2000:]
        assert out.strip() == f"({i}, 2)"


@pytest.mark.slow  # starts Python processes that import JAX (`pytest -m "not slow"`: README)
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


@pytest.mark.parametrize("address, message", [
    ("localhost:notaport,1,0", "needs a port 1-65535 after the host, got 'localhost:notaport,1,0'"),
    ("localhost:0,1,0", "needs a port 1-65535 after the host"),
    (":1234,1,0", "needs a port 1-65535 after the host"),
    ("nohost.invalid:1234,2,0", "--distributed nohost.invalid:1234: the host nohost.invalid "
                                "cannot be found"),
])
def test_a_coordinator_that_cannot_be_reached_is_one_line_before_any_wait(tmp_path, capsys,
                                                                        address, message):
    """Not a native crash (a port that is no number) or five minutes' wait for a host that does
    not exist: one line and exit 2 at once, nothing written."""
    out = tmp_path / "run"
    assert main(["run", "--setup", "1", "--distributed", address, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not out.exists()


@pytest.mark.slow  # starts a Python process that imports JAX (`pytest -m "not slow"`: README)
def test_distributed_alone_without_a_launcher_says_what_to_give(tmp_path):
    """`--distributed` reads Slurm's or Open MPI's environment; with neither, one line (JAX's
    own ValueError once ended in a traceback)."""
    out = tmp_path / "run"
    argv = ["graspjax", "run", "--setup", "1", "--distributed", "--dry-run", "--out", str(out)]
    clean = {k: v for k, v in os.environ.items()
             if not k.startswith(("SLURM_", "OMPI_", "PMI_", "JAX_COORDINATOR"))}
    proc = subprocess.run([sys.executable, "-c", "import sys; sys.argv = " + repr(argv)
                           + "; from graspjax.cli import entry; entry()"], text=True,
                          capture_output=True, timeout=120, env={**clean, "JAX_PLATFORMS": "cpu"})
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert proc.stderr.startswith("graspjax: error: --distributed alone reads the launcher's "
                                  "environment") and proc.stderr.count("\n") == 1
    assert "give --distributed HOST:PORT,N,I" in proc.stderr and not out.exists()


def test_a_run_of_one_process_that_did_not_start_says_the_address_must_be_this_host_s():
    from graspjax.runtime.distributed import _not_joined

    line = _not_joined(("example.org:1234", 1, 0))
    assert line.startswith("--distributed example.org:1234,1,0: the run did not start at "
                           "example.org:1234 within") and "this host's" in line
    assert "some of processes" not in line
