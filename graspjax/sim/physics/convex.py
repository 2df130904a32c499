"""MJX's convex-convex narrow phase (box-mesh, mesh-mesh), its pair grids laid out for the CPU.

MJX's `collision_convex.convex_convex` runs a separating axis test on the Gauss map (face
normals of both hulls, then every pair of edges that forms a face of the Minkowski difference)
and builds up to four contacts by clipping the incident face against the reference face. Its
pair tests are written per pair and vmapped, on arrays of 3-vectors: a box against the
32-vertex cylinder hull tests 576 edge pairs and clips 2 x 16 x 16 edges against planes, each
a (..., 3) array whose x, y, z are strided. On XLA:CPU that leaves the arithmetic unvectorized:
the narrow phase was three quarters of a physics step (results/benchmarks).

Here the same tests are written on grids: one axis per edge (or plane) of each side, each
coordinate its own array, and what depends on one edge alone (its direction, its Gauss-map arc)
computed once per edge instead of once per pair. The algorithm, its thresholds and the order
of the candidates are MJX's; the order of some float32 sums may differ, and where MJX picks a
third or fourth contact among clipped points whose scores tie, rounding may then pick another
(tests/test_convex.py compares contacts with MJX's on the scenes' hulls).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from graspjax import privates


def _xyz(v: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The coordinates of vectors (..., 3) as three arrays (...)."""
    return v[..., 0], v[..., 1], v[..., 2]


def _dot(u, v):
    """Dot products of coordinate triples (broadcast)."""
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _cross(u, v):
    """Cross products of coordinate triples (broadcast), as `jnp.cross`."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _sub(u, v):
    """Differences of coordinate triples (broadcast)."""
    return (u[0] - v[0], u[1] - v[1], u[2] - v[2])


def _side(triple, axis: int):
    """A coordinate triple of (n,) arrays as one side of a grid: along axis 1 (1, n) or 0 (n, 1)."""
    return tuple(jnp.expand_dims(c, 1 - axis) for c in triple)


def _edge_contact(centroid_a, edges_a, edges_b, edge_normals_a, edge_normals_b):
    """The deepest edge-edge axis (MJX's edge pass of `_sat_gaussmap`): over the grid (Eb, Ea)
    of edge pairs whose Gauss-map arcs cross, the axis of largest separation. Returns its
    distance () (-inf: none), axis (3,) and the two edges' end points (a0, a1, b0, b1) (3,)."""
    count_a = edges_a.shape[0]
    dir_a = jax.vmap(privates.normalize)(edges_a[:, 0] - edges_a[:, 1])
    dir_b = jax.vmap(privates.normalize)(edges_b[:, 0] - edges_b[:, 1])
    # Arcs (a1, a2) of hull a and (-b1, -b2) of hull b cross (MJX's `_arcs_intersect`).
    a1, a2 = _xyz(edge_normals_a[:, 0]), _xyz(edge_normals_a[:, 1])
    b1, b2 = _xyz(-edge_normals_b[:, 0]), _xyz(-edge_normals_b[:, 1])
    arc_a = _side(_cross(a2, a1), 1)  # per edge of a
    arc_b = _side(_cross(b2, b1), 0)  # per edge of b
    cba, dba = _dot(_side(b1, 0), arc_a), _dot(_side(b2, 0), arc_a)
    adc, bdc = _dot(_side(a1, 1), arc_b), _dot(_side(a2, 1), arc_b)
    minkowski = (cba * dba < 0) & (adc * bdc < 0) & (cba * bdc > 0)
    # The axis across both edges, pointing from a to b (b's frame: b at the origin).
    axis = _cross(_side(_xyz(dir_a), 1), _side(_xyz(dir_b), 0))
    degenerate = _dot(axis, axis) < 1e-6
    norm = jnp.sqrt(_dot(axis, axis))  # MJX's norm but for |axis| < 1e-8: degenerate, unused
    norm = norm + 1e-6 * (norm == 0.0)
    axis = tuple(c / norm for c in axis)
    start_a = _side(_xyz(edges_a[:, 0]), 1)
    sign = jnp.where(_dot(axis, _sub(start_a, _xyz(centroid_a))) > 0.0, 1.0, -1.0)
    axis = tuple(c * sign for c in axis)
    dist = _dot(axis, _sub(_side(_xyz(edges_b[:, 0]), 0), start_a))
    dist = jnp.where(degenerate | ~minkowski, -jnp.inf, dist).reshape(-1)
    best = jnp.argmax(dist)  # flat index b * Ea + a: MJX's pair order
    axis = jnp.stack([c.reshape(-1)[best] for c in axis])
    ia, ib = best % count_a, best // count_a
    return dist[best], axis, edges_a[ia, 0], edges_a[ia, 1], edges_b[ib, 0], edges_b[ib, 1]


def _clip_edges(start, end, plane_pt, plane_normal):
    """Edges (E, 3) from `start` to `end` clipped against side planes (J, 3) (MJX's
    `_clip_edge_to_planes` for every edge): the clipped end points (E, 2, 3) and whether each
    edge is kept (E,)."""
    p0, p1 = _side(_xyz(start), 0), _side(_xyz(end), 0)  # (E, 1)
    q, n = _side(_xyz(plane_pt), 1), _side(_xyz(plane_normal), 1)  # (1, J)
    front0 = _dot(_sub(p0, q), n) > 1e-6  # (E, J)
    front1 = _dot(_sub(p1, q), n) > 1e-6
    span = _sub(p1, p0)
    denom = _dot(n, span)
    t = (_dot(q, n) - _dot(n, p0)) / (denom + 1e-6 * (denom == 0.0))
    t = jnp.clip(t, 0, 1)
    cut = tuple(a + t * s for a, s in zip(p0, span, strict=True))  # (E, J)

    def furthest(point, other, front):
        moved = tuple(jnp.where(front, c, p) for c, p in zip(cut, point, strict=True))
        j = jnp.argmax(_dot(_sub(moved, point), _sub(other, point)), axis=1)[:, None]
        return jnp.stack([jnp.take_along_axis(c, j, axis=1)[:, 0] for c in moved], -1)

    new0, new1 = furthest(p0, p1, front0), furthest(p1, p0, front1)
    keep = ~jnp.any(front0 & front1, axis=1)
    new0 = jnp.where(keep[:, None], new0, start)
    new1 = jnp.where(keep[:, None], new1, end)
    keep = jnp.where(jnp.sum((start - end) * (new0 - new1), -1) < 0, False, keep)
    return jnp.stack([new0, new1], 1), keep


def _clip(clipping_poly, subject_poly, clipping_normal, subject_normal):
    """MJX's `_clip`: the subject polygon's edges clipped by the clipping polygon's side planes,
    and the clipping polygon's edges (projected onto the subject's plane) by the subject's. Points
    (4V, 3) in MJX's order and whether each is on the clipped polygon (4V,)."""
    clip_start = jnp.roll(clipping_poly, 1, axis=0)
    clip_sides = jnp.cross(clipping_poly - clip_start, clipping_normal)
    subject_start = jnp.roll(subject_poly, 1, axis=0)
    subject_sides = jnp.cross(subject_poly - subject_start, subject_normal)
    edges0, keep0 = _clip_edges(subject_start, subject_poly, clip_start, clip_sides)
    onto = privates.project_poly_onto_poly_plane
    edges1, keep1 = _clip_edges(
        onto(clip_start, clipping_normal, subject_poly, subject_normal),
        onto(clipping_poly, clipping_normal, subject_poly, subject_normal),
        subject_start, subject_sides)
    points = jnp.concatenate([edges0, edges1]).reshape(-1, 3)
    keep = jnp.repeat(jnp.concatenate([keep0, keep1]), 2)
    return points, keep


def _manifold(clipping_poly, subject_poly, clipping_normal, subject_normal, sep_axis):
    """MJX's `_create_contact_manifold` with `_clip` above: up to four contacts' distances (4,),
    points (4, 3) and normals (4, 3)."""
    incident, keep = _clip(clipping_poly, subject_poly, clipping_normal, subject_normal)
    ref = privates.project_poly_onto_plane(incident, clipping_poly[0], clipping_normal)
    keep = keep & privates.point_in_front_of_plane(clipping_poly[0], -clipping_normal, incident)
    best = privates.manifold_points(ref, keep, clipping_normal)
    points, kept = ref[best], keep[best]
    depth = (incident[best] - points) @ -clipping_normal
    dist = jnp.where(kept, -depth, jnp.ones_like(depth))
    return dist, points, -jnp.stack([sep_axis] * 4, 0)


def _sat(centroid_a, faces_a, faces_b, vertices_a, vertices_b, normals_a, normals_b, edges_a,
         edges_b, edge_normals_a, edge_normals_b):
    """MJX's `_sat_gaussmap` (hull b at the origin): distances (4,), points (4, 3), normals (4, 3)."""
    axes = jnp.concatenate([normals_a, -normals_b])
    high = jax.lax.Precision.HIGH
    support = (jnp.max(jnp.matmul(axes, vertices_a.T, precision=high), 1)
               - jnp.min(jnp.matmul(axes, vertices_b.T, precision=high), 1))
    separated = jnp.any(support < 0)
    best = jnp.argmin(jnp.where(support < 0, 1e6, support))
    axis = axes[best]
    face_a, face_b = jnp.argmax(normals_a @ axis), jnp.argmax(normals_b @ -axis)
    on_a = best < normals_a.shape[0]
    dist, pos, normal = _manifold(
        jnp.where(on_a, faces_a[face_a], faces_b[face_b]),
        jnp.where(on_a, faces_b[face_b], faces_a[face_a]),
        jnp.where(on_a, normals_a[face_a], normals_b[face_b]),
        jnp.where(on_a, normals_b[face_b], normals_a[face_a]), -axis)
    dist = jnp.where(separated, 1.0, dist)

    edge_dist, edge_axis, a0, a1, b0, b1 = _edge_contact(centroid_a, edges_a, edges_b,
                                                         edge_normals_a, edge_normals_b)
    deepest = dist.max()
    on_edge = jnp.where(deepest < 0.0, edge_dist > deepest - 1e-6,
                        (edge_dist < 0) & ~jnp.isinf(edge_dist)) & ~separated
    normal = jnp.where(on_edge, edge_axis, normal)
    dist = jnp.where(on_edge, jnp.array([edge_dist, 1, 1, 1]), dist)
    near_a, near_b = privates.closest_segment_to_segment_points(a0, a1, b0, b1)
    pos = jnp.where(on_edge, jnp.tile(0.5 * (near_a + near_b), (4, 1)), pos)
    return dist, pos, normal


def _convex_convex(c1: privates.ConvexInfo, c2: privates.ConvexInfo):
    """MJX's `_convex_convex` with `_sat` above: distances (4,), points (4, 3), normals (4, 3)."""
    width1, width2 = c1.face.shape[1], c2.face.shape[1]
    if width1 < width2:  # faces padded to one vertex count (their last vertex repeated)
        c1 = c1.replace(face=jnp.pad(c1.face, ((0, 0), (0, width2 - width1), (0, 0)), "edge"))
    elif width2 < width1:
        c2 = c2.replace(face=jnp.pad(c2.face, ((0, 0), (0, width1 - width2), (0, 0)), "edge"))
    swapped = c1.vert.shape[0] > c2.vert.shape[0]  # the hull with fewer vertices first
    if swapped:
        c1, c2 = c2, c1
    pos = c2.mat.T @ (c1.pos - c2.pos)  # c1 in c2's frame
    mat = c2.mat.T @ c1.mat
    vertices1 = pos + c1.vert @ mat.T
    dist, points, normal = _sat(
        pos, pos + c1.face @ mat.T, c2.face, vertices1, c2.vert, c1.face_normal @ mat.T,
        c2.face_normal, jnp.take(vertices1, c1.edge, axis=0), jnp.take(c2.vert, c2.edge, axis=0),
        c1.edge_face_normal @ mat.T, c2.edge_face_normal)
    normal = normal @ c2.mat.T
    return (jnp.where(jnp.isinf(dist), jnp.finfo(dist.dtype).max, dist), c2.pos + points @ c2.mat.T,
            -normal if swapped else normal)


@privates.collider(ncon=4)
def convex_convex(c1: privates.ConvexInfo, c2: privates.ConvexInfo):
    """Contacts of two convex hulls (box or mesh), as MJX's `convex_convex`: distances (4,),
    points (4, 3), frames (4, 3, 3)."""
    dist, pos, normal = _convex_convex(c1, c2)
    return dist, pos, jax.vmap(privates.make_frame)(normal)
