"""Which objects move while Setup 3's pile settles, and which widen it (layouts alone, no
grasping, no success looked at): the data behind the unmet spread bound of `docs/simulation.md`.

    python3 experiments/setup3_scatter.py ROUNDS OUT.csv [KEY=VALUE ...]

Places and settles ROUNDS Setup 3 rounds of a-f (seed 0, rounds 0..ROUNDS-1, as a run does:
`setup3_layouts.settle_chunks`) and writes one row per object and round: where its
origin was dropped (seen from above), where it settled, the settle segment it was dropped
before (`pile.Drops.segment`), and whether it rests on
another or touches one. Prints, over the rounds whose spread grew by more than 1 cm, which
object moved the most and when it was dropped. KEY=VALUE are `--set` overrides.
"""

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from graspjax.config import Config, override
from graspjax.sim.bodies import snapshot
from graspjax.sim.clutter import object_clutter

sys.path.insert(0, str(Path(__file__).parent))
from setup3_layouts import settle_chunks  # noqa: E402

LETTERS = "abcdef"


def _objects(scene, state, data):
    crowd = object_clutter(scene, data)
    return (state.drops.xy, state.drops.segment, snapshot(scene, data).object_pos[:, :2],
            crowd.resting, crowd.touching)


def settled_objects(rounds: int, config: Config, seed: int = 0) -> pd.DataFrame:
    """One row per object and round: dropped and settled positions, drop segment, clutter."""
    n = len(LETTERS)
    frames = []
    for trials, (dropped, segment, settled, resting, touching) in settle_chunks(
            rounds, config, _objects, seed):
        frames.append(pd.DataFrame({
            "round": np.repeat(trials, n), "object": np.tile(list(LETTERS), len(trials)),
            "drop_segment": segment.ravel(), "dropped_x": dropped[..., 0].ravel(),
            "dropped_y": dropped[..., 1].ravel(), "settled_x": settled[..., 0].ravel(),
            "settled_y": settled[..., 1].ravel(), "resting": resting.ravel(),
            "touching": touching.ravel()}))
    frame = pd.concat(frames, ignore_index=True)
    frame["moved_m"] = np.hypot(frame.settled_x - frame.dropped_x, frame.settled_y - frame.dropped_y)
    return frame


def _spread(x: np.ndarray, y: np.ndarray) -> float:
    points = np.stack([x, y], -1)
    return float(np.max(np.linalg.norm(points[:, None] - points[None], axis=-1)))


def summary(frame: pd.DataFrame) -> str:
    """Which object moved most in the rounds that widened, against all rounds."""
    per_round = frame.groupby("round").apply(lambda g: pd.Series({
        "grew": _spread(g.settled_x.to_numpy(), g.settled_y.to_numpy())
        - _spread(g.dropped_x.to_numpy(), g.dropped_y.to_numpy()) > 0.01,
        "object": g.object.loc[g.moved_m.idxmax()],
        "segment": g.drop_segment.loc[g.moved_m.idxmax()]}))
    grew = per_round[per_round.grew.astype(bool)]
    segments = sorted(frame.drop_segment.unique())
    return "\n".join([
        f"{len(per_round)} rounds, {len(grew)} whose spread grew by more than 1 cm",
        "moved while settling, mean (cm): " + ", ".join(
            f"{k} {100 * v:.1f}" for k, v in frame.groupby("object").moved_m.mean().items()),
        "the object that moved most, rounds that grew: " + ", ".join(
            f"{k} {v}" for k, v in grew.object.value_counts().sort_index().items()),
        "the settle segment it was dropped before (0.1 s each), rounds that grew: " + ", ".join(
            f"{s}: {int((grew.segment == s).sum())}" for s in segments),
        "the same, all rounds: " + ", ".join(
            f"{s}: {int((per_round.segment == s).sum())}" for s in segments)])


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    rounds, out = int(sys.argv[1]), sys.argv[2]
    objects = settled_objects(rounds, override(Config(), sys.argv[3:]))
    objects.to_csv(out, index=False)
    print(summary(objects))
