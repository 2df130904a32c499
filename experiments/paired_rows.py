"""Two runs of the same worlds, attempt by attempt: how often the outcome agrees, each run's
success rate with its 95 % interval, and McNemar's z of the paired successes, per setup and
object (a speed change must not move outcomes beyond chance).

McNemar's z = (gained - lost) / sqrt(gained + lost), where `gained` are the attempts that
succeed after but not before and `lost` the reverse; |z| > 1.96 is a change beyond chance at
the 5 % level for that cell (with 24 cells, about one such cell by chance alone).

    python3 experiments/paired_rows.py BEFORE/attempts.csv AFTER/attempts.csv
"""

import math
import sys

import pandas as pd

from graspjax.stats import wilson

KEY = ["setup", "object", "trial", "attempt"]


def mcnemar_z(gained: int, lost: int) -> float:
    """McNemar's z of paired binary outcomes (0 when no pair differs)."""
    return (gained - lost) / math.sqrt(gained + lost) if gained + lost else 0.0


def main(before_csv: str, after_csv: str) -> None:
    before, after = (pd.read_csv(p).set_index(["point", *KEY]).sort_index()
                     for p in (before_csv, after_csv))
    joined = before[["success", "reason"]].add_suffix("_before").join(
        after[["success", "reason"]].add_suffix("_after"), how="inner")
    joined["same"] = joined["reason_before"] == joined["reason_after"]
    rows = []
    for (setup, obj), g in joined.groupby(level=["setup", "object"]):
        n = len(g)
        b, a = g["success_before"].sum(), g["success_after"].sum()
        gained = int((g["success_after"] & ~g["success_before"]).sum())
        lost = int((g["success_before"] & ~g["success_after"]).sum())
        rows.append({"setup": setup, "object": obj, "n": n, "outcome_agreement": g["same"].mean(),
                     "before": b / n, "before_ci": "{:.2f}-{:.2f}".format(*wilson(b, n)),
                     "after": a / n, "after_ci": "{:.2f}-{:.2f}".format(*wilson(a, n)),
                     "gained": gained, "lost": lost, "mcnemar_z": mcnemar_z(gained, lost)})
    table = pd.DataFrame(rows)
    print(table.to_string(index=False, float_format="%.3f"))
    gained = int((joined["success_after"] & ~joined["success_before"]).sum())
    lost = int((joined["success_before"] & ~joined["success_after"]).sum())
    print(f"all: {len(joined)} attempts, outcome agreement {joined['same'].mean():.3f}, success "
          f"{joined['success_before'].mean():.3f} before, {joined['success_after'].mean():.3f} "
          f"after; {gained} gained, {lost} lost, McNemar z {mcnemar_z(gained, lost):+.2f}")


if __name__ == "__main__":
    main(*sys.argv[1:])
