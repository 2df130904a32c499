"""`graspjax bench pipeline --profile DIR` (and `bench detect`'s): where a run's device time
goes, by source line.

The run (`bench detect`: one batch call) plays under JAX's profiler. Every kernel a GPU ran
(every XLA thunk, on the CPU) is summed by the compiled operation that launched it, and that
operation is named by the Python line it was traced from: the compiled programs' HLO
metadata, one line per operation (`runtime.exported`). Nothing here steers a run; it reads the
profiler's files afterwards.
"""

from __future__ import annotations

import functools
import re
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd

from graspjax.schema import PROFILE_COLUMNS

_SECTION = re.compile(r"^(FileNames|FunctionNames|FileLocations|StackFrames)$")
_ENTRY = re.compile(r"^(\d+)\s+(.*)$")
_FIELD = re.compile(r"(\w+)=(\d+)")
_INSTRUCTION = re.compile(r"^\s*(?:ROOT\s+)?%?([^\s=]+)\s+=\s.*?metadata=\{([^}]*)\}")
_MODULE = re.compile(r"^HloModule\s+([^\s,]+)")
_QUOTED = re.compile(r'(\w+)="((?:[^"\\]|\\.)*)"')


class FirstRound:
    """`run_chunks`'s `status` and `progress` callbacks that profile the first round of the
    first chunks: from the moment no program is left to compile (a benchmark's run compiles
    every program first) to the end of the first attempt call, the worlds' placement, drop
    and first attempt. One round, not the run: a run's kernels would be millions, more than
    the profiler keeps."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.seconds = 0.0  # how long the trace ran
        self._started: float | None = None
        self._lock = threading.Lock()

    def status(self, compiling: str) -> None:
        import jax

        with self._lock:
            if not compiling and self._started is None:
                jax.profiler.start_trace(str(self.folder))
                self._started = time.perf_counter()

    def attempted(self, _attempts: int = 0) -> None:
        """The end of an attempt call: the first stops the trace."""
        import jax

        with self._lock:
            if self._started is not None and not self.seconds:
                jax.profiler.stop_trace()
                self.seconds = time.perf_counter() - self._started

    close = attempted  # after the run: a trace still running stops


def profile_call(fn, args: tuple, folder: Path) -> tuple[float, pd.DataFrame]:
    """One call of the jitted `fn` on `args` under JAX's profiler (`folder`/trace): the
    seconds it took and `attributed`'s rows, also written to `folder`/kernels.csv. The
    compiled text that names the lines is `fn`'s for these arguments (the same operations,
    from the compilation cache or compiled again)."""
    import jax

    start = time.perf_counter()
    with jax.profiler.trace(str(folder / "trace")):
        jax.block_until_ready(fn(*args))
    seconds = time.perf_counter() - start
    kernels = attributed(device_ops(folder / "trace"), [fn.lower(*args).compile().as_text()])
    kernels.to_csv(folder / "kernels.csv", index=False)
    return seconds, kernels


def device_ops(trace_dir: str | Path) -> pd.DataFrame:
    """The device time of every compiled operation in a profiler trace (`jax.profiler.trace`'s
    folder): columns module, op, kernel (the first kernel's name), calls, seconds. On a GPU
    the device planes' stream lines (not the derived "XLA Ops" lines, which repeat them),
    elsewhere every line's events that name an HLO operation; events that contain another
    event of their line (a CPU while loop around its body) are left out, so nothing counts
    twice."""
    from jax.profiler import ProfileData

    files = sorted(Path(trace_dir).rglob("*.xplane.pb"))
    if not files:
        raise FileNotFoundError(f"no *.xplane.pb under {trace_dir}")
    rows = []
    for path in files:
        data = ProfileData.from_file(str(path))
        planes = list(data.planes)
        gpu = [p for p in planes if p.name.startswith("/device:GPU")]
        for plane in gpu or planes:
            lines = list(plane.lines)
            streams = [line for line in lines if line.name.startswith("Stream")]
            for line in streams if gpu else lines:
                rows.extend(_leaf_ops(line))
    frame = pd.DataFrame(rows, columns=["module", "op", "kernel", "seconds"])
    return (frame.groupby(["module", "op"], sort=False)
            .agg(kernel=("kernel", "first"), calls=("seconds", "size"),
                 seconds=("seconds", "sum"))
            .reset_index().sort_values("seconds", ascending=False, ignore_index=True))


def _leaf_ops(line) -> list[tuple[str, str, str, float]]:
    """(module, op, kernel name, seconds) of a line's events that name an HLO operation and
    contain no other such event of the line."""
    events = []
    for event in line.events:
        stats = dict(event.stats)
        if stats.get("hlo_op"):
            events.append((event.start_ns, event.duration_ns, stats.get("hlo_module"),
                           stats["hlo_op"], event.name))
    if not events:
        return []
    events.sort(key=lambda e: (e[0], -e[1]))  # a parent before a child that starts with it
    start = np.array([e[0] for e in events], float)
    end = start + np.array([e[1] for e in events], float)
    parent = np.zeros(len(events), bool)
    parent[:-1] = start[1:] < end[:-1]
    return [(module, op, name, duration * 1e-9)
            for (_, duration, module, op, name), is_parent in zip(events, parent, strict=True)
            if not is_parent]


def op_sources(hlo_text: str) -> dict[str, tuple[str, str, int]]:
    """Each instruction of a compiled HLO module's text, by name: (file, function, line) of
    the source line it was traced from ("" and 0 where its metadata names none)."""
    tables: dict[str, dict[int, str]] = {}
    section = None
    sources = {}
    for text in hlo_text.splitlines():
        match = _SECTION.match(text.strip())
        if match:
            section = match.group(1)
            tables[section] = {}
            continue
        if section is not None:
            entry = _ENTRY.match(text.strip())
            if entry:
                tables[section][int(entry.group(1))] = entry.group(2)
                continue
            if text.strip():
                section = None
        instruction = _INSTRUCTION.match(text)
        if instruction:
            sources[instruction.group(1)] = _source(instruction.group(2), tables)
    return sources


def _source(metadata: str, tables: dict[str, dict[int, str]]) -> tuple[str, str, int]:
    quoted = dict(_QUOTED.findall(metadata))
    numbers = {k: int(v) for k, v in _FIELD.findall(_QUOTED.sub("", metadata))}
    frame = tables.get("StackFrames", {}).get(numbers.get("stack_frame_id", -1))
    if frame is not None:
        location_id = int(dict(_FIELD.findall(frame)).get("file_location_id", -1))
        location = tables.get("FileLocations", {}).get(location_id)
        if location is not None:
            fields = {k: int(v) for k, v in _FIELD.findall(location)}
            file = tables.get("FileNames", {}).get(fields.get("file_name_id"), '""').strip('"')
            function = tables.get("FunctionNames", {}).get(fields.get("function_name_id"),
                                                           '""').strip('"')
            return _short(file), function, fields.get("line", 0)
    if "source_file" in quoted:
        return _short(quoted["source_file"]), "", numbers.get("source_line", 0)
    return "", "", 0


@functools.cache
def _short(path: str) -> str:
    """A source file relative to the import path that holds it (`mujoco/mjx/_src/io.py`), or
    to the folder holding graspjax (an editable install is on no import path). A program
    loaded from the compilation cache names the files where the process that compiled it
    found them: there, the path after its last `site-packages/` or from its last `graspjax/`.
    Cached: a program's thousands of instructions name a few dozen files."""
    import graspjax

    places = [*sys.path, str(Path(graspjax.__file__).parents[1])]
    roots = sorted((p for p in places if p and path.startswith(p.rstrip("/") + "/")),
                   key=len, reverse=True)
    if roots:
        return path[len(roots[0].rstrip("/")) + 1:]
    for marker in ("/site-packages/", "/dist-packages/"):
        if marker in path:
            return path.rsplit(marker, 1)[1]
    _, found, rest = path.rpartition("/graspjax/")
    return "graspjax/" + rest if found else path


def attributed(ops: pd.DataFrame, texts: list[str]) -> pd.DataFrame:
    """`device_ops`'s rows with the source line of each operation (`PROFILE_COLUMNS`): `texts`
    are the compiled HLO texts of the modules profiled (a module's name, the profiler's
    `hlo_module`, is on its text's first line; of two modules of one name, the first's)."""
    sources = {}
    for text in reversed(texts):
        name = _MODULE.match(text)
        if name:
            sources[name.group(1)] = op_sources(text)
    found = [sources.get(m, {}).get(op, ("", "", 0)) for m, op in zip(ops["module"], ops["op"],
                                                                       strict=True)]
    out = ops.assign(file=[f[0] for f in found], function=[f[1] for f in found],
                     line=[f[2] for f in found])
    return out[list(PROFILE_COLUMNS)]


def summary(kernels: pd.DataFrame, traced_s: float, top: int = 12) -> str:
    """The device time by source file, then by function, then by line: a printed table."""
    total = kernels["seconds"].sum()
    named = kernels.assign(file=kernels["file"].replace("", "(no source line)"))
    lines = [f"device time {total:.2f} s in {int(kernels['calls'].sum()):,} kernels "
             f"in {traced_s:.2f} s traced"]
    for title, keys in (("file", ["file"]), ("function", ["file", "function"]),
                        ("line", ["file", "function", "line"])):
        table = named.groupby(keys)["seconds"].sum().sort_values(ascending=False).head(top)
        lines.append(f"\nby {title}:")
        for key, seconds in table.items():
            label = ":".join(str(k) for k in key) if isinstance(key, tuple) else str(key)
            lines.append(f"  {100 * seconds / total:5.1f} %  {seconds:8.3f} s  {label}")
    return "\n".join(lines)
