"""A helper process that traces one program into the store of exported programs.

Tracing is Python and holds its process's GIL, so a run with several programs to trace would
trace them one after another. With cores to spare, the run hands its later programs to helper
processes (`compiles.trace_in_worker`), one per program: each builds the program the run itself
would (`Compilable.trace_recipe`: same group and batch; the run's environment, hence its flags
and devices; its JAX settings that enter a program's key; the same graspjax package), saves it
in the store, and prints `{"seconds": ..., "traced": ...}`; the run then loads it as if an
earlier run had left it there. `trace_in_worker` runs `main` in a new Python process with the
job pickled on stdin.
"""

from __future__ import annotations

import dataclasses
import json
import pickle
import sys
from collections.abc import Callable

from graspjax.runtime import exported

# JAX settings the run passes on: those in a program's key, and the platforms, which decide the
# devices and so the batch per device.
SETTINGS = (*exported.KEY_SETTINGS, "jax_platforms")


@dataclasses.dataclass(frozen=True)
class TraceJob:
    """What a helper needs to trace the program that the run would trace."""

    build: Callable  # build(*args): the program (module-level, pickled by its name)
    args: tuple  # its arguments (a group reduced to its first world: the shapes of any batch)
    cache_dir: str  # the compilation cache folder: the store is its `exported/`
    jax_settings: dict  # name -> the run's value (`SETTINGS`)


def main() -> int:
    """Trace the job on stdin (saved in the store), print its seconds."""
    import jax

    job: TraceJob = pickle.load(sys.stdin.buffer)
    jax.config.update("jax_compilation_cache_dir", job.cache_dir)
    for name, value in job.jax_settings.items():
        jax.config.update(name, value)
    program = job.build(*job.args)
    seconds = sum(p.seconds for p in program.portable)
    print(json.dumps({"seconds": seconds, "traced": not all(p.loaded for p in program.portable)}))
    return 0
