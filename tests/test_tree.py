"""Pytree helpers (`graspjax/tree.py`) against plain NumPy."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from graspjax.tree import map_where


def _twice_and_next(x):
    return {"twice": 2.0 * x, "next": (x + 1).astype(jnp.int32)}


@pytest.mark.parametrize("chunk", [1, 3, 4, 10, 64, None])
def test_map_where_maps_the_kept_entries_and_fills_the_rest(chunk):
    """10 entries (not a multiple of most chunks; None: all at once, a GPU's way), none, some and
    all kept; the fill elsewhere."""
    x = jnp.arange(10, dtype=jnp.float32) * 1.5
    fill = {"twice": jnp.full(10, -1.0), "next": jnp.full(10, -7, jnp.int32)}
    rng = np.random.default_rng(0)
    for kept in (np.zeros(10, bool), rng.random(10) < 0.5, np.ones(10, bool)):
        got = jax.jit(lambda k: map_where(_twice_and_next, k, chunk, fill, x))(jnp.asarray(kept))
        np.testing.assert_array_equal(got["twice"], np.where(kept, 2.0 * np.asarray(x), -1.0))
        np.testing.assert_array_equal(got["next"], np.where(kept, np.asarray(x) + 1, -7).astype(int))


@pytest.mark.parametrize("chunk", [4, None])
def test_map_where_under_vmap_gives_each_row_its_own(chunk):
    """A batch whose rows keep 0, 2 and 9 entries (the loop runs as long as the longest)."""
    x = jnp.arange(27, dtype=jnp.float32).reshape(3, 9)
    kept = np.zeros((3, 9), bool)
    kept[1, [2, 7]] = True
    kept[2] = True
    fill = {"twice": jnp.zeros(9), "next": jnp.zeros(9, jnp.int32)}
    got = jax.jit(jax.vmap(lambda k, v: map_where(_twice_and_next, k, chunk, fill, v)))(
        jnp.asarray(kept), x)
    np.testing.assert_array_equal(got["twice"], np.where(kept, 2.0 * np.asarray(x), 0.0))
    np.testing.assert_array_equal(got["next"], np.where(kept, np.asarray(x) + 1, 0).astype(int))


@pytest.mark.parametrize("chunk, seen", [(4, (4,)), (None, (10,))])
def test_map_where_computes_a_chunk_at_a_time(chunk, seen):
    """With a chunk, `fn` is traced on chunk-sized inputs (only the kept entries are computed);
    with None, on all N at once."""
    shapes = []

    def recorded(x):
        shapes.append(x.shape)
        return _twice_and_next(x)

    fill = {"twice": jnp.zeros(10), "next": jnp.zeros(10, jnp.int32)}
    jax.jit(lambda k: map_where(recorded, k, chunk, fill, jnp.arange(10.0)))(jnp.arange(10) < 6)
    assert shapes == [seen]
