"""Whether runs of the same command gave the same attempt rows: every column but the run's id
and the chunk an attempt played in, compared row by row against the first folder (NaN equals
NaN). Used to check that a change of code, or another device, leaves the rows as they were:

    python experiments/same_rows.py BEFORE AFTER [MORE...]

Prints, per folder after the first, its rows, the columns that differ (with how many rows) and
the successes of both. Exit status 1 when any folder's rows differ. Values are compared exactly:
compare fresh runs, not a fresh run with a kept reference (`report.files.keep_attempts` stores
measured floats as float32).
"""

import sys

import pandas as pd

from graspjax.report.files import load_attempts

IGNORED = ("run_id", "chunk")  # where and when, not what the attempt did


def rows(folder: str) -> pd.DataFrame:
    frame = load_attempts(folder)
    return frame.drop(columns=[c for c in IGNORED if c in frame.columns]).reset_index(drop=True)


def differing(a: pd.DataFrame, b: pd.DataFrame) -> dict[str, int]:
    """Columns of `a` whose values differ in `b` (rows in order) -> rows that differ; a column
    missing from `b` differs in every row."""
    out = {}
    for column in a.columns:
        if column not in b.columns:
            out[column] = len(a)
            continue
        x, y = a[column], b[column]
        same = (x == y) | (x.isna() & y.isna())
        if not same.all():
            out[column] = int((~same).sum())
    return out


def main(folders: list[str]) -> int:
    if len(folders) < 2:
        print("usage: python experiments/same_rows.py BEFORE AFTER [MORE...]", file=sys.stderr)
        return 2
    base = rows(folders[0])
    status = 0
    for folder in folders[1:]:
        other = rows(folder)
        diff = differing(base, other) if len(other) == len(base) else {"(row count)": len(other)}
        status |= bool(diff)
        successes = [int((f["outcome"] == "SUCCESS").sum()) for f in (base, other)]
        print(f"{folder}: {len(other)} rows against {len(base)}; "
              f"{'the same rows' if not diff else f'differing columns {diff}'}; "
              f"successes {successes[1]} against {successes[0]}")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
