"""Compile time of a Setup 1 program whose scene holds the given letters."""

import sys
import time

import jax

from graspjax.batch import plan, program
from graspjax.config import Config

jax.config.update("jax_enable_compilation_cache", False)

letters = tuple(sys.argv[1])
worlds = tuple(plan.World(0, 0, 1, t, (letters[0],)) for t in range(10))
g = plan.Group(letters, False, 1, Config(), worlds)
p = program.program(g, 10, False)
t = time.perf_counter()
start, att = p.lower(0)
lo = time.perf_counter() - t
t = time.perf_counter()
att.compile()
ca = time.perf_counter() - t
t = time.perf_counter()
start.compile()
cs = time.perf_counter() - t
print(f"{''.join(letters)}: lower {lo:.1f}s attempt compile {ca:.1f}s start compile {cs:.1f}s", flush=True)
