"""One XLA_FLAGS variant (from the environment): lower group G's programs (10 worlds), compile,
play one chunk twice; save records; compare with /tmp/flag_base_G.npz if present."""

import os
import sys
import time

import jax
import numpy as np

from graspjax.batch import plan, program
from graspjax.config import Config

jax.config.update("jax_enable_compilation_cache", False)

gi = int(sys.argv[1])
name = sys.argv[2]
groups = plan.plan([plan.table_job(1, 10), plan.table_job(2, 10)], [Config()], 0)
g = groups[gi]
p = program.program(g, 10, False)
t = time.perf_counter()
start, att = p.lower(0)
lower = time.perf_counter() - t
t = time.perf_counter()
sc = start.compile()
cs = time.perf_counter() - t
t = time.perf_counter()
a = att.compile()
ca = time.perf_counter() - t
p._start[0], p._attempt[0] = sc, a
cks = plan.chunks([g], 10)
ts = []
for _rep in range(2):
    t = time.perf_counter()
    drop, recs, _ = p.play(cks[0].worlds, [Config()], lambda n: None)
    ts.append(time.perf_counter() - t)
leaves = [np.asarray(x) for x in jax.tree.leaves((drop, recs))]
base = f"/tmp/flag_base_{gi}.npz"
same = None
if os.path.exists(base):
    b = np.load(base)
    bl = [b[f"a{i}"] for i in range(len(b.files))]
    same = all(np.array_equal(x, y, equal_nan=True) for x, y in zip(bl, leaves, strict=False))
else:
    np.savez(base, **{f"a{i}": x for i, x in enumerate(leaves)})
print(
    f"group {gi} {name:24s} lower {lower:5.1f}s compile start {cs:5.1f}s attempt {ca:6.1f}s  "
    f"chunk {ts[0]:.2f}/{ts[1]:.2f}s  same_as_base={same}",
    flush=True,
)
