"""The real-capture judges of experiments/ (`real_depth_sources.label_verdict`), on analytic
depth and labels: a box seen 45 degrees off vertical, grasps whose finger places are known by
construction to stand beside it or on it."""

import sys
from pathlib import Path

import numpy as np
import pytest

from graspjax import Camera
from graspjax.synthetic import analytic_depth, box, rot_x

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
from real_depth_sources import FINGER_OFFSET, label_verdict  # noqa: E402

CAMERA = Camera(320, 240, 300.0, 300.0, 159.5, 119.5)
LENGTH, WIDTH, HEIGHT = 0.10, 0.04, 0.06  # the box: x along, y across, z up (m)
GRASP_DEPTH = 0.02


@pytest.fixture(scope="module")
def scene():
    """The camera 0.5 m from the box's top centre, looking down at it 45 degrees off vertical
    from -y: the box's top and its near (-y) face are seen. Labels: 2 the box, 1 the table."""
    rotation = rot_x(np.pi) @ rot_x(-np.pi / 4)  # camera-to-world: looking down, tilted to +y
    top = np.array([0.0, 0.0, HEIGHT])
    position = top - 0.5 * rotation[:, 2]
    solid = box((LENGTH, WIDTH, HEIGHT), (0.0, 0.0, HEIGHT / 2))
    depth = analytic_depth(CAMERA, rotation, position, [solid])
    alone = analytic_depth(CAMERA, rotation, position, [solid], ground=None)
    labels = np.where(depth > 0, 1, 0) + ((alone > 0) & np.isclose(alone, depth, atol=1e-6))
    return depth, labels.astype(np.int16), rotation, position


def _grasp(scene, centre_world, axis_world):
    """A record and candidate (camera frame) of a top-down grasp at `centre_world`, closing
    along `axis_world`, as wide as the box."""
    _, _, rotation, position = scene
    to_camera = rotation.T
    approach = to_camera @ np.array([0.0, 0.0, -1.0])  # down, as the fingers come
    axis = to_camera @ np.asarray(axis_world, float)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2] = axis, np.cross(approach, axis), approach
    rec = {"camera": {"fx": CAMERA.fx, "fy": CAMERA.fy, "cx": CAMERA.cx, "cy": CAMERA.cy}}
    candidate = {"position": to_camera @ (np.asarray(centre_world) - position),
                 "closing_axis": axis, "pose": pose, "width": WIDTH, "depth": GRASP_DEPTH}
    return rec, candidate


def test_fingers_beside_the_near_face_straddle_though_its_pixel_shows_the_box(scene):
    """Closing across the box (along y): the near finger's place, 6 mm in front of the seen
    near face, projects onto that face; the finger still comes down beside the box."""
    depth, labels, _, _ = scene
    rec, candidate = _grasp(scene, [0.0, 0.0, HEIGHT], [0.0, 1.0, 0.0])
    near = np.asarray(candidate["position"]) - np.asarray(candidate["closing_axis"]) * (
        WIDTH / 2 + FINGER_OFFSET)
    u = int(round(CAMERA.fx * near[0] / near[2] + CAMERA.cx))
    v = int(round(CAMERA.fy * near[1] / near[2] + CAMERA.cy))
    assert labels[v, u] == 2  # the place's pixel shows the box's near face
    assert label_verdict(rec, candidate, depth, labels)


def test_a_finger_on_the_box_s_top_does_not_straddle(scene):
    """Closing along the box's 10 cm length: both finger places lie on its top."""
    depth, labels, _, _ = scene
    rec, candidate = _grasp(scene, [0.0, 0.0, HEIGHT], [1.0, 0.0, 0.0])
    assert not label_verdict(rec, candidate, depth, labels)


def test_a_centre_off_every_object_does_not_straddle(scene):
    depth, labels, _, _ = scene
    rec, candidate = _grasp(scene, [0.1, 0.0, 0.0], [1.0, 0.0, 0.0])
    assert not label_verdict(rec, candidate, depth, labels)
