"""The host's work of `graspjax sweep --reuse` at Tables 1+2's size: RUN's rows read, the worlds
to play again found, and every grid point's copied rows kept in a run folder (`reuse.Reused`).

    python3 experiments/reuse_copy_time.py [RUN]

RUN: a finished Tables 1+2 run (default results/paper_gpu_1000, the paper preset at 1,000
trials per cell); the grid is the window study's six points (align.window_px 5-30). No device
runs: this is the time the run spends on the copies, made while its devices play.
"""

import json
import sys
import tempfile
import time

from graspjax.batch.rows import RunColumns
from graspjax.config import override, preset, run_settings
from graspjax.outputs import RunFolder
from graspjax.report.files import load_attempts, load_rounds
from graspjax.reuse import Reused, worlds_to_play_again


def main(source: str = "results/paper_gpu_1000") -> None:
    start = time.perf_counter()
    base = preset(json.load(open(f"{source}/config.json"))["preset"])
    attempts, rounds = load_attempts(source), load_rounds(source)
    reused = Reused("run", json.loads(json.dumps(run_settings(base), default=str)), attempts,
                    rounds, worlds_to_play_again(attempts, base))
    loaded = time.perf_counter()
    configs = [override(base, {"align.window_px": str(w)}) for w in (5, 10, 15, 20, 25, 30)]
    columns = RunColumns("study", configs, ["align.window_px"], base)
    points = reused.copied_points(configs)
    meta = {k: v for k, v in json.load(open(f"{source}/config.json")).items() if k != "finished"}
    rows = 0
    with tempfile.TemporaryDirectory() as folder:
        run = RunFolder(folder, meta, len(points), resume=False)
        copying = time.perf_counter()
        for index, point in enumerate(points):
            frame, round_rows = reused.rows(point, columns, index)
            run.add(index, frame, round_rows, None)
            rows += len(frame)
        done = time.perf_counter()
    print(f"RUN read and its worlds to play again found: {loaded - start:.2f} s "
          f"({len(reused.played_again)} of {reused.worlds} worlds play again); "
          f"{len(points)} points' copies, {rows:,} rows kept: {done - copying:.2f} s")


if __name__ == "__main__":
    main(*sys.argv[1:])
