"""A helper process that traces one group's batch program into the store of exported programs.

Tracing is Python and holds its process's GIL, so a run with several programs to trace would
trace them one after another. With cores to spare, the run hands its later programs to helper
processes (`program.trace_in_worker`), one per program: each traces the program the run itself
would (same group, batch, devices, flags and JAX settings, hence the same store key) and saves it;
the run then loads it as if an earlier run had left it there. Run as
`python -m graspjax.batch.worker` with the job pickled on stdin; prints its tracing seconds.
"""

from __future__ import annotations

import dataclasses
import json
import pickle
import sys


@dataclasses.dataclass(frozen=True)
class Job:
    """What a helper needs to trace the program that the run would trace."""

    group: object  # plan.Group, reduced to its first world (the shapes of any batch)
    batch: int  # the program's static batch (all devices)
    keep_views: bool
    cache_dir: str  # the compilation cache folder: the store is its `exported/`
    jax_settings: dict  # JAX settings that enter a program's key (`exported._path`)


def main() -> int:
    job: Job = pickle.load(sys.stdin.buffer)
    import jax

    jax.config.update("jax_compilation_cache_dir", job.cache_dir)
    for name, value in job.jax_settings.items():
        jax.config.update(name, value)
    from graspjax.batch.program import Program

    program = Program(job.group, job.batch, job.keep_views)
    seconds = sum(p.seconds for p in program.portable)
    print(json.dumps({"seconds": seconds, "traced": program.origin == "traced"}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
