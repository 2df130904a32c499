"""`graspjax bench finish`: what a large run does after its last chunk (its files assembled,
then its report), timed on the CPU with a finished run's rows repeated to any size."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import pandas as pd

from graspjax.bench import bench_record
from graspjax.outputs import RunFolder, read_run_config
from graspjax.provenance import device_line, provenance
from graspjax.report import load_attempts, load_rounds, write_report
from graspjax.schema import TIMINGS_COLUMNS


def finish_benchmark(source: str, rows: int = 96_000, progress=print) -> dict:
    """What a run of `rows` attempt rows does after its last chunk: its files assembled
    (`outputs.RunFolder.finish`), then its report from the rows in memory. The rows are a
    finished run's (`source`), repeated with their trials and rounds renumbered until there
    are `rows`, in that run's chunks; each chunk goes through `RunFolder.add` as the run's
    would (untimed), then the finish is timed."""
    meta = read_run_config(Path(source) / "config.json", ROWS_FROM)
    attempts, rounds = load_attempts(source), load_rounds(source)
    rounds = rounds if rounds is not None else pd.DataFrame(columns=["point", "setup", "round"])
    meta.pop("finished", None)
    span = int(attempts["trial"].max()) + 1  # trials (rounds) of a copy are renumbered past it
    copies = -(-rows // len(attempts))
    parts = []  # (attempt rows, round rows) per chunk: a copy's rounds go with its first chunk
    for copy in range(copies):
        frame = attempts.assign(trial=attempts["trial"] + copy * span)
        if "round" in frame.columns:
            frame["round"] = frame["round"] + copy * span
        played = rounds.assign(round=rounds["round"] + copy * span)
        for i, (_, rows_of) in enumerate(frame.groupby("chunk")):
            parts.append((rows_of.assign(chunk=len(parts)).reset_index(drop=True),
                          played if i == 0 else played.iloc[:0]))
    n = sum(len(f) for f, _ in parts)
    progress(f"{n:,} rows in {len(parts)} chunks (from {source})")
    timings = dict.fromkeys(TIMINGS_COLUMNS, 0)
    with tempfile.TemporaryDirectory() as folder:
        run = RunFolder(folder, meta, len(parts), resume=False)
        for index, (frame, chunk_rounds) in enumerate(parts):
            run.add(index, frame, chunk_rounds, {**timings, "chunk": index})
        start = time.perf_counter()
        run.finish()
        files = time.perf_counter()
        write_report(folder, rows=run.report_rows)
        end = time.perf_counter()
    return bench_record("finish", {"source": str(source), "rows": n, "chunks": len(parts),
                                   "files_s": files - start, "report_s": end - files,
                                   "after_last_chunk_s": end - start, **provenance()})


ROWS_FROM = "--rows-from takes a finished run's folder"  # why its config.json must be read


def format_finish(r: dict) -> str:
    return (f"{device_line(r)}\n{r['rows']:,} rows in {r['chunks']} chunks: after the last chunk "
            f"{r['after_last_chunk_s']:.2f} s = files {r['files_s']:.2f} s + report "
            f"{r['report_s']:.2f} s")
