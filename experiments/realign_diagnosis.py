"""Why re-aligned attempts fail, from attempts.csv alone (the ground-truth columns realign1_*).

    python3 experiments/realign_diagnosis.py results/studies/realign_gpu_300 [more folders]

Each re-aligned attempt gets one cause: the chosen plane's inliers lie mostly off the target
(wrong plane: table, other object, bin); else the re-aligned view found no grasp (by the
detector's reason); else the grasp was executed (by outcome, SUCCESS = rescued). Prints one
markdown table per folder and grid point (setups as columns), then the rescue rate by the
re-aligned view's tilt.
"""

from __future__ import annotations

import sys

import pandas as pd

from graspjax.report import load_attempts, markdown, varying_config


def cause(frame: pd.DataFrame) -> pd.Series:
    """One cause per re-aligned attempt (see the module docstring)."""
    wrong = "wrong plane: " + frame["realign1_surface"].astype(str)
    no_grasp = "no grasp: " + frame["detect_reason"].astype(str)
    executed = "executed: " + frame["outcome"].astype(str)
    return wrong.where(frame["realign1_surface"] != "target",
                       no_grasp.where(frame["grasp_found"] == 0, executed))


def diagnose(folder: str) -> str:
    frame = load_attempts(folder)
    frame = frame[(frame["attempt"] >= 0) & (frame["reorientations"] > 0)]
    out = []
    for values, part in frame.groupby(varying_config(frame) or (lambda _: 0)):
        table = pd.crosstab(cause(part), part["setup"], margins=True, margins_name="all")
        share = (100 * table / table.loc["all"]).round(0).astype(int).astype(str) + " %"
        table = table.astype(str) + " (" + share + ")"
        out += [f"## {folder} {values if varying_config(frame) else ''}".rstrip(), "",
                "Re-aligned attempts by cause, per setup (count, share of the setup's re-aligned).",
                "", markdown(table), ""]
        tilt = pd.cut(part["realign1_view_tilt_deg"], [0, 5, 15, 30, 45, 60, 90],
                      include_lowest=True)
        rescue = part.groupby([tilt, "setup"], observed=True)["success"].agg(["size", "mean"])
        cells = (100 * rescue["mean"]).round(0).astype(int).astype(str) + " % of " + rescue[
            "size"].astype(str)
        out += ["Rescued share by the re-aligned view's tilt from straight down (deg), per setup:",
                "", markdown(cells.unstack("setup").fillna("")), ""]
    return "\n".join(out)


if __name__ == "__main__":
    print("\n".join(diagnose(folder) for folder in sys.argv[1:]))
