import jax
import jax.numpy as jnp
import numpy as np

from graspjax.config import LayoutConfig
from graspjax.geometry import quat_to_matrix
from graspjax.sim import OBJECTS, layout

CFG = LayoutConfig()
LETTERS = "abcdef"
RADIUS = np.array([OBJECTS[c].footprint_radius for c in LETTERS])
POINTS = [OBJECTS[c].points() for c in LETTERS]
PADDED = np.stack([np.concatenate([p, np.repeat(p[:1], 40 - len(p), 0)]) for p in POINTS])


def test_same_seed_same_layout_other_trial_other_layout():
    a = layout.single(layout.layout_key(7, 1, 2, 5), 2, 6, CFG)
    b = layout.single(layout.layout_key(7, 1, 2, 5), 2, 6, CFG)
    c = layout.single(layout.layout_key(7, 1, 2, 6), 2, 6, CFG)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.allclose(a[0], c[0])
    assert not np.allclose(layout.dense(layout.layout_key(7, 3, 0), PADDED, CFG)[0],
                           layout.dense(layout.layout_key(8, 3, 0), PADDED, CFG)[0])


def test_setup1_one_object_in_the_workspace():
    for trial in range(20):
        pos, quat, active = layout.single(layout.layout_key(0, 1, 4, trial), 4, 6, CFG)
        assert np.asarray(active).tolist() == [False] * 4 + [True, False]
        assert (np.abs(np.asarray(pos[4, :2])) <= CFG.workspace).all()
        np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, rtol=1e-6)


def test_setup2_neighbours_keep_a_gap():
    for r in range(20):
        pos, _, active = layout.grouped(layout.layout_key(0, 2, r), RADIUS, CFG)
        xy = np.asarray(pos[:, :2])
        assert np.asarray(active).all()
        dist = np.linalg.norm(xy[:, None] - xy[None], axis=-1)
        clearance = dist - RADIUS[:, None] - RADIUS[None]
        np.fill_diagonal(clearance, np.inf)
        assert clearance.min() >= CFG.gap_min - 1e-6  # footprint circles never touch
        assert clearance.min() <= CFG.gap_max + 1e-6  # and the group stays together


def test_setup3_dense_stack_starts_without_overlap():
    for r in range(10):
        pos, quat, _ = layout.dense(layout.layout_key(0, 3, r), PADDED, CFG)
        assert (np.linalg.norm(np.asarray(pos[:, :2]), axis=1) <= CFG.dense_radius + 1e-6).all()
        spans = []
        for i in range(6):
            rot = np.asarray(quat_to_matrix(jnp.asarray(quat[i])))
            z = (POINTS[i] @ rot.T)[:, 2] + float(pos[i, 2])
            spans.append((z.min(), z.max()))
            tilt = np.degrees(np.arccos(np.clip(rot[2, 2], -1, 1)))
            assert tilt <= CFG.dense_tilt_deg + 1e-3
        spans.sort()
        assert spans[0][0] >= CFG.drop_clearance - 1e-6  # nothing starts in the table
        for (_, top), (bottom, _) in zip(spans[:-1], spans[1:], strict=True):
            assert bottom > top  # each object starts above everything dropped before it


def test_samplers_vmap_over_keys():
    keys = jax.vmap(lambda i: layout.layout_key(1, 3, i))(jnp.arange(4))
    pos, quat, active = jax.vmap(lambda k: layout.dense(k, PADDED, CFG))(keys)
    assert pos.shape == (4, 6, 3) and quat.shape == (4, 6, 4) and active.shape == (4, 6)
    np.testing.assert_array_equal(pos[2], layout.dense(layout.layout_key(1, 3, 2), PADDED, CFG)[0])
