"""Tables and figures computed from `attempts.csv` alone (plus the paper's published numbers).

- `summary.csv`: one row per cell (setup, object, and every configuration
  column that varies in the file): n, successes, rate, 95% Wilson interval,
  the paper's rate, and counts per outcome, counting one outcome per object
  and trial or round (`object_outcomes`), as the paper's tables do.
- `table1.md/.tex`, `table2.md/.tex`: the paper's Table 1 (a-f, Setups 1-3)
  and Table 2 (g-l, Setup 1) layouts, ours beside the paper's.
- `success_by_object.png`: our rates with intervals beside the paper's bars;
  `outcomes.png`: what happened in every cell.
- Sweeps (configuration columns `cfg.*` that vary): `sweep_summary.csv`,
  `sweep_<key>.png` (success against each parameter) and, for two-parameter
  grids, `sweep_heatmap.png`.
"""

from __future__ import annotations

import io
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from graspjax.config import Config, override
from graspjax.figures import new_figure, png
from graspjax.schema import LAYOUT_COLUMNS, outcome_label
from graspjax.stats import mean_interval, wilson

TABLE_OBJECTS = {1: tuple("abcdef"), 2: tuple("ghijkl")}
REQUIRED = ("setup", "object", "trial", "round", "seed", "success", "outcome", "reason")


def paper_tables() -> pd.DataFrame:
    """The paper's Tables 1 and 2: table, setup, object, success_pct, trials."""
    text = resources.files("graspjax").joinpath("data/paper_tables.csv").read_text()
    return pd.read_csv(io.StringIO(text))


def parse_attempts(text: str, name: str = "attempts.csv") -> pd.DataFrame:
    """Attempt rows from CSV text, checking the columns the report needs and that every row is
    complete (a file cut mid-row is refused: its last row would count as a failure)."""
    if not text.strip():
        raise ValueError(f"{name} has no attempts yet")
    if not text.endswith("\n"):
        raise ValueError(f"{name} ends in an incomplete row (still being written: try again; "
                         "cut by a kill: --resume the run to rewrite it)")
    frame = pd.read_csv(io.StringIO(text), keep_default_na=False, na_values=[""], low_memory=False,
                        dtype={"object": str, "lifted_object": str, "run_id": str})
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise ValueError(f"{name} lacks columns: {', '.join(missing)}")
    if frame.empty:
        raise ValueError(f"{name} has no attempts")
    if "run_id" in frame.columns and frame["run_id"].nunique() > 1:
        ids = sorted(frame["run_id"].astype(str).unique())
        raise ValueError(f"{name} mixes the rows of {len(ids)} runs (run_id {', '.join(ids[:3])})")
    return frame


def load_attempts(folder: str | Path) -> pd.DataFrame:
    """Read `attempts.csv` (or a gzipped `attempts.csv.gz`) from a run or sweep folder."""
    import gzip

    path = Path(folder) / "attempts.csv"
    if path.is_file():
        return parse_attempts(path.read_text(), str(path))
    if path.with_suffix(".csv.gz").is_file():
        text = gzip.decompress(path.with_suffix(".csv.gz").read_bytes()).decode()
        return parse_attempts(text, str(path.with_suffix(".csv.gz")))
    raise FileNotFoundError(f"no attempts.csv in {folder}")


def planned_worlds(meta: dict) -> int:
    """How many worlds a run plays, from its `config.json`: per grid point and job, each object's
    trials in Setup 1 and one round per trial in Setups 2 and 3 (`batch.plan.plan`)."""
    per_point = sum(len(job["objects"]) * job["trials"] if setup == 1 else job["trials"]
                    for job in meta["jobs"] for setup in job["setups"])
    return int(meta.get("points", 1)) * per_point


def played_worlds(frame: pd.DataFrame) -> int:
    """How many worlds the rows hold: (point, setup, object, trial) in Setup 1, (point, setup,
    trial) in Setups 2 and 3."""
    point = frame["point"] if "point" in frame.columns else pd.Series(0, frame.index)
    single = frame["setup"] == 1
    object_of = frame["object"].fillna("").where(single, "")
    return len(pd.DataFrame({"p": point, "s": frame["setup"], "o": object_of,
                             "t": frame["trial"]}).drop_duplicates())


def _meta(folder: str | Path) -> dict:
    """The folder's `config.json` ({} when it has none a run wrote)."""
    import json

    try:
        meta = json.loads((Path(folder) / "config.json").read_text())
    except (OSError, ValueError):
        return {}
    return meta if isinstance(meta, dict) else {}


def run_state(folder: str | Path, frame: pd.DataFrame) -> str:
    """"" for a finished run whose rows are all there (or rows without a run's `config.json`),
    "unfinished: n of N worlds" for a run still going or killed; a ValueError when the rows
    are not the folder's run's, or a finished run's file lacks worlds (cut)."""
    meta = _meta(folder)
    try:
        planned = planned_worlds(meta)
    except (KeyError, TypeError, ValueError):
        return ""  # rows from elsewhere: nothing to check them against
    ids = set(frame["run_id"].astype(str)) if "run_id" in frame.columns else set()
    if meta.get("run_id") and ids and ids != {str(meta["run_id"])}:
        raise ValueError(f"{folder}: attempts.csv holds rows of run {', '.join(sorted(ids))}, "
                         f"config.json describes run {meta['run_id']}")
    played = played_worlds(frame)
    if meta.get("finished") and played < planned:
        raise ValueError(f"{folder}: attempts.csv holds {played} of the run's {planned} "
                         "worlds though the run finished (the file was cut)")
    return "" if meta.get("finished") or played >= planned else \
        f"unfinished: {played} of {planned} worlds"

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


def success_figure(summary: pd.DataFrame) -> bytes:
    """Bars per object and setup: ours with 95% intervals (the share rescued by a re-alignment on
    top), the paper's beside them."""
    panels = [(t, s) for t in (1, 2) for s in sorted(summary["setup"].unique())
              if ((summary["setup"] == s) & (summary["table"] == t)).any()]
    fig = new_figure(4.2 * max(1, len(panels)), 3.6)
    axes = fig.subplots(1, max(1, len(panels)), squeeze=False)[0]
    for ax, (table, setup) in zip(axes, panels, strict=False):
        part = summary[(summary["setup"] == setup) & (summary["table"] == table)]
        part = part.sort_values("object")
        x = np.arange(len(part))
        err = np.maximum(0, np.vstack([part["rate"] - part["ci_low"],
                                       part["ci_high"] - part["rate"]])) * 100
        ax.bar(x - 0.2, 100 * part["rate"], 0.4, yerr=err, capsize=3, color="tab:blue",
               label="ours (95% CI)")
        if "rate_rescued" in part.columns:  # the top of each bar: rescued by a re-alignment
            ax.bar(x - 0.2, 100 * part["rate_rescued"], 0.4, bottom=100 * part["rate_first_view"],
                   color="tab:purple", label="of which rescued")
        if part["paper_pct"].notna().any():
            ax.bar(x + 0.2, part["paper_pct"], 0.4, color="none", edgecolor="tab:orange",
                   hatch="//", label="paper")
        ax.set_xticks(x, [f"{c})" for c in part["object"]])
        ax.set_ylim(0, 105)
        ax.set_title(f"Setup {setup}, objects {part['object'].iloc[0]}-{part['object'].iloc[-1]}")
        ax.set_ylabel("grasp success (%)")
        ax.legend(loc="lower left", fontsize=7)
    return png(fig)


def outcome_colours(labels) -> dict[str, object]:
    """A distinct colour per outcome label: SUCCESS green, every failure its own non-green colour."""
    import matplotlib

    palette = [c for name in ("tab20", "tab20b") for c in matplotlib.colormaps[name].colors
               if not (c[1] > c[0] + 0.1 and c[1] > c[2] + 0.1)]  # no greens among the failures
    failures = sorted(label for label in set(labels) if label != "SUCCESS")
    colours = {label: palette[i % len(palette)] for i, label in enumerate(failures)}
    colours["SUCCESS"] = matplotlib.colors.to_rgb("tab:green")
    return colours


def outcomes_figure(frame: pd.DataFrame) -> bytes:
    """Stacked shares of outcomes (and perception failures) per setup and object."""
    label = outcome_label(frame)
    cells = frame["setup"].astype(str) + "/" + frame["object"]
    shares = pd.crosstab(cells, label, normalize="index") * 100
    order = sorted(shares.index, key=lambda c: (int(c.split("/")[0]), c.split("/")[1]))
    shares = shares.loc[order]
    columns = (["SUCCESS"] if "SUCCESS" in shares.columns else []) + sorted(
        c for c in shares.columns if c != "SUCCESS")
    colours = outcome_colours(columns)
    fig = new_figure(max(6.0, 0.45 * len(shares) + 3), 4.2)
    ax = fig.subplots()
    bottom = np.zeros(len(shares))
    for column in columns:
        ax.bar(np.arange(len(shares)), shares[column], bottom=bottom, label=column,
               color=colours[column])
        bottom += shares[column].to_numpy()
    ax.set_xticks(np.arange(len(shares)), shares.index, rotation=90, fontsize=7)
    ax.set_ylabel("share of attempts (%)")
    ax.set_xlabel("setup / object")
    ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return png(fig)


def sweep_outputs(frame: pd.DataFrame) -> dict[str, bytes]:
    """Success against each swept parameter, per setup; a heat map for two-parameter grids."""
    keys = varying_config(frame)
    if not keys:
        return {}
    out = {}
    pooled = frame.groupby([*keys, "setup"], dropna=False)["success"].agg(
        n="size", successes="sum").reset_index()
    pooled["rate"] = pooled["successes"] / pooled["n"]
    pooled["ci_low"], pooled["ci_high"] = wilson(pooled["successes"], pooled["n"])
    out["sweep_summary.csv"] = pooled.to_csv(index=False).encode()
    axes = sweep_axes(frame)
    for axis in axes:
        key = axis[0]
        per = frame.groupby([key, "setup"], dropna=False)["success"].agg(
            n="size", successes="sum").reset_index()
        per["rate"] = per["successes"] / per["n"]
        per["ci_low"], per["ci_high"] = wilson(per["successes"], per["n"])
        fig = new_figure(5.5, 3.8)
        ax = fig.subplots()
        for setup, part in per.groupby("setup"):
            part = part.sort_values(key)
            values = part[key].to_numpy()
            numeric = np.issubdtype(values.dtype, np.number)
            x = values if numeric else np.arange(len(values))
            ax.errorbar(x, 100 * part["rate"], yerr=100 * np.maximum(0, np.vstack(
                [part["rate"] - part["ci_low"], part["ci_high"] - part["rate"]])),
                marker="o", capsize=3, label=f"Setup {setup}")
            if not numeric:
                ax.set_xticks(x, values)
        ax.set_xlabel(" : ".join(k[len("cfg."):] for k in axis))
        ax.set_ylabel("grasp success (%)")
        ax.set_ylim(0, 105)
        ax.legend(fontsize=8)
        ax.set_title("other swept keys pooled" if len(axes) > 1 else "")
        out[f"sweep_{key[len('cfg.'):]}.png"] = png(fig)
    if len(axes) == 2:
        keys = [axes[0][0], axes[1][0]]
        grid = frame.groupby(keys)["success"].mean().unstack(keys[1]) * 100
        fig = new_figure(6, 4.5)
        ax = fig.subplots()
        image = ax.imshow(grid.to_numpy(), origin="lower", cmap="viridis", vmin=0, vmax=100,
                          aspect="auto")
        ax.set_yticks(np.arange(len(grid.index)), grid.index)
        ax.set_xticks(np.arange(len(grid.columns)), grid.columns)
        ax.set_ylabel(keys[0][len("cfg."):])
        ax.set_xlabel(keys[1][len("cfg."):])
        for (i, j), value in np.ndenumerate(grid.to_numpy()):
            ax.text(j, i, f"{value:.0f}", ha="center", va="center", color="w", fontsize=8)
        fig.colorbar(image, ax=ax, label="grasp success (%), all setups and objects")
        out["sweep_heatmap.png"] = png(fig)
    return out


def load_rounds(folder: str | Path) -> pd.DataFrame | None:
    """`rounds.csv` (or a gzipped `rounds.csv.gz`, as committed results keep it) of a run
    folder (one row per Setup 2/3 round), None if it has none."""
    path = Path(folder) / "rounds.csv"
    if not path.is_file():
        path = path.with_suffix(".csv.gz")
    if not path.is_file() or not path.stat().st_size:
        return None
    return pd.read_csv(path)


def layout_lines(rounds: pd.DataFrame | None) -> list[str]:
    """How dense the Setup 2/3 layouts were and how their rounds went (clutter removal), one
    markdown line each per setup."""
    if rounds is None or rounds.empty:
        return []
    lines = ["", "Layouts once settled (`rounds.csv`), per setup: objects touching another, "
             "objects resting on another per round, median nearest face-to-face gap, spread "
             "(median over rounds).", ""]
    for setup, part in rounds.groupby("setup"):
        lines.append(f"- Setup {setup} ({len(part)} rounds): touching "
                     f"{100 * part.touching_fraction.mean():.0f} %, stacked "
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


def build(frame: pd.DataFrame, rounds: pd.DataFrame | None = None,
          state: str = "") -> dict[str, bytes]:
    """Every report file (name -> bytes) from the attempt rows (and the round rows); `state`
    ("unfinished: n of N worlds", `run_state`) goes into every table's title."""
    objects = object_outcomes(frame)  # the tables count objects per round, as the paper's
    summary = summarize(objects)
    files = {"summary.csv": summary.to_csv(index=False).encode()}
    if not varying_config(frame):
        for table in (1, 2):
            if summary["object"].isin(TABLE_OBJECTS[table]).any():
                text = table_markdown(summary, table, state)
                if table == 1:
                    text += "\n".join(layout_lines(rounds)) + ("\n" if rounds is not None else "")
                files[f"table{table}.md"] = text.encode()
                files[f"table{table}.tex"] = table_latex(summary, table, state).encode()
        files["success_by_object.png"] = success_figure(summary)
    files["outcomes.png"] = outcomes_figure(frame)  # every attempt
    files.update(sweep_outputs(objects))
    if varying_config(frame):
        order = point_order(frame)
        shared = shared_layouts(rounds)
        text = comparison_markdown(summary, order, state) + "".join(f"{x}\n" for x in shared)
        files["comparison.md"] = text.encode()
        files["comparison.png"] = comparison_figure(summary, order)
    clutter = clutter_summary(rounds)
    if clutter is not None:
        files["rounds_summary.csv"] = clutter.to_csv(index=False).encode()
    return files


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


def comparison_figure(summary: pd.DataFrame, labels: list[str]) -> bytes:
    """Success per object, one bar per grid point (95 % intervals, in the order of `labels`),
    a panel per table and setup; the share rescued by a re-alignment drawn on top."""
    labelled = summary.assign(label=point_labels(summary))
    panels = [(t, s) for t in (1, 2) for s in sorted(labelled["setup"].unique())
              if ((labelled["setup"] == s) & (labelled["table"] == t)).any()]
    fig = new_figure(4.8 * max(1, len(panels)), 4.4 + 0.2 * len(labels))
    axes = fig.subplots(1, max(1, len(panels)), squeeze=False)[0]
    width = 0.8 / max(1, len(labels))
    for ax, (table, setup) in zip(axes, panels, strict=False):
        part = labelled[(labelled["setup"] == setup) & (labelled["table"] == table)]
        objects = sorted(part["object"].unique())
        x = np.arange(len(objects))
        for i, label in enumerate(labels):
            cells = part[part["label"] == label].set_index("object").reindex(objects)
            offset = x - 0.4 + (i + 0.5) * width
            err = np.maximum(0, np.vstack([cells["rate"] - cells["ci_low"],
                                           cells["ci_high"] - cells["rate"]])) * 100
            bars = ax.bar(offset, 100 * cells["rate"], width, yerr=err, capsize=2, label=label)
            if "rate_rescued" in cells.columns and cells["rescued"].sum() > 0:
                ax.bar(offset, 100 * cells["rate_rescued"], width,
                       bottom=100 * cells["rate_first_view"], color=bars.patches[0].get_facecolor(),
                       hatch="///", edgecolor="white", linewidth=0)
        ax.set_xticks(x, [f"{c})" for c in objects])
        ax.set_ylim(0, 105)
        ax.set_title(f"Setup {setup}, objects {objects[0]}-{objects[-1]}")
        ax.set_ylabel("grasp success (%); hatched: rescued")
    axes[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.1))
    return png(fig)


def write_report(folder: str | Path, debug: int = 0) -> tuple[list[Path], str]:
    """Rebuild every table and figure of a run or sweep folder from its attempts.csv; with
    `debug`, also draw the first `debug` saved attempts (views/*.npz) into debug/. Returns the
    files written and the run's state (`run_state`: "" when finished)."""
    from graspjax.io import write_atomic

    folder = Path(folder)
    frame = load_attempts(folder)
    state = run_state(folder, frame)
    files = build(frame, load_rounds(folder), state)
    if state and _meta(folder).get("finished"):  # the run finished meanwhile: report its whole rows
        return write_report(folder, debug)
    if debug:
        files.update(debug_figures(folder, debug))
    for name, data in files.items():
        (folder / name).parent.mkdir(exist_ok=True)
        write_atomic(folder / name, data)
    return [folder / name for name in files], state


def debug_figures(folder: Path, count: int) -> dict[str, bytes]:
    """The first `count` saved attempts of a run, drawn (name -> PNG bytes), each with the
    configuration of its own grid point."""
    import json

    from graspjax.views import load, point_of
    from graspjax.viz import attempt_figure

    saved = sorted((folder / "views").glob("*.npz"))
    if not saved:
        raise FileNotFoundError(f"no saved views in {folder / 'views'} (run with --save-views)")
    meta = json.loads((folder / "config.json").read_text())
    return {f"debug/{path.stem}.png":
            attempt_figure(load(path), point_config(meta, point_of(path.stem)))
            for path in saved[:count]}


def point_config(meta: dict, point: int) -> Config:
    """The configuration grid point `point` of a run used, from its config.json: the base
    configuration's overrides, then the point's grid values."""
    base = override(Config(), {k: str(v) for k, v in meta.get("overrides", {}).items()})
    return override(base, {k: str(values[point]) for k, values in meta.get("grid", {}).items()})
