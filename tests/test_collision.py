"""The physics step's broad phase over the batch (`sim/physics/collision.py`), against MJX's own."""

import copy

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from graspjax.config import Config
from graspjax.sim.physics import collision
from graspjax.sim.physics.owners import HAND, OBJECTS, STATIC, WORLDS
from graspjax.sim.physics.step import step_with
from graspjax.sim.scene import build_scene, mjx
from graspjax.sim.world import move_hand, reset

CUBE, BLOCK = 0, 1


def test_parts_cut_a_group_by_owner():
    """Pairs of the same owners form one part, in the order of their first pair; two objects'
    pairs are one part whatever the objects."""
    owner = np.array([STATIC, HAND, HAND, 0, 0, 1, 2])
    pairs = np.array([(0, 3), (1, 3), (0, 5), (2, 4), (3, 5), (4, 6), (5, 1)])
    parts = collision.parts(pairs, owner)
    assert [p.owners for p in parts] == [(STATIC, 0), (HAND, 0), (STATIC, 1), (OBJECTS, OBJECTS),
                                         (HAND, 1)]
    assert [p.index.tolist() for p in parts] == [[0], [1, 3], [2], [4, 5], [6]]
    np.testing.assert_array_equal(parts[1].geom, [(1, 3), (2, 4)])
    # Each part's contacts (pair, contact c) hold 10 * pair + c: back in pair order, flat.
    results = [(np.array([[10 * i + c for c in range(2)] for i in part.index], float),)
               for part in parts]
    (flat,) = collision.in_group_order(parts, results)
    np.testing.assert_array_equal(flat, [10 * i + c for i in range(len(pairs)) for c in range(2)])


@pytest.fixture(scope="module")
def pair_scene():
    """A Setup 1 scene of the cube and the block, every contact kept (no max_contact_points),
    so each pair's contacts stay in their own slots. Both are boxes: their pairs with the hand
    share one MJX group, which the broad phase cuts in parts and puts back in order."""
    scene = build_scene(("a", "f"), objects_collide=False)
    mj_model = copy.deepcopy(scene.mj_model)
    mj_model.numeric_data[:] = -1
    return scene, mjx.put_model(mj_model), mj_model


def _worlds(scene, model, mj_model, block_and_hand_near: bool):
    """Two worlds. 0: the cube resting on the table, the block parked, the hand at home.
    1: the same, or the block on the table beside the cube with the hand just above it."""
    n = scene.num_objects
    pos = np.zeros((2, n, 3))
    pos[:, CUBE] = (0.0, 0.0, -0.0005)  # 0.5 mm into the table: the cube's contacts are active
    pos[:, BLOCK] = (0.1, 0.0, 0.0)
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (2, n, 1))
    active = np.array([[True, False], [True, block_and_hand_near]])
    template = mjx.make_data(mj_model)
    data = jax.vmap(lambda p, q, a: reset(scene, template, p, q, a))(pos, quat, active)
    if block_and_hand_near:  # the open hand's finger tips 5 mm above the block's top
        hand = jnp.array([0.1, 0.0, 0.03 + 0.005 + scene.tcp_offset])
        lowered = move_hand(scene, jax.tree.map(lambda x: x[1], data), hand,
                            jnp.array([0.0, 1.0, 0.0, 0.0]), opened=True)
        data = jax.tree.map(lambda x, y: x.at[1].set(y), data, lowered)
    return data


def _slots(mj_model, scene, wanted):
    """Contact slots (in `mjx.make_data`'s order) of the pairs whose owners (a set) are
    `wanted` (a set of sets)."""
    from mujoco.mjx._src import collision_driver

    slots, start = [], 0
    for key, pairs in collision_driver._geom_groups(mj_model).items():
        ncon = collision_driver._COLLISION_FUNC[key.types].ncon
        for g1, g2, _ in pairs:
            if set(scene.geom_owner[[g1, g2]].tolist()) in wanted:
                slots.extend(range(start, start + ncon))
            start += ncon
    return np.array(slots)


def test_far_pairs_are_skipped_and_the_rest_is_mjx(pair_scene):
    """World 0's contacts: MJX's where a part runs; the parked block's and the hand's pairs
    skipped (FAR apart) when no world needs them, run when world 1 does."""
    scene, model, mj_model = pair_scene
    ours = jax.jit(jax.vmap(lambda d: collision.collision(model, mjx.kinematics(model, d),
                                                          scene.geom_owner), axis_name=WORLDS))
    theirs = jax.jit(jax.vmap(lambda d: mjx.collision(model, mjx.kinematics(model, d))))
    cube_on_table = _slots(mj_model, scene, [{STATIC, CUBE}])
    block_and_hand = _slots(mj_model, scene, [{STATIC, BLOCK}, {HAND, BLOCK}, {HAND, CUBE}])
    for near in (False, True):
        data = _worlds(scene, model, mj_model, near)
        got = jax.tree.map(lambda x: np.asarray(x[0]), ours(data)._impl.contact)
        want = jax.tree.map(lambda x: np.asarray(x[0]), theirs(data)._impl.contact)
        np.testing.assert_array_equal(got.geom, want.geom)
        skipped = (got.dist == collision.FAR) & (got.pos == 0.0).all(-1)
        ran = ~skipped
        np.testing.assert_allclose(got.dist[ran], want.dist[ran], atol=1e-6)
        np.testing.assert_allclose(got.pos[ran], want.pos[ran], atol=1e-6)
        assert (want.dist[skipped] > collision.NEAR).all()  # MJX: apart, no force
        assert ran[cube_on_table].all() and (got.dist[cube_on_table] < 0).sum() >= 4
        assert (skipped if not near else ran)[block_and_hand].all()


def test_without_skipping_every_pair_runs_as_in_mjx(pair_scene):
    """`skip_far=False` (the bin scene's step): every pair's contacts, in MJX's slots; the
    scene's pairs are boxes, which MJX's own colliders collide, so the contacts are MJX's."""
    scene, model, mj_model = pair_scene
    ours = jax.jit(jax.vmap(lambda d: collision.collision(
        model, mjx.kinematics(model, d), scene.geom_owner, skip_far=False)))
    theirs = jax.jit(jax.vmap(lambda d: mjx.collision(model, mjx.kinematics(model, d))))
    data = _worlds(scene, model, mj_model, block_and_hand_near=False)
    got, want = ours(data)._impl.contact, theirs(data)._impl.contact
    for name in ("geom", "dist", "pos", "frame"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))


def _cube_and_cylinder(cylinder_vertices: np.ndarray, half: float) -> mujoco.MjModel:
    """A table plane, a cube of half side `half` and a hull of `cylinder_vertices` (V, 3), the
    cube and the hull each free: three pair types (plane-box, plane-mesh, box-mesh), each
    with 4 contact slots, every contact kept in its own slot."""
    vertices = " ".join(f"{v:.9g}" for v in cylinder_vertices.ravel())
    return mujoco.MjModel.from_xml_string(f"""<mujoco>
      <asset><mesh name="cylinder" vertex="{vertices}"/></asset>
      <worldbody>
        <geom name="table" type="plane" size="0.3 0.3 0.01"/>
        <body name="cube"><freejoint/><geom type="box" size="{half} {half} {half}"/></body>
        <body name="cylinder"><freejoint/><geom type="mesh" mesh="cylinder"/></body>
      </worldbody></mujoco>""")


def test_hull_pairs_through_the_step_are_mjx_up_to_rounding():
    """The cube pressed against the upright cylinder's side (a box-mesh pair, the grid
    collider) at five gaps, the cube 0.5 mm and the cylinder 1 mm into the table, every pair
    run (`skip_far=False`) against `mjx.collision`: the same pairs in the same slots, the same
    normals, the hull pair's first two contacts (distances, points) and the table pairs'
    distances equal to float32 rounding (`tests/test_convex.py` compares the hull contacts
    themselves). A model of those three geoms alone: the scenes' hand would only lengthen
    the compile."""
    scene = build_scene(("e",), objects_collide=False)
    mesh = int(scene.mj_model.geom_dataid[np.flatnonzero(scene.geom_object == 0)[0]])
    start, count = scene.mj_model.mesh_vertadr[mesh], scene.mj_model.mesh_vertnum[mesh]
    half = 0.025
    mj_model = _cube_and_cylinder(scene.mj_model.mesh_vert[start:start + count], half)
    model = mjx.put_model(mj_model)
    table, cube, cylinder = 0, 1, 2
    assert list(mj_model.geom_type) == [mjx.GeomType.PLANE, mjx.GeomType.BOX, mjx.GeomType.MESH]
    at_origin = mujoco.MjData(mj_model)  # the hull's vertices in the world, its body at qpos0
    mujoco.mj_kinematics(mj_model, at_origin)
    placed = at_origin.geom_xmat[cylinder].reshape(3, 3)
    vertices = at_origin.geom_xpos[cylinder] + mj_model.mesh_vert @ placed.T  # the only mesh
    radius = np.linalg.norm(vertices[:, :2], axis=1).max()
    worlds = 5
    qpos = np.tile(mj_model.qpos0, (worlds, 1))
    qpos[:, 0] = (radius + half) * np.linspace(0.8, 1.0, worlds)  # cube 0-20 % into the cylinder
    qpos[:, 2] = half - 0.0005
    qpos[:, 7:10] = (0.0, 0.0, -vertices[:, 2].min() - 0.001)
    data = jax.vmap(lambda q: mjx.make_data(mj_model).replace(qpos=q))(jnp.asarray(qpos))
    owner = np.array([STATIC, 0, 1])
    ours = jax.jit(jax.vmap(lambda d: collision.collision(
        model, mjx.kinematics(model, d), owner, skip_far=False)))(data)._impl.contact
    theirs = jax.jit(jax.vmap(lambda d: mjx.collision(model, mjx.kinematics(model, d))))(
        data)._impl.contact
    np.testing.assert_array_equal(ours.geom, theirs.geom)
    np.testing.assert_allclose(ours.frame, theirs.frame, atol=1e-5)
    pairs = np.sort(np.asarray(theirs.geom[0]), 1)
    assert [tuple(p) for p in pairs[::4]] == [(table, cube), (table, cylinder), (cube, cylinder)]
    assert (pairs.reshape(3, 4, 2) == pairs[::4, None]).all()  # 4 slots a pair, in MJX's order
    want = np.asarray(theirs.dist).reshape(worlds, 3, 4)
    assert (want[:-1, 2, :2] < 0).all()  # the hull pair touches where the cube presses in
    np.testing.assert_allclose(want[:, 0].min(1), -0.0005, atol=1e-6)  # the cube on the table
    np.testing.assert_allclose(want[:, 1].min(1), -0.001, atol=1e-6)  # the cylinder on it
    got, got_pos = np.asarray(ours.dist).reshape(worlds, 3, 4), np.asarray(ours.pos)
    np.testing.assert_allclose(got[:, 2, :2], want[:, 2, :2], atol=1e-6)
    np.testing.assert_allclose(got_pos[:, 8:10], np.asarray(theirs.pos)[:, 8:10], atol=1e-6)
    np.testing.assert_allclose(got[:, :2], want[:, :2], atol=1e-6)


def test_the_step_is_mjx_stage_by_stage(pair_scene):
    """With MJX's own collision, `step_with` traces to exactly `mjx.step`'s program: the
    stages, their order and the integrator are MJX's."""
    scene, model, mj_model = pair_scene
    data = mjx.make_data(mj_model)
    theirs = jax.make_jaxpr(lambda d: mjx.step(model, d))(data)
    ours = jax.make_jaxpr(lambda d: step_with(model, d, mjx.collision))(data)
    assert str(ours) == str(theirs)
    without_collision = jax.make_jaxpr(lambda d: step_with(model, d, lambda m, d: d))(data)
    assert str(without_collision) != str(theirs)


def test_scenes_skip_where_it_pays():
    """Setup 1 scenes skip far pairs; the bin scene (objects touch) and `skip_far_pairs=false`
    run every pair."""
    from graspjax.config import override

    off = override(Config(), ["sim.skip_far_pairs=false"])
    assert build_scene(("a",), objects_collide=False).skips_far_pairs
    assert not build_scene(("a",), objects_collide=True).skips_far_pairs
    assert not build_scene(("a",), sim=off.sim, objects_collide=False).skips_far_pairs
