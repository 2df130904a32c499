"""A run's folder: only graspjax's own files are ever replaced, one process writes it, and a
resume that would mix two runs is refused naming the setting that differs."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from graspjax.errors import InputError
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
            "comparison.md", "comparison.png", "rounds_summary.csv", "rounds.csv.gz",
            "attempts.csv.gz",
            "parts/attempts-00001.parquet", "parts/timings-00001.json",
            "views/p000_s1_r00002_a0_c.npz", "debug/p000_s1_r00002_a0_c.png"]
    theirs = ["notes.txt", "views/x", "debug/mine.png", "parts/keep.txt", "analysis/plot.png"]
    for name in ours + theirs:  # (rounds.csv.gz, attempts.csv.gz: as committed results keep them)
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
    from graspjax.report.files import load_rounds, read_attempts_csv
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
    rounds = [pd.DataFrame({"point": 0, "setup": int(c["setup"].iloc[0]),
                            "round": c["trial"].unique() if c["setup"].iloc[0] > 1
                            else np.array([], int),
                            "spread_m": rng.random(c["trial"].nunique() if c["setup"].iloc[0] > 1
                                                   else 0).astype(np.float32)})
              for c in chunks]
    for index in (2, 0, 3, 1):  # chunks end out of order
        (helper if index == 3 else folder).add(index, chunks[index], rounds[index], timings)
    assert set(folder._kept) == {0, 1, 2} and not helper._kept
    folder.finish()
    whole = sort_attempts(pd.concat(chunks, ignore_index=True))
    assert (tmp_path / "attempts.csv").read_bytes() == _csv(whole, True)
    assert pd.read_parquet(tmp_path / "attempts.parquet").equals(whole)
    # The rows the report gets from memory: the chunks' lines read one by one and joined equal
    # the whole file read at once (missing rounds in some chunks, float32 values, quotes).
    rounds_of_chunks = rounds
    attempts, rounds = folder.report_rows
    pd.testing.assert_frame_equal(attempts, read_attempts_csv(
        (tmp_path / "attempts.csv").read_bytes()))
    pd.testing.assert_frame_equal(rounds, load_rounds(tmp_path))
    # rounds.csv: the lines each chunk formatted, in pandas' stable sort of the joined rows
    assert (tmp_path / "rounds.csv").read_bytes() == _csv(
        pd.concat(rounds_of_chunks, ignore_index=True).sort_values(
            ["point", "setup", "round"], kind="stable"), True)


def _finished_run(folder: Path) -> RunFolder:
    """A run of two one-row chunks, finished: attempts.csv, .parquet, rounds.csv, timings."""
    from graspjax.schema import TIMINGS_COLUMNS

    run = RunFolder(folder, _meta(), chunks=2, resume=False)
    for chunk in (0, 1):
        run.add(chunk, pd.DataFrame({"point": [0], "setup": [1], "object": ["a"],
                                     "trial": [chunk], "attempt": [0]}),
                pd.DataFrame({"point": [], "setup": [], "round": []}),
                dict.fromkeys(TIMINGS_COLUMNS, 0))
    run.finish()
    return run


def test_resuming_a_finished_run_that_keeps_only_its_csv_keeps_every_row(tmp_path):
    """Committed results keep attempts.csv without attempts.parquet: --resume on such a folder
    is a finished run (config.json says so), its rows untouched, not a run to start over."""
    _finished_run(tmp_path)
    rows = (tmp_path / "attempts.csv").read_bytes()
    (tmp_path / "attempts.parquet").unlink()
    again = RunFolder(tmp_path, _meta(), chunks=2, resume=True)
    assert again.finished and again.done == {0, 1}
    assert (tmp_path / "attempts.csv").read_bytes() == rows
    assert again.finish() and (tmp_path / "attempts.csv").read_bytes() == rows
    assert not (tmp_path / "parts").exists()


def test_resuming_the_committed_reference_run_keeps_its_rows(tmp_path):
    """README's command with --resume on a copy of the committed 10-trial reference (a CLI
    process): its 240 rows stay, whatever the code makes of the folder."""
    reference = Path(__file__).parents[1] / "results" / "paper_cpu_10"
    copy = tmp_path / "copy"
    shutil.copytree(reference, copy)
    rows = (copy / "attempts.csv").read_bytes()
    done = subprocess.run([sys.executable, "-m", "graspjax.cli", "run", "--table", "1,2",
                           "--trials", "10", "--seed", "0", "--out", str(copy), "--resume",
                           "--quiet"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (copy / "attempts.csv").read_bytes() == rows
    assert len(pd.read_csv(copy / "attempts.csv")) == 240


def test_a_users_file_in_parts_outlives_the_run(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "notes.txt").write_text("mine")
    _finished_run(tmp_path)
    assert (tmp_path / "parts" / "notes.txt").read_text() == "mine"
    assert [p.name for p in (tmp_path / "parts").iterdir()] == ["notes.txt"]
    assert RunFolder(tmp_path, _meta(), chunks=2, resume=True).finished


def test_a_damaged_part_is_named_on_resume(tmp_path):
    run = RunFolder(tmp_path, _meta(), chunks=2, resume=False)
    run.add(0, pd.DataFrame({"setup": [1], "object": ["a"], "trial": [0]}),
            pd.DataFrame({"point": []}), {})
    (tmp_path / "parts" / "attempts-00000.parquet").write_bytes(b"PAR1 cut")
    with pytest.raises(InputError, match=r"attempts-00000.parquet cannot be read .*: remove it "
                                         "and --resume plays its chunk again"):
        RunFolder(tmp_path, _meta(), chunks=2, resume=True)


def test_a_resume_refused_names_the_setting_even_where_the_run_held_tuples(tmp_path):
    """The settings as the command gives them (tuples) and as config.json holds them (lists)
    are the same settings: a resume refused for another batch says batch, not jobs."""
    as_given = _meta(jobs=[{"objects": ("a",), "setups": (1,), "trials": 3}])
    RunFolder(tmp_path, as_given, chunks=2, resume=False)
    RunFolder(tmp_path, as_given, chunks=2, resume=True)  # the same run resumes
    with pytest.raises(InputError, match="batch: 3 there, 6 here"):
        RunFolder(tmp_path, {**as_given, "batch": 6}, chunks=2, resume=True)


def test_a_lock_file_that_is_a_link_is_refused_and_its_target_left_alone(tmp_path):
    """A planted `.graspjax.lock` link: the run stops in one line (a CLI process), the file it
    points at keeps its bytes, and a dangling link creates nothing outside the folder."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / LOCK).symlink_to(victim)
    for attempt in (lambda: writing(folder), lambda: check_output_folder(folder, resume=True)):
        with pytest.raises(InputError, match="is a symbolic link, which graspjax never makes"):
            with attempt():
                pass
    done = subprocess.run([sys.executable, "-m", "graspjax.cli", "run", "--setup", "1",
                           "--objects", "a", "--trials", "1", "--out", str(folder), "--resume"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "symbolic link" in done.stderr
    assert victim.read_text() == "precious"
    elsewhere = tmp_path / "elsewhere.txt"
    (folder / LOCK).unlink()
    (folder / LOCK).symlink_to(elsewhere)
    with pytest.raises(InputError, match="symbolic link"):
        with writing(folder):
            pass
    assert not elsewhere.exists()


def test_attempts_csv_is_never_appended_through_a_link(tmp_path):
    run = RunFolder(tmp_path, _meta(), chunks=2, resume=False)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (tmp_path / "attempts.csv").unlink()
    (tmp_path / "attempts.csv").symlink_to(victim)
    with pytest.raises(OSError):
        run.add(0, pd.DataFrame({"setup": [1]}), pd.DataFrame({"point": []}), {})
    assert victim.read_text() == "precious"


@pytest.mark.parametrize("name, words", [
    ("", "--out is empty: give a folder"),
    ("/", "is the file system's root"),
    ("dangling", "is a symbolic link to nowhere, which does not exist"),
])
def test_output_folders_no_run_can_use_get_one_line_that_says_why(tmp_path, name, words):
    if name == "dangling":
        (tmp_path / name).symlink_to("nowhere")
        name = str(tmp_path / name)
    with pytest.raises(InputError, match=words):
        check_output_folder(name)


def test_a_write_failure_is_the_error_told_not_the_lock_left_behind(tmp_path, monkeypatch):
    """A folder turned read-only mid-run: the run's own failed write is what the user reads,
    though its lock file cannot be removed either."""
    folder = tmp_path / "run"
    with pytest.raises(OSError) as failed:
        with writing(folder):
            def refuse(self, missing_ok=False):
                raise PermissionError(13, "Permission denied", str(self))

            monkeypatch.setattr(Path, "unlink", refuse)
            raise PermissionError(13, "Permission denied", str(folder / "attempts.csv"))
    assert failed.value.filename == str(folder / "attempts.csv")
