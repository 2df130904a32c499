"""Success against clutter in Setup 3, from a paired density sweep's files alone.

    python3 experiments/setup3_density.py SWEEP_FOLDER [REFERENCE_POINT]

The sweep (`experiments/references.sh density`) plays the same Setup 3 rounds at every grid point,
only the pile's density changing. Writes into the folder:

- `density.md`: per point its settings, its measured clutter (`rounds.csv`), its success (first
  view + rescued) with a 95 % Wilson interval, the paired change against the reference point
  (McNemar's z over the objects' outcomes), and how probable the paper's own run-level facts
  are at that density (`report.density.consistency`: a check, never a choice);
- `density.png`: success against the measured clutter of each round (objects near another,
  objects resting on another) and of each attempt's target when the robot looked (touching,
  resting on another, covered, its nearest outline gap) and against the free space around the
  open fingers at the grasp.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from graspjax.figures import png  # noqa: E402
from graspjax.report import load_attempts, load_rounds, markdown, object_outcomes  # noqa: E402
from graspjax.report.density import consistency  # noqa: E402
from graspjax.stats import paired_changes, wilson  # noqa: E402


def _rate(success: pd.Series) -> tuple[float, float, float, int]:
    k, n = int(success.sum()), len(success)
    low, high = wilson(k, n)
    return k / max(n, 1), float(low), float(high), n


def point_table(outcomes: pd.DataFrame, rounds: pd.DataFrame, reference: int) -> pd.DataFrame:
    """One row per grid point: settings, clutter, success, paired change, consistency."""
    settings = [c for c in outcomes.columns if c.startswith("cfg.") and outcomes[c].nunique() > 1]
    base = outcomes[outcomes.point == reference].set_index(["trial", "object"]).success.astype(bool)
    rows = []
    for point, part in outcomes.groupby("point"):
        layout = rounds[rounds.point == point]
        rate, low, high, n = _rate(part.success.astype(bool))
        here = part.set_index(["trial", "object"]).success.astype(bool)
        shared = here.index.intersection(base.index)
        gained, lost, z = paired_changes(base.loc[shared], here.loc[shared])
        row = {c.removeprefix("cfg."): part[c].iloc[0] for c in settings}
        row |= {"rounds": len(layout), "near": layout.near_fraction.mean(),
                "touching": layout.touching_fraction.mean(), "stacked": layout.stacked.mean(),
                "gap_mm": 1000 * layout.min_face_gap_m.mean(), "spread_cm": 100 * layout.spread_m.mean(),
                "success": rate, "ci": f"{100 * low:.1f}-{100 * high:.1f}",
                "first_view": (part.success.astype(bool) & ~part.rescued.astype(bool)).mean(),
                "rescued": part.rescued.astype(bool).mean(), "objects": n,
                "change": rate - base.mean(), "gained": gained, "lost": lost, "z": z}
        row |= consistency(part, setup=3) | {"rounds": len(layout)}
        rows.append(row)
    return pd.DataFrame(rows)


_MIN_BIN = 20  # bins with fewer attempts are left out of the figure


def _binned(ax, x, success, edges, labels, title):
    """Success with Wilson intervals in bins of x."""
    which = np.digitize(x, edges)
    rates, lows, highs, counts = [], [], [], []
    kept = [b for b in range(len(labels)) if np.sum(which == b) >= _MIN_BIN]
    for b in kept:
        rate, low, high, n = _rate(pd.Series(success[which == b]))
        rates.append(rate), lows.append(low), highs.append(high), counts.append(n)
    rates, lows, highs = map(np.asarray, (rates, lows, highs))
    labels = [labels[b] for b in kept]
    pos = np.arange(len(labels))
    ax.errorbar(pos, 100 * rates, yerr=100 * np.stack([rates - lows, highs - rates]), fmt="o",
                capsize=3, color="C0")
    for p, r, n in zip(pos, rates, counts, strict=True):
        ax.annotate(f"n={n}", (p, 100 * r), textcoords="offset points", xytext=(4, -12), fontsize=7)
    ax.set_xticks(pos, labels, fontsize=8)
    ax.set_ylim(0, 105)
    ax.set_title(title, fontsize=9)
    ax.grid(axis="y", alpha=0.3)


def _points(ax, table: pd.DataFrame, reference: int):
    """Each grid point's success and first view (95 % Wilson), in grid order, each labelled by
    its settings and its settled clutter; the reference point marked (in
    `references.sh density`'s sweep, point 0: the paper preset's reading). Points, not a
    line: the grid points are settings, not a continuous axis."""
    pos = np.arange(len(table))
    for shift, (column, label, color) in zip((-0.08, 0.08), (
            ("success", "success", "C0"), ("first_view", "first view", "C1")), strict=True):
        rate = table[column].to_numpy()
        low, high = np.transpose([wilson(round(r * n), n) for r, n in zip(rate, table.objects,
                                                                            strict=True)])
        ax.errorbar(pos + shift, 100 * rate, yerr=100 * np.stack([rate - low, high - rate]),
                    fmt="o", capsize=3, color=color, label=label)
    settings = list(table.columns[:list(table.columns).index("rounds")])
    labels = ["\n".join([*(f"{key.split('.')[-1]}={row[key]:g}" for key in settings),
                          f"{100 * row.touching:.0f} % touch"]) for _, row in table.iterrows()]
    ax.set_xticks(pos, labels, fontsize=6)
    ax.get_xticklabels()[reference].set_fontweight("bold")
    ax.axvspan(reference - 0.4, reference + 0.4, color="tab:orange", alpha=0.2, lw=0, zorder=0,
               label="the reference point (density.md's changes are against it)")
    ax.set_title("each grid point (its settings; settled contact)", fontsize=9)
    ax.set_ylabel("success (%)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.32), ncol=3, frameon=False)
    ax.grid(axis="y", alpha=0.3)


def figure(attempts: pd.DataFrame, outcomes: pd.DataFrame, rounds: pd.DataFrame,
           table: pd.DataFrame, reference: int, path: Path):
    tried = attempts[(attempts.attempt >= 0) & (attempts.object.fillna("") != "")]
    success = tried.success.astype(bool).to_numpy()
    points = max(1.8, 0.5 * len(table))  # the first panel's width: room for each point's label
    fig, axes = plt.subplots(1, 6, figsize=(20.4 + 2 * points, 4.2), dpi=130,
                             gridspec_kw={"width_ratios": [points, 1, 1, 1, 1, 1.2]})
    _points(axes[0], table, reference)
    axes = axes[1:]
    per_round = outcomes.merge(rounds[["point", "round", "near_fraction", "stacked"]].rename(
        columns={"round": "trial"}), on=["point", "trial"], how="left")
    round_success = per_round.success.astype(bool).to_numpy()
    _binned(axes[0], per_round.near_fraction.to_numpy(), round_success,
            [0.45, 0.75, 0.9], ["0-2 of 6", "3-4 of 6", "5 of 6", "all 6"],
            "objects of the round near another (settled)")
    _binned(axes[1], per_round.stacked.to_numpy(), round_success, [0.5, 1.5, 2.5],
            ["none", "1", "2", "3 or more"], "objects of the round resting on another (settled)")
    state = np.select([tried.target_covered == 1, tried.target_resting == 1,
                       tried.target_touching == 1], [0, 1, 2], 3)
    _binned(axes[2], state, success, [0.5, 1.5, 2.5], ["covered", "on another", "touching",
                                                       "apart"], "the target when the robot looked")
    gap = 100 * tried.target_gap_m.to_numpy()
    _binned(axes[3], gap, success, [-1.0, -0.01, 0.5, 2.0], ["< -1", "-1 to 0", "0-0.5", "0.5-2",
                                                             "> 2"],
            "the target's nearest outline gap (cm; below 0: overlapping)")
    room = 100 * tried.finger_clearance_m.to_numpy()
    executed = np.isfinite(room)
    _binned(axes[4], room[executed], success[executed], [0.0, 0.5, 1.0, 2.0],
            ["touch", "0-0.5", "0.5-1", "1-2", "> 2"], "free space at the fingers (cm, executed)")
    axes[0].set_ylabel("success (%)")
    fig.suptitle("Setup 3: success against clutter, each density point (left) and every point's "
                 "rounds and attempts pooled (right; bins of 20 or more); 95 % Wilson intervals",
                 fontsize=10)
    path.write_bytes(png(fig))  # laid out tightly, as every figure of the report
    plt.close(fig)


def main(folder: str, reference: int = 0) -> None:
    attempts = load_attempts(folder)
    attempts = attempts[attempts.setup == 3]
    outcomes = object_outcomes(attempts)
    rounds = load_rounds(folder)
    rounds = rounds[rounds.setup == 3]
    table = point_table(outcomes, rounds, reference)
    text = ["# Setup 3 against its density (paired)", "",
            f"Made by `python3 experiments/setup3_density.py {folder}` from the sweep's files. "
            f"Change, gained, lost and z against point {reference} (McNemar's z over the "
            "objects' outcomes). The last columns: how probable the paper's Setup 3 facts are at "
            "each density (all 10 runs with 2 or more failures; every Table 1 cell of 10 trials "
            "within 50-70 %), from our rates; a consistency check, never a choice.", "",
            markdown(table.map(lambda v: f"{v:.3g}" if isinstance(v, float) else v), index=False)]
    (Path(folder) / "density.md").write_text("\n".join(text) + "\n")
    figure(attempts, outcomes, rounds, table, reference, Path(folder) / "density.png")
    print("\n".join(text))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 0)
