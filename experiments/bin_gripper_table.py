"""Setup 3 over bin size x gripper, from the two sweeps' files alone (experiments/bin_gripper_gpu.sh).

    python3 experiments/bin_gripper_table.py results/target_labels/studies/bin_gripper_small \
        results/target_labels/studies/bin_gripper_franka

Per grid point: success with its Wilson 95 % interval, the share of attempts that end in
NO_ROOM and TOO_WIDE, the rescued share, and the layouts' density from rounds.csv (objects
touching another, objects resting on another per round).
"""

from __future__ import annotations

import sys

import pandas as pd

from graspjax.report import load_attempts, load_rounds, markdown
from graspjax.stats import wilson

FOOTPRINT = 0.0167  # total footprint of a-f (m^2): the 0.18 m bin's floor is 1.94 times it


def rows(folder: str) -> list[dict]:
    attempts = load_attempts(folder)
    attempts = attempts[attempts["attempt"] >= 0]
    rounds = load_rounds(folder)
    out = []
    for point, part in attempts.groupby("point"):
        layout = rounds[rounds["point"] == point]
        low, high = wilson(int(part["success"].sum()), len(part))
        size = float(part["cfg.layout.bin_size"].iloc[0])
        out.append({
            "gripper (opening / finger width)": f"{100 * part['cfg.gripper.opening'].iloc[0]:.0f} / "
                                                f"{100 * part['cfg.gripper.finger_width'].iloc[0]:.0f} cm",
            "bin side (floor / footprint)": f"{100 * size:.0f} cm ({size ** 2 / FOOTPRINT:.1f}x)",
            "attempts": len(part),
            "success % [95 %]": f"{100 * part['success'].mean():.0f} [{100 * low:.0f}-{100 * high:.0f}]",
            "NO_ROOM %": f"{100 * (part['reason'] == 'detection: NO_ROOM').mean():.0f}",
            "TOO_WIDE %": f"{100 * (part['reason'] == 'detection: TOO_WIDE').mean():.0f}",
            "rescued %": f"{100 * part['rescued'].mean():.0f}",
            "touching %": f"{100 * layout['touching_fraction'].mean():.0f}",
            "stacked per round": f"{layout['stacked'].mean():.2f}"})
    return out


if __name__ == "__main__":
    print(markdown(pd.DataFrame([r for folder in sys.argv[1:] for r in rows(folder)]), index=False))
