"""Paired studies of the re-alignment, from the run folders' files alone.

    python3 experiments/realign_studies.py SWEEP... [--planes PLANES...] > study.md
    python3 experiments/realign_studies.py SWEEP... --figure OUT.png

SWEEP: a folder of `graspjax sweep --paired` (every grid point plays the same worlds; in
Setups 2 and 3 an attempt pairs only where both points attempted the same object at the same
attempt number, since earlier outcomes change the pile). Per
grid point and setup: attempts, success with its Wilson 95 % interval, attempts that
re-aligned, rescued, and the rescue rate among the re-aligned (Wilson). Against the reference
point (the one whose values equal the default configuration, else point 0): the discordant
pairs (same world and attempt, success at only one of the two points), McNemar's exact
two-sided p, the smallest success difference this many pairs could detect (5 % two-sided,
80 % power, from the discordant share), and the paired difference with its 95 % interval
(Newcombe's square-and-add).

--across BEFORE AFTER: two sweeps of the same grid on the same worlds (same seed and command
but one setting), compared point by point the same way (AFTER is the reference).

PLANES: a folder of `graspjax planes`: its per-point summary as a table.

--figure OUT: instead of the tables, draw the SWEEP folders, one study's cells each run at the
trials it needs (`experiments/studies.sh`'s TAG), as one figure (`report.studies`): a panel per
setup and object set, the rates and the paired differences from the paper's value.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

from graspjax.config import Config
from graspjax.report import load_attempts
from graspjax.stats import mcnemar_p, paired_detectable, paired_difference, wilson
from graspjax.tree import named_fields

PAIR = ["setup", "object", "trial", "attempt"]


def _same(a, b) -> bool:
    """Grid value `a` equals config value `b` (numbers compared as numbers)."""
    try:
        return float(a) == float(b)
    except (TypeError, ValueError):
        return str(a) == str(b)


def _pct(x: float) -> str:
    return f"{100 * x:.1f}"


def _interval(k: int, n: int) -> str:
    low, high = wilson(k, n)
    return f"{_pct(k / max(n, 1))} [{_pct(float(low))}-{_pct(float(high))}]"


def _difference(here: pd.Series, reference: pd.Series) -> str:
    """The paired success difference, here less the reference, in points with its 95 %
    interval (`stats.paired_difference`: Newcombe's square-and-add)."""
    difference, low, high = paired_difference((here & reference).sum(), (here & ~reference).sum(),
                                              (~here & reference).sum(), (~here & ~reference).sum())
    return f"{100 * difference:+.1f} [{100 * low:+.1f} to {100 * high:+.1f}]"


def sweep_table(folder: str) -> str:
    frame = load_attempts(folder)
    frame = frame[frame["attempt"] >= 0]
    grid = json.loads((Path(folder) / "config.json").read_text())["grid"]
    keys = list(grid)
    default = named_fields(Config())
    points = sorted(frame["point"].unique())
    reference = next((p for p in points if all(
        _same(grid[k][p], default[k]) for k in keys)), points[0])
    lines = [f"### {folder}: {', '.join(keys)} (paired; reference: point {reference}, "
             f"{', '.join(f'{k}={grid[k][reference]}' for k in keys)})", "",
             "| " + " | ".join([*keys, "setup", "attempts", "success % [95 %]", "re-aligned",
                                "rescued", "rescue % of re-aligned [95 %]",
                                "only here / only ref.", "McNemar p",
                                "detectable diff. (points)", "diff. (points) [95 %]"]) + " |",
             "|" + "---|" * (len(keys) + 10)]
    for setup, part in frame.groupby("setup"):
        ref = part[part["point"] == reference].set_index(PAIR)["success"].astype(bool)
        for p in points:
            here = part[part["point"] == p]
            realigned = here[here["reorientations"] > 0]
            rescued = int(here["rescued"].sum())
            paired = pd.concat([here.set_index(PAIR)["success"].astype(bool), ref], axis=1,
                               keys=["here", "ref"]).dropna().astype(bool)
            only_here = int((paired["here"] & ~paired["ref"]).sum())
            only_ref = int((~paired["here"] & paired["ref"]).sum())
            compare = (("", "", "", "") if p == reference else (
                f"{only_here} / {only_ref}", f"{mcnemar_p(only_here, only_ref):.2g}",
                _pct(paired_detectable(only_here + only_ref, len(paired))),
                _difference(paired["here"], paired["ref"])))
            lines.append("| " + " | ".join([
                *(str(grid[k][p]) for k in keys), str(setup), str(len(here)),
                _interval(int(here["success"].sum()), len(here)), str(len(realigned)),
                str(rescued), _interval(rescued, len(realigned)), *compare]) + " |")
    return "\n".join(lines)


def across_table(before: str, after: str) -> str:
    """Point by point, AFTER against BEFORE on the same worlds (paired by world and attempt)."""
    a, b = (load_attempts(f) for f in (before, after))
    grid = json.loads((Path(after) / "config.json").read_text())["grid"]
    keys = list(grid)
    lines = [f"### {before} -> {after} (the same worlds; paired by world and attempt)", "",
             "| " + " | ".join([*keys, "pairs", "success before %", "success after %",
                                "only before / only after", "McNemar p",
                                "detectable diff. (points)", "diff. (points) [95 %]"]) + " |",
             "|" + "---|" * (len(keys) + 7)]
    for p in sorted(b["point"].unique()):
        pair = pd.concat([f[(f["point"] == p) & (f["attempt"] >= 0)].set_index(PAIR)["success"]
                          .astype(bool) for f in (a, b)], axis=1, keys=["a", "b"]).dropna().astype(bool)
        only_a = int((pair["a"] & ~pair["b"]).sum())
        only_b = int((~pair["a"] & pair["b"]).sum())
        lines.append("| " + " | ".join([
            *(str(grid[k][p]) for k in keys), str(len(pair)), _pct(pair["a"].mean()),
            _pct(pair["b"].mean()), f"{only_a} / {only_b}", f"{mcnemar_p(only_a, only_b):.2g}",
            _pct(paired_detectable(only_a + only_b, len(pair))),
            _difference(pair["a"], pair["b"])]) + " |")
    return "\n".join(lines)


def planes_table(folder: str) -> str:
    summary = pd.read_csv(Path(folder) / "planes_summary.csv")
    meta = json.loads((Path(folder) / "config.json").read_text())
    timings = meta["timings"]
    keys = list(meta["grid"])
    lines = [f"### {folder}: {', '.join(keys)} (perception only; overrides: "
             f"{meta['overrides'] or 'none'})", "",
             f"{int(summary['views'].iloc[0]):,} first views without a grasp per grid point; "
             f"scored at {timings['views_per_s']:,.0f} views/s on {meta['device']['kind']}.", "",
             "| " + " | ".join([*keys, "plane found %", "on target % [95 %]",
                                "detectable diff. (points)", "normal error, median (deg)",
                                "within 5 deg %", "view tilt, median (deg)"]) + " |",
             "|" + "---|" * (len(keys) + 6)]
    for _, row in summary.iterrows():
        lines.append("| " + " | ".join([
            *(str(meta["grid"][k][int(row["point"])]) for k in keys), _pct(row["plane_found"]),
            f"{_pct(row['on_target'])} [{_pct(row['on_target_low'])}-"
            f"{_pct(row['on_target_high'])}]", _pct(row["detectable_difference"]),
            f"{row['normal_error_median_deg']:.2f}", _pct(row["within_5deg"]),
            f"{row['view_tilt_median_deg']:.1f}"]) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweeps", nargs="*")
    parser.add_argument("--across", nargs=2, action="append", default=[],
                        metavar=("BEFORE", "AFTER"))
    parser.add_argument("--planes", nargs="*", default=[])
    parser.add_argument("--figure", metavar="OUT")
    args = parser.parse_args()
    if args.figure:
        if not args.sweeps or args.across or args.planes:
            parser.error("--figure draws SWEEP folders alone: give them, without --across or --planes")
        from graspjax.report.studies import study_figure

        Path(args.figure).write_bytes(study_figure(args.sweeps))
        raise SystemExit(0)
    print("\n\n".join([*map(sweep_table, args.sweeps),
                        *(across_table(*pair) for pair in args.across),
                        *map(planes_table, args.planes)]))
