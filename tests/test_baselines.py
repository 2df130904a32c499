"""The other grasp methods (highest-pca, antipodal) and the T-beams spread along each edge,
against analytic depth images of primitives: known principal axes, widths and face normals."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import world_to_camera

from graspjax import DetectorConfig, GraspReason, detect_grasp
from graspjax.config import BaselineConfig, Config, GripperConfig, override
from graspjax.perception.baselines import antipodal_grasp, grasp_method, highest_pca_grasp
from graspjax.synthetic import box, regular_prism

PCA = jax.jit(highest_pca_grasp, static_argnums=(2, 3))
ANTIPODAL = jax.jit(antipodal_grasp, static_argnums=(2, 3, 4))


def _pixel(camera, z):
    return z / min(camera.fx, camera.fy)


def _box_axis(yaw):
    """The box's local x axis (its 4 cm side) in the test camera's frame."""
    return world_to_camera([np.cos(yaw), np.sin(yaw), 0.0]) - world_to_camera([0, 0, 0])


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 75.0, 140.0])
def test_pca_closes_across_the_principal_axis_of_a_rectangle(camera, render, yaw_deg):
    """A 4 x 9 cm top: the principal axis is the 9 cm side, so the jaws close along the 4 cm
    side, at the rectangle's centre, as wide as the rectangle."""
    yaw, centre = np.deg2rad(yaw_deg), (0.01, -0.006)
    g = PCA(jnp.asarray(render([box((0.04, 0.09, 0.04), (*centre, 0.0), yaw)])), camera)
    assert bool(g.found), GraspReason(int(g.reason))
    assert abs(float(jnp.dot(g.closing_axis, _box_axis(yaw)))) > np.cos(np.deg2rad(3.0))
    top = world_to_camera([*centre, 0.04])
    tol = _pixel(camera, top[2])
    assert np.linalg.norm(np.asarray(g.position)[:2] - top[:2]) <= tol
    assert abs(float(g.width) - 0.04) <= 1.5 * tol  # measured on pixels: within 1.5 of them
    assert int(g.candidates.valid.sum()) == 1


def test_pca_refuses_a_top_wider_than_the_opening(camera, render):
    g = PCA(jnp.asarray(render([box((0.09, 0.10, 0.04))])), camera)
    assert not bool(g.found) and GraspReason(int(g.reason)) == GraspReason.TOO_WIDE


@pytest.mark.parametrize("yaw_deg", [0.0, 25.0, 60.0])
def test_antipodal_pairs_on_a_box_join_its_two_long_faces(camera, render, yaw_deg):
    """Every pair that passes lies within the friction cone of the 4 cm side's two faces (the
    9 cm pairs do not fit the opening); the chosen pair is as wide as the box."""
    yaw = np.deg2rad(yaw_deg)
    g = ANTIPODAL(jnp.asarray(render([box((0.04, 0.09, 0.04), yaw=yaw)])), camera)
    assert bool(g.found), GraspReason(int(g.reason))
    axis = _box_axis(yaw)[:2]
    cone = np.cos(np.deg2rad(BaselineConfig().antipodal_cone_deg))
    valid = np.asarray(g.candidates.valid)
    assert valid.sum() >= 5
    assert (np.abs(np.asarray(g.candidates.axis)[valid] @ axis) >= cone - 1e-6).all()
    # Normals are estimated on pixels: the most antipodal pair lies within a few degrees.
    assert abs(float(jnp.dot(g.closing_axis[:2], axis))) > np.cos(np.deg2rad(8.0))
    assert abs(float(g.width) - 0.04) <= 1.5 * _pixel(camera, 0.46)


def test_antipodal_grasps_a_cylinder_through_its_axis(camera, render):
    """A 5 cm round top (a 32-sided prism): the most antipodal pair is a diameter."""
    centre = (0.012, 0.008)
    g = ANTIPODAL(jnp.asarray(render([regular_prism(32, 0.025, 0.05, (*centre, 0.0))])), camera)
    assert bool(g.found), GraspReason(int(g.reason))
    top = world_to_camera([*centre, 0.05])
    tol = _pixel(camera, top[2])
    assert np.linalg.norm(np.asarray(g.position)[:2] - top[:2]) <= 1.5 * tol
    assert abs(float(g.width) - 0.05) <= 1.5 * tol


def test_antipodal_pinches_a_triangle_from_a_side_to_the_opposite_corner(camera, render):
    """An equilateral top has no two parallel sides (the T-beam finds no antipodal edges), but
    a side and the opposite corner are antipodal: the corner's normal cone holds the side's
    normal. The jaws close along a side's normal, as wide as the triangle is high (1.5 R)."""
    radius, yaw = 0.03, 0.2
    depth = jnp.asarray(render([regular_prism(3, radius, 0.04, yaw=yaw)]))
    tbeam = jax.jit(detect_grasp)(depth, camera)
    assert GraspReason(int(tbeam.reason)) == GraspReason.NO_ANTIPODAL
    g = ANTIPODAL(depth, camera)
    assert bool(g.found), GraspReason(int(g.reason))
    side_normals = [world_to_camera([np.cos(a), np.sin(a), 0.0])[:2] - world_to_camera([0, 0, 0])[:2]
                    for a in yaw + np.pi / 3 + 2 * np.pi / 3 * np.arange(3)]
    best = max(abs(float(jnp.dot(g.closing_axis[:2], n))) for n in side_normals)
    assert best > np.cos(np.deg2rad(10.0))  # contacts and normals are pixel estimates
    assert abs(float(g.width) - 1.5 * radius) <= 1.5 * _pixel(camera, 0.46)


def test_antipodal_refuses_a_top_wider_than_the_opening(camera, render):
    g = ANTIPODAL(jnp.asarray(render([box((0.09, 0.10, 0.04), yaw=0.3)])), camera)
    assert not bool(g.found) and GraspReason(int(g.reason)) == GraspReason.TOO_WIDE


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_every_method_reports_an_empty_view_as_no_depth(camera):
    empty = jnp.zeros((camera.height, camera.width), jnp.float32)
    for name in ("paper", "highest-pca", "antipodal"):
        g = jax.jit(grasp_method(name), static_argnums=(2,))(empty, camera, Config(), None)
        assert GraspReason(int(g.reason)) == GraspReason.NO_DEPTH, name


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_tbeams_along_the_edge_get_past_a_neighbour_at_its_middle(camera, render):
    """A 4 x 10 cm box with a 1 cm lower neighbour beside the middle of one long side: the
    paper's single T-beam per edge puts a finger on the neighbour; three along each edge find
    room beside it, off the middle."""
    target = box((0.04, 0.10, 0.04))
    neighbour = box((0.03, 0.03, 0.03), (0.05, 0.0, 0.0))
    depth = jnp.asarray(render([target, neighbour]))
    detect = jax.jit(lambda d, c: detect_grasp(d, camera, c), static_argnums=1)
    one = detect(depth, DetectorConfig())
    three = detect(depth, DetectorConfig(tbeam_positions=3))
    assert not bool(one.found) and GraspReason(int(one.reason)) == GraspReason.NO_ROOM
    assert bool(three.found), GraspReason(int(three.reason))
    along = world_to_camera([0.0, 1.0, 0.0]) - world_to_camera([0, 0, 0])
    offset = abs(float(jnp.dot(three.position - world_to_camera([0, 0, 0.04]), along)))
    assert 0.02 <= offset <= 0.035  # (10 cm - 2 cm) / 3 from the middle
    assert three.candidates.valid.shape == (3 * DetectorConfig().max_edges ** 2,)


def test_method_choice_is_a_static_value_with_a_one_line_error():
    with pytest.raises(ValueError, match="method must be one of"):
        Config(method="gqcnn")
    assert override(Config(), ["method=antipodal"]).method == "antipodal"
    with pytest.raises(ValueError, match="tbeam_positions"):
        DetectorConfig(tbeam_positions=0)
    assert GripperConfig().opening == 0.08  # the baselines share the paper's gripper


@pytest.mark.parametrize("density", [0.0, 0.002, 0.05, 1.0])
def test_antipodal_contacts_are_spread_evenly_through_the_boundary(density):
    """The first contacts are the boundary's pixels at even steps of its raster order, as
    numpy's list of a mask's pixels gives them; a boundary of fewer pixels than contacts has
    every pixel once, in the first slots, and the rest marked not real."""
    from graspjax.perception.baselines import _spread

    mask = np.random.default_rng(1).random((40, 60)) < density
    where = np.flatnonzero(mask)
    for count in (1, 7, 128):
        pixels, real = jax.jit(_spread, static_argnums=1)(mask, count)
        n = min(count, where.size)
        index = (where[(np.arange(count) * where.size) // count] if where.size >= count
                 else where)[:n]
        assert np.array_equal(np.asarray(pixels)[:n], np.stack([index % 60, index // 60], -1))
        assert np.array_equal(np.asarray(real), np.arange(count) < where.size)
