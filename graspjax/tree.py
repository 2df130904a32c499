"""Pytree helpers shared by every layer: dataclasses of arrays, selection between trees, a function
mapped over the kept entries only, and the dotted names of a nested dataclass's fields."""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp


def pytree_dataclass(cls=None, *, meta: tuple[str, ...] = ()):
    """A frozen dataclass registered as a JAX pytree: every field is data (a leaf, traced under
    `jit`, batched by `vmap`) except those named in `meta` (static: part of the tree's
    structure, e.g. an image size)."""

    def wrap(cls):
        cls = dataclasses.dataclass(frozen=True)(cls)
        data = [f.name for f in dataclasses.fields(cls) if f.name not in meta]
        jax.tree_util.register_dataclass(cls, data_fields=data, meta_fields=list(meta))
        return cls

    return wrap if cls is None else wrap(cls)


def where_tree(flag: jax.Array, a, b):
    """`a` where the scalar `flag` holds, else `b`, for two pytrees of one structure."""
    return jax.tree.map(lambda x, y: jnp.where(flag, x, y), a, b)


def concat_trees(*trees):
    """Pytrees of one structure joined along their leaves' leading axis."""
    return jax.tree.map(lambda *parts: jnp.concatenate(parts), *trees)


def map_where(fn, where: jax.Array, chunk: int | None, fill, *xs):
    """`fn` over the entries of `xs` (each (N, ...)) where `where` (N,) bool holds, and `fill` (a
    tree of (N, ...) arrays of `fn`'s result's shapes and dtypes) elsewhere. `fn` maps (M, ...) inputs to a
    tree of (M, ...) results. With a `chunk` (`detect.checks_in_chunks`), only the kept entries are computed,
    `chunk` at a time: a loop over chunks of their indices while any is left (one image's count;
    a batch's loop lasts as long as its longest); with None, every entry at once, no loop."""
    n = where.shape[0]
    if chunk is None:
        return jax.tree.map(lambda new, old: jnp.where(
            where.reshape(-1, *[1] * (new.ndim - 1)), new, old), fn(*xs), fill)
    chunk = min(n, chunk)
    order = jnp.nonzero(where, size=-(-n // chunk) * chunk, fill_value=n)[0]  # kept first, then n
    count = jnp.sum(where)

    def step(state):
        start, out = state
        index = jax.lax.dynamic_slice_in_dim(order, start, chunk)
        part = fn(*(x[jnp.minimum(index, n - 1)] for x in xs))
        return start + chunk, jax.tree.map(
            lambda whole, new: whole.at[index].set(new, mode="drop"), out, part)

    return jax.lax.while_loop(lambda state: state[0] < count, step, (jnp.int32(0), fill))[1]


def named_fields(obj: Any, prefix: str = "") -> dict[str, Any]:
    """Every field of a (nested) dataclass that is not itself a dataclass, by dotted name
    (`{"align.window_px": 15, ...}`), in declaration order."""
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out.update(named_fields(value, f"{prefix}{f.name}."))
        else:
            out[prefix + f.name] = value
    return out
