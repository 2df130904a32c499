"""Two runs of the same worlds, attempt by attempt: how often the outcome agrees, each run's
success rate with its 95 % interval, and McNemar's z of the paired successes, per setup and
object; per setup also the successes with the first view's grasp and the rescued ones (a speed
change must not move outcomes beyond chance).

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


def changes(before: pd.Series, after: pd.Series) -> tuple[int, int, float]:
    """Paired bool outcomes: (gained, lost, McNemar's z)."""
    gained, lost = int((after & ~before).sum()), int((before & ~after).sum())
    return gained, lost, mcnemar_z(gained, lost)


def main(before_csv: str, after_csv: str) -> None:
    columns = ["success", "rescued", "reason"]
    before, after = (pd.read_csv(p).set_index(["point", *KEY]).sort_index()[columns]
                     for p in (before_csv, after_csv))
    joined = before.add_suffix("_before").join(after.add_suffix("_after"), how="inner")
    for side in ("before", "after"):  # a success with the first view's grasp
        joined[f"first_view_{side}"] = (joined[f"success_{side}"].astype(bool)
                                        & ~joined[f"rescued_{side}"].astype(bool))
    for column in ("success", "rescued"):
        for side in ("before", "after"):
            joined[f"{column}_{side}"] = joined[f"{column}_{side}"].astype(bool)
    joined["same"] = joined["reason_before"] == joined["reason_after"]
    rows = []
    for (setup, obj), g in joined.groupby(level=["setup", "object"]):
        n = len(g)
        b, a = g["success_before"].sum(), g["success_after"].sum()
        gained, lost, z = changes(g["success_before"], g["success_after"])
        rows.append({"setup": setup, "object": obj, "n": n, "outcome_agreement": g["same"].mean(),
                     "before": b / n, "before_ci": "{:.2f}-{:.2f}".format(*wilson(b, n)),
                     "after": a / n, "after_ci": "{:.2f}-{:.2f}".format(*wilson(a, n)),
                     "gained": gained, "lost": lost, "mcnemar_z": z})
    table = pd.DataFrame(rows)
    print(table.to_string(index=False, float_format="%.3f"))
    for setup, g in joined.groupby(level="setup"):
        parts = []
        for what in ("success", "first_view", "rescued"):
            gained, lost, z = changes(g[f"{what}_before"], g[f"{what}_after"])
            parts.append(f"{what} {g[f'{what}_before'].mean():.3f} -> "
                         f"{g[f'{what}_after'].mean():.3f} (z {z:+.2f})")
        print(f"setup {setup}, {len(g)} paired attempts: " + ", ".join(parts))
    gained, lost, z = changes(joined["success_before"], joined["success_after"])
    print(f"all: {len(joined)} attempts, outcome agreement {joined['same'].mean():.3f}, success "
          f"{joined['success_before'].mean():.3f} before, {joined['success_after'].mean():.3f} "
          f"after; {gained} gained, {lost} lost, McNemar z {z:+.2f}")

if __name__ == "__main__":
    main(*sys.argv[1:])
