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

from graspjax import privates

AUTO = "auto"  # `--distributed` alone: the launcher's environment says who is who
BARRIER_TIMEOUT_MS = 7 * 24 * 3600 * 1000  # a week: a process that ends its share early waits


def initialize(spec: str) -> None:
    """Join the run's processes: `AUTO`, or (coordinator "HOST:PORT", process count, index)."""
    import jax

    if spec == AUTO:
        jax.distributed.initialize()
    else:
        address, count, index = spec
        jax.distributed.initialize(coordinator_address=address, num_processes=count,
                                   process_id=index)


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
