"""Layout samplers of the three setups, and footprint gaps against brute-force polygon distances."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from graspjax.config import LayoutConfig
from graspjax.geometry import quat_to_matrix
from graspjax.sim import OBJECTS, layout
from graspjax.sim.objects import resting_poses

CFG = LayoutConfig()
LETTERS = "abcdef"
POINTS = [OBJECTS[c].points() for c in LETTERS]
PADDED = jnp.asarray(np.stack([np.concatenate([p, np.repeat(p[:1], 40 - len(p), 0)])
                               for p in POINTS]), jnp.float32)
RESTING = jnp.asarray(np.stack([resting_poses(c) for c in LETTERS]), jnp.float32)


def _rotations(quat):
    return np.stack([np.asarray(quat_to_matrix(jnp.asarray(q))) for q in quat])


def _outline(points, rotation, xy):
    """Convex outline (K, 2) of vertices seen from above, at origin xy."""
    flat = (np.asarray(points) @ rotation.T)[:, :2] + xy
    return flat[ConvexHull(flat).vertices]


def _inside(p, poly, margin=0.0):
    """Point p (2,) inside the convex polygon poly (K, 2), `margin` (m) clear of its edges."""
    edges = np.roll(poly, -1, 0) - poly
    cross = (edges[:, 0] * (p[1] - poly[:, 1]) - edges[:, 1] * (p[0] - poly[:, 0])) / np.linalg.norm(
        edges, axis=1)
    return (cross >= margin).all() or (cross <= -margin).all()


def _polygon_distance(a, b):
    """Distance between two disjoint convex polygons (0 if they overlap): brute force."""
    def point_segment(p, s0, s1):
        t = np.clip(np.dot(p - s0, s1 - s0) / np.dot(s1 - s0, s1 - s0), 0, 1)
        return np.linalg.norm(p - (s0 + t * (s1 - s0)))

    if any(_inside(p, b) for p in a) or any(_inside(p, a) for p in b):
        return 0.0
    return min(point_segment(p, s, t) for poly, other in ((a, b), (b, a))
               for p in poly for s, t in zip(other, np.roll(other, -1, 0), strict=True))


def test_footprint_gap_matches_brute_force_polygon_distance():
    rng = np.random.default_rng(0)
    for _ in range(20):
        i, j = rng.choice(6, 2, replace=False)
        rot = [np.asarray(RESTING[k, rng.integers(64)]) for k in (i, j)]
        xy = [np.zeros(2), rng.uniform(-0.12, 0.12, 2)]
        supports = [layout.support(jnp.asarray((POINTS[k] @ r.T)[:, :2], jnp.float32))
                    for k, r in zip((i, j), rot, strict=True)]
        ours = float(layout.gap(supports[0], jnp.asarray(xy[0]), supports[1], jnp.asarray(xy[1])))
        truth = _polygon_distance(_outline(POINTS[i], rot[0], xy[0]), _outline(POINTS[j], rot[1], xy[1]))
        if truth > 0:
            assert truth - 2.5e-4 <= ours <= truth + 1e-6  # under by at most 8 cm / 2 * sin(pi / 512)
        else:
            assert ours <= 1e-4


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_same_seed_same_layout_other_trial_other_layout():
    a = layout.single(layout.layout_key(7, 1, 2, 5), 2, PADDED, CFG)
    b = layout.single(layout.layout_key(7, 1, 2, 5), 2, PADDED, CFG)
    c = layout.single(layout.layout_key(7, 1, 2, 6), 2, PADDED, CFG)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.allclose(a[1], c[1])
    assert not np.allclose(layout.grouped(layout.layout_key(7, 3, 0), RESTING, PADDED, CFG)[0],
                           layout.grouped(layout.layout_key(8, 3, 0), RESTING, PADDED, CFG)[0])


def test_setup1_drops_one_object_from_any_orientation():
    ups = []
    for trial in range(40):
        pos, quat, active = layout.single(layout.layout_key(0, 1, 4, trial), 4, PADDED, CFG)
        assert np.asarray(active).tolist() == [False] * 4 + [True, False]
        assert (np.abs(np.asarray(pos[4, :2])) <= CFG.workspace).all()
        rotation = _rotations(quat)[4]
        lowest = (POINTS[4] @ rotation.T)[:, 2].min() + float(pos[4, 2])
        assert lowest == pytest.approx(CFG.drop_height, abs=1e-6)
        ups.append(rotation[2])  # the world's up in the object frame
    ups = np.array(ups)
    # Uniform orientations: the object's up direction covers the sphere (mean near zero).
    assert np.linalg.norm(ups.mean(0)) < 0.35 and (ups[:, 2] < -0.5).any() and (ups[:, 2] > 0.5).any()


def test_setup2_members_keep_their_face_to_face_gaps():
    for r in range(10):
        pos, quat, active, _ = layout.grouped(layout.layout_key(0, 2, r), RESTING, PADDED, CFG)
        assert np.asarray(active).all()
        rotations, xy = _rotations(quat), np.asarray(pos[:, :2])
        outlines = [_outline(POINTS[i], rotations[i], xy[i]) for i in range(6)]
        apart = np.array([[_polygon_distance(outlines[i], outlines[j]) if i != j else np.inf
                           for j in range(6)] for i in range(6)])
        nearest = apart.min(1)
        assert nearest.min() >= CFG.gap_min - 5e-4  # never nearer than gap_min (brute force)
        assert nearest.max() <= CFG.gap_max + 5e-4  # each next to a member at most gap_max away
        for i in range(6):  # resting on the table: one of the object's resting poses, turned
            lowest = (POINTS[i] @ rotations[i].T)[:, 2].min() + float(pos[i, 2])
            assert lowest == pytest.approx(CFG.drop_clearance, abs=1e-6)


def _apart(pos, quat):
    """Brute-force outline distances (6, 6) of a layout (inf on the diagonal), and whether a
    vertex of one outline lies 1 mm or more inside another (6,) (the outlines overlap)."""
    rotations, xy = _rotations(quat), np.asarray(pos[:, :2])
    outlines = [_outline(POINTS[i], rotations[i], xy[i]) for i in range(6)]
    apart = np.array([[_polygon_distance(outlines[i], outlines[j]) if i != j else np.inf
                       for j in range(6)] for i in range(6)])
    overlaps = [any(_inside(p, outlines[j], 0.001) or any(_inside(q, outlines[i], 0.001)
                                                          for q in outlines[j])
                    for j in range(6) if j != i for p in outlines[i]) for i in range(6)]
    return apart, np.array(overlaps)


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_setup3_places_setup2s_group_touching_or_overlapping():
    """The paper's Setup 3 (default): Setup 2's group with every gap 0, so each object's outline
    touches another's (brute force: distance 0) and overlaps none; with negative gaps (the
    density sweep's denser point, U(-2 cm, 0)) most outlines overlap a neighbour's as placed.
    Resting poses on the table, as Setup 2's; for one key the same objects, poses and order as
    any other gaps give (the paired density sweep), the gaps alone differ."""
    assert CFG.bin is False and CFG.pile_gap_min == CFG.pile_gap_max == 0
    overlapping = 0
    for r in range(10):
        key = layout.layout_key(0, 3, r)
        pos, quat, active, order = layout.grouped(key, RESTING, PADDED, CFG, CFG.pile_gap_min,
                                                  CFG.pile_gap_max)
        assert np.asarray(active).all() and sorted(np.asarray(order).tolist()) == list(range(6))
        apart, overlaps = _apart(pos, quat)
        assert (apart.min(1) <= 5e-4).all()  # every object meets another's outline
        assert not overlaps.any()  # ... and lies inside none
        denser = layout.grouped(key, RESTING, PADDED, CFG, -0.02, 0.0)
        overlapping += int(_apart(*denser[:2])[1].sum())
        sparse = layout.grouped(key, RESTING, PADDED, CFG)  # Setup 2's gaps, the same key
        for other in (denser, sparse):
            np.testing.assert_array_equal(np.asarray(other[1]), np.asarray(quat))
            np.testing.assert_array_equal(np.asarray(other[3]), np.asarray(order))
        assert _apart(*sparse[:2])[0].min(1).min() >= CFG.gap_min - 5e-4
    assert overlapping >= 30  # of 60: with gaps down to -2 cm most outlines overlap as placed


def test_setup3_in_the_bin_drops_from_random_orientations_inside_its_walls():
    in_bin = LayoutConfig(bin=True)
    ups = []
    for r in range(10):
        pos, quat, active, order = layout.in_bin(layout.layout_key(0, 3, r), PADDED, in_bin)
        assert np.asarray(active).all() and sorted(np.asarray(order).tolist()) == list(range(6))
        rotations = _rotations(quat)
        for i in range(6):
            world = POINTS[i] @ rotations[i].T + np.asarray(pos[i])
            assert (np.abs(world[:, :2]) <= in_bin.bin_size / 2 + 1e-6).all()  # inside the walls
            assert world[:, 2].min() == pytest.approx(in_bin.drop_clearance, abs=1e-6)
        ups.append(rotations[:, :, 2])
    ups = np.concatenate(ups)
    assert (ups[:, 2] < -0.5).any() and (ups[:, 2] > 0.5).any()  # any orientation


def test_the_bin_floor_is_at_most_twice_the_objects_footprint():
    """The bin variant's clutter: objects a-f cover about half the bin's floor."""
    mean_area = sum(np.mean([ConvexHull((POINTS[i] @ r.T)[:, :2]).volume
                             for r in np.asarray(RESTING[i])]) for i in range(6))
    assert CFG.bin_size ** 2 <= 2.0 * mean_area


@pytest.mark.slow  # compiles programs of its own (`pytest -m "not slow"`: README)
def test_samplers_vmap_over_keys():
    keys = jax.vmap(lambda i: layout.layout_key(1, 3, i))(jnp.arange(4))
    pos, quat, active, order = jax.vmap(lambda k: layout.grouped(
        k, RESTING, PADDED, CFG, CFG.pile_gap_min, CFG.pile_gap_max))(keys)
    assert pos.shape == (4, 6, 3) and quat.shape == (4, 6, 4) and active.shape == (4, 6)
    assert order.shape == (4, 6)
    one = layout.grouped(layout.layout_key(1, 3, 2), RESTING, PADDED, CFG, CFG.pile_gap_min,
                         CFG.pile_gap_max)
    np.testing.assert_allclose(pos[2], one[0], rtol=1e-6, atol=1e-7)
