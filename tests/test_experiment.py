"""Runs end to end through the CLI: files, determinism, report, rounds, sweeps, bad input."""

import csv
import json

import pandas as pd
import pytest
from conftest import SIM_BATCH

from graspjax.cli import main

TINY = ["--setup", "1", "--objects", "a", "--trials", "2", "--seed", "3", "--quiet",
        "--batch", str(SIM_BATCH)]


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory, basic_sim):
    out = tmp_path_factory.mktemp("run") / "tiny"
    assert main(["run", *TINY, "--out", str(out), "--set", "align.window_px=12"]) == 0
    return out


def test_run_writes_every_file_with_the_right_columns(tiny_run):
    for name in ("attempts.csv", "attempts.parquet", "timings.csv", "config.json", "summary.csv",
                 "table1.md", "table1.tex", "success_by_object.png", "outcomes.png"):
        assert (tiny_run / name).is_file(), name
    frame = pd.read_csv(tiny_run / "attempts.csv")
    for column in ("setup", "object", "trial", "round", "seed", "success", "reason",
                   "reorientations", "lifted_object", "grasp_tcp_x", "grasp_closing_z",
                   "cfg.align.window_px", "chunk"):
        assert column in frame.columns, column
    assert len(frame) == 2 and set(frame["success"]) <= {0, 1}
    assert (frame["cfg.align.window_px"] == 12).all()
    parquet = pd.read_parquet(tiny_run / "attempts.parquet").replace("", float("nan"))
    pd.testing.assert_frame_equal(parquet, frame, check_dtype=False)
    meta = json.loads((tiny_run / "config.json").read_text())
    assert meta["seed"] == 3 and meta["overrides"] == {"align.window_px": 12}
    assert meta["config"]["align.window_px"] == 12 and meta["versions"]["jax"]
    summary = pd.read_csv(tiny_run / "summary.csv")
    row = summary.iloc[0]
    assert (row.setup, row.object, row.n, row.paper_pct) == (1, "a", 2, 90)
    assert row.ci_low <= row.rate <= row.ci_high


def test_same_seed_same_attempts(tiny_run, tmp_path):
    again = tmp_path / "again"
    assert main(["run", *TINY, "--out", str(again), "--set", "align.window_px=12"]) == 0
    assert (again / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()


def test_report_rebuilds_the_same_tables(tiny_run, tmp_path):
    copy = tmp_path / "copy"
    copy.mkdir()
    (copy / "attempts.csv").write_bytes((tiny_run / "attempts.csv").read_bytes())
    assert main(["report", str(copy)]) == 0
    for name in ("summary.csv", "table1.md", "table1.tex"):
        assert (copy / name).read_bytes() == (tiny_run / name).read_bytes(), name


def test_rounds_attempt_every_object_once(tmp_path):
    """Setups 2 and 3: each object gets one row per round; a lifted object leaves the scene."""
    out = tmp_path / "rounds"
    assert main(["run", "--setup", "2,3", "--trials", "3", "--quiet", "--batch", str(SIM_BATCH),
                 "--out", str(out)]) == 0
    frame = pd.read_csv(out / "attempts.csv", keep_default_na=False)
    assert len(frame) == 2 * 3 * 6
    for (_, _), part in frame.groupby(["setup", "round"]):
        assert sorted(part["object"]) == list("abcdef")
        tried = part[part["attempt"] >= 0]
        assert sorted(tried["attempt"]) == list(range(len(tried)))
        lifted = [c for c in part["lifted_object"] if c]
        assert len(lifted) == len(set(lifted))  # nothing is lifted twice
    table = (out / "table1.md").read_text()
    assert "Setup 2, ours" in table and "Setup 3, paper" in table


def test_sweep_grid_points_have_their_own_seed(tmp_path):
    out = tmp_path / "sweep"
    assert main(["sweep", *TINY, "--grid", "align.window_px=10,15", "--out", str(out)]) == 0
    frame = pd.read_csv(out / "attempts.csv")
    assert sorted(frame["cfg.align.window_px"].unique()) == [10, 15]
    assert frame.groupby("point")["seed"].first().tolist() == [3, 4]
    with open(out / "sweep_summary.csv") as handle:
        assert len(list(csv.DictReader(handle))) == 2
    assert (out / "sweep_align.window_px.png").is_file()


@pytest.mark.parametrize("args, message", [
    (["run", "--setup", "1", "--objects", "a,z", "--trials", "1"], "unknown object 'z'"),
    (["run", "--setup", "1", "--set", "align.windw_px=3"], "did you mean align.window_px"),
    (["run", "--setup", "1", "--set", "align.distance_threshold=-1"], "distance_threshold"),
    (["run", "--setup", "4"], "--setup must be among"),
    (["run", "--setup", "1", "--trials", "0"], "--trials must be >= 1"),
    (["run", "--table", "1", "--setup", "1"], "either --table"),
    (["run", "--table", "3"], "--table must be among"),
    (["sweep", "--setup", "1", "--grid", "align.window_px=5,x"], "must be int"),
    (["sweep", "--setup", "1"], "needs at least one --grid"),
])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, capsys, args, message):
    out = tmp_path / "out"
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_unwritable_output_directory(tmp_path, capsys):
    plain_file = tmp_path / "file.txt"
    plain_file.write_text("x")
    assert main(["run", "--setup", "1", "--out", str(plain_file / "out")]) == 2
    assert "is not an existing directory" in capsys.readouterr().err
    assert main(["run", "--setup", "1", "--out", str(plain_file)]) == 2
    assert "not a directory" in capsys.readouterr().err
    proc = "/proc/graspjax-results"  # refuses new files, even for root
    assert main(["run", "--setup", "1", "--out", proc]) == 2
    assert "not writable" in capsys.readouterr().err


def test_report_errors(tmp_path, capsys):
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no such directory" in err and "no attempts.csv" in err
