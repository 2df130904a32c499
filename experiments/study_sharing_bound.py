"""How fast a paired study over `align.*` or the re-alignments could be if its grid points shared
their worlds (`results/benchmarks/README.md`, the 6-point study's row).

    python experiments/study_sharing_bound.py RUN TIMINGS [POINTS]

RUN: a Tables 1+2 run folder (its attempts); TIMINGS: a `timings.csv` of the same command on
the device that matters; POINTS: the study's grid points (default 6). Those settings act only
after a first view without a grasp, so a world plays the same at every point until its first
such view. Per part of the Tables (a-f in Setup 1, g-l in Setup 1, Setups 2 and 3), it prints
the share of worlds that reach such a view, and the study's time against the Tables' if the
other points (a) played only those worlds again, from the start, or (b) resumed each at the
attempt of its first such view, perfectly packed, every device call of a chunk (the drop and
each attempt) taking the same time.
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from graspjax.report.files import load_attempts


def main(argv: list[str]) -> int:
    if len(argv) not in (2, 3):
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    rows = load_attempts(argv[0])
    rows = rows[rows["attempt"] >= 0]  # the objects a round never attempted have no view
    timings = pd.read_csv(argv[1])
    points = int(argv[2]) if len(argv) == 3 else 6
    single = rows["setup"] == 1
    parts = {  # part: (its rows, what keys a world, attempts per world, its chunks' seconds)
        "a-f, Setup 1": (rows[single & rows["object"].isin(list("abcdef"))], ["object", "trial"],
                         1, timings[(timings.scene == "abcdef") & (timings.attempts == timings.worlds)]),
        "g-l, Setup 1": (rows[single & rows["object"].isin(list("ghijkl"))], ["object", "trial"],
                         1, timings[timings.scene == "ghijkl"]),
        "Setups 2 and 3": (rows[~single], ["setup", "round"], int(rows[~single]["attempt"].max()) + 1,
                           timings[(timings.scene == "abcdef") & (timings.attempts > timings.worlds)]),
    }
    total = replay = resume = 0.0
    for name, (part, key, attempts, chunks) in parts.items():
        no_grasp = part.assign(miss=part["first_view_grasp"] == 0)
        first = no_grasp.groupby(key)[["attempt", "miss"]].apply(
            lambda w: w["attempt"][w["miss"]].min() if w["miss"].any() else np.nan)
        share = float(first.notna().mean())
        left = float((attempts - first.dropna()).sum() / (len(first) * (attempts + 1)))
        seconds = float(chunks["wall_s"].sum())
        total += seconds
        replay += seconds * (1 + (points - 1) * share)
        resume += seconds * (1 + (points - 1) * left)
        print(f"{name}: {len(first)} worlds, {100 * share:.0f} % reach a first view without a "
              f"grasp; chunks {seconds:.1f} s")
    print(f"{points} points against the Tables: played again {replay / total:.2f}x, "
          f"resumed {resume / total:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
