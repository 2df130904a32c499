"""Which of the jaws' rules refuse the grasps a run executed, on the views it saved.

    python3 experiments/jaw_sweep_refusals.py RUN [--preset NAME]

RUN: a `graspjax run --save-views all` folder made without the sweep (`detect.jaw_sweep`
false). For each saved attempt whose grasp was executed, the jaws' check is made on the view
that found it, as `detect.jaw_sweep` would make it (`perception.jaws.sweep_placements`), and
the rules it fails (`JawRule`) are counted per object apart for the attempts that
succeeded (a refusal there refuses a grasp that held) and those that failed. The outcome is the
simulator's: it judges the check, never steers it.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd

from graspjax.camera import Camera
from graspjax.config import preset
from graspjax.perception.jaws import JawRule, sweep_placements
from graspjax.perception.support import known_support
from graspjax.saved_views import attempt_name, load


@jax.jit
def _failed(grasp, depth, camera, rotation, position, config):
    """The rules the method's chosen grasp (the first swept) fails on its view."""
    table = known_support(rotation, position, jnp.array([0.0, 0.0, 1.0]), 0.0)
    return sweep_placements(grasp, depth, camera, table, config)[2].failed[0]


def _rules(failed: int) -> str:
    return "+".join(r.name for r in JawRule if failed & r) or "passes"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run")
    parser.add_argument("--preset", default="realistic")
    args = parser.parse_args()
    config = preset(args.preset)
    rows = pd.read_csv(Path(args.run) / "attempts.csv")
    tally: dict[tuple[str, bool], Counter] = {}
    for row in rows[rows["attempt"] >= 0].itertuples():
        path = Path(args.run) / "views" / f"{attempt_name(row)}.npz"
        if not path.exists():
            continue
        saved = load(path)
        found = np.flatnonzero(np.asarray(saved.grasp.found) & saved.looked[1:])
        if not found.size:
            continue
        v = int(found[-1])  # the view whose grasp was executed
        with np.load(path) as data:
            rotation, position = data["rotation"][1 + v], data["position"][1 + v]
        fx, fy, cx, cy = saved.camera
        h, w = saved.depth.shape[1:]
        camera = Camera(int(w), int(h), float(fx), float(fy), float(cx), float(cy))
        grasp, _, _ = saved.view(v)
        failed = int(_failed(grasp, saved.depth[1 + v], camera, rotation, position, config))
        tally.setdefault((row.object, bool(row.success)), Counter())[_rules(failed)] += 1
    for (name, success), counts in sorted(tally.items()):
        total = sum(counts.values())
        print(f"{name}, {'succeeded' if success else 'failed'} ({total} executed grasps): "
              + ", ".join(f"{k} {n}" for k, n in counts.most_common()))


if __name__ == "__main__":
    main()
