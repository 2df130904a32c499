"""Hull-hull contacts on pair grids (`sim/physics/convex.py`), against MJX's `convex_convex` and against
contacts computed by hand."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from mujoco.mjx._src import collision_convex as mjx_convex
from mujoco.mjx._src import mesh as mjx_mesh
from mujoco.mjx._src.collision_types import ConvexInfo, GeomInfo

from graspjax.geometry import quat_to_matrix
from graspjax.sim.physics import convex
from graspjax.sim.physics.collision import narrow_phase_function
from graspjax.sim.scene import build_scene, mjx


def _rotation(key) -> jax.Array:
    """A uniformly random rotation matrix (3, 3) (a normalized Gaussian quaternion)."""
    q = jax.random.normal(key, (4,))
    return quat_to_matrix(q / jnp.linalg.norm(q))


def _hull(mesh, pos, mat) -> ConvexInfo:
    """A processed mesh (`mjx_mesh.convex`) placed at pos (3,), mat (3, 3)."""
    return ConvexInfo(pos=pos, mat=mat, size=jnp.ones(3), vert=mesh.vert, face=mesh.face,
                      face_normal=mesh.face_normal, edge=mesh.edge,
                      edge_face_normal=mesh.edge_face_normal)


def _box(half, pos, mat) -> ConvexInfo:
    """A box of half sizes (3,) as MJX's box collider sees it, placed at pos (3,), mat (3, 3)."""
    box = mjx_mesh.box(GeomInfo(pos=pos, mat=mat, size=jnp.asarray(half)[None]))
    return box.replace(vert=box.vert[0], face=box.face[0])


@pytest.fixture(scope="module")
def cylinder():
    """The cylinder's hull (object e: a 16-sided prism, 32 vertices) as MJX processes it."""
    scene = build_scene(("e",), objects_collide=False)
    mesh_id = int(scene.mj_model.geom_dataid[np.flatnonzero(scene.geom_object == 0)[0]])
    mesh = mjx_mesh.convex(scene.mj_model, mesh_id)
    assert mesh.vert.shape == (32, 3)
    return mesh, float(jnp.linalg.norm(mesh.vert, axis=1).max())


def _poses(key, count, reach):
    """`count` random poses (pos (3,), mat (3, 3)) around the origin, 0.5 to 1.1 `reach` away."""
    k_dir, k_dist, k_mat = jax.random.split(key, 3)
    direction = jax.random.normal(k_dir, (count, 3))
    direction /= jnp.linalg.norm(direction, axis=1, keepdims=True)
    pos = direction * jax.random.uniform(k_dist, (count, 1), minval=0.5, maxval=1.1) * reach
    return pos, jax.vmap(_rotation)(jax.random.split(k_mat, count))


@pytest.mark.parametrize("other", ["box", "hull", "box second"])
def test_contacts_are_mjx_up_to_rounding(cylinder, other):
    """Random poses of a finger-sized box (first or second of the pair: the hull with fewer
    vertices is swapped first) or a second cylinder against the cylinder: the same normals and
    first two contacts as MJX's; the last two (MJX picks them among the clipped points by
    scores that often tie, so rounding decides) the same in most pairs."""
    mesh, radius = cylinder
    pos, mat = _poses(jax.random.key(0), 300, (1.8 if other == "hull" else 1.0) * radius)
    fixed = _rotation(jax.random.key(1))

    def pair(p, r):
        moving = _hull(mesh, p, r) if other == "hull" else _box(jnp.array([0.01, 0.008, 0.02]), p, r)
        still = _hull(mesh, jnp.zeros(3), fixed)
        return (still, moving) if other == "box second" else (moving, still)

    ours = jax.jit(jax.vmap(lambda p, r: convex._convex_convex(*pair(p, r))))(pos, mat)
    theirs = jax.jit(jax.vmap(lambda p, r: mjx_convex._convex_convex(*pair(p, r))))(pos, mat)
    (dist, point, normal), (want_dist, want_point, want_normal) = (
        jax.tree.map(np.asarray, ours), jax.tree.map(np.asarray, theirs))
    touching = (want_dist < 0).any(1)
    assert 0.3 < touching.mean() < 1.0  # both kinds of pair are tested
    edge_contact = (want_dist[:, 0] < 0) & (want_dist[:, 1:] == 1).all(1)
    assert edge_contact.any() and (touching & ~edge_contact).any()  # edge and face contacts
    np.testing.assert_array_equal((dist < 0).any(1), touching)
    np.testing.assert_allclose(normal, want_normal, atol=1e-5)
    np.testing.assert_allclose(dist[:, :2], want_dist[:, :2], atol=1e-6)
    np.testing.assert_allclose(point[touching, :2], want_point[touching, :2], atol=1e-6)
    same = np.all(np.abs(point - want_point).max(-1) < 1e-6, 1) & np.all(
        np.abs(dist - want_dist) < 1e-6, 1)
    assert same[touching].mean() > 0.85


def _cube_mesh(half: float):
    """A cube as a mesh asset, processed by MJX as a scene's hull would be."""
    corners = " ".join(f"{x * half:g} {y * half:g} {z * half:g}"
                       for x in (-1, 1) for y in (-1, 1) for z in (-1, 1))
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><asset><mesh name="cube" vertex="{corners}"/></asset>'
        '<worldbody><body><freejoint/><geom type="mesh" mesh="cube"/></body></worldbody></mujoco>')
    return mjx_mesh.convex(model, 0)


def test_a_box_pressed_into_a_face_touches_at_its_corners():
    """A 2 x 2 x 2 cm box 1 mm into the top face of a 10 cm cube, turned 30 degrees about the
    vertical: four contacts at the box's bottom corners, 1 mm deep, normal along z."""
    cube = _cube_mesh(0.05)
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    turn = jnp.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    box = _box(jnp.array([0.01, 0.01, 0.01]), jnp.array([0.0, 0.0, 0.059]), turn)
    dist, point, normal = jax.jit(convex._convex_convex)(box, _hull(cube, jnp.zeros(3), jnp.eye(3)))
    np.testing.assert_allclose(dist, -0.001, atol=1e-6)
    corners = np.array([[x, y, 0.0] for x in (-0.01, 0.01) for y in (-0.01, 0.01)]) @ np.asarray(turn).T
    # The contact points lie under the box's four corners, on the reference face: the box's
    # bottom (z = 0.049; the two faces' axes tie and the first hull's comes first).
    np.testing.assert_allclose(np.asarray(point)[:, 2], 0.049, atol=1e-6)
    got = sorted(map(tuple, np.round(np.asarray(point)[:, :2], 6)))
    want = sorted(map(tuple, np.round(corners[:, :2], 6)))
    np.testing.assert_allclose(got, want, atol=1e-6)
    np.testing.assert_allclose(np.asarray(normal), [[0.0, 0.0, -1.0]] * 4, atol=1e-6)  # first to second


def test_crossed_edges_touch_at_one_point():
    """Two cubes (10 cm) edge to edge, crossed at right angles and 1 mm into each other: one
    contact (edge-edge), 1 mm deep, midway between the two edges, normal along the line between
    the centres."""
    cube = _cube_mesh(0.05)
    h = 0.05 * np.sqrt(2)  # centre to edge of a cube turned 45 degrees
    c = s = np.sqrt(0.5)
    lower = jnp.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])  # top edge along x
    upper = jnp.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # bottom edge along y
    gap = -0.001
    first = _hull(cube, jnp.array([0.0, 0.0, 2 * h + gap]), upper)
    second = _hull(cube, jnp.zeros(3), lower)
    dist, point, normal = jax.jit(convex._convex_convex)(first, second)
    assert float(dist[0]) == pytest.approx(gap, abs=1e-6)
    np.testing.assert_array_equal(np.asarray(dist[1:]), 1.0)  # edge contact: one point
    np.testing.assert_allclose(np.asarray(point[0]), [0.0, 0.0, h + gap / 2], atol=1e-5)
    np.testing.assert_allclose(np.asarray(normal), [[0.0, 0.0, -1.0]] * 4, atol=1e-6)  # first to second


def test_hull_pairs_use_the_grid_collider():
    """Box-mesh and mesh-mesh pairs collide on grids; the other pair types are MJX's."""
    box, mesh, plane = (int(t) for t in (mjx.GeomType.BOX, mjx.GeomType.MESH, mjx.GeomType.PLANE))
    assert narrow_phase_function((box, mesh)) is convex.convex_convex
    assert narrow_phase_function((mesh, mesh)) is convex.convex_convex
    assert narrow_phase_function((box, box)) is not convex.convex_convex
    assert narrow_phase_function((plane, mesh)) is not convex.convex_convex
