"""`check_placements`: only the admissible placements are checked, a chunk at a time, each as
it would be checked alone."""

import jax
import jax.numpy as jnp
import numpy as np

from graspjax import DetectorConfig, GraspReason, GripperConfig
from graspjax.perception import placements
from graspjax.synthetic import box


def test_placements_checked_in_chunks_are_checked_as_alone(camera, render):
    """A 4 x 9 x 5 cm box beside a lower one; 200 placements (about 160 admissible: three
    chunks) at random centres, axes and widths over both, and eight across the box's 4 cm
    side. Each gets the reason and reach it gets checked alone; the inadmissible are
    NO_ANTIPODAL with no reach."""
    depth = jnp.asarray(render([box((0.04, 0.09, 0.05)), box((0.05, 0.05, 0.03), (0.07, 0.0, 0.0))]))
    z_s = jnp.float32(0.45)  # the box's top, 5 cm above the table, 0.5 m below the camera
    valid = depth > 0
    cluster = valid & (jnp.abs(depth - z_s) < 1e-3)
    rng = np.random.default_rng(0)
    n = 200
    g_xy = rng.uniform(-0.06, 0.1, (n, 2))
    g_xy[:8] = rng.uniform(-0.002, 0.002, (8, 2))  # on the box's centre: camera x, y = world x, -y
    angle = rng.uniform(0.0, np.pi, n)
    angle[:8] = rng.uniform(-0.05, 0.05, 8)  # closing along world x, across the 4 cm side
    axis = np.stack([np.cos(angle), np.sin(angle)], -1)
    width = rng.uniform(0.003, 0.1, n)
    width[:8] = 0.04
    admissible = rng.random(n) < 0.8
    admissible[:8] = True
    config, gripper = DetectorConfig(wall_check=True), GripperConfig()
    check = jax.jit(placements.check_placements)

    def checked(index):
        return check(depth, valid, cluster, z_s, camera, jnp.asarray(g_xy[index], jnp.float32),
                     jnp.asarray(axis[index], jnp.float32), jnp.asarray(width[index], jnp.float32),
                     jnp.asarray(admissible[index]), config, gripper)

    together = checked(np.arange(n).reshape(10, 20))  # any leading shape
    alone = [checked(np.array([i])) for i in range(n)]
    reason, reach = (np.asarray(x).reshape(-1) for x in together)
    assert int(admissible.sum()) > 2 * placements._CHECK_CHUNK  # three chunks
    np.testing.assert_array_equal(reason, [int(r[0]) for r, _ in alone])
    np.testing.assert_array_equal(reach, [float(d[0]) for _, d in alone])
    assert np.all(reason[~admissible] == GraspReason.NO_ANTIPODAL)
    assert np.all(np.isnan(reach[~admissible])) and np.all(np.isfinite(reach[admissible]))
    assert np.all(reason[:8] == GraspReason.FOUND)
    assert len(set(reason[admissible].tolist())) >= 4  # the random ones fail in several ways
