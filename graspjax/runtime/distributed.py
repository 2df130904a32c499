"""One run over several processes or hosts, on JAX's own multi-controller runtime.

`graspjax run ... --distributed` is started once per process (by Slurm, Open MPI, or by hand
with `--distributed HOST:PORT,N,I`): `initialize` joins JAX's distributed runtime
(`jax.distributed.initialize`, which reads the launcher's environment), every process plans
the same chunks and plays every N-th one from its index into one shared folder, and
`barrier` (JAX's coordination service) holds each process until all have reached the same
point: the folder is ready, then every chunk is played and process 0 writes the results. No
coordination of graspjax's own: no sockets, no lock files.
"""

from __future__ import annotations

import threading

from graspjax import privates
from graspjax.errors import InputError

AUTO = "auto"  # `--distributed` alone: the launcher's environment says who is who
BARRIER_TIMEOUT_MS = 7 * 24 * 3600 * 1000  # a week: a process that ends its share early waits
JOIN_TIMEOUT_S = 300.0  # how long a process waits for every other to join (JAX's default)
# JAX's own join timeout, never reached first: at its end JAX's client stops the process with
# a native stack trace (a fatal error of its coordination agent), which no Python code catches
_JAX_JOIN_TIMEOUT_S = 7 * 24 * 3600


def initialize(spec) -> None:
    """Join the run's processes: `AUTO`, or (coordinator "HOST:PORT", process count, index).
    Every process waits for all to join (`jax.distributed.initialize`): one that has not after
    `JOIN_TIMEOUT_S` is an `InputError` naming it (when this process can tell which)."""
    import jax

    if spec == AUTO:
        where = {}
    else:
        address, count, index = spec
        _resolve(address)
        where = dict(coordinator_address=address, num_processes=count, process_id=index)
    failed: list[BaseException] = []

    def join() -> None:
        try:
            jax.distributed.initialize(**where, initialization_timeout=_JAX_JOIN_TIMEOUT_S)
        except BaseException as exc:  # raised again by the caller's thread
            failed.append(exc)

    # In a thread of its own, so that this one stops waiting first; the process then ends
    # (the CLI) long before JAX's own timeout.
    joining = threading.Thread(target=join, name="join the run", daemon=True)
    joining.start()
    joining.join(JOIN_TIMEOUT_S)
    if joining.is_alive():
        raise InputError(_not_joined(spec))
    if failed and isinstance(failed[0], ValueError) and spec == AUTO:  # no launcher's variables
        raise InputError(f"--distributed alone reads the launcher's environment (Slurm, Open "
                         f"MPI), which names no run here ({failed[0]}): give --distributed "
                         "HOST:PORT,N,I") from None
    if failed:
        raise failed[0]


def _resolve(address: str) -> None:
    """Refuse a coordinator whose host name does not resolve (JAX would wait for it until
    `JOIN_TIMEOUT_S`)."""
    import socket

    host, _, port = address.rpartition(":")
    try:
        socket.getaddrinfo(host.strip("[]"), int(port))
    except (OSError, UnicodeError) as exc:
        raise InputError(f"--distributed {address}: the host {host} cannot be found "
                         f"({getattr(exc, 'strerror', None) or exc})") from None


def _not_joined(spec) -> str:
    """The one line of a run whose processes did not all join in time."""
    waited = f"within {JOIN_TIMEOUT_S:g} s"
    if spec == AUTO:
        return (f"--distributed: the run's processes did not all join {waited} (the launcher's "
                "environment names them): see whether every one started")
    address, count, index = spec
    others = [i for i in range(count) if i != index]
    if not others:  # a run of one process: it serves the address itself
        return (f"--distributed {address},{count},{index}: the run did not start at {address} "
                f"{waited}: process 0 serves it, so the address must be this host's")
    missing = (f"process {others[0]}" if len(others) == 1
               else f"some of processes {', '.join(map(str, others))}")
    return (f"--distributed {address},{count},{index}: {missing} did not join the run at "
            f"{address} {waited}: start every process I of the run with --distributed "
            f"{address},{count},I, or check the address (process 0 serves it)")


def process() -> tuple[int, int]:
    """(this process's index, the process count): (0, 1) without `initialize`."""
    import jax

    return jax.process_index(), jax.process_count()


def barrier(name: str) -> None:
    """Wait until every process of the run has called `barrier(name)` (a no-op alone)."""
    if process()[1] > 1:
        privates.distributed_client().wait_at_barrier(f"graspjax:{name}", BARRIER_TIMEOUT_MS)


def shutdown() -> None:
    """Leave JAX's distributed runtime together (its shutdown is a barrier of every process):
    before the process ends, which `cli.entry` does without Python's exit handlers."""
    import jax

    if process()[1] > 1:
        jax.distributed.shutdown()
