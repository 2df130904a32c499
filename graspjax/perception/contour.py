"""Contour of a surface cluster grouped into straight edges (one image).

The paper (section 3.1, Fig. 2) notes that chaining edge pixels gives a
jagged contour once the object is rotated against the pixel grid, and groups
edge points "with a set of rules". Ours:

1. trace the cluster's outer boundary in order (Moore-neighbour tracing,
   clockwise on screen, with Jacob's stopping rule);
2. give every contour point a direction from the chord between the points
   `tangent_window` steps before and after it, which averages out the
   staircase of a rotated edge (shorter on contours under 48 points, so
   that small surfaces keep their corners apart);
3. start at the sharpest turn and walk the contour once: a point joins the
   current edge while its direction is within `split_angle_deg` of the edge's
   mean direction, otherwise it starts a new edge;
4. fit a line to each edge's points (principal axis), and keep the
   `max_edges` longest edges with at least `min_edge_pixels` points.

Edge geometry is metric, on the surface plane at depth `z` in the camera frame.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from graspjax.camera import Camera
from graspjax.tree import pytree_dataclass

# Module constants are numpy: importing graspjax must not start a JAX backend (XLA reads its
# flags, e.g. the CLI's deterministic GPU ops, when the first backend starts).
# Moore neighbourhood, clockwise on screen (v grows downward): E, SE, S, SW, W, NW, N, NE.
_DU = np.array([1, 1, 0, -1, -1, -1, 0, 1], np.int32)
_DV = np.array([0, 1, 1, 1, 0, -1, -1, -1], np.int32)
# Direction index of an offset (du, dv), indexed [dv + 1, du + 1] (centre unused).
_DIRECTION_OF = np.array([[5, 6, 7], [4, 0, 0], [3, 2, 1]], np.int32)
_WEST = 4
_STEPS, _UNROLLED_STEPS = 8, 32  # trace and walk steps per loop iteration (`loop_steps`)


def loop_steps(unrolled: bool) -> int:
    """The contour trace's and the edge walk's steps per loop iteration (`detect.unrolled_loops`):
    each iteration costs a GPU a launch, each step more code to compile."""
    return _UNROLLED_STEPS if unrolled else _STEPS


@pytree_dataclass
class Contour:
    """Ordered outer boundary of a cluster (padded to a static length L)."""

    points: jax.Array  # (L, 2) int32 pixel (u, v) in tracing order; -1 past `length`
    length: jax.Array  # () int32 number of valid points
    closed: jax.Array  # () bool, False if the contour was truncated at L


@pytree_dataclass
class Edges:
    """Straight edges of a contour (padded to a static maximum K)."""

    center: jax.Array  # (K, 2) edge centre S, metric (x, y) on the surface plane
    direction: jax.Array  # (K, 2) unit direction along the contour (clockwise on screen)
    normal: jax.Array  # (K, 2) unit outward normal
    length: jax.Array  # (K,) metric length
    count: jax.Array  # (K,) int32 contour points on the edge
    valid: jax.Array  # (K,) bool


def trace_contour(mask: jax.Array, max_points: int, steps_per_iteration: int = _STEPS) -> Contour:
    """Outer boundary of the 8-connected region holding the first mask pixel in row-major order.

    mask: (H, W) bool. Returns a `Contour` of static length `max_points`. The loop takes
    `steps_per_iteration` tracing steps per iteration (steps after the stop change nothing):
    on a GPU every loop iteration costs a kernel launch and a host sync.
    """
    width = mask.shape[1]
    padded = jnp.pad(mask, 1)
    flat = jnp.argmax(mask.reshape(-1))
    nonempty = mask.reshape(-1)[flat]
    v0, u0 = jnp.divmod(flat, width)
    start = jnp.stack([u0, v0]).astype(jnp.int32)
    du, dv, direction_of = jnp.asarray(_DU), jnp.asarray(_DV), jnp.asarray(_DIRECTION_OF)

    def step(p, back):
        # Search clockwise from the backtrack neighbour for the next region pixel.
        order = (back + 1 + jnp.arange(8, dtype=jnp.int32)) % 8
        found = padded[p[1] + 1 + dv[order], p[0] + 1 + du[order]]
        k = jnp.argmax(found)
        d = order[k]
        nxt = p + jnp.stack([du[d], dv[d]])
        before = (d + 7) % 8  # last background neighbour checked becomes the new backtrack
        offset = p + jnp.stack([du[before], dv[before]]) - nxt
        return nxt, direction_of[offset[1] + 1, offset[0] + 1], found[k]

    second, back1, has_neighbour = step(start, jnp.int32(_WEST))
    points = jnp.full((max_points, 2), -1, jnp.int32).at[0].set(start)

    def advance(state):
        i, p, back, pts, done = state
        nxt, nxt_back, _ = step(p, back)
        closing = jnp.all(p == start) & jnp.all(nxt == second)  # Jacob's stopping rule
        moving = ~done & (i < max_points)
        record = moving & ~closing
        pts = pts.at[jnp.where(record, i, max_points)].set(p, mode="drop")  # one row, or none
        return (jnp.where(record, i + 1, i), jnp.where(record, nxt, p),
                jnp.where(record, nxt_back, back), pts, done | (moving & closing))

    def body(state):
        for _ in range(steps_per_iteration):
            state = advance(state)
        return state

    def cond(state):
        i, _, _, _, done = state
        return ~done & (i < max_points)

    done0 = ~nonempty | ~has_neighbour
    length, _, _, points, done = lax.while_loop(
        cond, body, (jnp.int32(1), second, back1, points, done0))
    length = jnp.where(nonempty, length, 0)
    return Contour(points=jnp.where(jnp.arange(max_points)[:, None] < length, points, -1),
                   length=length, closed=done)


def _unit(v: jax.Array, eps: float = 1e-12) -> jax.Array:
    return v / jnp.maximum(jnp.linalg.norm(v, axis=-1, keepdims=True), eps)


def _edge_ids(walk_t: jax.Array, length: jax.Array, cos_split: jax.Array,
              steps_per_iteration: int) -> jax.Array:
    """Each walk point's edge (size,) int32: a new edge starts where the walk's tangent
    `walk_t` (size, 2) turns from its edge's mean direction by more than the split angle
    (`cos_split`); the walk is closed, so its last run continues the first when their
    directions agree. Points past the contour's `length` get `size` (dropped by the fit).
    The walk takes `steps_per_iteration` points per loop iteration (a launch on a GPU)."""
    size = walk_t.shape[0]
    idx = jnp.arange(size)
    in_contour = idx < length
    n = jnp.maximum(length, 1)

    def walk(i, carry):
        edge, total, ids = carry
        t, ok = walk_t[jnp.minimum(i, size - 1)], i < length
        norm = jnp.linalg.norm(total)
        new = ok & (norm > 0) & (jnp.dot(total / jnp.maximum(norm, 1e-12), t) < cos_split)
        edge = edge + new.astype(jnp.int32)
        total = jnp.where(ok, jnp.where(new, t, total + t), total)
        return edge, total, ids.at[i].set(edge, mode="drop")

    def walk_steps(state):
        i, carry = state
        for step in range(steps_per_iteration):
            carry = walk(i + step, carry)
        return i + steps_per_iteration, carry

    # Only the contour's own points: a batch walks as far as its longest contour.
    _, (last_edge, _, edge_id) = lax.while_loop(
        lambda state: state[0] < length, walk_steps,
        (jnp.int32(0), (jnp.int32(0), jnp.zeros(2, jnp.float32), jnp.zeros(size, jnp.int32))))
    edge_id = jnp.where(in_contour, edge_id, last_edge)  # past the end the last edge goes on
    # The walk is closed: its last run continues the first when their directions agree.
    last = edge_id[n - 1]
    first_dir = jnp.sum(jnp.where((edge_id == 0)[:, None], walk_t, 0.0), 0)
    last_dir = jnp.sum(jnp.where(((edge_id == last) & in_contour)[:, None], walk_t, 0.0), 0)
    wraps = (last > 0) & (jnp.dot(_unit(first_dir), _unit(last_dir)) >= cos_split)
    edge_id = jnp.where(wraps & (edge_id == last), 0, edge_id)
    return jnp.where(in_contour, edge_id, size)  # out-of-range ids: dropped by the fit


def fit_edges(contour: Contour, camera: Camera, z: jax.Array, *, tangent_window: int,
              split_angle_deg: float, min_edge_pixels: int, max_edges: int,
              steps_per_iteration: int = _STEPS) -> Edges:
    """Group an ordered contour into straight edges on the plane at depth `z` (metric).

    Directions come from integer pixel differences and the fits are made in
    a frame anchored at the contour's first point, so translating the image
    by whole pixels translates the edges and changes nothing else.
    """
    size = contour.points.shape[0]
    n = jnp.maximum(contour.length, 1)
    idx = jnp.arange(size)
    in_contour = idx < contour.length
    scale = jnp.stack([z / camera.fx, z / camera.fy])  # metres per pixel along u and v
    origin = contour.points[0]
    local = (contour.points - origin).astype(jnp.float32) * scale  # metric, exact differences

    # A chord of +-k points blurs each corner over 2k points, so short contours (small
    # surfaces) get a shorter chord: at most one sixteenth of the contour each way.
    k = jnp.clip(n // 16, 1, tangent_window)
    ahead, here, behind = contour.points[(idx + k) % n], contour.points, contour.points[(idx - k) % n]

    def direction_of(delta):
        return _unit(delta.astype(jnp.float32) * scale)

    tangent = direction_of(ahead - behind)
    # Start the walk at the sharpest turn so that no edge is split by the start point.
    turn = jnp.sum(direction_of(here - behind) * direction_of(ahead - here), axis=-1)
    first = jnp.argmin(jnp.where(in_contour, turn, jnp.inf))
    order = (first + idx) % n
    walk_xy, walk_t = local[order], tangent[order]

    cos_split = jnp.cos(jnp.deg2rad(split_angle_deg))

    edge_id = _edge_ids(walk_t, contour.length, cos_split, steps_per_iteration)

    count = jax.ops.segment_sum(in_contour.astype(jnp.float32), edge_id, num_segments=size)
    top_count, top = lax.top_k(count, max_edges)  # ties keep walk order
    valid = top_count >= min_edge_pixels
    slot = jnp.full(size + 1, max_edges, jnp.int32).at[top].set(jnp.arange(max_edges))
    point_slot = slot[edge_id]  # kept edge of each walk point, max_edges if none

    def per_edge(values):
        return jax.ops.segment_sum(values, point_slot, num_segments=max_edges + 1)[:max_edges]

    c = jnp.maximum(top_count, 1.0)[:, None]
    mean = per_edge(walk_xy) / c
    safe_slot = jnp.minimum(point_slot, max_edges - 1)
    centred = walk_xy - mean[safe_slot]
    cov = per_edge(centred[:, :, None] * centred[:, None, :]) / c[..., None]  # (K, 2, 2)
    angle = 0.5 * jnp.arctan2(2.0 * cov[:, 0, 1], cov[:, 0, 0] - cov[:, 1, 1])  # principal axis
    direction = jnp.stack([jnp.cos(angle), jnp.sin(angle)], axis=-1)
    direction = jnp.where(jnp.sum(direction * per_edge(walk_t), -1, keepdims=True) < 0,
                          -direction, direction)
    normal = jnp.stack([direction[:, 1], -direction[:, 0]], axis=-1)  # outward for clockwise

    proj = jnp.sum(centred * direction[safe_slot], axis=-1)
    hi = jax.ops.segment_max(proj, point_slot, num_segments=max_edges + 1)[:max_edges]
    lo = jax.ops.segment_min(proj, point_slot, num_segments=max_edges + 1)[:max_edges]

    # Boundary pixel centres lie on average half a pixel step (along the larger
    # normal component) inside the true edge; move the line out by that much.
    offset = 0.5 * jnp.max(jnp.abs(normal) * scale, axis=-1)
    along = jnp.sum(jnp.abs(direction) * scale, axis=-1)  # one pixel along the edge
    origin_xy = (origin.astype(jnp.float32) - jnp.stack([camera.cx, camera.cy])) * scale
    center = (origin_xy + mean + direction * (0.5 * (hi + lo))[:, None]
              + normal * offset[:, None])
    length = jnp.where(valid, hi - lo + along, 0.0)
    return Edges(center=center, direction=direction, normal=normal, length=length,
                 count=top_count.astype(jnp.int32), valid=valid)
