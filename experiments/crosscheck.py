"""Recorded MJX grasp attempts replayed in C MuJoCo: how often the outcome agrees.

    graspjax run --table 1 --trials 70 --seed 0 --save-views all --max-views 100000 \
        --out runs/xcheck
    python3 experiments/crosscheck.py runs/xcheck --iterations 50 \
        --csv results/crosscheck/replays_converged.csv
    python3 experiments/crosscheck.py runs/xcheck --csv results/crosscheck/replays_run_options.csv

Every attempt whose views were saved carries the world's physics state before the attempt
(`views/*.npz`, `state.*`). Each one whose grasp was found is executed again by
`graspjax.sim.replay.replay` in C MuJoCo from that state, with the recorded grasp pose, and
its outcome is compared with the MJX outcome in `attempts.csv`. Needs a run without execution
error (the paper preset): the recorded pose is then the executed one, to the 7 significant
digits `attempts.csv` keeps. Prints markdown:
agreement per setup and object with Wilson 95 % intervals, and the outcomes side by side.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from graspjax.batch.plan import Job
from graspjax.codes import Outcome
from graspjax.report import load_attempts, markdown, point_config
from graspjax.saved_views import attempt_name
from graspjax.sim import scene_for
from graspjax.sim.replay import replay
from graspjax.sim.world import GraspPose, PhysicsState
from graspjax.stats import wilson


def replays(folder: Path, iterations: int | None, quiet: bool = False) -> pd.DataFrame:
    """One row per replayed attempt: its keys, the MJX outcome and the C MuJoCo outcome."""
    meta = json.loads((folder / "config.json").read_text())
    frame = load_attempts(folder)
    frame = frame[(frame["attempt"] >= 0) & (frame["grasp_found"] == 1)]
    frame = frame[[(folder / "views" / f"{attempt_name(r)}.npz").is_file()
                   for r in frame.itertuples()]]
    scenes, rows = {}, []
    for row in tqdm(list(frame.itertuples()), disable=quiet, unit="attempt", file=sys.stderr):
        config = point_config(meta, int(row.point))
        if config.procedure.tcp_error > 0 or config.procedure.tilt_error_deg > 0:
            raise SystemExit(f"{folder}: point {row.point} has execution error; replay a run "
                             "of the paper preset (the recorded pose must be the executed one)")
        letters = next(Job(tuple(j["objects"]), tuple(j["setups"]), j["trials"]).letters
                       for j in meta["jobs"] if row.setup in j["setups"]
                       and row.object in j["objects"])  # the scene's order, as the run built it
        key = (letters, row.setup > 1, int(row.point))
        if key not in scenes:
            scenes[key] = scene_for(letters, config, row.setup > 1)
        scene = scenes[key]
        with np.load(folder / "views" / f"{attempt_name(row)}.npz") as saved:
            state = PhysicsState(**{f: saved[f"state.{f}"] for f in PhysicsState.__dataclass_fields__})
        grasp = GraspPose(tcp=np.array([row.grasp_tcp_x, row.grasp_tcp_y, row.grasp_tcp_z]),
                          approach=np.array([row.grasp_approach_x, row.grasp_approach_y,
                                             row.grasp_approach_z]),
                          closing=np.array([row.grasp_closing_x, row.grasp_closing_y,
                                            row.grasp_closing_z]), valid=True)
        outcome = replay(scene, config, state, grasp, scene.letters.index(row.object), iterations)
        rows.append({"point": row.point, "setup": row.setup, "trial": row.trial,
                     "attempt": row.attempt, "object": row.object, "mjx": row.outcome,
                     "c_mujoco": outcome.name})
    return pd.DataFrame(rows)


def _rate(k: int, n: int) -> str:
    low, high = wilson(k, n)
    return f"{100 * k / max(n, 1):.0f} % [{100 * float(low):.0f}-{100 * float(high):.0f}] of {n}"


def agreement(table: pd.DataFrame) -> str:
    """Agreement per setup and object, then the outcomes side by side (markdown)."""
    table = table.assign(agree=table["mjx"] == table["c_mujoco"],
                         success_mjx=table["mjx"] == Outcome.SUCCESS.name,
                         success_c=table["c_mujoco"] == Outcome.SUCCESS.name)
    rows = {}
    for setup, part in table.groupby("setup"):
        rows[setup] = {o: _rate(int(p["agree"].sum()), len(p))
                       for o, p in part.groupby("object")}
        rows[setup]["all"] = _rate(int(part["agree"].sum()), len(part))
        rows[setup]["success MJX / C"] = (f"{100 * part['success_mjx'].mean():.0f} / "
                                          f"{100 * part['success_c'].mean():.0f} %")
    per_setup = pd.DataFrame.from_dict(rows, orient="index").fillna("")
    per_setup = per_setup[sorted(table["object"].unique()) + ["all", "success MJX / C"]]
    lines = ["Outcome agreement per setup, MJX against C MuJoCo (share [Wilson 95 %] of the "
             "replayed attempts):", "", markdown(per_setup)]
    confusion = pd.crosstab(table["mjx"], table["c_mujoco"], margins=True, margins_name="all")
    confusion.index.name = confusion.columns.name = None
    lines += ["", "Outcomes, MJX (rows) against C MuJoCo (columns):", "", markdown(confusion)]
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a run folder with views/ (--save-views all)")
    parser.add_argument("--csv", type=Path, help="also write one row per replay here")
    parser.add_argument("--iterations", type=int,
                        help="C MuJoCo's solver and line-search iterations (default: the run's "
                             "sim.iterations and sim.ls_iterations, as MJX ran them)")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args()
    result = replays(args.run, args.iterations, args.quiet)
    if result.empty:
        raise SystemExit(f"{args.run}: no saved attempt with a grasp to replay")
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        result.to_csv(args.csv, index=False)
    print(agreement(result))
