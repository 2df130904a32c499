"""A run folder read back: attempts.csv (or .gz), rounds.csv (or .gz), config.json, and how
far the run got."""

from __future__ import annotations

import io
from pathlib import Path

import pandas as pd

from graspjax.schema import WORLD_MAJOR, attempt_order, sort_attempts

REQUIRED = ("setup", "object", "trial", "round", "seed", "success", "outcome", "reason")
NUMBERS = ("setup", "trial", "seed", "success")  # columns the report counts with


def parse_attempts(text: str, name: str = "attempts.csv") -> pd.DataFrame:
    """Attempt rows from CSV text, checking the columns the report needs, that those it counts
    with hold numbers (`success` 0 or 1), and that every row is complete (a file cut mid-row is
    refused: its last row would count as a failure)."""
    if not text.strip():
        raise ValueError(f"{name} has no attempts yet")
    if not text.endswith("\n"):
        raise ValueError(f"{name} ends in an incomplete row (still being written: try again; "
                         "cut by a kill: --resume the run to rewrite it)")
    try:
        frame = read_attempts_csv(text)
    except pd.errors.ParserError as exc:  # a row of more fields than the header: edited by hand
        raise ValueError(f"{name} is not a whole CSV table ({str(exc).splitlines()[0]})") from None
    return checked_attempts(frame, name)


def read_attempts_csv(text: str | bytes) -> pd.DataFrame:
    """Attempt rows as the report reads them from CSV text (with its header): empty fields
    missing, letters and run ids as text. A run parses each chunk's rows so as they come
    (`outputs.RunFolder`): joined, they equal the whole file read at once."""
    data = io.BytesIO(text) if isinstance(text, bytes) else io.StringIO(text)
    return pd.read_csv(data, keep_default_na=False, na_values=[""], low_memory=False,
                       dtype={"object": str, "lifted_object": str, "run_id": str})


def checked_attempts(frame: pd.DataFrame, name: str) -> pd.DataFrame:
    """`frame` (attempt rows, read from CSV or Parquet) once it has the columns the report
    needs, numbers where it counts (`success` 0 or 1) and the rows of one run; else a
    ValueError naming `name`."""
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise ValueError(f"{name} lacks columns: {', '.join(missing)}")
    if frame.empty:
        raise ValueError(f"{name} has no attempts")
    for column in NUMBERS:
        numbers = pd.to_numeric(frame[column], errors="coerce")
        bad = numbers.isna() | (~numbers.isin([0, 1]) if column == "success" else False)
        if bad.any():
            row = int(bad.to_numpy().argmax())
            value = frame[column].iloc[row]
            wanted = "0 or 1" if column == "success" else "a number"
            found = "nothing" if pd.isna(value) else repr(str(value))
            raise ValueError(f"{name}: {column} must be {wanted}, row {row + 1} has {found}")
    if "run_id" in frame.columns and frame["run_id"].nunique() > 1:
        ids = sorted(frame["run_id"].astype(str).unique())
        raise ValueError(f"{name} mixes the rows of {len(ids)} runs (run_id {', '.join(ids[:3])})")
    return frame


def load_attempts(folder: str | Path) -> pd.DataFrame:
    """Read `attempts.csv` (or a gzipped `attempts.csv.gz`, else `attempts.parquet`, the same
    rows) from a run or sweep folder; a file that is not whole gzip or not UTF-8 text, or not
    Parquet, is a ValueError naming it."""
    import gzip
    import zlib

    path = Path(folder) / "attempts.csv"
    parquet = path.with_suffix(".parquet")
    if not path.is_file() and not path.with_suffix(".csv.gz").is_file() and parquet.is_file():
        try:
            frame = pd.read_parquet(parquet)
        except Exception as exc:  # pyarrow's errors: not Parquet, cut short, damaged
            raise ValueError(f"{parquet} is not a whole Parquet file: "
                             f"{str(exc).splitlines()[0]}") from None
        frame = checked_attempts(frame, str(parquet))
        if {"point", "attempt"} <= set(frame.columns):  # kept world-major: `keep_attempts`
            frame = sort_attempts(frame)
        return frame
    if path.is_file():
        data = path.read_bytes()
    elif path.with_suffix(".csv.gz").is_file():
        path = path.with_suffix(".csv.gz")
        packed = path.read_bytes()
        try:
            data = gzip.decompress(packed)
        except (OSError, EOFError, zlib.error) as exc:  # not gzip, cut short, or damaged
            raise ValueError(f"{path} is not a whole gzip file: {exc}") from None
    else:
        raise FileNotFoundError(f"no attempts.csv in {folder}")
    try:
        text = data.decode()
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path} is not UTF-8 text (byte {exc.start}: "
                         f"{data[exc.start:exc.start + 1]!r})") from None
    return parse_attempts(text, str(path))


def keep_attempts(folder: str | Path, omit: tuple[str, ...] = ()) -> Path:
    """A finished folder's rows kept for the repository: `attempts.parquet` (zstd) in place of
    attempts.csv, each measured float column as float32 split into byte streams (the CSV's 7
    significant digits are float32's: every value reads back as the same text; tested), the
    rows world-major (a paired sweep's grid points of one attempt side by side, where they
    often repeat: a quarter to two fifths smaller again), without the columns `omit` (a
    parameter study's: `schema.STUDY_OMITS`; the report needs none of them, tested). The report
    reads it where no CSV is (`load_attempts`), in the canonical order."""
    import numpy as np

    folder = Path(folder)
    frame = load_attempts(folder)
    frame = frame.drop(columns=[c for c in omit if c in frame.columns])
    frame = frame.take(attempt_order(frame, WORLD_MAJOR))  # repeats side by side; read back
    # in the canonical order by `load_attempts`
    floats = [c for c in frame.columns  # measured values; settings (`cfg.`) stay as given
              if frame[c].dtype in (np.float32, np.float64) and not c.startswith("cfg.")]
    path = folder / "attempts.parquet"
    frame.astype(dict.fromkeys(floats, np.float32)).to_parquet(
        path, index=False, compression="zstd", compression_level=19,
        use_byte_stream_split=floats, use_dictionary=[c for c in frame.columns if c not in floats])
    for csv in (folder / "attempts.csv", folder / "attempts.csv.gz"):
        csv.unlink(missing_ok=True)
    return path


def planned_worlds(meta: dict) -> int:
    """How many worlds a run plays, from its `config.json`: per grid point and job, each object's
    trials in Setup 1 and one round per trial in Setups 2 and 3 (`batch.plan.plan`)."""
    per_point = sum(len(job["objects"]) * job["trials"] if setup == 1 else job["trials"]
                    for job in meta["jobs"] for setup in job["setups"])
    return int(meta.get("points", 1)) * per_point


def played_worlds(frame: pd.DataFrame) -> int:
    """How many worlds the rows hold: (point, setup, object, trial) in Setup 1, (point, setup,
    trial) in Setups 2 and 3."""
    point = frame["point"] if "point" in frame.columns else pd.Series(0, frame.index)
    single = frame["setup"] == 1
    object_of = frame["object"].fillna("").where(single, "")
    return len(pd.DataFrame({"p": point, "s": frame["setup"], "o": object_of,
                             "t": frame["trial"]}).drop_duplicates())


def read_meta(folder: str | Path) -> dict:
    """The folder's `config.json` ({} when it has none a run wrote)."""
    import json

    try:
        meta = json.loads((Path(folder) / "config.json").read_text())
    except (OSError, ValueError):
        return {}
    return meta if isinstance(meta, dict) else {}


def run_state(folder: str | Path, frame: pd.DataFrame) -> str:
    """"" for a finished run whose rows are all there (or rows without a run's `config.json`),
    "unfinished: n of N worlds" for a run still going or killed; a ValueError when the rows
    are not the folder's run's, or a finished run's file lacks worlds (cut)."""
    meta = read_meta(folder)
    try:
        planned = planned_worlds(meta)
    except (KeyError, TypeError, ValueError):
        return ""  # rows from elsewhere: nothing to check them against
    ids = set(frame["run_id"].astype(str).unique()) if "run_id" in frame.columns else set()
    if meta.get("run_id") and ids and ids != {str(meta["run_id"])}:
        raise ValueError(f"{folder}: attempts.csv holds rows of run {', '.join(sorted(ids))}, "
                         f"config.json describes run {meta['run_id']}")
    played = played_worlds(frame)
    if meta.get("finished") and played < planned:
        raise ValueError(f"{folder}: attempts.csv holds {played} of the run's {planned} "
                         "worlds though the run finished (the file was cut)")
    return "" if meta.get("finished") or played >= planned else \
        f"unfinished: {played} of {planned} worlds"


def load_rounds(folder: str | Path) -> pd.DataFrame | None:
    """`rounds.csv` (or a gzipped `rounds.csv.gz`, as committed results keep it) of a run
    folder (one row per Setup 2/3 round), None if it has none."""
    path = Path(folder) / "rounds.csv"
    if not path.is_file():
        path = path.with_suffix(".csv.gz")
    if not path.is_file() or not path.stat().st_size:
        return None
    return read_rounds_csv(path)


def read_rounds_csv(source) -> pd.DataFrame:
    """Round rows from a rounds.csv path or buffer, as the report reads them."""
    return pd.read_csv(source)
