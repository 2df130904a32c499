"""`graspjax detect` end to end, and its one-line errors."""

import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from graspjax import Camera
from graspjax.cli import main
from graspjax.synthetic import box, render_depth, top_down_pose


@pytest.fixture(scope="module")
def kinect_scene(tmp_path_factory):
    """A 640x480 Kinect-like image of a 5 x 9 cm box, as .npy (m) and 16-bit .png (mm)."""
    folder = tmp_path_factory.mktemp("scene")
    rotation, eye = top_down_pose(0.6)
    depth = render_depth(Camera.kinect(640, 480), rotation, eye,
                         [box((0.05, 0.09, 0.05), (0.01, 0.02, 0.0), 0.35)])
    np.save(folder / "scene.npy", depth)
    Image.fromarray((depth * 1000).round().astype(np.uint16)).save(folder / "scene.png")
    return folder


@pytest.mark.parametrize("name", ["scene.npy", "scene.png"])
def test_detect_writes_json_and_figure(kinect_scene, tmp_path, capsys, name):
    out_json, out_png = tmp_path / "r.json", tmp_path / "r.png"
    assert main(["detect", str(kinect_scene / name), "--json", str(out_json),
                 "--figure", str(out_png)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads(out_json.read_text())
    grasp = printed["grasp"]
    assert grasp["found"] and grasp["reason"] == "FOUND"
    assert abs(grasp["width"] - 0.05) < 0.005
    # The box top centre (0.01, 0.02, 0.05) in the world is (0.01, -0.02, 0.55) in the camera.
    np.testing.assert_allclose(grasp["position"], [0.01, -0.02, 0.55], atol=0.005)
    assert printed["working_resolution"] == [160, 120] and printed["downsample"] == 4
    assert printed["alignment"]["found"]
    np.testing.assert_allclose(printed["alignment"]["normal"], [0, 0, -1], atol=1e-3)
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_detect_with_explicit_intrinsics_and_overrides(kinect_scene, capsys):
    cam = Camera.kinect(640, 480)
    args = ["detect", str(kinect_scene / "scene.npy"), "--fx", str(cam.fx), "--fy", str(cam.fy),
            "--downsample", "2", "--set", "gripper.opening=0.04"]
    assert main(args) == 0
    grasp = json.loads(capsys.readouterr().out)["grasp"]
    assert not grasp["found"] and grasp["reason"] == "TOO_WIDE"  # 5 cm does not fit 4 cm


@pytest.mark.parametrize("args, message", [
    (["missing.npy"], "no such file"),
    (["{scene}", "--set", "align.windw_px=3"], "did you mean align.window_px"),
    (["{scene}", "--set", "align.window_px=0"], "window_px"),
    (["{scene}", "--fov-x", "60", "--fx", "100"], "not both"),
    (["{scene}", "--json", "/nonexistent-dir/x.json"], "does not exist"),
])
def test_bad_input_gets_one_line_and_exit_2(kinect_scene, tmp_path, capsys, args, message):
    args = [a.replace("{scene}", str(kinect_scene / "scene.npy")) for a in args]
    assert main(["detect", *args, "--figure", str(tmp_path / "f.png")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "f.png").exists()


def test_console_script_exit_status(tmp_path):
    """The installed entry point: a user mistake exits non-zero without a traceback."""
    bad = tmp_path / "neg.npy"
    np.save(bad, -np.ones((20, 20), np.float32))
    proc = subprocess.run([sys.executable, "-m", "graspjax.cli", "detect", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "negative depth" in proc.stderr and "Traceback" not in proc.stderr
