"""`graspjax detect` end to end: one image, a folder of real-looking images, one-line errors."""

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest
from PIL import Image
from real_scenes import table_scene, with_holes_and_specks

from graspjax import Camera, cli
from graspjax.cli import main
from graspjax.synthetic import analytic_depth, box, top_down_pose

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def kinect_scene(tmp_path_factory):
    """A 640x480 Kinect-like image of a 5 x 9 cm box, as .npy (m) and 16-bit .png (mm)."""
    folder = tmp_path_factory.mktemp("scene")
    rotation, eye = top_down_pose(0.6)
    depth = analytic_depth(Camera.kinect(640, 480), rotation, eye,
                         [box((0.05, 0.09, 0.05), (0.01, 0.02, 0.0), 0.35)])
    np.save(folder / "scene.npy", depth)
    Image.fromarray((depth * 1000).round().astype(np.uint16)).save(folder / "scene.png")
    return folder


@pytest.fixture(scope="module")
def real_folder(tmp_path_factory):
    """The tilted-table scene three ways: .npy (H, W, 1), 16-bit .png in 0.1 mm, .npz with K;
    the intrinsics as a gqcnn .intr file."""
    folder = tmp_path_factory.mktemp("real")
    scene = table_scene()
    noisy = with_holes_and_specks(scene)
    np.save(folder / "a.npy", noisy.depth[..., None])
    Image.fromarray(np.nan_to_num(scene.depth * 1e4).round().astype(np.uint16)).save(folder / "b.png")
    c = scene.camera
    k = np.array([[c.fx, 0, c.cx], [0, c.fy, c.cy], [0, 0, 1]])
    np.savez(folder / "c.npz", depth=scene.depth, K=k)
    (folder / "cam.intr").write_text(json.dumps({"_fx": c.fx, "_fy": c.fy, "_cx": c.cx,
                                                 "_cy": c.cy, "_width": 640, "_height": 480}))
    return folder, scene


@pytest.mark.slow  # runs graspjax detect's whole program
@pytest.mark.parametrize("name", ["scene.npy", "scene.png"])
def test_detect_writes_json_and_figure(kinect_scene, tmp_path, capsys, name):
    out_json, out_png = tmp_path / "r.json", tmp_path / "r.png"
    # Top 3: test_jaws' ranked grasps run the same program (the suite compiles it once).
    assert main(["detect", str(kinect_scene / name), "--json", str(out_json), "--top", "3",
                 "--figure", str(out_png)]) == 0  # the others outlined in the figure
    captured = capsys.readouterr()
    printed = json.loads(captured.out)
    # No intrinsics given, none in the file: the Kinect's, never silently (one line on stderr).
    warnings = [w for w in captured.err.splitlines() if w.startswith("graspjax: warning:")]
    kinect = Camera.kinect(640, 480)
    assert warnings == [f"graspjax: warning: no intrinsics given and none in the files: assuming "
                        f"a Kinect v1's 57 x 43 degree field of view (fx {kinect.fx:.1f}, fy "
                        f"{kinect.fy:.1f} for 640x480); give the camera's own with --intrinsics "
                        "FILE, --K, --fx/--fy/--cx/--cy or --fov-x/--fov-y"]
    assert printed["camera"]["fx"] == pytest.approx(kinect.fx)
    assert printed == json.loads(out_json.read_text())
    assert printed["method"] == "paper" and len(printed["candidates"]) == 3
    grasp = printed["grasp"]
    assert printed["found"] and grasp["found"] and printed["reason"] == "FOUND"
    assert abs(grasp["width"] - 0.05) < 0.005
    # The box top centre (0.01, 0.02, 0.05) in the world is (0.01, -0.02, 0.55) in the camera.
    np.testing.assert_allclose(grasp["position"], [0.01, -0.02, 0.55], atol=0.005)
    # Its pose: the camera looks straight down, so the approach (z column) is the optical axis
    # and the closing axis (x column) lies in the image plane: a turn about z.
    pose = np.array(grasp["pose"])
    c, s = pose[0, 0], pose[1, 0]
    np.testing.assert_allclose(pose[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-6)
    for g in [grasp, *printed["candidates"]]:
        pose = np.array(g["pose"])
        rotation = pose[:3, :3]
        np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-6)
        assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-6)
        np.testing.assert_allclose(rotation[:, 0], g["closing_axis"], atol=1e-6)
        np.testing.assert_allclose(rotation[:, 2], grasp["approach"], atol=1e-6)
        np.testing.assert_allclose(rotation[:, 1], np.cross(grasp["approach"], g["closing_axis"]),
                                   atol=1e-6)
        np.testing.assert_allclose(pose[:3, 3], g["position"], atol=1e-7)
        assert pose[3].tolist() == [0, 0, 0, 1]
    assert printed["working_resolution"] == [640, 480] and printed["downsample"] == 1
    assert printed["support_resolution"] == [160, 120] and printed["window"] == 192
    # Straight down at the table: no virtual view is needed.
    assert printed["view"] == "camera" and printed["support_plane"]["tilt_deg"] < 0.1
    np.testing.assert_allclose(printed["support_plane"]["normal"], [0, 0, -1], atol=1e-3)
    assert printed["alignment"]["found"]
    np.testing.assert_allclose(printed["alignment"]["normal"], [0, 0, -1], atol=1e-3)
    assert out_png.read_bytes()[:8] == PNG


@pytest.mark.parametrize("args, line", [
    (["run", "--trials", "abc", "--out", "x"],
     "graspjax run: error: argument --trials: invalid int value: 'abc' (graspjax run --help)"),
    (["run", "--setup", "1"], "graspjax run: error: the following arguments are required: --out "
                              "(graspjax run --help)"),
    (["detect", "d.npy", "--roi", "-1,0,10,10"], "graspjax detect: error: argument --roi: "
     "expected one argument (a value that starts with '-' goes after '=': --roi=VALUE) "
     "(graspjax detect --help)"),
    (["bogus"], "graspjax: error: argument command: invalid choice: 'bogus' (choose from "
                "'detect', 'run', 'sweep', 'planes', 'config', 'report', 'assets', 'bench') "
                "(graspjax --help)"),
])
def test_argument_mistakes_are_one_line_without_the_usage(capsys, args, line):
    """argparse's own mistakes, as graspjax's: one line (argparse printed its usage first)."""
    with pytest.raises(SystemExit) as stopped:
        main(args)
    assert stopped.value.code == 2 and capsys.readouterr().err == line + "\n"


def test_detect_help_says_what_happens_without_intrinsics(capsys):
    with pytest.raises(SystemExit):
        main(["detect", "--help"])
    assert "else the Kinect's 57 x 43 degrees, with a one-line warning on stderr" in " ".join(
        capsys.readouterr().out.split())


@pytest.mark.slow  # runs graspjax detect's whole program
def test_detect_with_explicit_intrinsics_and_overrides(kinect_scene, capsys):
    cam = Camera.kinect(640, 480)
    args = ["detect", str(kinect_scene / "scene.npy"), "--fx", str(cam.fx), "--fy", str(cam.fy),
            "--downsample", "2", "--set", "detect.min_surface_pixels=100000"]
    assert main(args) == 0  # a traced setting: test_image_batches' large image's program
    captured = capsys.readouterr()
    printed = json.loads(captured.out)
    assert "warning" not in captured.err  # the intrinsics were given
    assert not printed["found"] and printed["reason"] == "SURFACE_TOO_SMALL"  # no top that large
    assert printed["camera"]["fx"] == pytest.approx(cam.fx) and printed["downsample"] == 2


@pytest.mark.slow  # runs graspjax detect's whole program
def test_a_folder_of_real_looking_images(real_folder, tmp_path, capsys):
    folder, scene = real_folder
    out, figures = tmp_path / "out", tmp_path / "figures"
    images = [str(folder / n) for n in ("a.npy", "b.png", "c.npz")]  # the folder's depth files
    # Batched by two, the last batch padded (a CPU's default is one image per call): the
    # program of test_bench's batch.
    assert main(["detect", str(folder), "--depth-scale", "0.0001", "--intrinsics",
                 str(folder / "cam.intr"), "--roi", ",".join(map(str, scene.roi)),
                 "--out", str(out), "--figures", str(figures), "--quiet", "--batch", "2"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[-1] == "3 of 3 images with a grasp"
    table = pd.read_csv(out / "results.csv")
    from graspjax.schema import DETECT_COLUMNS, detect_columns

    assert list(table.columns) == detect_columns()  # the one home of its columns, which
    assert all(DETECT_COLUMNS[c] for c in ("image", "pose_{i}{j}", "landing_fall"))  # docs list
    assert list(table["image"]) == images and table["found"].all()
    assert (table["view"] == "virtual").all() and (table["reason"] == "FOUND").all()
    top = scene.to_camera(scene.top)
    np.testing.assert_allclose(table[["x", "y", "z"]].to_numpy(), np.tile(top, (3, 1)), atol=0.004)
    # Each row's pose (row by row): columns the closing axis, approach x it, the approach (here
    # a virtual view's, tilted), translation G.
    pose = table[[f"pose_{i}{j}" for i in range(4) for j in range(4)]].to_numpy().reshape(-1, 4, 4)
    closing = table[["axis_x", "axis_y", "axis_z"]].to_numpy()
    approach = table[["approach_x", "approach_y", "approach_z"]].to_numpy()
    np.testing.assert_allclose(pose[:, :3, 0], closing, atol=1e-5)
    np.testing.assert_allclose(pose[:, :3, 1], np.cross(approach, closing), atol=1e-5)
    np.testing.assert_allclose(pose[:, :3, 2], approach, atol=1e-5)
    np.testing.assert_allclose(pose[:, :3, 3], table[["x", "y", "z"]].to_numpy(), atol=1e-5)
    np.testing.assert_allclose(np.linalg.det(pose[:, :3, :3]), 1.0, atol=1e-5)
    assert abs(approach[0, 2]) < 0.99  # the virtual view's axis is not the optical axis
    np.testing.assert_allclose(table["support_tilt_deg"], 13.0, atol=0.1)
    assert (table["compute_ms"] > 0).all() and table["width"].between(0.035, 0.045).all()
    assert (table["method"] == "paper").all() and (table["landing_fall"] >= 0.008).all()
    assert (table["placed_by"] == "paper").all()  # a lone box: the T-beam's own grasp
    records = json.loads((out / "results.json").read_text())
    assert [r["image"] for r in records] == images
    assert records[0]["workspace"]["roi"] == list(scene.roi)
    assert records[0]["workspace"]["range"] == [0.0, 10.0]
    assert sorted(p.name for p in figures.iterdir()) == ["a.png", "b.png", "c.png"]
    assert all(p.read_bytes()[:8] == PNG for p in figures.iterdir())


@pytest.mark.slow  # runs graspjax detect's whole program
def test_npz_intrinsics_are_used_when_none_are_given(real_folder, capsys):
    folder, scene = real_folder
    assert main(["detect", str(folder / "c.npz"), "--roi", ",".join(map(str, scene.roi))]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["camera"]["fx"] == 525.0 and printed["camera"]["source"] == "the file's K"
    assert printed["found"]
    np.testing.assert_allclose(printed["grasp"]["position"], scene.to_camera(scene.top),
                               atol=0.004)


@pytest.mark.slow  # runs graspjax detect's whole program
def test_detect_on_an_organised_point_cloud_needs_no_intrinsics(kinect_scene, tmp_path, capsys):
    """The Kinect scene as an .npz holding only `xyz` (back-projected by hand): the intrinsics
    come from its points, so no warning, and the grasp is the depth image's."""
    cam = Camera.kinect(640, 480)
    z = np.load(kinect_scene / "scene.npy").astype(np.float64)
    v, u = np.indices(z.shape)
    xyz = np.stack([(u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z], -1)
    np.savez(tmp_path / "cloud.npz", xyz=xyz.astype(np.float32))
    assert main(["detect", str(tmp_path / "cloud.npz")]) == 0
    captured = capsys.readouterr()
    printed = json.loads(captured.out)
    assert "warning" not in captured.err and printed["camera"]["source"] == "the file's K"
    for key in ("fx", "fy", "cx", "cy"):
        assert printed["camera"][key] == pytest.approx(getattr(cam, key), abs=1e-2)
    assert printed["found"]
    np.testing.assert_allclose(printed["grasp"]["position"], [0.01, -0.02, 0.55], atol=0.005)


def _bad_inputs(folder, tmp_path):
    """(arguments, expected message) of user mistakes, with the files they need."""
    Image.fromarray(np.zeros((480, 640, 3), np.uint8)).save(tmp_path / "photo.png")
    Image.fromarray(np.ones((400, 640), np.uint8)).save(tmp_path / "mask.png")
    (tmp_path / "bad.intr").write_text("{not json")
    np.save(tmp_path / "small.npy", np.ones((100, 100), np.float32))
    metres = np.nan_to_num(np.load(folder / "a.npy")[..., 0]).round().astype(np.uint16)
    Image.fromarray(metres).save(tmp_path / "metres.png")  # a 16-bit PNG of whole metres: 0, 1
    a, b, intr = str(folder / "a.npy"), str(folder / "b.png"), str(folder / "cam.intr")
    undecodable = tmp_path / os.fsdecode(b"b\xffd.npy")  # a name the records could not hold
    shutil.copy(a, undecodable)
    return [
        ([str(tmp_path / "photo.png")], "is a colour image (640x480, 3 channels, uint8)"),
        ([a, "--mask", str(tmp_path / "mask.png")], "is 640x400, the depth images are 640x480"),
        ([a, "--intrinsics", str(tmp_path / "bad.intr")], "cannot read intrinsics from"),
        ([a, "--roi", "60,20,700,350"], "lies outside the 640x480 image"),
        ([b, "--depth-scale", "1"], "every pixel lies outside the depth range 0-10 m"),
        ([a, "--range", "0.1,0.2"], "every pixel lies outside the depth range 0.1-0.2 m"),
        # Depths a thousandfold off (once "camera resolution 0x0" as a traceback):
        ([str(tmp_path / "metres.png")], "metres.png: median depth 0.001 m (in the depth range "
         "0-10 m) is implausible for a depth camera (0.05-20 m): check --depth-scale (metres "
         "per unit of the image, now 0.001)"),
        ([b, "--depth-scale", "1e-6"], "b.png: median depth 0.00749 m (in the depth range 0-10 "
         "m) is implausible for a depth camera (0.05-20 m): check --depth-scale (metres per unit "
         "of the image, now 1e-06)"),
        ([a, "--intrinsics", intr, "--fx", "500"], "not --fx/--fy/--cx/--cy and --intrinsics"),
        ([a, str(tmp_path / "small.npy")], "all images must have one size"),
        ([str(folder / "c.npz"), a], "c.npz holds its intrinsics K but"),
        ([a, b, "--figure", str(tmp_path / "f.png")], "--figure takes one image"),
        ([a, "--set", "image.max_targts=2"], "did you mean image.max_targets"),
        ([a, "--top", "0"], "--top must be >= 1"),
        ([a, "--fx", "nan"], "the intrinsics must be finite numbers"),
        ([a, "--fx", "inf"], "the intrinsics must be finite numbers"),
        # A focal length orders of magnitude off (once "camera resolution 0x0" as a traceback),
        # or in millimetres:
        ([a, "--fx", "1e5"], "the intrinsics from --fx 100000 --fy 100000 --cx 319.5 --cy 239.5 "
                             "give the 640x480 images a 0.367 x 0.275 degree field of view"),
        ([a, "--fx", "1e9"], "--fx 1e+09 --fy 1e+09 --cx 319.5 --cy 239.5 give the 640x480 "
                             "images a 3.67e-05 x 2.75e-05 degree field of view"),
        ([a, "--fx", "1.93"], "a 179 x 179 degree field of view, outside a depth camera's 5-150"),
        ([a, "--set", "image.top_k=2", "--set", "image.top_k=3"], "image.top_k is given twice"),
        ([a, "--set", "image.top_k=100"], "RealImageConfig.top_k must be in [1, 64]"),
        (["missing.npy"], "no such file"),
        ([a, str(undecodable)], "'" + str(tmp_path) + "/b\\udcffd.npy': the file name is not UTF-8 text"),
        ([a, "--method", "antipodal", "--set", "method=paper"], "method is given twice"),
        ([a, "--top", "2", "--set", "image.top_k=3"], "image.top_k is given twice"),
    ]


def test_user_mistakes_get_one_line_exit_2_and_nothing_written(real_folder, tmp_path, capsys):
    folder, _ = real_folder
    for args, message in _bad_inputs(folder, tmp_path):
        out = tmp_path / "out"
        assert main(["detect", *args, "--out", str(out), "--json", str(tmp_path / "r.json")]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1 and "Traceback" not in err, (args, err)
        assert not out.exists() and not (tmp_path / "r.json").exists()


@pytest.mark.parametrize("args, message", [
    (["{scene}", "--set", "align.windw_px=3"], "did you mean align.window_px"),
    (["{scene}", "--set", "align.window_px=0"], "window_px"),
    (["{scene}", "--fov-x", "60", "--fx", "100"], "not --fx/--fy/--cx/--cy and --fov-x/--fov-y"),
    (["{scene}", "--json", "/nonexistent-dir/x.json"], "does not exist"),
    (["{scene}", "--json", "{figure}"], "--json and --figure name the same path"),  # one lost
])
def test_bad_arguments_get_one_line_and_exit_2(kinect_scene, tmp_path, capsys, args, message):
    args = [a.replace("{scene}", str(kinect_scene / "scene.npy")).replace(
        "{figure}", str(tmp_path / "f.png")) for a in args]
    assert main(["detect", *args, "--figure", str(tmp_path / "f.png")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "f.png").exists()


@pytest.mark.parametrize("args, message", [
    (["detect", "--width", "0"], "--width must be >= 16 pixels, got 0"),
    (["detect", "--width", "-5", "--height", "3"], "--width must be >= 16 pixels, got -5"),
    (["pipeline", "--trials", "0"], "--trials must be >= 1, got 0"),
    (["physics", "--seconds", "-1"], "--seconds must be a positive number, got -1"),
    (["physics", "--seconds", "nan"], "--seconds must be a positive number, got nan"),
    (["finish"], "bench finish needs --rows-from FOLDER"),
    (["physics", "--profile", "prof"], "--profile is for bench pipeline and bench detect"),
    (["pipeline", "--profile", "/nonexistent/x/prof"], "cannot write /nonexistent/x/prof"),
    (["finish", "--rows-from", "/nonexistent"], "--rows-from: no attempts.csv in /nonexistent"),
    (["finish", "--rows-from", "results/paper_cpu_10", "--rows", "0"], "--rows must be >= 1"),
])
def test_bench_mistakes_get_one_line_before_anything_compiles(tmp_path, capsys, args, message):
    out = tmp_path / "bench.json"
    assert main(["bench", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not out.exists()


@pytest.mark.parametrize("settings, message", [
    ("{not json", "config.json cannot be read (Expecting property name"),
    ("[1, 2]", "config.json holds no run's settings (a JSON object)"),
    (None, "config.json cannot be read (No such file or directory)"),
])
def test_bench_finish_names_a_folder_without_a_run_s_settings(tmp_path, capsys, settings, message):
    folder = tmp_path / "run"
    shutil.copytree("results/paper_cpu_10", folder)
    if settings is None:
        (folder / "config.json").unlink()
    else:
        (folder / "config.json").write_text(settings)
    out = tmp_path / "bench.json"
    assert main(["bench", "finish", "--rows-from", str(folder), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not out.exists()


@pytest.mark.slow  # starts a Python process that imports JAX (`pytest -m "not slow"`: README)
def test_console_script_exit_status(tmp_path):
    """The installed entry point: a user mistake exits non-zero without a traceback."""
    bad = tmp_path / "neg.npy"
    np.save(bad, -np.ones((20, 20), np.float32))
    proc = subprocess.run([sys.executable, "-m", "graspjax.cli", "detect", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "negative depth" in proc.stderr and "Traceback" not in proc.stderr


def test_console_script_prints_all_its_output_before_it_ends(tmp_path):
    """`entry` ends the process without the interpreter's teardown: what the command printed
    into a pipe (block-buffered) still arrives, with its exit status."""
    proc = subprocess.run([sys.executable, "-m", "graspjax.cli", "assets", str(tmp_path / "a")],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    printed = proc.stdout.split()
    assert len(printed) > 12 and all(Path(p).is_file() for p in printed)
    assert {Path(p).name for p in printed} == {p.name for p in (tmp_path / "a").rglob("*")
                                               if p.is_file()}


def test_bench_detect_takes_the_preset_as_detect_does(tmp_path, monkeypatch):
    """`bench detect --preset realistic --set ...` measures the configuration that `detect
    --preset realistic --set ...` runs (the measurement itself is replaced: not timed here)."""
    import graspjax.bench
    import graspjax.imagefiles.inputs as inputs
    from graspjax.config import Config, RealImageConfig

    seen = {}

    def fake_measure(what, *, config, image, **_):
        seen["bench"] = (config, image)
        return {"what": what}, "measured"

    def fake_prepare(*args, overrides=(), **kwargs):
        seen["detect"] = inputs.split_overrides(overrides)
        raise SystemExit(0)  # stop before any image is read

    monkeypatch.setattr(graspjax.bench, "measure", fake_measure)
    monkeypatch.setattr(inputs, "prepare", fake_prepare)
    extra = ["--set", "image.max_targets=3"]
    out = tmp_path / "bench.json"
    assert main(["bench", "detect", "--preset", "realistic", *extra, "--out", str(out)]) == 0
    assert json.loads(out.read_text()) == {"what": "detect"}
    depth = tmp_path / "d.npy"
    np.save(depth, np.full((8, 8), 0.5, np.float32))
    with pytest.raises(SystemExit):
        main(["detect", str(depth), "--intrinsics", "8,8,5,5,3.5,3.5", "--preset", "realistic",
              *extra, "--out", str(tmp_path / "det")])
    assert seen["bench"] == seen["detect"]
    config, image = seen["bench"]
    assert config.detect.wall_check and not Config().detect.wall_check
    assert image.max_targets == 3 != RealImageConfig().max_targets


def test_config_lists_every_key_with_each_preset_s_default(capsys):
    from graspjax.config import Config
    from graspjax.tree import named_fields

    assert main(["config"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["key", "paper", "realistic", "unit", "kind", "meaning"]
    assert [line.split()[0] for line in lines[1:]] == list(named_fields(Config()))
    row = next(line for line in lines if line.startswith("camera.sensor "))
    assert row.split()[1:5] == ["ideal", "kinect", "static", "exact"]
    assert main(["config", "--preset", "realistic", "--format", "csv", "align.win"]) == 0
    frame = pd.read_csv(io.StringIO(capsys.readouterr().out), keep_default_na=False)
    assert frame.to_dict("records") == [
        {"key": "align.window_px", "realistic": "15", "unit": "pixels", "kind": "traced",
         "meaning": "inlier window in x, y and z (pixels), around window_centre"},
        {"key": "align.window_centre", "realistic": "triangle", "unit": "", "kind": "static",
         "meaning": frame.meaning[1]}]
    assert main(["config", "--format", "json", "detect.wall_check"]) == 0
    [record] = json.loads(capsys.readouterr().out)
    assert record["defaults"] == {"paper": False, "realistic": True} and record["kind"] == "traced"


def test_real_image_settings_are_config_s_and_a_simulated_run_refuses_them(tmp_path, capsys):
    """`Config.image` holds `graspjax detect`'s real-image settings: `graspjax config` lists them
    and `--set image.*` reaches them; a run or sweep, which never reads them, refuses them in one
    line and writes nothing."""
    from graspjax.config import Config, RealImageConfig, override

    assert override(Config(), ["image.top_k=3"]).image == RealImageConfig(top_k=3)
    assert main(["config", "image.top_k"]) == 0
    assert capsys.readouterr().out.splitlines()[1].split()[:3] == ["image.top_k", "1", "1"]
    job = ["--setup", "1", "--objects", "a", "--trials", "1", "--out", str(tmp_path / "run")]
    for args in (["run", *job, "--set", "image.top_k=3"],
                 ["sweep", *job, "--grid", "image.top_k=1,3"]):
        assert main(args) == 2
        err = capsys.readouterr().err.strip()
        assert "image.top_k" in err and "graspjax detect" in err and len(err.splitlines()) == 1
        assert not (tmp_path / "run").exists()


def test_config_with_an_unknown_prefix_is_one_line_and_exit_2(capsys):
    assert main(["config", "algn."]) == 2
    captured = capsys.readouterr()
    assert captured.err == ("graspjax: error: no configuration key starts with 'algn.' "
                            "(did you mean align.?)\n") and not captured.out


def test_a_reader_that_stops_early_is_no_error():
    """`graspjax config | head -1`: the command ends quietly when its reader closes the pipe."""
    done = subprocess.run(f"{sys.executable} -m graspjax.cli config | head -1", shell=True,
                          capture_output=True, text=True, timeout=120)
    assert done.stdout.startswith("key") and "error" not in done.stderr


@pytest.mark.slow  # runs graspjax detect's whole program
def test_detect_gives_each_grasp_in_the_world_frame_with_the_camera_pose(kinect_scene, tmp_path,
                                                                         capsys):
    """The scene's camera looks straight down from 0.6 m (camera to world: x kept, y and z
    flipped, 0.6 m up), given as a gqcnn .tf: the grasp lands on the box top's centre
    (0.01, 0.02, 0.05) in the world, approaching straight down; the CSV's pose_world columns
    are the record's."""
    tf = tmp_path / "camera.tf"
    tf.write_text("camera\nworld\n0 0 0.6\n1 0 0\n0 -1 0\n0 0 -1\n")
    table = tmp_path / "r.csv"
    assert main(["detect", str(kinect_scene / "scene.npy"), "--camera-pose", str(tf), "--top", "3",
                 "--out", str(table), "--quiet"]) == 0
    printed = json.loads(capsys.readouterr().out)
    world = np.array(printed["grasp"]["pose_world"])
    np.testing.assert_allclose(world[:3, 3], [0.01, 0.02, 0.05], atol=0.005)
    np.testing.assert_allclose(world[:3, 2], [0, 0, -1], atol=1e-6)
    assert np.array(printed["camera_pose"])[2, 3] == pytest.approx(0.6)
    rows = pd.read_csv(table)
    for row, candidate in zip(rows.itertuples(), printed["candidates"], strict=True):
        cells = [getattr(row, f"pose_world_{i}{j}") for i in range(4) for j in range(4)]
        np.testing.assert_allclose(np.reshape(cells, (4, 4)), candidate["pose_world"], atol=1e-5)


def test_a_camera_pose_that_is_no_rigid_transform_is_refused_in_one_line(kinect_scene, tmp_path,
                                                                        capsys):
    bad = tmp_path / "pose.txt"
    np.savetxt(bad, np.diag([2.0, 1.0, 1.0, 1.0]))  # a scale, not a rotation
    assert main(["detect", str(kinect_scene / "scene.npy"), "--camera-pose", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"graspjax: error: {bad}: the camera pose's upper-left 3x3 is not a rotation "
                   "(or its last row is not 0 0 0 1)")


def test_a_device_out_of_memory_is_one_line_and_exit_1(monkeypatch, capsys):
    """A batch beyond the device's memory (XLA's RESOURCE_EXHAUSTED, here a real allocation of
    4 EiB on the CPU) ends in one line that names the shortage and the way out, no traceback."""
    def allocate_too_much(args):
        return int(jnp.zeros((1 << 62,), jnp.uint8).sum())

    monkeypatch.setitem(cli.COMMANDS, "config", allocate_too_much)
    assert main(["config"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("graspjax: error: the device ran out of memory (")
    assert "); a smaller --batch needs less" in err
    assert "--resume" not in err  # `config` keeps no chunks (a run's message names --resume)


def test_other_runtime_errors_are_not_taken_for_a_shortage(monkeypatch):
    """A bug's RuntimeError keeps its traceback."""
    def fail(args):
        raise RuntimeError("something else")

    monkeypatch.setitem(cli.COMMANDS, "config", fail)
    with pytest.raises(RuntimeError, match="something else"):
        main(["config"])
