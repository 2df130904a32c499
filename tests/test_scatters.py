"""Scatters of trace-time indices recomputed by gathers (graspjax.sim.physics.scatters), against JAX's
own scatters on the CPU: the same values, bit for bit, and no scatter left that XLA would
sort."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from graspjax.sim.physics.scatters import without_sorted_scatters


@pytest.fixture(autouse=True)
def _on_the_cpu():
    """Bit for bit means against XLA's CPU scatter, which adds in update order (a GPU's
    deterministic scatter sums in another order, equal to rounding)."""
    with jax.default_device(jax.devices("cpu")[0]):
        yield


REPEATS = np.array([0, 2, 2, 1, 0, 4, 2])  # indices with repeats (a scatter-add sums them)
DISTINCT = np.array([3, 0, 4])


def scatters(fun, *args, sorted_only=False) -> int:
    """How many scatter equations `fun`'s jaxpr holds, those of loops and calls included
    (`sorted_only`: those XLA sorts under deterministic ops, whose indices are not declared
    unique)."""
    def count(jaxpr):
        n = 0
        for eqn in jaxpr.eqns:
            n += (eqn.primitive.name.startswith("scatter")
                  and not (sorted_only and eqn.params["unique_indices"]))
            for param in eqn.params.values():
                for sub in param if isinstance(param, tuple) else (param,):
                    inner = getattr(sub, "jaxpr", sub)
                    if hasattr(inner, "eqns"):
                        n += count(inner)
        return n

    return count(jax.make_jaxpr(fun)(*args).jaxpr)


def _values(shape, seed):
    return jnp.asarray(np.random.default_rng(seed).normal(size=shape), jnp.float32)


CASES = {  # name: (function of (x (5, 3), u (7, 3)), whether every scatter is rewritten)
    "add, repeated rows": lambda x, u: x.at[REPEATS].add(u),
    "add, repeated elements of a column": lambda x, u: x.at[REPEATS, 1].add(u[:, 0]),
    "add, columns": lambda x, u: x.T.at[:, REPEATS].add(u.T),
    "add, out of bounds dropped": lambda x, u: x.at[np.array([0, 9, 2, 7, 1, 1, 4])].add(
        u, mode="drop"),
    "add, clipped": lambda x, u: x.at[np.array([0, 9, 2, 7, 1, 1, 4])].add(u, mode="clip"),
    "add, negative indices": lambda x, u: x.at[-REPEATS - 1].add(u),
    "write, distinct rows": lambda x, u: x.at[DISTINCT].set(u[:3]),
    "write, distinct elements": lambda x, u: x.at[DISTINCT, np.array([2, 0, 1])].set(u[:3, 0]),
    "write, a block": lambda x, u: x.at[1:3, 1:].set(u[:2, :2]),
    "add, everything (no index)": lambda x, u: x.at[:].add(u[:5]),
    "add, in a loop": lambda x, u: jax.lax.fori_loop(
        0, 3, lambda i, c: c.at[REPEATS].add(u * i), x),
    "add, in a branch": lambda x, u: jax.lax.cond(
        u[0, 0] > 0, lambda: x.at[REPEATS].add(u), lambda: x.at[REPEATS].add(-u)),
    "add, in a vmap over rows": lambda x, u: jax.vmap(
        lambda r, v: r.at[np.array([0, 2, 0])].add(v))(x, u[:5]),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_same_values_as_jax_scatters(name):
    """Each pattern gives JAX's values bit for bit, in one world and vmapped over worlds,
    and its jaxpr keeps no scatter."""
    fun = CASES[name]
    x, u = _values((5, 3), 0), _values((7, 3), 1)
    ours = without_sorted_scatters(fun)
    np.testing.assert_array_equal(ours(x, u), jax.jit(fun)(x, u))
    xs, us = jnp.stack([x, 2 * x]), jnp.stack([u, u - 1])
    np.testing.assert_array_equal(jax.vmap(ours)(xs, us), jax.jit(jax.vmap(fun))(xs, us))
    assert scatters(fun, x, u), "the case has no scatter to rewrite"
    assert scatters(ours, x, u) == 0


def test_repeated_writes_traced_indices_and_long_sums_are_kept():
    """A write to one place twice (which one wins is XLA's), indices known only when the
    program runs and a sum of more than 64 updates into one place stay scatters, with JAX's
    values."""
    x, u = _values((5, 3), 0), _values((7, 3), 1)
    many = _values((100,), 2)

    def fun(x, u, many):
        return (x.at[REPEATS].set(u), x.at[jnp.argsort(u[:, 0])[:5]].add(u[:5]),
                jnp.zeros(2).at[np.zeros(100, int)].add(many))

    ours = without_sorted_scatters(fun)
    for a, b in zip(ours(x, u, many), jax.jit(fun)(x, u, many), strict=True):
        np.testing.assert_array_equal(a, b)
    assert scatters(ours, x, u, many) == scatters(fun, x, u, many) == 3


def test_signed_zeros_kept():
    """A place with fewer updates than the deepest keeps the sign of its zero, as XLA's sum
    does (-0.0 + -0.0 is -0.0)."""
    def fun(x, u):
        return x.at[np.array([0, 0, 1])].add(u)

    x, u = jnp.full(3, -0.0), jnp.full(3, -0.0)
    np.testing.assert_array_equal(np.signbit(without_sorted_scatters(fun)(x, u)),
                                  np.signbit(jax.jit(fun)(x, u)))
    assert np.signbit(jax.jit(fun)(x, u)).all()


def test_sums_in_update_order():
    """A repeated index's updates are added one after another in their order (as XLA's CPU
    scatter adds them), so rounding is the same: 1 + 1e8 - 1e8 differs from 1 + (1e8 - 1e8)."""
    u = jnp.array([1.0, 1e8, -1e8], jnp.float32)
    ours = without_sorted_scatters(lambda x, u: x.at[np.array([0, 0, 0])].add(u))
    assert float(ours(jnp.zeros(1), u)[0]) == float((np.float32(1) + np.float32(1e8))
                                                    - np.float32(1e8))


def test_the_physics_step_leaves_xla_nothing_to_sort():
    """The bin scene's physics step (MJX's, with graspjax's collision and solver) holds no
    scatter whose indices XLA would sort under deterministic ops; without the rewrite it holds
    dozens (MJX's tree sums, line search, kinematics, integrator)."""
    from graspjax.config import Config
    from graspjax.sim import scene_for
    from graspjax.sim.physics import collision, solver
    from graspjax.sim.physics.step import reworked_step, step_with
    from graspjax.sim.scene import mjx
    from graspjax.sim.world import physics_model

    scene = scene_for(tuple("abcdef"), Config(), True)
    model, data = physics_model(scene, Config()), mjx.make_data(scene.mj_model)

    def unrewritten(d):
        return step_with(
            model, d, lambda m, d: collision.collision(m, d, scene.geom_owner), solver.solve)

    assert scatters(unrewritten, data, sorted_only=True) > 10
    assert scatters(lambda d: reworked_step(model, d, scene.geom_owner), data,
                    sorted_only=True) == 0


BIG = np.array([2**31 - 3, -(2**31) + 2, 7, -5, 0, 1], np.int32)  # sums and products wrap


INDEX_ARITHMETIC = {  # name: function of (a (6,) int32, b (6,) int32) with integer results
    "wrapping arithmetic": lambda a, b: ((a + b) * 3 - b, -a, jnp.maximum(a, b), jnp.minimum(a, b)),
    "comparisons and logic": lambda a, b: (a < b, a <= b, a > b, a >= b, a == b, a != b,
                                           (a < 0) & (b > 0) | ~(a == b), a & b, ~a),
    "selects": lambda a, b: (jnp.where(a > b, a, b), jax.lax.select_n(
        jnp.clip(b, 0, 2), a, b, a * 2)),
    "casts": lambda a, b: (a.astype(bool), (a > b).astype(jnp.int32), a.astype(jnp.int8),
                           a.astype(jnp.uint32)),
    "shapes": lambda a, b: (jnp.broadcast_to(a[:, None], (6, 4)), jnp.concatenate([a, b])[1:11:3],
                            a.reshape(2, 3).T.reshape(3, 2, 1).squeeze(2),
                            jax.lax.reshape(a.reshape(2, 3), (3, 2), dimensions=(1, 0)),
                            jax.lax.broadcasted_iota(jnp.int32, (3, 4), 1) + jnp.arange(3)[:, None]),
    "calls": lambda a, b: jax.jit(lambda x, y: x * y + 1)(a, b),
}


@pytest.mark.parametrize("name", INDEX_ARITHMETIC)
def test_index_arithmetic_is_computed_by_numpy_as_xla_computes_it(name):
    """Integer equations of known inputs (a scatter's index computations) are computed by NumPy,
    not compiled per operation: the same values and dtypes as XLA's, overflow included."""
    from graspjax.sim.physics import scatters as module

    fun = INDEX_ARITHMETIC[name]
    a, b = jnp.asarray(BIG), jnp.asarray(np.roll(BIG, 2) // 3)
    closed = jax.make_jaxpr(fun)(a, b)
    primitives = {eqn.primitive.name for eqn in closed.jaxpr.eqns}
    assert primitives <= set(module._NUMPY) | {"jit"}  # no operation compiled by XLA
    ours = module._evaluated(closed.jaxpr, closed.consts, [np.asarray(a), np.asarray(b)])
    theirs = jax.tree.leaves(fun(a, b))
    assert all(isinstance(x, np.ndarray) for x in ours)
    for x, y in zip(ours, theirs, strict=True):
        assert x.dtype == y.dtype
        np.testing.assert_array_equal(x, np.asarray(y))


def test_every_numpy_operation_is_checked_against_xla():
    """Each operation NumPy computes appears in the cases above (so it meets XLA's values)."""
    from graspjax.sim.physics import scatters as module

    a = jnp.asarray(BIG)
    used = {eqn.primitive.name for fun in INDEX_ARITHMETIC.values()
            for eqn in jax.make_jaxpr(fun)(a, a).jaxpr.eqns}
    assert set(module._NUMPY) <= used
