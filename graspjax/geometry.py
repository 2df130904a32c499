"""Small rigid-body helpers in JAX, written for one pose (vmap for batches).

Quaternions are (w, x, y, z), as in MuJoCo; rotations are 3x3 matrices whose
columns are the rotated frame's axes.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def normalize(v: jax.Array, eps: float = 1e-12) -> jax.Array:
    """Unit vector along `v` (3,)."""
    return v / jnp.maximum(jnp.linalg.norm(v), eps)


def quat_to_matrix(q: jax.Array) -> jax.Array:
    """Rotation matrix (3, 3) of a unit quaternion (4,)."""
    w, x, y, z = q
    return jnp.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quat(r: jax.Array) -> jax.Array:
    """Unit quaternion (4,) with w >= 0 of a rotation matrix (3, 3) (branch-free, stable)."""
    trace = jnp.trace(r)
    candidates = jnp.array([
        [1 + trace, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]],
        [r[2, 1] - r[1, 2], 1 + r[0, 0] - r[1, 1] - r[2, 2], r[0, 1] + r[1, 0], r[0, 2] + r[2, 0]],
        [r[0, 2] - r[2, 0], r[0, 1] + r[1, 0], 1 - r[0, 0] + r[1, 1] - r[2, 2], r[1, 2] + r[2, 1]],
        [r[1, 0] - r[0, 1], r[0, 2] + r[2, 0], r[1, 2] + r[2, 1], 1 - r[0, 0] - r[1, 1] + r[2, 2]],
    ])
    # Use the row with the largest diagonal term: it is far from zero.
    q = candidates[jnp.argmax(jnp.array([candidates[i, i] for i in range(4)]))]
    q = normalize(q)
    return jnp.where(q[0] < 0, -q, q)


def axis_angle(axis: jax.Array, angle) -> jax.Array:
    """Rotation matrix (3, 3) about a unit `axis` (3,) by `angle` (Rodrigues)."""
    k = jnp.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return jnp.eye(3) + jnp.sin(angle) * k + (1 - jnp.cos(angle)) * (k @ k)


def frame_from_axes(z_axis: jax.Array, x_hint: jax.Array) -> jax.Array:
    """Rotation (3, 3) whose z column is `z_axis` and x column is `x_hint` made orthogonal to it."""
    z = normalize(z_axis)
    x = normalize(x_hint - jnp.dot(x_hint, z) * z)
    return jnp.stack([x, jnp.cross(z, x), z], axis=1)


def rotation_between(a: jax.Array, b: jax.Array) -> jax.Array:
    """The smallest rotation (3, 3) taking unit vector `a` to unit vector `b`."""
    axis = jnp.cross(a, b)
    sin, cos = jnp.linalg.norm(axis), jnp.clip(jnp.dot(a, b), -1.0, 1.0)
    # Opposite vectors: turn half-way round any axis perpendicular to a.
    other = jnp.where(jnp.abs(a[0]) < 0.9, jnp.array([1.0, 0, 0]), jnp.array([0, 1.0, 0]))
    fallback = normalize(jnp.cross(a, other))
    unit_axis = jnp.where(sin > 1e-9, axis / jnp.maximum(sin, 1e-12), fallback)
    return axis_angle(unit_axis, jnp.arctan2(sin, cos))


def look_down(position: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Camera pose (rotation, position) looking straight down (world -z) from `position`.

    Camera x = world x, camera y = world -y, optical axis = world -z.
    """
    return jnp.diag(jnp.array([1.0, -1.0, -1.0])), position
