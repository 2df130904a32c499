"""A run's folder, written as the run goes: nothing finished is ever lost, nothing is doubled.

While a run is going:

- `config.json`: every setting, seed, batch, devices, versions, command,
  written before the first chunk;
- `parts/timings-NNNNN.json`, `parts/rounds-NNNNN.parquet`,
  `parts/attempts-NNNNN.csv` (its rows as CSV text, formatted once) and
  `parts/attempts-NNNNN.parquet`: one set per finished chunk, each written
  atomically; a chunk is done when its attempts parquet exists;
- `attempts.csv`: the rows of each finished chunk appended at once (in the
  order chunks finish), to watch a long run with any tool. Only the run's own
  process appends: the chunks of its helper processes (`runtime.players`) are
  appended as it finds their parts (`RunFolder.catch_up`); the parts of a run
  split over hosts (`--part I/N`) write it only at the end.

When every chunk is done, `attempts.csv`, `attempts.parquet` and `rounds.csv` (one row per
Setup 2/3 round: how dense its layout was) are rebuilt from the parts, sorted (so a resumed or
split run ends byte-identical to an uninterrupted one), `timings.csv` joins the chunks'
timings, and `parts/` is removed; the report is then computed from those rows alone, as this
process holds them read (`RunFolder.report_rows`, `report.write_report`). `--resume` continues
a killed run: it checks that the folder holds the same run (same run id and batch), rewrites
`attempts.csv` from the parts (dropping an append whose chunk is not done) and runs only the
chunks not done.

`attempts.csv` is deterministic: wall-clock times live in `timings.csv`.

A folder is a run's own only when its `config.json` is graspjax's (`holds_graspjax_output`);
`--overwrite` removes only the files graspjax writes (`OWN_FILES`), and while a run writes a
folder it holds its lock (`writing`).
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import hashlib
import io
import json
import os
import socket
from datetime import UTC, datetime
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from graspjax.disk import write_atomic
from graspjax.errors import InputError
from graspjax.report.files import read_attempts_csv, read_rounds_csv
from graspjax.schema import TIMINGS_COLUMNS, attempt_order

LOCK = ".graspjax.lock"  # held (an OS lock) by the process that writes the folder
# The files of a chunk done (`RunFolder.add`), as glob patterns under the run's folder.
PART_FILES = ("parts/attempts-[0-9]*.parquet", "parts/attempts-[0-9]*.csv",
              "parts/rounds-[0-9]*.parquet", "parts/timings-[0-9]*.json")
# Everything a run, a sweep, `graspjax report` or `graspjax planes` writes into its folder, as
# glob patterns: the run's own files (and the gzipped copies that committed results keep).
# `--overwrite` removes these and nothing else.
OWN_FILES = ("config.json", LOCK, "attempts.csv", "attempts.csv.gz", "attempts.parquet",
             "rounds.csv", "rounds.csv.gz", "timings.csv", "summary.csv", "rounds_summary.csv",
             "sweep_*.csv", "table[12].md", "table[12].tex", "success_by_object.png",
             "outcomes.png", "comparison.md", "comparison.png", "sweep_*.png", "planes.csv.gz",
             "planes_summary.csv", *PART_FILES, "views/p[0-9][0-9][0-9]_s[123]_r*.npz",
             "debug/p[0-9][0-9][0-9]_s[123]_r*.png")


def holds_graspjax_output(folder: Path) -> bool:
    """Whether `folder` is graspjax's own: its `config.json` is one that graspjax wrote (the
    marker: it names graspjax's version)."""
    try:
        meta = json.loads((folder / "config.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(meta, dict) and "graspjax" in (meta.get("versions") or {})


def _foreign(folder: Path) -> list[str]:
    """Files under `folder` that graspjax did not write (relative paths, sorted)."""
    own = {p for pattern in OWN_FILES for p in folder.glob(pattern)}
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if not p.is_dir() and p not in own)


def remove_own_files(folder: Path) -> None:
    """`--overwrite`: remove every file a graspjax run or sweep writes in `folder` (and its
    sub-folders, once empty), never anything else."""
    for pattern in OWN_FILES:
        for path in folder.glob(pattern):
            if path.name != LOCK:  # held by this process now
                path.unlink(missing_ok=True)
    for sub in ("parts", "views", "debug"):
        if (folder / sub).is_dir() and not any((folder / sub).iterdir()):
            (folder / sub).rmdir()


def check_output_folder(folder: str | Path, resume: bool = False, overwrite: bool = False) -> Path:
    """Fail early (one line) if a run cannot be written to `folder`; creates nothing.

    Missing parent folders are fine (they are created when the run starts); a
    folder that already holds a run needs `resume` (continue it; also for the
    parts of a shared run) or `overwrite`; a folder that holds anything else is
    refused (a user's files are never removed or mixed with a run's).
    """
    if not str(folder).strip():
        raise InputError("--out is empty: give a folder")
    folder = Path(folder)
    if folder.is_symlink() and not folder.exists():
        raise InputError(f"--out {folder} is a symbolic link to {os.readlink(folder)}, which does "
                         "not exist: give a folder")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--out {folder} exists and is not a directory")
    if folder.resolve() == Path(folder.resolve().anchor):
        raise InputError(f"--out {folder} is the file system's root: give a folder of its own")
    if (folder / LOCK).is_symlink():
        raise _linked_lock(folder)
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
    only_locked = folder.is_dir() and [p.name for p in folder.iterdir()] == [LOCK]
    if only_locked or _held(folder / LOCK):  # a run writes the folder (maybe still setting it
        return folder  # up) or has just taken it: its lock says whose (`writing`)
    if folder.is_dir() and any(folder.iterdir()) and not holds_graspjax_output(folder):
        files = _foreign(folder)
        shown = ", ".join(files[:3]) + (f" and {len(files) - 3} more" if len(files) > 3 else "")
        raise InputError(f"--out {folder} is not empty and holds no graspjax run"
                         + (f" ({shown})" if shown else "") + ": give a new or empty folder")
    holds_run = (folder / "config.json").is_file()
    if holds_run and not (resume or overwrite):
        raise InputError(f"--out {folder} already holds a run (use --resume to continue it, "
                         "--overwrite to replace it, or another folder)")
    return folder


def _linked_lock(folder: Path) -> InputError:
    """The one line for a lock file planted as a link (never opened: it could point anywhere)."""
    return InputError(f"--out {folder}: its {LOCK} is a symbolic link, which graspjax never "
                      "makes; remove it")


def _held(lock: Path) -> bool:
    """Whether another process holds `lock` (`writing`'s OS lock) right now."""
    import fcntl

    try:
        fd = os.open(lock, os.O_RDONLY | os.O_NOFOLLOW)
    except FileNotFoundError:
        return False
    except OSError:  # a link (refused by `check_output_folder`) or unreadable: not a run's
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)  # released when closed
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


@contextlib.contextmanager
def writing(folder: Path, shared: bool = False):
    """Hold the folder's lock (`LOCK`, an OS lock the OS releases if the process dies) while a
    run writes it: a second process that would write the same folder stops at once with a
    one-line error naming the first. The parts of a shared run (`--part I/N`, several hosts)
    write one folder together by design and take no lock."""
    if shared:
        yield
        return
    import fcntl

    folder.mkdir(parents=True, exist_ok=True)
    try:  # never through a link: a planted one would have a file elsewhere truncated
        fd = os.open(folder / LOCK, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    except OSError as exc:
        if (folder / LOCK).is_symlink():
            raise _linked_lock(folder) from None
        raise exc
    with open(fd, "r+") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            raise InputError(f"--out {folder} is being written by {holder}; wait for it or "
                             "give another folder") from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"process {os.getpid()} on {socket.gethostname()}\n")
        handle.flush()
        try:
            yield
        finally:  # removed while still held, so no run's folder keeps it (unless the folder
            # became read-only: the error that stopped the run is the one to tell)
            with contextlib.suppress(OSError):
                (folder / LOCK).unlink(missing_ok=True)


RUN_KEYS = ("seed", "paired", "jobs", "overrides", "grid")  # what determines a run's rows


def run_id(meta: dict) -> str:
    """A short id derived from what determines the results (`RUN_KEYS`)."""
    key = json.dumps({k: meta[k] for k in RUN_KEYS}, sort_keys=True, default=str)
    return hashlib.sha1(key.encode()).hexdigest()[:10]


def _difference(old: dict, new: dict) -> str:
    """The first setting in which two runs' `config.json` differ, in words."""
    for key in (*RUN_KEYS, "batch", "reuse"):  # reuse: the same rows, other chunks
        if old.get(key) != new.get(key):
            if isinstance(old.get(key), dict) and isinstance(new.get(key), dict):
                for k in sorted(set(old[key]) | set(new[key])):
                    if old[key].get(k) != new[key].get(k):
                        return (f"{key} {k}: {old[key].get(k, 'unset')!r} there, "
                                f"{new[key].get(k, 'unset')!r} here")
            return f"{key}: {old.get(key)!r} there, {new.get(key)!r} here"
    return f"run_id: {old.get('run_id')!r} there, {new.get('run_id')!r} here"


def read_run_config(path: Path, needed: str) -> dict:
    """A run's `config.json` (a JSON object); else one line naming it and `needed` (why)."""
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc).splitlines()[0]
        raise InputError(f"{path} cannot be read ({why}): {needed}") from None
    if not isinstance(meta, dict):
        raise InputError(f"{path} holds no run's settings (a JSON object): {needed}")
    return meta


def _csv(frame: pd.DataFrame, header: bool) -> bytes:
    return frame.to_csv(index=False, header=header, float_format="%.7g").encode()  # float32 precision


def _sorted(frame: pd.DataFrame, parsed: pd.DataFrame | None, lines: list[bytes] | None
            ) -> tuple[pd.DataFrame, bytes, pd.DataFrame]:
    """`frame` (every chunk's rows, chunk by chunk) sorted (`schema.attempt_order`), its
    `attempts.csv` and the rows as the report reads it: `lines` (the rows formatted chunk by
    chunk, one line each) and `parsed` (those lines read chunk by chunk) put in that order, or
    without them (or where a field held a line break) formatted and read afresh: the same
    bytes and frames (tested), without formatting and parsing a large run again at its end."""
    order = attempt_order(frame)
    ordered = frame.take(order).reset_index(drop=True)
    if lines is None or parsed is None or len(lines) != len(frame):
        text = _csv(ordered, True)
        return ordered, text, read_attempts_csv(text)
    text = b"".join([_csv(ordered.iloc[:0], True), *(lines[i] for i in order)])
    return ordered, text, parsed.take(order).reset_index(drop=True)


class _Kept(NamedTuple):
    """A chunk this process added, as its parts read back (`RunFolder.add`), so that `finish`
    reads only other processes' parts (a run's helpers', a distributed run's others')."""

    rows: pd.DataFrame  # its attempt rows
    text: bytes  # their CSV lines
    rounds: pd.DataFrame  # its round rows
    parsed: pd.DataFrame  # its attempt rows as the report reads them from the CSV lines
    rounds_text: bytes  # the round rows' CSV lines


class RunFolder:
    """The files of one run (module docstring), written chunk by chunk.

    A chunk is done when its part file exists (parts are written atomically),
    so several processes may share one folder, each running its own chunks
    (`--part I/N` on several hosts, `shared`: whichever finds every chunk done
    assembles the results and keeps the parts for the others; or helper
    processes of one run, `runtime.players`: the run assembles them). One process at most
    appends to `attempts.csv` (`append`): the run's own, for its chunks and its helpers'.
    """

    def __init__(self, folder: str | Path, meta: dict, chunks: int, resume: bool,
                 shared: bool = False, keep: bool = True):
        self.folder = Path(folder)
        self.parts = self.folder / "parts"
        self.chunks, self.shared = chunks, shared
        self.meta = json.loads(json.dumps(meta, default=str))  # as config.json will hold it
        self.append = not shared
        config = self.folder / "config.json"
        old = {}
        if config.is_file() and (resume or shared):
            old = read_run_config(config, "it holds no run to resume")
            if any(old.get(key) != self.meta.get(key) for key in ("run_id", "batch", "reuse")):
                raise InputError(f"--out {self.folder} holds another run "
                                 f"({_difference(old, self.meta)})")
        elif self.folder.exists():  # --overwrite: nothing of the old run may mix with this one
            remove_own_files(self.folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        # Finished: every chunk's rows assembled (`finish`), its parts gone. Committed results
        # keep attempts.csv (or .gz) alone: config.json's "finished" then says so.
        rows = [self.folder / name for name in ("attempts.parquet", "attempts.csv",
                                                "attempts.csv.gz")]
        self.finished = not self._part_files() and (rows[0].is_file() or bool(
            old.get("finished")) and any(path.is_file() for path in rows[1:]))
        self.appended: set[int] = set()  # chunks whose rows attempts.csv holds
        self.keep = keep  # False: a process that never finishes the folder keeps nothing
        self._kept: dict[int, _Kept] = {}
        # finished here: the rows as the report reads the files (`report.write_report`'s `rows`)
        self.report_rows: tuple[pd.DataFrame, pd.DataFrame] | None = None
        if not self.finished:
            self.parts.mkdir(exist_ok=True)
            write_atomic(config, (json.dumps(meta, indent=2, default=str) + "\n").encode())
            if self.append:
                self._rewrite_csv()

    def _part_files(self) -> list[Path]:
        """The parts of the chunks done (`PART_FILES`)."""
        return [p for pattern in PART_FILES for p in self.folder.glob(pattern)]

    @property
    def done(self) -> set[int]:
        """Chunks whose rows are kept."""
        if self.finished:
            return set(range(self.chunks))
        return {int(p.stem.split("-")[1]) for p in self.parts.glob("attempts-*.parquet")}

    def _rewrite_csv(self) -> None:
        """attempts.csv = the rows of the chunks done (drops an append whose chunk is not done)."""
        done = self.done
        parts = [self._part(c) for c in sorted(done)]
        text = _csv(parts[0][0].iloc[:0], True) + b"".join(t for _, t in parts) if parts else b""
        write_atomic(self.folder / "attempts.csv", text)
        self.appended = done

    def _append(self, chunk: int, frame: pd.DataFrame, text: bytes) -> None:
        """Append one chunk's rows, `frame` formatted as `text` (the header first if the file
        is empty)."""
        fd = os.open(self.folder / "attempts.csv", os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW,
                     0o644)
        with open(fd, "ab") as handle:  # never through a link (it is made by write_atomic)
            if os.fstat(fd).st_size == 0:
                handle.write(_csv(frame.iloc[:0], True))
            handle.write(text)
        self.appended.add(chunk)

    def _part(self, chunk: int) -> tuple[pd.DataFrame, bytes]:
        """A done chunk's rows and their CSV text (formatted here if its part lacks it: a
        folder of an earlier version resumed)."""
        if chunk in self._kept:
            return self._kept[chunk].rows, self._kept[chunk].text
        frame = self._read(f"attempts-{chunk:05d}.parquet", pd.read_parquet)
        text = self.parts / f"attempts-{chunk:05d}.csv"
        return frame, text.read_bytes() if text.is_file() else _csv(frame, False)

    def _read(self, name: str, reader):
        """`reader(path)` of the part file `name`; one line naming it where it cannot be read
        (parts are written whole, so only a damaged disk or a hand edits one)."""
        path = self.parts / name
        try:
            return reader(path)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path} cannot be read ({str(exc).splitlines()[0]}): remove it "
                             "and --resume plays its chunk again") from None

    def catch_up(self) -> None:
        """Append the rows of chunks done by other processes (the run's helpers) that
        attempts.csv does not hold yet."""
        if self.append and not self.finished:
            for chunk in sorted(self.done - self.appended):
                self._append(chunk, *self._part(chunk))

    def add(self, chunk: int, frame: pd.DataFrame, layouts: pd.DataFrame, timings: dict | None) -> None:
        """Keep one finished chunk: the CSV append, its timings (None: rows copied, `reuse`) and
        round rows, then its attempt rows, whose part file marks it done (written last: a chunk
        marked done is all on disk; a kill before that leaves an append `--resume` drops)."""
        buffer = io.BytesIO()
        frame.to_parquet(buffer, index=False)
        rounds = io.BytesIO()
        layouts.to_parquet(rounds, index=False)
        text = _csv(frame, header=False)
        if self.append:
            self._append(chunk, frame, text)
        write_atomic(self.parts / f"attempts-{chunk:05d}.csv", text)
        write_atomic(self.parts / f"timings-{chunk:05d}.json", json.dumps(timings).encode())
        write_atomic(self.parts / f"rounds-{chunk:05d}.parquet", rounds.getvalue())
        write_atomic(self.parts / f"attempts-{chunk:05d}.parquet", buffer.getvalue())
        if self.keep:  # read back beside the devices' next chunks, not at the run's end
            kept_rounds = pd.read_parquet(rounds)
            self._kept[chunk] = _Kept(pd.read_parquet(buffer), text, kept_rounds,
                                      read_attempts_csv(_csv(frame.iloc[:0], True) + text),
                                      _csv(kept_rounds, False))

    def _rounds_csv(self, done: list[int]) -> bytes:
        """rounds.csv: every chunk's round rows sorted by point, setup and round (stable), from
        the lines each chunk formatted when it was kept where all are alike (else afresh)."""
        kept = [self._kept.get(c) for c in done]
        frames = [k.rounds if k else self._read(f"rounds-{c:05d}.parquet", pd.read_parquet)
                  for c, k in zip(done, kept, strict=True)]
        rounds = pd.concat(frames, ignore_index=True)
        order = np.lexsort((rounds["round"], rounds["setup"], rounds["point"]))
        lines = [line for k, f in zip(kept, frames, strict=True)
                 for line in (k.rounds_text if k else _csv(f, False)).splitlines(keepends=True)]
        full = [f for f in frames if len(f)]  # empty chunks (Setup 1) format no line
        if len(lines) != len(rounds) or not all(rounds.dtypes.equals(f.dtypes) for f in full):
            return _csv(rounds.take(order), True)
        return b"".join([_csv(rounds.iloc[:0], True), *(lines[i] for i in order)])

    def finish(self, remove_parts: bool | None = None) -> list[Path]:
        """Rebuild the attempts and rounds from the parts, sorted, and write the timings; the
        parts are removed then (`remove_parts`; default: unless the folder is shared, where
        another process may still be reading them). Returns the files written, or [] while
        chunks are missing; the report then reads their rows (`report_rows`)."""
        if not self.finished:
            if len(self.done) < self.chunks:
                return []
            done = sorted(self.done)
            parts = [self._part(c) for c in done]
            frame = pd.concat([f for f, _ in parts], ignore_index=True)
            alike = all(f.dtypes.equals(parts[0][0].dtypes) for f, _ in parts)
            lines = [line for _, text in parts for line in text.splitlines(keepends=True)]
            parsed = pd.concat([self._kept[c].parsed if c in self._kept else read_attempts_csv(
                _csv(f.iloc[:0], True) + text) for c, (f, text) in zip(done, parts, strict=True)],
                ignore_index=True) if alike else None
            frame, csv, report = _sorted(frame, parsed, lines if alike else None)
            timings = pd.DataFrame([t for c in done if (t := self._read(  # null: rows copied
                f"timings-{c:05d}.json", lambda p: json.loads(p.read_text())))], columns=TIMINGS_COLUMNS)
            with concurrent.futures.ThreadPoolExecutor(1) as pool:
                parquet = pool.submit(lambda: write_atomic(  # Arrow encodes without the GIL
                    self.folder / "attempts.parquet", frame.to_parquet(index=False)))
                rounds = self._rounds_csv(done)
                write_atomic(self.folder / "attempts.csv", csv)
                write_atomic(self.folder / "rounds.csv", rounds)
                write_atomic(self.folder / "timings.csv", timings.to_csv(index=False).encode())
                parquet.result()
            meta = {**self.meta, "finished": datetime.now(UTC).isoformat(timespec="seconds")}
            write_atomic(self.folder / "config.json",
                         (json.dumps(meta, indent=2, default=str) + "\n").encode())
            if not self.shared if remove_parts is None else remove_parts:
                for path in self._part_files():  # a user's file there stays, and so does parts/
                    path.unlink()
                with contextlib.suppress(OSError):
                    self.parts.rmdir()
            self.finished = True
            self._kept.clear()
            self.report_rows = report, read_rounds_csv(io.BytesIO(rounds))
        data_files = ("attempts.csv", "attempts.csv.gz", "attempts.parquet", "rounds.csv",
                      "rounds.csv.gz", "timings.csv", "config.json")
        return [self.folder / name for name in data_files if (self.folder / name).is_file()]
