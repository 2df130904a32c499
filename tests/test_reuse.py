"""A paired study of the re-alignment that reuses a finished run's worlds (`sweep --reuse`)."""

import json
import os

import pandas as pd
import pytest

from graspjax.cli import main
from graspjax.config import Config
from graspjax.reuse import worlds_to_play_again

# Objects a and c alone on every view tilted 30 deg (where first views often hold no grasp),
# 3 trials each in chunks of 3: the program of test_experiment's tiny run (the tilt is traced).
ANY_TILT = ["--setup", "1", "--objects", "a,c", "--trials", "3", "--quiet", "--batch", "3",
            "--set", "align.window_px=12"]
SLOPED = [*ANY_TILT, "--seed", "3", "--set", "procedure.view_tilt_deg=30"]
GRID = ["--paired", "--grid", "align.distance_threshold=0.3,0.6"]  # 0.3: the run's own
# test_experiment's continued rounds (its program): each round ends empty before its 4 attempts,
# so the attempts left find no target and every round plays again at the other point
CONTINUED = ["--setup", "2", "--objects", "a,d", "--trials", "3", "--batch", "3", "--seed", "2",
             "--quiet", "--preset", "realistic", "--set", "procedure.round_attempts=4"]


@pytest.fixture(scope="module")
def sloped_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("reuse") / "run"
    assert main(["run", *SLOPED, "--out", str(out)]) == 0
    return out


def test_a_study_reusing_a_run_has_the_full_studys_rows_and_plays_only_worlds_that_missed(
        sloped_run, tmp_path, capsys):
    """The rows equal those of the same sweep played in full; the device played only the
    run's worlds whose first view held no grasp, and only at the point whose settings differ
    from the run's (the other copies every row)."""
    full, shared = _played_in_full_and_reusing(SLOPED, GRID, sloped_run, tmp_path)
    first = pd.read_csv(sloped_run / "attempts.csv")
    missed = first[first.first_view_grasp == 0]
    played = pd.read_csv(shared / "timings.csv")
    assert 0 < len(missed) < len(first)
    assert played["worlds"].sum() == len(missed)
    assert len(pd.read_csv(full / "timings.csv")) == 4  # the full sweep: 2 points x 2 chunks
    meta, run_meta = (json.loads((f / "config.json").read_text()) for f in (shared, sloped_run))
    assert meta["reuse"] == {"folder": str(sloped_run.resolve()), "run_id": run_meta["run_id"]}
    assert meta["run_id"] == json.loads((full / "config.json").read_text())["run_id"]  # same rows
    # ... in other chunks: neither continues the other
    assert main(["sweep", *SLOPED, *GRID, "--reuse", str(sloped_run), "--out", str(full),
                 "--resume"]) == 2
    assert "reuse: None there" in capsys.readouterr().err
    parts = tmp_path / "parts"  # two parts of the study, each its share of played and copied,
    for part, run in (("1/2", sloped_run), ("0/2", os.path.relpath(sloped_run))):  # RUN either way
        assert main(["sweep", *SLOPED, *GRID, "--reuse", str(run), "--out", str(parts),
                     "--part", part]) == 0
    assert (parts / "attempts.csv").read_bytes() == (shared / "attempts.csv").read_bytes()


def test_a_dry_run_says_what_it_reuses_and_counts_only_the_worlds_it_plays(
        sloped_run, tmp_path, capsys):
    """--dry-run with --reuse: RUN's worlds that play again (those whose first view held no
    grasp, at the one point whose settings differ from RUN's) are all it plans; nothing written."""
    out = tmp_path / "out"
    assert main(["sweep", *SLOPED, *GRID, "--reuse", str(sloped_run), "--out", str(out),
                 "--dry-run"]) == 0
    printed = capsys.readouterr().out.splitlines()
    first = pd.read_csv(sloped_run / "attempts.csv")  # Setup 1: a world is one attempt
    missed = int((first.first_view_grasp == 0).sum())
    assert printed[0] == (f"--reuse {sloped_run}: {missed} of its {len(first)} worlds play again "
                          "where a point's settings differ from its; the others' rows are its own")
    assert printed[1].startswith(f"2 grid point(s), {missed} worlds in ")
    assert not out.exists()


@pytest.mark.parametrize("command, message", [
    ([*SLOPED, "--grid", "gripper.opening=0.08,0.1"], "--grid gripper.opening acts before a view"),
    ([*SLOPED, *GRID[1:]], "needs --paired"),
    ([*SLOPED, *GRID, "--save-views", "failed"], "no --save-views"),
    ([*ANY_TILT, "--seed", "3", "--set", "procedure.view_tilt_deg=10", *GRID],
     "its procedure.view_tilt_deg is 30.0, this sweep's 10.0"),
    ([*ANY_TILT, "--seed", "4", "--set", "procedure.view_tilt_deg=30", *GRID],
     "its seed is 3, this sweep's 4"),
    ([*SLOPED, "--batch", "2", *GRID], "its batch is 3, this sweep's 2"),
    ([*SLOPED, "--set", "detect.unrolled_loops=true", *GRID],  # a device's choice, set by hand
     "its detect.unrolled_loops is None, this sweep's True"),
])
def test_reuse_refuses_a_run_whose_worlds_would_not_play_the_same(
        sloped_run, tmp_path, capsys, command, message):
    out = tmp_path / "out"
    assert main(["sweep", *command, "--reuse", str(sloped_run), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("config, message", [
    (None, "no run there (no config.json)"),
    ("{not json", "no finished run there (its config.json says so)"),
    ('{"finished": "2026", "points": 1}', "no finished run there (its config.json says so)"),
])
def test_reuse_needs_a_finished_run(tmp_path, capsys, config, message):
    if config is not None:
        (tmp_path / "config.json").write_text(config)
    assert main(["sweep", *SLOPED, *GRID, "--reuse", str(tmp_path), "--out",
                 str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_a_world_plays_again_unless_every_attempt_found_its_grasp_in_the_first_view():
    """Hand-made rows: Setup 1 worlds of one attempt; Setup 2 rounds of three (a, c, f)."""
    def row(setup, trial, objects, attempt, first_view):
        return {"setup": setup, "trial": trial, "objects": objects, "attempt": attempt,
                "first_view_grasp": first_view}

    rows = pd.DataFrame([
        row(1, 0, "a", 0, 1),  # found at once: copied
        row(1, 1, "a", 0, 0),  # no grasp in the first view: played again
        row(1, 2, "a", -1, 0),  # never attempted (no target): played again
        *(row(2, 0, "acf", k, 1) for k in range(3)),  # every attempt found at once: copied
        row(2, 1, "acf", 0, 1), row(2, 1, "acf", 1, 0), row(2, 1, "acf", 2, 1),
        row(2, 2, "acf", 0, 1), row(2, 2, "acf", 1, 1), row(2, 2, "acf", -1, 0),  # one left
    ])
    assert worlds_to_play_again(rows, Config()) == {(1, 1, "a"), (1, 2, "a"), (2, 1, "acf"),
                                             (2, 2, "acf")}


def test_a_grid_of_the_runs_own_settings_plays_nothing_and_copies_every_row(sloped_run, tmp_path):
    out = tmp_path / "own"
    assert main(["sweep", *SLOPED, "--paired", "--grid", "align.distance_threshold=0.3",
                 "--reuse", str(sloped_run), "--out", str(out)]) == 0
    assert pd.read_csv(out / "timings.csv").empty
    rows = [pd.read_csv(f / "attempts.csv") for f in (sloped_run, out)]
    pd.testing.assert_frame_equal(rows[0].drop(columns=["run_id", "chunk"]),
                                  rows[1].drop(columns=["run_id", "chunk", "cfg.align.distance_threshold"]))


def test_rounds_whose_attempts_found_no_target_play_again_and_their_round_rows_match(tmp_path):
    base = tmp_path / "run"
    assert main(["run", *CONTINUED, "--out", str(base)]) == 0
    grid = ["--paired", "--grid", "align.distance_threshold=0.3,0.05"]
    _, shared = _played_in_full_and_reusing(CONTINUED, grid, base, tmp_path)
    rounds = pd.read_csv(base / "rounds.csv")
    assert (rounds["attempts"] < 4).all()  # so each round plays again at 0.05 (and only there)
    assert pd.read_csv(shared / "timings.csv")["worlds"].sum() == len(rounds)


def _played_in_full_and_reusing(command, grid, run, tmp_path):
    """The sweep `command` + `grid` played in full and reusing `run`: their folders, once their
    attempt rows (but the run id and chunk) and round rows are found the same."""
    full, shared = tmp_path / "full", tmp_path / "shared"
    assert main(["sweep", *command, *grid, "--out", str(full)]) == 0
    assert main(["sweep", *command, *grid, "--reuse", str(run), "--out", str(shared)]) == 0
    rows = [pd.read_csv(f / "attempts.csv").drop(columns=["run_id", "chunk"]) for f in (full, shared)]
    pd.testing.assert_frame_equal(*rows)
    assert (full / "rounds.csv").read_text() == (shared / "rounds.csv").read_text()
    return full, shared
