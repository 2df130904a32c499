"""The grid points of one paired sweep against a reference point, per table column: success,
first view and rescued for each point, and the paired change in success (points), the
objects gained and lost, and McNemar's z over the objects' outcomes (each object of a trial
or round, as the tables count it: `report.object_outcomes`). |z| > 1.96: a change beyond
chance at the 5 % level.

Columns: Setup 1 a-f, Setup 2, Setup 3, Setup 1 g-l (Tables 1+2), those the sweep played.

    python3 experiments/paired_points.py SWEEP_FOLDER [REFERENCE_POINT]
    python3 experiments/paired_points.py RUN_FOLDER OTHER_RUN_FOLDER ...

Two or more run folders of the same worlds (the same seed, trials and batch) are read as the
points of one sweep, the first the reference, each named by its folder.
"""

import sys
from pathlib import Path

import pandas as pd

from graspjax.report import load_attempts, object_outcomes
from graspjax.stats import paired_changes

COLUMNS = {"S1 a-f": (1, "abcdef"), "S2": (2, "abcdef"), "S3": (3, "abcdef"), "S1 g-l": (1, "ghijkl")}


def column_frames(frame: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """The table columns' object outcomes, indexed by (point, trial, object)."""
    out = {}
    for name, (setup, letters) in COLUMNS.items():
        part = frame[(frame.setup == setup) & frame.object.isin(list(letters))]
        if len(part):
            out[name] = part.set_index(["point", "trial", "object"]).sort_index()
    return out


def load(folders: list[str]) -> pd.DataFrame:
    """One sweep's attempts, or several runs' as the points of one (a `cfg.run` column names
    each run's folder)."""
    if len(folders) == 1:
        return load_attempts(folders[0])
    return pd.concat([load_attempts(f).assign(point=i, **{"cfg.run": Path(f).name})
                      for i, f in enumerate(folders)], ignore_index=True)


def main(folders: list[str], reference: int = 0) -> None:
    frame = object_outcomes(load(folders))
    frame["success"] = frame["success"].astype(bool)
    frame["rescued"] = frame["rescued"].astype(bool)
    columns = column_frames(frame)
    varying = [c for c in frame.columns if c.startswith("cfg.") and frame[c].nunique() > 1]
    labels = frame.groupby("point")[varying].first() if varying else None
    print("| point | " + " | ".join(f"{c}: success (first + rescued); change, z" for c in columns) + " |")
    print("|---|" + "---|" * len(columns))
    for point in sorted(frame.point.unique()):
        name = (", ".join(f"{k[4:]}={v}" for k, v in labels.loc[point].items())
                if labels is not None else str(point))
        cells = []
        for part in columns.values():
            mine, base = part.loc[point], part.loc[reference]
            mine, base = mine.align(base, join="inner", axis=0)
            rate = 100 * mine.success.mean()
            rescued = 100 * (mine.success & mine.rescued).mean()
            cell = f"{rate:.1f} % ({rate - rescued:.1f} + {rescued:.1f})"
            if point != reference:
                gained, lost, z = paired_changes(base.success, mine.success)
                cell += (f"; {rate - 100 * base.success.mean():+.1f} "
                         f"({gained} gained / {lost} lost), z {z:+.1f}")
            cells.append(cell)
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    args = sys.argv[1:]
    if len(args) == 2 and args[1].isdigit():
        main(args[:1], int(args[1]))
    else:
        main(args)
