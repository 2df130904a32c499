"""Figures from rows alone: success per object beside the paper's bars, outcomes per cell,
success against swept parameters, a sweep's comparison."""

from __future__ import annotations

import textwrap

import numpy as np
import pandas as pd
from matplotlib.collections import PolyCollection
from matplotlib.patches import Rectangle

from graspjax.figures import new_figure, png
from graspjax.figures.titles import run_description, sweep_title
from graspjax.report.tables import paper_value, point_labels, sweep_axes, varying_config
from graspjax.schema import outcome_label
from graspjax.stats import mcnemar_p, mcnemar_z, paired_detectable, paired_difference, wilson


def success_figure(summary: pd.DataFrame, meta: dict | None = None):
    """Bars per object and setup: ours with 95% intervals (the share rescued by a re-alignment on
    top), the paper's beside them; the run's preset, setups and trials in the title (`meta`:
    its config.json, `run_description`), the legend below the panels, over no data. A
    matplotlib figure (`figures.png(fig, laid_out=True)` makes it a PNG)."""
    panels = [(t, s) for t in (1, 2) for s in sorted(summary["setup"].unique())
              if ((summary["setup"] == s) & (summary["table"] == t)).any()]
    width = 4.2 * max(1, len(panels))
    fig = new_figure(width, 4.0)
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
                   color="tab:purple", label="of which rescued by a re-alignment")
        if part["paper_pct"].notna().any():
            ax.bar(x + 0.2, part["paper_pct"], 0.4, color="none", edgecolor="tab:orange",
                   hatch="//", label="paper (10 trials)")
        ax.set_xticks(x, [f"{c})" for c in part["object"]])
        ax.set_ylim(0, 105)
        ax.set_title(f"Setup {setup}, objects {part['object'].iloc[0]}-{part['object'].iloc[-1]}")
        ax.set_ylabel("grasp success (%)")
    legend = {}  # every panel's entries once, in the order first drawn
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    setups = sorted(summary["setup"].unique())
    title = "grasp success per object" + (f": {run_description(meta, setups)}" if meta else "")
    fig.suptitle(textwrap.fill(title, int(13 * width)), fontsize=10)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    fig.legend(list(legend.values()), list(legend), loc="lower center", ncol=len(legend),
               fontsize=8, frameon=False)
    return fig


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
    x = np.arange(len(shares))
    top = shares[columns].to_numpy().cumsum(axis=1)  # (cells, outcomes): each stack's tops
    for i, column in enumerate(columns):  # one collection of bars per outcome: a run of many
        # cells and outcomes draws in a fraction of the time of a patch per bar (`ax.bar`)
        low, high = (top[:, i - 1] if i else np.zeros(len(x))), top[:, i]
        corners = np.stack([np.stack([x - 0.4, low], -1), np.stack([x + 0.4, low], -1),
                            np.stack([x + 0.4, high], -1), np.stack([x - 0.4, high], -1)], 1)
        ax.add_collection(PolyCollection(corners, facecolors=[colours[column]],
                                         edgecolors="none", label=column), autolim=False)
    ax.set_xlim(-0.6, len(x) - 0.4)
    ax.set_ylim(0, 100)
    ax.set_xticks(x, shares.index, rotation=90, fontsize=7)
    ax.set_ylabel("share of attempts (%)")
    ax.set_xlabel("setup / object")
    ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return png(fig)


def swept_points(objects: pd.DataFrame, key: str, others: tuple[str, ...] = (),
                 paper=None) -> pd.DataFrame:
    """Per value of the swept column `key` and setup: objects tried (`n`), successes, the
    rate with its 95 % Wilson interval, the first-view and rescued rates, and the paired
    comparison with the paper preset's value (`paper_value`) by world and object (setup, seed,
    trial, object; an unpaired sweep's points share no world: nan): objects this value grasps
    and the paper's does not (`gained`) and the reverse (`lost`), McNemar's z (> 0: this value
    grasps more of the same objects) and exact two-sided p, and the smallest difference of
    rates the pairs resolve at 5 % with 80 % power (`stats.paired_detectable`), and the paired
    difference of rates with its 95 % interval (`difference_vs_paper`, `difference_low`,
    `difference_high`: fractions, `stats.paired_difference`; the paper's value against itself
    has no interval), over `pairs` objects (fewer than `n` where other swept keys must be
    equal in a pair, so the difference is not that of the pooled rates). `others`: the
    grid's other swept columns, held equal in a pair; `paper`: the reference value (default
    `paper_value(key)`)."""
    objects = objects.assign(first_view=objects["success"] * (1 - objects.get("rescued", 0)))
    per = objects.groupby([key, "setup"], dropna=False).agg(
        n=("success", "size"), successes=("success", "sum"),
        first_view=("first_view", "sum")).reset_index()
    per["rate"] = per["successes"] / per["n"]
    per["ci_low"], per["ci_high"] = wilson(per["successes"], per["n"])
    per["rate_first_view"] = per["first_view"] / per["n"]
    per["rate_rescued"] = per["rate"] - per["rate_first_view"]
    paired = ["gained", "lost", "pairs", "z_vs_paper", "p_vs_paper", "detectable_vs_paper",
              "difference_vs_paper", "difference_low", "difference_high"]
    per[paired] = np.nan
    paper = paper_value(key) if paper is None else paper
    if paper is not None and (objects[key] == paper).any():
        pair = ["setup", "seed", "trial", "object", *others]
        reference = objects[objects[key] == paper][[*pair, "success"]]
        joined = objects.merge(reference, on=pair, suffixes=("", "_paper"))
        by = [joined[key], joined["setup"]]
        here, there = joined["success"] > 0, joined["success_paper"] > 0
        counts = pd.DataFrame({"gained": (here & ~there).groupby(by).sum(),
                               "lost": (~here & there).groupby(by).sum(),
                               "pairs": joined.groupby(by).size(),
                               "both": (here & there).groupby(by).sum()})
        discordant = counts["gained"] + counts["lost"]
        changes = list(zip(counts["gained"].astype(int), counts["lost"].astype(int), strict=True))
        counts["z_vs_paper"] = [mcnemar_z(g, lo) for g, lo in changes]
        counts["p_vs_paper"] = [mcnemar_p(g, lo) for g, lo in changes]
        counts["detectable_vs_paper"] = [paired_detectable(int(d), int(n)) for d, n in zip(
            discordant, counts["pairs"], strict=True)]
        neither = counts["pairs"] - counts["both"] - discordant
        (counts["difference_vs_paper"], counts["difference_low"],
         counts["difference_high"]) = paired_difference(counts["both"], counts["gained"],
                                                        counts["lost"], neither)
        per = per.drop(columns=paired).merge(counts.drop(columns="both").reset_index(),
                                              on=[key, "setup"], how="left")
        itself = per[key] == paper  # nothing to resolve against itself
        per.loc[itself, ["detectable_vs_paper", "difference_low", "difference_high"]] = np.nan
    return per.sort_values(["setup", key], kind="stable").reset_index(drop=True)


def sweep_figure(per: pd.DataFrame, key: str, title: str, paper=None):
    """A study's figure: one column of panels per setup (or per panel name in `setup`, as
    `report.studies` names them: "1 g-l"), a bar per swept value (categories, no
    line between them), first view and rescued stacked, the 95 % interval of their sum, the
    paper preset's value (`paper`, default `paper_value(key)`) marked on its tick; where the
    points are paired with the paper's value (`swept_points`' differences), a second row: each
    value's paired difference from it in points, with its 95 % interval (`stats.
    paired_difference`), which shows differences of a point that the rates' scale hides. The
    legend below the panels, over no data."""
    setups = sorted(per["setup"].unique())
    values = per[key].drop_duplicates().tolist()
    wide = max(len(str(v)) for v in values) > 8  # grid points named by several values
    width = max(6.0, 3.4 * len(setups))
    base = 3.9 + (1.2 if wide else 0)
    paired = "difference_low" in per.columns and per["difference_low"].notna().any()
    row = 2.4  # inches the row of differences adds, its panels' height 0.4 less (their gap)
    height = base + (row if paired else 0)
    fig = new_figure(width, height)
    axes = fig.subplots(2 if paired else 1, len(setups), squeeze=False, sharey="row",
                        sharex="col", height_ratios=[base - 1.4, row - 0.4] if paired else None)
    paper = paper_value(key) if paper is None else paper
    for column, setup in enumerate(setups):
        ax = axes[0, column]
        part = per[per["setup"] == setup]
        x = np.arange(len(part))
        ax.bar(x, 100 * part["rate_first_view"], 0.7, color="tab:blue", label="first view")
        ax.bar(x, 100 * part["rate_rescued"], 0.7, bottom=100 * part["rate_first_view"],
               color="tab:purple", label="rescued by a re-alignment")
        ax.errorbar(x, 100 * part["rate"], yerr=100 * np.maximum(0, np.vstack(
            [part["rate"] - part["ci_low"], part["ci_high"] - part["rate"]])), fmt="none",
            ecolor="black", capsize=3, label="95 % interval")
        ax.set_ylim(0, 105)
        ax.set_title(f"Setup {setup} (n = {int(part['n'].min())}"
                     + (f"-{int(part['n'].max())}" if part["n"].nunique() > 1 else "")
                     + " objects per value)", fontsize=9)
        if paired:
            _difference_panel(axes[1, column], part, x)
        values = part[key].tolist()
        ax.set_xlim(-0.6, len(x) - 0.4)  # (shared by the column) a half bar's margin
        bottom = axes[-1, column]
        bottom.set_xticks(x, [f"{v:g}" if isinstance(v, float) else str(v) for v in values],
                          rotation=90 if wide else 0, fontsize=7 if wide else None)
        bottom.set_xlabel(key[len("cfg."):] if key.startswith("cfg.") else key,
                          fontsize=7 if wide else None)
        if paper in values:
            at = values.index(paper)
            bottom.get_xticklabels()[at].set_fontweight("bold")
            for ax in axes[:, column]:
                ax.axvspan(at - 0.45, at + 0.45, color="tab:orange", alpha=0.25, lw=0, zorder=0,
                           label=f"the paper preset's value ({paper:g})"
                           if isinstance(paper, float) else f"the paper preset's value ({paper})")
    axes[0, 0].set_ylabel("grasp success (%)")
    if paired:
        axes[1, 0].set_ylabel("paired difference from\nthe paper's value (points)")
    legend = {}  # every row's entries once, in the order first drawn
    for ax in axes[:, 0]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    fig.suptitle(textwrap.fill(title, int(13 * width)), fontsize=10)  # within the figure's width
    columns = _legend_columns(fig, legend)
    rows = -(-len(legend) // columns)
    below_panels = (0.05 + 0.05 * rows) * (0.8 if wide else 1) * base  # inches for the legend
    fig.tight_layout(rect=(0, below_panels / height, 1, 1))
    fig.legend(list(legend.values()), list(legend), loc="lower center", ncol=columns, fontsize=8,
               frameon=False)
    return fig


def _difference_panel(ax, part: pd.DataFrame, x: np.ndarray) -> None:
    """A setup's row of paired differences (`swept_points`' rows of that setup, at `x`): a bar
    per value from 0 with its 95 % interval, none for the paper's value itself; the number of
    pairs where other swept keys held equal made them fewer than the objects."""
    difference = 100 * part["difference_vs_paper"].where(part["difference_low"].notna())
    ax.bar(x, difference, 0.7, color="tab:gray",
           label="paired difference from the paper preset's value")
    ax.errorbar(x, difference, yerr=100 * np.maximum(0, np.vstack(
        [part["difference_vs_paper"] - part["difference_low"],
         part["difference_high"] - part["difference_vs_paper"]])), fmt="none", ecolor="black",
        capsize=3)
    ax.axhline(0.0, color="black", linewidth=0.8)
    compared = part[part["difference_low"].notna()]
    if compared.empty:  # this setup did not play the paper's value
        ax.text(0.5, 0.5, "no pairs with the paper preset's value", fontsize=8, ha="center",
                va="center", transform=ax.transAxes)
    elif (compared["pairs"] < compared["n"]).any():  # the other keys held equal
        ax.set_title(f"over {int(compared['pairs'].min())}"
                     + (f"-{int(compared['pairs'].max())}" if compared["pairs"].nunique() > 1
                        else "") + " pairs per value (other swept keys equal)", fontsize=8)


def _legend_columns(fig, entries: dict) -> int:
    """The most columns (at most one row's worth of `entries`, label -> handle) whose legend
    fits within the figure's width, as drawn at the size `sweep_figure` draws it."""
    renderer = fig.canvas.get_renderer()
    for columns in range(len(entries), 1, -1):
        trial = fig.legend(list(entries.values()), list(entries), ncol=columns, fontsize=8,
                           frameon=False)
        fits = trial.get_window_extent(renderer).width <= 0.97 * fig.bbox.width
        trial.remove()
        if fits:
            return columns
    return 1


def sweep_outputs(frame: pd.DataFrame, meta: dict | None = None) -> dict[str, bytes]:
    """Success against each swept parameter, per setup (`frame`: the objects' outcomes,
    `tables.object_outcomes`); a heat map for two-parameter grids. `meta`: the run's
    config.json, for the figures' titles."""
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
        per = swept_points(frame, key, tuple(a[0] for a in axes if a is not axis))
        name = key[len("cfg."):]
        out[f"sweep_{name}.csv"] = per.to_csv(index=False).encode()
        title = sweep_title(key, meta, sorted(per["setup"].unique()))
        if len(axes) > 1:
            title += "; other swept keys pooled (paired where they are equal)"
        out[f"sweep_{name}.png"] = png(sweep_figure(per, key, title), laid_out=True)
    if len(axes) > 1:
        out.update(grid_point_outputs(frame, [a[0] for a in axes], meta))
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


def grid_point_outputs(frame: pd.DataFrame, keys: list[str], meta: dict | None) -> dict:
    """`sweep_points.csv/png`: every grid point of a grid over several keys as one category,
    named by its values in the order of `keys` ("centre / anchor / pixel"), compared paired
    with the point where every key takes the paper preset's value, where the grid has it."""
    name = " / ".join(k[len("cfg."):] for k in keys)
    labels = frame[keys].astype(str).agg(" / ".join, axis=1)
    paper = " / ".join(str(paper_value(k)) for k in keys)
    per = swept_points(frame.assign(**{name: labels}), name,
                       paper=paper if (labels == paper).any() else None)
    title = sweep_title(name, meta, sorted(per["setup"].unique()))
    return {"sweep_points.csv": per.to_csv(index=False).encode(),
            "sweep_points.png": png(sweep_figure(per, name, title, paper), laid_out=True)}


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


PLANE_PANELS = (("on_target_surface", "plane on the target (%)", 100, "viridis"),
                ("normal_error_deg", "median normal error (deg)", 1, "magma_r"))


def planes_figure(rows: pd.DataFrame, keys: list[str], title: str):
    """`graspjax planes`' figure from its rows (planes.csv): over the views that re-align (no
    grasp in the first view) whose plane was found, one column of panels per setup, a heat map
    per statistic (the share whose winning plane lies on the target, as `planes.summarize`
    counts it; its normal's median error) over the first two grid keys
    (rows: `keys[0]`, columns: `keys[1]` when there is one), each cell's value written in it,
    the paper preset's cell outlined."""
    rows = rows.assign(**{k: pd.to_numeric(rows[k]) for k in keys})  # traced values: numbers
    realigning = rows[~rows["first_view_grasp"].astype(bool) & rows["plane_found"].astype(bool)
                      & (rows["target"].fillna("") != "")]
    realigning = realigning.assign(on_target_surface=realigning["surface"] == "target")
    setups = sorted(realigning["setup"].unique())
    row_key, column_key = keys[0], keys[1] if len(keys) > 1 else None
    fig = new_figure(3.6 * max(1, len(setups)), 6.4)
    axes = fig.subplots(len(PLANE_PANELS), max(1, len(setups)), squeeze=False)
    for j, setup in enumerate(setups):
        part = realigning[realigning["setup"] == setup]
        for i, (column, label, scale, cmap) in enumerate(PLANE_PANELS):
            ax = axes[i][j]
            group = [row_key] + ([column_key] if column_key else [])
            stat = part.groupby(group)[column].agg("mean" if scale == 100 else "median") * scale
            grid = stat.unstack(column_key) if column_key else stat.to_frame(label)
            image = ax.imshow(grid.to_numpy(float), origin="lower", cmap=cmap, aspect="auto",
                              vmin=0, vmax=100 if scale == 100 else None)
            for (r, c), value in np.ndenumerate(grid.to_numpy(float)):
                red, green, blue, _ = image.cmap(image.norm(value))
                ax.text(c, r, f"{value:.0f}" if scale == 100 else f"{value:.1f}", ha="center",
                        va="center", fontsize=7,  # dark text on light cells, light on dark
                        color="black" if 0.3 * red + 0.6 * green + 0.1 * blue > 0.5 else "white")
            ax.set_yticks(np.arange(len(grid.index)), [f"{v:g}" for v in grid.index])
            ax.set_xticks(np.arange(len(grid.columns)),
                          [f"{v:g}" for v in grid.columns] if column_key else [""])
            paper_row = _index_of(grid.index, paper_value(f"cfg.{row_key}"))
            paper_column = _index_of(grid.columns, paper_value(f"cfg.{column_key}")) \
                if column_key else 0
            if paper_row is not None and paper_column is not None:
                ax.add_patch(Rectangle((paper_column - 0.5, paper_row - 0.5), 1, 1, fill=False,
                                       ec="tab:orange", lw=2.5))
            views = len(part) // max(1, part["point"].nunique())
            ax.set_title(f"Setup {setup}: {label}\n({views} views per cell)", fontsize=8)
            ax.set_ylabel(row_key)
            if column_key:
                ax.set_xlabel(column_key)
            fig.colorbar(image, ax=ax, shrink=0.8)
    fig.suptitle(textwrap.fill(title + "; outlined: the paper preset's values", 120), fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    return fig


def _index_of(values, value):
    """Position of `value` among `values` (floats compared to 1e-9), None where absent."""
    if value is None:
        return None
    for i, v in enumerate(values):
        if isinstance(v, (int, float, np.number)) and abs(float(v) - float(value)) < 1e-9:
            return i
    return None
