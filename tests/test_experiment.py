"""Runs end to end through the CLI: files, reproducibility, resume, parts, devices, views."""

import concurrent.futures
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import types
from pathlib import Path

import jax
import numpy as np
import pandas as pd
import pytest

from graspjax import experiment
from graspjax.batch import plan, program, schedule
from graspjax.cli import main
from graspjax.config import MAX_REORIENTATIONS, Config, override
from graspjax.procedure import steps
from graspjax.runtime import exported, players
from graspjax.saved_views import attempt_name
from graspjax.schema import ROUND_COLUMNS, attempt_columns

# Objects a and c alone (Setup 1), 3 trials each: 6 worlds, in chunks of 3 (c needs a re-alignment).
TINY = ["--setup", "1", "--objects", "a,c", "--trials", "3", "--seed", "3", "--quiet",
        "--batch", "3", "--set", "align.window_px=12"]
VOLATILE = ["run_id", "chunk"]  # what may differ between two runs of the same worlds
ROUND_OBJECTS = ["a", "c", "f"]  # a cube, a wedge, a flat block
_ROUNDS = ["--quiet", "--objects", ",".join(ROUND_OBJECTS), "--batch", "4", "--seed", "5",
           "--save-views", "failed", "--max-views", "2"]
ROUNDS_RUNS = {"two": ["run", "--setup", "2", "--trials", "4", *_ROUNDS],
               "both": ["run", "--setup", "2,3", "--trials", "2", *_ROUNDS]}
CONTINUED_RUN = ["run", "--setup", "2", "--objects", "a,d", "--trials", "3", "--batch", "3",
                 "--seed", "2", "--quiet", "--preset", "realistic",
                 "--set", "procedure.round_attempts=4"]
METHODS_SWEEP = ["sweep", *TINY, "--paired", "--grid", "method=paper,antipodal"]
# The rounds run "both" again beside the antipodal baseline, every attempt's views kept: the
# paper's point reuses that run's program (views are kept there too, for its failed attempts).
ROUNDS_METHODS = ["sweep", *ROUNDS_RUNS["both"][1:], "--save-views", "all", "--max-views", "48",
                  "--paired", "--grid", "method=paper,antipodal"]
# tests/warm_cache.py runs these commands first, in a second process beside the suite's first
# modules: their programs then load here from the caches. The continued round, the smallest
# scene, goes first: placed last it was not ready in time and was compiled twice.
WARM_RUNS = [CONTINUED_RUN, METHODS_SWEEP, *ROUNDS_RUNS.values(), ROUNDS_METHODS]


def _cli(*args, env=None):
    """The installed CLI in a subprocess (its own JAX process, same compilation cache)."""
    return subprocess.Popen([sys.executable, "-m", "graspjax.cli", *args],
                            env={**os.environ, **(env or {})}, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "not" / "yet" / "there"  # --out creates its parents
    assert main(["run", *TINY, "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def two_devices(tiny_run, tmp_path_factory):
    """The tiny run again in a second process with two CPU devices, a chunk of 3 each: started by
    the module's first test and left to load its programs beside the tests that follow; its
    test waits for it. `--compile-first`: both devices' copies are ready
    before either plays, so each takes a chunk (else the first ready may play both)."""
    assert any(exported.store().glob("*.jaxexport"))  # the tiny run's programs, to be loaded
    folder = tmp_path_factory.mktemp("two")
    env = {**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=2",
           "JAX_PLATFORMS": "cpu"}
    with open(folder / "stderr.txt", "w") as err:  # a file: a full pipe would stall it
        proc = subprocess.Popen([sys.executable, "-m", "graspjax.cli", "run", *TINY,
                                 "--compile-first", "--out", str(folder / "run")],
                                env=env, stdout=subprocess.DEVNULL, stderr=err)
    yield proc, folder
    if proc.poll() is None:
        proc.kill()
        proc.wait()


def test_run_writes_every_file_with_the_right_columns(tiny_run, two_devices):
    for name in ("attempts.csv", "attempts.parquet", "rounds.csv", "timings.csv", "config.json",
                 "summary.csv", "table1.md", "table1.tex", "success_by_object.png", "outcomes.png"):
        assert (tiny_run / name).is_file(), name
    assert not (tiny_run / "parts").exists()  # assembled and removed
    frame = pd.read_csv(tiny_run / "attempts.csv")
    for column in ("setup", "object", "trial", "round", "seed", "success", "reason", "reason_code",
                   "reorientations", "lifted_object", "grasp_tcp_x", "grasp_closing_z",
                   "cfg.align.window_px", "chunk", "point"):
        assert column in frame.columns, column
    assert list(frame.columns) == attempt_columns(MAX_REORIENTATIONS, ["align.window_px"])
    assert len(frame) == 6 and set(frame["success"]) <= {0, 1}
    assert sorted(zip(frame["object"], frame["trial"], strict=True)) == [
        (c, t) for c in "ac" for t in range(3)]
    assert frame["round"].isna().all()  # Setup 1 has trials, not rounds
    assert (frame["cfg.align.window_px"] == 12).all()
    assert sorted(frame["chunk"].unique()) == [0, 1]
    parquet = pd.read_parquet(tiny_run / "attempts.parquet").replace("", float("nan"))
    pd.testing.assert_frame_equal(parquet, frame, check_dtype=False)
    meta = json.loads((tiny_run / "config.json").read_text())
    assert meta["seed"] == 3 and meta["overrides"] == {"align.window_px": 12}
    assert meta["config"]["align.window_px"] == 12 and meta["versions"]["jax"]
    assert meta["batch"] == 3 and meta["deterministic"] is True and meta["finished"]
    assert meta["preset"] == "paper"
    assert meta["devices"] and meta["devices"][0].startswith("cpu")
    from graspjax.provenance import code_identity

    assert meta["code"] == code_identity() and len(meta["code"]["digest"]) == 64
    timings = pd.read_csv(tiny_run / "timings.csv")
    assert list(timings["chunk"]) == [0, 1]
    first, second = timings.itertuples()
    assert second.compile_s == 0  # a group's compile time goes with its first chunk
    assert first.started_s >= first.compile_s  # the chunk waited for its program
    # one device: chunks run one after another (the times are rounded to the millisecond)
    assert second.started_s >= first.started_s + first.wall_s - 0.002
    assert timings["peak_gib"].isna().all()  # the CPU keeps no count of its memory
    summary = pd.read_csv(tiny_run / "summary.csv")
    row = summary[summary.object == "a"].iloc[0]
    assert (row.setup, row.n, row.paper_pct) == (1, 3, 90)
    assert row.ci_low <= row.rate <= row.ci_high


def test_a_run_s_report_from_its_rows_in_memory_equals_one_rebuilt_from_its_files(tiny_run,
                                                                                 tmp_path):
    """A run builds its report from the rows it holds (`RunFolder.report_rows`), not by reading
    them back: `graspjax report` on a copy of its folder, which reads the files, writes the same
    bytes."""
    copy = tmp_path / "copy"
    shutil.copytree(tiny_run, copy)
    report = ("summary.csv", "table1.md", "table1.tex", "success_by_object.png", "outcomes.png")
    for name in report:
        (copy / name).unlink()
    assert main(["report", str(copy)]) == 0
    for name in report:
        assert (copy / name).read_bytes() == (tiny_run / name).read_bytes(), name


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="Linux's /proc")
def test_a_run_s_before_phase_counts_from_the_interpreter_s_start():
    """`before` in a run's seconds: a process that sleeps 1.5 s at its start, then asks, has
    been running at least that long (and not minutes)."""
    code = ("import time; time.sleep(1.5); "
            "from graspjax.provenance import process_age as age; print(age())")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert 1.5 <= float(done.stdout) < 60


def test_peak_memory_is_the_device_s_in_gib():
    class Device:
        def __init__(self, stats):
            self.stats = stats

        def memory_stats(self):
            return self.stats

    gib = 2**30
    assert schedule.peak_gib(Device({"peak_bytes_in_use": 3 * gib, "bytes_in_use": gib})) == 3.0
    assert schedule.peak_gib(Device(None)) is None  # the CPU's answer


def test_a_dry_run_tells_the_plan_and_estimates_the_run_it_precedes(tiny_run, tmp_path, capsys):
    """--dry-run after a run of the same program (which recorded its timings): the worlds,
    chunks and programs, the programs stored, nothing written; its estimate is what that run's
    timings.csv says the worlds took (seconds per world played, times the worlds; nothing to
    compile: the program is stored). How close an estimate comes to a later run's time is a
    benchmark's question, not a test's."""
    first = tmp_path / "first"
    assert main(["run", *TINY, "--out", str(first)]) == 0
    capsys.readouterr()
    out = tmp_path / "again"
    assert main(["run", *TINY, "--out", str(out), "--dry-run"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("1 grid point(s), 6 worlds in 2 chunks of up to 3, ")
    assert "to trace" not in printed and "program stored" in printed and not out.exists()
    estimate = float(re.search(r"estimated: about ([0-9.]+) s on one device", printed).group(1))
    timings = pd.read_csv(first / "timings.csv")
    expected = timings["wall_s"].sum() / timings["worlds"].sum() * 6
    assert estimate == pytest.approx(expected, rel=0.05, abs=0.05)  # printed to 0.1 s


def test_same_seed_same_attempts(tiny_run, tmp_path):
    again = tmp_path / "again"
    assert main(["run", *TINY, "--out", str(again)]) == 0
    assert (again / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()


def test_a_folder_holding_a_run_needs_resume_or_overwrite(tiny_run, tmp_path, capsys):
    copy = tmp_path / "copy"
    assert main(["run", *TINY, "--out", str(copy)]) == 0
    assert main(["run", *TINY, "--out", str(copy)]) == 2
    assert "already holds a run" in capsys.readouterr().err
    # --resume of a finished run runs nothing and rebuilds the same results.
    assert main(["run", *TINY, "--out", str(copy), "--resume"]) == 0
    assert (copy / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()
    # Another command cannot resume this folder.
    assert main(["run", *TINY[:-1], "align.window_px=13", "--out", str(copy), "--resume"]) == 2
    assert "holds another run" in capsys.readouterr().err
    assert main(["run", *TINY, "--out", str(copy), "--overwrite"]) == 0


def test_a_run_never_removes_or_mixes_in_a_users_files(tiny_run, tmp_path, capsys):
    """A folder of a user's files is refused, whole; --overwrite onto a run's folder replaces
    the run's files (a sweep's comparison included) and keeps the user's beside them."""
    mine = tmp_path / "mine"
    (mine / "views").mkdir(parents=True)
    (mine / "views" / "x").write_text("x")
    assert main(["run", *TINY, "--out", str(mine), "--overwrite"]) == 2
    assert "holds no graspjax run (views/x)" in capsys.readouterr().err
    assert sorted(p.name for p in mine.rglob("*")) == ["views", "x"]
    copy = tmp_path / "copy"
    shutil.copytree(tiny_run, copy)
    (copy / "comparison.md").write_text("a sweep's, now stale")
    (copy / "views").mkdir()
    (copy / "views" / "notes.txt").write_text("mine")
    assert main(["run", *TINY, "--out", str(copy), "--overwrite"]) == 0
    assert not (copy / "comparison.md").exists()
    assert (copy / "views" / "notes.txt").read_text() == "mine"
    assert (copy / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()


def _kill_when(proc, ready, what):
    """SIGKILL `proc` as soon as `ready()` holds (it must, before the run ends)."""
    deadline = time.time() + 600
    while not ready() and proc.poll() is None and time.time() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert ready(), f"the run ended before {what}"


@pytest.mark.parametrize("moment", ["compiling", "between chunks", "appending"])
def test_a_killed_run_resumes_with_nothing_lost_or_doubled(tiny_run, tmp_path, moment):
    """A kill at any moment, then --resume: the uninterrupted run's rows, byte for byte. Killed
    while its programs load (no chunk done), between its two chunks (the first one's rows on
    disk at once, also when it may use two processes), and while it appends a chunk's rows
    (the state such a kill leaves: an incomplete row after the chunks done, which the report
    refuses and --resume drops)."""
    out = tmp_path / "killed"
    parts = out / "parts"
    if moment == "compiling":
        proc = _cli("run", *TINY, "--out", str(out))
        _kill_when(proc, lambda: (out / "config.json").exists(), "it started")
        assert not list(parts.glob("attempts-*.parquet")), "a chunk was done already"
    else:
        proc = _cli("run", *TINY, "--out", str(out), env={"GRASPJAX_PROCESSES": "2"})
        _kill_when(proc, lambda: (parts / "attempts-00000.parquet").exists(), "its first chunk")
        assert sorted(p.name for p in parts.glob("attempts-*.parquet")) == ["attempts-00000.parquet"]
        assert not (out / "attempts.parquet").exists()
        partial = pd.read_csv(out / "attempts.csv")
        assert len(partial) == 3  # the first chunk's rows were on disk at once
    if moment == "appending":
        with open(out / "attempts.csv", "a") as handle:
            handle.write((tiny_run / "attempts.csv").read_text().splitlines()[4][:40])
        assert main(["report", str(out)]) == 2  # refused: "ends in an incomplete row"
    assert main(["run", *TINY, "--out", str(out), "--resume"]) == 0
    assert (out / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()


def test_a_resume_while_the_run_still_writes_its_folder_stops_at_once(tmp_path, capsys):
    """The same --resume started twice at once: the second stops in one line, naming the
    first's process, and writes nothing."""
    out = tmp_path / "busy"
    proc = _cli("run", *TINY, "--out", str(out))
    try:
        deadline = time.time() + 600
        lock = out / ".graspjax.lock"  # its holder writes its name once it holds it
        while not (lock.exists() and lock.read_text().startswith("process")) \
                and proc.poll() is None and time.time() < deadline:
            time.sleep(0.02)
        assert main(["run", *TINY, "--out", str(out), "--resume"]) == 2
        err = capsys.readouterr().err.strip()
        assert f"is being written by process {proc.pid} on " in err and len(err.splitlines()) == 1
    finally:
        proc.kill()
        proc.wait()


def test_a_write_failure_ends_in_one_line_and_the_run_resumes(tiny_run, tmp_path, monkeypatch,
                                                             capsys):
    """A full disk (or a read-only folder, or a file size limit) mid-run: one line, exit 1,
    no lock left behind, and --resume gives the uninterrupted run's rows."""
    import errno

    from graspjax.outputs import LOCK, RunFolder

    out = tmp_path / "full"
    keep = RunFolder.add

    def add(self, chunk, *args):
        if chunk == 1:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.parts))
        keep(self, chunk, *args)

    monkeypatch.setattr(RunFolder, "add", add)
    assert main(["run", *TINY, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("graspjax: error: No space left on device") and "--resume" in err
    assert len(err.splitlines()) == 1
    assert not (out / LOCK).exists()
    monkeypatch.setattr(RunFolder, "add", keep)
    assert main(["run", *TINY, "--out", str(out), "--resume"]) == 0
    assert (out / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()


def test_parts_of_a_run_assemble_the_same_results(tiny_run, tmp_path, capsys):
    out = tmp_path / "shared"
    assert main(["run", *TINY, "--out", str(out), "--part", "1/2"]) == 0
    assert "part 1/2 done; 1 of 2 chunks" in capsys.readouterr().out
    assert not (out / "attempts.parquet").exists()
    assert main(["run", *TINY, "--out", str(out), "--part", "0/2"]) == 0
    assert (out / "attempts.csv").read_bytes() == (tiny_run / "attempts.csv").read_bytes()


def test_sweep_points_share_one_program_and_have_their_own_seed(tiny_run, tmp_path):
    out = tmp_path / "sweep"
    args = [a for a in TINY if a not in ("--set", "align.window_px=12")]
    assert main(["sweep", *args, "--grid", "align.distance_threshold=0.2,0.3",
                 "--out", str(out)]) == 0
    frame = pd.read_csv(out / "attempts.csv")
    assert sorted(frame["cfg.align.distance_threshold"].unique()) == [0.2, 0.3]
    assert frame.groupby("point")["seed"].first().tolist() == [3, 4]
    assert len(frame) == 12
    timings = pd.read_csv(out / "timings.csv")
    assert timings["group"].nunique() == 1  # a traced value: one compiled program for both
    assert len(pd.read_csv(out / "sweep_summary.csv")) == 2
    assert (out / "sweep_align.distance_threshold.png").is_file()


def test_a_paired_sweep_plays_the_same_worlds_at_every_point():
    points = [Config(), override(Config(), ["align.min_turn_deg=10"])]
    job = plan.Job(("a", "c"), (1, 2), 3)
    free, paired = plan.plan([job], points, 7), plan.plan([job], points, 7, paired=True)
    assert {w.seed for g in free for w in g.worlds if w.point == 1} == {8}
    assert {w.seed for g in paired for w in g.worlds} == {7}
    for group in paired:  # point 1 repeats point 0's worlds, world by world
        first = [(w.setup, w.trial, w.objects) for w in group.worlds if w.point == 0]
        assert first == [(w.setup, w.trial, w.objects) for w in group.worlds if w.point == 1]


@pytest.fixture(scope="module")
def rounds_runs(tmp_path_factory):
    """Setup 2 alone, and Setups 2 and 3 together, in one chunk of 4 worlds each (three of Table
    1's objects: a smaller scene compiles and plays faster)."""
    folder = tmp_path_factory.mktemp("rounds")
    for name, args in ROUNDS_RUNS.items():
        assert main([*args, "--out", str(folder / name)]) == 0
    return folder / "two", folder / "both"


def test_a_world_does_not_depend_on_its_chunk(rounds_runs):
    alone, mixed = (pd.read_csv(d / "attempts.csv").drop(columns=[*VOLATILE, "point"])
                    for d in rounds_runs)
    setup2 = mixed[mixed.setup == 2].reset_index(drop=True)
    pd.testing.assert_frame_equal(alone[alone["round"] < 2].reset_index(drop=True), setup2,
                                  check_dtype=False,  # a column empty in one file reads as float
                                  check_exact=True)  # bit for bit: one shape per device call


def test_rounds_attempt_every_object_once(rounds_runs):
    """Setups 2 and 3: each object gets one row per round; a lifted object leaves the scene."""
    frame = pd.read_csv(rounds_runs[1] / "attempts.csv", keep_default_na=False)
    assert len(frame) == 2 * 2 * len(ROUND_OBJECTS)
    assert (frame["round"] == frame["trial"]).all()  # a round is every object's trial
    for _, part in frame.groupby(["setup", "round"]):
        assert sorted(part["object"]) == ROUND_OBJECTS
        tried = part[part["attempt"] >= 0]
        assert sorted(tried["attempt"]) == list(range(len(tried)))
        lifted = [c for c in part["lifted_object"] if c]
        assert len(lifted) == len(set(lifted))  # nothing is lifted twice
    table = (rounds_runs[1] / "table1.md").read_text()
    assert "Setup 2, ours" in table and "Setup 3, paper" in table


def test_rounds_csv_says_how_dense_the_layouts_were(rounds_runs):
    """One row per Setup 2/3 round: Setup 2's face-to-face gaps in their configured range, Setup
    3's pile denser than the groups (closer than any group may be placed, in some round:
    which round is the physics' float-level luck, it differs between CPUs and between
    float-equal forms of the step, so two rounds' means do not order reliably; whether two of
    the three objects touch in either round is that luck too, so the touching count is checked
    on hand-placed layouts, `test_physics.py`); the table states them beside the rates."""
    from graspjax.config import LayoutConfig

    rounds = pd.read_csv(rounds_runs[1] / "rounds.csv")
    assert sorted(zip(rounds.setup, rounds["round"], strict=True)) == [(2, 0), (2, 1), (3, 0), (3, 1)]
    assert list(rounds.columns) == list(ROUND_COLUMNS)
    cfg = LayoutConfig()
    group = rounds[rounds.setup == 2]
    assert ((group.min_face_gap_m >= cfg.gap_min - 0.002)
            & (group.min_face_gap_m <= cfg.gap_max)).all()
    pile = rounds[rounds.setup == 3]
    assert ((rounds.touching_fraction >= 0) & (rounds.touching_fraction <= 1)).all()
    assert pile.min_face_gap_m.min() < cfg.gap_min
    assert "Setup 3 (2 rounds): touching" in (rounds_runs[1] / "table1.md").read_text()


def test_rounds_csv_measures_clutter_removal(rounds_runs):
    """VGN's metrics per round, from the round's own attempt rows: grasp success rate and
    declutter rate; the protocol as we read the paper attempts each object once."""
    attempts = pd.read_csv(rounds_runs[1] / "attempts.csv", keep_default_na=False)
    rounds = pd.read_csv(rounds_runs[1] / "rounds.csv")
    for row in rounds.itertuples():
        mine = attempts[(attempts.setup == row.setup) & (attempts["round"] == row.round)]
        tried = mine[mine.attempt >= 0]
        assert (row.attempts, row.successes) == (len(tried), tried.success.sum())
        lifted = {c for c in tried.lifted_object if c}
        assert (row.objects_placed, row.objects_removed) == (len(ROUND_OBJECTS), len(lifted))
        assert row.declutter_rate == pytest.approx(len(lifted) / len(ROUND_OBJECTS))
        assert row.grasp_success_rate == pytest.approx(tried.success.mean())
        assert row.end == "once each" and row.method == "paper"
    clutter = pd.read_csv(rounds_runs[1] / "rounds_summary.csv")
    assert list(clutter.setup) == [2, 3] and (clutter.rounds == 2).all()
    table = (rounds_runs[1] / "table1.md").read_text()
    assert "Clutter removal per round" in table and "declutter" in table


@pytest.fixture(scope="module")
def continued_rounds(tmp_path_factory):
    """Setup 2 rounds of a and d continued for up to 4 attempts, under the realistic preset."""
    out = tmp_path_factory.mktemp("continued") / "run"
    assert main([*CONTINUED_RUN, "--out", str(out)]) == 0
    return out


def test_a_continued_round_runs_until_the_scene_is_empty_or_stuck(continued_rounds):
    """`procedure.round_attempts`: an object may be tried again; the round ends empty, stuck
    (two failures in a row) or at its limit, and rounds.csv says which."""
    attempts = pd.read_csv(continued_rounds / "attempts.csv", keep_default_na=False)
    rounds = pd.read_csv(continued_rounds / "rounds.csv")
    assert len(rounds) == 3 and set(rounds.end) <= {"empty", "stuck", "limit"}
    for row in rounds.itertuples():
        tried = attempts[(attempts["round"] == row.round) & (attempts.attempt >= 0)]
        assert row.attempts == len(tried) <= 4
        outcomes = list(tried.sort_values("attempt").success)
        if row.end == "empty":
            assert row.objects_removed == row.objects_placed == 2
        if row.end == "stuck":
            assert outcomes[-2:] == [0, 0]
        # after two failures in a row nothing more is attempted
        assert not any(outcomes[i] == outcomes[i + 1] == 0 for i in range(len(outcomes) - 2))
        lifted = [c for c in tried.lifted_object if c]
        assert len(lifted) == len(set(lifted)) == row.objects_removed


def test_the_realistic_preset_is_recorded_and_runs(continued_rounds):
    meta = json.loads((continued_rounds / "config.json").read_text())
    assert meta["preset"] == "realistic"
    assert meta["overrides"] == {"camera.sensor": "kinect", "detect.wall_check": True,
                                 "procedure.tcp_error": 0.002, "procedure.tilt_error_deg": 1.0,
                                 "align.anchor": "centre", "align.window_centre": "triangle",
                                 "align.turn_normal": "metric", "procedure.round_attempts": 4}
    frame = pd.read_csv(continued_rounds / "attempts.csv")
    assert (frame["cfg.camera.sensor"] == "kinect").all() and frame["cfg.detect.wall_check"].all()


@pytest.fixture(scope="module")
def methods_sweep(tiny_run, tmp_path_factory):
    """The paper's method and the antipodal baseline on the tiny run's worlds (paired)."""
    out = tmp_path_factory.mktemp("methods") / "sweep"
    assert main([*METHODS_SWEEP, "--out", str(out)]) == 0
    return out


def test_a_method_sweep_plays_the_same_worlds_and_compares_them(methods_sweep, tiny_run):
    """The method is a static value: the paper's point reuses the tiny run's program and gives
    its rows, the antipodal point compiles a program of its own."""
    frame = pd.read_csv(methods_sweep / "attempts.csv")
    assert list(frame.groupby("method").size().items()) == [("antipodal", 6), ("paper", 6)]
    assert (frame["method"] == frame["cfg.method"]).all()
    keys = frame.groupby("method")[["seed", "object", "trial"]].apply(
        lambda part: tuple(map(tuple, part.to_numpy())))
    assert len(set(keys)) == 1  # paired: every method plays the same worlds
    timings = pd.read_csv(methods_sweep / "timings.csv")
    assert timings["group"].nunique() == 2
    paper = frame[frame["method"] == "paper"].drop(columns=[*VOLATILE, "point", "cfg.method"])
    reference = pd.read_csv(tiny_run / "attempts.csv").drop(columns=[*VOLATILE, "point"])
    pd.testing.assert_frame_equal(paper.reset_index(drop=True), reference, check_dtype=False)
    comparison = (methods_sweep / "comparison.md").read_text()
    for method in ("paper", "antipodal"):
        assert f"| Setup 1, method={method} |" in comparison
    assert "| Setup 1, the paper |" in comparison
    assert (methods_sweep / "comparison.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    meta = json.loads((methods_sweep / "config.json").read_text())
    assert meta["grid"] == {"method": ["paper", "antipodal"]}


def test_a_worker_process_traces_the_second_program_and_the_rows_stay(methods_sweep, tmp_path,
                                                                       monkeypatch):
    """With a trace worker and an empty store, the run traces its first program itself and a
    helper process traces the second (`compiles.trace_in_worker`); the run loads the helper's,
    says so in timings.csv, and gives the rows of the sweep traced in one process."""
    monkeypatch.setattr(exported, "store", lambda: tmp_path / "exported")
    monkeypatch.setattr(program, "_PROGRAMS", {})  # not the sweep's compiled programs
    monkeypatch.setenv("GRASPJAX_TRACE_WORKERS", "1")
    out = tmp_path / "sweep"
    assert main([*METHODS_SWEEP, "--out", str(out)]) == 0
    timings = pd.read_csv(out / "timings.csv").drop_duplicates("group")
    assert list(timings["program"]) == ["traced", "worker"] and (timings["trace_s"] > 1).all()
    assert len(list((tmp_path / "exported").glob("*.jaxexport"))) == 4  # two programs of two
    ours = pd.read_csv(out / "attempts.csv").drop(columns=VOLATILE)
    reference = pd.read_csv(methods_sweep / "attempts.csv").drop(columns=VOLATILE)
    pd.testing.assert_frame_equal(ours, reference)


def test_helper_processes_play_groups_side_by_side_and_the_files_stay(methods_sweep, tmp_path,
                                                                     monkeypatch):
    """Two processes (`batch.players`): the run plays one method's group, a helper process the
    other's, on a core of its own; the run assembles their parts into the files one process
    writes, byte for byte, and timings.csv says which process played each chunk. The folder
    is given relative to a working directory outside the checkout (the helpers start in
    another): every row lands in it."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "sweep"
    assert main([*METHODS_SWEEP, "--out", "sweep", "--processes", "2"]) == 0
    for name in ("attempts.csv", "rounds.csv"):
        assert (out / name).read_bytes() == (methods_sweep / name).read_bytes()
    timings = pd.read_csv(out / "timings.csv")
    assert timings.groupby("group")["process"].nunique().eq(1).all()  # a group stays together
    assert sorted(timings["process"].unique()) == [0, 1]
    assert not (out / "parts").exists()


def test_a_failed_helper_stops_the_run_with_one_line_and_keeps_the_finished_chunks(
        methods_sweep, tmp_path, monkeypatch, capsys):
    """A helper that fails while the run plays its own share: the run stops the helpers, exits
    non-zero with the helper's last words in one line, and keeps its own finished chunks for
    --resume; no results are assembled."""
    stopped = []

    class FailingHelper:
        def __init__(self, *args, **options):
            self.chunks = args[5]  # (play, experiment, out, meta, process, chunks, ...)

        def check(self):
            raise players.HelperFailed("a helper process of the run failed: MemoryError")

        wait = check

        def stop(self):
            stopped.append(self.chunks)

    monkeypatch.setattr(experiment, "Helper", FailingHelper)
    out = tmp_path / "sweep"
    assert main([*METHODS_SWEEP, "--out", str(out), "--processes", "2"]) == 1
    err = capsys.readouterr().err
    assert err == ("graspjax: error: a helper process of the run failed: MemoryError (the "
                   "finished chunks are kept: the same command with --resume continues)\n")
    assert len(stopped) == 1 and stopped[0]  # the one helper, which had chunks to play
    done = {int(p.stem.split("-")[1]) for p in (out / "parts").glob("attempts-*.parquet")}
    assert done and done.isdisjoint(stopped[0])  # the run's own first chunk, none of the helper's
    assert not (out / "attempts.parquet").exists()


@pytest.mark.parametrize("work, processes, expected", [
    ({0: 120, 1: 840, 2: 120}, 2, [[1], [0, 2]]),  # README's command: the rounds alone
    ({0: 120, 1: 840, 2: 120}, 1, [[0, 1, 2]]),
    ({0: 5, 1: 5}, 4, [[0], [1]]),  # never more shares than groups
    ({3: 10, 5: 9, 7: 8, 9: 7}, 2, [[3, 9], [5, 7]]),  # 10, 9, then the lighter: 9+8, 10+7
    ({2: 1}, 3, [[2]]),
    ({0: 10, 1: 6, 2: 5}, 2, [[1, 2], [0]]),  # 6 + 5 outweighs 10: the lightest share is last
    ({}, 2, [[]]),  # every chunk done already
])
def test_groups_are_shared_among_processes_most_work_first(work, processes, expected):
    assert plan.share(work, processes) == expected


def test_a_stored_program_loads_and_lowers_without_its_scene(tiny_run, monkeypatch):
    """A warm start finds its programs in the store by their key alone and lowers them before
    the scene exists (the run builds it beside the load, `Program.prepare`); the scene is then
    built once."""
    from graspjax.sim import scene_for

    compiled = next(p for p in program._PROGRAMS.values() if p.group.letters == ("a", "c"))
    fresh = program.Program(compiled.group, compiled.batch, compiled.keep_views)
    built = []
    monkeypatch.setattr(program, "scene_for", lambda *args: built.append(args) or scene_for(*args))
    assert fresh.stored() and fresh.origin == "loaded"
    start, attempt = fresh.lower()
    assert built == []
    assert attempt.as_text() == compiled.lower()[1].as_text()  # the run's very program
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        list(pool.map(lambda _: fresh.prepare(), range(2)))  # two threads ask: one build
    assert len(built) == 1 and fresh.arrays[0] is fresh.scene.model


def test_a_bad_trace_worker_count_is_one_line_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("GRASPJAX_TRACE_WORKERS", "many")
    assert main(["run", *TINY, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.strip() == ("graspjax: error: GRASPJAX_TRACE_WORKERS must be a whole number, "
                           "got 'many'")
    assert not (tmp_path / "run").exists()


def test_the_rounds_group_has_the_most_device_work():
    """Calls per world x worlds x moving objects: 10 trials of Table 1's Setup 1 (60 worlds, drop
    and one attempt, one object), its rounds (20 worlds, drop and six attempts, six objects)
    and Table 2 (60 worlds)."""
    groups = plan.plan([plan.table_job(1, 10), plan.table_job(2, 10)], [Config()], 0)
    assert [g.work for g in groups] == [60 * 2 * 1, 20 * 7 * 6, 60 * 2 * 1]


def test_devices_take_the_rounds_first_then_the_drops_of_more_convex_pieces():
    """Tables 1+2 at 10 trials, 30 worlds a chunk: the rounds' chunk (the most work per world)
    first, then g-l's drops (objects of 2 to 15 convex pieces) before a-f's (one piece each),
    though both have the same work per world; plan order within a group."""
    groups = plan.plan([plan.table_job(1, 10), plan.table_job(2, 10)], [Config()], 0)
    assert [g.letters for g in groups] == [tuple("abcdef"), tuple("abcdef"), tuple("ghijkl")]
    assert groups[0].work / 60 == groups[2].work / 60 < groups[1].work / 20
    order = schedule.heaviest_first(plan.chunks(groups, 30), groups)
    assert [(c.group, c.index) for c in order] == [(1, 2), (2, 3), (2, 4), (0, 0), (0, 1)]


class _FakeProgram:
    """A compiled program whose `play` says when each chunk starts playing."""

    def __init__(self, group, started):
        self.group, self.batch, self.started, self.calls = group, 3, started, 0
        self.name = "".join(group.letters)
        self.compiled, self.origin, self.trace_s, self.compile_s = True, "loaded", 0.0, 0.0
        self.devices = [types.SimpleNamespace(memory_stats=lambda: None)]

    def executable(self, device):
        return "loaded"

    def play(self, worlds, points, device, progress):
        self.started[self.calls].set()
        self.calls += 1
        record = types.SimpleNamespace(aimed=np.ones(self.batch, bool))
        return record, [record], None


@pytest.mark.parametrize("keep_views", [False, True])
def test_the_next_chunk_plays_while_the_caller_handles_the_last(monkeypatch, keep_views):
    """The caller's rows and files of one chunk overlap the next chunk's play, unless views are
    kept (two chunks' views would share the device memory)."""
    groups = plan.plan([plan.Job(("a",), (1,), 6)], [Config()], 0)
    started = {i: threading.Event() for i in range(2)}
    fake = _FakeProgram(groups[0], started)
    monkeypatch.setattr(schedule, "program", lambda group, batch, keep: fake)
    chunks = schedule.run_chunks(groups, [Config()], 3, keep_views=keep_views)
    first = next(chunks)
    assert first.chunk.index == 0
    assert started[1].wait(timeout=0 if keep_views else 10) is not keep_views
    assert [r.chunk.index for r in chunks] == [1]


def test_a_program_that_failed_to_compile_raises_after_the_chunks_before_it(monkeypatch):
    """The first group's chunk is handed over (its rows get written) before the second group's
    compile failure surfaces (two objects of one convex piece each: plan order)."""
    groups = plan.plan([plan.Job(("a",), (1,), 3), plan.Job(("b",), (1,), 3)], [Config()], 0)
    fakes = {g.letters: _FakeProgram(g, {i: threading.Event() for i in range(2)}) for g in groups}
    failed = concurrent.futures.Future()
    failed.set_exception(RuntimeError("failed to compile"))
    monkeypatch.setattr(schedule, "program", lambda group, batch, keep: fakes[group.letters])
    monkeypatch.setattr(schedule, "start_compiles",
                        lambda programs, pool, log: {id(fakes[("b",)]): [failed]})
    chunks = schedule.run_chunks(groups, [Config()], 3)
    assert next(chunks).chunk.index == 0
    with pytest.raises(RuntimeError, match="failed to compile"):
        next(chunks)


def test_every_method_traces_into_the_attempt_program(monkeypatch):
    """The highest-PCA baseline in the batch program, traced and exported (not compiled: the
    two methods above run end to end); the store is off, so it is traced here. The search is
    traced once: the idle branch of its conditional takes the shapes of that trace. A Setup 1
    program measures no layout density (rounds.csv has no Setup 1 rows)."""
    monkeypatch.setattr(exported, "store", lambda: None)
    searches, densities = [], []
    search, density = steps._search, steps.layout_stats
    monkeypatch.setattr(steps, "_search", lambda *a, **k: searches.append(1) or search(*a, **k))
    monkeypatch.setattr(steps, "layout_stats",
                        lambda *a: densities.append(1) or density(*a))
    config = override(Config(), ["method=highest-pca", "align.window_px=12"])
    group, = plan.plan([plan.Job(("a", "c"), (1,), 3)], [config], 3)
    start, attempt = program.Program(group, 3, False).portable
    assert not start.loaded and not attempt.loaded
    leaves = jax.tree.leaves(attempt.out_shapes())
    assert leaves and all(leaf.shape[:1] == (3,) for leaf in leaves)  # one slice of 3 worlds
    assert len(searches) == 1 and not densities


@pytest.mark.parametrize("sweep, calls", [("true", 1), ("false", 0)])
def test_the_jaw_sweep_traces_into_the_attempt_program(monkeypatch, sweep, calls):
    """`detect.jaw_sweep` sends every view's grasp through `admit_by_jaws` in the batch program
    (traced and exported, not compiled; its kernel is tested in test_jaws); off, no view does."""
    monkeypatch.setattr(exported, "store", lambda: None)
    swept, admit = [], steps.admit_by_jaws
    monkeypatch.setattr(steps, "admit_by_jaws", lambda *a: swept.append(1) or admit(*a))
    config = override(Config(), [f"detect.jaw_sweep={sweep}"])
    group, = plan.plan([plan.Job(("a", "c"), (1,), 3)], [config], 3)
    _, attempt = program.Program(group, 3, False).portable
    assert jax.tree.leaves(attempt.out_shapes())
    assert len(swept) == calls


def test_two_methods_of_a_paired_sweep_play_the_same_settled_worlds(rounds_runs, tmp_path):
    """Paired means the same world states, not only the same labels: the settled position of
    every object before each round's first attempt (the physics state saved with its views) is
    the same, bit for bit, under the paper's method and the antipodal baseline; and the paper's
    point gives the rows of the plain run of those worlds."""
    out = tmp_path / "methods"
    assert main([*ROUNDS_METHODS, "--out", str(out)]) == 0
    frame = pd.read_csv(out / "attempts.csv")
    first = frame[frame.attempt == 0]
    assert sorted(first.groupby("point").size()) == [4, 4]  # 2 rounds x Setups 2, 3 per method
    settled = {}
    for row in first.itertuples():
        with np.load(out / "views" / f"{attempt_name(row)}.npz") as saved:
            settled[row.point, row.setup, row.trial] = (saved["state.qpos"],
                                                        saved["state.mocap_pos"])
    for (point, setup, trial), (qpos, mocap) in settled.items():
        if point == 1:
            paper_qpos, paper_mocap = settled[0, setup, trial]
            np.testing.assert_array_equal(qpos, paper_qpos)  # every object's pose (and the hand)
            np.testing.assert_array_equal(mocap, paper_mocap)
    assert len(settled) == 8
    paper = frame[frame.point == 0].drop(columns=[*VOLATILE, "point", "cfg.method"])
    plain = pd.read_csv(rounds_runs[1] / "attempts.csv").drop(columns=[*VOLATILE, "point"])
    pd.testing.assert_frame_equal(paper.reset_index(drop=True), plain, check_dtype=False)


def test_failed_attempts_keep_their_views_and_report_draws_them(rounds_runs, capsys):
    folder = rounds_runs[1]
    frame = pd.read_csv(folder / "attempts.csv")
    saved = sorted((folder / "views").glob("*.npz"))
    failed = frame[(frame.attempt >= 0) & (frame.success == 0)]
    assert len(saved) == min(2, len(failed)) and len(failed) > 0
    assert main(["report", str(folder), "--debug", "1"]) == 0
    assert "debug/" in capsys.readouterr().out
    drawn = list((folder / "debug").glob("*.png"))
    assert [p.stem for p in drawn] == [saved[0].stem]
    assert drawn[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_cut_views_file_is_one_line_in_report_debug(rounds_runs, tmp_path, capsys):
    copy = tmp_path / "copy"
    shutil.copytree(rounds_runs[1], copy)
    first = sorted((copy / "views").glob("*.npz"))[0]
    first.write_bytes(first.read_bytes()[:1000])
    assert main(["report", str(copy), "--debug", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{first} cannot be read as saved views" in err


def test_a_chunks_views_are_on_disk_before_the_chunk_counts_as_done(monkeypatch):
    """A kill between the two writes must leave a chunk to replay, views and all: the views
    of a chunk are saved before its part marks it done (`_play`'s order)."""
    order = []
    result = types.SimpleNamespace(chunk=types.SimpleNamespace(index=0), views="views",
                                   timings={})
    monkeypatch.setattr(experiment, "run_chunks", lambda *args, **options: iter([result]))
    monkeypatch.setattr(experiment, "attempt_rows", lambda result, columns: "rows")
    monkeypatch.setattr(experiment, "round_rows", lambda result, columns: "rounds")
    folder = types.SimpleNamespace(add=lambda *args: order.append("chunk done"))
    saver = types.SimpleNamespace(save=lambda *args: order.append("views saved"))
    experiment._play([], [], 3, set(), folder, None, None, None, process=1, saver=saver,
                     keep_views=True)
    assert order == ["views saved", "chunk done"]


def test_a_second_process_on_two_devices_loads_the_programs_and_gives_the_same_rows(
        tiny_run, two_devices):
    """The tiny run left its programs' exported forms and executables in the stores; another
    process, with two CPU devices playing a chunk of 3 worlds each side by side, loads them
    instead of tracing and compiling, says so in timings.csv, and gives the rows of one device
    playing both chunks."""
    proc, folder = two_devices
    assert proc.wait(timeout=900) == 0, (folder / "stderr.txt").read_text()[-2000:]
    out = folder / "run"
    meta = json.loads((out / "config.json").read_text())
    assert len(meta["devices"]) == 2 and meta["batch"] == 3
    timings = pd.read_csv(out / "timings.csv")
    assert set(timings["program"]) == {"loaded"} and timings["trace_s"].max() > 0
    assert sorted(timings["device"]) == [0, 1]  # the two chunks played side by side
    # ... on the executables the one-device run kept (compiled there, or loaded there from an
    # earlier run's store): this process compiles nothing. (Where that run read them from JAX's
    # cache, which keys them by device, they were not kept: `runtime.executables`.)
    if set(pd.read_csv(tiny_run / "timings.csv")["executable"]) <= {"compiled", "loaded"}:
        assert set(timings["executable"]) == {"loaded"}
    ours = pd.read_csv(out / "attempts.csv").drop(columns=VOLATILE)
    reference = pd.read_csv(tiny_run / "attempts.csv").drop(columns=VOLATILE)
    pd.testing.assert_frame_equal(ours, reference, check_exact=True)


def test_two_processes_on_jax_s_distributed_runtime_leave_one_process_s_rows(tiny_run,
                                                                            tmp_path):
    """Two CPU processes joined by `jax.distributed` (`--distributed HOST:PORT,2,I`) share the
    tiny run's two chunks by process index in one folder; once both are played, process 0
    writes the results: the rows of one process, no parts left behind."""
    with socket.socket() as probe:  # a free port for JAX's coordinator (the test's, not ours)
        probe.bind(("localhost", 0))
        port = probe.getsockname()[1]
    out = tmp_path / "run"
    procs = [_cli("run", *TINY, "--distributed", f"localhost:{port},2,{i}", "--out", str(out),
                  env={"JAX_PLATFORMS": "cpu"}) for i in range(2)]
    said = [proc.communicate(timeout=600) for proc in procs]
    for proc, (_, stderr) in zip(procs, said, strict=True):
        assert proc.returncode == 0, stderr[-2000:]
    assert "success" in said[0][0], said[0][1][-2000:]
    assert "process 0 writes the results" in said[1][0], said[1][1][-2000:]
    # where its seconds went, from the interpreter's start (Linux): before, then the run's phases
    if os.path.exists("/proc/self/stat"):
        before = re.search(r"^seconds: before ([\d.]+), start [\d.]+, chunks ", said[0][0],
                           re.M)
        assert before and 0 < float(before.group(1)) < 600
    timings = pd.read_csv(out / "timings.csv")
    assert sorted(timings["process"]) == [0, 1]  # one chunk each
    if set(pd.read_csv(tiny_run / "timings.csv")["executable"]) <= {"compiled", "loaded"}:
        assert set(timings["executable"]) == {"loaded"}  # the one-process run's: no compile
    assert not (out / "parts").exists() and (out / "table1.md").is_file()
    ours = pd.read_csv(out / "attempts.csv").drop(columns=VOLATILE)
    reference = pd.read_csv(tiny_run / "attempts.csv").drop(columns=VOLATILE)
    pd.testing.assert_frame_equal(ours, reference, check_exact=True)


@pytest.mark.parametrize("args, message", [
    (["run", "--setup", "1", "--objects", "a,z", "--trials", "1"], "unknown object 'z'"),
    (["run", "--setup", "1", "--set", "align.windw_px=3"], "did you mean align.window_px"),
    (["run", "--setup", "1", "--set", "align.distance_threshold=-1"], "distance_threshold"),
    (["run", "--setup", "1", "--set", "align.window_px=40"], "window_px must be in [1, 32]"),
    (["run", "--setup", "4"], "--setup must be among"),
    (["run", "--setup", "1", "--trials", "0"], "--trials must be >= 1"),
    (["run", "--table", "1", "--setup", "1"], "either --table"),
    (["run", "--table", "3"], "--table must be among"),
    (["run", "--setup", "1", "--part", "2/2"], "0 <= I < N"),
    (["run", "--setup", "1", "--part", "x"], "--part takes I/N"),
    (["run", "--setup", "1", "--processes", "0"], "--processes must be >= 1, got 0"),
    (["run", "--setup", "1", "--processes", "0", "--dry-run"], "--processes must be >= 1, got 0"),
    (["run", "--setup", "1", "--resume", "--overwrite"], "not both"),
    (["sweep", "--setup", "1", "--grid", "align.window_px=5,x"], "must be int"),
    (["sweep", "--setup", "1"], "needs at least one --grid"),
    # Settings that used to be dropped or pooled silently (issue 55):
    (["run", "--setup", "1", "--objects", ""], "--objects: no objects given"),
    (["run", "--setup", "1", "--set", "align.distance_threshold=inf"], "must be a finite number"),
    (["run", "--setup", "1", "--set", "align.window_px=5", "--set", "align.window_px=7"],
     "align.window_px is given twice"),
    (["sweep", "--setup", "1", "--grid", "align.window_px=10,15", "--grid", "align.window_px=5"],
     "align.window_px is given twice"),
    (["sweep", "--setup", "1", "--grid", "align.window_px=10,15", "--set", "align.window_px=5"],
     "align.window_px is given twice (in two --grid, or in --grid and --set or --config)"),
    (["sweep", "--setup", "1", "--grid", "align.window_px=10,10"],
     "--grid gives one point twice (align.window_px=10 and align.window_px=10)"),
    (["sweep", "--setup", "1", "--grid", "align.distance_threshold=0.3,0.30"], "one point twice"),
    (["run", "--table", "1,1"], "--table names a value twice"),  # one job twice: a run never ends
    (["run", "--setup", "1,2,1"], "--setup names a value twice"),
    # Issue 81: a zipped grid naming one key twice kept its last value alone.
    (["sweep", "--setup", "1", "--grid", "align.window_px:align.window_px=10:11"],
     "--grid align.window_px:align.window_px names align.window_px twice"),
    # Seeds are int32 on the device: refused before the folder, not an OverflowError after it
    (["run", "--setup", "1", "--seed", "2147483648"],
     "--seed must be in [0, 2147483647], got 2147483648"),
    (["sweep", "--setup", "1", "--seed", "2147483647", "--grid", "align.window_px=5,6"],
     "the sweep's 2 points take seeds 2147483647 to 2147483648 (point i: seed + i), past the "
     "largest seed 2147483647; give --seed <= 2147483646, or --paired"),
    (["run", "--setup", "1", "--set", "sim.settle_time=1e9"],
     "SimConfig.settle_time must be > 0 and <= 60 s, got 1000000000.0"),
    # every chunk is padded to the batch: a million worlds took 4.2 GB of host memory
    (["run", "--setup", "1", "--trials", "1", "--batch", "1000000"],
     "--batch must be in [1, 65536] worlds per device call, got 1000000"),
])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, capsys, monkeypatch, args, message):
    def no_run(*args, **kwargs):
        raise AssertionError("a run started")

    monkeypatch.setattr(experiment, "run", no_run)  # refused while the arguments are checked
    out = tmp_path / "out"
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_the_largest_seed_and_batch_are_taken_where_every_point_s_seed_stays_in_range():
    from graspjax.arguments import experiment_request
    from graspjax.parser import build_parser

    sweep = ["sweep", "--setup", "1", "--grid", "align.window_px=5,6", "--out", "x"]
    for args in (["run", "--setup", "1", "--seed", "2147483647", "--batch", "65536", "--out", "x"],
                 [*sweep, "--seed", "2147483646"], [*sweep, "--seed", "2147483647", "--paired"]):
        parsed = build_parser().parse_args(args)
        request = experiment_request(parsed, parsed.grid if args[0] == "sweep" else None)
        assert (request.seed, request.batch) == (parsed.seed, parsed.batch)


def test_unwritable_output_directory(tmp_path, capsys):
    plain_file = tmp_path / "file.txt"
    plain_file.write_text("x")
    assert main(["run", "--setup", "1", "--out", str(plain_file / "out")]) == 2
    assert "is not a directory" in capsys.readouterr().err
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
    # rows with the re-alignment's column but not its companion: one line, no traceback
    rows = pd.DataFrame({"setup": [1], "object": ["a"], "trial": [0], "round": [None], "seed": [0],
                         "success": [1], "outcome": ["SUCCESS"], "reason": ["SUCCESS"],
                         "rescued": [0]})
    rows.to_csv(tmp_path / "attempts.csv", index=False)
    assert main(["report", str(tmp_path)]) == 0


def test_a_background_import_loads_the_module_once_in_its_own_thread(tmp_path, monkeypatch):
    (tmp_path / "slow_to_import.py").write_text(
        "import threading, time\ntime.sleep(0.5)\nIMPORTED_BY = threading.current_thread().name\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "slow_to_import", raising=False)
    experiment.import_in_background.cache_clear()
    experiment.import_in_background("slow_to_import")
    experiment.import_in_background("slow_to_import")  # already on its way: no second thread
    importing = [t for t in threading.enumerate() if t.name == "import slow_to_import"]
    assert len(importing) == 1
    importing[0].join(30)
    assert sys.modules["slow_to_import"].IMPORTED_BY == "import slow_to_import"
    monkeypatch.delitem(sys.modules, "slow_to_import")
    experiment.import_in_background.cache_clear()


def test_the_recorded_command_is_the_one_a_script_typed(tmp_path, monkeypatch):
    """A script that calls `main([...])` (a study in experiments/) records the graspjax command
    it typed in config.json, not its own command line."""
    import shlex

    monkeypatch.setattr(sys, "argv", ["experiments/a_study.py", "window", "threshold"])
    out = tmp_path / "typed dir"  # a space: the command is quoted as a shell would need it
    assert main(["run", *TINY, "--out", str(out)]) == 0
    recorded = json.loads((out / "config.json").read_text())["command"]
    assert recorded == shlex.join(["graspjax", "run", *TINY, "--out", str(out)])
    assert shlex.split(recorded)[1:] == ["run", *TINY, "--out", str(out)]


def test_figure_names_stay_in_the_folder_and_are_distinct(tmp_path):
    """`detect --figures DIR`: images of one file name in sibling folders, or one of them in a
    folder at the root's first level (`/data/x.npy` beside `/mnt/data/x.npy`), get distinct
    bare names, never the root or a separator (a name with the root wrote outside DIR)."""
    cases = [[tmp_path / "a" / "x.npy", tmp_path / "b" / "x.npy"],
             [Path("/gjx81-data/x.npy"), Path("/gjx81-mnt/gjx81-data/x.npy")],
             [Path("/gjx81-data/x.npy"), Path("/gjx81-other/x.npy")]]
    expected = [["a_x.png", "b_x.png"], ["gjx81-data_x.png", "gjx81-mnt_gjx81-data_x.png"],
                ["gjx81-data_x.png", "gjx81-other_x.png"]]
    for paths, names in zip(cases, expected, strict=True):
        got = experiment.figure_names(paths)
        assert got == names
        assert all(Path(n).name == n and (tmp_path / n).parent == tmp_path for n in got)


def _request(args):
    from graspjax.arguments import experiment_request
    from graspjax.parser import build_parser

    parsed = build_parser().parse_args([*args, "--out", "x"])
    return experiment_request(parsed, parsed.grid if args[0] == "sweep" else None)


def test_a_settings_file_is_the_same_run_as_its_sets_and_config_json_records_it(tmp_path):
    import dataclasses

    settings = tmp_path / "s.toml"
    settings.write_text('method = "antipodal"\n[align]\nwindow_px = 12\n[camera]\nsensor = "kinect"\n')
    sets = ["--set", "method=antipodal", "--set", "align.window_px=12", "--set", "camera.sensor=kinect"]
    for command in (["run", "--setup", "1"], ["sweep", "--setup", "1", "--grid", "align.min_inliers=5,9"]):
        from_file = _request([*command, "--config", str(settings)])
        from_sets = _request([*command, *sets])
        assert from_file.config_file == {"path": str(settings), "settings": {
            "method": "antipodal", "align.window_px": "12", "camera.sensor": "kinect"}}
        assert dataclasses.replace(from_file, config_file=None) == from_sets
        meta, other = experiment.run_meta(from_file, 10), experiment.run_meta(from_sets, 10)
        assert meta["run_id"] == other["run_id"] and meta["overrides"] == other["overrides"] == {
            "method": "antipodal", "align.window_px": 12, "camera.sensor": "kinect"}
        assert meta["config_file"] == from_file.config_file and other["config_file"] is None
    # a file and --set of other keys add up; their order does not matter (one validation)
    settings.write_text("sim.min_lift = 0.15\n")  # above the default lift_height: fixed by --set
    both = _request(["run", "--setup", "1", "--config", str(settings), "--set", "sim.lift_height=0.2"])
    assert (both.base.sim.min_lift, both.base.sim.lift_height) == (0.15, 0.2)


@pytest.mark.parametrize("text, args, message", [
    ("[align]\nwindow_px = 12\n", ["--set", "align.window_px=12"],
     "align.window_px is given twice (in --config {path} and on the command line)"),
    ('method = "antipodal"\n', ["--method", "paper"],
     "method is given twice (in --config {path} and on the command line)"),
    ("[align]\nwindw_px = 12\n", [],
     "--config {path}: unknown configuration key 'align.windw_px' (did you mean align.window_px?)"),
    ("align.window_px = 1.5\n", [], "--config {path}: align.window_px must be int, got '1.5'"),
    ("align.window_px = 40\n", [], "--config {path}: AlignConfig.window_px must be in [1, 32], got 40"),
    ('camera = "kinect"\n', [], "--config {path}: unknown configuration key 'camera'"),
    ("align.window_px = 12\n", ["--set", "align.windw_px=3"],  # the --set's mistake: no file named
     "graspjax: error: unknown configuration key 'align.windw_px' (did you mean align.window_px?)"),
    ("[align\n", [], "--config {path}: not valid TOML"),
    (None, [], "--config {path}: No such file or directory"),
])
def test_a_bad_settings_file_is_one_line_exit_2_nothing_written(tmp_path, capsys, monkeypatch, text,
                                                                args, message):
    monkeypatch.setattr(experiment, "run", lambda *a, **k: pytest.fail("a run started"))
    path, out = tmp_path / "s.toml", tmp_path / "out"
    if text is not None:
        path.write_text(text)
    assert main(["run", "--setup", "1", "--config", str(path), *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message.format(path=path) in err and err.count("\n") == 1
    assert not out.exists()


def test_a_grid_over_a_key_of_the_settings_file_is_refused(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text("align.window_px = 12\n")
    for command in (["sweep", "--setup", "1", "--grid", "align.window_px=5,15"],
                    ["planes", "--setup", "1", "--grid", "align.window_px=5,15"]):
        assert main([*command, "--config", str(path), "--out", str(tmp_path / "out")]) == 2
        assert capsys.readouterr().err == ("graspjax: error: align.window_px is given twice (in two "
                                           "--grid, or in --grid and --set or --config)\n")
    assert not (tmp_path / "out").exists()


def test_planes_takes_a_settings_file_as_run_does(tmp_path):
    from graspjax.arguments import plane_request
    from graspjax.parser import build_parser

    path = tmp_path / "s.toml"
    path.write_text("[procedure]\nview_tilt_deg = 30\n")
    common = ["planes", "--setup", "1", "--grid", "align.window_px=5,15", "--out", "x"]
    *request, config_file = plane_request(build_parser().parse_args([*common, "--config", str(path)]))
    *same, none = plane_request(build_parser().parse_args([*common, "--set",
                                                           "procedure.view_tilt_deg=30"]))
    assert request == same and request[1].procedure.view_tilt_deg == 30.0
    assert config_file == {"path": str(path), "settings": {"procedure.view_tilt_deg": "30"}}
    assert none is None


def test_nothing_to_play_shows_no_bar_and_still_says_its_lines(capsys):
    """A run whose rows are all copied (`--reuse`) has no attempts to count: no bar, its log
    lines alone; with a count, the bar."""
    from graspjax.experiment import progress_bar

    for total in (0, 3):
        bar, log = progress_bar(total, quiet=False)
        log("copied")
        bar.close()
        err = capsys.readouterr().err
        assert (err == "copied\n") == (total == 0) and "copied\n" in err


def test_the_progress_bar_names_the_programs_still_compiling(monkeypatch):
    """`run_chunks`' status: both programs while both compile, the second alone once the first
    is ready, nothing once both are."""
    groups = plan.plan([plan.Job(("a",), (1,), 3), plan.Job(("b",), (1,), 3)], [Config()], 0)
    fakes = {g.letters: _FakeProgram(g, {i: threading.Event() for i in range(2)}) for g in groups}
    ready = {letters: concurrent.futures.Future() for letters in fakes}
    monkeypatch.setattr(schedule, "program", lambda group, batch, keep: fakes[group.letters])
    monkeypatch.setattr(schedule, "start_compiles", lambda programs, pool, log: {
        id(fakes[k]): [ready[k], ready[k]] for k in fakes})
    said = []
    chunks = schedule.run_chunks(groups, [Config()], 3, status=said.append)
    ready[("a",)].set_result(None)
    assert next(chunks).chunk.index == 0
    ready[("b",)].set_result(None)
    assert [r.chunk.index for r in chunks] == [1]
    assert said == ["compiling a (Setup 1), b (Setup 1)", "compiling b (Setup 1)", ""]
