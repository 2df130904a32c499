"""Tables from rows alone: per-cell success with Wilson intervals beside the paper's, the
paper's Table 1 and 2 layouts, a sweep's comparison, the clutter of Setup 2/3 rounds; and the
readings of a run's settings the report's titles and comparisons share (a swept column's
paper-preset value, the objects named)."""

from __future__ import annotations

import io
import math
from importlib import resources

import pandas as pd

from graspjax.schema import LAYOUT_COLUMNS
from graspjax.stats import mean_interval, wilson

TABLE_OBJECTS = {1: tuple("abcdef"), 2: tuple("ghijkl")}


def paper_tables() -> pd.DataFrame:
    """The paper's Tables 1 and 2: table, setup, object, success_pct, trials."""
    text = resources.files("graspjax").joinpath("data/paper_tables.csv").read_text()
    return pd.read_csv(io.StringIO(text))


def varying_config(frame: pd.DataFrame) -> list[str]:
    """Configuration columns (`cfg.*`) whose value changes within the file: the sweep keys."""
    return [c for c in frame.columns if c.startswith("cfg.") and frame[c].nunique(dropna=False) > 1]


def sweep_axes(frame: pd.DataFrame) -> list[list[str]]:
    """Sweep keys grouped into axes: keys that vary together (one-to-one) form one axis."""
    axes: list[list[str]] = []
    for key in varying_config(frame):
        for axis in axes:
            n = frame[[axis[0], key]].drop_duplicates().shape[0]
            if n == frame[axis[0]].nunique() == frame[key].nunique():
                axis.append(key)
                break
        else:
            axes.append([key])
    return axes


def object_outcomes(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per object and trial or round, as the paper's tables count: an object tried
    more than once in a round (a failed object left in the scene, or clutter removal) is a
    success when any attempt credited to it succeeded (that row), else its first attempt. An
    attempt credited to no object (its target point lay on none) counts for none."""
    frame = frame[frame["object"].fillna("") != ""]
    keys = [c for c in ("point", *varying_config(frame)) if c in frame.columns]
    keys += ["setup", "trial", "object"]
    attempt = frame["attempt"] if "attempt" in frame.columns else pd.Series(0, frame.index)
    order = frame.assign(_first=attempt.where(attempt >= 0, 99))
    order = order.sort_values(["success", "_first"], ascending=[False, True], kind="stable")
    kept = order.drop_duplicates(keys).drop(columns="_first")
    return kept.sort_index()


def summarize(frame: pd.DataFrame) -> pd.DataFrame:
    """Per cell, from `object_outcomes`' rows: n, successes, rate, Wilson interval, the
    paper's rate, outcome counts."""
    keys = [*varying_config(frame), "setup", "object"]
    grouped = frame.groupby(keys, dropna=False)
    summary = grouped["success"].agg(n="size", successes="sum").reset_index()
    summary["rate"] = summary["successes"] / summary["n"]
    summary["ci_low"], summary["ci_high"] = wilson(summary["successes"], summary["n"])
    if {"rescued", "reorientations"} <= set(frame.columns):  # first view or a re-alignment
        parts = frame.assign(realigned=frame["reorientations"] > 0).groupby(keys, dropna=False).agg(
            realigned=("realigned", "sum"), rescued=("rescued", "sum")).reset_index()
        summary = summary.merge(parts, on=keys, how="left")
        summary["first_view_successes"] = summary["successes"] - summary["rescued"]
        summary["rate_first_view"] = summary["first_view_successes"] / summary["n"]
        summary["rate_rescued"] = summary["rescued"] / summary["n"]
        summary["rescue_rate"] = summary["rescued"] / summary["realigned"].where(
            summary["realigned"] > 0)  # among the attempts that re-aligned
    summary["table"] = summary["object"].map(lambda c: 1 if c in TABLE_OBJECTS[1] else 2)
    paper = paper_tables().rename(columns={"success_pct": "paper_pct", "trials": "paper_n"})
    summary = summary.merge(paper[["setup", "object", "paper_pct", "paper_n"]],
                            on=["setup", "object"], how="left")
    counts = frame.groupby(keys, dropna=False)["outcome"].value_counts().unstack(fill_value=0)
    counts.columns = [f"n_{c.lower()}" for c in counts.columns]
    return summary.merge(counts.reset_index(), on=keys, how="left")


def _cell(row) -> str:
    return f"{100 * row.rate:.0f} % [{100 * row.ci_low:.0f}-{100 * row.ci_high:.0f}]"


def _rate_cells(part: pd.DataFrame, objects) -> tuple[pd.DataFrame, list[str]]:
    """Per-object cells (`_cell`) of summary rows `part` and the pooled rate with its Wilson
    interval last; and `part` indexed by object."""
    by_obj = part.set_index("object")
    cells = [_cell(by_obj.loc[c]) if c in by_obj.index else "" for c in objects]
    k, n = part["successes"].sum(), part["n"].sum()
    low, high = wilson(k, n)
    return by_obj, cells + [f"{100 * k / n:.0f} % [{100 * low:.0f}-{100 * high:.0f}]"]


def _table_rows(summary: pd.DataFrame, table: int):
    """(label, cells, n cells) per setup and source, for present setups of a table."""
    objects = TABLE_OBJECTS[table]
    rows = []
    for setup in sorted(summary["setup"].unique()):
        part = summary[(summary["setup"] == setup) & summary["object"].isin(objects)]
        if part.empty:
            continue
        by_obj, ours = _rate_cells(part, objects)
        total_n = part["n"].sum()
        ns = [str(int(by_obj.loc[c, "n"])) if c in by_obj.index else "" for c in objects]
        ns.append(str(int(total_n)))
        rows.append((f"Setup {setup}, ours", ours, ns))
        if "rescued" in part.columns:
            rescued = [f"{100 * by_obj.loc[c, 'rate_rescued']:.0f} %" if c in by_obj.index else ""
                       for c in objects]
            rescued.append(f"{100 * part['rescued'].sum() / total_n:.0f} %")
            rows.append((f"Setup {setup}, of which rescued", rescued, None))
        if part["paper_pct"].notna().any():
            paper = [f"{by_obj.loc[c, 'paper_pct']:.0f} %" if c in by_obj.index
                     and not math.isnan(by_obj.loc[c, "paper_pct"]) else "" for c in objects]
            known = part["paper_pct"].dropna()
            paper.append(f"{known.mean():.0f} %" if len(known) == len(objects) else "")
            rows.append((f"Setup {setup}, paper", paper, None))
    return rows


def markdown(frame: pd.DataFrame, index: bool = True) -> str:
    """A DataFrame as a markdown table (its index as the first column unless `index` is off)."""
    header = ([""] if index else []) + [str(c) for c in frame.columns]
    rows = [([str(i)] if index else []) + [str(v) for v in row]
            for i, row in zip(frame.index, frame.to_numpy(), strict=True)]
    return "\n".join("| " + " | ".join(r) + " |" for r in [header, ["---"] * len(header), *rows])


def table_markdown(summary: pd.DataFrame, table: int, state: str = "") -> str:
    objects = TABLE_OBJECTS[table]
    title = {1: "Table 1: grasp success in Setups 1-3, objects a-f",
             2: "Table 2: grasp success in Setup 1, objects g-l"}[table]
    lines = [f"# {title}" + (f" ({state})" if state else ""), "",
             "Ours: success rate with its 95% Wilson interval; paper: the published rate "
             "(10 trials per cell). `all` pools the row's attempts (paper: mean of the row). "
             "Rescued: the share of attempts that succeeded with a grasp found only after a "
             "re-alignment (the rest of the rate came from the first view).", "",
             "| | " + " | ".join(f"{c})" for c in objects) + " | all |",
             "|---" * (len(objects) + 2) + "|"]
    ns = []
    for label, cells, n in _table_rows(summary, table):
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
        if n is not None:
            ns.append(f"| {label.split(',')[0]}, n | " + " | ".join(n) + " |")
    return "\n".join(lines + ns) + "\n"


def table_latex(summary: pd.DataFrame, table: int, state: str = "") -> str:
    objects = TABLE_OBJECTS[table]
    caption = {1: "Grasp success in Setups 1--3 for objects a--f (ours with 95\\% Wilson "
                  "intervals beside the paper's).",
               2: "Grasp success in Setup 1 for objects g--l (ours with 95\\% Wilson "
                  "intervals beside the paper's)."}[table]
    caption += f" ({state})" if state else ""
    lines = ["\\begin{table}[t]", "\\centering", f"\\caption{{{caption}}}",
             f"\\label{{tab:graspjax-table{table}}}",
             "\\begin{tabular}{l" + "c" * (len(objects) + 1) + "}", "\\toprule",
             " & " + " & ".join(f"{c})" for c in objects) + " & all \\\\", "\\midrule"]
    for label, cells, n in _table_rows(summary, table):
        cells = [c.replace("%", "\\%") for c in cells]
        lines.append(f"{label} & " + " & ".join(cells) + " \\\\")
        if n is not None:
            lines.append("\\quad $n$ & " + " & ".join(n) + " \\\\")
    lines += ["\\bottomrule", "\\end{tabular}", "\\end{table}"]
    return "\n".join(lines) + "\n"


def layout_lines(rounds: pd.DataFrame | None) -> list[str]:
    """How dense the Setup 2/3 layouts were and how their rounds went (clutter removal), one
    markdown line each per setup."""
    if rounds is None or rounds.empty:
        return []
    lines = ["", "Layouts once settled (`rounds.csv`), per setup: objects touching another, "
             "objects within 2 mm of another's outline seen from above (near), objects resting "
             "on another per round, median nearest face-to-face gap, spread (median over "
             "rounds).", ""]
    for setup, part in rounds.groupby("setup"):
        near = (f"near {100 * part.near_fraction.mean():.0f} %, "
                if "near_fraction" in part.columns else "")  # older runs' rounds.csv lack it
        lines.append(f"- Setup {setup} ({len(part)} rounds): touching "
                     f"{100 * part.touching_fraction.mean():.0f} %, {near}stacked "
                     f"{part.stacked.mean():.2f} per round, gap "
                     f"{100 * part.min_face_gap_m.median():.1f} cm, "
                     f"spread {100 * part.spread_m.median():.1f} cm")
    clutter = clutter_summary(rounds)
    if clutter is None:
        return lines
    lines += ["", "Clutter removal per round, as VGN defines it (`rounds_summary.csv`): grasp "
              "success rate (successes / attempts) and declutter rate (objects removed / placed), "
              "means over rounds with 95 % intervals.", ""]
    for row in clutter.itertuples():
        lines.append(f"- Setup {row.setup}: grasp success {_pct(row.grasp_success_rate)} "
                     f"[{_pct(row.grasp_success_low)}-{_pct(row.grasp_success_high)}], declutter "
                     f"{_pct(row.declutter_rate)} [{_pct(row.declutter_low)}-"
                     f"{_pct(row.declutter_high)}], {row.attempts_mean:.1f} attempts per round")
    return lines


def shared_layouts(rounds: pd.DataFrame | None) -> list[str]:
    """For a sweep's Setup 2/3 rounds: in how many rounds every grid point settled the same
    layout (the statistics of `rounds.csv`, to the file's precision), one markdown line per
    setup. A paired sweep's points play the same worlds, but a pile settles alike only when
    their chunks batch alike (issue 53): where they do not, the pairs are of layouts and keys,
    not of settled piles."""
    if rounds is None or rounds.empty or rounds["point"].nunique() < 2:
        return []
    if "seed" in rounds.columns and rounds.groupby("point")["seed"].first().nunique() > 1:
        return []  # not paired: every point has its own seed, so its own worlds
    lines = ["", "Settled layouts every grid point shares (`rounds.csv`'s statistics equal at "
             "every point; a paired sweep's points play the same worlds):", ""]
    for setup, part in rounds.groupby("setup"):
        varied = part.groupby("round")[list(LAYOUT_COLUMNS)].nunique(dropna=False)
        same = int((varied <= 1).all(axis=1).sum())
        lines.append(f"- Setup {setup}: {same} of {len(varied)} rounds")
    return lines


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %"


def clutter_summary(rounds: pd.DataFrame | None) -> pd.DataFrame | None:
    """Per grid point and setup, over its rounds: VGN's clutter-removal metrics (grasp success
    rate, declutter rate) as means with 95 % intervals, the attempts per round and how the
    rounds ended. None for round rows without them (runs before these columns)."""
    if rounds is None or rounds.empty or "grasp_success_rate" not in rounds.columns:
        return None
    keys = [k for k in ("point", "method", "setup") if k in rounds.columns]
    out = []
    for values, part in rounds.groupby(keys):
        success = mean_interval(part["grasp_success_rate"])
        declutter = mean_interval(part["declutter_rate"])
        out.append({**dict(zip(keys, values, strict=True)), "rounds": len(part),
                    "attempts_mean": part["attempts"].mean(),
                    "grasp_success_rate": success[0], "grasp_success_low": success[1],
                    "grasp_success_high": success[2], "pooled_success_rate":
                    part["successes"].sum() / max(part["attempts"].sum(), 1),
                    "declutter_rate": declutter[0], "declutter_low": declutter[1],
                    "declutter_high": declutter[2],
                    **{f"ended_{end}": (part["end"] == end).mean()
                       for end in ("empty", "stuck", "limit") if (part["end"] == end).any()}})
    return pd.DataFrame(out)


def point_order(frame: pd.DataFrame) -> list[str]:
    """The grid points' labels (`point_labels`) in the order of the grid."""
    keys = varying_config(frame)
    ordered = frame.sort_values("point", kind="stable") if "point" in frame.columns else frame
    points = ordered.drop_duplicates(keys)
    return list(dict.fromkeys(point_labels(points[keys])))


def point_labels(summary: pd.DataFrame) -> pd.Series:
    """A label per summary row naming its grid point by the values that vary
    ("method=antipodal, procedure.max_reorientations=0")."""
    keys = [c for c in summary.columns if c.startswith("cfg.")]
    if not keys:
        return pd.Series("", index=summary.index)
    return summary[keys].astype(str).apply(
        lambda row: ", ".join(f"{k[len('cfg.'):]}={v}" for k, v in row.items()), axis=1)


def comparison_markdown(summary: pd.DataFrame, order: list[str], state: str = "") -> str:
    """Every grid point of a sweep in the paper's Tables 1 and 2 layout: per table and setup one
    row per point (success with its 95 % Wilson interval), one for the share rescued by a
    re-alignment where any was, and the paper's row."""
    labelled = summary.assign(label=point_labels(summary))
    lines = ["# Every grid point in the Tables 1 and 2 layout" + (f" ({state})" if state else ""), "",
             "Success with its 95 % Wilson interval; *rescued*: the share of attempts that "
             "succeeded with a grasp found only after a re-alignment (the rest came from the "
             "first view); the paper's row: its 10 trials per cell.", ""]
    for table, objects in TABLE_OBJECTS.items():
        part = labelled[labelled["object"].isin(objects)]
        if part.empty:
            continue
        lines += [f"## Table {table}", "", "| | " + " | ".join(f"{c})" for c in objects)
                  + " | all |", "|---" * (len(objects) + 2) + "|"]
        for setup in sorted(part["setup"].unique()):
            here = part[part["setup"] == setup]
            for label in order:
                cells = here[here["label"] == label]
                if cells.empty:
                    continue
                by_obj, row = _rate_cells(cells, objects)
                n = cells["n"].sum()
                lines.append(f"| Setup {setup}, {label} | " + " | ".join(row) + " |")
                if "rescued" in cells.columns and cells["rescued"].sum() > 0:
                    rescued = [f"{100 * by_obj.loc[c, 'rate_rescued']:.0f} %"
                               if c in by_obj.index else "" for c in objects]
                    rescued.append(f"{100 * cells['rescued'].sum() / n:.0f} %")
                    lines.append("| of which rescued | " + " | ".join(rescued) + " |")
            paper = here.drop_duplicates("object").set_index("object")["paper_pct"]
            if paper.notna().any():
                cells = [f"{paper[c]:.0f} %" if c in paper.index and pd.notna(paper[c]) else ""
                         for c in objects]
                known = paper.dropna()
                cells.append(f"{known.mean():.0f} %" if len(known) == len(objects) else "")
                lines.append(f"| Setup {setup}, the paper | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def paper_value(key: str):
    """The paper preset's value of a swept `cfg.` column (the paper's 15 px, 0.3, one
    re-alignment; our reading where the paper is silent); None for a column that is no
    setting."""
    from graspjax.config import preset
    from graspjax.tree import named_fields

    if not key.startswith("cfg."):
        return None
    return named_fields(preset("paper")).get(key[len("cfg."):])


def objects_named(objects) -> str:
    """Object letters as a title writes them: "a-f" for three or more without a gap, else
    "a, c" (sorted); "" for all twelve of Tables 1 and 2."""
    letters = sorted(set(objects))
    if len(letters) == len(TABLE_OBJECTS[1]) + len(TABLE_OBJECTS[2]):
        return ""
    if len(letters) > 2 and ord(letters[-1]) - ord(letters[0]) == len(letters) - 1:
        return f"{letters[0]}-{letters[-1]}"
    return ", ".join(letters)
