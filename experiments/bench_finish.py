"""Time the end of a large run (`RunFolder.finish`: the rows phase of `seconds:`) on a folder
built from a real run's rows, repeated: README's Tables 1+2 run (results/paper_cpu_10, 240
rows, its rounds) copied `--copies` times with the trials shifted, in chunks of `--chunk` rows.
Prints the time of adding the chunks and of `finish`, for each of `--repeats` fresh folders,
and with `--profile` where `finish`'s time went (cProfile, the main thread, cumulative).

    python experiments/bench_finish.py --copies 400     # 96,000 rows: 4,000 trials per cell
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from graspjax.outputs import RunFolder
from graspjax.schema import TIMINGS_COLUMNS

SOURCE = Path(__file__).resolve().parents[1] / "results" / "paper_cpu_10"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, default=400)
    parser.add_argument("--chunk", type=int, default=1000, help="rows per chunk")
    parser.add_argument("--folder", default="", help="where to build it (default: a temp folder)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--profile", action="store_true", help="profile the last finish")
    args = parser.parse_args()
    rows = pd.read_csv(SOURCE / "attempts.csv")
    rounds = pd.read_csv(SOURCE / "rounds.csv.gz")
    trials = int(rows["trial"].max()) + 1
    whole = pd.concat([rows.assign(trial=rows["trial"] + i * trials) for i in range(args.copies)],
                      ignore_index=True)
    layouts = pd.concat([rounds.assign(round=rounds["round"] + i * trials)
                         for i in range(args.copies)], ignore_index=True)
    chunks = np.array_split(np.arange(len(whole)), max(1, len(whole) // args.chunk))
    per_round = np.array_split(np.arange(len(layouts)), len(chunks))
    for repeat in range(args.repeats):
        profile = cProfile.Profile() if args.profile and repeat == args.repeats - 1 else None
        added, finished = _once(whole, layouts, chunks, per_round, args, profile)
        print(f"{len(whole)} rows, {len(layouts)} rounds, {len(chunks)} chunks: adding the chunks "
              f"{added:.2f} s ({1e3 * added / len(chunks):.1f} ms each), finish {finished:.2f} s"
              + (" (profiled)" if profile else ""))
    if args.profile:
        stats = pstats.Stats(profile)
        stats.sort_stats("cumulative").print_stats(
            r"outputs\.py|schema\.py|to_parquet|read_parquet|concat|to_csv|sort_values", 14)


def _once(whole, layouts, chunks, per_round, args, profile) -> tuple[float, float]:
    """Seconds to add every chunk to a fresh folder, and to finish it."""
    with tempfile.TemporaryDirectory(dir=args.folder or None) as folder:
        run = RunFolder(folder, {"run_id": "bench", "batch": args.chunk}, chunks=len(chunks),
                        resume=False)
        start = time.perf_counter()
        for c, (index, layout) in enumerate(zip(chunks, per_round, strict=True)):
            run.add(c, whole.iloc[index].reset_index(drop=True),
                    layouts.iloc[layout].reset_index(drop=True), dict.fromkeys(TIMINGS_COLUMNS, 0))
        added = time.perf_counter() - start
        start = time.perf_counter()
        if profile:
            profile.runcall(run.finish)
        else:
            run.finish()
        return added, time.perf_counter() - start


if __name__ == "__main__":
    main()
