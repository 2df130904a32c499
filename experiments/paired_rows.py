"""Two runs of the same worlds, attempt by attempt: how often the outcome agrees, and each
run's success rate with its 95 % interval, per setup and object (a speed change must not move
outcomes beyond chance).

    python3 experiments/paired_rows.py BEFORE/attempts.csv AFTER/attempts.csv
"""

import sys

import pandas as pd

from graspjax.stats import wilson

KEY = ["setup", "object", "trial", "attempt"]


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
        rows.append({"setup": setup, "object": obj, "n": n, "outcome_agreement": g["same"].mean(),
                     "before": b / n, "before_ci": "{:.2f}-{:.2f}".format(*wilson(b, n)),
                     "after": a / n, "after_ci": "{:.2f}-{:.2f}".format(*wilson(a, n))})
    table = pd.DataFrame(rows)
    print(table.to_string(index=False, float_format="%.3f"))
    print(f"all: {len(joined)} attempts, outcome agreement {joined['same'].mean():.3f}, success "
          f"{joined['success_before'].mean():.3f} before, {joined['success_after'].mean():.3f} "
          "after")


if __name__ == "__main__":
    main(*sys.argv[1:])
