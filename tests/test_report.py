"""Tables and figures from hand-made attempt rows with known counts."""

import io

import numpy as np
import pandas as pd
import pytest

from graspjax.report import (
    build,
    object_outcomes,
    paper_tables,
    parse_attempts,
    summarize,
    sweep_axes,
)
from graspjax.schema import STUDY_OMITS
from graspjax.stats import wilson


def test_wilson_interval_known_values():
    # Reference values of the 95% Wilson score interval (z = 1.96).
    low, high = wilson(9, 10)
    assert (low, high) == pytest.approx((0.5958, 0.9821), abs=1e-4)
    assert wilson(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)
    assert wilson(50, 100) == pytest.approx((0.4038, 0.5962), abs=1e-4)


def test_paper_tables_are_the_published_numbers():
    paper = paper_tables()
    assert len(paper) == 24 and (paper["trials"] == 10).all()
    cell = paper.set_index(["setup", "object"])["success_pct"]
    assert (cell[(1, "a")], cell[(3, "d")], cell[(1, "h")]) == (90, 50, 30)


def _frame(cells, extra=None):
    """Attempt rows: cells = {(setup, object): (successes, n)}."""
    rows = []
    for (setup, obj), (k, n) in cells.items():
        for t in range(n):
            rows.append({"setup": setup, "object": obj, "trial": t, "round": t, "seed": 0,
                         "success": int(t < k), "outcome": "SUCCESS" if t < k else "MISSED",
                         "reason": "SUCCESS" if t < k else "MISSED", **(extra or {})})
    return pd.DataFrame(rows)


def test_a_study_figure_names_its_preset_and_marks_the_papers_value():
    """A paired window study (5, 15, 25 px) on the same objects: the figure's title names the
    preset, setups, trials and pairing, the paper's 15 px is marked, a panel per setup shows
    first view and rescued stacked; McNemar's z against 15 px by hand."""
    from graspjax.figures.report import sweep_figure, sweep_outputs, swept_points
    from graspjax.figures.titles import sweep_title
    from graspjax.stats import paired_difference

    parts = []
    # Setup 1, object a, 10 trials: successes and rescues per window, same worlds (seed 0).
    for window, success, rescued in ((5, [1] * 6 + [0] * 4, [0] * 10),
                                     (15, [1] * 8 + [0] * 2, [1] * 2 + [0] * 8),
                                     (25, [1] * 5 + [0] * 3 + [1] * 2, [0] * 10)):
        part = _frame({(1, "a"): (0, 10), (3, "a"): (5, 10)})
        part.loc[part["setup"] == 1, "success"] = success
        part["rescued"] = 0
        part.loc[part["setup"] == 1, "rescued"] = rescued
        part["cfg.align.window_px"] = window
        parts.append(part)
    objects = object_outcomes(pd.concat(parts, ignore_index=True))
    per = swept_points(objects, "cfg.align.window_px").set_index(["setup", "cfg.align.window_px"])
    # 5 px against 15 px: trials 6, 7 lost, none gained: z = -2/sqrt(2); 25 px: trials 8, 9
    # gained, 5, 6, 7 lost: z = -1/sqrt(5); 15 px against itself: 0.
    assert per.loc[(1, 5), "z_vs_paper"] == pytest.approx(-2 / np.sqrt(2))
    assert per.loc[(1, 25), "z_vs_paper"] == pytest.approx(-1 / np.sqrt(5))
    assert per.loc[(1, 15), "z_vs_paper"] == 0 and per.loc[(3, 5), "z_vs_paper"] == 0
    assert per.loc[(1, 25), ["gained", "lost"]].tolist() == [2, 3]
    # exact McNemar: 2 of 5 discordant pairs, two-sided: 2 (1 + 5 + 10) / 32 = 1.0
    assert per.loc[(1, 25), "p_vs_paper"] == pytest.approx(1.0)
    assert per.loc[(1, 5), "p_vs_paper"] == pytest.approx(0.5)  # 0 of 2: 2 / 4
    # resolvable at 5 % with 80 % power: 2.8 sqrt(p_d / n), p_d = 5 / 10 discordant
    assert per.loc[(1, 25), "detectable_vs_paper"] == pytest.approx(2.8 * np.sqrt(0.5 / 10))
    assert per.loc[(1, 15), ["rate_first_view", "rate_rescued"]].tolist() == pytest.approx([0.6, 0.2])
    meta = {"preset": "paper", "paired": True, "jobs": [{"trials": 10, "setups": [1, 3]}]}
    title = sweep_title("cfg.align.window_px", meta, [1, 3])
    assert title == "align.window_px, paper preset, Setups 1, 3, 10 trials per cell, paired"
    sloped = sweep_title("cfg.align.window_px", {**meta, "overrides": {"procedure.view_tilt_deg": 30.0}},
                         [1, 3])
    assert sloped.startswith("align.window_px, paper preset (procedure.view_tilt_deg=30.0), Setups")
    # the objects, where the run played some of the twelve (Table 2's in Setup 1, or three)
    table_2 = {**meta, "jobs": [{"trials": 600, "setups": [1], "objects": list("ghijkl")}]}
    assert (sweep_title("cfg.align.window_px", table_2, [1])
            == "align.window_px, paper preset, Setup 1, objects g-l, 600 trials per cell, paired")
    some = {**meta, "jobs": [{"trials": 10, "setups": [1], "objects": ["d", "a", "b"]}]}
    assert "Setup 1, objects a, b, d, 10 trials" in sweep_title("cfg.align.window_px", some, [1])
    tables = {**meta, "jobs": [{"trials": 10, "setups": [1, 2, 3], "objects": list("abcdef")},
                               {"trials": 10, "setups": [1], "objects": list("ghijkl")}]}
    assert "objects" not in sweep_title("cfg.align.window_px", tables, [1, 2, 3])
    # the paired difference from 15 px, per setup: 5 px, Setup 1: 6 pairs both succeed, none
    # gained, 2 lost, 2 neither: -20 points; Setup 3 (every point alike): 0
    assert per.loc[(1, 5), "difference_vs_paper"] == pytest.approx(-0.2)
    assert per.loc[(1, 25), "difference_vs_paper"] == pytest.approx(-0.1)
    assert (per.loc[(1, 5), ["difference_low", "difference_high"]].tolist()
            == pytest.approx(list(paired_difference(6, 0, 2, 2)[1:])))
    assert np.isnan(per.loc[(1, 15), "difference_low"])  # 15 px against itself: no interval
    fig = sweep_figure(per.reset_index(), "cfg.align.window_px", title)
    assert fig._suptitle.get_text() == title
    rates, differences = fig.axes[:2], fig.axes[2:]  # a row of rates, a row of differences
    assert [ax.get_title().split(" (")[0] for ax in rates] == ["Setup 1", "Setup 3"]
    for ax in differences:
        ticks = [t.get_text() for t in ax.get_xticklabels()]
        assert ticks == ["5", "15", "25"]
        assert ax.get_xticklabels()[1].get_fontweight() == "bold"  # the paper's 15 px
    bars = [round(p.get_height(), 6) for p in differences[0].patches if p.get_width() == 0.7]
    assert bars[0] == pytest.approx(-20) and np.isnan(bars[1]) and bars[2] == pytest.approx(-10)
    for ax in fig.axes:
        lines = [line for line in ax.get_lines() if line.get_linestyle() != "None"]  # caps
        # alone, and in a row of differences its zero: no line from one category to the next
        assert all(list(line.get_ydata()) == [0, 0] for line in lines)
        assert len(lines) == (ax in differences)
        assert ax.get_legend() is None  # the legend sits below the panels, over no data
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert sorted(labels) == ["95 % interval", "first view",
                              "paired difference from the paper preset's value",
                              "rescued by a re-alignment", "the paper preset's value (15)"]
    # points that share no world (an unpaired sweep): no differences, one row of rates
    unpaired = per.reset_index().assign(difference_low=np.nan, difference_high=np.nan)
    assert len(sweep_figure(unpaired, "cfg.align.window_px", title).axes) == 2
    # one setup, a long title: the title and the legend stay inside the narrower figure
    one = per.reset_index()
    fig = sweep_figure(one[one["setup"] == 1], "cfg.align.window_px", sloped + ", 1500 trials")
    fig.canvas.draw()
    for artist in (fig._suptitle, fig.legends[0]):
        box = artist.get_window_extent()
        assert 0 <= box.x0 and box.x1 <= fig.bbox.width and 0 <= box.y0 and box.y1 <= fig.bbox.height
    files = sweep_outputs(objects, meta)
    assert files["sweep_align.window_px.png"][:8] == b"\x89PNG\r\n\x1a\n"
    assert "z_vs_paper" in files["sweep_align.window_px.csv"].decode().splitlines()[0]


def test_table_cells_put_ours_beside_the_paper():
    frame = _frame({(1, "a"): (9, 10), (1, "b"): (6, 10), (3, "a"): (5, 10), (1, "g"): (0, 4)})
    files = build(parse_attempts(frame.to_csv(index=False)))
    table1 = files["table1.md"].decode()
    assert "| Setup 1, ours | 90 % [60-98] | 60 % [31-83] |" in table1
    assert "| Setup 1, paper | 90 % | 60 % |" in table1
    assert "| Setup 3, ours | 50 % [24-76] |" in table1
    assert "| Setup 1, n | 10 | 10 |" in table1
    table2 = files["table2.md"].decode()
    assert "| Setup 1, ours | 0 % [0-49] |" in table2 and "| Setup 1, paper | 60 % |" in table2
    assert "90 \\% [60-98]" in files["table1.tex"].decode()
    for name in ("summary.csv", "success_by_object.png", "outcomes.png"):
        assert files[name]
    summary = summarize(frame).set_index(["setup", "object"])
    assert summary.loc[(1, "b"), "n_missed"] == 4 and summary.loc[(1, "b"), "paper_pct"] == 60


def test_the_success_figure_names_the_run_and_keeps_its_legend_off_the_bars():
    """One panel per table and setup, the run's preset, setups and trials in the title, and
    one legend for every panel below them: no legend inside a panel, none over an axes."""
    from graspjax.figures.report import success_figure

    frame = _frame({(1, "a"): (9, 10), (1, "b"): (1, 10), (3, "a"): (5, 10), (1, "g"): (0, 4)})
    meta = {"preset": "paper", "jobs": [{"trials": 10}]}
    fig = success_figure(summarize(object_outcomes(parse_attempts(frame.to_csv(index=False)))), meta)
    assert fig._suptitle.get_text() == ("grasp success per object: paper preset, Setups 1, 3, "
                                        "10 trials per cell")
    assert [ax.get_title() for ax in fig.axes] == ["Setup 1, objects a-b", "Setup 3, objects a-a",
                                                   "Setup 1, objects g-g"]
    assert all(ax.get_legend() is None for ax in fig.axes)
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["ours (95% CI)", "paper (10 trials)"]
    fig.canvas.draw()
    box = legend.get_window_extent()
    assert 0 <= box.x0 and box.x1 <= fig.bbox.width and 0 <= box.y0
    assert all(not box.overlaps(ax.get_window_extent()) for ax in fig.axes)


def test_sweeps_group_by_the_varying_configuration():
    parts = []
    for window, k in ((5, 2), (15, 8), (25, 5)):
        part = _frame({(1, "a"): (k, 10), (2, "a"): (k // 2, 10)})
        part["cfg.align.window_px"] = window
        part["cfg.camera.width"] = 8 * window  # varies together with the window: one axis
        part["cfg.align.distance_threshold"] = 0.3  # constant: not a sweep key
        parts.append(part)
    frame = pd.concat(parts, ignore_index=True)
    assert sweep_axes(frame) == [["cfg.align.window_px", "cfg.camera.width"]]
    files = build(frame)
    assert "table1.md" not in files  # grid points are not pooled into the paper's tables
    sweep = pd.read_csv(pd.io.common.BytesIO(files["sweep_summary.csv"]))
    row = sweep[(sweep["cfg.align.window_px"] == 15) & (sweep["setup"] == 1)].iloc[0]
    assert (row.n, row.successes) == (10, 8)
    assert "sweep_align.window_px.png" in files and "sweep_heatmap.png" not in files
    frame["cfg.align.distance_threshold"] = np.tile([0.1, 0.5], len(frame) // 2)
    assert "sweep_heatmap.png" in build(frame)


def test_parse_attempts_checks_columns():
    with pytest.raises(ValueError, match="lacks columns: success"):
        parse_attempts("setup,object,trial,round,seed,outcome,reason\n1,a,0,0,0,MISSED,x\n")


def test_gzipped_attempts_give_the_same_report(tmp_path):
    """Large reference runs keep attempts.csv gzipped (the studies as Parquet); the report reads
    every form."""
    import gzip

    from graspjax.report import load_attempts, write_report

    text = _frame({(1, "a"): (7, 10), (2, "c"): (3, 10)}).to_csv(index=False)
    plain, packed = tmp_path / "plain", tmp_path / "packed"
    plain.mkdir()
    packed.mkdir()
    (plain / "attempts.csv").write_text(text)
    (packed / "attempts.csv.gz").write_bytes(gzip.compress(text.encode()))
    pd.testing.assert_frame_equal(load_attempts(plain), load_attempts(packed))
    parquet = tmp_path / "parquet"  # the committed studies keep their rows as Parquet
    parquet.mkdir()
    load_attempts(plain).to_parquet(parquet / "attempts.parquet", index=False)
    pd.testing.assert_frame_equal(load_attempts(plain), load_attempts(parquet))
    write_report(packed)
    assert (packed / "table1.md").read_text() == build(parse_attempts(text))["table1.md"].decode()
    with pytest.raises(FileNotFoundError, match="no attempts.csv"):
        load_attempts(tmp_path)


def test_rows_kept_as_compact_parquet_read_back_as_the_csv_and_give_the_same_report(tmp_path):
    """`keep_attempts` on a copy of the committed 10-trial run: the CSV goes, every measured
    float reads back as the CSV's text (7 significant digits), settings stay exact, and the
    report rebuilt from the Parquet equals the committed one byte for byte."""
    import shutil
    from pathlib import Path

    from graspjax.report import load_attempts, write_report
    from graspjax.report.files import keep_attempts

    reference = Path(__file__).parents[1] / "results" / "paper_cpu_10"
    copy = tmp_path / "copy"
    shutil.copytree(reference, copy)
    csv = load_attempts(copy)
    keep_attempts(copy)
    assert not (copy / "attempts.csv").exists()
    kept = load_attempts(copy)
    assert list(kept.columns) == list(csv.columns) and len(kept) == len(csv)
    for column in csv.columns:
        if csv[column].dtype == np.float64:
            as_text = [f"{v:.7g}" for v in kept[column].astype(np.float64)]
            assert as_text == [f"{v:.7g}" for v in csv[column]], column
        else:
            pd.testing.assert_series_equal(kept[column], csv[column], check_dtype=False)
    assert all(kept[c].dtype == csv[c].dtype for c in csv.columns if c.startswith("cfg."))
    report = ("summary.csv", "table1.md", "table2.md", "success_by_object.png", "outcomes.png")
    for name in report:
        (copy / name).unlink()
    write_report(copy)
    for name in report:
        assert (copy / name).read_bytes() == (reference / name).read_bytes(), name


@pytest.mark.parametrize("study", ["realign_gpu_300", "window_sloped_setup3_gpu_1800"])
def test_a_committed_study_s_report_rebuilds_from_rows_without_what_it_never_reads(tmp_path,
                                                                                   study):
    """A parameter study keeps its rows without `schema.STUDY_OMITS` (`keep_attempts(omit=...)`):
    its tables and figures rebuild from those rows byte for byte (a report that read one of them
    would fail here), and keeping them again without those columns changes no value."""
    import shutil
    from pathlib import Path

    from graspjax.report import load_attempts, write_report
    from graspjax.report.files import keep_attempts

    reference = Path(__file__).parents[1] / "results" / "studies" / study
    copy = tmp_path / study
    shutil.copytree(reference, copy)
    rows = load_attempts(copy)
    assert not set(STUDY_OMITS) & set(rows.columns)
    keep_attempts(copy, STUDY_OMITS)
    pd.testing.assert_frame_equal(load_attempts(copy), rows)
    written = [p.name for p in write_report(copy)[0]]
    assert "outcomes.png" in written and any(n.startswith("sweep_") for n in written)
    for name in written:
        assert (copy / name).read_bytes() == (reference / name).read_bytes(), name


def test_kept_rows_are_stored_world_major_and_read_back_in_the_canonical_order(tmp_path):
    """A two-point sweep's rows: the Parquet holds each attempt's points side by side (where
    they repeat), `load_attempts` gives them back point by point, as written."""
    from graspjax.report import load_attempts
    from graspjax.report.files import keep_attempts

    points = [_frame({(1, "a"): (3, 4), (1, "b"): (2, 4)}, {"point": p, "attempt": 0,
                                                          "rise_m": 0.1 * p}) for p in (0, 1)]
    frame = pd.concat(points, ignore_index=True)  # canonical: point, setup, trial, ..., object
    frame = frame.sort_values(["point", "setup", "trial", "object"], ignore_index=True)
    frame.to_csv(tmp_path / "attempts.csv", index=False)
    keep_attempts(tmp_path)
    stored = pd.read_parquet(tmp_path / "attempts.parquet")
    assert stored["point"].tolist()[:4] == [0, 1, 0, 1]  # trial 0: a at both points, then b
    assert stored[["trial", "object"]].iloc[:4].values.tolist() == [[0, "a"], [0, "a"],
                                                                     [0, "b"], [0, "b"]]
    back = load_attempts(tmp_path)
    pd.testing.assert_frame_equal(back, frame, check_dtype=False)


def test_a_damaged_or_non_numeric_attempts_file_is_one_line_naming_it(tmp_path, capsys):
    """A gzip file that is not one or is cut short, bytes that are not text, and a column the
    report counts with that holds words: one line naming the file, exit 2, nothing written."""
    import gzip

    from graspjax.cli import main

    text = _frame({(1, "a"): (7, 10)}).to_csv(index=False)
    packed = gzip.compress(text.encode())
    cases = [("attempts.csv.gz", b"not gzip", "is not a whole gzip file: Not a gzipped file"),
             ("attempts.csv.gz", packed[:len(packed) // 2], "is not a whole gzip file"),
             ("attempts.csv.gz", gzip.compress(b"\xff\xfe"), "is not UTF-8 text (byte 0"),
             ("attempts.csv", text.replace(",1,SUCCESS", ",yes,SUCCESS", 1).encode(),
              "success must be 0 or 1, row "),
             ("attempts.csv", text.replace("\n1,", "\nx,", 1).encode(),
              "setup must be a number, row 1 has 'x'"),
             ("attempts.parquet", b"PAR1 cut", "is not a whole Parquet file"),
             ("attempts.csv", "".join(line.replace("\n", ",1,2\n") if i == 2 else line for i, line
                                      in enumerate(text.splitlines(True))).encode(),  # a long row
              "is not a whole CSV table (Error tokenizing data. C error: Expected ")]
    for i, (name, data, message) in enumerate(cases):
        folder = tmp_path / str(i)
        folder.mkdir()
        (folder / name).write_bytes(data)
        assert main(["report", str(folder)]) == 2
        err = capsys.readouterr().err
        assert f"{folder / name}" in err and message in err, err
        assert err.count("\n") == 1 and "Traceback" not in err
        assert [p.name for p in folder.iterdir()] == [name]


def test_debug_figures_use_each_grid_points_own_configuration():
    """A sweep's saved attempt is drawn with its grid point's values, over the run's overrides
    (config.json as the CLI writes it; the file stem names the point)."""
    from types import SimpleNamespace

    from graspjax.report import point_config
    from graspjax.saved_views import attempt_name, point_of

    meta = {"overrides": {"camera.sensor": "kinect", "align.window_px": 20},
            "grid": {"align.window_px": ["5", "10", "30"],
                     "align.distance_threshold": ["0.1", "0.3", "0.9"]}}
    third = point_config(meta, 2)
    assert (third.align.window_px, third.align.distance_threshold) == (30, 0.9)
    assert third.camera.sensor == "kinect"
    plain = point_config({"overrides": {"align.window_px": 20}, "grid": {}}, 0)
    assert plain.align.window_px == 20
    row = SimpleNamespace(point=12, setup=2, trial=3, attempt=1, object="b")
    assert point_of(attempt_name(row)) == 12


def test_summary_and_tables_split_success_into_first_view_and_rescued():
    """Cell (1, a): 10 attempts, 4 re-aligned, 3 of them rescued, 5 first-view successes."""
    rows = []
    for t in range(10):
        realigned, success = t < 4, t < 3 or 4 <= t < 9
        rows.append({"setup": 1, "object": "a", "trial": t, "round": t, "seed": 0,
                     "success": int(success), "outcome": "SUCCESS" if success else "MISSED",
                     "reason": "SUCCESS" if success else "MISSED",
                     "reorientations": int(realigned), "rescued": int(realigned and success)})
    frame = pd.DataFrame(rows)
    row = summarize(frame).set_index(["setup", "object"]).loc[(1, "a")]
    assert (row["successes"], row["rescued"], row["first_view_successes"]) == (8, 3, 5)
    assert row["rate_rescued"] == pytest.approx(0.3) and row["rate_first_view"] == pytest.approx(0.5)
    assert row["rescue_rate"] == pytest.approx(0.75)
    table1 = build(parse_attempts(frame.to_csv(index=False)))["table1.md"].decode()
    assert "| Setup 1, of which rescued | 30 % |" in table1


def test_an_object_tried_twice_in_a_round_counts_once():
    """A failed object left in the scene may be tried again: the paper's tables count objects
    per round, so a round where its second attempt lifted it is one success, n = 1."""
    rows = [(0, "a", 0, 0, "MISSED"), (0, "a", 2, 1, "SUCCESS"), (0, "b", 1, 0, "SLIPPED"),
            (0, "b", 3, 0, "MISSED"), (1, "a", 0, 1, "SUCCESS"), (1, "b", -1, 0, "NOT_EXECUTED")]
    frame = pd.DataFrame([{"setup": 2, "trial": t, "round": t, "object": o, "attempt": k,
                           "seed": 0, "success": s, "outcome": out, "reason": out}
                          for t, o, k, s, out in rows])
    summary = summarize(object_outcomes(frame)).set_index("object")
    assert summary.loc["a", ["n", "successes"]].tolist() == [2, 2]
    assert summary.loc["b", ["n", "successes"]].tolist() == [2, 0]
    assert summary.loc["b", "n_slipped"] == 1  # its first attempt's outcome


def test_a_report_checks_its_rows_and_says_when_the_run_is_unfinished(tmp_path, capsys):
    """Complete rows of one run only; a run not finished is reported with "unfinished: n of N
    worlds" in every table's title, and a finished run's file that lacks worlds is refused."""
    import json

    from graspjax.cli import main

    run = "1234e56789"  # a run id pandas would read as a number (inf)
    meta = {"run_id": run, "jobs": [{"objects": ["a", "c"], "setups": [1], "trials": 3}],
            "points": 1, "versions": {"graspjax": "0.1.0"}}
    (tmp_path / "config.json").write_text(json.dumps(meta))
    some = _frame({(1, "a"): (2, 3)}, {"run_id": run, "point": 0})  # 3 of the run's 6 worlds
    every = _frame({(1, "a"): (2, 3), (1, "c"): (1, 3)}, {"run_id": run, "point": 0})

    def report(frame, text=None):
        (tmp_path / "attempts.csv").write_text(frame.to_csv(index=False) if text is None else text)
        code = main(["report", str(tmp_path)])
        return code, capsys.readouterr().err

    code, err = report(some)
    assert code == 0 and "unfinished: 3 of 6 worlds" in err
    assert (tmp_path / "table1.md").read_text().startswith(
        "# Table 1: grasp success in Setups 1-3, objects a-f (unfinished: 3 of 6 worlds)")
    assert "unfinished: 3 of 6 worlds" in (tmp_path / "table1.tex").read_text()
    text = every.to_csv(index=False)
    code, err = report(every, text[:-7])  # cut mid-row
    assert code == 2 and "ends in an incomplete row" in err and len(err.splitlines()) == 1
    code, err = report(pd.concat([some, every.assign(run_id="r2")]))
    assert code == 2 and f"mixes the rows of 2 runs (run_id {run}, r2)" in err
    code, err = report(every.assign(run_id="r2"))
    assert code == 2 and f"rows of run r2, config.json describes run {run}" in err
    code, err = report(some, "")  # before the first chunk
    assert code == 2 and "has no attempts yet" in err
    (tmp_path / "config.json").write_text(json.dumps({**meta, "finished": "2026-11-27"}))
    code, err = report(some)  # cut at a row's end: the rows look whole, the worlds are not
    assert code == 2 and "holds 3 of the run's 6 worlds though the run finished" in err
    code, err = report(every)
    assert code == 0 and err == ""
    assert "unfinished" not in (tmp_path / "table1.md").read_text()


def test_a_sweeps_comparison_says_in_how_many_rounds_every_point_settled_the_same_layout():
    """Hand-made rounds: Setup 2's two rounds settle alike at both points, Setup 3's second
    round differs in one statistic."""
    from graspjax.report import shared_layouts

    rows = []
    for point in (0, 1):
        for setup in (2, 3):
            for rnd in (0, 1):
                spread = 0.2 + (0.01 * point if (setup, rnd) == (3, 1) else 0.0)
                rows.append({"point": point, "setup": setup, "round": rnd, "touching_fraction": 0.5,
                             "near_fraction": 0.5, "stacked": 1, "min_face_gap_m": 0.01,
                             "spread_m": spread})
    lines = shared_layouts(pd.DataFrame(rows))
    assert lines[-2:] == ["- Setup 2: 2 of 2 rounds", "- Setup 3: 1 of 2 rounds"]
    assert shared_layouts(pd.DataFrame(rows)[lambda r: r.point == 0]) == []  # one point: nothing


def test_rounds_are_read_gzipped_as_committed_results_keep_them(tmp_path):
    """`load_rounds` reads `rounds.csv`, else `rounds.csv.gz`; neither: None."""
    from graspjax.report import load_rounds

    assert load_rounds(tmp_path) is None
    frame = pd.DataFrame({"point": [0, 0], "setup": [3, 3], "round": [0, 1],
                          "touching_fraction": [0.5, 1 / 3]})
    frame.to_csv(tmp_path / "rounds.csv.gz", index=False)
    pd.testing.assert_frame_equal(load_rounds(tmp_path), frame)


def test_report_runs_without_the_simulator(tmp_path):
    """`graspjax report` reads a run's files with mujoco blocked: it imports neither MuJoCo nor
    the simulator's modules (the columns and labels come from `schema.py` and `codes.py`)."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    reference = Path(__file__).parent.parent / "results" / "paper_cpu_10"
    for name in ("attempts.csv", "rounds.csv.gz", "config.json", "timings.csv"):
        shutil.copy(reference / name, tmp_path / name)
    script = ("import sys; sys.modules['mujoco'] = None; from graspjax.cli import main; code = main("
              f"['report', {str(tmp_path)!r}]); loaded = sorted(m for m, module in sys.modules.items() "
              "if module is not None and m.startswith(('graspjax.sim', 'graspjax.batch', "
              "'graspjax.procedure', 'mujoco'))); "
              "print('LOADED', loaded); sys.exit(code)")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "LOADED []" in done.stdout
    assert "| Setup 1, ours |" in (tmp_path / "table1.md").read_text()


def test_a_grid_of_several_keys_is_compared_point_by_point_with_the_papers_point():
    """A readings grid (anchor, turn) of three points on the same 10 worlds: every point
    against the paper's (nearest, pixel) by hand; the anchor's own file pairs centre with
    nearest only where the turn is the same (pixel), never across turns."""
    from graspjax.figures.report import grid_point_outputs, swept_points

    parts = []
    for anchor, turn, success in (("nearest", "pixel", [1] * 8 + [0] * 2),
                                  ("centre", "pixel", [1] * 6 + [0] * 2 + [1] * 2),
                                  ("centre", "metric", [1] * 10)):
        part = _frame({(1, "a"): (0, 10)})
        part["success"] = success
        part["rescued"] = 0
        part["cfg.align.anchor"], part["cfg.align.turn_normal"] = anchor, turn
        parts.append(part)
    objects = object_outcomes(pd.concat(parts, ignore_index=True))
    files = grid_point_outputs(objects, ["cfg.align.anchor", "cfg.align.turn_normal"],
                               {"preset": "paper"})
    per = pd.read_csv(io.BytesIO(files["sweep_points.csv"])).set_index(
        "align.anchor / align.turn_normal")
    assert per.loc["nearest / pixel", ["gained", "lost"]].tolist() == [0, 0]  # the paper's
    # centre/pixel: trials 8, 9 gained, 6, 7 lost; centre/metric: 8, 9 gained
    assert per.loc["centre / pixel", ["gained", "lost"]].tolist() == [2, 2]
    assert per.loc["centre / metric", ["gained", "lost"]].tolist() == [2, 0]
    anchor = swept_points(objects, "cfg.align.anchor", ("cfg.align.turn_normal",)).set_index(
        "cfg.align.anchor")
    assert anchor.loc["centre", ["gained", "lost"]].tolist() == [2, 2]  # pixel pairs alone
    # ... so its difference (0 of 10 pairs) is not that of the pooled rates (18 of 20 centre
    # grasps against 8 of 10), and the figure's row of differences says over how many pairs
    assert anchor.loc["centre", ["n", "pairs", "difference_vs_paper"]].tolist() == [20, 10, 0]
    from graspjax.figures.report import sweep_figure

    fig = sweep_figure(anchor.reset_index(), "cfg.align.anchor", "anchor")
    assert fig.axes[1].get_title() == "over 10 pairs per value (other swept keys equal)"
    assert files["sweep_points.png"][:8] == b"\x89PNG\r\n\x1a\n"


def test_a_study_run_cell_by_cell_is_drawn_as_one_figure():
    """Parts of one window study, each run at its own trials (15 px and 5 px on the same
    worlds): Setup 1 with objects a and b at 10 trials, Setup 1 with g at 20, and Setups 2
    and 3 with a-f at 5: a panel per setup and object set, named by both, with the objects and
    the paired differences of its own part, in the order of the setups; parts that sweep
    another key, run under other settings or play the same panel again are refused."""
    from graspjax.report.studies import study_points

    def part(cells, trials, won_at_5):
        frames = []
        for window in (15, 5):
            frame = _frame(cells).assign(**{"cfg.align.window_px": window, "rescued": 0})
            if window == 5:  # the first `won_at_5` failures of each cell succeed at 5 px
                for _, rows in frame.groupby(["setup", "object"]):
                    failed = rows.index[rows["success"] == 0][:won_at_5]
                    frame.loc[failed, ["success", "outcome", "reason"]] = [1, "SUCCESS", "SUCCESS"]
            frames.append(frame)
        meta = {"preset": "paper", "paired": True, "overrides": {"procedure.view_tilt_deg": 30.0},
                "jobs": [{"trials": trials, "setups": sorted({s for s, _ in cells}),
                          "objects": sorted({o for _, o in cells})}]}
        return pd.concat(frames, ignore_index=True), meta

    a_b = part({(1, "a"): (6, 10), (1, "b"): (4, 10)}, 10, 2)  # 4 more of 20 at 5 px
    g = part({(1, "g"): (5, 20)}, 20, 2)  # 2 more of 20
    piles = part({(s, o): (1, 5) for s in (2, 3) for o in "abcdef"}, 5, 1)  # 6 more of 30
    per, key, title = study_points([piles, g, a_b])
    assert key == "cfg.align.window_px"
    assert title == ("align.window_px, paper preset (procedure.view_tilt_deg=30.0), each panel "
                     "at its own trials (5/10/20 trials per cell), paired")
    assert per["setup"].drop_duplicates().tolist() == ["1 a, b", "1 g", "2 a-f", "3 a-f"]
    at_5 = per[per[key] == 5].set_index("setup")
    assert at_5["n"].tolist() == [20, 20, 30, 30]
    assert (100 * at_5["difference_vs_paper"]).tolist() == pytest.approx([20, 10, 20, 20])
    assert at_5[["gained", "lost"]].to_numpy().tolist() == [[4, 0], [2, 0], [6, 0], [6, 0]]
    single, _, alone = study_points([g])
    assert alone.endswith("(procedure.view_tilt_deg=30.0), 20 trials per cell, paired")
    assert single.loc[single[key] == 5, "difference_low"].item() == pytest.approx(
        at_5.loc["1 g", "difference_low"])
    other_key = (a_b[0].rename(columns={key: "cfg.align.distance_threshold"}), a_b[1])
    with pytest.raises(ValueError, match="must sweep the one key cfg.align.window_px"):
        study_points([a_b, other_key])
    with pytest.raises(ValueError, match="other settings"):
        study_points([a_b, (g[0], {**g[1], "overrides": {}})])
    with pytest.raises(ValueError, match="the same panel: Setup 1 g"):
        study_points([g, a_b, g])
    with pytest.raises(ValueError, match="no parts"):
        study_points([])


def test_titles_name_objects_only_where_a_run_played_some():
    """The object letters of a title: a run of three or more as a range, else a list, and
    nothing for all twelve."""
    from graspjax.report.tables import objects_named

    assert objects_named("ghijkl") == "g-l" and objects_named(["d", "a", "b"]) == "a, b, d"
    assert objects_named(["g"]) == "g" and objects_named("ab") == "a, b"
    assert objects_named("abcdefghijkl") == ""


@pytest.mark.parametrize("module", ["graspjax.figures.report", "graspjax.figures.titles",
                                    "graspjax.report.studies", "graspjax.report.tables"])
def test_each_module_of_the_report_imports_first(module):
    """A fresh interpreter imports each module that draws or titles the report first (the
    figures and the report's package import each other's parts)."""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr.splitlines()[-1:]
