"""The perception-only plane study: judged planes against analytic views, its summary by
hand, and the command end to end on a small Setup 1 study."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest

from graspjax import cli
from graspjax.codes import Surface
from graspjax.config import Config, override
from graspjax.planes import FirstView, judge, summarize
from graspjax.stats import detectable_difference
from graspjax.synthetic import analytic_depth, box, rot_y, top_down_pose

CENTRE = override(Config(), ["align.anchor=centre", "align.turn_normal=metric"])  # ours


def _box_view(tilt_deg: float) -> FirstView:
    """A 6 x 5 x 5 cm box on the table seen from 0.45 m, the camera swung `tilt_deg` about the
    world y axis through the box's top centre (as `procedure.view_tilt_deg` swings it)."""
    solid = box((0.06, 0.05, 0.05), (0.0, 0.0, 0.0), 0.3)
    camera = CENTRE.camera.camera()
    rotation, position = top_down_pose(0.5)
    pivot = np.array([0.0, 0.0, 0.05])
    swing = rot_y(np.deg2rad(tilt_deg))
    rotation, position = swing @ rotation, pivot + swing @ (position - pivot)
    depth = analytic_depth(camera, rotation, position, [solid])
    on_box = analytic_depth(camera, rotation, position, [solid], ground=None) > 0
    surface = np.where(on_box, Surface.TARGET, np.where(depth > 0, Surface.TABLE, Surface.NONE))
    return FirstView(depth=jnp.asarray(depth), mask=jnp.asarray(on_box),
                     surface=jnp.asarray(surface, jnp.int32),
                     rotation=jnp.asarray(rotation, jnp.float32),
                     face_normals=jnp.asarray(solid.normals, jnp.float32),
                     face_real=jnp.ones(len(solid.normals), bool), key=jax.random.key(0),
                     target=jnp.int32(0), grasp_found=jnp.array(False))


@pytest.mark.parametrize("tilt_deg", [0.0, 30.0])
def test_the_judged_plane_is_the_boxs_top(tilt_deg):
    """Straight down or swung 30 degrees, the plane around the top's centre is the top: on the
    target, its normal within 2 degrees of the top's, the re-aligned view straight down."""
    truth = judge(_box_view(tilt_deg), CENTRE.align, CENTRE)
    assert Surface(int(truth.surface)) == Surface.TARGET
    assert float(truth.on_target) > 0.9
    assert float(truth.normal_error_deg) < 2.0
    assert float(truth.view_tilt_deg) < 2.0


def test_summary_counts_only_views_that_re_align():
    rows = pd.DataFrame({
        "point": [0] * 6 + [1] * 6,
        "target": ["a"] * 12,
        "first_view_grasp": [True, False, False, False, False, False] * 2,
        "plane_found": [True] * 5 + [False] + [True] * 6,
        "surface": ["target", "target", "target", "table", "target", ""]
                   + ["target", "table", "table", "table", "target", "target"],
        "normal_error_deg": [0.0, 1.0, 3.0, 20.0, 9.0, np.nan] + [0.0, 30, 40, 50, 2.0, 4.0],
        "view_tilt_deg": [0.0, 1.0, 2.0, 70.0, 3.0, np.nan] + [0.0, 70, 71, 72, 1.0, 2.0]})
    summary = summarize(rows, {"align.window_px": [15, 30]}).set_index("point")
    first, second = summary.loc[0], summary.loc[1]
    assert (first["views"], first["plane_found"]) == (5, pytest.approx(4 / 5))
    assert first["on_target"] == pytest.approx(3 / 4)  # of the planes found
    assert first["normal_error_median_deg"] == pytest.approx(6.0)  # 1, 3, 9, 20
    assert first["within_5deg"] == pytest.approx(2 / 4)
    assert second["on_target"] == pytest.approx(2 / 5) and second["align.window_px"] == 30
    assert first["on_target_low"] < first["on_target"] < first["on_target_high"]


def test_detectable_difference_by_hand():
    # 2.8 * sqrt(2 * 0.5 * 0.5 / 10,000) = 0.0198
    assert detectable_difference(0.5, 10_000) == pytest.approx(0.0198, abs=1e-4)
    assert detectable_difference(0.5, 2_500) == pytest.approx(2 * 0.0198, abs=2e-4)


def test_planes_refuses_a_grid_that_is_not_an_alignment_value(tmp_path, capsys):
    code = cli.main(["planes", "--setup", "1", "--objects", "a", "--out", str(tmp_path / "p"),
                     "--grid", "camera.width=80,160"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "align.*" in err
    assert not (tmp_path / "p").exists()


@pytest.mark.slow
def test_planes_end_to_end(tmp_path, capsys):
    """Two tilted first views of a cube per grid point: rows per (point, world), a summary per
    point, one compiled scoring call; a cube's top is judged on the target. Written over a
    finished run's folder (--overwrite): none of the run's files stay beside the study."""
    out = tmp_path / "planes"
    run_files = ["attempts.csv", "attempts.parquet", "rounds.csv.gz", "table1.md",
                 "summary.csv", "views/p000_s1_r00000_a0_a.npz"]
    for name in run_files:
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_text("the run's")
    (out / "config.json").write_text(json.dumps({"versions": {"graspjax": "0.1.0"},
                                                 "finished": "2026-12-01T00:00:00+00:00"}))
    code = cli.main(["planes", "--setup", "1", "--objects", "a", "--trials", "2", "--quiet",
                     "--overwrite",
                     "--set", "procedure.view_tilt_deg=30", "--set", "align.anchor=centre",
                     "--set", "align.turn_normal=metric",  # ours; and a tolerance tighter than
                     "--set", "detect.antipodal_tolerance_deg=15",  # the default: no grasp, so
                     # the tilted views re-align
                     "--grid", "align.window_px=5,15", "--out", str(out), "--batch", "2"])
    assert code == 0, capsys.readouterr().err
    rows = pd.read_csv(out / "planes.csv.gz")
    assert len(rows) == 4 and sorted(rows["align.window_px"].unique()) == [5, 15]
    assert set(rows.target) == {"a"}
    found = rows[rows.plane_found]
    assert len(found) > 0 and (found.surface == "target").all() and (found.normal_error_deg < 2.0).all()
    summary = pd.read_csv(out / "planes_summary.csv")
    assert list(summary.point) == [0, 1]
    assert not any((out / name).exists() for name in run_files)
    assert "timings" in json.loads((out / "config.json").read_text())  # the study's own
    assert (out / "planes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary_bytes = (out / "planes_summary.csv").read_bytes()
    (out / "planes.png").unlink()
    assert cli.main(["report", str(out)]) == 0  # rebuilt from the rows alone
    assert (out / "planes_summary.csv").read_bytes() == summary_bytes
    assert (out / "planes.png").exists()


def test_planes_stops_at_the_lock_of_a_run_writing_the_folder(tmp_path):
    """`graspjax planes` (a CLI process) into the folder of a run still going: one line naming
    the run's process; the run's config.json (what --resume needs) keeps its bytes."""
    import os
    import subprocess
    import sys

    from graspjax.outputs import writing

    out = tmp_path / "run"
    with writing(out):
        (out / "config.json").write_text(json.dumps({"versions": {"graspjax": "0.1.0"}}))
        settings = (out / "config.json").read_bytes()
        done = subprocess.run([sys.executable, "-m", "graspjax.cli", "planes", "--setup", "1",
                               "--objects", "a", "--out", str(out), "--quiet"],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
        assert f"is being written by process {os.getpid()}" in done.stderr
        assert (out / "config.json").read_bytes() == settings


def test_plane_study_figure_names_its_preset_and_outlines_the_papers_cell():
    """Two setups, window x threshold: a panel per setup and statistic, the share on the target
    by hand in its cell, the paper's 15 px / 0.3 outlined, the title naming preset and trials."""
    from matplotlib.patches import Rectangle

    from graspjax.figures.report import planes_figure
    from graspjax.figures.titles import planes_title

    rows = []
    for setup in (1, 3):
        for window in (5, 15):
            for threshold in (0.3, 1.0):
                for view in range(4):  # view 3 found a grasp first: not counted
                    rows.append({"point": 0, "setup": setup, "target": "a",
                                 "align.window_px": window, "align.distance_threshold": threshold,
                                 "first_view_grasp": view == 3, "plane_found": True,
                                 "surface": "target" if view < window // 5 else "table",
                                 "normal_error_deg": float(view), "view_tilt_deg": 0.0})
    meta = {"preset": "paper", "jobs": [{"setups": [1, 3], "trials": 4}], "overrides": {},
            "grid": {"align.window_px": [5, 15], "align.distance_threshold": [0.3, 1.0]}}
    title = planes_title(meta)
    assert "paper preset" in title and "Setups 1, 3" in title and "4 trials per cell" in title
    fig = planes_figure(pd.DataFrame(rows), list(meta["grid"]), title)
    assert "the paper preset's values" in fig._suptitle.get_text()
    heatmaps = [ax for ax in fig.axes if ax.get_title()]
    assert len(heatmaps) == 4  # 2 statistics x 2 setups
    on_target = heatmaps[0].images[0].get_array()
    # 5 px: 1 of 3 views on the target; 15 px: 3 of 3
    assert np.asarray(on_target)[:, 0] == pytest.approx([100 / 3, 100.0])
    outlined = [p for p in heatmaps[0].patches if isinstance(p, Rectangle)]
    assert [(p.get_x(), p.get_y()) for p in outlined] == [(-0.5, 0.5)]  # 15 px (row 1), 0.3 (column 0)


def test_a_planes_dry_run_tells_the_worlds_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "p"
    assert cli.main(["planes", "--setup", "1,3", "--objects", "a,b", "--trials", "3",
                     "--grid", "align.window_px=5,15", "--batch", "4", "--out", str(out),
                     "--dry-run"]) == 0
    printed = capsys.readouterr().out.splitlines()
    # Setup 1: 2 objects x 3 trials = 6 worlds (2 chunks of 4); Setup 3: 3 rounds (1 chunk)
    assert printed[0].startswith("2 grid point(s) scored on every first view, 9 worlds settled "
                                 "and viewed in 3 chunks of up to 4;")
    assert printed[1].endswith("6 worlds, 2 chunk(s)") and printed[2].endswith("3 worlds, 1 chunk(s)")
    assert printed[-1].startswith("estimated: unknown") and not out.exists()
