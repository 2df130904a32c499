"""Paired comparisons from rows alone (`graspjax report --compare`): several runs of the same
worlds, or the grid points of one paired sweep, against the first.

Each object of a trial or round counts once, as the paper's tables count it
(`tables.object_outcomes`); an object pairs with the same object of the same trial or round at
the reference. Per column of the tables (Setup 1 a-f, Setups 2 and 3, Setup 1 g-l: those the
rows hold; other objects in a column of their own per setup): success, first view + rescued,
and against the reference the paired change in points, the objects gained and lost,
McNemar's z and exact p (`stats`), and the smallest change the pairs could resolve (5 %
two-sided, 80 % power). |z| > 1.96: a change beyond chance at the 5 % level. In Setups 2 and 3
a round's later objects pair only as well as its pile: an earlier outcome changes the scene.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from graspjax.report.files import load_attempts, read_meta
from graspjax.report.tables import object_outcomes, point_labels, varying_config
from graspjax.stats import mcnemar_p, paired_changes, paired_detectable

TABLE_COLUMNS = (("Setup 1, a-f", 1, "abcdef"), ("Setup 2", 2, "abcdef"), ("Setup 3", 3, "abcdef"),
                 ("Setup 1, g-l", 1, "ghijkl"))  # the paper's Tables 1 and 2, by column


def compared_rows(folders: list[str | Path]) -> tuple[pd.DataFrame, list[str]]:
    """The attempt rows of the compared points and each point's name: one folder is a paired
    sweep (its grid points, named by their values); several are runs of one point each, read
    as the points of one sweep in the order given (named by their folders). A ValueError (one
    line) where they do not play the same worlds."""
    if len(folders) == 1:
        folder = Path(folders[0])
        frame, meta = load_attempts(folder), read_meta(folder)
        points = sorted(frame["point"].unique()) if "point" in frame.columns else [0]
        if len(points) < 2:
            raise ValueError(f"{folder} holds one grid point: give the runs to compare with it "
                             f"(--compare {folder} OTHER ...)")
        if meta.get("paired") is False:
            raise ValueError(f"{folder} is an unpaired sweep: its points play other worlds "
                             "(sweep with --paired to compare them)")
        labels = point_labels(frame.groupby("point")[varying_config(frame)].first())
        return frame, [labels.get(p) or str(p) for p in points]
    frames, names, seeds = [], [], {}
    for i, folder in enumerate(map(Path, folders)):
        frame = load_attempts(folder)
        if "point" in frame.columns and frame["point"].nunique() > 1:
            raise ValueError(f"{folder} is a sweep of {frame['point'].nunique()} points: compare "
                             f"its points with --compare {folder} alone")
        seed = read_meta(folder).get("seed")
        if seed is not None:
            seeds[folder] = seed
        frames.append(frame.assign(point=i, **{"cfg.run": folder.name}))
        names.append(folder.name)
    if len(set(seeds.values())) > 1:
        shown = ", ".join(f"{f}: {s}" for f, s in seeds.items())
        raise ValueError(f"the runs play other worlds (seeds {shown}): a paired comparison "
                         "needs the same seed")
    return pd.concat(frames, ignore_index=True), names


def _columns(outcomes: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """The table columns the rows hold, then each setup's other objects."""
    columns, covered = [], pd.Series(False, outcomes.index)
    for name, setup, letters in TABLE_COLUMNS:
        part = (outcomes["setup"] == setup) & outcomes["object"].isin(list(letters))
        covered |= part
        if part.any():
            columns.append((name, outcomes[part]))
    for setup in sorted(outcomes.loc[~covered, "setup"].unique()):
        columns.append((f"Setup {setup}, others", outcomes[~covered & (outcomes["setup"] == setup)]))
    return columns


def _cell(mine: pd.DataFrame, base: pd.DataFrame | None) -> str:
    """One point's column: success (first view + rescued); against the reference (`base`,
    None for the reference itself) the change, gained / lost, z, p and the resolvable change."""
    rate = 100 * mine["success"].mean()
    rescued = 100 * (mine["success"] & mine["rescued"]).mean()
    cell = f"{rate:.1f} % ({rate - rescued:.1f} + {rescued:.1f})"
    if base is None:
        return cell
    pairs = pd.concat([mine["success"], base["success"]], axis=1, join="inner",
                      keys=["here", "base"])
    gained, lost, z = paired_changes(pairs["base"], pairs["here"])
    change = 100 * (pairs["here"].mean() - pairs["base"].mean())
    resolvable = 100 * paired_detectable(gained + lost, len(pairs))
    return (f"{cell}; {change:+.1f} ({gained} gained / {lost} lost of {len(pairs)}), z {z:+.1f}, "
            f"p {_p(mcnemar_p(gained, lost))}, resolves {resolvable:.1f}")


def _p(p: float) -> str:
    return f"{p:.2g}" if p > 0 else "< 1e-300"  # below what a float holds


def comparison_table(frame: pd.DataFrame, names: list[str]) -> str:
    """The markdown table of `compared_rows`' rows: one line per point, the first the
    reference (module docstring)."""
    outcomes = object_outcomes(frame.drop(columns=varying_config(frame)))
    outcomes = outcomes.assign(success=outcomes["success"].astype(bool),
                               rescued=outcomes["rescued"].astype(bool))
    points = sorted(outcomes["point"].unique())
    columns = [(name, part.set_index(["point", "setup", "trial", "object"]).sort_index())
               for name, part in _columns(outcomes)]
    lines = ["| point | " + " | ".join(f"{name}: success (first view + rescued); change, "
                                      "gained / lost, McNemar" for name, _ in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for point, name in zip(points, names, strict=True):
        cells = []
        for _, part in columns:
            mine = part.xs(point, level="point") if point in part.index.levels[0] else None
            base = part.xs(points[0], level="point") if points[0] in part.index.levels[0] else None
            cells.append("-" if mine is None else _cell(mine, None if point == points[0] else base))
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
