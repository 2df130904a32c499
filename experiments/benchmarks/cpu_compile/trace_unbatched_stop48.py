"""Trace the g-l attempt for one world (no vmap) and vmapped, as jaxprs: how much of lowering is batching."""

import dataclasses
import functools
import sys
import time

import jax
import jax.numpy as jnp

from graspjax.batch import plan, program
from graspjax.config import Config
from graspjax.procedure import attempt, start_round
from graspjax.sim.collision import WORLDS

jax.config.update("jax_enable_compilation_cache", False)

gi = int(sys.argv[1])
mode = sys.argv[2]
groups = plan.plan([plan.table_job(1, 10), plan.table_job(2, 10)], [Config()], 0)
p = program.program(groups[gi], 10, False)
spec0 = p._key()[0]
arrays = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), p.arrays)
scene = p.scene
t = time.perf_counter()
state = jax.eval_shape(
    lambda a, sp: jax.vmap(
        lambda o: start_round(dataclasses.replace(scene, model=a[0]), a[1], o, p.group.setups),
        axis_name=WORLDS,
    )(sp),
    arrays,
    spec0,
)
print("start traced", f"{time.perf_counter() - t:.1f}s")


def one(model, state, spec, k):
    sc = dataclasses.replace(scene, model=model)
    return attempt(sc, state, spec, k, keep_views=False, setups=p.group.setups)


def unb(s):
    return jax.ShapeDtypeStruct(s.shape[1:], s.dtype)


k = jax.ShapeDtypeStruct((), jnp.int32)
t = time.perf_counter()
if mode == "one":
    jax.make_jaxpr(one)(arrays[0], jax.tree.map(unb, state), jax.tree.map(unb, spec0), k)
else:
    jax.make_jaxpr(
        lambda m, s, sp, kk: jax.vmap(functools.partial(one, m), in_axes=(0, 0, None), axis_name=WORLDS)(
            s, sp, kk
        )
    )(arrays[0], state, spec0, k)
print(mode, f"{time.perf_counter() - t:.1f}s")
