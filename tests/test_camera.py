import math

import jax.numpy as jnp
import numpy as np
import pytest

from graspjax import Camera


def test_kinect_intrinsics_match_the_field_of_view():
    cam = Camera.kinect(160, 120)
    # Half the image width subtends half the horizontal field of view.
    assert math.degrees(2 * math.atan(80 / cam.fx)) == pytest.approx(57.0)
    assert math.degrees(2 * math.atan(60 / cam.fy)) == pytest.approx(43.0)
    assert (cam.cx, cam.cy) == (79.5, 59.5)
    assert math.degrees(cam.fov_x) == pytest.approx(57.0)


def test_project_unproject_round_trip():
    cam = Camera.kinect()
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-0.2, 0.2, (50, 2)), rng.uniform(0.3, 2.0, 50)])
    uv = cam.project(jnp.asarray(pts, jnp.float32))
    back = cam.unproject(uv, jnp.asarray(pts[:, 2], jnp.float32))
    np.testing.assert_allclose(np.asarray(back), pts, rtol=1e-5, atol=1e-6)


def test_image_corner_ray_points_along_the_field_of_view():
    cam = Camera.from_fov(64, 48, 90.0)
    # The image edge (-0.5 px) is at 45 degrees for a 90 degree field of view.
    x = cam.unproject(jnp.array([-0.5, cam.cy]), jnp.array(1.0))
    assert float(x[0]) == pytest.approx(-1.0)


def test_d_p_is_a_pixels_footprint_and_printed_eq2_half_of_it():
    cam = Camera.kinect()
    z = 0.5
    footprint = 2 * z * math.tan(math.radians(57) / 2) / 160  # width of the view / pixels
    assert cam.d_p(z) == pytest.approx(footprint)
    printed = z * math.tan(math.radians(57) / 2) / 160  # Eq. 2 as printed
    assert cam.d_p(z, footprint=False) == pytest.approx(printed)
    assert printed == pytest.approx(footprint / 2)


def test_scaled_keeps_the_field_of_view():
    full = Camera.kinect(640, 480)
    small = full.scaled(160, 120)
    assert small.fov_x == pytest.approx(full.fov_x)
    assert (small.cx, small.cy) == pytest.approx((79.5, 59.5))


def test_bad_camera_arguments():
    with pytest.raises(ValueError, match="field of view"):
        Camera.from_fov(160, 120, 0.0)
    with pytest.raises(ValueError, match="too small"):
        Camera.from_fov(4, 4, 60.0)
