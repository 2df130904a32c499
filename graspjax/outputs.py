"""A run's folder, written as the run goes: nothing finished is ever lost, nothing is doubled.

While a run is going:

- `config.json`: every setting, seed, batch, devices, versions, command,
  written before the first chunk;
- `parts/timings-NNNNN.json`, `parts/rounds-NNNNN.parquet` and
  `parts/attempts-NNNNN.parquet`: one set per finished chunk, each written
  atomically; a chunk is done when its attempts part exists;
- `attempts.csv`: the rows of each finished chunk appended at once (in the
  order chunks finish, before its parts), to watch a long run with any tool
  (not while several processes write the folder: it then appears at the end).

When every chunk is done, `attempts.csv`, `attempts.parquet` and
`rounds.csv` (one row per Setup 2/3 round: how dense its layout was) are
rebuilt from the parts, sorted (so a resumed or split run ends byte-identical to an
uninterrupted one), `timings.csv` joins the chunks' timings, and `parts/` is
removed; the report (`summary.csv`, tables, figures) is then computed from
those files alone (`report.write_report`). `--resume` continues a killed run: it checks that the
folder holds the same run (same run id and batch), rewrites `attempts.csv`
from the parts (dropping an append whose chunk is not done) and runs only the
chunks not done.

`attempts.csv` is deterministic: wall-clock times live in `timings.csv`.
"""

from __future__ import annotations

import hashlib
import io
import json
import shutil
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

from graspjax.batch.rows import sort_attempts
from graspjax.io import InputError, write_atomic


def check_output_folder(folder: str | Path, resume: bool = False, overwrite: bool = False) -> Path:
    """Fail early (one line) if a run cannot be written to `folder`; creates nothing.

    Missing parent folders are fine (they are created when the run starts); a
    folder that already holds a run needs `resume` (continue it; also for the
    parts of a shared run) or `overwrite`.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--out {folder} exists and is not a directory")
    probe = folder
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise InputError(f"--out {folder}: {probe} is not a directory")
    try:
        import tempfile

        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError:
        raise InputError(f"--out {folder}: {probe} is not writable") from None
    holds_run = (folder / "config.json").is_file()
    if holds_run and not (resume or overwrite):
        raise InputError(f"--out {folder} already holds a run (use --resume to continue it, "
                         "--overwrite to replace it, or another folder)")
    return folder


def run_id(meta: dict) -> str:
    """A short id derived from what determines the results (seed, jobs, configuration, grid)."""
    key = json.dumps({k: meta[k] for k in ("seed", "jobs", "overrides", "grid")}, sort_keys=True,
                     default=str)
    return hashlib.sha1(key.encode()).hexdigest()[:10]


def _csv(frame: pd.DataFrame, header: bool) -> bytes:
    return frame.to_csv(index=False, header=header, float_format="%.7g").encode()  # float32 precision


class RunFolder:
    """The files of one run (module docstring), written chunk by chunk.

    A chunk is done when its part file exists (parts are written atomically),
    so several processes may share one folder, each running its own chunks
    (`--part I/N` on several hosts, `shared`: whichever finds every chunk done
    assembles the results and keeps the parts for the others; or helper
    processes of one run, `batch.players`: the run assembles them). Processes
    that share a folder do not append to `attempts.csv` (`append`).
    """

    def __init__(self, folder: str | Path, meta: dict, chunks: int, resume: bool,
                 shared: bool = False, append: bool | None = None):
        self.folder = Path(folder)
        self.parts = self.folder / "parts"
        self.chunks, self.meta, self.shared = chunks, meta, shared
        self.append = not shared if append is None else append
        config = self.folder / "config.json"
        if config.is_file() and (resume or shared):
            old = json.loads(config.read_text())
            for key in ("run_id", "batch"):
                if old.get(key) != meta.get(key):
                    raise InputError(f"--out {self.folder} holds another run ({key} "
                                     f"{old.get(key)!r}, this command {meta.get(key)!r})")
        elif self.folder.exists():  # --overwrite: nothing of the old run may mix with this one
            for stale in ("parts", "views", "debug"):
                shutil.rmtree(self.folder / stale, ignore_errors=True)
            for stale in ("attempts.csv", "attempts.parquet", "rounds.csv", "timings.csv"):
                (self.folder / stale).unlink(missing_ok=True)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.finished = (self.folder / "attempts.parquet").is_file() and not self.parts.is_dir()
        if not self.finished:
            self.parts.mkdir(exist_ok=True)
            write_atomic(config, (json.dumps(meta, indent=2, default=str) + "\n").encode())
            if self.append:
                self._rewrite_csv()
            elif not shared:  # written when the run ends; an earlier run's appends would mislead
                (self.folder / "attempts.csv").unlink(missing_ok=True)

    @property
    def done(self) -> set[int]:
        """Chunks whose rows are kept."""
        if self.finished:
            return set(range(self.chunks))
        return {int(p.stem.split("-")[1]) for p in self.parts.glob("attempts-*.parquet")}

    def _part_frames(self) -> list[pd.DataFrame]:
        return [pd.read_parquet(self.parts / f"attempts-{c:05d}.parquet") for c in sorted(self.done)]

    def _rewrite_csv(self) -> None:
        """attempts.csv = the rows of the chunks done (drops an append whose chunk is not done)."""
        frames = self._part_frames()
        text = _csv(pd.concat(frames, ignore_index=True), True) if frames else b""
        write_atomic(self.folder / "attempts.csv", text)

    def add(self, chunk: int, frame: pd.DataFrame, layouts: pd.DataFrame, timings: dict) -> None:
        """Keep one finished chunk: the CSV append, its timings and round rows, then its attempt
        rows, whose part file marks it done (written last: a chunk marked done is all on disk;
        a kill before that leaves an append that `--resume` drops)."""
        buffer = io.BytesIO()
        frame.to_parquet(buffer, index=False)
        rounds = io.BytesIO()
        layouts.to_parquet(rounds, index=False)
        if self.append:
            csv = self.folder / "attempts.csv"
            with open(csv, "ab") as handle:
                handle.write(_csv(frame, header=csv.stat().st_size == 0))
        write_atomic(self.parts / f"timings-{chunk:05d}.json", json.dumps(timings).encode())
        write_atomic(self.parts / f"rounds-{chunk:05d}.parquet", rounds.getvalue())
        write_atomic(self.parts / f"attempts-{chunk:05d}.parquet", buffer.getvalue())

    def finish(self) -> list[Path]:
        """Rebuild the attempts and rounds from the parts, sorted, and write the timings.

        Returns the files written, or an empty list while chunks are missing. The report
        (tables, figures) is computed from these files afterwards (`report.write_report`).
        """
        if not self.finished:
            if len(self.done) < self.chunks:
                return []
            frame = sort_attempts(pd.concat(self._part_frames(), ignore_index=True))
            timings = pd.DataFrame([json.loads((self.parts / f"timings-{c:05d}.json").read_text())
                                    for c in sorted(self.done)])
            parquet = io.BytesIO()
            frame.to_parquet(parquet, index=False)
            rounds = pd.concat([pd.read_parquet(self.parts / f"rounds-{c:05d}.parquet")
                                for c in sorted(self.done)], ignore_index=True)
            rounds = rounds.sort_values(["point", "setup", "round"], kind="stable")
            write_atomic(self.folder / "attempts.parquet", parquet.getvalue())
            write_atomic(self.folder / "attempts.csv", _csv(frame, True))
            write_atomic(self.folder / "rounds.csv", _csv(rounds, True))
            write_atomic(self.folder / "timings.csv", timings.to_csv(index=False).encode())
            meta = {**self.meta, "finished": datetime.now(UTC).isoformat(timespec="seconds")}
            write_atomic(self.folder / "config.json",
                         (json.dumps(meta, indent=2, default=str) + "\n").encode())
            if not self.shared:  # another process may still be reading them
                shutil.rmtree(self.parts)
            self.finished = True
        data_files = ("attempts.csv", "attempts.parquet", "rounds.csv", "timings.csv", "config.json")
        return [self.folder / name for name in data_files]
