"""The best distinct grasps among many candidates of one image (`graspjax detect`'s top k)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax


def distinct_best(passed, score, position, axis, count: int, distance: float) -> tuple[jax.Array, jax.Array]:
    """The `count` best distinct grasps among N: indices (count,) int32 and validity (count,).
    A grasp within `distance` of a better one with its axis within 20 deg (either sign) is the
    same grasp (mirror placements: edge i with j, and j with i)."""
    cos_same = np.cos(np.deg2rad(20.0))

    def pick(open_, _):
        best = jnp.argmax(jnp.where(open_, score, -jnp.inf))
        ok = open_[best]
        same = ((jnp.linalg.norm(position - position[best], axis=-1) <= distance)
                & (jnp.abs(axis @ axis[best]) >= cos_same))
        return open_ & ~(same & ok) & (jnp.arange(open_.shape[0]) != best), (best, ok)

    _, (chosen, ok) = lax.scan(pick, passed, None, length=count)
    return jnp.where(ok, chosen, -1).astype(jnp.int32), ok
