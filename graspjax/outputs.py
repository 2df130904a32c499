"""Files of a run: one row per attempt (CSV and Parquet), timings, configuration, report.

`attempts.csv` is deterministic: the same command with the same seed on the
same device writes the same bytes. Wall-clock times therefore live in
`timings.csv` (one row per batch of worlds, by phase); every attempt row
names its batch in the `chunk` column.
"""

from __future__ import annotations

import hashlib
import io
import json
import platform
import sys
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

import pandas as pd

from graspjax.config import Config, differences, flatten
from graspjax.io import InputError, write_atomic

FIRST_COLUMNS = ["run_id", "setup", "object", "trial", "round", "attempt", "seed", "success",
                 "outcome", "reason", "reorientations", "lifted_object"]


def check_output_folder(folder: str | Path) -> Path:
    """Fail early (one line) if results cannot be written to `folder`; creates nothing."""
    import tempfile

    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--out {folder} exists and is not a directory")
    probe = folder if folder.exists() else folder.parent
    if not probe.is_dir():
        raise InputError(f"--out {folder}: {probe} is not an existing directory")
    try:
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError:
        raise InputError(f"--out {folder}: {probe} is not writable") from None
    return folder


def run_id(meta: dict) -> str:
    """A short id derived from what determines the results (seed, jobs, configuration)."""
    key = json.dumps({k: meta[k] for k in ("seed", "jobs", "overrides")}, sort_keys=True,
                     default=str)
    return hashlib.sha1(key.encode()).hexdigest()[:10]


def attempts_frame(rows: list[dict], config: Config, keys: list[str], rid: str) -> pd.DataFrame:
    """Rows -> DataFrame with `cfg.<key>` columns for `keys` and every non-default value."""
    frame = pd.DataFrame(rows)
    frame.insert(0, "run_id", rid)
    values = flatten(config)
    for key in [*keys, *sorted(set(differences(config, Config())) - set(keys))]:
        frame[f"cfg.{key}"] = values[key]
    frame["attempt_order"] = frame["attempt"].where(frame["attempt"] >= 0, 99)
    frame = frame.sort_values(["setup", "round", "attempt_order", "object"], kind="stable")
    frame = frame.drop(columns="attempt_order")
    rest = [c for c in frame.columns if c not in FIRST_COLUMNS]
    return frame[FIRST_COLUMNS + rest].reset_index(drop=True)


def environment() -> dict:
    """Package versions, device and command line, for config.json."""
    import jax

    versions = {}
    for name in ("graspjax", "jax", "jaxlib", "mujoco", "mujoco-mjx", "numpy", "pandas"):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    device = jax.devices()[0]
    return {"versions": versions, "python": platform.python_version(),
            "device": {"platform": device.platform,
                       "kind": getattr(device, "device_kind", str(device)),
                       "count": jax.device_count()},
            "command": " ".join(["graspjax", *sys.argv[1:]]),
            "finished": datetime.now(UTC).isoformat(timespec="seconds")}


def write_run(folder: str | Path, frame: pd.DataFrame, timings: list[dict], meta: dict,
              config: Config) -> list[Path]:
    """Write attempts (CSV, Parquet), timings, config.json and the report into `folder`."""
    from graspjax.report import build, parse_attempts

    folder = Path(folder)
    parquet = io.BytesIO()
    frame.to_parquet(parquet, index=False)
    csv_text = frame.to_csv(index=False, float_format="%.7g")  # float32 precision
    meta = {**meta, "config": flatten(config), **environment()}
    data_files = {
        "attempts.csv": csv_text.encode(),
        "attempts.parquet": parquet.getvalue(),
        "timings.csv": pd.DataFrame(timings).to_csv(index=False).encode(),
        "config.json": (json.dumps(meta, indent=2, default=str) + "\n").encode(),
    }
    folder.mkdir(parents=True, exist_ok=True)
    for name, data in data_files.items():  # the results first: a report can be rebuilt
        write_atomic(folder / name, data)
    report = build(parse_attempts(csv_text))  # exactly what `graspjax report` rebuilds
    for name, data in report.items():
        write_atomic(folder / name, data)
    return [folder / name for name in (*data_files, *report)]
