"""A run's folder: only graspjax's own files are ever replaced, one process writes it, and a
resume that would mix two runs is refused naming the setting that differs."""

import json
import os

import pytest

from graspjax.io import InputError
from graspjax.outputs import (
    LOCK,
    RunFolder,
    check_output_folder,
    holds_graspjax_output,
    remove_own_files,
    run_id,
    writing,
)


def _meta(**changes):
    meta = {"seed": 0, "paired": False, "jobs": [{"objects": ["a"], "setups": [1], "trials": 3}],
            "overrides": {}, "grid": {}, "batch": 3, "versions": {"graspjax": "0.1.0"}}
    meta.update(changes)
    return {"run_id": run_id(meta), **meta}


def test_a_folder_of_someone_elses_files_is_refused_and_left_alone(tmp_path):
    (tmp_path / "views").mkdir()
    (tmp_path / "views" / "x").write_text("mine")
    (tmp_path / "attempts.csv").write_text("a user's own table")
    for overwrite in (False, True):
        with pytest.raises(InputError, match="is not empty and holds no graspjax run"):
            check_output_folder(tmp_path, overwrite=overwrite)
    assert (tmp_path / "views" / "x").read_text() == "mine"
    assert (tmp_path / "attempts.csv").read_text() == "a user's own table"
    # A config.json that graspjax did not write is no marker either.
    (tmp_path / "config.json").write_text(json.dumps({"seed": 1}))
    assert not holds_graspjax_output(tmp_path)
    with pytest.raises(InputError, match="holds no graspjax run"):
        check_output_folder(tmp_path, overwrite=True)
    empty = tmp_path / "empty"
    empty.mkdir()
    assert check_output_folder(empty) == empty


def test_overwrite_removes_every_file_of_a_run_or_sweep_and_nothing_else(tmp_path):
    RunFolder(tmp_path, _meta(), chunks=2, resume=False)  # writes config.json and parts/
    ours = ["attempts.csv", "attempts.parquet", "rounds.csv", "timings.csv", "summary.csv",
            "table1.md", "table2.tex", "outcomes.png", "success_by_object.png",
            "sweep_summary.csv", "sweep_align.window_px.png", "sweep_heatmap.png",
            "comparison.md", "comparison.png", "rounds_summary.csv",
            "parts/attempts-00001.parquet", "parts/timings-00001.json",
            "views/p000_s1_r00002_a0_c.npz", "debug/p000_s1_r00002_a0_c.png"]
    theirs = ["notes.txt", "views/x", "debug/mine.png", "parts/keep.txt", "analysis/plot.png"]
    for name in ours + theirs:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(name)
    assert check_output_folder(tmp_path, overwrite=True) == tmp_path
    remove_own_files(tmp_path)
    left = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert left == sorted(theirs)


def test_one_process_writes_a_folder(tmp_path):
    folder = tmp_path / "run"
    with writing(folder):
        with pytest.raises(InputError, match=f"being written by process {os.getpid()} on "):
            with writing(folder):
                pass
        # The parts of a shared run (--part I/N) write one folder together.
        with writing(folder, shared=True):
            pass
    with writing(folder):  # released at the end, and by the OS if the process dies
        assert (folder / LOCK).read_text().startswith(f"process {os.getpid()} on ")
    assert not (folder / LOCK).exists()  # a finished run leaves no lock file behind


def test_a_resume_that_would_mix_two_runs_names_the_setting(tmp_path):
    assert run_id(_meta(paired=True)) != run_id(_meta())  # paired changes the rows
    RunFolder(tmp_path, _meta(), chunks=2, resume=False)
    for other, words in ((_meta(paired=True), "paired: False there, True here"),
                         (_meta(overrides={"align.window_px": 12}),
                          "overrides align.window_px: 'unset' there, 12 here"),
                         (_meta(batch=6), "batch: 3 there, 6 here")):
        with pytest.raises(InputError, match="holds another run") as error:
            RunFolder(tmp_path, other, chunks=2, resume=True)
        assert words in str(error.value)
    RunFolder(tmp_path, _meta(), chunks=2, resume=True)  # the same run resumes


def test_the_runs_process_streams_its_helpers_rows_as_their_chunks_end(tmp_path):
    """Only the run's own process appends to attempts.csv; a helper's finished chunk (its part,
    written by a process that shares the folder) is appended when the run catches up."""
    import pandas as pd

    run = RunFolder(tmp_path, _meta(), chunks=2, resume=False)
    helper = RunFolder(tmp_path, _meta(), chunks=2, resume=True, shared=True)
    rows = [pd.DataFrame({"setup": [1], "object": ["a"], "trial": [t]}) for t in (0, 1)]
    empty = pd.DataFrame({"point": []})
    run.add(0, rows[0], empty, {})
    helper.add(1, rows[1], empty, {})
    assert pd.read_csv(tmp_path / "attempts.csv")["trial"].tolist() == [0]  # the helper never appends
    run.catch_up()
    run.catch_up()  # nothing twice
    assert pd.read_csv(tmp_path / "attempts.csv")["trial"].tolist() == [0, 1]


def test_a_folder_a_run_has_just_locked_is_left_to_the_lock(tmp_path):
    """Between taking its lock and writing config.json a run's folder holds the lock alone: a
    second run is sent on to the lock (which names the first), not told the folder is a
    user's."""
    folder = tmp_path / "run"
    with writing(folder):
        assert check_output_folder(folder, resume=True) == folder
        with pytest.raises(InputError, match="being written by process"):
            with writing(folder):
                pass


@pytest.mark.parametrize("reason", ["not attempted: a, b \"quoted\"", "a line\nbreak"])
def test_the_finished_attempts_csv_is_the_sorted_rows_formatted_afresh(tmp_path, reason):
    """The end of a run puts the lines its chunks formatted into the sorted order; the bytes
    equal the whole sorted frame formatted at once (pandas, a reference that does not reorder
    lines), with missing rounds, float32 values, quoted fields, and a field whose line break
    makes the lines unusable (then it formats afresh); one chunk comes from another process's
    part file, the others from what the run kept."""
    import numpy as np
    import pandas as pd

    from graspjax.outputs import _csv
    from graspjax.schema import TIMINGS_COLUMNS, sort_attempts

    rng = np.random.default_rng(0)

    def rows(setup, trials):
        n = 3 * len(trials)
        return pd.DataFrame({
            "point": 0, "setup": setup, "object": np.tile(["c", "a", "b"], len(trials)),
            "trial": np.repeat(trials, 3),
            "round": pd.array(np.repeat(trials, 3) if setup > 1 else [None] * n, dtype="Int64"),
            "attempt": rng.integers(-1, 3, n), "rise_m": rng.random(n).astype(np.float32) / 3,
            "reason": reason})

    chunks = [rows(2, [3, 1]), rows(1, [2, 0]), rows(3, [0]), rows(1, [1, 3])]
    folder = RunFolder(tmp_path, _meta(), chunks=len(chunks), resume=False)
    # A helper process's folder object: its chunks reach the run's only as files.
    helper = RunFolder(tmp_path, _meta(), chunks=len(chunks), resume=True, shared=True, keep=False)
    timings = dict.fromkeys(TIMINGS_COLUMNS, 0)
    for index in (2, 0, 3, 1):  # chunks end out of order
        (helper if index == 3 else folder).add(
            index, chunks[index], pd.DataFrame({"point": [], "setup": [], "round": []}), timings)
    assert set(folder._kept) == {0, 1, 2} and not helper._kept
    folder.finish()
    whole = sort_attempts(pd.concat(chunks, ignore_index=True))
    assert (tmp_path / "attempts.csv").read_bytes() == _csv(whole, True)
    assert pd.read_parquet(tmp_path / "attempts.parquet").equals(whole)
