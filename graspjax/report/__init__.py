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
  grids, `sweep_heatmap.png`; grids over several keys, `sweep_points.csv/png` (every grid
  point against the paper preset's).
- A plane study's folder (`graspjax planes`: planes.csv.gz): `planes_summary.csv` and
  `planes.png`.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from graspjax.config import Config, override
from graspjax.figures import png
from graspjax.report.density import consistency_lines, target_clutter_lines
from graspjax.report.files import (
    load_attempts,
    load_rounds,
    parse_attempts,
    planned_worlds,
    played_worlds,
    read_meta,
    run_state,
)
from graspjax.report.tables import (
    TABLE_OBJECTS,
    clutter_summary,
    comparison_markdown,
    layout_lines,
    markdown,
    object_outcomes,
    paper_tables,
    point_labels,
    point_order,
    shared_layouts,
    summarize,
    sweep_axes,
    table_latex,
    table_markdown,
    varying_config,
)

__all__ = [
    "TABLE_OBJECTS", "build", "clutter_summary", "comparison_markdown", "debug_figures",
    "layout_lines", "load_attempts", "load_rounds", "markdown", "object_outcomes",
    "paper_tables", "parse_attempts", "planned_worlds", "played_worlds", "point_config",
    "point_labels", "point_order", "run_state", "shared_layouts", "summarize", "sweep_axes",
    "table_latex", "table_markdown", "varying_config", "write_report",
]


def build(frame: pd.DataFrame, rounds: pd.DataFrame | None = None,
          state: str = "", meta: dict | None = None) -> dict[str, bytes]:
    """Every report file (name -> bytes) from the attempt rows (and the round rows); `state`
    ("unfinished: n of N worlds", `run_state`) goes into every table's title, `meta` (the
    run's config.json: preset, trials, pairing) into a sweep figure's."""
    # (here, not at the top: the figures read the settings with this package's `tables`)
    from graspjax.figures.report import comparison_figure, outcomes_figure, success_figure, sweep_outputs

    objects = object_outcomes(frame)  # the tables count objects per round, as the paper's
    summary = summarize(objects)
    files = {"summary.csv": summary.to_csv(index=False).encode()}
    if not varying_config(frame):
        for table in (1, 2):
            if summary["object"].isin(TABLE_OBJECTS[table]).any():
                text = table_markdown(summary, table, state)
                if table == 1:
                    lines = (layout_lines(rounds) + target_clutter_lines(frame)
                             + consistency_lines(objects))
                    text += "".join(f"{line}\n" for line in lines)
                files[f"table{table}.md"] = text.encode()
                files[f"table{table}.tex"] = table_latex(summary, table, state).encode()
        files["success_by_object.png"] = png(success_figure(summary, meta), laid_out=True)
    files["outcomes.png"] = outcomes_figure(frame)  # every attempt
    files.update(sweep_outputs(objects, meta))
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


def write_report(folder: str | Path, debug: int = 0,
                 rows: tuple[pd.DataFrame, pd.DataFrame | None] | None = None
                 ) -> tuple[list[Path], str]:
    """Rebuild every table and figure of a run or sweep folder from its attempts.csv; with
    `debug`, also draw the first `debug` saved attempts (views/*.npz) into debug/. `rows`: the
    attempt and round rows as `load_attempts` and `load_rounds` would read them, held by the
    run that just wrote them (`outputs.RunFolder.report_rows`; None: read the files). Returns
    the files written and the run's state (`run_state`: "" when finished)."""
    from graspjax.disk import write_atomic

    folder = Path(folder)
    if not (folder / "attempts.csv").exists() and (folder / "planes.csv.gz").exists():
        files = plane_outputs(pd.read_csv(folder / "planes.csv.gz", keep_default_na=False,
                                          na_values=[""]), read_meta(folder))
        for name, data in files.items():
            write_atomic(folder / name, data)
        return [folder / name for name in files], ""
    frame, rounds = rows if rows is not None else (load_attempts(folder), load_rounds(folder))
    state = run_state(folder, frame)
    files = build(frame, rounds, state, read_meta(folder))
    if state and read_meta(folder).get("finished"):  # the run finished meanwhile: report its whole rows
        return write_report(folder, debug)
    if debug:
        files.update(debug_figures(folder, debug))
    for name, data in files.items():
        (folder / name).parent.mkdir(exist_ok=True)
        write_atomic(folder / name, data)
    return [folder / name for name in files], state


def plane_outputs(rows: pd.DataFrame, meta: dict) -> dict[str, bytes]:
    """A plane study's tables and figure from its rows (planes.csv) and config.json:
    planes_summary.csv (`planes.summarize`) and planes.png (`figures.planes_figure`)."""
    from graspjax.figures.report import planes_figure
    from graspjax.figures.titles import planes_title
    from graspjax.planes import summarize

    grid = meta.get("grid", {})
    summary = summarize(rows, grid)
    return {"planes_summary.csv": summary.to_csv(index=False).encode(),
            "planes.png": png(planes_figure(rows, list(grid), planes_title(meta)), laid_out=True)}


def debug_figures(folder: Path, count: int) -> dict[str, bytes]:
    """The first `count` saved attempts of a run, drawn (name -> PNG bytes), each with the
    configuration of its own grid point."""
    import json

    from graspjax.figures.views import attempt_figure
    from graspjax.saved_views import load, point_of

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
